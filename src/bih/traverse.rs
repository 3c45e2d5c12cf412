//! Ray casting: closest hit and any hit, and a brute-force reference.
//!
//! Numerics. Vertices are `f32`, but every ray computation is done in `f64`:
//! with coordinates of 1e15, the triangle test's edge functions are products
//! of 1e15-sized differences (1e30, and `t` a quotient of 1e45-sized sums,
//! beyond `f32`'s 3.4e38), and with 1e-15 they are 1e-30 to 1e-45 (below
//! `f32`'s smallest normal, 1.2e-38); `f64` holds both. The triangle test
//! is watertight ([`super::watertight`]). A zero
//! direction component gives an infinite reciprocal, and the slab distance
//! `(plane - origin) * inf` is ±inf (the ray never crosses) or NaN (the ray
//! lies in the plane); `f64::min`/`max` drop the NaN, so a ray in a plane
//! counts as inside both closed half-spaces, which is right. Only such rays
//! (a zero or subnormal direction component) take that careful slab test at
//! the leaf boxes; every other ray, whose slab distances cannot be NaN, takes
//! a branch-free one that gives the same interval (chosen once per ray). The
//! sign of the direction (including the sign of a zero) picks the near child.
//!
//! Node intervals are widened by a relative [`SLACK`] so that rounding never
//! culls a node the ray touches; triangle tests use the ray's own
//! `[tmin, best]`, so widening only costs a few visits, never a wrong hit.
//! Equal `t` is broken by the lower triangle id, the same rule brute force
//! uses, so both return the same triangle.
//!
//! What a renderer makes of a tree, [`Tracer`], is in `tracer.rs`; its
//! packets in `packet.rs`.

use glam::DVec3;

use super::watertight::{self, Shear};
use super::{BihNode, SLACK};
use crate::aabb::Aabb;
use crate::scene::{Scene, Triangle};

/// A ray `origin + t·dir` for `t` in `[tmin, tmax]`; `dir` need not be unit
/// length and `t` is in units of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub dir: DVec3,
    pub tmin: f64,
    pub tmax: f64,
}

impl Ray {
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax: f64::INFINITY,
        }
    }

    /// The same ray with its direction scaled by a power of two so that
    /// its largest component lies in [1, 2) (the direction times `2^-k`),
    /// and `k`: a hit at `t'` on it is at `t' · 2^-k` on this ray (`tmin`
    /// and `tmax` are scaled by `2^k`). Every path's triangle test multiplies origin offsets
    /// by the direction; a direction near 1 keeps those products inside
    /// `f64` for every origin up to ±1e200 (`rays_csv::MAX_COMPONENT`),
    /// where a direction of 1e155 beside an origin of 1e154 would
    /// overflow them and miss. Exact: scaling by a power of two changes
    /// no bit of a normal product, so a ray already at this scale (`k`
    /// = 0) and the hits of every other one are what they were.
    pub fn at_unit_scale(&self) -> (Ray, i32) {
        let largest = self.dir.abs().max_element();
        if !largest.is_normal() {
            return (*self, 0);
        }
        let k = ((largest.to_bits() >> 52) & 0x7ff) as i32 - 1023;
        let ray = Ray {
            origin: self.origin,
            dir: self.dir.map(|c| times_pow2(c, -k)),
            tmin: times_pow2(self.tmin, k),
            tmax: times_pow2(self.tmax, k),
        };
        (ray, k)
    }
}

/// 2^k for k in -1022..=1023.
fn pow2(k: i32) -> f64 {
    f64::from_bits(((k + 1023) as u64) << 52)
}

/// `x · 2^k` for |k| ≤ 2044, in two steps (each factor a normal `f64`):
/// exact but where the result leaves the normal range.
pub fn times_pow2(x: f64, k: i32) -> f64 {
    let half = k / 2;
    x * pow2(half) * pow2(k - half)
}

/// The closest (or any) hit: triangle id, distance and barycentrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub prim: u32,
    pub t: f64,
    pub u: f64,
    pub v: f64,
}

/// What one or more rays cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RayStats {
    pub rays: u64,
    pub nodes_visited: u64,
    pub triangles_tested: u64,
}

impl std::ops::AddAssign for RayStats {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.nodes_visited += o.nodes_visited;
        self.triangles_tested += o.triangles_tested;
    }
}

/// The watertight test (`bih/watertight.rs`; [`Shear`]) of `tri` against `ray` in
/// `[tmin, tmax]`: `t` and the barycentrics of vertices 1 and 2. Edges and
/// corners count as inside; a zero-area triangle is never hit. A caller
/// testing many triangles against one ray makes its [`Shear`] once and
/// calls [`intersect_sheared`].
#[inline]
pub fn intersect_triangle(
    tri: &Triangle,
    ray: &Ray,
    tmin: f64,
    tmax: f64,
) -> Option<(f64, f64, f64)> {
    intersect_sheared(tri, &Shear::of(ray), tmin, tmax)
}

/// [`intersect_triangle`] with the ray's shear made once.
#[inline]
pub fn intersect_sheared(
    tri: &Triangle,
    sh: &Shear,
    tmin: f64,
    tmax: f64,
) -> Option<(f64, f64, f64)> {
    test_sheared(tri, sh, tmin, tmax).1
}

/// [`intersect_sheared`], and whether the ray's line meets the triangle
/// at all (its edge functions agree), whatever `t`: what decides whether
/// a SIMD kernel goes on from the edge tests to `t`.
#[inline]
pub fn test_sheared(
    tri: &Triangle,
    sh: &Shear,
    tmin: f64,
    tmax: f64,
) -> (bool, Option<(f64, f64, f64)>) {
    watertight::intersect(PreTriangle::new(tri).v, sh, tmin, tmax)
}

/// A triangle ready for ray tests: `f32` vertices (36 bytes, half the cache
/// footprint of `f64`), widened to `f64` in the test. A zero-area triangle is
/// stored collapsed to its first vertex, so that its edge functions are
/// exactly zero and it is never hit.
#[derive(Clone, Copy, Debug)]
pub(super) struct PreTriangle {
    pub(super) v: [glam::Vec3; 3],
}

impl PreTriangle {
    pub(super) fn new(tri: &Triangle) -> Self {
        let v = if tri.is_degenerate() {
            [tri.v[0]; 3]
        } else {
            tri.v
        };
        PreTriangle { v }
    }
}

/// Closest hit by testing every triangle: the reference every tree must
/// agree with. Ties in `t` go to the lower triangle id.
pub fn brute_force_closest(scene: &Scene, ray: &Ray) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let sh = Shear::of(ray);
    for (i, tri) in scene.triangles.iter().enumerate() {
        let tmax = best.map_or(ray.tmax, |h| h.t);
        if let Some((t, u, v)) = intersect_sheared(tri, &sh, ray.tmin, tmax)
            && best.is_none_or(|h| t < h.t)
        {
            best = Some(Hit {
                prim: i as u32,
                t,
                u,
                v,
            });
        }
    }
    best
}

/// `t` moved up by the relative slack: of `t·(1 + SLACK)` and
/// `t·(1 - SLACK)` the larger, whatever the sign of `t`. ±inf stay as they
/// are (the additive form `t + |t|·SLACK` would turn them into NaN and cull
/// nothing), and no sign test is needed.
#[inline(always)]
pub(super) fn widen_up(t: f64) -> f64 {
    (t * (1.0 + SLACK)).max(t * (1.0 - SLACK))
}

/// `t` moved down by the relative slack; ±inf stay as they are.
#[inline(always)]
pub(super) fn widen_down(t: f64) -> f64 {
    (t * (1.0 + SLACK)).min(t * (1.0 - SLACK))
}

/// Slab test of a box: the `[t0, t1]` of the ray inside it, widened.
fn clip_to_box(b: &Aabb, ray: &Ray, inv: DVec3) -> (f64, f64) {
    clip_range(b, ray, inv, ray.tmin, ray.tmax)
}

/// The part of `[t0, t1]` in which the ray is inside `b`, widened.
#[inline(always)]
pub(super) fn clip_range(b: &Aabb, ray: &Ray, inv: DVec3, mut t0: f64, mut t1: f64) -> (f64, f64) {
    for a in 0..3 {
        let ta = (b.min[a] as f64 - ray.origin[a]) * inv[a];
        let tb = (b.max[a] as f64 - ray.origin[a]) * inv[a];
        // NaN (0·inf: a zero direction component and the origin on a face
        // plane) means the ray lies in that plane, inside the closed slab:
        // this axis bounds nothing.
        let (near, far) = if ta <= tb {
            (ta, tb)
        } else if tb < ta {
            (tb, ta)
        } else {
            continue;
        };
        t0 = t0.max(widen_down(near));
        t1 = t1.min(widen_up(far));
    }
    (t0, t1)
}

/// [`clip_range`] for a ray whose reciprocal direction is finite on every
/// axis: no slab distance is then NaN, so each axis gives its near and far
/// distance by a min and a max, without branches. Widening is monotone, so
/// it is applied once, to the largest near and the smallest far distance;
/// the result is the same as [`clip_range`]'s.
#[inline(always)]
pub(super) fn clip_range_finite(b: &Aabb, o: DVec3, inv: DVec3, t0: f64, t1: f64) -> (f64, f64) {
    let ta = (b.min.as_dvec3() - o) * inv;
    let tb = (b.max.as_dvec3() - o) * inv;
    let near = ta.min(tb).max_element();
    let far = ta.max(tb).min_element();
    (t0.max(widen_down(near)), t1.min(widen_up(far)))
}

/// Where a ray goes at an inner node: its near and far child, the part
/// of `[tn, tf]` it spends in each (widened), and whether it enters them.
/// One step of the traversal: the SPE caster's (`crate::cast`); the
/// host's [`Tracer`] writes the same arithmetic out in its loop (see
/// there), so both cull exactly alike.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Descend {
    pub near: u32,
    pub far: u32,
    /// The near child's interval ends here (the far one's starts at
    /// `far_tn`).
    pub near_tf: f64,
    pub far_tn: f64,
    pub go_near: bool,
    pub go_far: bool,
}

/// The step at inner node `nd` of a ray inside `[tn, tf]`; `inv` is the
/// ray's reciprocal direction, `neg` the signs of its direction.
#[inline(always)]
pub(crate) fn descend(
    nd: &BihNode,
    ray: &Ray,
    inv: DVec3,
    neg: [bool; 3],
    tn: f64,
    tf: f64,
) -> Descend {
    let a = nd.axis();
    let [cl, cr] = nd.clip();
    let t_left = (cl as f64 - ray.origin[a]) * inv[a];
    let t_right = (cr as f64 - ray.origin[a]) * inv[a];
    // Going up the axis the ray leaves the left child at t_left and enters
    // the right one at t_right; going down, the reverse. NaN (ray in the
    // plane) constrains nothing.
    let (t_exit_near, t_enter_far) = if neg[a] {
        (t_right, t_left)
    } else {
        (t_left, t_right)
    };
    // Written as comparisons so that a NaN bound is dropped.
    let exit = widen_up(t_exit_near);
    let enter = widen_down(t_enter_far);
    let near_tf = if exit < tf { exit } else { tf };
    let far_tn = if enter > tn { enter } else { tn };
    let left = nd.left_child();
    let (near, far) = if neg[a] {
        (left + 1, left)
    } else {
        (left, left + 1)
    };
    Descend {
        near,
        far,
        near_tf,
        far_tn,
        go_near: tn <= near_tf,
        go_far: far_tn <= tf,
    }
}

/// A node popped from the stack is still worth visiting if its interval
/// starts at or before this bound (the best hit's `t`, widened).
#[inline(always)]
pub(crate) fn pop_bound(best_t: f64) -> f64 {
    widen_up(best_t)
}

/// The part of the ray's `[tmin, tmax]` inside the tree's bounds, widened;
/// `None` when the ray misses them (a NaN bound misses too).
pub(crate) fn root_interval(bounds: &Aabb, ray: &Ray, inv: DVec3) -> Option<(f64, f64)> {
    let (t0, t1) = clip_to_box(bounds, ray, inv);
    (t0.partial_cmp(&t1).is_some_and(|o| o.is_le())).then_some((t0, t1))
}

/// Whether a hit at `t` on triangle `prim` replaces `best`: closer, or as
/// close on a lower triangle id (the rule brute force follows).
#[inline(always)]
pub(crate) fn closer(t: f64, prim: u32, best: Option<Hit>) -> bool {
    best.is_none_or(|h| t < h.t || (t == h.t && prim < h.prim))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use proptest::prelude::*;

    /// A coordinate anywhere from 1e-15 to 1e15 in magnitude, or zero.
    fn coord() -> impl Strategy<Value = f64> {
        prop_oneof![-1e3..1e3f64, -1e15..1e15f64, -1e-15..1e-15f64, Just(0.0),]
    }

    /// A direction component that is not zero: magnitudes 1e-300 to 1e300.
    fn component() -> impl Strategy<Value = f64> {
        (any::<bool>(), 0.1..1.0f64, -300i32..300)
            .prop_map(|(neg, m, e)| if neg { -1.0 } else { 1.0 } * m * 10f64.powi(e))
    }

    proptest! {
        /// The branch-free slab test gives exactly the careful one's
        /// interval for every ray whose reciprocal direction is finite.
        #[test]
        fn the_branch_free_slab_test_equals_the_careful_one(
            o in [coord(), coord(), coord()],
            d in [component(), component(), component()],
            a in [coord(), coord(), coord()],
            b in [coord(), coord(), coord()],
            (t0, t1) in (-10.0..10.0f64, prop_oneof![0.0..1e20f64, Just(f64::INFINITY)]),
        ) {
            let lo = Vec3::from_array([0, 1, 2].map(|i| a[i].min(b[i]) as f32));
            let hi = Vec3::from_array([0, 1, 2].map(|i| a[i].max(b[i]) as f32));
            let bx = Aabb::new(lo, hi);
            let ray = Ray { origin: DVec3::from_array(o), dir: DVec3::from_array(d), tmin: t0, tmax: t1 };
            let inv = DVec3::ONE / ray.dir;
            prop_assume!(inv.is_finite());
            let want = clip_range(&bx, &ray, inv, t0, t1);
            let got = clip_range_finite(&bx, ray.origin, inv, t0, t1);
            prop_assert!(!got.0.is_nan() && !got.1.is_nan());
            prop_assert!(got == want, "{got:?} != {want:?}");
        }
    }

    /// A ray along an axis, lying in a face plane of the box, is inside it:
    /// the careful test keeps it (the branch-free one is never asked).
    #[test]
    fn a_ray_in_a_face_plane_takes_the_careful_test_and_is_inside() {
        let bx = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let ray = Ray::new(DVec3::new(-1.0, 0.0, 0.5), DVec3::X);
        let inv = DVec3::ONE / ray.dir;
        assert!(!inv.is_finite());
        let (t0, t1) = clip_range(&bx, &ray, inv, 0.0, f64::INFINITY);
        assert!(t0 <= 1.0 && t1 >= 2.0, "[{t0}, {t1}]");
    }
}
