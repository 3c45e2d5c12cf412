//! The Morton route's shared kernels (issue 12, `src/kernels/morton.rs`):
//! keys in the global heuristic's order give the baseline's tree from the
//! sorted keys alone, at every width and at the numerical extremes; the
//! round-robin order gives another valid tree that answers every ray as
//! brute force does.

mod common;

use cellbih::bih::{BihConfig, Tracer};
use cellbih::kernels::morton::{KeyOrder, build_scene};
use cellbih::registry::BuilderKind;
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
        let cfg = BihConfig { leaf_size: leaf, max_depth: depth, ..BihConfig::default() };
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

use cellbih::cell::CellConfig;
use cellbih::scene::Scene;
use cellbih::strategy::{KeyOrder as Order, Knobs};

fn spe_morton() -> BuilderKind {
    BuilderKind::from_name("spe_morton").unwrap()
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
        spe_morton()
            .build_with(s, s.bounds(), cfg, &cell, knobs)
            .unwrap_or_else(|e| panic!("{what}: {e}"))
    };
    let r = build();
    r.bih.validate(s).unwrap_or_else(|v| panic!("{what}: {v}"));
    common::check_multi_spe_runs(&r, &build(), what);
    r
}

/// With the global heuristic's order, `spe_morton` gives the baseline's
/// tree on 1 to 8 SPEs and with every knob: key width, digit width,
/// region size (small: a deep top; huge: regions too large for the local
/// store, built by the baseline's breadth-first loop), static dealing. With
/// several SPEs on a large scene it beats the baseline.
#[test]
fn spe_morton_builds_the_baseline_tree_with_every_knob() {
    let cfg = BihConfig::default();
    let d = Knobs::default();
    for spec in ["default", "car", "rtperf:30000:3"] {
        let s = scene::load(spec, None).unwrap();
        let base = BuilderKind::SPE_BFS.build(&s, &cfg).unwrap();
        let base_cycles = base.simulated.unwrap().run.cycles;
        let mut settings: Vec<(String, Knobs, Vec<usize>)> =
            vec![("default".into(), d, (1..=8).collect())];
        for (label, k) in [
            ("64-bit keys", Knobs { key_bits: 64, ..d }),
            ("4-bit digits", Knobs { digit_bits: 4, ..d }),
            (
                "11-bit digits",
                Knobs {
                    digit_bits: 11,
                    ..d
                },
            ),
            (
                "regions of 64",
                Knobs {
                    region_size: 64,
                    ..d
                },
            ),
            (
                "one region",
                Knobs {
                    region_size: 100_000_000,
                    ..d
                },
            ),
            (
                "static regions",
                Knobs {
                    static_regions: true,
                    ..d
                },
            ),
        ] {
            settings.push((label.into(), k, vec![1, 3, 8]));
        }
        for (label, knobs, counts) in settings {
            for spes in counts {
                let what = format!("spe_morton, {spec} on {spes} SPEs, {label}");
                let r = morton_build(&s, spes, &knobs, &cfg, &what);
                same_tree_structure(&base.bih, &r.bih).unwrap_or_else(|e| panic!("{what}: {e}"));
                let sim = r.simulated.unwrap();
                if spes > 1 && s.len() > 10_000 && knobs.region_size < s.len() {
                    for (name, c) in &sim.run.cores[1..] {
                        assert!(c.busy.0 > 0, "{what}: {name} did nothing");
                    }
                    assert!(
                        sim.run.cycles < base_cycles,
                        "{what}: slower than the baseline"
                    );
                }
            }
        }
    }
}

/// Round-robin keys: another tree, valid and equal to brute force.
#[test]
fn spe_morton_round_robin_gives_a_valid_tree() {
    let cfg = BihConfig::default();
    for spec in ["default", "car", "rtperf:30000:3"] {
        let s = scene::load(spec, None).unwrap();
        for bits in [32, 64] {
            let knobs = Knobs {
                key_order: Order::RoundRobin,
                key_bits: bits,
                ..Knobs::default()
            };
            let what = format!("spe_morton xyz {bits} bits, {spec}");
            let r = morton_build(&s, 6, &knobs, &cfg, &what);
            let tracer = Tracer::new(&r.bih, &s);
            for ray in common::rays_for(&s, 200, 11) {
                common::check_ray(&s, &tracer, &ray).unwrap_or_else(|e| panic!("{what}: {e}"));
            }
        }
    }
}

/// Knobs out of range are errors naming the builder.
#[test]
fn spe_morton_refuses_knobs_out_of_range() {
    let s = scene::load("default", None).unwrap();
    let cell = CellConfig::ps3();
    let d = Knobs::default();
    for knobs in [
        Knobs { key_bits: 48, ..d },
        Knobs { digit_bits: 3, ..d },
        Knobs {
            digit_bits: 12,
            ..d
        },
        Knobs {
            region_size: 0,
            ..d
        },
    ] {
        let e = spe_morton().build_with(&s, s.bounds(), &BihConfig::default(), &cell, &knobs);
        let e = e
            .err()
            .unwrap_or_else(|| panic!("accepted {knobs:?}"))
            .to_string();
        assert!(e.contains("spe_morton"), "{e}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..Default::default() })]

    /// `spe_morton` at the extremes, on 1 to 8 SPEs with any knobs: valid,
    /// equal to brute force; the baseline's tree in the global
    /// heuristic's order.
    #[test]
    fn spe_morton_at_the_extremes(
        scene in common::scene_strategy(),
        spes in 1usize..=8,
        leaf in 1u32..4,
        round_robin in any::<bool>(),
        wide in any::<bool>(),
        digit_bits in 4u32..=11,
        region_size in 1usize..100,
        static_regions in any::<bool>(),
    ) {
        let cfg = BihConfig { leaf_size: leaf, ..BihConfig::default() };
        let knobs = Knobs {
            key_order: if round_robin { Order::RoundRobin } else { Order::GlobalHeuristic },
            key_bits: if wide { 64 } else { 32 },
            digit_bits,
            region_size,
            static_regions,
            ..Knobs::default()
        };
        let cell = CellConfig::ps3().with_spes(spes);
        let fail = |e: String| TestCaseError::fail(format!("{spes} SPEs, {knobs:?}: {e}"));
        let r = spe_morton().build_with(&scene, scene.bounds(), &cfg, &cell, &knobs).map_err(|e| fail(e.to_string()))?;
        r.bih.validate(&scene).map_err(|v| fail(v.to_string()))?;
        if !round_robin {
            let base = BuilderKind::SPE_BFS.build(&scene, &cfg).unwrap();
            same_tree_structure(&base.bih, &r.bih).map_err(fail)?;
        }
        let tracer = Tracer::new(&r.bih, &scene);
        for ray in common::rays_for(&scene, 24, 5) {
            common::check_ray(&scene, &tracer, &ray).map_err(fail)?;
        }
    }
}
