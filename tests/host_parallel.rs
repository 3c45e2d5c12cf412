//! Issue 29: the host's parallel builders (every builder of the registry
//! that builds on the threads of the current rayon pool) build exactly the
//! serial host builder's tree — the same nodes, numbered alike, and the
//! same triangle order — with 1, 2, 3 and 8 threads, on the property
//! scenes, the extremes and the real meshes, with every quality knob.

mod common;

use cellbih::bih::BihConfig;
use cellbih::registry::BuilderKind;
use cellbih::scene::{self, Scene};
use proptest::prelude::*;

/// The builders that build on the host's threads.
fn parallel() -> Vec<BuilderKind> {
    let v: Vec<BuilderKind> = (BuilderKind::ALL.iter().copied())
        .filter(|b| b.host_threads())
        .collect();
    assert!(!v.is_empty(), "the registry has no parallel host builder");
    v
}

/// The settings checked: the paper's tree and each quality knob.
fn settings() -> Vec<BihConfig> {
    vec![
        BihConfig::default(),
        BihConfig::SAH_CUT,
        BihConfig {
            leaf_size: 1,
            max_depth: 20,
            ..BihConfig::default()
        },
    ]
}

/// `b`'s tree of `s` built in a pool of `threads` threads.
fn build_in_pool(b: BuilderKind, s: &Scene, cfg: &BihConfig, threads: usize) -> cellbih::bih::Bih {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| b.build(s, cfg)).unwrap().bih
}

/// Every parallel builder gives the serial host builder's tree of `s`.
fn check(s: &Scene, cfg: &BihConfig, threads: &[usize]) -> Result<(), String> {
    let serial = BuilderKind::HOST.build(s, cfg).unwrap().bih;
    for b in parallel() {
        for &t in threads {
            let tree = build_in_pool(b, s, cfg, t);
            if tree != serial {
                let why = common::same_tree_structure(&serial, &tree)
                    .err()
                    .unwrap_or_else(|| {
                        "the same structure, another numbering or triangle order".into()
                    });
                return Err(format!("{b}, {t} threads, {}: {why}", s.name));
            }
        }
    }
    Ok(())
}

#[test]
fn the_serial_tree_with_1_2_3_and_8_threads_on_procedural_scenes_and_extremes() {
    let mut scenes = vec![
        scene::load("default", None).unwrap(),
        scene::load("car", None).unwrap(),
        scene::load("rtperf:30000:1", None).unwrap(),
    ];
    scenes.extend(
        scene::extremes::CASES
            .iter()
            .map(|c| scene::extremes::case(c).unwrap()),
    );
    for s in &scenes {
        for cfg in settings() {
            check(s, &cfg, &[1, 2, 3, 8]).unwrap();
        }
    }
}

#[test]
fn the_serial_tree_on_the_real_meshes() {
    let Some(dir) = scene::data_dir(None) else {
        eprintln!("host_parallel: CELLBIH_DATA is not set: the real meshes did NOT run");
        return;
    };
    for name in ["bunny", "sponza-dabrovic", "sibenik", "dragon"] {
        let s = scene::load(name, Some(&dir)).unwrap();
        check(&s, &BihConfig::default(), &[1, 2, 3, 8]).unwrap();
        check(&s, &BihConfig::SAH_CUT, &[3]).unwrap();
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn the_serial_tree_with_any_number_of_threads(
        s in common::scene_strategy(),
        threads in 1usize..9,
        pick in 0usize..3,
    ) {
        let cfg = settings()[pick];
        check(&s, &cfg, &[threads]).map_err(TestCaseError::fail)?;
    }
}

/// `--threads N` builds a host-thread builder on N threads (the report
/// says so) and is refused, naming the builders that take it, by a builder
/// that builds on one thread.
#[test]
fn threads_on_the_command_line() {
    for b in parallel() {
        let out = common::cellbih(&[
            "build",
            "--builder",
            b.name(),
            "--threads",
            "3",
            "--format",
            "json",
        ]);
        common::assert_ok(&out);
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(j["threads"], 3, "{b}");
        let serial = common::cellbih(&["build", "--builder", "host", "--format", "json"]);
        let s: serde_json::Value = serde_json::from_slice(&serial.stdout).unwrap();
        assert_eq!(j["quality"], s["quality"], "{b}: another tree than host's");
    }
    for b in BuilderKind::ALL.iter().filter(|b| !b.host_threads()) {
        let out = common::cellbih(&["build", "--builder", b.name(), "--threads", "2"]);
        common::assert_fails_with(&out, "--threads");
        for p in parallel() {
            assert!(
                common::stderr(&out).contains(p.name()),
                "{b}: {}",
                common::stderr(&out)
            );
        }
    }
    let out = common::cellbih(&["compare", "--threads", "2", "--format", "json"]);
    common::assert_ok(&out);
}
