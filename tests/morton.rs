//! The Morton route's shared kernels (`src/kernels/morton.rs`):
//! keys in the global heuristic's order give the baseline's tree from the
//! sorted keys alone, at every width and at the numerical extremes; the
//! round-robin order gives another valid tree that answers every ray as
//! brute force does.

mod common;

use cellbih::bih::{BihConfig, Tracer};
use cellbih::kernels::morton::{KeyOrder, build_scene};
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene;
use common::same_tree_structure;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

#[test]
fn global_heuristic_keys_give_the_host_tree_on_real_scenes() {
    let cfg = BihConfig::default();
    for spec in ["default", "car", "rtperf:30000:3"] {
        let s = scene::load(spec, None).unwrap();
        let host = Build::new(BuilderKind::HOST)
            .with_tree(cfg)
            .run(&s)
            .unwrap()
            .bih;
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
        let cfg = BihConfig { leaf_size: leaf, max_depth: depth, ..BihConfig::default() };
        let bits = if wide { 64 } else { 32 };
        let host = Build::new(BuilderKind::HOST).with_tree(cfg).run(&scene).unwrap().bih;
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

use cellbih::cell::CellConfig;
use cellbih::scene::Scene;
use cellbih::strategy::Knobs;

fn spe_morton() -> BuilderKind {
    BuilderKind::from_name("spe_morton").unwrap()
}

/// `spe_morton` with `--NAME VALUE` pairs.
fn knobs(pairs: &[(&str, &str)]) -> Knobs {
    let mut k = Knobs::default();
    for (name, value) in pairs {
        spe_morton().set_knob(&mut k, name, value).unwrap();
    }
    k
}

/// Builds `s` with `spe_morton`, checks it is valid, deterministic and
/// every node made by one SPE; returns the build.
fn morton_build(
    s: &Scene,
    spes: usize,
    knobs: &Knobs,
    cfg: &BihConfig,
    what: &str,
) -> cellbih::registry::BuildReport {
    let cell = CellConfig::ps3().with_spes(spes);
    let build = || {
        Build::new(spe_morton())
            .with_tree(*cfg)
            .on(&cell)
            .with_knobs(knobs)
            .run(s)
            .unwrap_or_else(|e| panic!("{what}: {e}"))
    };
    let r = build();
    r.bih.validate(s).unwrap_or_else(|v| panic!("{what}: {v}"));
    common::check_multi_spe_runs(&r, &build(), what);
    r
}

/// With the global heuristic's order, `spe_morton` gives the baseline's
/// tree at the ends of its region size that its sweep values do not reach
/// (`tests/multi_spe.rs` builds those): regions of 64 (a deep top) and one
/// region of the whole scene (too large for the local store, built by the
/// baseline's breadth-first loop), on 1, 3 and 8 SPEs.
#[test]
fn spe_morton_builds_the_baseline_tree_at_the_ends_of_its_region_size() {
    let cfg = BihConfig::default();
    for spec in ["default", "car", "rtperf:30000:3"] {
        let s = scene::load(spec, None).unwrap();
        let base = Build::new(BuilderKind::SPE_BFS)
            .with_tree(cfg)
            .run(&s)
            .unwrap();
        for regions in ["64", "100000000"] {
            let k = knobs(&[("region-size", regions)]);
            for spes in [1, 3, 8] {
                let what = format!("spe_morton --region-size {regions}, {spec} on {spes} SPEs");
                let r = morton_build(&s, spes, &k, &cfg, &what);
                same_tree_structure(&base.bih, &r.bih).unwrap_or_else(|e| panic!("{what}: {e}"));
            }
        }
    }
}

/// Round-robin keys: another tree, valid and equal to brute force, with
/// 32- and 64-bit keys.
#[test]
fn spe_morton_round_robin_gives_a_valid_tree() {
    let cfg = BihConfig::default();
    for spec in ["default", "car", "rtperf:30000:3"] {
        let s = scene::load(spec, None).unwrap();
        for bits in ["32", "64"] {
            let k = knobs(&[("key-order", "xyz"), ("key-bits", bits)]);
            assert!(k.change_the_tree());
            let what = format!("spe_morton xyz {bits} bits, {spec}");
            let r = morton_build(&s, 6, &k, &cfg, &what);
            let tracer = Tracer::new(&r.bih, &s);
            for ray in common::rays_for(&s, 200, 11) {
                common::check_ray(&s, &tracer, &ray).unwrap_or_else(|e| panic!("{what}: {e}"));
            }
        }
    }
}

/// Each region's gather is issued before the build of the one before it
/// (two slots of the local store): the same tree as `--no-prefetch`,
/// which loads each region only when its build starts, on one SPE and on
/// six, and fewer cycles on one (on six the saving, about 0.1 %, is
/// within what the order of the counter's takes moves); with few regions
/// left per SPE no SPE takes one ahead, so the default scene on eight
/// SPEs still builds every region.
#[test]
fn spe_morton_gathers_the_next_region_during_this_ones_build() {
    let cfg = BihConfig::default();
    let s = scene::load("rtperf:30000:3", None).unwrap();
    for spes in [1, 6] {
        let what = format!("spe_morton on {spes} SPEs");
        let ahead = morton_build(&s, spes, &Knobs::default(), &cfg, &what);
        let what = format!("spe_morton --no-prefetch on {spes} SPEs");
        let waited = morton_build(&s, spes, &knobs(&[("no-prefetch", "")]), &cfg, &what);
        assert_eq!(ahead.bih.tree_hash(), waited.bih.tree_hash(), "{what}");
        let cycles = |r: &cellbih::registry::BuildReport| r.simulated.as_ref().unwrap().run.cycles;
        if spes == 1 {
            assert!(cycles(&ahead) < cycles(&waited), "{what}");
        }
    }
    let small = scene::load("default", None).unwrap();
    let r = morton_build(&small, 8, &Knobs::default(), &cfg, "default scene, 8 SPEs");
    let work = &r.simulated.as_ref().unwrap().spe_work;
    assert!(
        work.iter().all(|w| w.taken > 0),
        "an SPE built no region: {work:?}"
    );
}
