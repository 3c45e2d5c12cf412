//! The recursive in-place build of Wächter & Keller (section 2's naive
//! build), written once over any boxed item with an id ([`build_items`]),
//! counting the work it does ([`BuildStats`]): the host builder runs it
//! natively, `ppe_naive` runs it on the triangle records in emulated memory
//! and charges those counts, and the builders that finish their upper levels
//! another way (`ppe_approx`, the Morton reference) finish with
//! [`build_subtree`].

use glam::{Vec3A, Vec4};

use super::cutoff::child_regions;
use super::decide::{Decision, NodeView, decide};
use super::sah::Bins;
use super::split::{Boxed, Side, clip_planes, partition, side_of};
use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode};

/// Something a builder sorts: a box, and the id of the triangle it stands for.
pub trait Item: Boxed {
    fn id(&self) -> u32;
}

/// A triangle as the host builder sorts it: its box and id, 32 bytes, two
/// SIMD lanes of four. The id rides in the fourth lane of `lo` (as bits).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct PrimRef {
    lo_id: Vec4,
    hi: Vec4,
}

impl Boxed for PrimRef {
    #[inline]
    fn lo(&self) -> Vec3A {
        Vec3A::from_vec4(self.lo_id)
    }
    #[inline]
    fn hi(&self) -> Vec3A {
        Vec3A::from_vec4(self.hi)
    }
}

impl Item for PrimRef {
    fn id(&self) -> u32 {
        self.lo_id.w.to_bits()
    }
}

impl PrimRef {
    pub fn new(id: u32, b: Aabb) -> Self {
        PrimRef {
            lo_id: b.min.extend(f32::from_bits(id)),
            hi: b.max.extend(0.0),
        }
    }
}

/// The work a build did, for cost models and reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct BuildStats {
    /// Items looked at by partitions, summed over every node that split.
    pub items_partitioned: u64,
    /// Nodes written (inner and leaves).
    pub nodes: u64,
    /// Partitions run (one per inner node that splits).
    pub partitions: u64,
    /// Items binned by the binned SAH split choice, summed over every node
    /// that chose a plane that way (0 with the global heuristic).
    pub items_binned: u64,
    /// Bin sweeps of the binned SAH split choice (one per node that
    /// binned), each over `3 × bins` bins.
    pub sah_sweeps: u64,
    /// Clip nodes the empty-space cut-off emitted (0 when it is off).
    pub clip_nodes: u64,
    /// Halvings of the global heuristic that `f32` could not make
    /// ([`super::split::choose_split_counted`]); counted by the host
    /// recursion.
    pub f32_stalls: u64,
}

/// Builds a tree over `items`, sorting them in place, with `region` as the
/// scene box of the global heuristic (the whole scene, or one node's region
/// in a local update).
pub fn build_items<T: Item>(items: &mut [T], region: Aabb, cfg: &BihConfig) -> (Bih, BuildStats) {
    assert!(cfg.max_depth <= BihConfig::MAX_SUPPORTED_DEPTH);
    let all = side_of(items);
    let mut b = Builder {
        items,
        nodes: Vec::with_capacity(all.count * 2 / cfg.leaf_size.max(1) as usize + 1),
        cfg,
        stats: BuildStats::default(),
    };
    b.nodes.push(BihNode::default());
    b.node(0, 0, all.count, region, &all, 0, region);
    let (nodes, mut stats) = (b.nodes, b.stats);
    stats.nodes = nodes.len() as u64;
    let bih = Bih {
        nodes,
        prim_ids: items.iter().map(T::id).collect(),
        bounds: region,
        config: *cfg,
    };
    (bih, stats)
}

/// Builds the subtree of `items[first .. first + count]` into node `id` of
/// `nodes` (appending its descendants), with `candidate` as the node's
/// candidate box at depth `depth`: the naive recursion, for builders that
/// finish their upper levels another way. The items' bounds are found by one
/// pass, counted in `items_partitioned`.
#[allow(clippy::too_many_arguments)]
pub fn build_subtree<T: Item>(
    items: &mut [T],
    nodes: &mut Vec<BihNode>,
    id: usize,
    first: usize,
    count: usize,
    candidate: Aabb,
    depth: u32,
    cfg: &BihConfig,
) -> BuildStats {
    let side = side_of(&items[first..first + count]);
    let mut b = Builder {
        items,
        nodes: std::mem::take(nodes),
        cfg,
        stats: BuildStats::default(),
    };
    b.stats.items_partitioned += count as u64;
    // The node's region as far as the cut-off is concerned: its candidate,
    // grown to its triangles (they may straddle the candidate's faces).
    let region = candidate.union(Aabb::new(side.lo.into(), side.hi.into()));
    b.node(id, first, count, candidate, &side, depth, region);
    *nodes = b.nodes;
    b.stats
}

struct Builder<'a, T> {
    items: &'a mut [T],
    nodes: Vec<BihNode>,
    cfg: &'a BihConfig,
    stats: BuildStats,
}

impl<T: Item> Builder<'_, T> {
    /// Fills node `id` for `items[first .. first + count]`; `region` is the
    /// box its ancestors' planes leave it (what a ray must enter).
    #[allow(clippy::too_many_arguments)]
    fn node(
        &mut self,
        id: usize,
        first: usize,
        count: usize,
        mut candidate: Aabb,
        side: &Side,
        depth: u32,
        region: Aabb,
    ) {
        let view = NodeView::of_side((first, count, depth), region, side, candidate);
        let split = match decide(self.cfg, &view, &mut self.stats.f32_stalls) {
            Decision::Leaf => None,
            Decision::Clip(clip) => {
                self.stats.clip_nodes += 1;
                let full = clip.make_in(&mut self.nodes, id);
                return self.node(full, first, count, candidate, side, depth + 1, clip.region);
            }
            Decision::Split(split, c) => {
                candidate = c;
                Some(split)
            }
            Decision::Bin(bins) => {
                self.stats.items_binned += count as u64;
                self.stats.sah_sweeps += 1;
                let mut b = Bins::new(&view.centers, bins);
                b.add(&self.items[first..first + count]);
                b.choose_or_halve(&mut candidate, &mut self.stats.f32_stalls)
            }
        };
        let Some(split) = split else {
            self.nodes[id] = BihNode::leaf(first as u32, count as u32);
            return;
        };
        let (l, r) = partition(&mut self.items[first..first + count], split);
        self.stats.items_partitioned += count as u64;
        self.stats.partitions += 1;
        debug_assert!(l.count > 0 && r.count > 0);
        let children = self.nodes.len();
        self.nodes.push(BihNode::default());
        self.nodes.push(BihNode::default());
        let [cl, cr] = clip_planes(split.axis, &l, &r);
        self.nodes[id] = BihNode::inner(children as u32, split.axis, cl, cr);
        let [lc, rc] = split.candidates(candidate);
        let [lr, rr] = child_regions(region, split.axis, [cl, cr]);
        self.node(children, first, l.count, lc, &l, depth + 1, lr);
        self.node(
            children + 1,
            first + l.count,
            r.count,
            rc,
            &r,
            depth + 1,
            rr,
        );
    }
}
