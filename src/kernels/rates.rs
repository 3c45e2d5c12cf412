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
    /// SPE cycles per item binned by the binned SAH split choice: one
    /// 48-byte record as the partition handles it (3 quadword loads; its
    /// box, 8, and center, 2); the bin on all three axes at once ((center −
    /// lo) × scale, to integer, clamped, × 32 bytes: 5); per axis the index
    /// moved to the preferred slot (3 odd), the bin's count and box loaded
    /// (6 odd), grown (3 × 5 even) and stored (6 odd): about 30 even and 19
    /// odd, dual-issued 30, and the store-to-load chain when consecutive
    /// triangles fall in one bin. Counted 40, scaled by
    /// [`FITTED_OVER_DERIVED`].
    pub spe_bin_item: Cycles,
    /// SPE cycles per bin and axis of the binned SAH sweep
    /// (`kernels::sah::Bins::choose`): the right-to-left running union
    /// stored (single precision, about 6), then left to right the running
    /// union and, in double precision as the kernel computes them, both
    /// sides' extents, surface areas, `area · count`, the sum and the
    /// compare: about 10 double-precision instructions, which the PS3's SPU
    /// issues one every 7 cycles (CBE programming handbook, "Floating-point
    /// operations"): about 70. Counted 75, scaled the same way.
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

/// The partition's fitted SPE rate over its derived one: the factor a new
/// SPE kernel's derived rate is scaled by, so that no strategy is faster
/// only because its bookkeeping is modelled as cheaper. The partition
/// counted like every derived kernel (one 48-byte record at a time, as the
/// paper's code): odd pipe — 3 quadword loads, 3 shuffles to gather the
/// split axis' coordinates, 3 quadword stores, a branch: about 10; even
/// pipe — the record's box (8), its center (2), the compare (1), the
/// chosen side's box and center bounds (8, and 8 selects of that side's
/// accumulators), two pointer updates (2): about 29; dual-issued 29, with
/// the dependent min/max chain (6-cycle latency) not fully hidden: about
/// 40. Fitted 161 (Table 1, Dragon): 161 / 40 ≈ 4. Every derived rate is
/// in this one class, *written like the paper's partition*; SPU kernels
/// timed on a PS3 run within 9 % of their count (tuned code: about x1.1),
/// so 4 is the paper's code, not the pipeline (`docs/validation.md`,
/// "Compute").
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

/// One rate of a rate set `S` (the shared kernels' [`KernelRates`], a
/// strategy's own): its name, written once, where it lives in the set, and
/// how sure its value is. The set's table of these is what overrides,
/// sensitivity and the registry read: a name in one place only.
pub struct Rate<S: 'static> {
    /// The rate's name, as [`RateOverrides`] takes it.
    pub name: &'static str,
    /// The rate in a set.
    pub at: fn(&mut S) -> &mut Cycles,
    pub band: Band,
}

/// How sure a rate's value is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Band {
    /// Fitted on a figure timed on hardware: it does not move.
    Fitted,
    /// Not pinned, and no band given (why not).
    Open(&'static str),
    /// Not pinned by a measurement; plausibly between `low` and `high`
    /// (why the band is what it is).
    Between {
        low: Cycles,
        high: Cycles,
        why: &'static str,
    },
}

/// A rate set's table ([`Rate`]s), each rate named by its field (after
/// `prefix`), so that a name is written once:
/// `rate_table!(KernelRates, "", { spe_job: estimate(200), … })`.
#[macro_export]
macro_rules! rate_table {
    ($set:ty, $prefix:literal, { $($field:ident: $band:expr),* $(,)? }) => {
        &[$($crate::kernels::rates::Rate::<$set> {
            name: concat!($prefix, stringify!($field)),
            at: |s| &mut s.$field,
            band: $band,
        }),*]
    };
}

/// A rate of some set with its type left out: what the registry lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RateInfo {
    pub name: &'static str,
    pub band: Band,
}

impl<S> Rate<S> {
    /// The rate without its set.
    pub fn info(&self) -> RateInfo {
        RateInfo {
            name: self.name,
            band: self.band,
        }
    }
}

impl RateInfo {
    /// The rate as the sensitivity report moves it, if it has a band.
    pub fn uncertain(&self) -> Option<Uncertain> {
        match self.band {
            Band::Between { low, high, why } => Some(Uncertain {
                name: self.name,
                low,
                high,
                why,
            }),
            Band::Fitted | Band::Open(_) => None,
        }
    }
}

/// Every rate of `table`, without its set.
pub fn infos<S>(table: &[Rate<S>]) -> Vec<RateInfo> {
    table.iter().map(Rate::info).collect()
}

/// `base` with the rates of `table` that `overrides` moves.
pub fn overridden<S: Copy>(base: S, table: &[Rate<S>], overrides: &RateOverrides) -> S {
    let mut set = base;
    for rate in table {
        if let Some(v) = overrides.get(rate.name) {
            *(rate.at)(&mut set) = v;
        }
    }
    set
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
/// A name no rate table holds is refused when a build is checked
/// (`registry::Build::check`).
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
        overridden(KernelRates::PS3, KernelRates::TABLE, self)
    }
}

/// A derived rate's band: from its value (the instruction count scaled
/// like the partition) to 1.6 times it (the partition's own derived count
/// misses its fit by that much before scaling: the key-bit rate's 30 to
/// 49 cycles).
pub const fn derived(low: u64, high: u64) -> Band {
    Band::Between {
        low: Cycles(low),
        high: Cycles(high),
        why: "derived",
    }
}

/// An estimate's band: from half to twice its value.
const fn estimate(value: u64) -> Band {
    Band::Between {
        low: Cycles(value / 2),
        high: Cycles(value * 2),
        why: "estimate",
    }
}

impl KernelRates {
    /// Every shared kernel rate: an estimate from half to twice its value;
    /// a derived rate by [`derived`]'s band. The two fitted rates do not
    /// move.
    pub const TABLE: &'static [Rate<KernelRates>] = crate::rate_table!(KernelRates, "", {
        ppe_partition_item: Band::Fitted,
        ppe_node: estimate(1000),
        spe_partition_item: Band::Fitted,
        spe_bounds_item: estimate(20),
        spe_job: estimate(200),
        spe_bin_item: derived(160, 256),
        spe_sah_bin: derived(300, 480),
        ppe_sah_bin: Band::Open("by analogy with spe_sah_bin"),
        spe_level_scan: derived(8, 13),
    });
}

/// Checks a rate table against its set: every field is in the table once,
/// under its own name (`prefix` + the field's), and overriding a name
/// moves that field and no other.
#[cfg(test)]
pub(crate) fn check_table<S: Copy + serde::Serialize>(base: S, table: &[Rate<S>], prefix: &str) {
    let fields = |s: &S| match serde_json::to_value(s).unwrap() {
        serde_json::Value::Object(m) => m,
        _ => panic!("a rate set serializes as an object"),
    };
    let plain = fields(&base);
    let mut named: Vec<&str> = table.iter().map(|r| r.name).collect();
    named.sort_unstable();
    named.dedup();
    assert_eq!(named.len(), table.len(), "a name twice");
    assert_eq!(plain.len(), table.len(), "a field without a rate, or more");
    for r in table {
        let field = r.name.strip_prefix(prefix).expect("the set's prefix");
        let old = plain[field].as_u64().expect("cycles");
        let moved = overridden(
            base,
            table,
            &RateOverrides::default().with(r.name, Cycles(old + 7)),
        );
        let changed: Vec<String> = (fields(&moved).into_iter())
            .filter(|(k, v)| plain[k] != *v)
            .map(|(k, _)| k)
            .collect();
        assert_eq!(changed, [field.to_string()], "{}", r.name);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kernel_table_names_every_rate_once() {
        check_table(KernelRates::PS3, KernelRates::TABLE, "");
        let mut base = KernelRates::PS3;
        for r in KernelRates::TABLE {
            if let Band::Between { low, high, .. } = r.band {
                let at = *(r.at)(&mut base);
                assert!(
                    low <= at && at <= high,
                    "{}: {at:?} outside its band",
                    r.name
                );
            }
        }
    }
}
