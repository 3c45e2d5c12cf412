//! Ray casting on the emulated Cell (`cellbih::cast`): the SPE
//! caster answers as the host tracer does, ray for ray and bit for bit,
//! for every builder's tree, at the numerical extremes of the property
//! scenes, with any cache shape, tile size and SPE count; its time is
//! simulated and deterministic, and the cache and the SPEs behave as a
//! software cache and a shared tile counter should.

mod common;

use cellbih::bih::{BihConfig, Hit, Ray, RayStats, Tracer};
use cellbih::cast::{
    CacheConfig, CastConfig, CastReport, Packet, Precision, RecordOrder, cast_camera, cast_on_cell,
};
use cellbih::cell::{CellConfig, CostModel};
use cellbih::kernels::rates::Code;
use cellbih::registry::{Build, BuilderKind};
use cellbih::render::Camera;
use cellbih::scene::{self, Scene};
use common::{check_ray, rays_for, same_hit as same, scene_strategy};
use proptest::prelude::*;

fn cast(
    scene: &Scene,
    bih: &cellbih::bih::Bih,
    rays: &[Ray],
    cfg: &CastConfig,
    spes: usize,
) -> CastReport {
    let cell = CellConfig::ps3().with_spes(spes);
    cast_on_cell(bih, scene, rays, cfg, &cell, RecordOrder::LeafOrder).expect("the cast runs")
}

/// The default scene and `b`'s tree of it (the paper's settings).
fn default_scene_tree(b: BuilderKind) -> (Scene, cellbih::registry::BuildReport) {
    let s = scene::load("default", None).unwrap();
    let r = Build::new(b).run(&s).unwrap();
    (s, r)
}

/// The default cast with this cache shape and rays in flight, ray by ray
/// (the cache's knobs measured on the single-ray walk; packets have their
/// own tests below, and any tile size fits single rays).
fn shaped(kib: u32, ways: u32, fetch_lines: u32, rays_in_flight: u32) -> CastConfig {
    CastConfig {
        cache: CacheConfig {
            kib,
            ways,
            fetch_lines,
        },
        rays_in_flight,
        packet: Packet::SINGLE,
        ..CastConfig::DEFAULT
    }
}

/// The host tracer's answers.
fn host(scene: &Scene, bih: &cellbih::bih::Bih, rays: &[Ray]) -> Vec<Option<Hit>> {
    let t = Tracer::new(bih, scene);
    rays.iter()
        .map(|r| t.closest(r, &mut RayStats::default()))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    /// Every builder's tree of a property scene (scales 1e-15 to 1e15,
    /// flat, degenerate, stacks, clusters far from the rest): the SPEs'
    /// hits are the host tracer's, which agree with brute force; with a
    /// random cache shape, tile size, rays in flight and SPE count (up to
    /// 16, the what-if beyond a Cell).
    #[test]
    fn the_spes_answer_as_the_host_tracer_and_brute_force(
        scene in scene_strategy(),
        kib in 1u32..=8,
        ways in prop_oneof![Just(1u32), Just(2), Just(4)],
        fetch_lines in 1u32..=4,
        tile_rays in 1u32..=16,
        spes in 1usize..=16,
        rays_in_flight in 1u32..=6,
    ) {
        // At most as many lines a miss as a way has sets.
        let sets = kib * 1024 / 128 / ways;
        let fetch_lines = 1 + (fetch_lines - 1) % sets;
        let cfg = CastConfig { tile_rays, ..shaped(kib, ways, fetch_lines, rays_in_flight) };
        let rays = rays_for(&scene, 40, scene.len() as u64 + 7);
        for &b in BuilderKind::ALL {
            let r = Build::new(b).run(&scene)
                .map_err(|e| TestCaseError::fail(format!("{b}: {e}")))?;
            let want = host(&scene, &r.bih, &rays);
            let got = cast(&scene, &r.bih, &rays, &cfg, spes);
            let tracer = Tracer::new(&r.bih, &scene);
            for (i, ray) in rays.iter().enumerate() {
                prop_assert!(same(&got.hits[i], &want[i]),
                    "{b}: ray {i}: SPEs {:?}, host {:?}", got.hits[i], want[i]);
                check_ray(&scene, &tracer, ray).map_err(|e| TestCaseError::fail(format!("{b}: {e}")))?;
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Packets of any shape, every builder's tree of a property scene (the
    /// extremes as above): a camera's rays cast in packets give the host
    /// tracer's hits and each ray the single-ray caster's cost (nodes and
    /// triangles: each ray is active exactly where its own walk goes);
    /// incoherent rays in packets (most cast ray by ray) the same hits.
    #[test]
    fn packets_answer_as_single_rays(
        scene in scene_strategy(),
        w in 1u32..=4,
        h in 1u32..=4,
        per_tile in 1u32..=3,
        rays_in_flight in 1u32..=3,
        spes in 1usize..=6,
    ) {
        let packet = Packet { w, h };
        let cfg = CastConfig { tile_rays: w * h * per_tile, packet, rays_in_flight, ..CastConfig::DEFAULT };
        let single = CastConfig { packet: Packet::SINGLE, ..cfg };
        let cam = Camera::framing(&scene.bounds(), 10, 7);
        let cell = CellConfig::ps3().with_spes(spes);
        let loose = rays_for(&scene, 24, scene.len() as u64 + 3);
        for &b in BuilderKind::ALL {
            let r = Build::new(b).run(&scene)
                .map_err(|e| TestCaseError::fail(format!("{b}: {e}")))?;
            let order = r.record_order();
            let want = host(&scene, &r.bih, &cam.rays());
            let got = cast_camera(&r.bih, &scene, &cam, &cfg, &cell, order).unwrap();
            let one = cast_camera(&r.bih, &scene, &cam, &single, &cell, order).unwrap();
            for (i, (g, w)) in got.hits.iter().zip(&want).enumerate() {
                prop_assert!(same(g, w), "{b}, {packet}: pixel {i}: SPEs {g:?}, host {w:?}");
            }
            prop_assert_eq!(&got.costs, &one.costs, "{}, {}", b, packet);
            prop_assert_eq!(got.stats(), one.stats());
            let want = host(&scene, &r.bih, &loose);
            let got = cast_on_cell(&r.bih, &scene, &loose, &cfg, &cell, order).unwrap();
            for (i, (g, w)) in got.hits.iter().zip(&want).enumerate() {
                prop_assert!(same(g, w), "{b}, {packet}: ray {i}");
            }
        }
    }
}

/// 4 × 4 packets on the default scene's camera rays: one node read a
/// packet instead of one a ray — fewer cache lookups and fewer cycles than
/// single rays, the same hits and the same cost per ray. The framing
/// camera's rays change sign across the image, so some packets are cast
/// ray by ray; 8 × 8 packets, with more rays a node, are fewer still.
#[test]
fn packets_read_each_node_once_for_their_rays() {
    let (s, r) = default_scene_tree(BuilderKind::HOST);
    let cam = Camera::framing(&s.bounds(), 64, 48);
    let cell = CellConfig::ps3();
    let with = |w, h| {
        let cfg = CastConfig {
            packet: Packet { w, h },
            ..CastConfig::DEFAULT
        };
        cast_camera(&r.bih, &s, &cam, &cfg, &cell, RecordOrder::LeafOrder).unwrap()
    };
    let (one, four, eight) = (with(1, 1), with(4, 4), with(8, 8));
    let packets = |c: &CastReport| c.spes.iter().map(|w| w.packets).sum::<u64>();
    assert_eq!(packets(&one), 0);
    let pixels = 64 * 48;
    assert!(packets(&four) > 0 && packets(&four) < pixels / 16);
    assert!(packets(&eight) > 0 && packets(&eight) < packets(&four));
    for c in [&four, &eight] {
        assert!(one.hits.iter().zip(&c.hits).all(|(a, b)| same(a, b)));
        assert_eq!(c.costs, one.costs);
    }
    assert!(four.cache().lookups < one.cache().lookups / 2);
    assert!(four.run.cycles < one.run.cycles);
    // Packets that do not fill a tile are refused, naming both.
    let bad = CastConfig {
        packet: Packet { w: 4, h: 4 },
        tile_rays: 24,
        ..CastConfig::DEFAULT
    };
    let e = cast_camera(&r.bih, &s, &cam, &bad, &cell, RecordOrder::LeafOrder).unwrap_err();
    assert!(
        e.to_string().contains("4x4") && e.to_string().contains("24"),
        "{e}"
    );
    assert_eq!(Packet::parse("2x8"), Ok(Packet { w: 2, h: 8 }));
    for wrong in ["0x4", "9x1", "4", "4x", "ax2"] {
        assert!(Packet::parse(wrong).is_err(), "{wrong}");
    }
}

/// The default scene's camera rays and incoherent rays, every builder's
/// tree and every quality knob it builds: the same hits on the SPEs as on
/// the host.
#[test]
fn every_builders_tree_is_cast_as_the_host_casts_it() {
    let s = scene::load("default", None).unwrap();
    let mut rays = Camera::framing(&s.bounds(), 40, 30).rays();
    rays.extend(rays_for(&s, 300, 3));
    for &b in BuilderKind::ALL {
        for cfg in [BihConfig::default(), BihConfig::SAH_CUT] {
            if !b.builds(&cfg) {
                continue;
            }
            let r = Build::new(b).with_tree(cfg).run(&s).unwrap();
            let want = host(&s, &r.bih, &rays);
            let got = cast(&s, &r.bih, &rays, &CastConfig::DEFAULT, 6);
            let differ = (got.hits.iter().zip(&want))
                .filter(|(g, w)| !same(g, w))
                .count();
            assert_eq!(differ, 0, "{b} {cfg:?}: {differ} rays differ");
            assert!(
                want.iter().flatten().count() > 300,
                "{b}: the rays hit the scene"
            );
            let st = got.stats();
            assert_eq!(st.rays, rays.len() as u64);
            let costs: u64 = got.costs.iter().map(|&c| c as u64).sum();
            assert_eq!(costs, st.nodes_visited + st.triangles_tested);
        }
    }
}

/// The same input gives the same cycles; the hits do not depend on the
/// SPE count, the tile size or the cache; six SPEs cast the frame at least
/// 3x faster than one, every SPE takes tiles, and a miss costs a get.
#[test]
fn the_cast_is_deterministic_and_spreads_over_the_spes() {
    let (s, r) = default_scene_tree(BuilderKind::SPE_BFS);
    let rays = Camera::framing(&s.bounds(), 96, 72).rays();
    let d = CastConfig::DEFAULT;
    let one = cast(&s, &r.bih, &rays, &d, 1);
    let six = cast(&s, &r.bih, &rays, &d, 6);
    let again = cast(&s, &r.bih, &rays, &d, 6);
    assert_eq!(six.run.cycles, again.run.cycles);
    assert_eq!(six.spes, again.spes);
    assert!(one.hits.iter().zip(&six.hits).all(|(a, b)| same(a, b)));
    assert!(
        one.run.ms > 3.0 * six.run.ms,
        "1 SPE {} ms, 6 SPEs {} ms",
        one.run.ms,
        six.run.ms
    );
    assert!(six.spes.iter().all(|w| w.tiles > 0), "{:?}", six.spes);
    let tiles: u64 = six.spes.iter().map(|w| w.tiles).sum();
    assert_eq!(tiles, (rays.len() as u64).div_ceil(d.tile_rays as u64));
    // Every miss is one get of a line; the tiles' rays one get each.
    let gets: u64 = six.run.cores[1..].iter().map(|(_, c)| c.gets).sum();
    assert_eq!(gets, six.cache().misses + tiles);
    assert!(
        six.cache().hit_rate() > 0.5 && six.cache().misses > 0,
        "{:?}",
        six.cache()
    );
    assert!(six.rays_per_s().unwrap() > one.rays_per_s().unwrap() * 3.0);
}

/// The cache's knobs do what they say: a larger cache misses less than a
/// tiny one, fetching 16 lines a miss takes fewer gets than one, and
/// neither changes a hit.
#[test]
fn a_larger_cache_and_longer_fetches_miss_less() {
    let (s, r) = default_scene_tree(BuilderKind::HOST);
    let rays = Camera::framing(&s.bounds(), 64, 48).rays();
    let with = |kib, ways, fetch_lines| shaped(kib, ways, fetch_lines, 1);
    let tiny = cast(&s, &r.bih, &rays, &with(1, 2, 1), 6);
    let big = cast(&s, &r.bih, &rays, &with(128, 4, 1), 6);
    let long = cast(&s, &r.bih, &rays, &with(32, 4, 16), 6);
    let single = CastConfig {
        packet: Packet::SINGLE,
        ..CastConfig::DEFAULT
    };
    let sdk = cast(&s, &r.bih, &rays, &single, 6);
    assert!(
        big.cache().misses < tiny.cache().misses / 2,
        "{:?} vs {:?}",
        big.cache(),
        tiny.cache()
    );
    assert!(
        long.cache().misses < sdk.cache().misses,
        "{:?} vs {:?}",
        long.cache(),
        sdk.cache()
    );
    for other in [&big, &long, &sdk] {
        assert!(tiny.hits.iter().zip(&other.hits).all(|(a, b)| same(a, b)));
        // The lookups are the tracer's reads: the same whatever the cache.
        assert_eq!(other.cache().lookups, tiny.cache().lookups);
    }
}

/// The functional mode casts the same hits and says it kept no time;
/// a tile or a cache that cannot be is an error that says why.
#[test]
fn functional_mode_and_bad_shapes() {
    let (s, r) = default_scene_tree(BuilderKind::HOST);
    let rays = rays_for(&s, 200, 1);
    let mut cell = CellConfig::ps3();
    cell.cost = CostModel::functional();
    let f = cast_on_cell(
        &r.bih,
        &s,
        &rays,
        &CastConfig::DEFAULT,
        &cell,
        r.record_order(),
    )
    .unwrap();
    assert!(!f.run.timed && f.rays_per_s().is_none());
    let want = host(&s, &r.bih, &rays);
    assert!(f.hits.iter().zip(&want).all(|(a, b)| same(a, b)));
    let bad = |cfg: CastConfig| {
        cast_on_cell(
            &r.bih,
            &s,
            &rays,
            &cfg,
            &CellConfig::ps3(),
            r.record_order(),
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
    };
    let d = CastConfig::DEFAULT;
    assert!(bad(CastConfig { tile_rays: 0, ..d }).contains("rays a tile"));
    assert!(
        bad(CastConfig {
            tile_rays: 257,
            ..d
        })
        .contains("rays a tile")
    );
    let shape = CacheConfig {
        kib: 1,
        ways: 16,
        fetch_lines: 1,
    };
    assert!(bad(CastConfig { cache: shape, ..d }).contains("whole sets"));
    let shape = CacheConfig {
        kib: 4,
        ways: 4,
        fetch_lines: 9,
    };
    assert!(bad(CastConfig { cache: shape, ..d }).contains("fetching 9 lines"));
    for k in [0, 17] {
        let e = bad(CastConfig {
            rays_in_flight: k,
            ..d
        });
        assert!(e.contains(&format!("{k} rays in flight")), "{e}");
    }
    // No ray at all: nothing to cast, nothing fails.
    let none = cast_on_cell(&r.bih, &s, &[], &d, &CellConfig::ps3(), r.record_order()).unwrap();
    assert!(none.hits.is_empty());
}

/// Charging the SPEs for double-precision arithmetic (what the emulation
/// computes) instead of single-precision SIMD changes the time, by the
/// rates' ratio at most, and never a hit.
#[test]
fn the_precision_charged_changes_the_time_not_the_hits() {
    let (s, r) = default_scene_tree(BuilderKind::HOST);
    let rays = Camera::framing(&s.bounds(), 48, 36).rays();
    let single = cast(&s, &r.bih, &rays, &CastConfig::DEFAULT, 6);
    let cfg = CastConfig {
        precision: Precision::Double,
        ..CastConfig::DEFAULT
    };
    let double = cast(&s, &r.bih, &rays, &cfg, 6);
    assert!(
        single
            .hits
            .iter()
            .zip(&double.hits)
            .all(|(a, b)| same(a, b))
    );
    assert_eq!(single.stats(), double.stats());
    let (sr, dr) = (
        Precision::Single.rates(Code::Paper),
        Precision::Double.rates(Code::Paper),
    );
    let worst = (dr.ray_setup.0 / sr.ray_setup.0)
        .max(dr.node_step.0 / sr.node_step.0)
        .max(dr.triangle_test.0 / sr.triangle_test.0);
    let ratio = double.run.ms / single.run.ms;
    assert!(ratio > 3.0 && ratio <= worst as f64, "{ratio}");
}

/// Rays in flight (software hyperthreading): with a cache that misses
/// often, keeping 2 or 4 rays in flight hides the misses — less time
/// waiting for DMA and a faster frame, though each switch costs — and
/// never changes a hit; one ray in flight never switches. With a tiny
/// cache whose every set is soon in use by the rays in flight, rays wait
/// for a way and still answer the same.
#[test]
fn rays_in_flight_hide_the_misses_and_keep_the_hits() {
    let (s, r) = default_scene_tree(BuilderKind::HOST);
    let rays = Camera::framing(&s.bounds(), 64, 48).rays();
    let with = shaped;
    let one = cast(&s, &r.bih, &rays, &with(4, 2, 1, 1), 6);
    let switches = |c: &CastReport| c.spes.iter().map(|w| w.switches).sum::<u64>();
    assert_eq!(switches(&one), 0);
    for k in [2, 4] {
        let many = cast(&s, &r.bih, &rays, &with(4, 2, 1, k), 6);
        assert!(one.hits.iter().zip(&many.hits).all(|(a, b)| same(a, b)));
        assert!(switches(&many) > 0);
        assert!(
            many.shares().dma_wait < one.shares().dma_wait / 2.0,
            "{k} in flight: DMA wait {:.3} vs {:.3}",
            many.shares().dma_wait,
            one.shares().dma_wait
        );
        assert!(
            many.run.cycles < one.run.cycles,
            "{k} in flight: {} vs {} cycles",
            many.run.cycles.0,
            one.run.cycles.0
        );
        assert_eq!(many.stats(), one.stats());
    }
    // 16 rays in flight through one set of 8 ways, and through 8 sets of
    // one way with 4 lines a miss: rays wait for a way, and still answer.
    let cramped = cast(&s, &r.bih, &rays, &with(1, 8, 1, 16), 2);
    assert!(one.hits.iter().zip(&cramped.hits).all(|(a, b)| same(a, b)));
    let sixteen = cast(&s, &r.bih, &rays, &with(1, 1, 4, 16), 3);
    assert!(one.hits.iter().zip(&sixteen.hits).all(|(a, b)| same(a, b)));
}

/// A tree whose build left the records in the scene's order with a column
/// of ids (`spe_morton`) is cast through that column: the same hits as
/// the host tracer, and the ids' reads are paid — more cache lookups and
/// more cycles than the same tree with its records in leaf order.
#[test]
fn records_left_in_the_scenes_order_are_read_through_their_ids() {
    let morton = BuilderKind::ALL
        .iter()
        .copied()
        .find(|b| b.name() == "spe_morton")
        .expect("the Morton builder");
    let (s, r) = default_scene_tree(morton);
    assert_eq!(r.record_order(), RecordOrder::InputWithIds);
    let (_, bfs) = default_scene_tree(BuilderKind::SPE_BFS);
    assert_eq!(bfs.record_order(), RecordOrder::LeafOrder);
    let rays = rays_for(&s, 300, 4);
    let cast = |order| {
        cast_on_cell(
            &r.bih,
            &s,
            &rays,
            &CastConfig::DEFAULT,
            &CellConfig::ps3(),
            order,
        )
        .unwrap()
    };
    let (ids, leaf) = (
        cast(RecordOrder::InputWithIds),
        cast(RecordOrder::LeafOrder),
    );
    let want = host(&s, &r.bih, &rays);
    assert!(ids.hits.iter().zip(&want).all(|(a, b)| same(a, b)));
    assert!(leaf.hits.iter().zip(&want).all(|(a, b)| same(a, b)));
    let tests: u64 = leaf.spes.iter().map(|c| c.rays.triangles_tested).sum();
    assert!(tests > 0);
    // One more read a triangle tested: its id (a record straddles two
    // lines in either order a quarter of the time).
    assert!(ids.cache().lookups > leaf.cache().lookups + tests / 2);
    assert!(ids.run.cycles > leaf.run.cycles);
}
