//! Section 5's multi-SPE strategies (every builder of the registry that
//! puts every SPE to work) with every knob setting their tables sweep, on
//! 1 to 8 SPEs: the baseline's tree (same splits, same leaves; only
//! numbering may differ) unless a knob that changes the tree is set,
//! valid, equal to brute force at the extremes, and the same cycles,
//! counters and nodes on every run.

mod common;

use cellbih::bih::{BihConfig, SplitChoice, Tracer};
use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{self, Scene};
use cellbih::strategy::{Kind, Knobs};
use common::same_tree_structure;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// The builders that put every SPE to work.
fn multi_spe() -> Vec<BuilderKind> {
    let v: Vec<BuilderKind> = (BuilderKind::ALL.iter().copied())
        .filter(|b| b.multi_spe())
        .collect();
    assert!(!v.is_empty(), "the registry has no multi-SPE builder");
    v
}

/// The knob settings a builder is checked with, each with the SPE counts
/// it runs on: its defaults on every count, every other setting its
/// registry entry sweeps on 1, 3 and 8.
fn settings(b: BuilderKind) -> Vec<(Knobs, Vec<usize>)> {
    (b.sweeps().into_iter().enumerate())
        .map(|(i, k)| match i {
            0 => (k, (1..=8).collect()),
            _ => (k, vec![1, 3, 8]),
        })
        .collect()
}

/// Builds `s` with `b` and checks the run against the baseline's tree and
/// a second run; returns the simulated cycles.
fn check_build(
    b: BuilderKind,
    s: &Scene,
    spes: usize,
    (knobs, cfg): (&Knobs, &BihConfig),
    what: &str,
) -> u64 {
    let cell = CellConfig::ps3().with_spes(spes);
    let build = || {
        Build::new(b)
            .with_tree(*cfg)
            .on(&cell)
            .with_knobs(knobs)
            .run(s)
            .unwrap()
    };
    let r = build();
    r.bih.validate(s).unwrap_or_else(|v| panic!("{what}: {v}"));
    let base = Build::new(BuilderKind::SPE_BFS)
        .with_tree(*cfg)
        .run(s)
        .unwrap();
    if !knobs.change_the_tree() {
        same_tree_structure(&base.bih, &r.bih).unwrap_or_else(|e| panic!("{what}: {e}"));
    }
    common::check_multi_spe_runs(&r, &build(), what);
    let a = r.simulated.unwrap();
    if spes > 1 && s.len() > 10_000 {
        // The SPEs the builder used (a small scene uses fewer).
        let used = a.spe_work.len();
        assert!(used >= 1 && used <= spes, "{what}: {used} SPEs used");
        // The strategy's own count is the SPEs that worked; the rest idle.
        assert_eq!(a.spes_used, used, "{what}");
        for (name, c) in &a.run.cores[1..=used] {
            assert!(c.busy.0 > 0, "{what}: {name} did nothing");
        }
        for (name, c) in &a.run.cores[used + 1..] {
            assert_eq!(c.busy.0, 0, "{what}: {name} worked but is not counted");
        }
        let base_cycles = base.simulated.unwrap().run.cycles;
        assert!(
            a.run.cycles < base_cycles,
            "{what}: slower than the baseline"
        );
    }
    a.run.cycles.0
}

/// A builder with every setting, on scenes large enough for every path:
/// levels that spill, intervals over 16 KiB and under, several arena
/// blocks per SPE, regions in and out of a local store. Where the SPEs can
/// wait instead of helping with the top levels, helping pays.
fn every_setting_gives_the_baseline_tree(b: BuilderKind) {
    for spec in ["default", "car", "rtperf:30000:3"] {
        let s = scene::load(spec, None).unwrap();
        let mut by_setting = std::collections::HashMap::new();
        for (knobs, counts) in settings(b) {
            let label = knobs.spelled();
            for spes in counts {
                let what = format!("{b} {label}, {spec} on {spes} SPEs");
                let cycles = check_build(b, &s, spes, (&knobs, &BihConfig::default()), &what);
                by_setting.insert((label.clone(), spes), cycles);
            }
        }
        // The quality knobs it builds: the jobs carry their regions through
        // the deal, the shared queue and the spills; split jobs bin their
        // triangles.
        let cut = BihConfig {
            empty_cut: Some(10),
            ..BihConfig::default()
        };
        let sah_above = BihConfig {
            split: SplitChoice::BinnedSah {
                bins: 16,
                above: 40,
            },
            ..BihConfig::SAH_CUT
        };
        for cfg in [cut, BihConfig::SAH_CUT, sah_above] {
            for spes in [1, 3, 8].into_iter().filter(|_| b.builds(&cfg)) {
                let what = format!("{b} {}, {spec} on {spes} SPEs", cfg.flags());
                check_build(b, &s, spes, (&Knobs::default(), &cfg), &what);
            }
        }
        let alone = |spes| by_setting.get(&("--no-coop-top".to_string(), spes));
        if s.len() > 10_000 && alone(3).is_some() {
            for spes in [3, 8] {
                let helped = by_setting[&(String::new(), spes)];
                assert!(
                    helped < *alone(spes).unwrap(),
                    "{b}, {spec} on {spes} SPEs: helping pays"
                );
            }
        }
    }
}

/// Every multi-SPE builder of the registry, side by side on the host's
/// cores (each is deterministic, so the order cannot matter).
#[test]
fn every_multi_spe_builder_builds_the_baseline_tree_on_1_to_8_spes_with_every_knob() {
    use rayon::prelude::*;
    multi_spe()
        .into_par_iter()
        .for_each(every_setting_gives_the_baseline_tree);
}

/// The what-if beyond a Cell's 8 SPEs (`--spes` up to 16, one memory
/// interface as on 8): every multi-SPE builder with its defaults and its
/// most knobs at once builds the baseline's tree on 12 and 16 SPEs, every
/// SPE works, the run is the same twice, and 16 SPEs share the memory
/// interface: the transfers of the run wait for it more than on 8.
#[test]
fn twelve_and_sixteen_spes_build_the_baseline_tree() {
    let s = scene::load("rtperf:60000:2", None).unwrap();
    let cfg = BihConfig::default();
    let base = Build::new(BuilderKind::SPE_BFS)
        .with_tree(cfg)
        .run(&s)
        .unwrap();
    for b in multi_spe() {
        for mut knobs in [Knobs::default(), b.sweeps().pop().unwrap()] {
            // Every SPE given, whatever the builder would choose.
            b.set_knob(&mut knobs, "tris-per-spe", "1").unwrap();
            let mut mem_wait = Vec::new();
            for spes in [8, 12, 16] {
                let what = format!("{b} {} on {spes} SPEs", knobs.spelled());
                let cell = CellConfig::ps3().with_spes(spes);
                let build = || {
                    Build::new(b)
                        .with_tree(cfg)
                        .on(&cell)
                        .with_knobs(&knobs)
                        .run(&s)
                        .unwrap()
                };
                let r = build();
                r.bih.validate(&s).unwrap_or_else(|v| panic!("{what}: {v}"));
                if !knobs.change_the_tree() {
                    same_tree_structure(&base.bih, &r.bih)
                        .unwrap_or_else(|e| panic!("{what}: {e}"));
                }
                common::check_multi_spe_runs(&r, &build(), &what);
                let sim = r.simulated.unwrap();
                assert_eq!(sim.run.cores.len(), spes + 1, "{what}");
                for (name, c) in &sim.run.cores[1..] {
                    assert!(c.busy.0 > 0, "{what}: {name} did nothing");
                }
                mem_wait.push(
                    sim.run.cores[1..]
                        .iter()
                        .map(|(_, c)| c.memory_wait.0)
                        .sum::<u64>(),
                );
            }
            assert!(
                mem_wait[2] > mem_wait[0],
                "{b}: memory-interface wait {mem_wait:?}"
            );
        }
    }
}

/// The same cycles, counters and tree whatever the host does: builds run
/// side by side in rayon pools of one and two threads agree with a lone
/// build.
#[test]
fn host_threads_change_nothing() {
    use rayon::prelude::*;
    let s = scene::load("rtperf:20000:5", None).unwrap();
    let cell = CellConfig::ps3().with_spes(8);
    for b in multi_spe() {
        // Its last sweep setting: the most knobs at once.
        let knobs = b.sweeps().pop().unwrap();
        let build = || {
            let r = Build::new(b).on(&cell).with_knobs(&knobs).run(&s);
            let r = r.unwrap();
            let sim = r.simulated.unwrap();
            (
                sim.run.cycles,
                format!("{:?}", sim.run.cores),
                sim.spe_work,
                r.bih.nodes,
            )
        };
        let alone = build();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let runs: Vec<_> = pool.install(|| (0..4).into_par_iter().map(|_| build()).collect());
            for r in runs {
                assert!(r == alone, "{b}: {threads} host threads changed the run");
            }
        }
    }
}

/// The ObjectArena pool holds 2n + 1 nodes, every node a tree of the
/// paper's settings can have; the empty-space cut-off at a tiny threshold
/// with leaves of one triangle makes more (rtperf:20000: 77,929 nodes, more
/// than the pool's blocks hold once each of 8 SPEs has part-filled its
/// own). The SPEs then ask the PPE for overflow blocks, as the paper's
/// arena does: the build gives the baseline's tree, cycle for cycle the
/// same on every run.
#[test]
fn a_cut_off_that_outgrows_the_arena_pool_grows_it() {
    let s = scene::load("rtperf:20000:1", None).unwrap();
    for b in multi_spe().into_iter().filter(|b| b.quality().empty_cut) {
        let tiny = BihConfig {
            leaf_size: 1,
            empty_cut: Some(1),
            ..BihConfig::default()
        };
        for spes in [1, 6, 8] {
            let what = format!("{b} on {spes} SPEs with {tiny:?}");
            check_build(b, &s, spes, (&Knobs::default(), &tiny), &what);
        }
    }
}

/// Every knob of every builder's table refuses a value out of its range,
/// naming the builder and the knob, and sets nothing.
#[test]
fn knobs_out_of_range_are_errors() {
    let mut refused = 0;
    for &b in BuilderKind::ALL {
        for &k in b.knobs() {
            let bad: Vec<String> = match k.kind {
                Kind::Flag => vec!["1".into()],
                Kind::Int { min, max, .. } => {
                    let mut v = vec!["-1".to_string(), "x".into()];
                    v.extend(min.checked_sub(1).map(|m| m.to_string()));
                    v.extend((max < usize::MAX).then(|| (max + 1).to_string()));
                    v
                }
                Kind::Word(_) => vec!["nope".into(), String::new()],
            };
            for value in bad {
                let mut knobs = Knobs::default();
                let e = b.set_knob(&mut knobs, k.name, &value);
                let e = e
                    .err()
                    .unwrap_or_else(|| panic!("{b} --{} {value}", k.name));
                let e = e.to_string();
                assert!(e.contains(b.name()) && e.contains(k.name), "{e}");
                assert_eq!(knobs, Knobs::default(), "{e}");
                refused += 1;
            }
        }
    }
    assert!(refused > 0);
}

/// A take of the shared queue must fit `WorkA`: 128 jobs of 128 bytes with
/// the empty-space cut-off. More is refused by the builders that take
/// `--agglomerate`, naming it, though it is in the knob's range.
#[test]
fn a_take_larger_than_work_a_is_refused() {
    let s = scene::load("default", None).unwrap();
    let cut = BihConfig {
        empty_cut: Some(10),
        ..BihConfig::default()
    };
    let takers = (BuilderKind::ALL.iter()).filter(|b| b.knob("agglomerate").is_ok());
    let mut checked = 0;
    for &b in takers {
        let mut knobs = Knobs::default();
        b.set_knob(&mut knobs, "agglomerate", "129").unwrap();
        let cell = CellConfig::ps3();
        let e = (Build::new(b)
            .with_tree(cut)
            .on(&cell)
            .with_knobs(&knobs)
            .run(&s))
        .unwrap_err();
        assert!(e.to_string().contains("--agglomerate 129"), "{e}");
        let paper = Build::new(b).on(&cell).with_knobs(&knobs).run(&s);
        assert!(paper.is_ok(), "64-byte jobs: 256 fit");
        checked += 1;
    }
    assert!(checked > 0);
}

/// Section 5's software cache for the job queue (`--job-cache`): the same
/// tree as the explicit gets; each SPE empties its cache at every level's
/// barrier (so every SPE the same number of times); each job record is
/// read once, so lines are reused only where two takes of one SPE share
/// one: most lookups miss. A cache the local store has no room for is
/// refused, naming the knob.
#[test]
fn the_job_queue_cache_reads_the_same_jobs_and_is_emptied_every_level() {
    let s = scene::load("rtperf:30000:3", None).unwrap();
    let cfg = BihConfig::default();
    let cell = CellConfig::ps3().with_spes(3);
    let users = (BuilderKind::ALL.iter()).filter(|b| b.knob("job-cache").is_ok());
    let mut checked = 0;
    for &b in users {
        let plain = Build::new(b).with_tree(cfg).on(&cell).run(&s).unwrap();
        let mut knobs = Knobs::default();
        b.set_knob(&mut knobs, "job-cache", "4").unwrap();
        let cached = Build::new(b)
            .with_tree(cfg)
            .on(&cell)
            .with_knobs(&knobs)
            .run(&s)
            .unwrap();
        assert_eq!(plain.bih.nodes, cached.bih.nodes, "{b}");
        assert_eq!(plain.bih.prim_ids, cached.bih.prim_ids, "{b}");
        let work = &cached.simulated.as_ref().unwrap().spe_work;
        assert_eq!(work.len(), 3);
        let emptied = work[0].job_cache.invalidations;
        assert!(emptied > 2, "{b}: emptied {emptied} times");
        for w in work {
            assert_eq!(w.job_cache.invalidations, emptied, "{b}: {work:?}");
            assert!(w.job_cache.lookups >= w.taken, "{b}: {w:?}");
            assert!(w.job_cache.hit_rate() < 0.5, "{b}: {w:?}");
        }
        assert!(
            plain
                .simulated
                .as_ref()
                .unwrap()
                .spe_work
                .iter()
                .all(|w| w.job_cache.lookups == 0),
            "{b}: no cache, no lookups"
        );
        b.set_knob(&mut knobs, "job-cache", "32").unwrap();
        // Double buffers (on by default or by a knob) take local store too.
        if b.knob("double-buffer").is_ok() {
            b.set_knob(&mut knobs, "double-buffer", "").unwrap();
        }
        let e = Build::new(b)
            .with_tree(cfg)
            .on(&cell)
            .with_knobs(&knobs)
            .run(&s)
            .unwrap_err();
        assert!(e.to_string().contains("--job-cache 32"), "{b}: {e}");
        checked += 1;
    }
    assert!(checked > 0);
}

/// Knobs for `b`: each knob of its table at its default, its least value,
/// one of its sweep values, or a value in its range (up to four times its
/// default), as `picks` say.
fn knobs_from(b: BuilderKind, picks: &[(u32, f64)]) -> Knobs {
    let mut knobs = Knobs::default();
    for (&k, &(pick, frac)) in b.knobs().iter().zip(picks.iter().cycle()) {
        let value = match k.kind {
            Kind::Flag if pick % 2 == 1 => String::new(),
            Kind::Flag => continue,
            Kind::Word(words) => words[pick as usize % words.len()].to_string(),
            Kind::Int { default, min, max } => match pick % 4 {
                0 => k.default_text(),
                1 => min.to_string(),
                2 => k.sweep[(pick / 4) as usize % k.sweep.len()].to_string(),
                _ => {
                    // An `auto` default (0) reads as its least value here.
                    let hi = max.min(4 * default.max(min));
                    (min + (frac * (hi - min) as f64) as usize).to_string()
                }
            },
        };
        knobs.set(k, &value).unwrap();
    }
    knobs
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..Default::default() })]

    /// Every multi-SPE builder on the property scenes (scales 1e-15 to
    /// 1e15, flat, degenerate, stacks, grids) with 1 to 8 SPEs, any knobs
    /// of its table and small leaves (so that the top levels hand over),
    /// with or without the empty-space cut-off and binned SAH where it
    /// builds them: valid, equal to brute force, the baseline's tree unless
    /// a knob that changes the tree is set.
    #[test]
    fn multi_spe_builders_on_any_scene_spe_count_and_knobs(
        scene in common::scene_strategy(),
        which in any::<prop::sample::Index>(),
        spes in 1usize..=8,
        leaf in 1u32..4,
        picks in proptest::collection::vec((0u32..64, 0.0f64..1.0), 1..12),
        empty_cut in proptest::option::of(1u32..=99),
        sah in proptest::option::of((2u32..=32, prop_oneof![Just(0u32), 1u32..64])),
    ) {
        let b = *which.get(&multi_spe());
        let knobs = knobs_from(b, &picks);
        let split = sah.map_or(SplitChoice::GlobalHeuristic, |(bins, above)| SplitChoice::BinnedSah { bins, above });
        let cfg = BihConfig { leaf_size: leaf, split, empty_cut, ..BihConfig::default() };
        let cfg = b.quality().reach(&cfg);
        let cell = CellConfig::ps3().with_spes(spes);
        let fail = |e: String| TestCaseError::fail(format!("{b} {} {} on {spes} SPEs: {e}", knobs.spelled(), cfg.flags()));
        let r = Build::new(b).with_tree(cfg).on(&cell).with_knobs(&knobs).run(&scene)
            .map_err(|e| fail(e.to_string()))?;
        r.bih.validate(&scene).map_err(|v| fail(v.to_string()))?;
        if !knobs.change_the_tree() {
            let base = Build::new(BuilderKind::SPE_BFS).with_tree(cfg).run(&scene).unwrap();
            same_tree_structure(&base.bih, &r.bih).map_err(fail)?;
        }
        let tracer = Tracer::new(&r.bih, &scene);
        for ray in common::rays_for(&scene, 24, 5) {
            common::check_ray(&scene, &tracer, &ray).map_err(fail)?;
        }
    }
}

/// A strategy made of phases runs every phase on every SPE: on 8 SPEs
/// each phase takes at most two thirds of its simulated time on one SPE
/// (the memory-bound permutation about a half; a phase left to SPE 0
/// alone, as spe_morton's top of the tree was in earlier versions, about all
/// of it).
#[test]
fn every_phase_of_a_phased_build_runs_on_every_spe() {
    let s = scene::load("rtperf:100000:1", None).unwrap();
    let cfg = BihConfig::default();
    let durations = |b: BuilderKind, spes: usize| {
        let cell = CellConfig::ps3().with_spes(spes);
        let r = Build::new(b).with_tree(cfg).on(&cell).run(&s);
        let phases = r.unwrap().simulated.unwrap().phases;
        let mut start = 0;
        (phases.iter())
            .map(|&(name, end)| (name, end - std::mem::replace(&mut start, end)))
            .collect::<Vec<_>>()
    };
    let mut phased = 0;
    for b in multi_spe() {
        let (one, eight) = (durations(b, 1), durations(b, 8));
        if one.is_empty() {
            continue;
        }
        phased += 1;
        assert_eq!(one.len(), eight.len(), "{b}: the same phases");
        for ((name, t1), (_, t8)) in one.iter().zip(&eight) {
            assert!(
                3 * t8 <= 2 * t1,
                "{b}: {name} {t8} cycles on 8 SPEs, {t1} on 1"
            );
        }
    }
    assert!(phased > 0, "no multi-SPE builder reports phases");
}

/// A scene whose triangles crowd into one corner: 19,200 in a unit box
/// beside 4,800 spread over a box a hundred times larger, so that a level
/// of one job per SPE holds one job with most of the triangles.
fn crowded_corner() -> Scene {
    use cellbih::scene::procedural::PartsBuilder;
    use glam::Vec3;
    let mut b = PartsBuilder::default();
    b.part("crowd");
    b.grid_box(Vec3::ZERO, Vec3::ONE, 40);
    b.part("room");
    b.grid_box(Vec3::splat(-50.0), Vec3::splat(50.0), 20);
    b.finish("crowded corner")
}

/// where the top ends by count, one job holds most of the
/// work and the other SPEs wait (at the deal's tail, or at the shared
/// levels' barriers); `--top-end split` splits that job before the deal.
/// On 8 SPEs it builds the baseline's tree faster, with less waiting.
#[test]
fn a_split_top_keeps_the_spes_from_waiting_on_a_crowded_scene() {
    let s = crowded_corner();
    let cfg = BihConfig::default();
    let mut checked = 0;
    for b in multi_spe() {
        let Some(&knob) = b.knobs().iter().find(|k| k.name == "top-end") else {
            continue;
        };
        let run = |end: &str| {
            let knobs = Knobs::default().with(knob, end).unwrap();
            let what = format!("{b} --top-end {end}");
            let cycles = check_build(b, &s, 8, (&knobs, &cfg), &what);
            let cell = CellConfig::ps3().with_spes(8);
            let r = Build::new(b)
                .with_tree(cfg)
                .on(&cell)
                .with_knobs(&knobs)
                .run(&s)
                .unwrap();
            let run = r.simulated.unwrap().run;
            let waiting: u64 = (run.cores.iter())
                .filter(|(name, _)| name.starts_with("SPE"))
                .map(|(_, c)| c.idle.0 + c.mailbox_wait.0)
                .sum();
            (cycles, waiting)
        };
        let (count, split) = (run("count"), run("split"));
        assert!(split.0 < count.0, "{b}: split {split:?}, count {count:?}");
        assert!(split.1 < count.1, "{b}: split {split:?}, count {count:?}");
        checked += 1;
    }
    assert!(checked > 0, "no multi-SPE builder has --top-end");
}
