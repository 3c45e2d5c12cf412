//! The host tracer's fast walk (`Tracer::closest_fast`: `f32` boxes of a
//! four-wide tree, widened never to cull what the exact test keeps) and
//! its default for sets of rays (`Tracer::hits`, also with packets that
//! hand their rays over to the fast walk): every ray answers as the
//! exact walk does, bit for bit, for every builder's tree at the numerical
//! extremes of the property scenes — camera rays from outside and inside,
//! rays from scattered origins, rays turned into one octant — in both
//! builds of the loop (AVX2 and portable). The brute-force check
//! (`check_ray`, every builder's proptests) holds the fast walk to the
//! exact one too.

mod common;

use cellbih::bih::{Ray, RayStats, Tracer};
use cellbih::registry::{Build, BuilderKind};
use cellbih::render::Camera;
use common::{packet_ray_sets as ray_sets, same_hit as same, scene_strategy};
use glam::DVec3;
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    #[test]
    fn the_fast_walk_answers_as_the_exact_walk(scene in scene_strategy(), seed in any::<u64>()) {
        for &b in BuilderKind::ALL {
            let r = Build::new(b).run(&scene)
                .map_err(|e| TestCaseError::fail(format!("{b}: {e}")))?;
            let tracer = Tracer::new(&r.bih, &scene);
            let portable = Tracer::new(&r.bih, &scene).portable();
            // Packets that hand rays over to the fast walk, at one active
            // ray and at up to all sixteen.
            let handing = [1, 16].map(|k| Tracer::new(&r.bih, &scene).handing_over(k));
            for (set, rays) in ray_sets(&scene, seed) {
                let mut st = RayStats::default();
                let exact = tracer.closest_all(&rays, &mut st);
                for t in [&tracer, &portable] {
                    for (i, (ray, want)) in rays.iter().zip(&exact).enumerate() {
                        let got = t.closest_fast(ray);
                        prop_assert!(same(&got, want),
                            "{b}, {set}: ray {i}: fast {got:?} exact {want:?}");
                    }
                    let all = t.hits(&rays);
                    for (i, (got, want)) in all.iter().zip(&exact).enumerate() {
                        prop_assert!(same(got, want), "{b}, {set}: hits() ray {i}");
                    }
                }
                for (t, k) in handing.iter().zip([1, 16]) {
                    let all = t.hits(&rays);
                    for (i, (got, want)) in all.iter().zip(&exact).enumerate() {
                        prop_assert!(same(got, want), "{b}, {set}: handing over at {k}: ray {i}");
                    }
                }
            }
        }
    }
}

/// The fast walk takes the rays of ordinary scenes — at 1e-7 and 1e7 as
/// well as at 1 — and leaves to the exact walk only those it cannot
/// carry in `f32`: a zero direction component, a ray whose distances
/// would pass 1e30, a NaN end.
#[test]
fn the_fast_walk_takes_every_ray_f32_can_carry() {
    for exp in [-7, 0, 7] {
        let s = common::make_scene(60, exp, 1, 0, 9);
        let bih = Build::new(BuilderKind::HOST).run(&s).unwrap().bih;
        let tracer = Tracer::new(&bih, &s);
        let cam = Camera::framing(&s.bounds(), 12, 9);
        let rays = cam.rays_in_blocks(4, 4);
        assert!(rays.iter().all(|r| tracer.fast_walk_takes(r)), "1e{exp}");
        let r = rays[40];
        for (what, odd) in [
            (
                "zero direction",
                Ray {
                    dir: DVec3::new(0.0, r.dir.y, r.dir.z),
                    ..r
                },
            ),
            (
                "origin 1e31 out",
                Ray {
                    origin: r.origin + DVec3::splat(1e31),
                    ..r
                },
            ),
            (
                "direction 1e-40",
                Ray {
                    dir: r.dir * 1e-40,
                    ..r
                },
            ),
            (
                "NaN end",
                Ray {
                    tmax: f64::NAN,
                    ..r
                },
            ),
        ] {
            assert!(!tracer.fast_walk_takes(&odd), "1e{exp}: {what}");
            let want = tracer.closest(&odd, &mut RayStats::default());
            assert!(same(&tracer.closest_fast(&odd), &want), "1e{exp}: {what}");
        }
        // And the walk finds what the camera sees.
        assert!(
            rays.iter().any(|r| tracer.closest_fast(r).is_some()),
            "1e{exp}"
        );
    }
}
