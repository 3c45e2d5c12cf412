//! Algorithm 1 of the paper: from the root, narrow down to the smallest node
//! whose subtree encloses the *enclosing bounding box* (EBB) of what moved.
//!
//! Where the paper is terse we read it so:
//!
//! - an *interval* of a node is a child's slab, its region clipped by the
//!   child's plane; it *overlaps* the EBB when they share a point (touching
//!   counts, so no triangle on a plane is missed);
//! - the *splitting plane* is the plane the global heuristic splits the
//!   node's region at: the middle of the region on the node's axis (the
//!   tree does not store the candidate box the builder used, so the region
//!   stands for it, as it does when the interval is rebuilt);
//! - *setting the clipping plane to the EBB's value* widens the child's
//!   plane in the tree, so that the child's interval holds the EBB, and with
//!   it the moved geometry's new state.
//!
//! Why this finds every moved triangle: a moved triangle's old box lies in
//! the EBB, and (the tree being valid) in the interval of every ancestor
//! of its leaf; the traversal leaves a child only when the child's interval
//! does not overlap the EBB, so the leaf is below the enclosing node. And the
//! enclosing node's region contains the EBB (the root's is the unchanged
//! scene box; each step keeps it, widening if need be), so the rebuilt
//! subtree holds the new state within its ancestors' planes.

use serde::Serialize;

use crate::aabb::Aabb;
use crate::bih::Bih;

/// Why Algorithm 1 stopped where it did.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// A leaf was reached.
    Leaf,
    /// Both intervals overlap the EBB: no telling which side the moved
    /// geometry belongs to.
    BothOverlap,
    /// One interval overlaps the EBB but does not contain it, and the EBB
    /// straddles the splitting plane: "abort traversal".
    Straddles,
    /// Neither interval overlaps the EBB (it lies in the gap between them).
    NoneOverlaps,
}

/// The smallest node found whose subtree encloses the EBB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Enclosing {
    pub node: u32,
    /// The node's region: the scene box clipped by its ancestors' planes,
    /// widened to the EBB where Algorithm 1 set a plane. The scene box of
    /// the rebuild.
    pub region: Aabb,
    /// Depth of the node (root = 0): the paper's "traversal depth".
    pub depth: u32,
    pub stop: Stop,
    /// Clip planes Algorithm 1 set to the EBB on the way down.
    pub planes_set: u32,
}

/// Algorithm 1: narrows from the root to the enclosing node of `ebb`,
/// setting clip planes to the EBB where an interval must grow to hold it.
/// `ebb` must lie inside the tree's root region (otherwise the scene box
/// changed and the paper rebuilds everything).
pub fn enclosing_node(bih: &mut Bih, ebb: &Aabb, read: &mut impl FnMut(u32)) -> Enclosing {
    debug_assert!(bih.bounds.contains_box(ebb), "the EBB leaves the scene box");
    let (mut id, mut region, mut depth, mut planes_set) = (0u32, bih.bounds, 0u32, 0u32);
    let stop = loop {
        read(id);
        let node = bih.nodes[id as usize];
        if node.is_leaf() {
            break Stop::Leaf;
        }
        let a = node.axis();
        let [mut cl, mut cr] = node.clip();
        let (mut left, mut right) = (region, region);
        left.max[a] = left.max[a].min(cl);
        right.min[a] = right.min[a].max(cr);
        let (in_left, in_right) = (left.overlaps(ebb), right.overlaps(ebb));
        if in_left && in_right {
            break Stop::BothOverlap;
        }
        if !in_left && !in_right {
            break Stop::NoneOverlaps;
        }
        // Only one interval overlaps the EBB.
        let mut interval = if in_left { left } else { right };
        if !interval.contains_box(ebb) {
            let splitting_plane = region.center()[a];
            if ebb.min[a] < splitting_plane && splitting_plane < ebb.max[a] {
                break Stop::Straddles;
            }
            // Set the clipping plane for the interval to the EBB's value.
            if in_left {
                cl = cl.max(ebb.max[a]);
                interval.max[a] = interval.max[a].max(ebb.max[a]);
            } else {
                cr = cr.min(ebb.min[a]);
                interval.min[a] = interval.min[a].min(ebb.min[a]);
            }
            bih.nodes[id as usize] = crate::bih::BihNode::inner(node.left_child(), a, cl, cr);
            planes_set += 1;
        }
        // Set traversal data to the successive node.
        id = node.left_child() + u32::from(!in_left);
        region = interval;
        depth += 1;
    };
    Enclosing {
        node: id,
        region,
        depth,
        stop,
        planes_set,
    }
}

/// The triangle interval of the subtree at `node`: from its leftmost leaf's
/// first slot to its rightmost leaf's end (a subtree's leaves are adjacent in
/// the triangle order).
pub fn interval(bih: &Bih, node: u32) -> (usize, usize) {
    let mut l = bih.nodes[node as usize];
    while !l.is_leaf() {
        l = bih.nodes[l.left_child() as usize];
    }
    let mut r = bih.nodes[node as usize];
    while !r.is_leaf() {
        r = bih.nodes[r.left_child() as usize + 1];
    }
    let ((first, _), (rf, rc)) = (l.leaf_range(), r.leaf_range());
    (first as usize, (rf + rc) as usize)
}
