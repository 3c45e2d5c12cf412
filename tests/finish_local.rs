//! `--finish local` (the breadth-first strategies finishing jobs that fit
//! as subtrees in the local store, section 5's independent subtrees
//! reached level by level): a job at the local store's budget and one
//! over, the shared queue's bound on a subtree, and the phases a
//! breadth-first run reports — every tree the baseline's.

mod common;

use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{self, Scene};
use cellbih::strategy::Knobs;
use common::same_tree_structure;

/// The builders that put every SPE to work and take `--finish`.
fn finishing() -> Vec<BuilderKind> {
    let v: Vec<BuilderKind> = (BuilderKind::ALL.iter().copied())
        .filter(|b| b.multi_spe() && b.knob("finish").is_ok())
        .collect();
    assert!(!v.is_empty(), "no multi-SPE builder takes --finish");
    v
}

/// Two clusters far apart on x: `near` triangles in the unit cube at the
/// origin, `far` in the one at x = 100. The root's halving plane (x =
/// 50.5) parts them, so the root's left child holds exactly `near`.
fn two_clusters(near: usize, far: usize) -> Scene {
    use cellbih::scene::Triangle;
    use glam::Vec3;
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut r = move || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut tri = |x: f32| {
        let c = Vec3::new(x + r(), r(), r());
        let mut v = || c + 0.01 * Vec3::new(r(), r(), r());
        Triangle::new(v(), v(), v())
    };
    let mut t: Vec<Triangle> = (0..near).map(|_| tri(0.0)).collect();
    t.extend((0..far).map(|_| tri(100.0)));
    Scene::from_triangles("two clusters", t).unwrap()
}

/// `--finish local` at its budget: a job of exactly the most triangles an
/// SPE's local store can finish (`subtree_limit`) is finished there whole;
/// one triangle more and it is split level by level first, its children
/// finished there. Either way the baseline's tree.
#[test]
fn a_job_at_the_local_store_budget_finishes_there_and_one_more_streams() {
    for b in finishing() {
        let mut knobs = Knobs::default();
        b.set_knob(&mut knobs, "finish", "local").unwrap();
        let cell = CellConfig::ps3().with_spes(1);
        let build = |s: &Scene| {
            let r = Build::new(b).on(&cell).with_knobs(&knobs).run(s).unwrap();
            let base = Build::new(BuilderKind::SPE_BFS).run(s).unwrap();
            same_tree_structure(&base.bih, &r.bih).unwrap_or_else(|e| panic!("{b}: {e}"));
            r.simulated.unwrap().spe_work[0]
        };
        let limit = build(&two_clusters(2000, 100)).subtree_limit as usize;
        assert!(
            limit > 100,
            "{b}: a local store that finishes {limit} triangles"
        );
        // The root streams; its children (the two clusters) are finished
        // in the local store, one at exactly the limit.
        let at = build(&two_clusters(limit, 100));
        assert_eq!(at.subtrees, 2, "{b} at the limit {limit}: {at:?}");
        // One more: the near cluster splits by streaming, then each part.
        let over = build(&two_clusters(limit + 1, 100));
        assert!(
            over.subtrees >= 3,
            "{b} one over the limit {limit}: {over:?}"
        );
    }
}

/// The shared queue finishes in a local store no job larger than an SPE's
/// share of the triangles (one SPE would build it while the others have
/// nothing left to take), and still finishes the smaller ones there; the
/// tree is the baseline's.
#[test]
fn the_shared_queue_finishes_no_subtree_over_an_spes_share() {
    let s = scene::load("rtperf:4000:2", None).unwrap();
    let base = Build::new(BuilderKind::SPE_BFS).run(&s).unwrap();
    let shared = (finishing().into_iter()).filter(|b| b.knob("agglomerate").is_ok());
    let mut checked = 0;
    for b in shared {
        let mut knobs = Knobs::default();
        b.set_knob(&mut knobs, "finish", "local").unwrap();
        b.set_knob(&mut knobs, "tris-per-spe", "1").unwrap();
        let cell = CellConfig::ps3().with_spes(8);
        let r = Build::new(b).on(&cell).with_knobs(&knobs).run(&s).unwrap();
        same_tree_structure(&base.bih, &r.bih).unwrap_or_else(|e| panic!("{b}: {e}"));
        let work = r.simulated.unwrap().spe_work;
        assert_eq!(work.len(), 8, "{b}");
        let share = s.len().div_ceil(8) as u64;
        assert!(
            work.iter().all(|w| w.subtree_limit == share),
            "{b}: limits {:?}, share {share}",
            work.iter().map(|w| w.subtree_limit).collect::<Vec<_>>()
        );
        let subtrees: u64 = work.iter().map(|w| w.subtrees).sum();
        assert!(subtrees >= 8, "{b}: {subtrees} subtrees");
        checked += 1;
    }
    assert!(checked > 0, "no shared-queue builder takes --finish");
}

/// A breadth-first run's phases split each SPE's run: the top levels
/// (the same whatever the finish), then the subtrees finished in the
/// local store (none when every job streams) within what is left, each
/// with its DMA wait and bytes within the phase's own.
#[test]
fn the_phases_of_a_breadth_first_run_split_each_spes_run() {
    let s = scene::load("rtperf:4000:2", None).unwrap();
    let mut checked = 0;
    for b in finishing() {
        let run = |finish: &str| {
            let mut knobs = Knobs::default();
            b.set_knob(&mut knobs, "finish", finish).unwrap();
            b.set_knob(&mut knobs, "tris-per-spe", "1").unwrap();
            let cell = CellConfig::ps3().with_spes(4);
            let r = Build::new(b).on(&cell).with_knobs(&knobs).run(&s).unwrap();
            r.simulated.unwrap()
        };
        let (local, stream) = (run("local"), run("stream"));
        for (i, (l, st)) in local.spe_work.iter().zip(&stream.spe_work).enumerate() {
            assert!(l.top.cycles > 0 && l.top.bytes > 0, "{b} SPE {i}: {l:?}");
            assert_eq!(l.top, st.top, "{b} SPE {i}: the top differs by finish");
            assert_eq!(st.in_subtrees, Default::default(), "{b} SPE {i}");
            assert_eq!(l.subtrees > 0, l.in_subtrees.cycles > 0, "{b} SPE {i}");
            let core = &local.run.cores[i + 1].1;
            let end = local.run.cycles.0 - core.idle.0;
            assert!(l.top.cycles + l.in_subtrees.cycles <= end, "{b} SPE {i}");
            assert!(l.top.dma_wait + l.in_subtrees.dma_wait <= core.dma_wait.0);
            let bytes = core.bytes_get + core.bytes_put;
            assert!(l.top.bytes + l.in_subtrees.bytes <= bytes, "{b} SPE {i}");
            for p in [l.top, l.in_subtrees] {
                assert!(p.dma_wait <= p.cycles, "{b} SPE {i}: {p:?}");
            }
        }
        let subtrees: u64 = local.spe_work.iter().map(|w| w.subtrees).sum();
        assert!(subtrees > 0, "{b}: no subtree finished locally");
        checked += 1;
    }
    assert!(checked > 0, "no multi-SPE builder takes --finish");
}
