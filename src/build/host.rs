//! The host builder: the recursive in-place build of Wächter & Keller with
//! the global heuristic. The recursion ([`build_items`]) is written once,
//! over any boxed item with an id, and counts the work it does
//! ([`BuildStats`]); the host builder runs it natively, the PPE strategy runs
//! it on the triangle records in emulated memory and charges those counts.

use glam::{Vec3A, Vec4};

use super::kernels::{Boxed, Side, Split, choose_split_counted, clip_planes, partition, side_of};
use super::sah::sah_split;
use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode, SplitChoice};
use crate::scene::Scene;

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
    /// Clip nodes the empty-space cut-off emitted (0 when it is off).
    pub clip_nodes: u64,
    /// Halvings of the global heuristic that `f32` could not make
    /// ([`super::kernels::choose_split_counted`]); counted by the host
    /// recursion.
    pub f32_stalls: u64,
}

/// Builds the tree of `scene` in one host thread.
/// The host builder in the registry of builders.
pub const BUILDER: super::Builder = super::Builder::host(
    "host",
    "recursive in-place build, global heuristic, on the host (one thread)",
    build_in,
);

pub fn build(scene: &Scene, cfg: &BihConfig) -> Bih {
    build_in(scene, scene.bounds(), cfg)
}

/// [`build`] with `region` as the scene box of the global heuristic.
pub fn build_in(scene: &Scene, region: Aabb, cfg: &BihConfig) -> Bih {
    let mut refs: Vec<PrimRef> = scene
        .triangles
        .iter()
        .enumerate()
        .map(|(i, t)| PrimRef::new(i as u32, t.bounds()))
        .collect();
    let (bih, _) = build_items(&mut refs, region, cfg);
    bih
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
        let leaf = BihNode::leaf(first as u32, count as u32);
        if self.cfg.ends_in_leaf(count, depth) {
            self.nodes[id] = leaf;
            return;
        }
        if let Some(cut) = self.cfg.empty_cut.and_then(|p| empty_gap(&region, side, p)) {
            return self.clip_node(id, first, count, candidate, side, depth, region, cut);
        }
        let Some(split) = self.choose(first, count, &mut candidate, side) else {
            self.nodes[id] = leaf;
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
        let (mut lr, mut rr) = (region, region);
        lr.max[split.axis] = lr.max[split.axis].min(cl);
        rr.min[split.axis] = rr.min[split.axis].max(cr);
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

    /// The split of the configured choice; binned SAH falls back to the
    /// global heuristic when no binned plane separates in `f32`.
    fn choose(
        &mut self,
        first: usize,
        count: usize,
        candidate: &mut Aabb,
        side: &Side,
    ) -> Option<Split> {
        let centers = side.centers();
        match self.cfg.split {
            SplitChoice::GlobalHeuristic => {
                choose_split_counted(candidate, &centers, &mut self.stats.f32_stalls)
            }
            SplitChoice::BinnedSah { bins } => {
                if centers.min == centers.max {
                    return None;
                }
                self.stats.items_binned += count as u64;
                sah_split(&self.items[first..first + count], &centers, bins).or_else(|| {
                    choose_split_counted(candidate, &centers, &mut self.stats.f32_stalls)
                })
            }
        }
    }

    /// The empty-space cut-off: node `id` becomes a clip node on
    /// `cut.axis` whose empty child is a leaf of no triangles behind a
    /// plane at ∓∞ (so traversal never enters it: the ray leaves that child
    /// before it enters, see `traverse.rs`), and whose other child is the
    /// node again, its region cut to its triangles on that side. The
    /// candidate box is left as it is, so the planes below are the ones the
    /// node would have had.
    #[allow(clippy::too_many_arguments)]
    fn clip_node(
        &mut self,
        id: usize,
        first: usize,
        count: usize,
        candidate: Aabb,
        side: &Side,
        depth: u32,
        mut region: Aabb,
        cut: Cut,
    ) {
        let a = cut.axis;
        let children = self.nodes.len();
        self.nodes.push(BihNode::default());
        self.nodes.push(BihNode::default());
        self.stats.clip_nodes += 1;
        let (empty, full, cl, cr) = if cut.low {
            region.min[a] = side.lo[a];
            (children, children + 1, f32::NEG_INFINITY, side.lo[a])
        } else {
            region.max[a] = side.hi[a];
            (children + 1, children, side.hi[a], f32::INFINITY)
        };
        // The empty leaf sits where its slots would be (before the node's
        // triangles, or after them): leaf ranges stay in tree order.
        let at = if cut.low { first } else { first + count };
        self.nodes[empty] = BihNode::leaf(at as u32, 0);
        self.nodes[id] = BihNode::inner(children as u32, a, cl, cr);
        self.node(full, first, count, candidate, side, depth + 1, region);
    }
}

/// A gap to cut off: on `axis`, below the triangles (`low`) or above.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cut {
    axis: usize,
    low: bool,
}

/// The widest gap between `region` and the triangles' box `side` that is
/// more than `percent` of the region's extent on its axis, if any (ties: the
/// lower axis, the low side). In `f64`: extents may pass `f32::MAX`.
fn empty_gap(region: &Aabb, side: &Side, percent: u32) -> Option<Cut> {
    let threshold = percent as f64 / 100.0;
    let mut best: Option<(f64, Cut)> = None;
    for axis in 0..3 {
        let ext = region.max[axis] as f64 - region.min[axis] as f64;
        if !(ext > 0.0 && ext.is_finite()) {
            continue;
        }
        let gaps = [
            (side.lo[axis] as f64 - region.min[axis] as f64, true),
            (region.max[axis] as f64 - side.hi[axis] as f64, false),
        ];
        for (gap, low) in gaps {
            let f = gap / ext;
            if f > threshold && best.is_none_or(|(b, _)| f > b) {
                best = Some((f, Cut { axis, low }));
            }
        }
    }
    best.map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_gap_over_the_threshold_is_cut_on_its_side_and_none_under_it() {
        let region = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        let mut side = Side::EMPTY;
        side.lo = Vec3A::new(0.0, 0.0, 6.0);
        side.hi = Vec3A::new(10.0, 9.0, 10.0);
        // z: 60 % empty below; y: 10 % above.
        assert_eq!(
            empty_gap(&region, &side, 50),
            Some(Cut { axis: 2, low: true })
        );
        assert_eq!(
            empty_gap(&region, &side, 5),
            Some(Cut { axis: 2, low: true })
        );
        assert_eq!(empty_gap(&region, &side, 60), None);
        side.lo.z = 0.0;
        assert_eq!(
            empty_gap(&region, &side, 5),
            Some(Cut {
                axis: 1,
                low: false
            })
        );
        assert_eq!(empty_gap(&region, &side, 10), None);
    }
}
