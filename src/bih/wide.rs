//! The host tracer's fast walk: single precision that never culls what
//! the exact test keeps (Ize, "Robust BVH Ray Traversal — revised",
//! JCGT 2013: widen each slab distance by a bound on its rounding error).
//!
//! The tracer's tree, collapsed four children to a node: each BIH node's
//! two children, the larger of them opened while a node has fewer than
//! four (Wald, Benthin & Boulos, "Getting rid of packets", 2008: the
//! four-wide node of a binary tree), and each child given the box of the
//! triangles beneath it, in `f32`, which the BIH's planes only bound from
//! two sides. A ray tests a node's four boxes in one pass of `f32` lanes;
//! a leaf is the tracer's leaf, its triangles tested exactly
//! ([`Tracer::test_triangles`], `f64`). So the walk tests every triangle a
//! ray can hit before its best hit, and reports the exact walk's hit, bit
//! for bit (tests/tracer_fast.rs); the nodes it visits are its own, and
//! what quality reports stays the exact walk's counts.
//!
//! Why the widening holds. The box planes `c` are `f32` (vertex
//! coordinates), exact. The ray's origin `o` and reciprocal `1/d` are
//! rounded to `f32` (`u = 2⁻²⁴`), then `t = (c − o)·(1/d)` takes two
//! `f32` roundings: the computed `t'` is within `3.01u·|t| + 1.01u·|o|·|1/d|`
//! of the true `t`. Each entry is lowered, and each exit raised, by
//! [`REL`]`·|t'|` (`8u`) plus `4u·|o|·|1/d|` plus [`TINY`] (the absolute
//! error of a subnormal result), the widening's own roundings included:
//! twice the bound. A hit the exact test finds lies in its triangle's box
//! within that test's error (`SLACK / 4` relative, `watertight`), far inside
//! the widening. The walk stays in `f32`'s range: a ray whose `|o|`,
//! `|1/d|` or `(M + |o|)·|1/d|` (M the largest coordinate, itself below
//! the limit) reaches [`F32_LIMIT`], or whose `1/d` is not a normal `f32`,
//! takes the exact walk.

use std::mem::MaybeUninit;

use glam::DVec3;

use super::{BihConfig, BihNode, Hit, PACKET_RAYS, Ray, RayStats, Shear, Tracer, prefetch};
use crate::aabb::Aabb;

/// A child slot that holds nothing.
const EMPTY: u32 = u32::MAX;
/// A child that is a leaf of the tracer's tree: the bit, and the leaf's
/// triangle count in the low bits.
const LEAF: u32 = 1 << 31;
const _: () = assert!(size_of::<WideNode>() == 128);
/// `f32`'s unit roundoff.
const U: f32 = f32::EPSILON / 2.0;
/// Relative widening of every slab distance.
const REL: f32 = 8.0 * U;
/// Absolute widening of every slab distance: covers subnormal results.
const TINY: f32 = 1e-36;
/// Past this, a slab distance could overflow `f32`: the exact walk.
const F32_LIMIT: f64 = 1e30;
/// Deepest stack the walk needs: each node pushes at most three children.
const STACK: usize = 3 * BihConfig::MAX_SUPPORTED_DEPTH as usize + 4;

/// Four children: their boxes lane by lane, and what each is.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct WideNode {
    lo: [[f32; 4]; 3],
    hi: [[f32; 4]; 3],
    /// A wide node's index, `LEAF | the leaf's triangle count`, or
    /// `EMPTY`.
    child: [u32; 4],
    /// A leaf child's first slot in the padded triangle order.
    first: [u32; 4],
}

impl WideNode {
    /// A bit per slot that holds a child.
    #[inline(always)]
    fn valid(&self) -> u32 {
        let mut m = 0;
        for k in 0..4 {
            m |= ((self.child[k] != EMPTY) as u32) << k;
        }
        m
    }

    const NONE: WideNode = WideNode {
        lo: [[0.0; 4]; 3],
        hi: [[0.0; 4]; 3],
        child: [EMPTY; 4],
        first: [0; 4],
    };
}

/// The four-wide tree over the tracer's `nodes` (children after parents),
/// whose leaves' boxes are `leaf_boxes` (by leaf number).
pub(super) fn collapse(nodes: &[BihNode], leaf_boxes: &[Aabb]) -> Vec<WideNode> {
    // The box of every node's triangles, children before parents.
    let mut boxes = vec![Aabb::EMPTY; nodes.len()];
    for id in (0..nodes.len()).rev() {
        let nd = nodes[id];
        boxes[id] = if nd.is_leaf() {
            if nd.leaf_range().1 == 0 {
                Aabb::EMPTY
            } else {
                leaf_boxes[nd.leaf_number() as usize]
            }
        } else {
            let l = nd.left_child() as usize;
            boxes[l].union(boxes[l + 1])
        };
    }
    let mut wide = vec![WideNode::NONE];
    // (a BIH node, the wide node made of its children)
    let mut todo = vec![(0u32, 0u32)];
    while let Some((id, at)) = todo.pop() {
        let nd = nodes[id as usize];
        let mut kids: Vec<u32> = if nd.is_leaf() {
            vec![id]
        } else {
            vec![nd.left_child(), nd.left_child() + 1]
        };
        kids.retain(|&k| !boxes[k as usize].is_empty());
        // Open the inner child of largest area while there is room.
        while kids.len() < 4 {
            let inner = (0..kids.len())
                .filter(|&i| !nodes[kids[i] as usize].is_leaf())
                .max_by(|&i, &j| {
                    let area = |k: u32| boxes[k as usize].surface_area();
                    area(kids[i]).total_cmp(&area(kids[j]))
                });
            let Some(i) = inner else { break };
            let l = nodes[kids[i] as usize].left_child();
            kids.remove(i);
            kids.extend(
                [l, l + 1]
                    .into_iter()
                    .filter(|&k| !boxes[k as usize].is_empty()),
            );
        }
        let mut w = WideNode::NONE;
        for (slot, &k) in kids.iter().enumerate() {
            let b = boxes[k as usize];
            for a in 0..3 {
                (w.lo[a][slot], w.hi[a][slot]) = (b.min[a], b.max[a]);
            }
            let nd = nodes[k as usize];
            w.child[slot] = if nd.is_leaf() {
                let (first, count) = nd.leaf_range();
                w.first[slot] = first;
                LEAF | count
            } else {
                let next = wide.len() as u32;
                wide.push(WideNode::NONE);
                todo.push((k, next));
                next
            };
        }
        wide[at as usize] = w;
    }
    wide
}

/// The nearest `f32` at or above `x`.
#[inline(always)]
fn up32(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

/// The nearest `f32` at or below `x`.
#[inline(always)]
fn down32(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) > x { f.next_down() } else { f }
}

impl Tracer<'_> {
    /// The closest hit in `[tmin, tmax]`, ties to the lower triangle id:
    /// [`Tracer::closest`]'s answer, bit for bit, by the fast walk (this
    /// module), or by the exact walk for a ray outside its range. No
    /// counts: what a ray costs is the exact walk's to say.
    pub fn closest_fast(&self, ray: &Ray) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the CPU has AVX2 (checked when the tracer was made).
            return unsafe { self.fast_avx2(ray) };
        }
        self.fast_portable(ray)
    }

    /// Every ray's closest hit, the fastest way the tracer has: sixteen
    /// consecutive rays as a packet where their directions agree in sign
    /// ([`Tracer::closest_packet`], which beats the fast walk on camera
    /// rays), else ray by ray by [`Tracer::closest_fast`]. The same hits
    /// as [`Tracer::closest_all`], bit for bit; no counts.
    pub fn hits(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        let mut hits = Vec::with_capacity(rays.len());
        let (mut chunk, mut each) = ([None; PACKET_RAYS], [RayStats::default(); PACKET_RAYS]);
        for r in rays.chunks(PACKET_RAYS) {
            let chunk = &mut chunk[..r.len()];
            if self.packet(r, chunk, &mut each[..r.len()], self.hand_over) {
                hits.extend_from_slice(chunk);
            } else {
                hits.extend(r.iter().map(|ray| self.closest_fast(ray)));
            }
        }
        hits
    }

    /// Whether the fast walk takes `ray` (its numbers stay in `f32`'s
    /// range: see the module's notes); else [`Tracer::closest_fast`] is
    /// the exact walk.
    pub fn fast_walk_takes(&self, ray: &Ray) -> bool {
        let inv = DVec3::ONE / ray.dir;
        let o = ray.origin.abs();
        let reach = (DVec3::splat(self.largest) + o) * inv.abs();
        // `1/d` a normal f32 (its rounding relative), and the box, the
        // origin, `1/d` and every distance within `F32_LIMIT`.
        let normal = inv.abs().cmpge(DVec3::splat(f32::MIN_POSITIVE as f64));
        let limit = DVec3::splat(F32_LIMIT);
        normal.all()
            && inv.abs().cmplt(limit).all()
            && o.cmplt(limit).all()
            && self.largest < F32_LIMIT
            && reach.max_element() < F32_LIMIT
            && !ray.tmin.is_nan()
            && !ray.tmax.is_nan()
    }

    /// The portable build of the walk (never inlined: see
    /// `Tracer::traverse_portable`).
    #[inline(never)]
    fn fast_portable(&self, ray: &Ray) -> Option<Hit> {
        self.fast_body(ray)
    }

    /// The walk compiled for AVX2; chosen at run time.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    fn fast_avx2(&self, ray: &Ray) -> Option<Hit> {
        self.fast_body(ray)
    }

    /// Asks for the memory a child will read: a wide node's two lines,
    /// or a leaf's first triangle group.
    #[inline(always)]
    fn prefetch_child(&self, child: u32, first: u32) {
        if child & LEAF != 0 {
            self.prefetch_slots(first, child & !LEAF);
        } else {
            let w = self.wide.as_ptr().wrapping_add(child as usize).cast::<u8>();
            prefetch(w);
            prefetch(w.wrapping_add(64));
        }
    }

    #[inline(always)]
    fn fast_body(&self, ray: &Ray) -> Option<Hit> {
        if !self.fast_walk_takes(ray) {
            return self.closest(ray, &mut RayStats::default());
        }
        let inv = DVec3::ONE / ray.dir;
        let o = ray.origin;
        // Written out, not `array::map`: left as a call where the walk
        // grows large, it ran at half its speed, measured.
        let o32 = [o.x as f32, o.y as f32, o.z as f32];
        let inv32 = [inv.x as f32, inv.y as f32, inv.z as f32];
        let widen = |a: usize| 4.0 * U * o32[a].abs() * inv32[a].abs() + TINY;
        let e = [widen(0), widen(1), widen(2)];
        let neg = [inv32[0] < 0.0, inv32[1] < 0.0, inv32[2] < 0.0];
        let tmin = down32(ray.tmin);
        let mut best: Option<Hit> = None;
        let mut best_t = ray.tmax;
        let mut bound = up32(best_t);
        let mut stats = RayStats::default();
        let mut stack = [const { MaybeUninit::<(u32, u32, f32)>::uninit() }; STACK];
        let mut sp = 0usize;
        let sh = Shear::of(ray);
        // The child in hand: a wide node, or a leaf and its first slot.
        let (mut node, mut first) = (0u32, 0u32);
        loop {
            if node & LEAF != 0 {
                self.test_slots::<false>(
                    first,
                    node & !LEAF,
                    &sh,
                    &mut best,
                    &mut best_t,
                    &mut stats,
                );
                bound = up32(best_t);
            } else {
                let w = &self.wide[node as usize];
                let (near, far) = slabs(w, &o32, &inv32, &e, &neg, tmin, bound);
                // The children the ray meets, nearest last on the stack.
                let mut hit = [(0u32, 0u32, 0f32); 4];
                let mut n = 0;
                let mut m = meets(&near, &far) & w.valid();
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    // Insertion by entry, farthest first.
                    let mut j = n;
                    while j > 0 && hit[j - 1].2 < near[k] {
                        hit[j] = hit[j - 1];
                        j -= 1;
                    }
                    hit[j] = (w.child[k], w.first[k], near[k]);
                    n += 1;
                    self.prefetch_child(w.child[k], w.first[k]);
                }
                if n > 0 {
                    for &h in &hit[..n - 1] {
                        stack[sp].write(h);
                        sp += 1;
                    }
                    (node, first, _) = hit[n - 1];
                    continue;
                }
            }
            // Pop the next child that may still hold a closer hit.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                // SAFETY: slots below the stack pointer were all written by
                // a push (the pointer only grows by a write).
                let (n, f, near) = unsafe { stack[sp].assume_init() };
                if near <= bound {
                    (node, first) = (n, f);
                    break;
                }
            }
        }
    }
}

/// Each child's widened entry and exit: `[tmin, bound]` cut by the
/// ray's slabs of its box, four children at once.
#[inline(always)]
fn slabs(
    w: &WideNode,
    o: &[f32; 3],
    inv: &[f32; 3],
    e: &[f32; 3],
    neg: &[bool; 3],
    tmin: f32,
    bound: f32,
) -> ([f32; 4], [f32; 4]) {
    let mut near = [tmin; 4];
    let mut far = [bound; 4];
    for a in 0..3 {
        let (enter, exit) = if neg[a] {
            (&w.hi[a], &w.lo[a])
        } else {
            (&w.lo[a], &w.hi[a])
        };
        for k in 0..4 {
            let t0 = (enter[k] - o[a]) * inv[a];
            let t1 = (exit[k] - o[a]) * inv[a];
            near[k] = max(near[k], min(t0 * (1.0 - REL), t0 * (1.0 + REL)) - e[a]);
            far[k] = min(far[k], max(t1 * (1.0 + REL), t1 * (1.0 - REL)) + e[a]);
        }
    }
    (near, far)
}

/// A bit per lane whose entry is not past its exit.
#[inline(always)]
fn meets(near: &[f32; 4], far: &[f32; 4]) -> u32 {
    let mut m = 0;
    for k in 0..4 {
        m |= ((near[k] <= far[k]) as u32) << k;
    }
    m
}

// No NaN reaches these: boxes and the ray's `f32` origin and reciprocal
// are finite, and a distance is at most `F32_LIMIT` in size.

#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registry::{Build, BuilderKind};

    /// Every leaf that holds triangles is one child of one wide node, in
    /// a box that holds its triangles' box; every wide node but the root
    /// is one child of one node; no node holds more than four.
    #[test]
    fn the_wide_tree_holds_every_leaf_once_in_its_box() {
        let s = crate::scene::load("default", None).unwrap();
        let cfg = BihConfig {
            empty_cut: Some(30),
            ..BihConfig::DEFAULT
        };
        let bih = Build::new(BuilderKind::HOST)
            .with_tree(cfg)
            .run(&s)
            .unwrap()
            .bih;
        let t = Tracer::new(&bih, &s);
        let mut leaves_seen = std::collections::HashMap::new();
        let mut wide_seen = vec![0u32; t.wide.len()];
        let mut slots = 0;
        for w in &t.wide {
            for k in 0..4 {
                let c = w.child[k];
                if c == EMPTY {
                    continue;
                }
                let b = Aabb::new(
                    glam::Vec3::new(w.lo[0][k], w.lo[1][k], w.lo[2][k]),
                    glam::Vec3::new(w.hi[0][k], w.hi[1][k], w.hi[2][k]),
                );
                if c & LEAF != 0 {
                    *leaves_seen.entry(w.first[k]).or_insert(0) += 1;
                    slots += c & !LEAF;
                    let id = (t.nodes.iter())
                        .position(|n| n.is_leaf() && n.leaf_range() == (w.first[k], c & !LEAF))
                        .expect("a leaf of the tracer");
                    let own = t.leaf_boxes[t.nodes[id].leaf_number() as usize];
                    assert!(b.contains_box(&own), "leaf at slot {}", w.first[k]);
                } else {
                    wide_seen[c as usize] += 1;
                }
            }
        }
        assert!(leaves_seen.values().all(|&n| n == 1));
        let full = (t.nodes.iter()).filter(|n| n.is_leaf() && n.leaf_range().1 > 0);
        assert_eq!(leaves_seen.len(), full.count());
        assert_eq!(slots as usize, s.len());
        assert_eq!(wide_seen[0], 0);
        assert!(wide_seen[1..].iter().all(|&n| n == 1));
        // Collapsing two levels at a time: well under one wide node per
        // two inner BIH nodes.
        let inner = t.nodes.iter().filter(|n| !n.is_leaf()).count();
        assert!(
            2 * t.wide.len() < inner,
            "{} wide, {inner} inner",
            t.wide.len()
        );
    }
}
