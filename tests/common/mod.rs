//! Helpers shared by the integration tests: scene and ray generators for
//! proptest, the brute-force comparison, and the data directory.
#![allow(dead_code)]

use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use cellbih::bih::{Bih, Hit};
#[allow(unused_imports)]
pub use cellbih::quality::agree::{check_ray, rays_for};
use cellbih::scene::{Scene, SplitMix64, Triangle};
use glam::Vec3;
use proptest::prelude::*;

/// Runs the `cellbih` binary with `args`.
pub fn cellbih(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_cellbih"))
        .args(args)
        .output()
        .unwrap()
}

/// Fails with the command's stderr unless it succeeded.
pub fn assert_ok(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs experiment binary `exe` with `args`, `--format json` and `--out`
/// a fresh directory named `name`; returns its rows and the directory.
pub fn run_experiment(
    exe: &str,
    name: &str,
    args: &[&str],
) -> (Vec<serde_json::Value>, std::path::PathBuf) {
    let dir = tmp(name);
    let out = std::process::Command::new(exe)
        .args(args)
        .args(["--format", "json", "--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert_ok(&out);
    // The standard output carries the file's document, settings included.
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        doc["settings"]["version"].is_string(),
        "{exe}: stdout has no settings"
    );
    // Every JSON file it wrote names its settings: the command line that
    // made it and the version.
    for f in std::fs::read_dir(&dir).unwrap() {
        let path = f.unwrap().path();
        if path.extension().is_some_and(|e| e == "json") {
            let doc: serde_json::Value =
                serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
            let settings = &doc["settings"];
            let command = settings["command"].as_str().unwrap_or_default();
            assert!(
                command.contains(args.first().copied().unwrap_or_default())
                    && settings["version"].is_string(),
                "{}: settings {settings}",
                path.display()
            );
        }
    }
    (doc["rows"].as_array().unwrap().clone(), dir)
}

/// A path in this test process's own temporary directory.
pub fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("cellbih-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// Panics unless every two complete ("X") events on one track of a Chrome
/// trace are apart or nested, as the format requires (Perfetto drops or
/// misdraws the others). Compared in whole nanoseconds, as Perfetto reads
/// them.
pub fn assert_slices_nest(trace: &serde_json::Value) {
    let ns = |v: &serde_json::Value| (v.as_f64().unwrap() * 1000.0).round() as i64;
    let mut by_track: std::collections::BTreeMap<i64, Vec<(i64, i64)>> = Default::default();
    for e in trace["traceEvents"].as_array().unwrap() {
        if e["ph"] == "X" {
            let start = ns(&e["ts"]);
            by_track
                .entry(e["tid"].as_i64().unwrap())
                .or_default()
                .push((start, start + ns(&e["dur"])));
        }
    }
    for (tid, mut slices) in by_track {
        // Longest first among equal starts, so that a parent precedes its children.
        slices.sort_by_key(|&(a, b)| (a, std::cmp::Reverse(b)));
        let mut open: Vec<i64> = Vec::new();
        for (a, b) in slices {
            while open.last().is_some_and(|&end| end <= a) {
                open.pop();
            }
            if let Some(&end) = open.last() {
                assert!(
                    b <= end,
                    "track {tid}: slice {a}..{b} ns overlaps its neighbour ending at {end} without nesting"
                );
            }
            open.push(b);
        }
    }
}

/// A scene of `n` triangles at a scale of `10^exp`, offset by `offset`
/// scales, of one of several shapes: random, flat, duplicated, with
/// degenerate triangles, one identical stack, on a coarse grid.
pub fn scene_strategy() -> impl Strategy<Value = Scene> {
    (
        1usize..80,
        prop::sample::select(vec![-15i32, -7, 0, 7, 15]),
        -2i32..3,
        0u8..6,
        any::<u64>(),
    )
        .prop_map(|(n, exp, offset, kind, seed)| make_scene(n, exp, offset, kind, seed))
}

pub fn make_scene(n: usize, exp: i32, offset: i32, kind: u8, seed: u64) -> Scene {
    let scale = 10f32.powi(exp);
    let off = Vec3::splat(offset as f32 * scale);
    let mut rng = SplitMix64::new(seed);
    let p = |rng: &mut SplitMix64| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let mut tris = Vec::with_capacity(n);
    for i in 0..n {
        let c = p(&mut rng);
        let small = 0.05 + 0.2 * rng.next_f32();
        let mut v = [
            c,
            c + (p(&mut rng) - 0.5) * small,
            c + (p(&mut rng) - 0.5) * small,
        ];
        match kind {
            1 => v.iter_mut().for_each(|q| q.z = 0.5), // flat
            2 if i % 2 == 1 => v = tris.last().map(|t: &Triangle| t.v).unwrap_or(v), // duplicates
            3 if i % 3 == 0 => v = [v[0], v[0], v[0]], // point triangle
            3 if i % 3 == 1 => v = [v[0], v[1], v[0] * 2.0 - v[1]], // collinear
            4 => v = [Vec3::ZERO, Vec3::X * 0.1, Vec3::Y * 0.1], // one identical stack
            5 => v.iter_mut().for_each(|q| *q = (*q * 8.0).round() / 8.0), // coarse grid
            _ => {}
        }
        tris.push(Triangle::new(
            v[0] * scale + off,
            v[1] * scale + off,
            v[2] * scale + off,
        ));
    }
    Scene::from_triangles(format!("prop n={n} 1e{exp} off={offset} kind={kind}"), tris).unwrap()
}

/// The same tree whatever the node numbering: walks both trees together and
/// compares every node's kind, axis, clip planes and leaf range, and the
/// set of triangles in every leaf.
pub fn same_tree_structure(a: &Bih, b: &Bih) -> Result<(), String> {
    let mut stack = vec![(0u32, 0u32, String::from("root"))];
    while let Some((i, j, path)) = stack.pop() {
        let (x, y) = (a.nodes[i as usize], b.nodes[j as usize]);
        match (x.is_leaf(), y.is_leaf()) {
            (true, true) => {
                if x.leaf_range() != y.leaf_range() {
                    return Err(format!("{path}: leaf ranges differ"));
                }
                let (f, c) = x.leaf_range();
                let r = f as usize..(f + c) as usize;
                let (mut p, mut q) = (a.prim_ids[r.clone()].to_vec(), b.prim_ids[r].to_vec());
                p.sort_unstable();
                q.sort_unstable();
                if p != q {
                    return Err(format!("{path}: leaves hold different triangles"));
                }
            }
            (false, false) => {
                if (x.axis(), x.clip()) != (y.axis(), y.clip()) {
                    return Err(format!("{path}: splits differ"));
                }
                let (l, m) = (x.left_child(), y.left_child());
                stack.push((l + 1, m + 1, format!("{path}/R")));
                stack.push((l, m, format!("{path}/L")));
            }
            _ => return Err(format!("{path}: a leaf against an inner node")),
        }
    }
    if a.nodes.len() != b.nodes.len() {
        return Err(format!("{} vs {} nodes", a.nodes.len(), b.nodes.len()));
    }
    Ok(())
}

/// Two runs of one multi-SPE build agree (cycles, per-core counters,
/// per-SPE work, node array); every node was made by one job of one SPE;
/// the arenas' blocks hold exactly the nodes and their unused slots.
pub fn check_multi_spe_runs(
    r: &cellbih::registry::BuildReport,
    again: &cellbih::registry::BuildReport,
    what: &str,
) {
    let (a, b) = (
        r.simulated.as_ref().unwrap(),
        again.simulated.as_ref().unwrap(),
    );
    assert_eq!(a.run.cycles, b.run.cycles, "{what}");
    assert_eq!(a.run.cores, b.run.cores, "{what}");
    assert_eq!(a.spe_work, b.spe_work, "{what}");
    assert_eq!(r.bih.nodes, again.bih.nodes, "{what}");
    let jobs: u64 = a.spe_work.iter().map(|w| w.jobs).sum();
    assert_eq!(jobs as usize, r.bih.nodes.len(), "{what}");
    let slots: u64 = a.spe_work.iter().map(|w| w.arena_blocks).sum::<u64>()
        * cellbih::strategy::machinery::arena::BLOCK_NODES as u64;
    let unused: u64 = a.spe_work.iter().map(|w| w.arena_unused).sum();
    assert_eq!(slots - unused, jobs, "{what}");
}

/// Runs `exe` with `args`, killing it after `limit`: a refusal must come
/// at once, so a run that takes longer is a failure (a hang or a huge
/// allocation), not a slow pass.
pub fn run_limited(exe: &str, args: &[&str], limit: Duration) -> Output {
    let mut child = Command::new(exe)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            child.kill().unwrap();
            panic!("{exe} {args:?} still ran after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Fails unless the command failed with `msg` in its stderr.
pub fn assert_fails_with(out: &Output, msg: &str) {
    let err = stderr(out);
    assert!(
        !out.status.success() && err.contains(msg),
        "expected a failure saying '{msg}', got {:?}: {err}",
        out.status
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// Bitwise the same answer (`Hit`'s f64 compared by bits, so that a NaN
/// or a signed zero could not pass unnoticed).
pub fn same_hit(a: &Option<Hit>, b: &Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(x), Some(y)) => {
            x.prim == y.prim
                && x.t.to_bits() == y.t.to_bits()
                && x.u.to_bits() == y.u.to_bits()
                && x.v.to_bits() == y.v.to_bits()
        }
        _ => false,
    }
}
