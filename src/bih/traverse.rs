//! Ray casting: closest hit and any hit, and a brute-force reference.
//!
//! Numerics. Vertices are `f32`, but every ray computation is done in `f64`:
//! with coordinates of 1e15, the Möller–Trumbore determinant is a product of
//! three 1e15-sized terms (1e45, beyond `f32`'s 3.4e38), and with 1e-15 it is
//! 1e-45 (below `f32`'s smallest normal, 1.2e-38); `f64` holds both. A zero
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
//! The [`Tracer`] is what a renderer makes of a tree: its own copy of the
//! nodes with each leaf starting a group of four in a padded triangle order
//! ([`super::lanes`]: four Möller–Trumbore tests per step), and the box of
//! each leaf's triangles, which the ray must meet within `[tmin, best]`
//! (widened likewise) before the leaf's triangles are tested. A BIH leaf's
//! region is bounded only by its ancestors' planes and is often far larger
//! than what it holds; on the dragon this box cuts triangle tests per
//! primary ray from 48 to 4. The tree itself is not changed.

use std::mem::MaybeUninit;

use glam::DVec3;

use super::lanes::{self, Group};
use super::{Bih, BihConfig, BihNode};
use crate::aabb::Aabb;
use crate::scene::{Scene, Triangle};

/// Relative widening of node intervals: covers the three roundings of
/// `(clip - o) * (1/d)` in `f64` many times over.
pub(super) const SLACK: f64 = 1e-12;

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

/// Möller–Trumbore ("Fast, minimum storage ray/triangle intersection", JGT
/// 1997) in `f64`. Edges and corners count as inside. A zero-area triangle
/// (edge cross product exactly zero) is never hit.
#[inline]
pub fn intersect_triangle(
    tri: &Triangle,
    ray: &Ray,
    tmin: f64,
    tmax: f64,
) -> Option<(f64, f64, f64)> {
    PreTriangle::new(tri).intersect(ray, tmin, tmax)
}

/// A triangle ready for ray tests: `f32` vertices (36 bytes, half the cache
/// footprint of `f64`), widened to `f64` in the test. A zero-area triangle is
/// stored collapsed to its first vertex, so that its determinant is exactly
/// zero and it is never hit.
#[derive(Clone, Copy, Debug)]
struct PreTriangle {
    v: [glam::Vec3; 3],
}

impl PreTriangle {
    fn new(tri: &Triangle) -> Self {
        let v = if tri.is_degenerate() {
            [tri.v[0]; 3]
        } else {
            tri.v
        };
        PreTriangle { v }
    }

    /// Möller–Trumbore without a division until the hit is certain: the
    /// barycentric tests compare numerators against the determinant.
    #[inline(always)]
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<(f64, f64, f64)> {
        let v0 = self.v[0].as_dvec3();
        let e1 = self.v[1].as_dvec3() - v0;
        let e2 = self.v[2].as_dvec3() - v0;
        let p = ray.dir.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        // Flip signs so that det > 0 and the tests are 0 <= u, v; u + v <= det.
        let sign = det.signum();
        let adet = det.abs();
        let s = ray.origin - v0;
        let u = s.dot(p) * sign;
        if u < 0.0 || u > adet {
            return None;
        }
        let q = s.cross(e1);
        let v = ray.dir.dot(q) * sign;
        if v < 0.0 || u + v > adet {
            return None;
        }
        let inv = 1.0 / det;
        let t = e2.dot(q) * inv;
        // A hit has a finite t: with a direction so short (1e-320) that the
        // distance in its units overflows f64, t is infinite and no hit.
        (t >= tmin && t <= tmax && t.is_finite()).then(|| (t, u / adet, v / adet))
    }
}

/// Closest hit by testing every triangle: the reference every tree must
/// agree with. Ties in `t` go to the lower triangle id.
pub fn brute_force_closest(scene: &Scene, ray: &Ray) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (i, tri) in scene.triangles.iter().enumerate() {
        let tmax = best.map_or(ray.tmax, |h| h.t);
        if let Some((t, u, v)) = intersect_triangle(tri, ray, ray.tmin, tmax)
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
fn clip_range(b: &Aabb, ray: &Ray, inv: DVec3, mut t0: f64, mut t1: f64) -> (f64, f64) {
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

/// How many slots ahead [`Tracer::new`] prefetches the triangle it will
/// read: about one memory latency of work at a few ns a triangle.
const PREFETCH_AHEAD: usize = 16;

/// A hint that `p` will be read soon (x86-64; elsewhere nothing).
#[inline(always)]
fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch never faults, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// A tree bound to its triangles, laid out in leaf order for traversal.
pub struct Tracer<'a> {
    pub(super) bih: &'a Bih,
    /// The tree's nodes with every leaf's first slot moved to a multiple of
    /// four in the padded triangle order below, so that a leaf starts a
    /// group and no lane tests another leaf's triangle.
    pub(super) nodes: Vec<BihNode>,
    /// Padded slot → scene triangle id (`u32::MAX` for padding).
    pub(super) prims: Vec<u32>,
    /// The box of each leaf's triangles, by node id (unused for inner
    /// nodes): a BIH leaf's region is bounded only by its ancestors' planes
    /// and is often much larger than what it holds, so a ray is tested
    /// against this box before the leaf's triangles.
    pub(super) leaf_boxes: Vec<Aabb>,
    /// Padded slot `k` is lane `k % 4` of group `k / 4`.
    pub(super) groups: Vec<Group>,
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
        // One pass over the leaves in depth-first order, each triangle read
        // once: its slot in the padded order, its lane in a group, its box
        // into the leaf's box.
        let mut nodes = bih.nodes.clone();
        let mut leaf_boxes = vec![Aabb::EMPTY; nodes.len()];
        let slots = bih.prim_ids.len() + 3 * bih.nodes.len().div_ceil(2);
        let mut prims = Vec::with_capacity(slots);
        let mut groups: Vec<Group> = Vec::with_capacity(slots.div_ceil(4));
        let mut stack = vec![0u32];
        while let Some(id) = stack.pop() {
            let nd = bih.nodes[id as usize];
            if !nd.is_leaf() {
                stack.extend([nd.left_child() + 1, nd.left_child()]);
                continue;
            }
            let (first, count) = nd.leaf_range();
            nodes[id as usize] = BihNode::leaf(prims.len() as u32, count);
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
            leaf_boxes[id as usize] = bounds;
            prims.resize(prims.len().next_multiple_of(4), u32::MAX);
        }
        Tracer {
            bih,
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
        ray: &Ray,
        inv: DVec3,
        best: &mut Option<Hit>,
        best_t: &mut f64,
        stats: &mut RayStats,
    ) -> bool {
        // Only a ray that meets the box of the leaf's triangles before its
        // best hit so far can hit one of them.
        let leaf_box = &self.leaf_boxes[node as usize];
        let (b0, b1) = if FINITE {
            clip_range_finite(leaf_box, ray.origin, inv, ray.tmin, *best_t)
        } else {
            clip_range(leaf_box, ray, inv, ray.tmin, *best_t)
        };
        b0 <= b1 && self.test_triangles::<ANY>(node, ray, best, best_t, stats)
    }

    /// Leaf `node`'s triangles against `ray` (whose test of the leaf's
    /// box passed), four at a time: a closer hit replaces `best` (and
    /// `best_t`). With `ANY`, `true` at the first hit found. The single-ray
    /// walk and the packets ([`super::packet`]) both test triangles here.
    #[inline(always)]
    pub(super) fn test_triangles<const ANY: bool>(
        &self,
        node: u32,
        ray: &Ray,
        best: &mut Option<Hit>,
        best_t: &mut f64,
        stats: &mut RayStats,
    ) -> bool {
        let (first, count) = self.nodes[node as usize].leaf_range();
        stats.triangles_tested += count as u64;
        let (o, d) = (ray.origin.to_array(), ray.dir.to_array());
        let (first, end) = (first as usize, (first + count) as usize);
        for g in first / 4..end.div_ceil(4) {
            let f = lanes::intersect4(&self.groups[g], o, d, ray.tmin, *best_t);
            // Lanes of this leaf only (it starts a group), in slot order.
            let mut m = f.mask & ((1u32 << (end - g * 4).min(4)) - 1);
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                let (t, prim) = (f.t[l], self.prims[g * 4 + l]);
                if closer(t, prim, *best) {
                    let (u, v) = (f.u[l] / f.adet[l], f.v[l] / f.adet[l]);
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
                if self.test_leaf::<ANY, FINITE>(node, ray, inv, &mut best, &mut best_t, stats) {
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
