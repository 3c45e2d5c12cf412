//! Four ray/triangle tests at once: the triangles of the triangle order in
//! groups of four slots, stored lane by lane (`f32`, 144 bytes a group), so
//! that the compiler runs Möller–Trumbore on four triangles per instruction
//! (AVX: four `f64` lanes; SSE2: two). Every lane computes exactly what
//! [`super::traverse::intersect_triangle`] computes, operation for
//! operation in the same order, so Möller–Trumbore's `t` and `det` are
//! bitwise the scalar test's; only the branches become lane masks. The
//! `t` a hit reports and its range test are the scalar test's too
//! ([`super::traverse::settle_t`], applied by the caller to the lanes the
//! mask keeps).

use glam::Vec3;

/// Slots `4i .. 4i + 4` of the triangle order: `v[vertex][axis][lane]`.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
pub(super) struct Group {
    v: [[[f32; 4]; 3]; 3],
}

impl Group {
    /// Puts triangle `v` (already collapsed if degenerate) in lane `lane`;
    /// lanes never set hold zero triangles, which are never hit.
    pub(super) fn set(&mut self, lane: usize, v: [Vec3; 3]) {
        for (i, p) in v.iter().enumerate() {
            for a in 0..3 {
                self.v[i][a][lane] = p[a];
            }
        }
    }

    /// The triangle in lane `lane`, as [`Group::set`] put it.
    pub(super) fn get(&self, lane: usize) -> [Vec3; 3] {
        [0, 1, 2].map(|i| Vec3::new(self.v[i][0][lane], self.v[i][1][lane], self.v[i][2][lane]))
    }
}

/// What the four tests found: a bit per lane whose line meets the
/// triangle (the range of `t` is tested by the caller, on the settled
/// `t`), and per lane Möller–Trumbore's `t` and determinant and the
/// barycentrics' numerators and denominator.
pub(super) struct Found {
    pub mask: u32,
    pub t: [f64; 4],
    pub det: [f64; 4],
    pub u: [f64; 4],
    pub v: [f64; 4],
    pub adet: [f64; 4],
}

/// Möller–Trumbore on the four triangles of `g` against the ray `o + t·d`.
#[inline(always)]
pub(super) fn intersect4(g: &Group, o: [f64; 3], d: [f64; 3]) -> Found {
    let mut f = Found {
        mask: 0,
        t: [0.0; 4],
        det: [0.0; 4],
        u: [0.0; 4],
        v: [0.0; 4],
        adet: [0.0; 4],
    };
    let mut hit = [false; 4];
    // One lane per iteration, indexing the group and five outputs by lane.
    #[allow(clippy::needless_range_loop)]
    for l in 0..4 {
        let p0 = each(|a| g.v[0][a][l] as f64);
        let e1 = each(|a| g.v[1][a][l] as f64 - p0[a]);
        let e2 = each(|a| g.v[2][a][l] as f64 - p0[a]);
        let p = cross(d, e2);
        let det = dot(e1, p);
        let sign = if det < 0.0 { -1.0 } else { 1.0 };
        let adet = det.abs();
        let s = each(|a| o[a] - p0[a]);
        let u = dot(s, p) * sign;
        let q = cross(s, e1);
        let v = dot(d, q) * sign;
        let t = dot(e2, q) * (1.0 / det);
        hit[l] =
            det != 0.0 && det.is_finite() && u >= 0.0 && u <= adet && v >= 0.0 && u + v <= adet;
        (f.t[l], f.det[l], f.u[l], f.v[l], f.adet[l]) = (t, det, u, v, adet);
    }
    for (l, h) in hit.iter().enumerate() {
        f.mask |= (*h as u32) << l;
    }
    f
}

/// `[f(0), f(1), f(2)]`, written out: `array::map` is sometimes left as
/// a call where the traversal that inlines this test grows large (the fast
/// walk ran at half its speed so, measured).
#[inline(always)]
fn each(f: impl Fn(usize) -> f64) -> [f64; 3] {
    [f(0), f(1), f(2)]
}

/// glam's `DVec3::cross`, term for term.
#[inline(always)]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - b[1] * a[2],
        a[2] * b[0] - b[2] * a[0],
        a[0] * b[1] - b[0] * a[1],
    ]
}

/// glam's `DVec3::dot`, term for term.
#[inline(always)]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] * b[0]) + (a[1] * b[1]) + (a[2] * b[2])
}
