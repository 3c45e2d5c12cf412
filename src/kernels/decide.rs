//! The node decision, written once for every builder (the host recursion,
//! `spe_dfs`'s PPE, the SPE breadth-first loop): what a node of `count`
//! triangles becomes, in the order the host builder established — a
//! **leaf** by the size and depth rule; a **clip node** where the
//! empty-space cut-off finds a gap ([`super::cutoff`]); else a **split**,
//! whose plane the global heuristic chooses at once (section 2) or binned
//! SAH chooses once the node's triangles are binned ([`super::sah`]), which
//! a builder does where the records are.

use super::cutoff::{Clip, empty_gap};
use super::split::{Side, Split, choose_split_counted};
use crate::aabb::Aabb;
use crate::bih::{BihConfig, BihNode};

/// What a node becomes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Decision {
    /// A leaf of the node's triangles.
    Leaf,
    /// A clip node; its full child is the node again, in the clip's region.
    Clip(Clip),
    /// A split by the global heuristic, and the candidate box it was
    /// chosen in (its empty halvings peeled).
    Split(Split, Aabb),
    /// A split by binned SAH into this many bins, once the triangles are
    /// binned (`sah::Bins::choose_or_halve`, which may still find none:
    /// then a leaf).
    Bin(u32),
}

/// A node's triangles as the decision sees them.
#[derive(Clone, Copy, Debug)]
pub struct NodeView {
    pub first: usize,
    pub count: usize,
    pub depth: u32,
    /// The box its ancestors' planes leave it (what a ray must enter).
    pub region: Aabb,
    /// Its triangles' bounds and their centers' bounds.
    pub bounds: Aabb,
    pub centers: Aabb,
    /// The global heuristic's candidate box.
    pub candidate: Aabb,
}

impl NodeView {
    /// The node of `count` triangles from `first` at `depth` whose
    /// triangles' bounds and centers' bounds `side` holds.
    pub fn of_side(
        (first, count, depth): (usize, usize, u32),
        region: Aabb,
        side: &Side,
        candidate: Aabb,
    ) -> Self {
        NodeView {
            first,
            count,
            depth,
            region,
            bounds: side.bounds(),
            centers: side.centers(),
            candidate,
        }
    }
}

/// What the node `v` becomes under `cfg`; `stalls` counts the halvings
/// `f32` could not make (`kernels::split::choose_split_counted`).
pub fn decide(cfg: &BihConfig, v: &NodeView, stalls: &mut u64) -> Decision {
    if cfg.ends_in_leaf(v.count, v.depth) {
        return Decision::Leaf;
    }
    if let Some(cut) = (cfg.empty_cut).and_then(|p| empty_gap(&v.region, &v.bounds, p)) {
        return Decision::Clip(cut.clip(v.region, &v.bounds, v.first, v.count));
    }
    if v.centers.min == v.centers.max {
        // No plane can separate triangles whose centers coincide.
        return Decision::Leaf;
    }
    match cfg.sah_bins(v.count) {
        Some(bins) => Decision::Bin(bins),
        None => {
            let mut candidate = v.candidate;
            match choose_split_counted(&mut candidate, &v.centers, stalls) {
                Some(s) => Decision::Split(s, candidate),
                None => Decision::Leaf,
            }
        }
    }
}

impl Clip {
    /// Makes node `id` of a node array this clip node: its two children
    /// appended (the empty leaf, and a slot for the full child); returns
    /// the full child's id.
    pub fn make_in(&self, nodes: &mut Vec<BihNode>, id: usize) -> usize {
        let children = nodes.len();
        nodes.extend([BihNode::default(); 2]);
        self.make_at(nodes, id, children)
    }

    /// [`Self::make_in`] with the children's two slots at `children`
    /// (handed out by the caller).
    pub fn make_at(&self, nodes: &mut [BihNode], id: usize, children: usize) -> usize {
        nodes[children + self.empty] = BihNode::leaf(self.leaf_at as u32, 0);
        let [cl, cr] = self.planes;
        nodes[id] = BihNode::inner(children as u32, self.axis, cl, cr);
        children + 1 - self.empty
    }
}

#[cfg(test)]
mod tests {
    use super::{Decision, NodeView, decide};
    use crate::aabb::Aabb;
    use crate::bih::BihConfig;
    use glam::Vec3;

    fn view(count: usize, depth: u32, bounds: Aabb, centers: Aabb) -> NodeView {
        let region = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        NodeView {
            first: 0,
            count,
            depth,
            region,
            bounds,
            centers,
            candidate: region,
        }
    }

    #[test]
    fn leaf_then_clip_then_split_in_the_host_builders_order() {
        let full = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        let centers = Aabb::new(Vec3::splat(1.0), Vec3::splat(9.0));
        // A gap of 60 % below on x: clipped with the cut-off, even though
        // the node would split; a leaf first, whatever the gap.
        let gap = Aabb::new(Vec3::new(6.0, 0.0, 0.0), Vec3::splat(10.0));
        let gap_centers = Aabb::new(Vec3::new(7.0, 1.0, 1.0), Vec3::splat(9.0));
        let cut = BihConfig {
            empty_cut: Some(10),
            ..BihConfig::DEFAULT
        };
        let d = |cfg: &BihConfig, v: &NodeView| decide(cfg, v, &mut 0);
        assert_eq!(d(&cut, &view(12, 0, gap, gap_centers)), Decision::Leaf);
        assert_eq!(d(&cut, &view(100, 64, gap, gap_centers)), Decision::Leaf);
        assert!(matches!(
            d(&cut, &view(100, 0, gap, gap_centers)),
            Decision::Clip(c) if c.axis == 0 && c.empty == 0
        ));
        assert!(matches!(
            d(&BihConfig::DEFAULT, &view(100, 0, gap, gap_centers)),
            Decision::Split(..)
        ));
        assert_eq!(
            d(&BihConfig::SAH_CUT, &view(100, 0, full, centers)),
            Decision::Bin(16)
        );
        // Centers that coincide cannot be separated: a leaf, with either
        // split choice.
        let point = Aabb::new(Vec3::splat(5.0), Vec3::splat(5.0));
        for cfg in [BihConfig::DEFAULT, BihConfig::SAH_CUT] {
            assert_eq!(d(&cfg, &view(100, 0, full, point)), Decision::Leaf);
        }
    }
}
