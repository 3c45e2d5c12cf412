//! Property tests of the one tree type and the host builder: every tree is
//! valid, and every ray answers what brute force over all triangles answers.
//! Scenes range over scales 1e-15 … 1e15, flat scenes, duplicates,
//! degenerate triangles, identical stacks and grid-aligned coordinates.

mod common;

use cellbih::bih::{BihConfig, Ray, RayStats, SplitChoice, Tracer};
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{Scene, Triangle};
use cellbih::spe::footprint::{widest_level, work_ppe_jobs};
use common::{check_ray, make_scene, rays_for, scene_strategy};
use glam::{DVec3, Vec3};
use proptest::prelude::*;

fn check_scene(scene: &Scene, cfg: &BihConfig, rays: usize) -> Result<(), TestCaseError> {
    for &b in BuilderKind::ALL {
        let built = Build::new(b).with_tree(*cfg).run(scene);
        if !b.builds(cfg) {
            // A builder refuses the knobs it does not build, by name.
            let e = built.err().map(|e| e.to_string()).unwrap_or_default();
            prop_assert!(e.contains("global heuristic"), "{b}: {e}");
            continue;
        }
        let r = built.map_err(|e| TestCaseError::fail(format!("{b}: {e}")))?;
        // The widest level within the bound WorkAPPE is sized by.
        let widest = widest_level(&r.bih);
        prop_assert!(
            widest <= work_ppe_jobs(scene.len(), cfg.leaf_size) as u64,
            "{}: {}",
            b,
            widest
        );
        r.bih
            .validate(scene)
            .map_err(|v| TestCaseError::fail(format!("{b}: {v}")))?;
        // The AVX2 build of the traversal (where the CPU has it) and the
        // portable one.
        let tracers = [
            Tracer::new(&r.bih, scene),
            Tracer::new(&r.bih, scene).portable(),
        ];
        for ray in rays_for(scene, rays, scene.len() as u64) {
            for tracer in &tracers {
                check_ray(scene, tracer, &ray)
                    .map_err(|e| TestCaseError::fail(format!("{b}: {e}")))?;
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn trees_are_valid_and_agree_with_brute_force(scene in scene_strategy(), leaf in 1u32..14) {
        check_scene(&scene, &BihConfig { leaf_size: leaf, ..BihConfig::default() }, 64)?;
    }

    /// The quality knobs (binned SAH, the empty-space cut-off, leaf sizes
    /// 1 to 16, shallow limits) at every scale of the scene strategy.
    #[test]
    fn quality_knobs_give_valid_trees_that_agree_with_brute_force(
        scene in scene_strategy(),
        leaf in 1u32..=16,
        max_depth in prop_oneof![Just(64u32), 0u32..8],
        sah in proptest::option::of((2u32..=32, prop_oneof![Just(0u32), 1u32..64])),
        empty_cut in proptest::option::of(1u32..=99),
    ) {
        let split = match sah {
            Some((bins, above)) => SplitChoice::BinnedSah { bins, above },
            None => SplitChoice::GlobalHeuristic,
        };
        check_scene(&scene, &BihConfig { leaf_size: leaf, max_depth, split, empty_cut }, 48)?;
    }

    #[test]
    fn a_shallow_depth_limit_gives_valid_trees(scene in scene_strategy(), depth in 0u32..4) {
        check_scene(&scene, &BihConfig { leaf_size: 1, max_depth: depth, ..BihConfig::default() }, 16)?;
    }
}

#[test]
fn large_random_scenes_at_every_scale() {
    for (exp, kind) in [
        (-15, 0),
        (0, 0),
        (15, 0),
        (0, 1),
        (0, 3),
        (0, 5),
        (15, 5),
        (-15, 2),
    ] {
        let scene = make_scene(3000, exp, 1, kind, 7);
        check_scene(&scene, &BihConfig::default(), 400).unwrap();
        let best = BihConfig::SAH_CUT;
        check_scene(&scene, &best, 400).unwrap();
    }
}

#[test]
fn one_triangle() {
    let s =
        Scene::from_triangles("one", vec![Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)]).unwrap();
    let r = Build::new(BuilderKind::HOST).run(&s).unwrap();
    r.bih.validate(&s).unwrap();
    assert_eq!(r.bih.nodes.len(), 1);
    let tracer = Tracer::new(&r.bih, &s);
    let hit = tracer
        .closest(
            &Ray::new(DVec3::new(0.25, 0.25, 1.0), DVec3::new(0.0, 0.0, -2.0)),
            &mut RayStats::default(),
        )
        .unwrap();
    assert_eq!((hit.prim, hit.t), (0, 0.5));
}

#[test]
fn a_stack_of_identical_triangles_is_one_leaf() {
    let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
    let s = Scene::from_triangles("stack", vec![t; 1000]).unwrap();
    let r = Build::new(BuilderKind::HOST).run(&s).unwrap();
    r.bih.validate(&s).unwrap();
    assert_eq!(
        r.bih.nodes.len(),
        1,
        "no split can separate identical triangles"
    );
    let hit = Tracer::new(&r.bih, &s)
        .closest(
            &Ray::new(DVec3::new(0.1, 0.1, 1.0), DVec3::NEG_Z),
            &mut RayStats::default(),
        )
        .unwrap();
    assert_eq!(hit.prim, 0, "ties go to the lowest id");
}

#[test]
fn zero_area_triangles_are_kept_and_never_hit() {
    let tris = vec![
        Triangle::new(Vec3::ZERO, Vec3::X, Vec3::X * 2.0), // collinear, on the ray's path
        Triangle::new(Vec3::Y, Vec3::Y, Vec3::Y),          // a point
        Triangle::new(
            Vec3::new(0.0, -1.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
            Vec3::new(0.0, 0.0, 1.0),
        ),
    ];
    let s = Scene::from_triangles("degenerate", tris).unwrap();
    assert_eq!(s.degenerate_count(), 2);
    let r = Build::new(BuilderKind::HOST)
        .with_tree(BihConfig {
            leaf_size: 1,
            ..BihConfig::default()
        })
        .run(&s)
        .unwrap();
    r.bih.validate(&s).unwrap();
    let tracer = Tracer::new(&r.bih, &s);
    // Along the x axis the ray runs through the collinear triangle and
    // meets the third one at x = 0.
    let hit = tracer.closest(
        &Ray::new(DVec3::new(-1.0, 0.0, 0.0), DVec3::X),
        &mut RayStats::default(),
    );
    assert_eq!(hit.map(|h| (h.prim, h.t)), Some((2, 1.0)));
}

/// Axis-parallel rays must not make traversal visit nearly every node
/// (madmann91/bvh #21, #60): on a 20k-triangle scene a ray down each axis
/// visits a small fraction of the tree.
#[test]
fn axis_parallel_rays_stay_cheap() {
    let s = cellbih::scene::procedural::rtperf(20_000, 3);
    let r = Build::new(BuilderKind::HOST).run(&s).unwrap();
    let tracer = Tracer::new(&r.bih, &s);
    let c = (s.bounds().min + s.bounds().max).as_dvec3() * 0.5;
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let mut d = DVec3::ZERO;
            d[axis] = sign;
            let mut st = RayStats::default();
            tracer.closest(&Ray::new(c - d * 1000.0, d), &mut st);
            assert!(
                (st.nodes_visited as usize) < r.bih.nodes.len() / 20,
                "axis {axis}: {} of {} nodes visited",
                st.nodes_visited,
                r.bih.nodes.len()
            );
        }
    }
}

/// `validate` names each kind of corruption.
#[test]
fn validate_catches_corrupt_trees() {
    use cellbih::bih::{BihNode, Violation};
    let s = make_scene(500, 0, 0, 0, 11);
    let good = Build::new(BuilderKind::HOST).run(&s).unwrap().bih;
    good.validate(&s).unwrap();
    let inner = good.nodes.iter().position(|n| !n.is_leaf()).unwrap();
    let leaf = good.nodes.iter().position(|n| n.is_leaf()).unwrap();

    let mut t = good.clone();
    let n = t.nodes[inner];
    let [cl, cr] = n.clip();
    t.nodes[inner] = BihNode::inner(n.left_child(), n.axis(), cl - 0.01, cr);
    assert!(
        matches!(t.validate(&s), Err(Violation::OutsidePlanes { .. })),
        "{:?}",
        t.validate(&s)
    );

    let mut t = good.clone();
    t.nodes[inner] = BihNode::inner(t.nodes.len() as u32, n.axis(), cl, cr);
    assert!(matches!(
        t.validate(&s),
        Err(Violation::ChildOutOfRange { .. })
    ));

    let mut t = good.clone();
    t.nodes[inner] = BihNode::inner(0, n.axis(), cl, cr);
    assert!(matches!(
        t.validate(&s),
        Err(Violation::ReachedTwice { .. })
    ));

    let mut t = good.clone();
    t.prim_ids[0] = t.prim_ids[1];
    assert!(matches!(
        t.validate(&s),
        Err(Violation::TriangleCoverage { .. })
    ));

    let mut t = good.clone();
    let (first, count) = t.nodes[leaf].leaf_range();
    t.nodes[leaf] = BihNode::leaf(first + 1, count);
    assert!(t.validate(&s).is_err());

    let mut t = good.clone();
    t.nodes[0] = BihNode::leaf(0, s.len() as u32);
    assert!(matches!(t.validate(&s), Err(Violation::LeafTooBig { .. })));
}

#[test]
fn a_ray_lying_in_a_face_plane_of_a_box_is_inside_it() {
    // The ray runs along z in the plane x = 0, the scene box's min-x face
    // (and the leaf box's), and meets the triangle on its edge x = 0. With
    // d.x = 0 the slab distance of that face is 0·inf = NaN: it must bound
    // nothing, not cull the box.
    let scene = Scene::from_triangles(
        "face",
        vec![
            Triangle::new(
                Vec3::new(0.0, 0.0, 5.0),
                Vec3::new(1.0, 0.0, 5.0),
                Vec3::new(0.0, 1.0, 5.0),
            ),
            Triangle::new(
                Vec3::new(0.5, 0.5, 9.0),
                Vec3::new(1.0, 0.5, 9.0),
                Vec3::new(0.5, 1.0, 9.0),
            ),
        ],
    )
    .unwrap();
    let bih = Build::new(BuilderKind::HOST).run(&scene).unwrap().bih;
    let tracer = Tracer::new(&bih, &scene);
    for dir in [DVec3::Z, DVec3::new(-0.0, 0.0, 1.0)] {
        let ray = Ray::new(DVec3::new(0.0, 0.25, 0.0), dir);
        let hit = tracer.closest(&ray, &mut RayStats::default());
        assert_eq!(hit.map(|h| (h.prim, h.t)), Some((0, 5.0)), "{dir:?}");
        check_ray(&scene, &tracer, &ray).unwrap();
    }
}

/// The empty-space cut-off emits clip nodes (an empty leaf behind a plane
/// at ∓∞), and a ray through the cut-off space no longer descends: on a
/// cluster of 200 triangles in the unit cube and one triangle 100 away, a
/// ray through the empty space above the cluster visits fewer nodes.
#[test]
fn the_empty_space_cut_off_emits_clip_nodes_that_rays_skip() {
    let mut rng = cellbih::scene::SplitMix64::new(3);
    let mut tris: Vec<Triangle> = (0..200)
        .map(|_| {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            Triangle::new(p, p + Vec3::X * 0.05, p + Vec3::Y * 0.05)
        })
        .collect();
    let far = Vec3::splat(100.0);
    tris.push(Triangle::new(far, far + Vec3::X, far + Vec3::Y));
    let s = Scene::from_triangles("cluster and one far", tris).unwrap();
    let paper = Build::new(BuilderKind::HOST).run(&s).unwrap().bih;
    let cut = BihConfig {
        empty_cut: Some(20),
        ..BihConfig::default()
    };
    let clipped = Build::new(BuilderKind::HOST)
        .with_tree(cut)
        .run(&s)
        .unwrap()
        .bih;
    clipped.validate(&s).unwrap();
    let clip_nodes = (clipped.nodes.iter().filter(|n| !n.is_leaf()))
        .filter(|n| n.clip().iter().any(|c| c.is_infinite()))
        .count();
    let empty_leaves = (clipped.nodes.iter())
        .filter(|n| n.is_leaf() && n.leaf_range().1 == 0)
        .count();
    assert!(
        clip_nodes > 0 && clip_nodes == empty_leaves,
        "{clip_nodes} clip nodes, {empty_leaves} empty leaves"
    );
    assert!(
        paper
            .nodes
            .iter()
            .all(|n| n.is_leaf() || n.clip().iter().all(|c| c.is_finite()))
    );
    // Along z through the cluster's x range, far above it in y: inside
    // the region of the root's left child, but misses everything.
    let ray = Ray::new(DVec3::new(0.5, 60.0, -10.0), DVec3::Z);
    let visits = |bih: &cellbih::bih::Bih| {
        let mut st = RayStats::default();
        assert_eq!(Tracer::new(bih, &s).closest(&ray, &mut st), None);
        st.nodes_visited
    };
    let (before, after) = (visits(&paper), visits(&clipped));
    assert!(
        after < before,
        "{after} nodes visited with the cut-off, {before} without"
    );
}
