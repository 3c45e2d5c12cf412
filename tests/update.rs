//! Moving objects and the paper's animations.

use cellbih::scene;
use cellbih::update::{Animation, Move, apply};
use glam::{Affine3A, Vec3};

#[test]
fn a_move_transforms_its_geometry_and_nothing_else() {
    let s = scene::load("car", None).unwrap();
    let by = Vec3::new(0.5, 0.0, 0.0);
    let moved = apply(&s, &[Move::translate(3, by)]).unwrap();
    let mut changed = 0;
    for ((a, b), &g) in s
        .triangles
        .iter()
        .zip(&moved.triangles)
        .zip(&s.geometry_ids)
    {
        if g == 3 {
            changed += 1;
            for k in 0..3 {
                assert!((b.v[k] - a.v[k] - by).length() < 1e-5);
            }
        } else {
            assert_eq!(a, b);
        }
    }
    assert!(changed > 0);
    assert_eq!(moved.geometry_ids, s.geometry_ids);
}

#[test]
fn a_marked_move_changes_nothing() {
    let s = scene::load("cup", None).unwrap();
    let moved = apply(&s, &[Move::marked(0)]).unwrap();
    assert_eq!(moved.triangles, s.triangles);
    assert_eq!(moved.bounds(), s.bounds());
}

#[test]
fn bad_moves_are_errors() {
    let s = scene::load("cup", None).unwrap();
    let e = apply(&s, &[Move::translate(7, Vec3::ONE)])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("geometry id 7") && e.contains("1 geometries"),
        "{e}"
    );
    let blow_up = Move {
        geometry: 0,
        transform: Affine3A::from_scale(Vec3::splat(f32::MAX)),
    };
    let e = apply(&s, &[blow_up]).unwrap_err().to_string();
    assert!(e.contains("non-finite"), "{e}");
}

#[test]
fn animations_are_deterministic_and_move_like_the_papers() {
    let rt = scene::load("rtperf:10000:1", None).unwrap();
    let a = Animation::named("rtperf", &rt, 20, 7).unwrap();
    let b = Animation::named("rtperf", &rt, 20, 7).unwrap();
    assert_eq!(a.frames, b.frames);
    assert_ne!(
        a.frames,
        Animation::named("rtperf", &rt, 20, 8).unwrap().frames
    );
    assert_eq!(a.frames.len(), 20);
    // One sphere per frame at every size; every fifth frame marked only.
    assert!(a.frames.iter().all(|f| f.len() == 1));
    let big = scene::load("rtperf:100000:1", None).unwrap();
    let c = Animation::named("rtperf", &big, 20, 7).unwrap();
    assert!(c.frames.iter().all(|f| f.len() == 1));
    assert!(a.frames[4].iter().all(Move::is_identity));
    assert!(!a.frames[0].iter().all(Move::is_identity));

    // cupVis: every real move changes the scene box.
    let cup = scene::load("cup", None).unwrap();
    let anim = Animation::named("cup", &cup, 30, 0).unwrap();
    let mut s = cup.clone();
    let (mut real, mut marked) = (0, 0);
    for f in &anim.frames {
        let next = apply(&s, f).unwrap();
        if f.iter().all(Move::is_identity) {
            marked += 1;
            assert_eq!(next.bounds(), s.bounds());
        } else {
            real += 1;
            assert_ne!(next.bounds(), s.bounds());
        }
        s = next;
    }
    assert_eq!((real, marked), (29, 1));

    // carVis: a part out and back returns the scene (within rounding).
    let car = scene::load("car", None).unwrap();
    let anim = Animation::named("car", &car, 2, 0).unwrap();
    let there = apply(&car, &anim.frames[0]).unwrap();
    assert_ne!(there.triangles, car.triangles);
    let back = apply(&there, &anim.frames[1]).unwrap();
    for (a, b) in car.triangles.iter().zip(&back.triangles) {
        for k in 0..3 {
            assert!((a.v[k] - b.v[k]).length() < 1e-5);
        }
    }
    assert!(Animation::named("walk", &car, 2, 0).is_err());
}

// ---------------------------------------------------------------------------
// Algorithm 1 and the deeper update.

mod common;

use cellbih::bih::{BihConfig, SplitChoice, Tracer};
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{Scene, SplitMix64, Triangle};
use cellbih::update::{Method, Stop, Updater};
use common::{check_ray, rays_for};
use proptest::prelude::*;

/// `objects` clusters of 1 to 24 triangles each, one geometry id per
/// cluster, at a scale of `10^exp`.
fn cluster_scene(objects: usize, exp: i32, seed: u64) -> Scene {
    let mut rng = SplitMix64::new(seed);
    let s = 10f32.powi(exp);
    let (mut tris, mut ids, mut names) = (Vec::new(), Vec::new(), Vec::new());
    for g in 0..objects {
        let c = Vec3::new(
            rng.range(0.0, 100.0),
            rng.range(0.0, 100.0),
            rng.range(0.0, 100.0),
        );
        let size = rng.range(0.1, 4.0);
        for _ in 0..1 + rng.next_u64() % 24 {
            let mut p = || {
                (c + Vec3::new(
                    rng.range(-size, size),
                    rng.range(-size, size),
                    rng.range(-size, size),
                )) * s
            };
            tris.push(Triangle::new(p(), p(), p()));
            ids.push(g as u32);
        }
        names.push(format!("object{g}"));
    }
    Scene::new(format!("clusters:{objects}:{exp}:{seed}"), tris, ids, names).unwrap()
}

/// A frame of moves: each one small, far (out of the scene box), or marked.
fn frame(rng: &mut SplitMix64, objects: usize, scale: f32) -> Vec<Move> {
    (0..rng.next_u64() % 4)
        .map(|_| {
            let g = (rng.next_u64() % objects as u64) as u32;
            match rng.next_u64() % 6 {
                0 => Move::marked(g),
                1 => Move::translate(g, Vec3::new(rng.range(-150.0, 150.0), 0.0, 0.0) * scale),
                _ => Move::translate(
                    g,
                    Vec3::new(
                        rng.range(-3.0, 3.0),
                        rng.range(-3.0, 3.0),
                        rng.range(-3.0, 3.0),
                    ) * scale,
                ),
            }
        })
        .collect()
}

/// The updated tree is valid for the moved scene and answers every ray as
/// brute force does.
fn check(u: &Updater, what: &str) -> Result<(), TestCaseError> {
    u.bih
        .validate(&u.scene)
        .map_err(|v| TestCaseError::fail(format!("{what}: {v}")))?;
    let tracer = Tracer::new(&u.bih, &u.scene);
    for ray in rays_for(&u.scene, 48, u.scene.len() as u64) {
        check_ray(&u.scene, &tracer, &ray)
            .map_err(|e| TestCaseError::fail(format!("{what}: {e}")))?;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn updates_keep_the_tree_valid_and_equal_to_brute_force(
        objects in 1usize..40,
        exp in prop::sample::select(vec![-15i32, 0, 15]),
        leaf in 1u32..13,
        seed in any::<u64>(),
        sah in any::<bool>(),
        empty_cut in proptest::option::of(1u32..=99),
    ) {
        let scene = cluster_scene(objects, exp, seed);
        // The quality knobs too: an update rebuilds with the tree's own.
        let split = if sah { SplitChoice::BinnedSah { bins: 8, above: 0 } } else { SplitChoice::GlobalHeuristic };
        let cfg = BihConfig { leaf_size: leaf, split, empty_cut, ..BihConfig::default() };
        let scale = 10f32.powi(exp);
        for &method in Method::ALL {
            let mut u = Updater::new(scene.clone(), Build::new(BuilderKind::HOST).with_tree(cfg), method).unwrap();
            u.deep_stop_below = (seed % 3) as usize * 8;
            let mut rng = SplitMix64::new(seed ^ 0x5eed);
            for f in 0..6 {
                let moves = frame(&mut rng, objects, scale);
                let want = apply(&u.scene, &moves).unwrap();
                let r = u.step(&moves).unwrap();
                prop_assert_eq!(&u.scene.triangles, &want.triangles);
                prop_assert_eq!(u.scene.bounds(), want.bounds());
                prop_assert!(r.rebuilt <= scene.len());
                check(&u, &format!("{} frame {f}: {moves:?}", method.name()))?;
            }
        }
    }
}

#[test]
fn an_empty_update_changes_nothing_and_a_marked_one_keeps_the_answers() {
    let scene = cluster_scene(30, 0, 3);
    for &method in Method::ALL {
        let mut u = Updater::new(scene.clone(), Build::new(BuilderKind::HOST), method).unwrap();
        let before = u.bih.clone();
        let r = u.step(&[]).unwrap();
        assert_eq!(u.bih, before);
        assert_eq!((r.rebuilt, r.transformed, r.full_rebuild), (0, 0, false));
        // Marked only: the triangles stay; the tree may be rebuilt but
        // answers as before.
        let r = u.step(&[Move::marked(4)]).unwrap();
        assert_eq!(u.scene.triangles, scene.triangles);
        assert!(r.transformed > 0 && !r.full_rebuild || method == Method::Rebuild);
        check(&u, method.name()).unwrap();
    }
}

#[test]
fn algorithm_1_narrows_to_a_small_interval_and_deep_rebuilds_no_more() {
    // rtPerf of 20,000 triangles, one sphere nudged per frame.
    let scene = cellbih::scene::load("rtperf:20000:3", None).unwrap();
    let anim = Animation::named("rtperf", &scene, 30, 1).unwrap();
    let cfg = BihConfig::default();
    let mut local = Updater::new(
        scene.clone(),
        Build::new(BuilderKind::HOST).with_tree(cfg),
        Method::Local,
    )
    .unwrap();
    let mut deep = Updater::new(
        scene.clone(),
        Build::new(BuilderKind::HOST).with_tree(cfg),
        Method::Deep,
    )
    .unwrap();
    let (mut l_sum, mut d_sum, mut partial) = (0, 0, 0);
    for f in &anim.frames {
        let (l, d) = (local.step(f).unwrap(), deep.step(f).unwrap());
        assert_eq!(l.full_rebuild, d.full_rebuild);
        assert_eq!(l.transformed, d.transformed);
        if !l.full_rebuild {
            partial += 1;
            assert_eq!(l.transformed, 200);
            assert!(l.depth > 0 && l.stop.is_some());
            assert_eq!(l.rebuilt, l.interval);
            assert!(d.rebuilt <= d.interval && d.rebuilt + d.kept == d.interval);
        }
        l_sum += l.rebuilt;
        d_sum += d.rebuilt;
    }
    assert!(partial >= 25, "only {partial} of 30 frames were partial");
    // Every partial update touches a small part of the scene, and the deep
    // update sorts fewer triangles than the paper's.
    assert!(l_sum < 30 * scene.len() / 4, "local rebuilt {l_sum}");
    assert!(d_sum < l_sum, "deep {d_sum} vs local {l_sum}");
    check(&local, "local").unwrap();
    check(&deep, "deep").unwrap();
}

#[test]
fn a_move_that_grows_the_scene_box_rebuilds_everything() {
    let cup = cellbih::scene::load("cup", None).unwrap();
    let mut u = Updater::new(cup, Build::new(BuilderKind::HOST), Method::Local).unwrap();
    let r = u.step(&[Move::translate(0, Vec3::X * 0.05)]).unwrap();
    assert!(r.full_rebuild && r.rebuilt == 7040 && r.stop.is_none());
    // Marked only: the whole glass is the EBB, the root the enclosing node.
    let r = u.step(&[Move::marked(0)]).unwrap();
    assert!(!r.full_rebuild);
    assert_eq!((r.depth, r.rebuilt, r.transformed), (0, 7040, 7040));
    assert_ne!(r.stop, Some(Stop::Leaf));
}

#[test]
fn an_emulated_builder_rebuilds_the_interval_on_the_cell() {
    // ppe_naive builds the same tree as the host builder, so the two
    // updaters must agree node for node; the emulated one also reports
    // simulated time.
    let scene = cellbih::scene::load("car", None).unwrap();
    let anim = Animation::named("car", &scene, 6, 0).unwrap();
    let cfg = BihConfig::default();
    for method in [Method::Local, Method::Deep] {
        let mut host = Updater::new(
            scene.clone(),
            Build::new(BuilderKind::HOST).with_tree(cfg),
            method,
        )
        .unwrap();
        let mut cell = Updater::new(
            scene.clone(),
            Build::new(BuilderKind::PPE_NAIVE).with_tree(cfg),
            method,
        )
        .unwrap();
        for f in &anim.frames {
            let (h, c) = (host.step(f).unwrap(), cell.step(f).unwrap());
            assert_eq!(h.rebuilt, c.rebuilt);
            assert!(h.simulated_ms.is_none());
            assert!(c.simulated_ms.is_some_and(|ms| ms > 0.0) || c.rebuilt == 0);
            assert_eq!(host.bih, cell.bih);
        }
    }
}

/// `--find-moved spe`: the same trees; the PPE no longer scans the
/// interval, the rebuild's SPEs test every slot of it and replace the moved
/// triangles, charged within the rebuild (on the SPEs the build used).
#[test]
fn the_spes_find_the_moved_triangles_as_the_rebuild_streams_them() {
    use cellbih::update::FindMoved;
    let scene = cellbih::scene::load("rtperf:5000:1", None).unwrap();
    let anim = Animation::named("rtperf", &scene, 4, 3).unwrap();
    let b = Build::new(BuilderKind::from_name("spe_bfs_private").unwrap());
    let mut ppe = Updater::new(scene.clone(), b.clone(), Method::Local).unwrap();
    let mut spe = ppe.clone();
    spe.find_moved = FindMoved::Spe;
    let mut searched = 0;
    for f in &anim.frames {
        let (p, s) = (ppe.step(f).unwrap(), spe.step(f).unwrap());
        assert_eq!(ppe.bih, spe.bih);
        if p.full_rebuild || p.rebuilt == 0 {
            assert_eq!(s.spe_find_ms, 0.0);
            continue;
        }
        searched += 1;
        assert_eq!(p.ppe_find.scanned, p.interval as u64);
        assert_eq!(s.ppe_find.scanned, 0);
        assert_eq!(
            (s.spe_find.slots, s.spe_find.moved),
            (s.interval as u64, s.transformed as u64)
        );
        assert!((1..=6).contains(&s.spe_find.spes));
        assert!(s.spe_find_ms > 0.0 && s.ppe_find_ms < p.ppe_find_ms);
        let build = |r: &cellbih::update::UpdateReport| r.build_ms.unwrap();
        assert!((build(&s) - build(&p) - s.spe_find_ms).abs() < 1e-9);
        assert_eq!(spe.spe_find, Some(s.spe_find));
    }
    assert!(searched > 0, "no frame searched");
}

#[test]
fn a_bad_move_leaves_the_updater_as_it_was() {
    let scene = cluster_scene(10, 0, 9);
    let mut u = Updater::new(scene.clone(), Build::new(BuilderKind::HOST), Method::Local).unwrap();
    let before = u.bih.clone();
    let blow_up = Move {
        geometry: 3,
        transform: Affine3A::from_scale(Vec3::splat(f32::MAX)),
    };
    let e = u
        .step(&[Move::translate(1, Vec3::ONE), blow_up])
        .unwrap_err();
    assert!(e.to_string().contains("non-finite"), "{e}");
    assert!(u.step(&[Move::translate(99, Vec3::ONE)]).is_err());
    assert_eq!(u.scene.triangles, scene.triangles);
    assert_eq!(u.scene.bounds(), scene.bounds());
    assert_eq!(u.bih, before);
}

#[test]
fn a_builder_error_puts_the_scene_back_and_keeps_a_valid_tree() {
    let scene = cluster_scene(20, 0, 11);
    for method in [Method::Local, Method::Deep, Method::Rebuild] {
        let mut u = Updater::new(scene.clone(), Build::new(BuilderKind::SPE_BFS), method).unwrap();
        u.build.cell.spes = 0; // the next emulated build cannot start
        let e = u.step(&[Move::translate(2, Vec3::splat(0.5))]).unwrap_err();
        assert!(e.to_string().contains("SPEs"), "{e}");
        assert_eq!(u.scene.triangles, scene.triangles);
        assert_eq!(u.scene.bounds(), scene.bounds());
        check(&u, method.name()).unwrap();
    }
}

/// The `part` animation plays on any mesh: `Animation::prepare` splits 2 %
/// of its triangles (those nearest one point) off as the `moving part`,
/// leaves every other animation's scene as it is, and every method keeps
/// the tree valid and equal to brute force while the part moves; a plan
/// counts before the update what the local and the deep update then
/// rebuild.
#[test]
fn a_mesh_with_a_moving_part_plays_and_plans_ahead() {
    let s = scene::load("rtperf:4000:3", None).unwrap();
    let same = Animation::prepare("rtperf", s.clone()).unwrap();
    assert_eq!(same.geometry_ids, s.geometry_ids);
    let p = Animation::prepare("part", s.clone()).unwrap();
    assert_eq!(p.triangles, s.triangles);
    let part = p
        .geometry_names
        .iter()
        .position(|n| n == "moving part")
        .unwrap() as u32;
    let members = p.geometry_ids.iter().filter(|&&g| g == part).count();
    assert_eq!(members, s.len() / 50);
    // Without the split the animation has nothing to move, and says how.
    let e = Animation::named("part", &s, 2, 0).unwrap_err();
    assert!(e.contains("Animation::prepare"), "{e}");
    let anim = Animation::named("part", &p, 6, 0).unwrap();
    let mut deep_pieces_seen = 0;
    for &method in Method::ALL {
        let mut u = Updater::new(p.clone(), Build::new(BuilderKind::HOST), method).unwrap();
        for (f, moves) in anim.frames.iter().enumerate() {
            let plan = u.plan(moves).unwrap();
            let before = (u.scene.triangles.clone(), u.bih.nodes.clone());
            // Planning changes nothing.
            let again = u.plan(moves).unwrap();
            assert_eq!(plan, again);
            // The search alone: the same node and interval, no scan and
            // no descent counted.
            let search = u.plan_search(moves).unwrap();
            assert_eq!(
                (search.full_rebuild, search.interval, search.depth),
                (plan.full_rebuild, plan.interval, plan.depth)
            );
            assert!(plan.deep_planned);
            assert_eq!(search.deep_planned, plan.full_rebuild);
            assert!(search.find.scanned == 0 && search.find.routed == 0);
            assert_eq!((u.scene.triangles.clone(), u.bih.nodes.clone()), before);
            let r = u.step(moves).unwrap();
            assert_eq!(plan.transformed, r.transformed, "{method:?} frame {f}");
            if method == Method::Local {
                assert_eq!(plan.full_rebuild, r.full_rebuild);
                assert_eq!(plan.interval, r.rebuilt, "frame {f}");
            }
            if !r.full_rebuild && method != Method::Rebuild {
                // The update's PPE search: Algorithm 1 and the scan of the
                // interval; the deep update's also its descent, as the plan
                // counted it.
                assert_eq!(r.ppe_find.scanned, r.interval as u64);
                assert!(r.ppe_find.nodes_visited > r.depth as u64);
                if method == Method::Deep {
                    assert_eq!(r.ppe_find, plan.find, "frame {f}");
                }
                assert!(r.ppe_apply.ids_copied >= r.rebuilt as u64);
            }
            if method == Method::Deep {
                // The dry descent counts what the update then rebuilds.
                assert_eq!(plan.full_rebuild, r.full_rebuild);
                assert_eq!(plan.deep_rebuilt(), r.rebuilt, "frame {f}");
                assert_eq!(plan.deep_pieces.len(), r.pieces, "frame {f}");
                deep_pieces_seen += plan.deep_pieces.len();
            }
            check(&u, &format!("part, {} frame {f}", method.name())).unwrap();
        }
    }
    assert!(
        deep_pieces_seen > 6,
        "the deep update rebuilt pieces in most frames"
    );
}
