//! The Morton route's shared kernels (issue 12, `src/build/morton.rs`):
//! keys in the global heuristic's order give the baseline's tree from the
//! sorted keys alone, at every width and at the numerical extremes; the
//! round-robin order gives another valid tree that answers every ray as
//! brute force does.

mod common;

use cellbih::bih::{BihConfig, Tracer};
use cellbih::build::BuilderKind;
use cellbih::build::morton::{KeyOrder, build_scene};
use cellbih::scene;
use common::same_tree_structure;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

#[test]
fn global_heuristic_keys_give_the_host_tree_on_real_scenes() {
    let cfg = BihConfig::default();
    for spec in ["default", "car", "rtperf:30000:3"] {
        let s = scene::load(spec, None).unwrap();
        let host = BuilderKind::HOST.build(&s, &cfg).unwrap().bih;
        for bits in [32, 64] {
            let t = build_scene(&s, KeyOrder::GlobalHeuristic, bits, &cfg);
            t.validate(&s).unwrap();
            same_tree_structure(&host, &t).unwrap_or_else(|e| panic!("{spec}, {bits} bits: {e}"));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..Default::default() })]

    /// At the extremes (scales 1e-15 to 1e15, flat, degenerate, stacks,
    /// grids), with any leaf size and depth limit: the global heuristic's
    /// keys give the host tree; round robin a valid tree equal to brute
    /// force on every ray.
    #[test]
    fn keys_at_the_extremes(
        scene in common::scene_strategy(),
        leaf in 1u32..6,
        depth in prop::sample::select(vec![2u32, 64]),
        wide in any::<bool>(),
    ) {
        let cfg = BihConfig { leaf_size: leaf, max_depth: depth };
        let bits = if wide { 64 } else { 32 };
        let host = BuilderKind::HOST.build(&scene, &cfg).unwrap().bih;
        let gh = build_scene(&scene, KeyOrder::GlobalHeuristic, bits, &cfg);
        gh.validate(&scene).map_err(|v| TestCaseError::fail(format!("global heuristic: {v}")))?;
        same_tree_structure(&host, &gh).map_err(TestCaseError::fail)?;
        let rr = build_scene(&scene, KeyOrder::RoundRobin, bits, &cfg);
        rr.validate(&scene).map_err(|v| TestCaseError::fail(format!("round robin: {v}")))?;
        let tracer = Tracer::new(&rr, &scene);
        for ray in common::rays_for(&scene, 24, 3) {
            common::check_ray(&scene, &tracer, &ray).map_err(TestCaseError::fail)?;
        }
    }
}
