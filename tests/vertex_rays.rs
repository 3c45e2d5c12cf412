//! Rays aimed exactly at the vertices and edges of sliver triangles — a
//! fan of long thin triangles around one vertex, as a finely cut sphere
//! has at its pole — at every scale of the property scenes: every
//! builder's tree answers as brute force does, bit for bit, on the host
//! (ray by ray and in packets) and on the SPEs. The triangle test's `t` is
//! least accurate on such triangles, and a cull whose widening its error
//! exceeds drops the closer of two triangles that meet at the vertex.

mod common;

use cellbih::bih::{Ray, RayStats, Tracer, brute_force_closest};
use cellbih::cast::{CastConfig, cast_on_cell};
use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{Scene, SplitMix64, Triangle};
use common::same_hit;
use glam::{DVec3, Vec3};
use proptest::prelude::*;

/// A cap of a sphere of radius `scale` cut into `slices` slivers meeting
/// at its pole, above a ring of `slices` wider triangles, centred at
/// `offset × scale`.
fn sliver_cap(slices: usize, scale: f32, offset: f32) -> Scene {
    let at = |lat: f32, lon: f32| {
        let (s, c) = lat.sin_cos();
        (Vec3::new(c * lon.cos(), s, c * lon.sin()) + offset) * scale
    };
    let pole = Vec3::new(0.0, 1.0, 0.0) * scale + offset * scale;
    let step = std::f32::consts::TAU / slices as f32;
    let mut tris = Vec::new();
    for i in 0..slices {
        let (a, b) = (i as f32 * step, (i + 1) as f32 * step);
        tris.push(Triangle::new(pole, at(0.5, a), at(0.5, b)));
        tris.push(Triangle::new(at(0.5, a), at(0.2, a), at(0.5, b)));
    }
    Scene::from_triangles(format!("sliver cap {slices} x{scale}"), tris).unwrap()
}

/// Rays from random points around the cap aimed at a vertex, or at a
/// point of an edge, of a random triangle.
fn aimed(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let b = scene.bounds();
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let ext = hi - lo;
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|i| {
            let mut r = || rng.next_f32() as f64;
            let origin = lo - ext + DVec3::new(r(), r(), r()) * ext * 3.0;
            let t = &scene.triangles[(r() * scene.len() as f64) as usize % scene.len()];
            let (p, q) = (t.v[i % 3].as_dvec3(), t.v[(i + 1) % 3].as_dvec3());
            let target = if i % 2 == 0 { p } else { p + (q - p) * r() };
            Ray::new(origin, target - origin)
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn rays_through_vertices_and_edges_of_slivers_agree_with_brute_force(
        slices in 60usize..500,
        exp in prop::sample::select(vec![-15i32, -7, 0, 7, 15]),
        offset in -2i32..3,
        seed in any::<u64>(),
    ) {
        let scene = sliver_cap(slices, 10f32.powi(exp), offset as f32);
        let rays = aimed(&scene, 96, seed);
        let want: Vec<_> = rays.iter().map(|r| brute_force_closest(&scene, r)).collect();
        for &b in BuilderKind::ALL {
            let r = Build::new(b).run(&scene)
                .map_err(|e| TestCaseError::fail(format!("{b}: {e}")))?;
            let tracer = Tracer::new(&r.bih, &scene);
            let mut stats = RayStats::default();
            let packets = tracer.closest_all(&rays, &mut stats);
            for (i, ray) in rays.iter().enumerate() {
                let alone = tracer.closest(ray, &mut RayStats::default());
                prop_assert!(same_hit(&alone, &want[i]),
                    "{b}: ray {i} {ray:?}: tracer {alone:?}, brute force {:?}", want[i]);
                prop_assert!(same_hit(&packets[i], &want[i]),
                    "{b}: ray {i} in a packet: {:?}, brute force {:?}", packets[i], want[i]);
            }
            {
                let cast = cast_on_cell(&r.bih, &scene, &rays, &CastConfig::DEFAULT,
                    &CellConfig::ps3(), r.record_order())
                    .map_err(|e| TestCaseError::fail(e.to_string()))?;
                for (i, hit) in cast.hits.iter().enumerate() {
                    prop_assert!(same_hit(hit, &want[i]),
                        "SPEs: ray {i}: {hit:?}, brute force {:?}", want[i]);
                }
            }
        }
    }
}

/// The case that found it: a ray aimed at the pole of a 400-slice cap
/// hits two slivers meeting there; the tracer answered the farther one.
#[test]
fn the_pole_of_a_fine_cap_answers_as_brute_force() {
    let scene = sliver_cap(400, 1.0, 0.0);
    let tracer_of = |b: BuilderKind| Build::new(b).run(&scene).unwrap();
    let rays = aimed(&scene, 4000, 7);
    for &b in BuilderKind::ALL {
        let r = tracer_of(b);
        let tracer = Tracer::new(&r.bih, &scene);
        let wrong = (rays.iter())
            .filter(|ray| {
                !same_hit(
                    &tracer.closest(ray, &mut RayStats::default()),
                    &brute_force_closest(&scene, ray),
                )
            })
            .count();
        assert_eq!(wrong, 0, "{b}: {wrong} of {} rays differ", rays.len());
    }
}
