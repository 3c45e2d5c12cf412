//! The host's parallel builders (every builder of the registry
//! that builds on the threads of the current rayon pool) build exactly the
//! serial host builder's tree — the same nodes, numbered alike, the same
//! leaves with the same triangles — with 1, 2, 3 and 8 threads, on the
//! property scenes, the extremes and the real meshes, with every quality
//! knob each builds; with a grain of a few items (so that the parallel
//! part, not one thread's serial recursion, builds a small scene); and
//! every ray they answer, brute force answers the same.

mod common;

use cellbih::bih::{Bih, BihConfig, SplitChoice, Tracer};
use cellbih::registry::{Build, BuilderKind};
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

/// The settings checked: the paper's tree and each quality knob — the
/// cut-off alone (`host_morton`: clip nodes among the keys' splits, and
/// with a low depth limit, leaves where clip nodes reach it) and binned SAH
/// above a few triangles, the global heuristic below (its keyed subtrees
/// under SAH's candidates).
fn settings() -> Vec<BihConfig> {
    vec![
        BihConfig::default(),
        BihConfig::SAH_CUT,
        BihConfig {
            empty_cut: Some(10),
            ..BihConfig::default()
        },
        BihConfig {
            split: SplitChoice::BinnedSah { bins: 8, above: 24 },
            empty_cut: Some(25),
            ..BihConfig::default()
        },
        // Clip nodes that bring splits to the depth limit.
        BihConfig {
            empty_cut: Some(5),
            leaf_size: 1,
            max_depth: 7,
            ..BihConfig::default()
        },
        BihConfig {
            leaf_size: 1,
            max_depth: 20,
            ..BihConfig::default()
        },
    ]
}

/// `b`'s tree of `s` built in a pool of `threads` threads.
fn build_in_pool(b: BuilderKind, s: &Scene, cfg: &BihConfig, threads: usize) -> Bih {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| Build::new(b).with_tree(*cfg).run(s))
        .unwrap()
        .bih
}

/// `tree` is `serial`: the same nodes, numbered alike, and each leaf the
/// same triangles (in any order).
fn same_tree(serial: &Bih, tree: &Bih) -> Result<(), String> {
    common::same_tree_structure(serial, tree)?;
    match tree.nodes == serial.nodes {
        true => Ok(()),
        false => Err("the same structure, numbered otherwise".into()),
    }
}

/// Every parallel builder that builds `cfg` gives the serial host
/// builder's tree of `s`.
fn check(s: &Scene, cfg: &BihConfig, threads: &[usize]) -> Result<(), String> {
    let serial = Build::new(BuilderKind::HOST)
        .with_tree(*cfg)
        .run(s)
        .unwrap()
        .bih;
    for b in parallel().into_iter().filter(|b| b.builds(cfg)) {
        for &t in threads {
            let tree = build_in_pool(b, s, cfg, t);
            same_tree(&serial, &tree)
                .map_err(|why| format!("{b}, {t} threads, {}: {why}", s.name))?;
        }
    }
    Ok(())
}

/// [`check`] with jobs of at most `grain` items finished by one thread,
/// and every ray of the trees against brute force.
fn check_grained(s: &Scene, cfg: &BihConfig, threads: usize, grain: usize) -> Result<(), String> {
    let serial = Build::new(BuilderKind::HOST)
        .with_tree(*cfg)
        .run(s)
        .unwrap()
        .bih;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    for b in parallel().into_iter().filter(|b| b.builds(cfg)) {
        let tree = pool
            .install(|| b.build_grained(s, cfg, grain))
            .expect("a grained builder");
        let at = || format!("{b}, {threads} threads, grain {grain}, {}", s.name);
        same_tree(&serial, &tree).map_err(|why| format!("{}: {why}", at()))?;
        tree.validate(s).map_err(|v| format!("{}: {v}", at()))?;
        let tracer = Tracer::new(&tree, s);
        for ray in common::rays_for(s, 16, 5) {
            common::check_ray(s, &tracer, &ray).map_err(|e| format!("{}: {e}", at()))?;
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
            for grain in [1, 7, 64] {
                check_grained(s, &cfg, 3, grain).unwrap();
            }
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
        // Binned SAH down to 65,536 triangles, then the global heuristic
        // (host_morton: keyed subtrees under SAH's candidates).
        let hybrid = BihConfig {
            split: SplitChoice::BinnedSah {
                bins: 16,
                above: 65_536,
            },
            ..BihConfig::SAH_CUT
        };
        check(&s, &hybrid, &[3]).unwrap();
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn the_serial_tree_with_any_number_of_threads(
        s in common::scene_strategy(),
        threads in 1usize..9,
        cfg in prop::sample::select(settings()),
        grain in prop::sample::select(vec![1usize, 2, 5, 33]),
    ) {
        check(&s, &cfg, &[threads]).map_err(TestCaseError::fail)?;
        check_grained(&s, &cfg, threads.max(2), grain).map_err(TestCaseError::fail)?;
    }
}
