//! The PPE's share of an update (section 3: Algorithm 1, the scan of the
//! enclosing node's interval by geometry id, the graft; section 5: the deep
//! update's descent and its index bookkeeping), counted as the update does
//! it and charged on the PPE's clock.
//!
//! The rebuilds run on the SPEs; the PPE finds what to rebuild before them
//! ([`PpeWork`] "find") and puts the rebuilt subtrees in place after them
//! ("apply"), so its time adds to the update's. Each step is priced in two
//! parts: its own work (compares, branches, stores: [`PpeRates`], counted
//! from IBM's "Cell Broadband Engine Architecture and its first
//! implementation": a dependent floating-point operation about 10 cycles,
//! a mispredicted branch 23, half of them 11.5), and each load and store
//! it makes, which [`PpeMemory`] runs through a model of the PPE's caches
//! (`cell::ppe_cache`: 32 KiB L1, 512 KiB L2, 128-byte lines) at the
//! addresses of the arrays the step touches. An access found in the L1
//! costs a chained L1 load (6.4 cycles), in the L2 a chained L2 hit (36),
//! both timed on a retail PS3 (cellmark's PPE page,
//! `cellmark:docs/ppe_tuning.md`); one neither holds costs the machine's
//! `ppe_memory_cycles`. So a scan whose id column and geometry-id table
//! exceed the L2 (3.5 MB each on the dragon) pays the memory latency
//! where it misses, and one over a small scene does not. The caches are
//! empty at each update's start (between updates the application
//! transforms the moved objects and the frame is rendered, through the
//! same caches). They are the PPE's own, in either code class: the naive
//! build's fitted `ppe_partition_item` (48-byte records far beyond the
//! L2, an allocation a node) is that build's figure, not these steps'.
//! Copies of triangle ids go at the PPE's memory bandwidth
//! (`CostModel::ppe_memory_bandwidth`), bytes read and written.
//!
//! Not charged here: the moved objects' boxes before and after (the EBB),
//! made while the application transforms their triangles (its work, as the
//! transform is).

use serde::Serialize;

use std::cell::{Cell, RefCell};

use crate::cell::ppe_cache::{Loads, PpeCaches};
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
    /// The steps' loads and stores, by where the PPE's caches found them.
    pub loads: Loads,
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
        Cycles(steps + copies.0 + self.loads_cycles(cost).0)
    }

    /// The cycles of the steps' loads and stores: each at the latency of
    /// the level that held its line.
    pub fn loads_cycles(&self, cost: &CostModel) -> Cycles {
        crate::kernels::ppe_rates::loads_cycles(&self.loads, cost)
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
        self.loads += o.loads;
    }
}

/// The arrays the PPE's steps touch, each at its own place in the PPE's
/// address space (a region of 2^40 bytes apiece, its index times its
/// element's bytes from the region's start).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Array {
    /// The tree's nodes (12 bytes).
    Nodes,
    /// The triangle order: the tree's triangle ids (4 bytes a slot).
    PrimIds,
    /// Each triangle's geometry id (4 bytes a triangle).
    GeometryIds,
    /// Each geometry's moved flag (a byte a geometry).
    Moved,
    /// The scene's triangles (three vertices, 36 bytes).
    Triangles,
    /// A rebuilt subtree's nodes as its build left them in main memory
    /// (12 bytes); each piece at a place of its own.
    Piece,
}

impl Array {
    fn bytes(self) -> u64 {
        match self {
            Array::Nodes | Array::Piece => 12,
            Array::PrimIds | Array::GeometryIds => 4,
            Array::Moved => 1,
            Array::Triangles => 36,
        }
    }
}

/// The PPE's caches as an update's steps meet them: each load and store
/// at the address of the element it touches. Off where nothing is timed
/// (a host builder, the functional mode): then it models nothing and the
/// host's time is the update's alone.
#[derive(Clone, Debug)]
pub struct PpeMemory {
    on: bool,
    caches: RefCell<PpeCaches>,
    /// Where the next rebuilt subtree's nodes lie in [`Array::Piece`].
    next_piece: Cell<u64>,
}

impl PpeMemory {
    /// The PPE's caches, empty, modelled only if `on`.
    pub fn new(on: bool) -> Self {
        PpeMemory {
            on,
            caches: RefCell::new(PpeCaches::ps3()),
            next_piece: Cell::new(0),
        }
    }

    fn ea(array: Array, index: u64) -> u64 {
        ((array as u64 + 1) << 40) + index * array.bytes()
    }

    /// Empties the caches and their tally.
    pub fn cold(&self) {
        if !self.on {
            return;
        }
        *self.caches.borrow_mut() = PpeCaches::ps3();
        self.next_piece.set(0);
    }

    /// A load of element `index` of `array` (each line it spans).
    pub fn load(&self, array: Array, index: u64) {
        if !self.on {
            return;
        }
        let ea = Self::ea(array, index);
        self.caches.borrow_mut().load_lines(ea, array.bytes());
    }

    /// A store into element `index` of `array`.
    pub fn store(&self, array: Array, index: u64) {
        if !self.on {
            return;
        }
        self.caches.borrow_mut().store(Self::ea(array, index));
    }

    /// The place of a new piece of `nodes` nodes in [`Array::Piece`]: its
    /// first node's index there.
    pub fn new_piece(&self, nodes: u64) -> u64 {
        let at = self.next_piece.get();
        self.next_piece.set(at + nodes);
        at
    }

    /// The accesses since the last take.
    pub fn take(&self) -> Loads {
        std::mem::take(&mut self.caches.borrow_mut().loads)
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

    #[test]
    fn each_load_costs_the_latency_of_the_level_that_held_its_line() {
        let cost = CostModel::ps3();
        let w = PpeWork {
            loads: Loads {
                l1: 10,
                l2: 1,
                memory: 2,
            },
            ..PpeWork::default()
        };
        let want = 64 + 36 + 2 * cost.ppe_memory_cycles.0;
        assert_eq!(w.cycles(&cost, &RateOverrides::default()).0, want);
        // A column past the L2 misses a line every 32 ids, each pass; one
        // inside it, only the first time.
        let mem = PpeMemory::new(true);
        for (ids, second_misses) in [(1u64 << 18, 1u64 << 13), (1 << 16, 0)] {
            mem.cold();
            for pass in 0..2 {
                for i in 0..ids {
                    mem.load(Array::PrimIds, i);
                }
                let t = mem.take();
                assert_eq!(t.total(), ids, "{t:?}");
                let misses = if pass == 0 { ids / 32 } else { second_misses };
                assert_eq!(t.memory, misses, "{ids} ids, pass {pass}: {t:?}");
            }
        }
        // Off, nothing is modelled.
        let off = PpeMemory::new(false);
        off.load(Array::Nodes, 7);
        off.store(Array::Nodes, 7);
        assert_eq!(off.take(), Loads::default());
    }
}
