//! The compute rates of the kernels that host-side recursion, PPE programs
//! and SPE programs share (DESIGN.md rule 4: cost is charged where the work
//! is done, by named rates): the Table 1 calibration's two fitted rates,
//! the estimates beside them, and the binned SAH's derived rates. A
//! strategy's own kernels keep their rates in the strategy's file
//! (`spe_morton`'s keys and radix passes). The machine never charges these
//! itself; programs charge them through `Spe::compute_items` and
//! `Ppe::compute_items`, and the functional mode charges nothing.
//! Sources, derivations and the calibration: `docs/cost-model.md`,
//! `docs/calibration.md`.

use crate::cell::Cycles;

/// Compute rates of the shared kernels, per core type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct KernelRates {
    /// PPE cycles per item looked at by an in-place partition (load the
    /// record, its box center, compare, swap), all cache effects included.
    /// Fitted on one cell of the paper's Table 1 (naive PPE build of the
    /// Stanford Bunny, 340 ms) with `ppe_node` fixed beforehand.
    pub ppe_partition_item: Cycles,
    /// PPE cycles per node written: split choice, a heap allocation for the
    /// node (the paper's naive build allocates each), recursion. Estimate.
    pub ppe_node: Cycles,
    /// SPE cycles per item of an in-place partition on a local-store block
    /// (box of the record's three vertices, center, compare, move). Fitted
    /// on one cell of Table 1 (SPE breadth-first build of the Dragon, 897 ms).
    pub spe_partition_item: Cycles,
    /// SPE cycles per item of a bounds pass (box and center min/max only).
    /// Estimate.
    pub spe_bounds_item: Cycles,
    /// SPE cycles per job of a build run on the SPE (read the job, choose
    /// the split, write the node, push the children's jobs). Estimate.
    pub spe_job: Cycles,
    /// SPE cycles per item binned by the binned SAH split choice (the
    /// record's box and center, a bin index per axis, three bins' counts
    /// and boxes updated). Derived from an instruction count and scaled by
    /// the partition's fitted/derived ratio (`docs/cost-model.md`).
    pub spe_bin_item: Cycles,
    /// SPE cycles per bin and axis of the binned SAH sweep (the two
    /// running unions, both sides' areas and the cost in double precision,
    /// the best kept). Derived and scaled the same way.
    pub spe_sah_bin: Cycles,
    /// PPE cycles per bin and axis of the binned SAH sweep
    /// (`ppe_naive`, `spe_dfs`): by analogy with `spe_sah_bin`, the same
    /// sweep, whose dependent double-precision operations the PPE's scalar
    /// FPU issues at a latency close to the SPU's.
    pub ppe_sah_bin: Cycles,
    /// SPE cycles per job looked at when the multi-SPE strategies' top
    /// levels decide whether a level is balanced enough to deal (a load of
    /// the job's count from `WorkA`, a compare and an add: about 2 SPU
    /// cycles pipelined). Derived and scaled the same way.
    pub spe_level_scan: Cycles,
}

/// The partition's fitted SPE rate over its derived one (161 fitted, 40
/// SPU cycles counted): the factor a new SPE kernel's derived rate is
/// scaled by, so that no strategy is faster only because its bookkeeping
/// is modelled as cheaper (`docs/cost-model.md`). Every derived rate is in
/// this one class, *written like the paper's partition*, supported by the
/// partition's Table 1 fit; SPU kernels timed on a PS3 run within 9 % of
/// their count (tuned code: about x1.1), so 4 is the paper's code, not
/// the pipeline (`docs/validation.md`, "Compute").
pub const FITTED_OVER_DERIVED: u64 = 4;

impl KernelRates {
    /// The PS3's, as calibrated and derived.
    pub const PS3: KernelRates = KernelRates {
        ppe_partition_item: Cycles(1065),
        ppe_node: Cycles(1000),
        spe_partition_item: Cycles(161),
        spe_bounds_item: Cycles(20),
        spe_job: Cycles(200),
        // Derived: 40 and 75 SPU cycles; x4 the same way.
        spe_bin_item: Cycles(40 * FITTED_OVER_DERIVED),
        spe_sah_bin: Cycles(75 * FITTED_OVER_DERIVED),
        // By analogy: spe_sah_bin's count and scale.
        ppe_sah_bin: Cycles(75 * FITTED_OVER_DERIVED),
        // Derived: 2 SPU cycles a job; x4 the same way.
        spe_level_scan: Cycles(2 * FITTED_OVER_DERIVED),
    };
}

/// A rate whose value is not pinned by a measurement, and the band it may
/// plausibly lie in: what the sensitivity report moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Uncertain {
    /// The rate's name, as [`RateOverrides`] takes it.
    pub name: &'static str,
    pub low: Cycles,
    pub high: Cycles,
    /// Why the band is what it is.
    pub why: &'static str,
}

/// Rates moved from their PS3 values for one run, by name (the
/// sensitivity report's); empty: every rate as calibrated and derived.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RateOverrides(Vec<(&'static str, Cycles)>);

impl RateOverrides {
    /// These overrides and `name` at `value`.
    pub fn with(mut self, name: &'static str, value: Cycles) -> Self {
        self.0.retain(|(n, _)| *n != name);
        self.0.push((name, value));
        self
    }

    /// `name`'s value if it is moved.
    pub fn get(&self, name: &str) -> Option<Cycles> {
        self.0.iter().find(|(n, _)| *n == name).map(|&(_, v)| v)
    }

    /// The names moved.
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.0.iter().map(|(n, _)| *n)
    }

    /// The shared kernels' rates with these overrides.
    pub fn kernels(&self) -> KernelRates {
        let mut k = KernelRates::PS3;
        for (name, field) in [
            ("ppe_node", &mut k.ppe_node),
            ("spe_bounds_item", &mut k.spe_bounds_item),
            ("spe_job", &mut k.spe_job),
            ("spe_bin_item", &mut k.spe_bin_item),
            ("spe_sah_bin", &mut k.spe_sah_bin),
            ("ppe_sah_bin", &mut k.ppe_sah_bin),
            ("spe_level_scan", &mut k.spe_level_scan),
        ] {
            if let Some(v) = self.get(name) {
                *field = v;
            }
        }
        k
    }
}

impl KernelRates {
    /// The shared kernels' rates that are estimates, derived or by
    /// analogy, with their plausible bands: an estimate from half to twice
    /// its value; a derived rate from its value (the instruction count
    /// scaled like the partition) to 1.6 times it (the partition's own
    /// derived count misses its fit by that much before scaling: the
    /// key-bit rate's 30 to 49 cycles). The two fitted rates do not move.
    pub const UNCERTAIN: &'static [Uncertain] = &[
        Uncertain {
            name: "ppe_node",
            low: Cycles(500),
            high: Cycles(2000),
            why: "estimate",
        },
        Uncertain {
            name: "spe_bounds_item",
            low: Cycles(10),
            high: Cycles(40),
            why: "estimate",
        },
        Uncertain {
            name: "spe_job",
            low: Cycles(100),
            high: Cycles(400),
            why: "estimate",
        },
        Uncertain {
            name: "spe_bin_item",
            low: Cycles(160),
            high: Cycles(256),
            why: "derived",
        },
        Uncertain {
            name: "spe_sah_bin",
            low: Cycles(300),
            high: Cycles(480),
            why: "derived",
        },
        Uncertain {
            name: "spe_level_scan",
            low: Cycles(8),
            high: Cycles(13),
            why: "derived",
        },
    ];
}
