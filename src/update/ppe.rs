//! The PPE's share of an update (section 3: Algorithm 1, the scan of the
//! enclosing node's interval by geometry id, the graft; section 5: the deep
//! update's descent and its index bookkeeping), counted as the update does
//! it and charged on the PPE's clock.
//!
//! The rebuilds run on the SPEs; the PPE finds what to rebuild before them
//! ([`PpeWork`] "find") and puts the rebuilt subtrees in place after them
//! ("apply"), so its time adds to the update's. Each step is priced from
//! the bytes it touches, how it touches them (streaming, a dependent load,
//! a branch) and the PPE's measured latencies and bandwidths — cellmark's
//! PPE page (`cellmark:docs/ppe_tuning.md`, a retail PS3): a chained L1
//! load 6.4 cycles, an L2 hit 36, L2 reads streaming at 2.75 GB/s plain
//! (1.16 cycles a byte) and 8.4 GB/s with `dcbt`; and IBM's "Cell
//! Broadband Engine Architecture and its first implementation": a
//! dependent floating-point operation about 10 cycles, a mispredicted
//! branch 23 (half of them: 11.5). They are the PPE's own, in either code
//! class: the naive build's fitted `ppe_partition_item` (48-byte records
//! far beyond the L2, an allocation a node) is that build's figure, not
//! these steps'. Copies of triangle ids go at the PPE's memory bandwidth
//! (`CostModel::ppe_memory_bandwidth`), bytes read and written.
//!
//! Not charged here: the moved objects' boxes before and after (the EBB),
//! made while the application transforms their triangles (its work, as the
//! transform is).

use serde::Serialize;

use crate::cell::{CostModel, Cycles};
pub use crate::kernels::ppe_rates::PpeRates;
use crate::kernels::rates::RateOverrides;

/// Bytes a triangle id copy moves: its 4 bytes read and written.
pub const ID_COPY_BYTES: u64 = 8;

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
    /// The PPE cycles of this work on `cost`'s machine at the run's rates
    /// (none where the machine charges no compute: the functional mode).
    pub fn cycles(&self, cost: &CostModel, rates: &RateOverrides) -> Cycles {
        if !cost.charge_compute {
            return Cycles::ZERO;
        }
        let r = PpeRates::of(rates);
        let steps = r.node_visit.0 * self.nodes_visited
            + r.route.0 * self.routed
            + r.scan_slot.0 * self.scanned
            + r.node_write.0 * self.nodes_written;
        let copies = cost
            .ppe_memory_bandwidth
            .cycles(ID_COPY_BYTES * self.ids_copied);
        Cycles(steps + copies.0)
    }

    /// The same in simulated ms.
    pub fn ms(&self, cost: &CostModel, rates: &RateOverrides) -> f64 {
        self.cycles(cost, rates).0 as f64 / cost.clock_hz * 1e3
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
    use crate::kernels::rates::KernelRates;

    #[test]
    fn the_steps_are_charged_at_their_rates_and_copies_at_the_ppe_bandwidth() {
        let cost = CostModel::ps3();
        let rates = RateOverrides::default();
        let one = |w: PpeWork| w.cycles(&cost, &rates).0;
        let scan = one(PpeWork {
            scanned: 1,
            ..PpeWork::default()
        });
        assert_eq!(scan, PpeRates::PS3.scan_slot.0);
        // Far below the naive build's fitted record step.
        assert!(scan * 10 < KernelRates::PS3.ppe_partition_item.0);
        // 1,000 ids copied: 8,000 bytes at 6.4 GB/s, 4,000 cycles.
        let ids = one(PpeWork {
            ids_copied: 1000,
            ..PpeWork::default()
        });
        assert_eq!(ids, cost.ppe_memory_bandwidth.cycles(8000).0);
        assert!((3900..=4100).contains(&ids), "{ids}");
        // A rate moved by name moves that step only.
        let moved = rates.with("update.scan_slot", Cycles(111));
        let w = PpeWork {
            scanned: 2,
            nodes_visited: 1,
            ..PpeWork::default()
        };
        assert_eq!(
            w.cycles(&cost, &moved).0 - w.cycles(&cost, &rates).0,
            2 * (111 - PpeRates::PS3.scan_slot.0)
        );
        // The functional mode charges nothing.
        let free = CostModel {
            charge_compute: false,
            ..cost.clone()
        };
        assert_eq!(w.cycles(&free, &rates), Cycles::ZERO);
        assert!(w.ms(&cost, &rates) > 0.0);
    }
}
