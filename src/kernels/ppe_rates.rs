//! The PPE's rates of an update's steps (section 3's Algorithm 1, the scan
//! by geometry id and the graft; section 5's deep descent), priced from
//! the bytes each step touches and the PPE's measured latencies: the
//! derivation is `update::ppe`'s, where the steps are counted. They live
//! here, beside the other rate tables, so that the registry lists them.

use crate::cell::Cycles;
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

/// The PPE's rates of an update's steps, cycles each.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PpeRates {
    /// A node read on the way down (Algorithm 1, the deep descent): a
    /// pointer chase through a tree far larger than the L2 (the dragon's
    /// 20 MB), so the node comes from memory; then its planes against the
    /// region and the EBB (two dependent min/max, 20; two compares, 10),
    /// whether to widen (10), the branch (11.5). No published PPE memory
    /// latency was found; 912 cycles (285 ns) is the count (60) scaled
    /// like the naive partition (× 15.2), kept as the memory round trip
    /// plus that work: an estimate, half to twice.
    pub node_visit: Cycles,
    /// A moved triangle routed to a child by the deep descent: its box's
    /// two bounds on the node's axis (in L1 since the EBB was made: 6.4),
    /// two dependent compares with the planes (20), the branch (11.5), its
    /// id pushed (2): 40. Band: 30 (the compares overlapped) to 90 (the
    /// box's line from the L2: + 36, and the push's line).
    pub route: Cycles,
    /// A slot of the interval scanned by geometry id: the triangle id
    /// streamed (4 bytes at 2.75 GB/s: 4.7), its geometry id (a dependent
    /// load into an array of 4 bytes a triangle: an L2 hit, 36), that
    /// geometry's moved flag (a chained L1 load, 6.4), the compare and a
    /// branch that moved runs make predictable (2), the slot noted (1):
    /// 50. Band: 17 (ids in order, so the geometry ids come from L1 lines,
    /// streamed with `dcbt`) to 150 (a 128-byte line streamed in from
    /// memory at the plain rate for every slot).
    pub scan_slot: Cycles,
    /// A node written by the graft (or a kept subtree's node whose leaves
    /// shift): the piece's node read (an L1 line streamed: 6.4), the leaf
    /// test's branch (11.5), a free pair taken (a load and a store: 7.4),
    /// three words stored and the children pushed (5), and the tree's line
    /// brought into the L2 to be written (an L2 hit: 36): 66. Band: 31
    /// (the line already in L1) to 220 (each node's line from memory at
    /// the plain streaming rate, 149, besides).
    pub node_write: Cycles,
}

impl PpeRates {
    /// The PS3's.
    pub const PS3: PpeRates = PpeRates {
        node_visit: Cycles(912),
        route: Cycles(40),
        scan_slot: Cycles(50),
        node_write: Cycles(66),
    };

    /// Each rate, named (`update.…`) and banded.
    pub fn table() -> Vec<Rate<PpeRates>> {
        let between = |low, high, why| Band::Between {
            low: Cycles(low),
            high: Cycles(high),
            why,
        };
        crate::rate_table!(PpeRates, "update.", {
            node_visit: between(456, 1824, "estimate"),
            route: between(30, 90, "derived for the PPE"),
            scan_slot: between(17, 150, "derived for the PPE"),
            node_write: between(31, 220, "derived for the PPE"),
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
            // The id streamed, its geometry id from the L2, the moved flag
            // from the L1, the compare and predictable branch, the note.
            (
                PpeRates::PS3.scan_slot,
                4.0 * STREAM_BYTE + L2_HIT + L1_LOAD + 2.0 + 1.0,
            ),
            // The bounds from L1, two dependent compares, half a
            // mispredict, the push.
            (
                PpeRates::PS3.route,
                L1_LOAD + 2.0 * DEPENDENT_FP + MISPREDICT / 2.0 + 2.0,
            ),
            // The node from L1, the leaf test's branch, a free pair (a load
            // and a store), three words and the pushes, the line from L2.
            (
                PpeRates::PS3.node_write,
                L1_LOAD + MISPREDICT / 2.0 + (L1_LOAD + 1.0) + 5.0 + L2_HIT,
            ),
        ];
        for (rate, sum) in sums {
            assert_eq!(rate.0, sum.round() as u64, "{sum}");
        }
    }
}
