//! The one tree type. Every builder of this crate — host or emulated, every
//! strategy — returns a [`Bih`]; validation, quality metrics, traversal,
//! rendering and updates are written once against it. Each operation lives
//! in its own file (`traverse`, `validate`), as `impl Bih` blocks.

mod lanes;
mod node;
mod traverse;
mod validate;

pub use node::{BihNode, MAX_INDEX};
pub use traverse::{Hit, Ray, RayStats, Tracer, brute_force_closest, intersect_triangle};
pub use validate::Violation;

use crate::aabb::Aabb;

/// The limits every builder honours.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct BihConfig {
    /// A node with at most this many triangles becomes a leaf. The paper's
    /// ray tracer used 12 (section 4.1), and so do we by default.
    pub leaf_size: u32,
    /// Deepest level (root = 0) a leaf may sit at; a node there becomes a
    /// leaf whatever its size. Traversal stacks are sized from it.
    pub max_depth: u32,
}

impl Default for BihConfig {
    fn default() -> Self {
        BihConfig {
            leaf_size: 12,
            max_depth: 64,
        }
    }
}

impl BihConfig {
    /// The deepest tree traversal supports (its stack has this many slots).
    pub const MAX_SUPPORTED_DEPTH: u32 = 126;

    /// Whether a node of `count` triangles at `depth` is a leaf whatever
    /// its triangles: the one rule every builder applies, so that they all
    /// make the same tree.
    pub fn ends_in_leaf(&self, count: usize, depth: u32) -> bool {
        count <= self.leaf_size as usize || depth >= self.max_depth
    }
}

/// A Bounding Interval Hierarchy over a scene's triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct Bih {
    /// Root at index 0; children of an inner node are adjacent.
    pub nodes: Vec<BihNode>,
    /// Leaf order → triangle id: a leaf `(first, count)` holds triangles
    /// `prim_ids[first .. first + count]`. A permutation of the scene's ids.
    pub prim_ids: Vec<u32>,
    /// The root region: the scene box the tree was built for.
    pub bounds: Aabb,
    pub config: BihConfig,
}

impl Bih {
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes of the node array and the triangle index array.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.prim_ids.as_slice())
    }
}
