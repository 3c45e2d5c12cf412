//! The watertight ray/triangle test (Woop, Benthin & Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2013), in `f64`, the one triangle test
//! of every path: the exact walk, the four-lane groups, the packets, the
//! fast walk, brute force and the SPE caster.
//!
//! Each ray is turned once ([`Shear::of`]) so that it runs along +z from
//! the origin: its axes permuted so that z is its largest direction
//! component, and sheared so that its direction becomes (0, 0, 1). A
//! triangle is then hit where the origin lies inside its projection on
//! the xy plane, which three 2-D edge functions decide. Each edge
//! function reads only the two vertices of its edge, each vertex
//! transformed by the ray alone: two triangles that share an edge compute
//! the same value for it with the opposite sign, bit for bit, so a ray
//! through the edge is inside one of them or on it, never outside both.
//! Where an edge function rounds to zero (the ray through the edge or a
//! vertex, or so close that rounding cannot tell), it is recomputed
//! exactly from the same operands ([`fix_ties`]), so a tie is a true
//! tie, and a true tie counts as inside both neighbours. Triangles are
//! two-sided (edge functions all ≥ 0 or all ≤ 0).

use glam::Vec3;

use super::{Ray, SLACK};

/// A ray turned to run along +z ([`Shear::of`]), and the ray: made once
/// per ray, what its triangle tests read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shear {
    /// The axes in their new order: `k[2]` the direction's largest
    /// component, `k[0]`, `k[1]` the next two, swapped where the direction
    /// is negative along `k[2]` (so that the winding is kept).
    k: [usize; 3],
    /// The shear: `-d[kx]/d[kz]`, `-d[ky]/d[kz]` as multipliers of `a[kz]`
    /// (here without the minus) and the scale `1/d[kz]`.
    s: [f64; 3],
    /// The origin, in the new axis order.
    o: [f64; 3],
    /// The ray itself.
    ray: Ray,
}

impl Shear {
    /// The shear of `ray`.
    pub fn of(ray: &Ray) -> Shear {
        let (origin, dir) = (ray.origin, ray.dir);
        let a = dir.abs().to_array();
        // The first largest component, so that equal ones choose alike.
        let kz = if a[0] >= a[1] && a[0] >= a[2] {
            0
        } else if a[1] >= a[2] {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let dz = dir[kz];
        Shear {
            k: [kx, ky, kz],
            s: [dir[kx] / dz, dir[ky] / dz, 1.0 / dz],
            o: [origin[kx], origin[ky], origin[kz]],
            ray: *ray,
        }
    }

    /// The ray sheared.
    pub fn ray(&self) -> &Ray {
        &self.ray
    }

    /// The axis order: which axes become x, y and z.
    pub fn axes(&self) -> [usize; 3] {
        self.k
    }
}

/// A triangle seen from a ray: its vertices' sheared coordinates and its
/// three edge functions (`e[i]` opposite vertex `i`, the doubled signed
/// area of the triangle the ray's point makes with vertex `i`'s edge).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Sheared {
    pub(super) x: [f64; 3],
    pub(super) y: [f64; 3],
    pub(super) z: [f64; 3],
    pub(super) e: [f64; 3],
}

/// Vertices `p` (`p[vertex][axis]`, already in the shear's axis order)
/// seen from the ray of `sh`; an edge function that rounds to zero is
/// recomputed exactly.
#[inline(always)]
pub(super) fn edges(p: [[f64; 3]; 3], sh: &Shear) -> Sheared {
    let mut w = edges_rounded(p, sh);
    if ties(&w.e) {
        fix_ties(&mut w);
    }
    w
}

/// [`edges`] before the ties are recomputed: branch-free, so that four
/// lanes of it run as SIMD instructions.
#[inline(always)]
pub(super) fn edges_rounded(p: [[f64; 3]; 3], sh: &Shear) -> Sheared {
    let mut w = Sheared::default();
    for (i, q) in p.iter().enumerate() {
        let a = [q[0] - sh.o[0], q[1] - sh.o[1], q[2] - sh.o[2]];
        w.x[i] = a[0] - sh.s[0] * a[2];
        w.y[i] = a[1] - sh.s[1] * a[2];
        w.z[i] = sh.s[2] * a[2];
    }
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        w.e[i] = w.x[k] * w.y[j] - w.y[k] * w.x[j];
    }
    w
}

/// Whether an edge function rounded to zero.
#[inline(always)]
pub(super) fn ties(e: &[f64; 3]) -> bool {
    e[0] == 0.0 || e[1] == 0.0 || e[2] == 0.0
}

/// Each edge function that rounded to zero, recomputed exactly: with
/// `p = x_k·y_j` and `q = y_k·x_j` rounded, the difference rounds to zero
/// only where `p = q`, and then `x_k·y_j - y_k·x_j` is exactly the
/// difference of the two products' rounding errors, each exact by a fused
/// multiply-add; their rounded difference has the true sign. The
/// neighbour across the edge computes the same products in the other
/// order, so its value is this one negated.
#[cold]
#[inline(never)]
pub(super) fn fix_ties(w: &mut Sheared) {
    for i in 0..3 {
        if w.e[i] == 0.0 {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let p = w.x[k] * w.y[j];
            let q = w.y[k] * w.x[j];
            w.e[i] = w.x[k].mul_add(w.y[j], -p) - w.y[k].mul_add(w.x[j], -q);
        }
    }
}

/// The edge functions' verdict: the ray meets the triangle (no two of
/// different sign, and a nonzero, finite determinant, their sum).
#[inline(always)]
pub(super) fn inside(e: &[f64; 3]) -> bool {
    let neg = e[0] < 0.0 || e[1] < 0.0 || e[2] < 0.0;
    let pos = e[0] > 0.0 || e[1] > 0.0 || e[2] > 0.0;
    let det = e[0] + e[1] + e[2];
    !(neg && pos) && det != 0.0 && det.is_finite()
}

/// `t` of a hit (`inside`) and a bound on its rounding error: the
/// first-order forward error of `Σ e·z / Σ e`, each vertex's sheared
/// coordinates within `4u` of their operands' magnitudes, each product and
/// sum rounding once, the whole doubled.
#[inline(always)]
pub(super) fn t_and_error(w: &Sheared, sh: &Shear) -> (f64, f64) {
    const U: f64 = f64::EPSILON / 2.0;
    let det = w.e[0] + w.e[1] + w.e[2];
    let t = (w.e[0] * w.z[0] + w.e[1] * w.z[1] + w.e[2] * w.z[2]) / det;
    // Magnitudes of the sheared coordinates' operands.
    let mx = |i: usize| w.x[i].abs() + (sh.s[0] * w.z[i] / sh.s[2]).abs();
    let my = |i: usize| w.y[i].abs() + (sh.s[1] * w.z[i] / sh.s[2]).abs();
    let (mut de, mut dt, mut ez) = (0.0, 0.0, 0.0);
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let dei = 12.0 * U * (mx(k) * my(j) + my(k) * mx(j));
        de += dei + 2.0 * U * w.e[i].abs();
        dt += dei * w.z[i].abs() + 4.0 * U * (w.e[i] * w.z[i]).abs();
        ez += (w.e[i] * w.z[i]).abs();
    }
    let err = 2.0 * ((dt + 3.0 * U * ez + t.abs() * de) / det.abs() + 2.0 * U * t.abs());
    (t, err)
}

/// The `t` a hit reports: the edge functions' `t` where its error is
/// certainly within a quarter of the culls' [`SLACK`], else `t` from the
/// triangle's plane.
///
/// For a sliver triangle (two nearly parallel edges), or a ray nearly in
/// its plane, the edge functions are small beside the products they are
/// the differences of, and `t`'s relative error grows with that ratio: as
/// large as the widening of every cull, so a leaf box or node whose entry
/// lies just before a vertex could be culled while a triangle in it
/// reports a hit a hair closer than the one kept. Where the bound of
/// [`t_and_error`] is too large, `t` comes from the plane, `-(n·s)/(n·d)`
/// with `n = e1×e2` and `s = o - v0`: the edges come from `f32` vertices,
/// so `n` is computed nearly exactly and the error is `u/cos θ` (θ the
/// ray's angle to the normal), free of the sliver factor. A ray within
/// about 0.05° of a triangle's plane can still err beyond the slack
/// (docs/tree.md, "Culls and the triangle test").
///
/// Every path calls this with the same operands, so all report the same
/// `t`, bit for bit.
#[inline]
pub(super) fn settle_t(v: [Vec3; 3], sh: &Shear, t: f64, err: f64) -> f64 {
    if err <= 0.25 * SLACK * t.abs() || !err.is_finite() {
        return t;
    }
    let v0 = v[0].as_dvec3();
    let e1 = v[1].as_dvec3() - v0;
    let e2 = v[2].as_dvec3() - v0;
    let n = e1.cross(e2);
    let tp = -n.dot(sh.ray.origin - v0) / n.dot(sh.ray.dir);
    if tp.is_finite() { tp } else { t }
}

/// Triangle `v` (collapsed to a point if degenerate) against the ray of
/// `sh`: whether its line meets the triangle ([`inside`]), and the hit in
/// `[tmin, tmax]` if any, `t` and the barycentrics of vertices 1 and 2.
#[inline(always)]
pub(super) fn intersect(
    v: [Vec3; 3],
    sh: &Shear,
    tmin: f64,
    tmax: f64,
) -> (bool, Option<(f64, f64, f64)>) {
    let p = v.map(|q| sh.k.map(|a| q[a] as f64));
    let w = edges(p, sh);
    (inside(&w.e), hit(&w, v, sh, tmin, tmax))
}

/// The hit the edge functions `w` of triangle `v` give, if any, in
/// `[tmin, tmax]`; shared by the scalar test and the four-lane groups.
#[inline(always)]
pub(super) fn hit(
    w: &Sheared,
    v: [Vec3; 3],
    sh: &Shear,
    tmin: f64,
    tmax: f64,
) -> Option<(f64, f64, f64)> {
    if !inside(&w.e) {
        return None;
    }
    let (t, err) = t_and_error(w, sh);
    let t = settle_t(v, sh, t, err);
    // A hit has a finite t: with a direction so short (1e-320) that the
    // distance in its units overflows f64, t is infinite and no hit.
    if !(t >= tmin && t <= tmax && t.is_finite()) {
        return None;
    }
    let det = w.e[0] + w.e[1] + w.e[2];
    Some((t, w.e[1] / det, w.e[2] / det))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn shear(o: DVec3, d: DVec3) -> Shear {
        Shear::of(&Ray::new(o, d))
    }

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [Vec3; 3] {
        [a, b, c].map(Vec3::from_array)
    }

    fn cast(v: [Vec3; 3], o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64, f64)> {
        let sh = shear(DVec3::from_array(o), DVec3::from_array(d));
        intersect(v, &sh, 0.0, f64::INFINITY).1
    }

    #[test]
    fn the_largest_axis_becomes_z_and_a_negative_one_swaps_the_others() {
        let sh = shear(DVec3::ZERO, DVec3::new(0.5, -3.0, 1.0));
        assert_eq!(sh.axes(), [0, 2, 1]);
        let sh = shear(DVec3::ZERO, DVec3::new(0.5, 3.0, 1.0));
        assert_eq!(sh.axes(), [2, 0, 1]);
        // Ties go to the first axis.
        assert_eq!(shear(DVec3::ZERO, DVec3::ONE).axes(), [1, 2, 0]);
    }

    #[test]
    fn a_hit_has_its_distance_and_weights_from_either_side() {
        let v = tri([0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0]);
        let (t, u, w) = cast(v, [0.25, 0.5, 0.0], [0.0, 0.0, 1.0]).expect("hit");
        assert_eq!((t, u, w), (2.0, 0.25, 0.5));
        let (t, u, w) = cast(v, [0.25, 0.5, 4.0], [0.0, 0.0, -0.5]).expect("back face");
        assert_eq!((t, u, w), (4.0, 0.25, 0.5));
        assert_eq!(cast(v, [0.25, 0.5, 3.0], [0.0, 0.0, 1.0]), None, "behind");
        assert_eq!(cast(v, [0.75, 0.5, 0.0], [0.0, 0.0, 1.0]), None, "beside");
    }

    #[test]
    fn a_ray_through_a_shared_edge_meets_one_side_or_both() {
        // Two triangles sharing the edge from a to b, rays through points
        // of the edge nudged by a few ulps either way: never a miss of
        // both, and both sides do occur.
        let (a, b) = ([0.1f32, 0.2, 0.3], [0.7f32, 1.3, -0.4]);
        let left = tri(a, b, [-1.0, 1.0, 0.2]);
        let right = tri(b, a, [1.5, -0.5, 0.1]);
        let o = [0.3, -0.2, 5.0];
        let (mut only_left, mut only_right) = (0, 0);
        for step in 1..200 {
            let f = step as f64 / 200.0;
            for nudge in -3..=3 {
                let p: [f64; 3] = std::array::from_fn(|i| {
                    a[i] as f64 + f * (b[i] as f64 - a[i] as f64) + nudge as f64 * 1e-15
                });
                let d = std::array::from_fn(|i| p[i] - o[i]);
                let (l, r) = (cast(left, o, d).is_some(), cast(right, o, d).is_some());
                assert!(l || r, "leak at {f} {nudge}");
                only_left += (l && !r) as u32;
                only_right += (r && !l) as u32;
            }
        }
        assert!(only_left > 0 && only_right > 0, "{only_left} {only_right}");
    }

    #[test]
    fn a_tie_is_recomputed_exactly() {
        let eps = f64::EPSILON;
        let mut w = Sheared {
            x: [0.0, 1.0, 1.0 + eps],
            y: [0.0, 1.0 + eps, 1.0 + 2.0 * eps],
            ..Sheared::default()
        };
        // e[0] from vertices 1 and 2: (1+ε)(1+ε) - (1+2ε)·1 = ε², which
        // rounds to zero as a difference of rounded products.
        let (x, y) = (w.x, w.y);
        w.e[0] = x[2] * y[1] - y[2] * x[1];
        assert_eq!(w.e[0], 0.0);
        fix_ties(&mut w);
        assert_eq!(w.e[0], eps * eps);
    }

    #[test]
    fn zero_area_and_zero_direction_miss() {
        let p = [1.0f32, 1.0, 1.0];
        assert_eq!(cast(tri(p, p, p), [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]), None);
        let v = tri([0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0]);
        assert_eq!(cast(v, [0.25, 0.25, 0.0], [0.0, 0.0, 0.0]), None);
    }
}
