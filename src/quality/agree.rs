//! Agreement with brute force, the correctness check of every tree: the
//! closest (and any) hit of a tree's tracer against a test of every
//! triangle, on rays made to probe the tree's corners — from outside and
//! inside the scene box, aimed at vertices, with zero direction components,
//! axis-parallel, with finite `tmax`. The property tests and
//! `cli/experiments/extremes.rs` use the same rays and the same check.

use glam::DVec3;

use crate::bih::{Hit, Ray, RayStats, Tracer, brute_force_closest};
use crate::scene::{Scene, SplitMix64};

/// Checks the tree's answer for `ray` against brute force: the same
/// triangle at the same `t`, bit for bit (both sides run the same triangle
/// test, and ties in `t` go to the lower triangle id on both), and the
/// tracer's fast walk's answer against its exact walk's, bit for bit; an
/// error names what differs.
pub fn check_ray(scene: &Scene, tracer: &Tracer, ray: &Ray) -> Result<(), String> {
    let want = brute_force_closest(scene, ray);
    let got = tracer.closest(ray, &mut RayStats::default());
    let any = tracer.any(ray, &mut RayStats::default());
    let fast = tracer.closest_fast(ray);
    if !same_hit(&fast, &got) {
        return Err(format!(
            "fast walk {fast:?} but exact walk {got:?} for {ray:?}"
        ));
    }
    if any.is_some() != want.is_some() {
        return Err(format!(
            "any-hit {any:?} but brute force {want:?} for {ray:?}"
        ));
    }
    match (got, want) {
        (None, None) => Ok(()),
        (Some(g), Some(w)) if g.prim == w.prim && g.t.to_bits() == w.t.to_bits() => Ok(()),
        (g, w) => Err(format!("tree {g:?} but brute force {w:?} for {ray:?}")),
    }
}

/// Bitwise the same answer (`Hit`'s f64 compared by bits, so that a NaN
/// or a signed zero could not pass unnoticed).
pub fn same_hit(a: &Option<Hit>, b: &Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(x), Some(y)) => {
            x.prim == y.prim
                && x.t.to_bits() == y.t.to_bits()
                && x.u.to_bits() == y.u.to_bits()
                && x.v.to_bits() == y.v.to_bits()
        }
        _ => false,
    }
}

/// Rays that hit the scene's box from outside and inside, one in eight
/// with a zero direction component (one in sixteen axis-parallel), some
/// with a finite tmax.
pub fn rays_for(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let b = scene.bounds();
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let ext = (hi - lo).max(DVec3::splat(
        lo.abs().max_element().max(hi.abs().max_element()) * 1e-3,
    ));
    let mut rng = SplitMix64::new(seed);
    let mut r01 = || rng.next_f32() as f64;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let origin = lo - ext * 0.5 + DVec3::new(r01(), r01(), r01()) * ext * 2.0;
        let mut target = lo + DVec3::new(r01(), r01(), r01()) * (hi - lo);
        // Aim at a vertex now and then: edges and corners are hit exactly.
        if i % 5 == 0 {
            let t = &scene.triangles[(r01() * scene.len() as f64) as usize % scene.len()];
            target = t.v[i % 3].as_dvec3();
        }
        let mut dir = target - origin;
        if i % 8 == 3 {
            dir[i % 3] = if i % 16 == 3 { 0.0 } else { -0.0 };
        }
        if i % 16 == 11 {
            let keep = i % 3;
            for a in 0..3 {
                if a != keep {
                    dir[a] = 0.0;
                }
            }
            if dir[keep] == 0.0 {
                dir[keep] = 1.0;
            }
            let mut o = target;
            o[keep] = if dir[keep] >= 0.0 {
                lo[keep] - ext[keep]
            } else {
                hi[keep] + ext[keep]
            };
            out.push(Ray::new(o, dir));
            continue;
        }
        if dir == DVec3::ZERO {
            dir = DVec3::X;
        }
        let mut ray = Ray::new(origin, dir);
        if i % 7 == 2 {
            ray.tmax = 0.5 + r01();
        }
        out.push(ray);
    }
    out
}

/// What one builder made of one scene, checked: the tree's validity, how
/// many rays disagree with brute force, its depth and largest leaf.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Examined {
    /// `None` when valid, else the first violation (or the build's error).
    pub invalid: Option<String>,
    /// Rays whose closest or any hit differs from brute force's, of `rays`.
    pub disagree: usize,
    pub rays: usize,
    pub depth: u32,
    pub largest_leaf: u32,
}

impl Examined {
    /// Valid, and every ray agreed.
    pub fn ok(&self) -> bool {
        self.invalid.is_none() && self.disagree == 0
    }
}

/// Builds `scene` as `build` asks and checks the tree and every ray of
/// `rays` against brute force.
pub fn examine(build: &crate::registry::Build, scene: &Scene, rays: &[Ray]) -> Examined {
    let r = match build.run(scene) {
        Ok(r) => r,
        Err(e) => {
            return Examined {
                invalid: Some(format!("build failed: {e}")),
                disagree: rays.len(),
                rays: rays.len(),
                depth: 0,
                largest_leaf: 0,
            };
        }
    };
    let q = r.bih.quality();
    let invalid = r.bih.validate(scene).err().map(|v| v.to_string());
    let disagree = if invalid.is_none() {
        let tracer = Tracer::new(&r.bih, scene);
        rays.iter()
            .filter(|ray| check_ray(scene, &tracer, ray).is_err())
            .count()
    } else {
        rays.len()
    };
    Examined {
        invalid,
        disagree,
        rays: rays.len(),
        depth: q.max_depth,
        largest_leaf: q.max_leaf_triangles,
    }
}
