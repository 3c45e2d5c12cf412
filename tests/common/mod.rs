//! Helpers shared by the integration tests: scene and ray generators for
//! proptest, the brute-force comparison, and the data directory.
#![allow(dead_code)]

pub mod leaks;

use cellbih::bih::{Bih, Ray};
#[allow(unused_imports)]
pub use cellbih::quality::agree::{check_ray, rays_for, same_hit};
use cellbih::render::Camera;
use cellbih::scene::{Scene, SplitMix64, Triangle};
use glam::DVec3;
use glam::Vec3;
use proptest::prelude::*;

/// A path in this test process's own temporary directory.
pub fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("cellbih-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
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

/// The sets of rays a packet is tried on: a framing camera's rays and a
/// camera's from inside the box, in 4 × 4 blocks (edge blocks cut, so
/// some packets hold fewer rays); scattered rays with every direction
/// turned into the positive octant (coherent packets whose rays start
/// anywhere and some end early); and the scattered rays as they are
/// (mixed signs and zero components: ray by ray).
pub fn packet_ray_sets(scene: &Scene, seed: u64) -> Vec<(&'static str, Vec<Ray>)> {
    let b = scene.bounds();
    let outside = Camera::framing(&b, 10, 7);
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let inside = Camera::look(lo + (hi - lo) * 0.3, hi, DVec3::Z, 70.0, 9, 6);
    let loose = rays_for(scene, 48, seed);
    let octant = (loose.iter())
        .filter(|r| (DVec3::ONE / r.dir).is_finite())
        .map(|r| Ray {
            dir: r.dir.abs(),
            ..*r
        })
        .collect();
    vec![
        ("framing camera", outside.rays_in_blocks(4, 4)),
        ("inside camera", inside.rays_in_blocks(4, 4)),
        ("one octant", octant),
        ("scattered", loose),
    ]
}
