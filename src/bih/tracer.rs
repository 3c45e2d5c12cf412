//! The host's ray tracer. A [`Tracer`] is what a renderer makes of a tree: its own copy of the
//! nodes with each leaf starting a group of four in a padded triangle order
//! ([`super::lanes`]: four watertight triangle tests per step), and the box of
//! each leaf's triangles, which the ray must meet within `[tmin, best]`
//! (widened as node intervals are, `traverse`) before the leaf's triangles are tested. A BIH leaf's
//! region is bounded only by its ancestors' planes and is often far larger
//! than what it holds; on the dragon this box cuts triangle tests per
//! primary ray from 48 to 4. The tree itself is not changed.

use std::mem::MaybeUninit;

use glam::DVec3;

use super::lanes::{self, Group};
use super::traverse::{
    PreTriangle, clip_range, clip_range_finite, closer, pop_bound, root_interval, widen_down,
    widen_up,
};
use super::watertight::{self, Shear};
use super::wide::{self, WideNode};
use super::{Bih, BihConfig, BihNode, Hit, Ray, RayStats, prefetch};
use crate::aabb::Aabb;
use crate::scene::Scene;

/// How many slots ahead [`Tracer::new`] prefetches the triangle it will
/// read: about one memory latency of work at a few ns a triangle.
const PREFETCH_AHEAD: usize = 16;

/// A tree bound to its triangles, laid out in leaf order for traversal.
pub struct Tracer<'a> {
    pub(super) bih: &'a Bih,
    /// The tree's nodes, each pair of children after its parent's pair in
    /// depth-first order, every leaf's first slot moved to a multiple of
    /// four in the padded triangle order below (so that a leaf starts a
    /// group and no lane tests another leaf's triangle) and its number in
    /// `leaf_boxes` in its third word.
    pub(super) nodes: Vec<BihNode>,
    /// Padded slot → scene triangle id (`u32::MAX` for padding).
    pub(super) prims: Vec<u32>,
    /// The box of each leaf's triangles, by leaf number: a BIH leaf's region is bounded only by its ancestors' planes
    /// and is often much larger than what it holds, so a ray is tested
    /// against this box before the leaf's triangles.
    pub(super) leaf_boxes: Vec<Aabb>,
    /// Padded slot `k` is lane `k % 4` of group `k / 4`.
    pub(super) groups: Vec<Group>,
    /// The tree collapsed four children to a node, each child's box that
    /// of its triangles: the fast walk's ([`super::wide`]).
    pub(super) wide: Vec<WideNode>,
    /// The largest coordinate of the tree's box, in size: which rays the
    /// fast walk can take.
    pub(super) largest: f64,
    /// [`Tracer::hits`]' packets hand a ray over to the fast walk at a node
    /// where at most this many of their rays are active (0: never).
    pub(super) hand_over: u32,
    /// The CPU has AVX2: traverse with the AVX2 build of the loop.
    #[cfg(target_arch = "x86_64")]
    pub(super) avx2: bool,
}

impl<'a> Tracer<'a> {
    pub fn new(bih: &'a Bih, scene: &Scene) -> Self {
        assert_eq!(
            bih.prim_ids.len(),
            scene.len(),
            "tree and scene differ in size"
        );
        assert!(bih.config.max_depth <= BihConfig::MAX_SUPPORTED_DEPTH);
        // One pass over the tree in depth-first order. The tracer's nodes
        // are laid out anew, each pair of children after the pair before it
        // in that order (a ray's descent down the near side reads on in
        // memory), and each leaf numbered with its box's index in a table
        // of leaves only, in the same order. Each triangle is read once:
        // its slot in the padded order, its lane in a group, its box into
        // the leaf's box.
        let mut nodes = Vec::with_capacity(bih.nodes.len());
        nodes.push(BihNode::default());
        let mut leaf_boxes = Vec::with_capacity(bih.nodes.len().div_ceil(2));
        let slots = bih.prim_ids.len() + 3 * bih.nodes.len().div_ceil(2);
        let mut prims = Vec::with_capacity(slots);
        let mut groups: Vec<Group> = Vec::with_capacity(slots.div_ceil(4));
        // (the tree's id, the tracer's id)
        let mut stack = vec![(0u32, 0u32)];
        while let Some((id, at)) = stack.pop() {
            let nd = bih.nodes[id as usize];
            if !nd.is_leaf() {
                let pair = nodes.len() as u32;
                nodes.extend([BihNode::default(); 2]);
                let [cl, cr] = nd.clip();
                nodes[at as usize] = BihNode::inner(pair, nd.axis(), cl, cr);
                let left = nd.left_child();
                stack.extend([(left + 1, pair + 1), (left, pair)]);
                continue;
            }
            let (first, count) = nd.leaf_range();
            nodes[at as usize] =
                BihNode::numbered_leaf(prims.len() as u32, count, leaf_boxes.len() as u32);
            let mut bounds = Aabb::EMPTY;
            for k in first as usize..(first + count) as usize {
                // Leaves come in tree order, their ranges in slot order: the
                // triangle a few slots on is the next cache miss (the scene
                // is in file order), so ask for it now.
                if let Some(&ahead) = bih.prim_ids.get(k + PREFETCH_AHEAD) {
                    prefetch(scene.triangles.as_ptr().wrapping_add(ahead as usize));
                }
                let p = bih.prim_ids[k];
                let tri = &scene.triangles[p as usize];
                bounds = bounds.union(tri.bounds());
                if prims.len() % 4 == 0 {
                    groups.push(Group::default());
                }
                let lane = prims.len() % 4;
                groups
                    .last_mut()
                    .expect("pushed")
                    .set(lane, PreTriangle::new(tri).v);
                prims.push(p);
            }
            leaf_boxes.push(bounds);
            prims.resize(prims.len().next_multiple_of(4), u32::MAX);
        }
        let wide = wide::collapse(&nodes, &leaf_boxes);
        let b = &bih.bounds;
        Tracer {
            bih,
            wide,
            largest: b.min.abs().max(b.max.abs()).max_element() as f64,
            hand_over: 0,
            nodes,
            leaf_boxes,
            prims,
            groups,
            #[cfg(target_arch = "x86_64")]
            avx2: std::arch::is_x86_feature_detected!("avx2"),
        }
    }

    /// The same tracer using the portable (SSE2) build of the traversal
    /// loop even where the CPU has AVX2: for tests and comparisons. Both
    /// builds give bitwise the same hits.
    pub fn portable(mut self) -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            self.avx2 = false;
        }
        self
    }

    /// The same tracer whose [`Tracer::hits`] hands a packet's rays over
    /// to the fast walk, each alone, at a node where at most `lanes` of
    /// them are active: the same hits; measured slower than keeping them
    /// (docs/tradeoff.md), so off by default (0).
    pub fn handing_over(mut self, lanes: u32) -> Self {
        self.hand_over = lanes;
        self
    }

    pub fn bih(&self) -> &Bih {
        self.bih
    }

    /// Bytes of the tracer's own arrays (its node copy, padded triangle
    /// order, leaf boxes and four-lane triangle groups), beside the tree's.
    pub fn memory_bytes(&self) -> usize {
        size_of_val(self.nodes.as_slice())
            + size_of_val(self.prims.as_slice())
            + size_of_val(self.leaf_boxes.as_slice())
            + size_of_val(self.groups.as_slice())
            + size_of_val(self.wide.as_slice())
    }

    /// The closest hit in `[tmin, tmax]`, ties to the lower triangle id.
    pub fn closest(&self, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        self.traverse::<false>(ray, stats)
    }

    /// Any hit in `[tmin, tmax]` (shadow rays): stops at the first found.
    pub fn any(&self, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        self.traverse::<true>(ray, stats)
    }

    /// Leaf `node`'s triangles against `ray`, if the ray meets the box
    /// of the leaf's triangles before its best hit so far: a closer hit
    /// replaces `best` (and `best_t`). With `ANY`, `true` at the first hit
    /// found.
    #[inline(always)]
    fn test_leaf<const ANY: bool, const FINITE: bool>(
        &self,
        node: u32,
        sh: &Shear,
        inv: DVec3,
        best: &mut Option<Hit>,
        best_t: &mut f64,
        stats: &mut RayStats,
    ) -> bool {
        // Only a ray that meets the box of the leaf's triangles before its
        // best hit so far can hit one of them.
        let nd = self.nodes[node as usize];
        let (first, count) = nd.leaf_range();
        // The leaf's triangles are the next cache misses after its box:
        // ask for them now, so that both misses overlap.
        self.prefetch_slots(first, count);
        let leaf_box = &self.leaf_boxes[nd.leaf_number() as usize];
        let ray = sh.ray();
        let (b0, b1) = if FINITE {
            clip_range_finite(leaf_box, ray.origin, inv, ray.tmin, *best_t)
        } else {
            clip_range(leaf_box, ray, inv, ray.tmin, *best_t)
        };
        b0 <= b1 && self.test_triangles::<ANY>(node, sh, best, best_t, stats)
    }

    /// Asks for the memory of slots `first .. first + count` (a leaf's
    /// triangle groups, up to four cache lines).
    #[inline(always)]
    pub(super) fn prefetch_slots(&self, first: u32, count: u32) {
        let g = (self.groups.as_ptr())
            .wrapping_add(first as usize / 4)
            .cast::<u8>();
        let bytes = (count as usize).div_ceil(4) * size_of::<Group>();
        for line in 0..bytes.div_ceil(64).min(4) {
            prefetch(g.wrapping_add(64 * line));
        }
    }

    /// Leaf `node`'s triangles against `ray` (whose test of the leaf's
    /// box passed), four at a time: a closer hit replaces `best` (and
    /// `best_t`). With `ANY`, `true` at the first hit found. The single-ray
    /// walk and the packets ([`super::packet`]) both test triangles here.
    #[inline(always)]
    pub(super) fn test_triangles<const ANY: bool>(
        &self,
        node: u32,
        sh: &Shear,
        best: &mut Option<Hit>,
        best_t: &mut f64,
        stats: &mut RayStats,
    ) -> bool {
        let (first, count) = self.nodes[node as usize].leaf_range();
        self.test_slots::<ANY>(first, count, sh, best, best_t, stats)
    }

    /// Slots `first .. first + count` of the padded triangle order (a
    /// leaf's: `first` starts a group) against `ray`, as
    /// [`Tracer::test_triangles`].
    #[inline(always)]
    pub(super) fn test_slots<const ANY: bool>(
        &self,
        first: u32,
        count: u32,
        sh: &Shear,
        best: &mut Option<Hit>,
        best_t: &mut f64,
        stats: &mut RayStats,
    ) -> bool {
        stats.triangles_tested += count as u64;
        let (first, end) = (first as usize, (first + count) as usize);
        for g in first / 4..end.div_ceil(4) {
            let group = &self.groups[g];
            let f = lanes::intersect4(group, sh);
            // Lanes of this leaf only (it starts a group), in slot order.
            let mut m = f.mask & ((1u32 << (end - g * 4).min(4)) - 1);
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                // The scalar test's `t` and range test, on the same operands.
                let Some((t, u, v)) =
                    watertight::hit(&f.w[l], group.get(l), sh, sh.ray().tmin, *best_t)
                else {
                    continue;
                };
                let prim = self.prims[g * 4 + l];
                if closer(t, prim, *best) {
                    *best = Some(Hit { prim, t, u, v });
                    *best_t = t;
                    if ANY {
                        return true;
                    }
                }
            }
        }
        false
    }

    fn traverse<const ANY: bool>(&self, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        // A zero (or subnormal) direction component makes a reciprocal
        // infinite, and slab distances can be NaN: such rays take the
        // careful slab test, all others the branch-free one.
        if (DVec3::ONE / ray.dir).is_finite() {
            self.traverse_in::<ANY, true>(ray, stats)
        } else {
            self.traverse_in::<ANY, false>(ray, stats)
        }
    }

    #[inline(always)]
    fn traverse_in<const ANY: bool, const FINITE: bool>(
        &self,
        ray: &Ray,
        stats: &mut RayStats,
    ) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the CPU has AVX2 (checked when the tracer was made).
            return unsafe { self.traverse_avx2::<ANY, FINITE>(ray, stats) };
        }
        self.traverse_portable::<ANY, FINITE>(ray, stats)
    }

    /// The portable build of the loop. Never inlined, like
    /// [`Tracer::traverse_avx2`]: built for a CPU that has AVX2 anyway
    /// (`-C target-cpu=native`), both would otherwise be inlined into their
    /// caller, four copies of the loop in one function, and the tracer ran
    /// 30–45 % slower.
    #[inline(never)]
    fn traverse_portable<const ANY: bool, const FINITE: bool>(
        &self,
        ray: &Ray,
        stats: &mut RayStats,
    ) -> Option<Hit> {
        self.traverse_body::<ANY, FINITE>(ray, stats)
    }

    /// The same traversal compiled for AVX2, so that the four-lane triangle
    /// tests run four `f64` lanes at a time; chosen at run time.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    fn traverse_avx2<const ANY: bool, const FINITE: bool>(
        &self,
        ray: &Ray,
        stats: &mut RayStats,
    ) -> Option<Hit> {
        self.traverse_body::<ANY, FINITE>(ray, stats)
    }

    /// `FINITE`: every component of the ray's reciprocal direction is
    /// finite.
    #[inline(always)]
    fn traverse_body<const ANY: bool, const FINITE: bool>(
        &self,
        ray: &Ray,
        stats: &mut RayStats,
    ) -> Option<Hit> {
        stats.rays += 1;
        let nodes = &self.nodes;
        let inv = DVec3::ONE / ray.dir;
        let (t0, t1) = root_interval(&self.bih.bounds, ray, inv)?;
        let sh = Shear::of(ray);
        let neg = [
            ray.dir.x.is_sign_negative(),
            ray.dir.y.is_sign_negative(),
            ray.dir.z.is_sign_negative(),
        ];
        // Not zeroed per ray (3 KiB): a slot is read only after a push.
        let mut stack = [const { MaybeUninit::<(u32, f64, f64)>::uninit() };
            BihConfig::MAX_SUPPORTED_DEPTH as usize + 2];
        let mut sp = 0usize;
        let mut best: Option<Hit> = None;
        let mut best_t = ray.tmax;
        let (mut node, mut tn, mut tf) = (0u32, t0, t1);
        loop {
            stats.nodes_visited += 1;
            let nd = &nodes[node as usize];
            if nd.is_leaf() {
                if self.test_leaf::<ANY, FINITE>(node, &sh, inv, &mut best, &mut best_t, stats) {
                    return best;
                }
            } else {
                // [`descend`]'s step, written out: called here (a struct
                // returned and matched) it cost 4 % of the host's primary
                // rays per second on the dragon, measured. The SPE caster
                // calls `descend`; tests/cast.rs holds both to the same
                // hits, bit for bit.
                let a = nd.axis();
                let [cl, cr] = nd.clip();
                let t_left = (cl as f64 - ray.origin[a]) * inv[a];
                let t_right = (cr as f64 - ray.origin[a]) * inv[a];
                let (t_exit_near, t_enter_far) = if neg[a] {
                    (t_right, t_left)
                } else {
                    (t_left, t_right)
                };
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
                let go_near = tn <= near_tf;
                let go_far = far_tn <= tf;
                if go_near {
                    if go_far {
                        stack[sp].write((far, far_tn, tf));
                        sp += 1;
                    }
                    node = near;
                    tf = near_tf;
                    continue;
                } else if go_far {
                    node = far;
                    tn = far_tn;
                    continue;
                }
            }
            // Pop the next node that may still hold a closer hit.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                // SAFETY: slots below the stack pointer were all written by
                // a push (the pointer only grows by a write).
                let (n, a, b) = unsafe { stack[sp].assume_init() };
                let bound = pop_bound(best_t);
                if a <= bound {
                    (node, tn, tf) = (n, a, b.min(bound));
                    break;
                }
            }
        }
    }
}
