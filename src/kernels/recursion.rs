//! The recursive in-place build of Wächter & Keller (section 2's naive
//! build), written once over any boxed item with an id ([`build_items`]),
//! counting the work it does ([`BuildStats`]): the host builder runs it
//! natively, `ppe_naive` runs it on the triangle records in emulated memory
//! and charges those counts, and the builders that finish their upper levels
//! another way (`ppe_approx`, the Morton reference) finish with
//! [`build_subtree`].

use glam::{BVec4A, Vec3A, Vec4};

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

/// The three coordinate lanes of a [`PrimRef`]'s `lo_id`.
const XYZ: BVec4A = BVec4A::from_array([true, true, true, false]);

impl Boxed for PrimRef {
    #[inline]
    fn lo(&self) -> Vec3A {
        // The id's bits read as a float are a subnormal number; arithmetic
        // on one is a microcode assist on Intel cores (a hundred cycles and
        // more), and the centre multiplies every lane. So the lane is
        // cleared before any arithmetic sees it.
        Vec3A::from_vec4(Vec4::select(XYZ, self.lo_id, Vec4::ZERO))
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

impl BuildStats {
    /// Adds the work `o` counted (not its nodes: each build counts its own).
    pub fn add(&mut self, o: &BuildStats) {
        self.items_partitioned += o.items_partitioned;
        self.partitions += o.partitions;
        self.items_binned += o.items_binned;
        self.sah_sweeps += o.sah_sweeps;
        self.clip_nodes += o.clip_nodes;
        self.f32_stalls += o.f32_stalls;
    }
}

/// Builds a tree over `items`, sorting them in place, with `region` as the
/// scene box of the global heuristic (the whole scene, or one node's region
/// in a local update).
pub fn build_items<T: Item>(items: &mut [T], region: Aabb, cfg: &BihConfig) -> (Bih, BuildStats) {
    assert!(cfg.max_depth <= BihConfig::MAX_SUPPORTED_DEPTH);
    let all = side_of(items);
    let mut b = Builder {
        items,
        base: 0,
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
    let mut b = Builder::taking(items, nodes, cfg);
    b.stats.items_partitioned += count as u64;
    // The node's region as far as the cut-off is concerned: its candidate,
    // grown to its triangles (they may straddle the candidate's faces).
    let region = candidate.union(Aabb::new(side.lo.into(), side.hi.into()));
    b.node(id, first, count, candidate, &side, depth, region);
    *nodes = b.nodes;
    b.stats
}

/// Builds the subtree of the node `view` over all of `items` (its
/// triangles, from place 0) into node 0 of `nodes`, appending its
/// descendants in pairs (1, 2), (3, 4), …: the same decisions as a
/// level-by-level build of that node, for a breadth-first job finished in
/// a local store. The node's bounds, centers and region come with it: no
/// bounds pass.
pub fn build_below<T: Item>(
    items: &mut [T],
    nodes: &mut Vec<BihNode>,
    view: &NodeView,
    cfg: &BihConfig,
) -> BuildStats {
    let (b, c) = (view.bounds, view.centers);
    let side = Side {
        count: items.len(),
        lo: b.min.into(),
        hi: b.max.into(),
        center_lo: c.min.into(),
        center_hi: c.max.into(),
    };
    let mut b = Builder::taking(items, nodes, cfg);
    b.nodes.clear();
    b.nodes.push(BihNode::default());
    let (count, depth) = (side.count, view.depth);
    b.node(0, 0, count, view.candidate, &side, depth, view.region);
    *nodes = b.nodes;
    b.stats
}

struct Builder<'a, T> {
    /// The items from `base` on (a node's leaves still name their place in
    /// the whole array).
    items: &'a mut [T],
    base: usize,
    nodes: Vec<BihNode>,
    cfg: &'a BihConfig,
    stats: BuildStats,
}

impl<'a, T: Item> Builder<'a, T> {
    /// A builder over `items` that appends to `nodes` (taken; the caller
    /// puts them back).
    fn taking(items: &'a mut [T], nodes: &mut Vec<BihNode>, cfg: &'a BihConfig) -> Self {
        Builder {
            items,
            base: 0,
            nodes: std::mem::take(nodes),
            cfg,
            stats: BuildStats::default(),
        }
    }

    /// Fills node `id` for `items[first .. first + count]`; `region` is the
    /// box its ancestors' planes leave it (what a ray must enter).
    #[allow(clippy::too_many_arguments)]
    fn node(
        &mut self,
        id: usize,
        first: usize,
        count: usize,
        candidate: Aabb,
        side: &Side,
        depth: u32,
        region: Aabb,
    ) {
        let node = NodeJob {
            first,
            depth,
            region,
            candidate,
            side: *side,
        };
        let items = &mut self.items[first - self.base..first - self.base + count];
        match step(items, &node, self.cfg, &mut self.stats) {
            Step::Leaf => self.nodes[id] = BihNode::leaf(first as u32, count as u32),
            Step::Clip(clip) => {
                let full = clip.make_in(&mut self.nodes, id);
                self.node(full, first, count, candidate, side, depth + 1, clip.region);
            }
            Step::Split(split) => {
                let [left, right] = split.make_in(&mut self.nodes, id, &node);
                for child in [left, right] {
                    let (first, count, side) = (child.first, child.side.count, child.side);
                    self.node(
                        child.id,
                        first,
                        count,
                        child.candidate,
                        &side,
                        depth + 1,
                        child.region,
                    );
                }
            }
        }
    }
}

/// A node to make: where its items start, its depth, the region its
/// ancestors' planes leave it, the global heuristic's candidate box, and
/// what its items' bounds are.
#[derive(Clone, Copy, Debug)]
pub struct NodeJob {
    pub first: usize,
    pub depth: u32,
    pub region: Aabb,
    pub candidate: Aabb,
    pub side: Side,
}

/// The subtree of `node` built by the serial recursion over the node's
/// own `items` (`items[0]` is item `node.first` of the whole array): its
/// nodes, root 0 and children appended as the recursion makes them, leaf
/// ranges in the whole array's places. What a host builder does with a job
/// small enough to finish alone.
pub fn build_node<T: Item>(
    items: &mut [T],
    node: &NodeJob,
    cfg: &BihConfig,
    stats: &mut BuildStats,
) -> Vec<BihNode> {
    let count = items.len();
    let mut b = Builder {
        items,
        base: node.first,
        nodes: vec![BihNode::default()],
        cfg,
        stats: BuildStats::default(),
    };
    let (candidate, side) = (node.candidate, node.side);
    b.node(
        0,
        node.first,
        count,
        candidate,
        &side,
        node.depth,
        node.region,
    );
    stats.add(&b.stats);
    b.nodes
}

impl NodeJob {
    /// The job of a clip node's full child: this node's items again, one
    /// level down, in the clip's `region`.
    pub fn clipped(&self, region: Aabb) -> NodeJob {
        NodeJob {
            depth: self.depth + 1,
            region,
            ..*self
        }
    }
}

impl Child {
    /// The child's own job, one level below `parent`.
    pub fn job(&self, parent: &NodeJob) -> NodeJob {
        NodeJob {
            first: self.first,
            depth: parent.depth + 1,
            region: self.region,
            candidate: self.candidate,
            side: self.side,
        }
    }
}

/// What one node of the recursion became ([`step`]).
#[derive(Clone, Copy, Debug)]
pub enum Step {
    Leaf,
    /// A clip node; its full child is the node again, in the clip's region.
    Clip(crate::kernels::cutoff::Clip),
    /// Split, its items partitioned.
    Split(Made),
}

/// A split made: the plane, the candidate box it was chosen in, and the
/// two sides of the partition.
#[derive(Clone, Copy, Debug)]
pub struct Made {
    pub split: crate::kernels::split::Split,
    pub candidate: Aabb,
    pub left: Side,
    pub right: Side,
}

/// A child of a split: its node id and what its own [`NodeJob`] needs.
#[derive(Clone, Copy, Debug)]
pub struct Child {
    pub id: usize,
    pub first: usize,
    pub region: Aabb,
    pub candidate: Aabb,
    pub side: Side,
}

impl Made {
    /// Writes the split node `id` of `node` into `nodes` with its two
    /// children's slots appended (adjacent, left first); returns the
    /// children.
    pub fn make_in(&self, nodes: &mut Vec<BihNode>, id: usize, node: &NodeJob) -> [Child; 2] {
        let children = nodes.len();
        nodes.extend([BihNode::default(); 2]);
        self.make_at(nodes, id, children, node)
    }

    /// [`Self::make_in`] with the children's two slots at `children`
    /// (handed out by the caller).
    pub fn make_at(
        &self,
        nodes: &mut [BihNode],
        id: usize,
        children: usize,
        node: &NodeJob,
    ) -> [Child; 2] {
        let [cl, cr] = clip_planes(self.split.axis, &self.left, &self.right);
        nodes[id] = BihNode::inner(children as u32, self.split.axis, cl, cr);
        self.children(children, node)
    }

    /// The two children of the split node of `node`, their slots at
    /// `children` and `children + 1`.
    pub fn children(&self, children: usize, node: &NodeJob) -> [Child; 2] {
        let axis = self.split.axis;
        let [cl, cr] = clip_planes(axis, &self.left, &self.right);
        let [lc, rc] = self.split.candidates(self.candidate);
        let [lr, rr] = child_regions(node.region, axis, [cl, cr]);
        [
            Child {
                id: children,
                first: node.first,
                region: lr,
                candidate: lc,
                side: self.left,
            },
            Child {
                id: children + 1,
                first: node.first + self.left.count,
                region: rr,
                candidate: rc,
                side: self.right,
            },
        ]
    }
}

/// One node of the in-place build over its own `items`: the node decision
/// ([`decide`]), binning where binned SAH chooses, and the partition of a
/// split — everything but writing the node, which the caller does (the
/// serial recursion at once, the host's parallel builders in their own
/// order). Counts its work in `stats`.
pub fn step<T: Item>(
    items: &mut [T],
    node: &NodeJob,
    cfg: &BihConfig,
    stats: &mut BuildStats,
) -> Step {
    step_with(
        items,
        node,
        (cfg, stats),
        |b, items| b.add(items),
        partition,
    )
}

/// [`step`] with the node's binning (`bin`: fill the bins with the items)
/// and partition (`part`) given: the host's cooperative top passes ones
/// that share the work among threads. They must give the same bins and the
/// same sides (a partition may leave the items of a side in another order).
pub fn step_with<T: Item>(
    items: &mut [T],
    node: &NodeJob,
    (cfg, stats): (&BihConfig, &mut BuildStats),
    bin: impl FnOnce(&mut Bins, &[T]),
    part: impl FnOnce(&mut [T], crate::kernels::split::Split) -> (Side, Side),
) -> Step {
    let count = items.len();
    let mut candidate = node.candidate;
    let view = NodeView::of_side(
        (node.first, count, node.depth),
        node.region,
        &node.side,
        candidate,
    );
    let split = match decide(cfg, &view, &mut stats.f32_stalls) {
        Decision::Leaf => None,
        Decision::Clip(clip) => {
            stats.clip_nodes += 1;
            return Step::Clip(clip);
        }
        Decision::Split(split, c) => {
            candidate = c;
            Some(split)
        }
        Decision::Bin(bins) => {
            stats.items_binned += count as u64;
            stats.sah_sweeps += 1;
            let mut b = Bins::new(&view.centers, bins);
            bin(&mut b, items);
            b.choose_or_halve(&mut candidate, &mut stats.f32_stalls)
        }
    };
    let Some(split) = split else {
        return Step::Leaf;
    };
    let (left, right) = part(items, split);
    stats.items_partitioned += count as u64;
    stats.partitions += 1;
    debug_assert!(left.count > 0 && right.count > 0);
    Step::Split(Made {
        split,
        candidate,
        left,
        right,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_prim_refs_box_carries_no_id_bits_into_arithmetic() {
        let r = PrimRef::new(7, Aabb::new(Vec3::ONE, Vec3::splat(2.0)));
        assert_eq!(r.id(), 7);
        // All four SIMD lanes, the hidden one too: the id's bits there
        // would be a subnormal float in every centre computed.
        let lanes = |v: Vec3A| -> [f32; 4] {
            // SAFETY: Vec3A is four f32 lanes (16 bytes, one SIMD register).
            unsafe { std::mem::transmute::<Vec3A, [f32; 4]>(v) }
        };
        assert_eq!(lanes(r.lo()), [1.0, 1.0, 1.0, 0.0]);
        assert_eq!(lanes(r.center()), [1.5, 1.5, 1.5, 0.0]);
    }
}
