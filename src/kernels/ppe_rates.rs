//! The PPE's rates of an update's steps (section 3's Algorithm 1, the scan
//! by geometry id and the graft; section 5's deep descent), priced from
//! the bytes each step touches and the PPE's measured latencies: the
//! derivation is `update::ppe`'s, where the steps are counted. They live
//! here, beside the other rate tables, so that the registry lists them.

use crate::cell::ppe_cache::Loads;
use crate::cell::{CostModel, Cycles};
use crate::kernels::rates::{Band, Rate, RateOverrides, overridden};

/// The PPE's measured latencies and bandwidths its rates are built from,
/// in cycles at 3.2 GHz: cellmark's PPE page (`docs/ppe_tuning.md` §6, a
/// retail PS3) and IBM's "Cell Broadband Engine Architecture and its
/// first implementation" (2005). `validate`'s PPE section lists them and
/// writes a sort timed on a PS3's PPE with them.
pub mod latency {
    /// A load chained on the one before, hitting the L1 (2.0 ns).
    pub const L1_LOAD: f64 = 6.4;
    /// A load chained on the one before, hitting the L2 (11.3 ns).
    pub const L2_HIT: f64 = 36.0;
    /// A byte read streaming from the L2, plain loads (2.75 GB/s).
    pub const STREAM_BYTE: f64 = 3.2 / 2.75;
    /// A byte read streaming from the L2 with `dcbt` 512 bytes ahead
    /// (8.4 GB/s).
    pub const STREAM_BYTE_DCBT: f64 = 3.2 / 8.4;
    /// A floating-point operation whose result the next one waits for
    /// (IBM: about 10 cycles).
    pub const DEPENDENT_FP: f64 = 10.0;
    /// A mispredicted branch (IBM: 23 cycles).
    pub const MISPREDICT: f64 = 23.0;
}

/// The cycles of the PPE's loads and stores `l` on `cost`'s machine: each
/// at the latency of the level of its caches that held its line, a chained
/// L1 load, a chained L2 hit, or the machine's `ppe_memory_cycles` (none
/// in the functional mode).
pub fn loads_cycles(l: &Loads, cost: &CostModel) -> Cycles {
    if !cost.charge_compute {
        return Cycles::ZERO;
    }
    let cached = l.l1 as f64 * latency::L1_LOAD + l.l2 as f64 * latency::L2_HIT;
    Cycles(cached.round() as u64 + l.memory * cost.ppe_memory_cycles.0)
}

/// The PPE's rates of an update's steps, cycles each: a step's own work,
/// its loads and stores left out (`update::ppe` charges each at the level
/// of the PPE's caches that held its line).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PpeRates {
    /// A node read on the way down (Algorithm 1, the deep descent): its
    /// planes against the region and the EBB (two dependent min/max, 20;
    /// two compares, 10), whether to widen (10), the branch (half a
    /// mispredict, 11.5), the child's index (2): 54 (the node's load, a
    /// pointer chase, apart). Band: 27 to 108, half to twice (no PPE code
    /// of the descent was timed).
    pub node_visit: Cycles,
    /// A moved triangle routed to a child by the deep descent: two
    /// dependent compares of its box's bounds with the planes (20), the
    /// branch (11.5), its id pushed (2): 34 (the triangle's load apart).
    /// Band: 24 (the compares overlapped) to 68 (twice).
    pub route: Cycles,
    /// A slot of the interval scanned by geometry id: the compare of the
    /// moved flag and a branch that moved runs make predictable (2), the
    /// slot noted (1): 3 (its three chained loads apart: the triangle id,
    /// its geometry id, that geometry's flag). Band: 2 to 6 (the loop's
    /// own branch and index once more).
    pub scan_slot: Cycles,
    /// A node written by the graft (or a kept subtree's node whose leaves
    /// shift): the leaf test's branch (11.5), a free pair taken (a load
    /// and a store on the free list's top, in L1: 7.4), three words formed
    /// and the children pushed (5): 24 (the piece's node read and the
    /// tree's node stored apart). Band: 16 (the branch predicted) to 48
    /// (twice).
    pub node_write: Cycles,
}

impl PpeRates {
    /// The PS3's.
    pub const PS3: PpeRates = PpeRates {
        node_visit: Cycles(54),
        route: Cycles(34),
        scan_slot: Cycles(3),
        node_write: Cycles(24),
    };

    /// Each rate, named (`update.…`) and banded.
    pub fn table() -> Vec<Rate<PpeRates>> {
        let between = |low, high, why| Band::Between {
            low: Cycles(low),
            high: Cycles(high),
            why,
        };
        crate::rate_table!(PpeRates, "update.", {
            node_visit: between(27, 108, "derived for the PPE"),
            route: between(24, 68, "derived for the PPE"),
            scan_slot: between(2, 6, "derived for the PPE"),
            node_write: between(16, 48, "derived for the PPE"),
        })
        .to_vec()
    }

    /// The rates of a run, with its overrides.
    pub fn of(rates: &RateOverrides) -> PpeRates {
        overridden(Self::PS3, &Self::table(), rates)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_rate_lies_inside_its_band_and_is_named_once() {
        crate::kernels::rates::check_table(PpeRates::PS3, &PpeRates::table(), "update.");
        let mut base = PpeRates::PS3;
        for r in PpeRates::table() {
            let at = *(r.at)(&mut base);
            let Band::Between { low, high, .. } = r.band else {
                panic!("{}: unbanded", r.name)
            };
            assert!(low < at && at < high, "{}", r.name);
        }
    }

    /// Each derived rate is the sum its doc comment names, of the PPE's
    /// measured latencies, rounded to a cycle.
    #[test]
    fn the_derived_rates_are_the_sums_of_their_latencies() {
        use latency::*;
        let sums = [
            // The planes against the region and the EBB, whether to widen,
            // half a mispredict, the child's index.
            (
                PpeRates::PS3.node_visit,
                2.0 * DEPENDENT_FP + 10.0 + 10.0 + MISPREDICT / 2.0 + 2.0,
            ),
            // Two dependent compares, half a mispredict, the push.
            (
                PpeRates::PS3.route,
                2.0 * DEPENDENT_FP + MISPREDICT / 2.0 + 2.0,
            ),
            // The compare and predictable branch, the note.
            (PpeRates::PS3.scan_slot, 2.0 + 1.0),
            // Half a mispredict, a free pair (a load and a store in L1),
            // three words and the pushes.
            (
                PpeRates::PS3.node_write,
                MISPREDICT / 2.0 + (L1_LOAD + 1.0) + 5.0,
            ),
        ];
        for (rate, sum) in sums {
            assert_eq!(rate.0, sum.round() as u64, "{sum}");
        }
    }

    /// The PPE's memory latency is the L2's lookup and a line's round trip
    /// through the machine's memory interface, as the machine prices a
    /// get less the SPU's issue and the MFC's command.
    #[test]
    fn the_ppe_memory_latency_is_the_l2_lookup_and_the_memory_interfaces_line() {
        let c = crate::cell::CostModel::ps3();
        let line = c.dma_latency_cycles.0 + c.memory_bandwidth.cycles(128).0;
        assert_eq!(c.ppe_memory_cycles.0, latency::L2_HIT as u64 + line);
    }
}
