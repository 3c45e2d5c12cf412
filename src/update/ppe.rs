//! The PPE's share of an update (section 3: Algorithm 1, the scan of the
//! enclosing node's interval by geometry id, the graft; section 5: the deep
//! update's descent and its index bookkeeping), counted as the update does
//! it and charged on the PPE's clock.
//!
//! The rebuilds run on the SPEs; the PPE finds what to rebuild before them
//! ([`PpeWork`] "find") and puts the rebuilt subtrees in place after them
//! ("apply"), so its time adds to the update's. The rates:
//!
//! - **pointer-chasing steps** (a node read, a moved triangle routed, an
//!   interval slot scanned, a node written) are counted in cycles of the
//!   in-order PPE — a dependent load 5 cycles, a dependent floating-point
//!   operation 10, a mispredicted branch 23 (its 23-stage pipeline; IBM,
//!   "Cell Broadband Engine Architecture and its first implementation"),
//!   one load or store a cycle otherwise — and scaled like the PPE's
//!   partition: the fitted `ppe_partition_item` (1,065 cycles, Table 1's
//!   naive build of the Bunny) over the same count of the naive
//!   partition's step ([`PARTITION_COUNT`], 70), as the SPE's new kernels
//!   are scaled by the SPE partition's fitted/derived ratio;
//! - **copies of triangle ids** (the interval's order saved, kept ranges
//!   moved, a rebuilt piece's ids written) at the PPE's memory bandwidth
//!   (`CostModel::ppe_memory_bandwidth`), bytes read and written.
//!
//! Not charged here: the moved objects' boxes before and after (the EBB),
//! made while the application transforms their triangles (its work, as the
//! transform is).

use serde::Serialize;

use crate::cell::{CostModel, Cycles};
use crate::kernels::rates::KernelRates;

/// The naive PPE partition's step counted the same way: two dependent
/// loads of the box on the axis (5), its center (an add and a multiply,
/// 10 each), the compare with the split (10), the branch mispredicted half
/// the time (11.5), the swap of two 48-byte records (12 loads and 12
/// stores, 24): 70.
pub const PARTITION_COUNT: u64 = 70;

/// A node read on the way down (Algorithm 1, the deep descent): the node
/// (5), its axis and planes decoded (2), the region clipped to both
/// children (two dependent min/max, 20), the EBB's overlap with each (two
/// compares, 10), whether a plane must be widened (10), the branch
/// mispredicted half the time (11.5): 60.
pub const NODE_VISIT_COUNT: u64 = 60;

/// A moved triangle routed to a child by the deep descent: its box's two
/// bounds on the node's axis loaded (5; the box is made once, when the
/// EBB is), compared with the two planes (10: the node's region already
/// holds the box on the other axes), the branch mispredicted half the
/// time (11.5), its center against the middle where both children could
/// hold it (rare, 2), its id pushed (1), rounded: 30.
pub const ROUTE_COUNT: u64 = 30;

/// A slot of the interval scanned by geometry id: the triangle id (5), its
/// geometry id (a dependent load, 5), the moved flag of that geometry (5),
/// the compare and branch (moved triangles come in runs: 2), the slot
/// noted if moved (1): 18.
pub const SCAN_COUNT: u64 = 18;

/// A node written by the graft (or a kept subtree's node whose leaves are
/// shifted): the piece's node read (5), the leaf test's branch mispredicted
/// half the time (11.5), a free pair taken (a load and a store, 6), the
/// node's three words stored (3), its children pushed (2), rounded: 30.
pub const NODE_WRITE_COUNT: u64 = 30;

/// Bytes a triangle id copy moves: its 4 bytes read and written.
pub const ID_COPY_BYTES: u64 = 8;

/// A count of PPE cycles scaled like the PPE's partition.
fn scaled(count: u64) -> Cycles {
    Cycles(count * KernelRates::PS3.ppe_partition_item.0 / PARTITION_COUNT)
}

/// What the PPE did (or would do) for one update, counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct PpeWork {
    /// Nodes read on the way down: Algorithm 1's, the deep descent's.
    pub nodes_visited: u64,
    /// Moved triangles routed to a child by the deep descent, once a node.
    pub routed: u64,
    /// Slots of the enclosing interval scanned by geometry id.
    pub scanned: u64,
    /// Nodes written by the graft, and nodes of kept subtrees whose
    /// leaves were shifted.
    pub nodes_written: u64,
    /// Triangle ids copied (each read and written).
    pub ids_copied: u64,
}

impl PpeWork {
    /// The PPE cycles of this work on `cost`'s machine (none where the
    /// machine charges no compute: the functional mode).
    pub fn cycles(&self, cost: &CostModel) -> Cycles {
        if !cost.charge_compute {
            return Cycles::ZERO;
        }
        let steps = scaled(NODE_VISIT_COUNT).0 * self.nodes_visited
            + scaled(ROUTE_COUNT).0 * self.routed
            + scaled(SCAN_COUNT).0 * self.scanned
            + scaled(NODE_WRITE_COUNT).0 * self.nodes_written;
        let copies = cost
            .ppe_memory_bandwidth
            .cycles(ID_COPY_BYTES * self.ids_copied);
        Cycles(steps + copies.0)
    }

    /// The same in simulated ms.
    pub fn ms(&self, cost: &CostModel) -> f64 {
        self.cycles(cost).0 as f64 / cost.clock_hz * 1e3
    }
}

impl std::ops::AddAssign for PpeWork {
    fn add_assign(&mut self, o: PpeWork) {
        self.nodes_visited += o.nodes_visited;
        self.routed += o.routed;
        self.scanned += o.scanned;
        self.nodes_written += o.nodes_written;
        self.ids_copied += o.ids_copied;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rates_scale_like_the_partition_and_copies_go_at_the_ppe_bandwidth() {
        let cost = CostModel::ps3();
        let one = |w: PpeWork| w.cycles(&cost).0;
        // A scan slot is 18 of the partition's 70 counted cycles: 273 of
        // its fitted 1,065.
        let scan = one(PpeWork {
            scanned: 1,
            ..PpeWork::default()
        });
        assert_eq!(scan, 18 * 1065 / 70);
        assert!(scan < KernelRates::PS3.ppe_partition_item.0);
        // 1,000 ids copied: 8,000 bytes at 6.4 GB/s, 4,000 cycles.
        let ids = one(PpeWork {
            ids_copied: 1000,
            ..PpeWork::default()
        });
        assert_eq!(ids, cost.ppe_memory_bandwidth.cycles(8000).0);
        assert!((3900..=4100).contains(&ids), "{ids}");
        // The functional mode charges nothing.
        let free = CostModel {
            charge_compute: false,
            ..cost.clone()
        };
        let w = PpeWork {
            nodes_visited: 5,
            scanned: 100,
            ..PpeWork::default()
        };
        assert_eq!(w.cycles(&free), Cycles::ZERO);
        assert!(w.ms(&cost) > 0.0);
    }
}
