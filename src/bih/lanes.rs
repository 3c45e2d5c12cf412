//! Four ray/triangle tests at once: the triangles of the triangle order in
//! groups of four slots, stored lane by lane (`f32`, 144 bytes a group), so
//! that the compiler can run the watertight test on four triangles per
//! instruction (AVX: four `f64` lanes; SSE2: two). Every lane computes
//! exactly what [`super::traverse::intersect_triangle`] computes
//! ([`super::watertight::edges`] on the same operands), so the edge
//! functions are bitwise the scalar test's; the `t` a hit reports and its
//! range test are the scalar test's too ([`super::watertight::hit`],
//! applied by the caller to the lanes the mask keeps).

use glam::Vec3;

use super::watertight::{self, Shear, Sheared};

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
/// `t`), and per lane the triangle as the ray sees it.
pub(super) struct Found {
    pub mask: u32,
    pub w: [Sheared; 4],
}

/// The watertight test on the four triangles of `g` against the ray of
/// `sh`: each lane reads its vertices' components in the shear's axis
/// order and runs [`watertight::edges`], the scalar test's arithmetic
/// (the lanes' edge functions first, then any tie of theirs).
#[inline(always)]
pub(super) fn intersect4(g: &Group, sh: &Shear) -> Found {
    let [kx, ky, kz] = sh.axes();
    let mut f = Found {
        mask: 0,
        w: [Sheared::default(); 4],
    };
    // One lane per iteration, indexing the group and the output by lane.
    #[allow(clippy::needless_range_loop)]
    for l in 0..4 {
        let vertex = |i: usize| {
            [
                g.v[i][kx][l] as f64,
                g.v[i][ky][l] as f64,
                g.v[i][kz][l] as f64,
            ]
        };
        f.w[l] = watertight::edges_rounded([vertex(0), vertex(1), vertex(2)], sh);
    }
    // The ties recomputed, as `watertight::edges` does, after the lanes.
    for (l, w) in f.w.iter_mut().enumerate() {
        if watertight::ties(&w.e) {
            watertight::fix_ties(w);
        }
        f.mask |= (watertight::inside(&w.e) as u32) << l;
    }
    f
}
