//! Packets of coherent rays on the host (Wald, Slusallek, Benthin &
//! Wagner, "Interactive Rendering with Coherent Ray Tracing", 2001; the
//! host side of the SPE's packets in `crate::cast`): up to [`PACKET_RAYS`]
//! rays whose directions agree in sign share one traversal of the
//! [`Tracer`]'s tree. A node is read once for all of them, and its step —
//! where each ray leaves the near child and enters the far one — runs over
//! the rays' lanes at once: fixed-width lanes of `f64` that the compiler
//! turns into SIMD instructions (four lanes an instruction in the AVX2
//! build the tracer picks at run time, two in the portable SSE2 one), as
//! the four-lane triangle tests ([`super::lanes`]) are.
//!
//! Each ray keeps its own interval and its own active bit: it is active at
//! a node exactly when its own walk visits that node with that interval
//! (the same near-first order, the same pop bound), and it tests a leaf as
//! its own walk does (the box of the leaf's triangles, then
//! `Tracer::test_triangles`). So every ray answers as the
//! single-ray walk does, bit for bit, with the same nodes visited and
//! triangles tested (tests/tracer_packets.rs). A packet whose directions
//! differ in sign on some axis, or one of whose rays has a zero or
//! subnormal direction component, is traced ray by ray.

use std::mem::MaybeUninit;

use super::SLACK;
use super::{BihConfig, Hit, Ray, RayStats, Shear, Tracer, closer};
use crate::aabb::Aabb;

/// The most rays a host packet holds: a 4 × 4 block of pixels.
pub const PACKET_RAYS: usize = 16;
const N: usize = PACKET_RAYS;

/// A node kept for later, the rays that will enter it and their
/// intervals there (each ray's entry checked against its best hit when
/// the node is taken, as a single ray's stack entry is).
#[derive(Clone, Copy)]
struct Kept {
    node: u32,
    mask: u32,
    tn: [f64; N],
    tf: [f64; N],
}

impl Tracer<'_> {
    /// The closest hit of each of `rays` (at most [`PACKET_RAYS`]) in
    /// `hits`, and what each ray cost in `stats` (added to): traced as one
    /// packet when their directions agree in sign and have no zero
    /// component, else ray by ray. Either way every answer and every count
    /// is the single-ray walk's ([`Tracer::closest`]).
    pub fn closest_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>], stats: &mut [RayStats]) {
        assert!(rays.len() <= N, "{} rays: a packet holds {N}", rays.len());
        assert!(hits.len() == rays.len() && stats.len() == rays.len());
        if !self.packet(rays, hits, stats, 0) {
            for ((ray, hit), st) in rays.iter().zip(hits).zip(stats) {
                *hit = self.closest(ray, st);
            }
        }
    }

    /// `rays` traced as one packet, if they are coherent (see
    /// `packet_body`); else `false`, and nothing written. `hand_over`:
    /// see `packet_body` (0 for exact counts).
    #[inline(always)]
    pub(super) fn packet(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        stats: &mut [RayStats],
        hand_over: u32,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the CPU has AVX2 (checked when the tracer was made).
            return unsafe { self.packet_avx2(rays, hits, stats, hand_over) };
        }
        self.packet_portable(rays, hits, stats, hand_over)
    }

    /// Every ray's closest hit, the rays taken [`PACKET_RAYS`] at a time
    /// as packets ([`Tracer::closest_packet`]); what they cost added to
    /// `stats`. Consecutive rays should be neighbours (a camera's rays in
    /// 4 × 4 blocks: `crate::render::block_order`) for the packets to pay.
    pub fn closest_all(&self, rays: &[Ray], stats: &mut RayStats) -> Vec<Option<Hit>> {
        let mut hits = Vec::with_capacity(rays.len());
        let (mut chunk, mut each) = ([None; N], [RayStats::default(); N]);
        for r in rays.chunks(N) {
            let (chunk, each) = (&mut chunk[..r.len()], &mut each[..r.len()]);
            each.fill(RayStats::default());
            self.closest_packet(r, chunk, each);
            hits.extend_from_slice(chunk);
            for s in each.iter() {
                *stats += *s;
            }
        }
        hits
    }

    /// The portable build of the packet loop (never inlined: see
    /// `Tracer::traverse_portable`).
    #[inline(never)]
    fn packet_portable(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        stats: &mut [RayStats],
        hand_over: u32,
    ) -> bool {
        self.packet_body(rays, hits, stats, hand_over)
    }

    /// The packet loop compiled for AVX2: four lanes an instruction.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    fn packet_avx2(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        stats: &mut [RayStats],
        hand_over: u32,
    ) -> bool {
        self.packet_body(rays, hits, stats, hand_over)
    }

    /// One packet's traversal, if its rays are coherent (else `false`,
    /// and nothing written): their directions agree in sign on every axis
    /// (every ray has the same near child at every node) and have no zero
    /// or subnormal component (every reciprocal is finite, so the
    /// branch-free slab test holds for all of them), and their origins and
    /// ends are numbers (so that no slab distance is NaN: see below).
    ///
    /// `hand_over` > 0: at a node where at most that many rays are
    /// active, each of them leaves the packet and finishes alone by the
    /// fast walk, from the root up to its best hit so far (the same hits;
    /// the counts then mean nothing). Measured slower: docs/tradeoff.md.
    #[inline(always)]
    fn packet_body(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        stats: &mut [RayStats],
        hand_over: u32,
    ) -> bool {
        if rays.is_empty() {
            return false;
        }
        // Lanes by axis: the step at a node reads one axis of every ray.
        // Lanes past the packet's rays copy its last ray and stay
        // inactive. Filled and checked lane-wise, so that the reciprocals
        // and the checks are SIMD instructions too.
        let (mut o, mut d) = ([[0.0f64; N]; 3], [[1.0f64; N]; 3]);
        let (mut tmin, mut best_t) = ([0.0f64; N], [0.0f64; N]);
        for i in 0..N {
            let ray = &rays[i.min(rays.len() - 1)];
            for a in 0..3 {
                (o[a][i], d[a][i]) = (ray.origin[a], ray.dir[a]);
            }
            (tmin[i], best_t[i]) = (ray.tmin, ray.tmax);
        }
        let inv = d.map(|d| d.map(|d| 1.0 / d));
        let neg = [0, 1, 2].map(|a| d[a][0].is_sign_negative());
        let mut coherent = true;
        for a in 0..3 {
            for i in 0..N {
                coherent &= inv[a][i].is_finite()
                    & (d[a][i].is_sign_negative() == neg[a])
                    & o[a][i].is_finite();
            }
        }
        for i in 0..N {
            coherent &= !tmin[i].is_nan() & !best_t[i].is_nan();
        }
        if !coherent {
            return false;
        }
        // Each ray's shear for the triangle tests, made once.
        let shears: [Shear; N] = std::array::from_fn(|i| Shear::of(&rays[i.min(rays.len() - 1)]));
        // `root_interval`'s interval, lane-wise: the branch-free slab test
        // gives the careful one's for a finite reciprocal.
        let b = &self.bih.bounds;
        let (mut tn, mut tf) = clip_lanes(b, &o, &inv, &tmin, &best_t);
        let mut mask = 0u32;
        for i in 0..rays.len() {
            stats[i].rays += 1;
            hits[i] = None;
            mask |= ((tn[i] <= tf[i]) as u32) << i;
        }
        // Not zeroed per packet: an entry is read only after a push.
        let mut stack =
            [const { MaybeUninit::<Kept>::uninit() }; BihConfig::MAX_SUPPORTED_DEPTH as usize + 2];
        let mut sp = 0usize;
        let mut node = 0u32;
        // Nodes each ray visits, counted in lanes.
        let mut visits = [0u32; N];
        // Rays handed over to the fast walk.
        let mut gone = 0u32;
        while mask != 0 {
            for (i, v) in visits.iter_mut().enumerate() {
                *v += mask >> i & 1;
            }
            let nd = &self.nodes[node as usize];
            let descended = if mask.count_ones() <= hand_over {
                let mut m = mask;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let alone = Ray {
                        tmax: best_t[i],
                        ..rays[i]
                    };
                    if let Some(h) = self.closest_fast(&alone)
                        && closer(h.t, h.prim, hits[i])
                    {
                        hits[i] = Some(h);
                    }
                }
                gone |= mask;
                false
            } else if nd.is_leaf() {
                // Each ray's test of the box of the leaf's triangles, as
                // `Tracer::test_leaf` makes it (its slab distances are never
                // NaN here: every reciprocal is finite), then the triangles
                // of the rays that meet it before their best hit.
                let (first, count) = nd.leaf_range();
                self.prefetch_slots(first, count);
                let bx = &self.leaf_boxes[nd.leaf_number() as usize];
                let (b0, b1) = clip_lanes(bx, &o, &inv, &tmin, &best_t);
                let mut meets = 0u32;
                for i in 0..N {
                    meets |= ((b0[i] <= b1[i]) as u32) << i;
                }
                let mut m = meets & mask;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let mut t = best_t[i];
                    self.test_triangles::<false>(
                        node,
                        &shears[i],
                        &mut hits[i],
                        &mut t,
                        &mut stats[i],
                    );
                    best_t[i] = t;
                }
                false
            } else {
                // Every lane's step, as `Tracer::traverse_body` takes it
                // for one ray: the plane where the ray leaves the near
                // child and the one where it enters the far child.
                let a = nd.axis();
                let [cl, cr] = nd.clip();
                let (exit_plane, enter_plane) = if neg[a] { (cr, cl) } else { (cl, cr) };
                let (exit_plane, enter_plane) = (exit_plane as f64, enter_plane as f64);
                let (mut near_tf, mut far_tn) = ([0.0f64; N], [0.0f64; N]);
                let (mut go_near, mut go_far) = (0u32, 0u32);
                for i in 0..N {
                    let exit = up((exit_plane - o[a][i]) * inv[a][i]);
                    let enter = down((enter_plane - o[a][i]) * inv[a][i]);
                    near_tf[i] = if exit < tf[i] { exit } else { tf[i] };
                    far_tn[i] = if enter > tn[i] { enter } else { tn[i] };
                    go_near |= ((tn[i] <= near_tf[i]) as u32) << i;
                    go_far |= ((far_tn[i] <= tf[i]) as u32) << i;
                }
                let (go_near, go_far) = (go_near & mask, go_far & mask);
                let left = nd.left_child();
                let (near, far) = if neg[a] {
                    (left + 1, left)
                } else {
                    (left, left + 1)
                };
                if go_near != 0 {
                    if go_far != 0 {
                        // A ray that enters only the far child does so
                        // after the near child's rays, where its own walk
                        // goes at once: nothing of its changes in between,
                        // and its entry passes the check (a ray's interval
                        // never reaches beyond its best hit).
                        stack[sp].write(Kept {
                            node: far,
                            mask: go_far,
                            tn: far_tn,
                            tf,
                        });
                        sp += 1;
                    }
                    (node, mask, tf) = (near, go_near, near_tf);
                    true
                } else if go_far != 0 {
                    (node, mask, tn) = (far, go_far, far_tn);
                    true
                } else {
                    false
                }
            };
            if descended {
                continue;
            }
            // Take the next kept node that some ray still needs: the rays
            // whose entry is not beyond their best hit, cut there.
            mask = 0;
            while mask == 0 && sp > 0 {
                sp -= 1;
                // SAFETY: entries below the stack pointer were all written
                // by a push (the pointer only grows by a write).
                let k = unsafe { stack[sp].assume_init_ref() };
                let mut entering = 0u32;
                for i in 0..N {
                    let bound = up(best_t[i]);
                    entering |= ((k.tn[i] <= bound) as u32) << i;
                    tf[i] = min(k.tf[i], bound);
                }
                (node, mask, tn) = (k.node, k.mask & entering & !gone, k.tn);
            }
        }
        for (st, v) in stats.iter_mut().zip(visits) {
            st.nodes_visited += v as u64;
        }
        true
    }
}

/// Each lane's `clip_range_finite` of box `b`: its entry and exit,
/// widened, cut to `[t0, t1]`.
#[inline(always)]
fn clip_lanes(
    b: &Aabb,
    o: &[[f64; N]; 3],
    inv: &[[f64; N]; 3],
    t0: &[f64; N],
    t1: &[f64; N],
) -> ([f64; N], [f64; N]) {
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let (mut b0, mut b1) = ([0.0; N], [0.0; N]);
    for i in 0..N {
        let (mut near, mut far) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            let ta = (lo[a] - o[a][i]) * inv[a][i];
            let tb = (hi[a] - o[a][i]) * inv[a][i];
            near = max(near, min(ta, tb));
            far = min(far, max(ta, tb));
        }
        b0[i] = max(t0[i], down(near));
        b1[i] = min(t1[i], up(far));
    }
    (b0, b1)
}

// The packet's arithmetic never meets a NaN: every reciprocal is finite
// and nonzero, planes and origins are finite ([`coherent`]), so a slab
// distance is a number or ±inf. Its maximum and minimum are then plain comparisons (one
// SIMD instruction, where `f64::max` also handles NaN), and they pick the
// same number as `f64::max`/`min` (at most the sign of a zero differs,
// which no comparison below sees).

#[inline(always)]
fn max(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

#[inline(always)]
fn min(a: f64, b: f64) -> f64 {
    if a < b { a } else { b }
}

/// `widen_up` of the single-ray walk, for numbers.
#[inline(always)]
fn up(t: f64) -> f64 {
    max(t * (1.0 + SLACK), t * (1.0 - SLACK))
}

/// `widen_down` of the single-ray walk, for numbers.
#[inline(always)]
fn down(t: f64) -> f64 {
    min(t * (1.0 + SLACK), t * (1.0 - SLACK))
}
