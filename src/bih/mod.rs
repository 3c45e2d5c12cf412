//! The one tree type. Every builder of this crate — host or emulated, every
//! strategy — returns a [`Bih`]; validation, quality metrics, traversal,
//! rendering and updates are written once against it. Each operation lives
//! in its own file (`traverse`, `validate`), as `impl Bih` blocks.

mod hash;
mod lanes;
mod node;
mod packet;
mod tracer;
mod traverse;
mod validate;
mod watertight;
mod wide;

pub use node::{BihNode, MAX_INDEX};
pub use packet::PACKET_RAYS;
pub use tracer::Tracer;
pub use traverse::{
    Hit, Ray, RayStats, brute_force_closest, intersect_sheared, intersect_triangle, test_sheared,
    times_pow2,
};
pub(crate) use traverse::{closer, descend, pop_bound, root_interval};
pub use validate::Violation;
pub use watertight::Shear;

use crate::aabb::Aabb;

/// Relative widening of node intervals: covers the three roundings of
/// `(clip - o) * (1/d)` in `f64` many times over.
const SLACK: f64 = 1e-12;

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

/// The limits every builder honours, and the quality knobs (which builder
/// builds which: [`Quality`]). Each knob is off by default: the
/// default is the paper's tree, and Table 1 does not move.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct BihConfig {
    /// A node with at most this many triangles becomes a leaf. The paper's
    /// ray tracer used 12 (section 4.1), and so do we by default. Buys
    /// (smaller): fewer triangle tests per ray. Costs: more nodes, more
    /// partitions, more node visits.
    pub leaf_size: u32,
    /// Deepest level (root = 0) a leaf may sit at; a node there becomes a
    /// leaf whatever its size. Traversal stacks are sized from it.
    pub max_depth: u32,
    /// How an inner node chooses its plane.
    pub split: SplitChoice,
    /// Empty-space cut-off (Wächter & Keller 2006, section 3.2; Sunflow's
    /// BIH): when the node's triangles leave a gap of more than this
    /// percentage of the node's extent on one side of one axis, a *clip
    /// node* cuts the gap off before the node splits. Buys: rays that pass
    /// through the gap no longer descend into the node. Costs: two more
    /// nodes (24 bytes) and one more level per cut. `None`: off.
    pub empty_cut: Option<u32>,
}

/// The split choice of an inner node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum SplitChoice {
    /// The paper's: halve the candidate box at the middle of its longest
    /// side, the *global heuristic* ([`crate::kernels::split::choose_split`]).
    /// Buys: no pass over the triangles to choose. Costs: planes blind to
    /// where the triangles are.
    GlobalHeuristic,
    /// The plane of least surface-area cost among `bins - 1` candidates on
    /// each axis, the triangles binned by their box centers
    /// ([`crate::kernels::sah`]). Buys: fewer nodes visited and triangles
    /// tested per ray (the high-quality end of the trade). Costs: one more
    /// pass over every node's triangles to bin them.
    ///
    /// Nodes of at most `above` triangles take the global heuristic's
    /// halving instead (0: every node bins). Buys: the build skips the
    /// binning pass and the bin sweep where they cost the most per
    /// triangle — the many small nodes of the lower levels, where most of
    /// the sweeps are. Costs: the lower levels' planes are blind again;
    /// measured in `docs/tradeoff.md`.
    BinnedSah { bins: u32, above: u32 },
}

impl Default for BihConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl BihConfig {
    /// The paper's limits and quality: leaves of 12, depth 64, the global
    /// heuristic, no cut-off.
    pub const DEFAULT: BihConfig = BihConfig {
        leaf_size: 12,
        max_depth: 64,
        split: SplitChoice::GlobalHeuristic,
        empty_cut: None,
    };

    /// The quality knobs' high end as the tests and experiments run it:
    /// binned SAH (16 bins) with the empty-space cut-off at 10 %.
    pub const SAH_CUT: BihConfig = BihConfig {
        split: SplitChoice::BinnedSah { bins: 16, above: 0 },
        empty_cut: Some(10),
        ..BihConfig::DEFAULT
    };

    /// The deepest tree traversal supports (its stack has this many slots).
    pub const MAX_SUPPORTED_DEPTH: u32 = 126;

    /// Whether a node of `count` triangles at `depth` is a leaf whatever
    /// its triangles: the one rule every builder applies, so that they all
    /// make the same tree.
    pub fn ends_in_leaf(&self, count: usize, depth: u32) -> bool {
        count <= self.leaf_size as usize || depth >= self.max_depth
    }

    /// The `cellbih build` options that give this configuration (empty for
    /// the default), as reports name settings.
    pub fn flags(&self) -> String {
        let d = BihConfig::DEFAULT;
        let mut f = Vec::new();
        if self.leaf_size != d.leaf_size {
            f.push(format!("--leaf-size {}", self.leaf_size));
        }
        if self.max_depth != d.max_depth {
            f.push(format!("--max-depth {}", self.max_depth));
        }
        if let SplitChoice::BinnedSah { bins, above } = self.split {
            f.push("--split sah".to_string());
            if bins != DEFAULT_BINS {
                f.push(format!("--sah-bins {bins}"));
            }
            if above != 0 {
                f.push(format!("--sah-above {above}"));
            }
        }
        if let Some(p) = self.empty_cut {
            f.push(format!("--empty-cut {p}"));
        }
        f.join(" ")
    }

    /// The bins per axis that a node of `count` triangles chooses its plane
    /// with, or `None` where it takes the global heuristic's halving: the
    /// one rule every builder applies.
    pub fn sah_bins(&self, count: usize) -> Option<u32> {
        match self.split {
            SplitChoice::BinnedSah { bins, above } if count > above as usize => Some(bins),
            _ => None,
        }
    }

    /// Whether the split choice and empty-space cut-off are the paper's
    /// (the global heuristic, no cut-off): what every builder supports.
    pub fn paper_quality(&self) -> bool {
        self.split == SplitChoice::GlobalHeuristic && self.empty_cut.is_none()
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
    /// Bytes of the node array and the triangle index array.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.prim_ids.as_slice())
    }
}

/// `nodes` (root 0, children adjacent) renumbered in the serial
/// recursion's order: a node's two children take the next two ids when the
/// node is made, its left subtree is made before its right. A builder that
/// makes the serial recursion's nodes in another order gives back its node
/// array this way.
pub fn depth_first(nodes: &[BihNode]) -> Vec<BihNode> {
    let mut out = vec![BihNode::default(); nodes.len()];
    let mut next = 1;
    let mut stack = vec![(0usize, 0usize)];
    while let Some((from, to)) = stack.pop() {
        let n = nodes[from];
        if n.is_leaf() {
            out[to] = n;
            continue;
        }
        let (c, children) = (n.left_child() as usize, next);
        next += 2;
        let [l, r] = n.clip();
        out[to] = BihNode::inner(children as u32, n.axis(), l, r);
        stack.push((c + 1, children + 1));
        stack.push((c, children));
    }
    out.truncate(next);
    out
}

/// Which of [`BihConfig`]'s quality knobs a builder builds (the leaf size
/// and depth limit every builder builds).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quality {
    /// `SplitChoice::BinnedSah`: the builder bins its nodes' triangles.
    pub binned_sah: bool,
    /// `BihConfig::empty_cut`: the builder knows each node's region.
    pub empty_cut: bool,
}

impl Quality {
    /// The paper's tree only.
    pub const PAPER: Quality = Quality {
        binned_sah: false,
        empty_cut: false,
    };
    /// Every knob (the shared recursion of `kernels::recursion` builds them).
    pub const ALL: Quality = Quality {
        binned_sah: true,
        empty_cut: true,
    };
    /// Whether a builder with these knobs builds `cfg`.
    pub fn builds(self, cfg: &BihConfig) -> bool {
        (self.binned_sah || cfg.split == SplitChoice::GlobalHeuristic)
            && (self.empty_cut || cfg.empty_cut.is_none())
    }

    /// The options of `cfg` a builder with these does not build, as the
    /// command line spells them (empty where it builds `cfg`).
    pub fn missing(self, cfg: &BihConfig) -> Vec<&'static str> {
        let mut m = Vec::new();
        if !self.binned_sah && cfg.split != SplitChoice::GlobalHeuristic {
            m.push("--split sah");
        }
        if !self.empty_cut && cfg.empty_cut.is_some() {
            m.push("--empty-cut");
        }
        m
    }

    /// `cfg` without the knobs a builder with these does not build (the
    /// paper's setting in their place).
    pub fn reach(self, cfg: &BihConfig) -> BihConfig {
        BihConfig {
            split: if self.binned_sah {
                cfg.split
            } else {
                SplitChoice::GlobalHeuristic
            },
            empty_cut: cfg.empty_cut.filter(|_| self.empty_cut),
            ..*cfg
        }
    }
}

/// Bins per axis when none is asked for: 16, a common choice (Wald 2007
/// found 16 bins within a few percent of the full sweep's quality).
pub const DEFAULT_BINS: u32 = 16;
/// Most bins per axis a builder accepts.
pub const MAX_BINS: u32 = 256;
