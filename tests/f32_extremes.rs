//! Scenes whose extent overflows `f32`: every coordinate is a finite `f32`,
//! but a scene from -3e38 to 3e38 is 6e38 wide, past `f32::MAX` (3.4e38).
//! Every builder, the quality metrics, the camera and the update must handle
//! it: valid trees, rays equal to brute force, a finite SAH, an image whose
//! hits are brute force's.

mod common;

use cellbih::bih::{BihConfig, Tracer, brute_force_closest};
use cellbih::registry::{Build, BuilderKind};
use cellbih::render::{Camera, trace};
use cellbih::scene::{Scene, SplitMix64, Triangle};
use cellbih::update::{Method, Move, Updater};
use common::{check_ray, rays_for};
use glam::Vec3;
use proptest::prelude::*;

/// `n` triangles of three kinds: large ones anywhere in ±3.4e38, small ones
/// (1 to 1e37 wide) near the corners at ±3e38, and unit ones at the origin.
fn huge_scene(n: usize, seed: u64) -> Scene {
    let mut rng = SplitMix64::new(seed);
    let mut unit = || rng.next_f32() * 2.0 - 1.0;
    let mut tris = Vec::with_capacity(n);
    for i in 0..n {
        let v: [Vec3; 3] = match i % 3 {
            0 => std::array::from_fn(|_| Vec3::new(unit(), unit(), unit()) * 3.4e38),
            1 => {
                let corner = Vec3::new(unit().signum(), unit().signum(), unit().signum()) * 3e38;
                let size = 10f32.powi((unit().abs() * 37.0) as i32);
                std::array::from_fn(|_| corner + Vec3::new(unit(), unit(), unit()) * size)
            }
            _ => std::array::from_fn(|_| Vec3::new(unit(), unit(), unit())),
        };
        tris.push(Triangle::new(v[0], v[1], v[2]));
    }
    Scene::from_triangles(format!("huge n={n} seed={seed}"), tris).unwrap()
}

fn check_every_builder(scene: &Scene) -> Result<(), TestCaseError> {
    let b = scene.bounds();
    prop_assume!(b.extent().max_element().is_infinite() || scene.len() < 3);
    // The paper's tree from every builder, and the quality knobs from the
    // builders that build them.
    let runs = BuilderKind::every_run(BihConfig::SAH_CUT);
    for (builder, cfg) in runs {
        let fail = |e: String| TestCaseError::fail(format!("{builder}: {e}"));
        let r = Build::new(builder)
            .with_tree(cfg)
            .run(scene)
            .map_err(|e| fail(e.to_string()))?;
        r.bih.validate(scene).map_err(|v| fail(v.to_string()))?;
        let q = r.bih.quality();
        prop_assert!(q.sah_cost.is_finite(), "{builder}: SAH cost {}", q.sah_cost);
        let tracer = Tracer::new(&r.bih, scene);
        for ray in rays_for(scene, 48, 3) {
            check_ray(scene, &tracer, &ray).map_err(fail)?;
        }
        // The camera frames the scene: its rays hit what brute force hits.
        let cam = Camera::framing(&b, 24, 18);
        let frame = trace(&tracer, &scene.triangles, &cam);
        for (k, ray) in cam.rays().iter().enumerate() {
            let hit = brute_force_closest(scene, ray).is_some();
            prop_assert_eq!(frame.shade[k].is_some(), hit, "{}: pixel {}", builder, k);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn every_builder_handles_scenes_wider_than_f32(n in 3usize..40, seed in any::<u64>()) {
        check_every_builder(&huge_scene(n, seed))?;
    }
}

/// The scene of the report: two small triangles at opposite corners
/// (±3e38) and one at the origin. `ppe_approx` indexed out of its grid on
/// such scenes, and the SAH cost was NaN; the camera saw only background.
#[test]
fn corners_at_plus_and_minus_3e38() {
    let t = |c: f32, d: f32| {
        Triangle::new(
            Vec3::splat(c),
            Vec3::new(c + d, c, c),
            Vec3::new(c, c + d, c),
        )
    };
    let scene = Scene::from_triangles("corners", vec![t(-3e38, 1e37), t(3e38, -1e37), t(0.0, 1.0)])
        .unwrap();
    check_every_builder(&scene).unwrap();
    let host = Build::new(BuilderKind::HOST).run(&scene).unwrap();
    let tracer = Tracer::new(&host.bih, &scene);
    let frame = trace(
        &tracer,
        &scene.triangles,
        &Camera::framing(&scene.bounds(), 400, 300),
    );
    assert!(
        frame.shade.iter().any(Option::is_some),
        "the corner triangles are in view"
    );
}

/// The update, with every builder, on a scene wider than `f32`: moving the
/// small triangle at the origin updates locally; the tree stays valid.
#[test]
fn the_update_handles_scenes_wider_than_f32() {
    let mut tris = Vec::new();
    let mut ids = Vec::new();
    for (g, c) in [(0u32, -3e38f32), (0, 3e38), (1, 0.0), (1, 1.0)] {
        let d = if c == 0.0 || c == 1.0 { 0.5 } else { 1e37 };
        let d = if c > 2.0 { -d } else { d };
        tris.push(Triangle::new(
            Vec3::splat(c),
            Vec3::new(c + d, c, c),
            Vec3::new(c, c + d, c),
        ));
        ids.push(g);
    }
    let scene = Scene::new("wide", tris, ids, vec!["corners".into(), "small".into()]).unwrap();
    for &builder in BuilderKind::ALL {
        for method in [Method::Local, Method::Deep] {
            let mut u = Updater::new(scene.clone(), Build::new(builder), method)
                .unwrap_or_else(|e| panic!("{builder}: {e}"));
            for k in 0..4 {
                let by = Vec3::new(if k % 2 == 0 { 0.25 } else { -0.25 }, 0.0, 0.0);
                u.step(&[Move::translate(1, by)])
                    .unwrap_or_else(|e| panic!("{builder} {method:?}: {e}"));
                u.bih
                    .validate(&u.scene)
                    .unwrap_or_else(|v| panic!("{builder} {method:?}: {v}"));
                assert!(u.bih.quality().sah_cost.is_finite());
            }
        }
    }
}
