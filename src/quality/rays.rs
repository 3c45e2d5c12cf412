//! Ray cost measured, not estimated: the two ray sets the testbed traces
//! (primary rays of the render camera; incoherent rays from random points
//! inside the scene box in random directions) and what one host thread
//! spends on them — nodes visited and triangles tested per ray, rays per
//! second.

use std::time::Instant;

use glam::DVec3;

use crate::aabb::Aabb;
use crate::bih::{Ray, RayStats, Tracer};
use crate::scene::SplitMix64;

/// What tracing a set of rays cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RayCost {
    /// Per ray: inner and leaf nodes visited, triangles tested.
    pub nodes: f64,
    pub triangles: f64,
    /// Million rays per second, one host thread (closest hit).
    pub mrays_per_s: f64,
    /// Where a set would cost more than [`WORK_BUDGET`] (a shallow tree's
    /// huge leaves), the rays measured: every k-th of the set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampled: Option<u64>,
}

/// Node visits plus triangle tests that measuring one ray set may take
/// (about a second on one host thread): a tree whose rays would cost more
/// is measured on an even sample of its rays, and says so. A usual tree
/// (the dragon's: about 50 a ray, 15 M for the primary rays) is measured
/// on every ray.
pub const WORK_BUDGET: u64 = 100_000_000;

impl RayCost {
    /// Nodes plus triangles per ray: the work a ray costs.
    pub fn per_ray(&self) -> f64 {
        self.nodes + self.triangles
    }
}

/// The testbed's two ray sets for a scene: primary rays of a camera (the
/// scene's own viewpoint by default, [`crate::render::View`]; 640 x 480,
/// in 4 × 4 blocks of pixels, the packets [`measure`] traces)
/// and 16,384 incoherent rays (seed 1). `compare`, `build` and the
/// experiments measure every tree on these.
pub struct RaySets {
    pub primary: Vec<Ray>,
    pub incoherent: Vec<Ray>,
}

impl RaySets {
    pub const WIDTH: u32 = 640;
    pub const HEIGHT: u32 = 480;
    pub const INCOHERENT: usize = 16_384;

    /// The sets of `scene` seen from `view`; a viewpoint of another scene
    /// is an error.
    pub fn for_scene(
        scene: &crate::scene::Scene,
        view: &crate::render::View,
    ) -> Result<Self, String> {
        let bounds = scene.bounds();
        let cam = view.camera(&scene.name, &bounds, Self::WIDTH, Self::HEIGHT)?;
        Ok(RaySets {
            primary: cam.rays_in_blocks(4, 4),
            incoherent: incoherent_rays(&bounds, Self::INCOHERENT, 1),
        })
    }

    /// The sets of `scene` from its own viewpoint (inside the indoor
    /// scenes), else from outside its box.
    pub fn standard(scene: &crate::scene::Scene) -> Self {
        Self::for_scene(scene, &crate::render::View::Default)
            .expect("every scene has a default view")
    }

    /// The cost of both sets through `tracer`: (primary, incoherent),
    /// each within [`WORK_BUDGET`].
    pub fn measure(&self, tracer: &Tracer) -> (RayCost, RayCost) {
        (
            measure_bounded(tracer, &self.primary, WORK_BUDGET),
            measure_bounded(tracer, &self.incoherent, WORK_BUDGET),
        )
    }
}

/// [`measure`] of `rays`, or of every k-th of them where all of them would
/// cost more than `budget` node visits and triangle tests: the cost is
/// first estimated on every 64th ray.
pub fn measure_bounded(tracer: &Tracer, rays: &[Ray], budget: u64) -> RayCost {
    const PILOT: usize = 64;
    let mut pilot = RayStats::default();
    for ray in rays.iter().step_by(PILOT) {
        tracer.closest(ray, &mut pilot);
    }
    let per_ray = (pilot.nodes_visited + pilot.triangles_tested) as f64 / pilot.rays.max(1) as f64;
    let total = per_ray * rays.len() as f64;
    if total <= budget as f64 {
        return measure(tracer, rays);
    }
    let k = (total / budget as f64).ceil() as usize;
    let sample: Vec<Ray> = rays.iter().step_by(k).copied().collect();
    RayCost {
        sampled: Some(sample.len() as u64),
        ..measure(tracer, &sample)
    }
}

/// `n` rays from uniform random points inside `bounds` in uniform random
/// directions (seeded: the same rays on every run and host).
pub fn incoherent_rays(bounds: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = SplitMix64::new(seed);
    let (lo, ext) = (bounds.min.as_dvec3(), bounds.extent_f64());
    (0..n)
        .map(|_| {
            let mut u = || rng.next_f32() as f64;
            let origin = lo + DVec3::new(u(), u(), u()) * ext;
            let z = 2.0 * u() - 1.0;
            let phi = std::f64::consts::TAU * u();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Ray::new(origin, DVec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}

/// The cost of `rays` through `tracer` (closest hit, one thread): nodes
/// visited and triangles tested by the exact walk ([`Tracer::closest_all`]:
/// the tree's own counts), rays per second by the tracer's fastest
/// ([`Tracer::hits`]: the same hits).
pub fn measure(tracer: &Tracer, rays: &[Ray]) -> RayCost {
    let mut st = RayStats::default();
    std::hint::black_box(tracer.closest_all(rays, &mut st));
    let start = Instant::now();
    std::hint::black_box(tracer.hits(rays));
    let secs = start.elapsed().as_secs_f64().max(1e-9);
    let n = st.rays.max(1) as f64;
    RayCost {
        nodes: st.nodes_visited as f64 / n,
        triangles: st.triangles_tested as f64 / n,
        mrays_per_s: rays.len() as f64 / secs / 1e6,
        sampled: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Within the budget every ray is measured; past it an even sample,
    /// named, whose cost per ray is the whole set's within sampling noise.
    #[test]
    fn a_set_past_the_budget_is_measured_on_a_sample() {
        let s = crate::scene::load("default", None).unwrap();
        let bih = crate::registry::Build::new(crate::registry::BuilderKind::HOST)
            .run(&s)
            .unwrap()
            .bih;
        let tracer = Tracer::new(&bih, &s);
        let rays = incoherent_rays(&s.bounds(), 4096, 3);
        let all = measure_bounded(&tracer, &rays, u64::MAX);
        assert_eq!(all.sampled, None);
        let work = (all.per_ray() * rays.len() as f64) as u64;
        let part = measure_bounded(&tracer, &rays, work / 8);
        let n = part.sampled.expect("sampled");
        assert!((400..=700).contains(&n), "{n} of 4096");
        assert!(
            (part.per_ray() / all.per_ray() - 1.0).abs() < 0.25,
            "{part:?} {all:?}"
        );
    }

    #[test]
    fn incoherent_rays_start_inside_and_point_everywhere() {
        let b = Aabb::new(Vec3::splat(-2.0), Vec3::new(1.0, 3.0, 5.0));
        let rays = incoherent_rays(&b, 2000, 7);
        assert_eq!(rays, incoherent_rays(&b, 2000, 7), "seeded");
        let mut octants = [0; 8];
        for r in &rays {
            assert!(
                b.min.as_dvec3().cmple(r.origin).all() && r.origin.cmple(b.max.as_dvec3()).all()
            );
            assert!((r.dir.length() - 1.0).abs() < 1e-9);
            let o = (r.dir.x > 0.0) as usize
                | ((r.dir.y > 0.0) as usize) << 1
                | ((r.dir.z > 0.0) as usize) << 2;
            octants[o] += 1;
        }
        // Uniform directions: each octant near 1/8 of 2000.
        assert!(
            octants.iter().all(|&c| (180..320).contains(&c)),
            "{octants:?}"
        );
    }
}
