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
    /// PPE cycles per record of the bounds pass the PPE's builds make of
    /// their input (the box of the triangles and of their centers, which
    /// the SPE builds pay at `spe_bounds_item`): [`PPE_BOUNDS_ITEM`].
    pub ppe_bounds_item: Cycles,
    /// SPE cycles per job looked at when the multi-SPE strategies' top
    /// levels decide whether a level is balanced enough to deal (a load of
    /// the job's count from `WorkA`, a compare and an add: about 2 SPU
    /// cycles pipelined). Derived and scaled the same way.
    pub spe_level_scan: Cycles,
    /// SPE cycles per record of an interval the rebuild streams, to find
    /// whether its triangle moved (the update's search moved to the SPEs,
    /// `--find-moved spe`): the geometry id rotated out of the record's
    /// quadword (1 odd), its word and bit of the moved-geometry bitmap in
    /// the local store (2 even), the word loaded (1 odd), the bit shifted
    /// and tested (2 even), a hinted branch (1 odd): about 4 dual-issued,
    /// 5 counted. Scaled the same way.
    pub spe_find_slot: Cycles,
    /// SPE cycles per moved record put in place of the stale one in the
    /// stream: its three quadwords loaded from the moved records got by
    /// DMA and stored (3 odd + 3 odd), the pointer moved on: 6 counted.
    pub spe_find_moved: Cycles,
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

/// The class of code a kernel rate prices: the paper's code, compiled C
/// with SIMD intrinsics, or tuned SIMD. A derived rate is its instruction
/// count on the SPU's two pipelines ([`Count`]) times the class's factor;
/// the class is a model option (`--code`), the same for every strategy
/// and the caster.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Code {
    /// The paper's code: scalar, a record at a time, latency-bound, like the
    /// partition Table 1 fits (its count × [`FITTED_OVER_DERIVED`]). The
    /// partition keeps its fitted rate. The default.
    #[default]
    Paper,
    /// C with SIMD intrinsics as spu-gcc compiles it, where most shipped
    /// Cell code sat: its count × [`compiled::FACTOR_PER_MILLE`] / 1000,
    /// the factor two such kernels timed on a retail PS3 run at over
    /// their counts ([`compiled`]), the partition included (its count,
    /// 40, × the factor).
    Compiled,
    /// Tuned SIMD code: its count × 1.1, as SPU kernels timed on a PS3 run
    /// (`validate`'s compute section: within 9 % of their count), the
    /// partition included (its count, 40, × 1.1).
    Tuned,
}

/// The compiled class's factor, from two SPU kernels written in C with
/// intrinsics, compiled by spu-lv2-gcc 4.1.1 at -O3 and timed by each
/// SPE's decrementer on a retail PS3 with all their data in the local
/// store (cellmark, `benches/nbody/`, `benches/fft/`; README §7 and
/// `docs/cell_tuning.md` §5.2). Each is counted from its source as every
/// derived rate is (even pipe: arithmetic, compares, shifts; odd: loads,
/// stores, shuffles, the estimate instructions, branches; the busier pipe's
/// slots), and its measured cycles divided by the count:
///
/// - **N-body**, one vector of four pairs (`spu_nbody_kernel.c`'s inner
///   loop): even 3 `fs` + 3 `fma` (r²) + 3 `fm` + 3 `fma` (the
///   accelerations) + the loop's add = 13; odd 4 `lqd`, `frsqest`, the
///   branch = 6: 13 cycles. Measured 2,195 Mpairs/s on 6 SPEs: 3.2 GHz ×
///   6 / 2,195 M = 8.75 cycles a pair, 34.99 a vector: **2.69** × the
///   count (the four accumulators' and r²'s 6-cycle chains, not the
///   issue slots, bound it).
/// - **FFT**, one batch of four 1,024-point transforms (`spu_fft_kernel.c`,
///   everything the timed loop runs): 5,120 vector butterflies at 16 (even
///   8 single-precision operations + 8 integer: the two indices, their
///   byte offsets, the twiddle index and its offset, the counter and its
///   compare; odd 15: two scalar twiddle loads each `lqx` + `rotqby` +
///   `shufb` splat, 4 `lqx`, 4 `stqx`, the branch), the bit reversal's
///   1,024 steps at 7 (a table load, its rotate, the compare and branch;
///   half of them swap two vectors of each array), the 1,023 passes of the
///   middle loop at 5: 94,203 cycles. Measured 184.82 Mpoints/s on 6 SPEs:
///   103.9 cycles a point, 425,514 a batch of 4,096 points: **4.52** × the
///   count (a butterfly's loads wait on the last one's stores, which the
///   compiler cannot prove apart, and the short early stages miss their
///   branches).
///
/// The class charges their geometric mean, 3.49, and its band runs from
/// the one to the other. A BIH kernel (loads and stores through indices,
/// short data-dependent loops) is nearer the FFT's kind than the N-body's
/// streaming arithmetic: the band's high end is the likelier side. The
/// paper's fitted partition, 161 over its count 40 (4.0), lies inside this
/// band: the paper's scalar code and compiled SIMD C cost about the same.
pub mod compiled {
    /// N-body's measured cycles over its count, per mille: 34.99 / 13.
    pub const NBODY_PER_MILLE: u64 = 2_692;
    /// The FFT's measured cycles over its count, per mille:
    /// 425,514 / 94,203.
    pub const FFT_PER_MILLE: u64 = 4_517;
    /// The class's factor, per mille: their geometric mean,
    /// √(2.692 × 4.517) = 3.487.
    pub const FACTOR_PER_MILLE: u64 = (NBODY_PER_MILLE * FFT_PER_MILLE).isqrt();
}

impl Code {
    /// Every class, the default first.
    pub const ALL: [Code; 3] = [Code::Paper, Code::Compiled, Code::Tuned];

    /// Its name, as `--code` takes it.
    pub const fn name(self) -> &'static str {
        match self {
            Code::Paper => "paper",
            Code::Compiled => "compiled",
            Code::Tuned => "tuned",
        }
    }

    /// The class named `name`.
    pub fn from_name(name: &str) -> Option<Code> {
        Code::ALL.into_iter().find(|c| c.name() == name)
    }

    /// The cycles charged for a kernel counted at `count`.
    pub const fn charge(self, count: Count) -> Cycles {
        match self {
            Code::Paper => Cycles(count.0 * FITTED_OVER_DERIVED / 10),
            // Tenths × the factor per mille, rounded to the nearest cycle.
            Code::Compiled => Cycles((count.0 * compiled::FACTOR_PER_MILLE + 5_000) / 10_000),
            // × 1.1, rounded to the nearest cycle.
            Code::Tuned => Cycles((count.0 * 11 + 50) / 100),
        }
    }

    /// A derived rate's band in this class, two-sided around `value` (the
    /// rate charged for `count`). The paper's class: down to 0.73 of it —
    /// Codeplay's scalar C++ quicksort on one SPU through a software cache
    /// runs 117–121 cycles an element a level where the fitted partition
    /// takes 161 — and up to 1.6 times it (the partition's own count misses
    /// its fit by that much before scaling). Tuned: from the count itself
    /// (the hardware never beat a count) to 1.25 times it (IBM's Cell
    /// programming tutorial: well-written SPU kernels reach 80–95 % of
    /// their issue-limited peak). Compiled: from the N-body's factor to
    /// the FFT's ([`compiled`]).
    pub const fn band(self, count: Count) -> Band {
        let value = self.charge(count).0;
        match self {
            Code::Paper => Band::Between {
                low: Cycles(value * 73 / 100),
                high: Cycles(value * 16 / 10),
                why: "derived",
            },
            Code::Compiled => Band::Between {
                low: Cycles(count.0 * compiled::NBODY_PER_MILLE / 10_000),
                high: Cycles((count.0 * compiled::FFT_PER_MILLE).div_ceil(10_000)),
                why: "derived",
            },
            Code::Tuned => Band::Between {
                low: Cycles(count.0.div_ceil(10)),
                high: Cycles((count.0 * 125).div_ceil(1000)),
                why: "derived",
            },
        }
    }
}

impl std::fmt::Display for Code {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// An instruction count, in tenths of an SPU cycle (a key bit costs 7.5
/// cycles a triangle: `Count::tenths(75)`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Count(pub u64);

impl Count {
    /// `cycles` whole SPU cycles.
    pub const fn of(cycles: u64) -> Count {
        Count(cycles * 10)
    }

    /// `tenths` tenths of an SPU cycle.
    pub const fn tenths(tenths: u64) -> Count {
        Count(tenths)
    }
}

/// The counts behind the shared kernels' derived rates (their fields' doc
/// comments give each count).
pub mod counts {
    use super::Count;
    /// The paper's partition step (see [`super::FITTED_OVER_DERIVED`]).
    pub const SPE_PARTITION_ITEM: Count = Count::of(40);
    /// A bounds pass's record (`KernelRates::spe_bounds_item`).
    pub const SPE_BOUNDS_ITEM: Count = Count::of(20);
    /// A job's own work (`KernelRates::spe_job`).
    pub const SPE_JOB: Count = Count::of(50);
    pub const SPE_BIN_ITEM: Count = Count::of(40);
    pub const SPE_SAH_BIN: Count = Count::of(75);
    pub const SPE_LEVEL_SCAN: Count = Count::of(2);
    pub const SPE_FIND_SLOT: Count = Count::of(5);
    pub const SPE_FIND_MOVED: Count = Count::of(6);
}

impl KernelRates {
    /// The PS3's in the paper's class, as calibrated and derived.
    pub const PS3: KernelRates = KernelRates::of(Code::Paper);

    /// The PS3's in the class `code`: the SPU's kernels at their counts ×
    /// the class's factor (the partition fitted in the paper's class); the
    /// PPE's the same in both (the PPE's code is the paper's either way).
    pub const fn of(code: Code) -> KernelRates {
        KernelRates {
            ppe_partition_item: Cycles(1065),
            ppe_node: Cycles(1000),
            spe_partition_item: match code {
                Code::Paper => Cycles(161),
                Code::Compiled | Code::Tuned => code.charge(counts::SPE_PARTITION_ITEM),
            },
            spe_bounds_item: code.charge(counts::SPE_BOUNDS_ITEM),
            spe_job: code.charge(counts::SPE_JOB),
            spe_bin_item: code.charge(counts::SPE_BIN_ITEM),
            spe_sah_bin: code.charge(counts::SPE_SAH_BIN),
            ppe_sah_bin: Cycles(PPE_SAH_BIN),
            ppe_bounds_item: Cycles(PPE_BOUNDS_ITEM),
            spe_level_scan: code.charge(counts::SPE_LEVEL_SCAN),
            spe_find_slot: code.charge(counts::SPE_FIND_SLOT),
            spe_find_moved: code.charge(counts::SPE_FIND_MOVED),
        }
    }
}

/// The bands of the two fitted rates: the spread of their fits, each
/// rate refitted on every real-mesh cell of its Table 1 column on the
/// default model (`table1 --fits`, generated in `docs/calibration.md`;
/// a test holds these to it). The rates stay as fitted: 1,065 (naive /
/// Bunny) and 161 (breadth first / Dragon).
pub mod table1_fits {
    use crate::cell::Cycles;
    /// `ppe_partition_item` refitted on naive / Bunny and naive / Dragon.
    pub const PPE_PARTITION_ITEM: (Cycles, Cycles) = (Cycles(1012), Cycles(1048));
    /// `spe_partition_item` refitted on breadth first / Dragon and / Bunny.
    pub const SPE_PARTITION_ITEM: (Cycles, Cycles) = (Cycles(158), Cycles(201));
}

/// A fitted rate's band: the spread of its fits and of `value`, the rate
/// as fitted (which stays: since the PPE's loads go through its caches the
/// naive build's fits lie below its value, and the band holds both).
const fn fits((low, high): (Cycles, Cycles), value: Cycles) -> Band {
    Band::Between {
        low: if value.0 < low.0 { value } else { low },
        high: if value.0 > high.0 { value } else { high },
        why: "Table 1's fits",
    }
}

/// `ppe_sah_bin`, derived for the PPE: the sweep's ten dependent
/// double-precision operations a bin and axis at the PPE FPU's 10-cycle
/// dependent latency (IBM, "Cell Broadband Engine Architecture and its
/// first implementation": the in-order PPE's dependent floating-point
/// operation), and the single-precision union, loads and stores beside
/// them (about 10): 110 cycles, in either class.
pub const PPE_SAH_BIN: u64 = 110;

/// `ppe_bounds_item`, derived for the PPE: a record's three vertices as
/// three quadwords (L1 hits: the read of the array streamed them in), the
/// box's minimum and maximum each a chain of three dependent vector
/// min/max a record at the PPE's dependent-operation latency (10 cycles,
/// `ppe_rates::latency::DEPENDENT_FP`; the centers' chains run beside
/// them), and the loads: 32 cycles, in either class. Band: 21 (the chain
/// at the 7-cycle latency of cellmark's PPE FMA) to 64.
pub const PPE_BOUNDS_ITEM: u64 = 32;

/// One rate of a rate set `S` (the shared kernels' [`KernelRates`], a
/// strategy's own): its name, written once, where it lives in the set, and
/// how sure its value is. The set's table of these is what overrides,
/// sensitivity and the registry read: a name in one place only.
#[derive(Clone, Copy)]
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
    /// Its value in the set it was listed from.
    pub value: Cycles,
    pub band: Band,
}

impl<S: Copy> Rate<S> {
    /// The rate without its set, at its value in `base`.
    pub fn info(&self, base: S) -> RateInfo {
        let mut set = base;
        RateInfo {
            name: self.name,
            value: *(self.at)(&mut set),
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

/// Every rate of `table`, without its set, at its value in `base`.
pub fn infos<S: Copy>(base: S, table: &[Rate<S>]) -> Vec<RateInfo> {
    table.iter().map(|r| r.info(base)).collect()
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

/// The most rates one run can move by name.
const MOST_MOVED: usize = 128;

/// The library's rates for one run: the code class, and the rates moved
/// from that class's values by name (`--rate`, `--rates`, the sensitivity
/// report); `RateOverrides::default()`: the paper's class, nothing moved.
/// A name no rate table holds is refused when a build is checked
/// (`registry::Build::check`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RateOverrides {
    code: Code,
    moved: [(&'static str, Cycles); MOST_MOVED],
    len: usize,
}

impl Default for RateOverrides {
    fn default() -> Self {
        RateOverrides::PAPER
    }
}

impl RateOverrides {
    /// The paper's class, nothing moved.
    pub const PAPER: RateOverrides = RateOverrides {
        code: Code::Paper,
        moved: [("", Cycles::ZERO); MOST_MOVED],
        len: 0,
    };

    /// These overrides in the class `code`.
    pub fn with_code(self, code: Code) -> Self {
        RateOverrides { code, ..self }
    }

    /// The code class.
    pub fn code(&self) -> Code {
        self.code
    }

    /// These overrides and `name` at `value`.
    pub fn with(mut self, name: &'static str, value: Cycles) -> Self {
        if let Some(at) = self.moved[..self.len].iter_mut().find(|(n, _)| *n == name) {
            at.1 = value;
            return self;
        }
        assert!(self.len < MOST_MOVED, "more than {MOST_MOVED} rates moved");
        self.moved[self.len] = (name, value);
        self.len += 1;
        self
    }

    /// `name`'s value if it is moved.
    pub fn get(&self, name: &str) -> Option<Cycles> {
        (self.moved[..self.len].iter())
            .find(|(n, _)| *n == name)
            .map(|&(_, v)| v)
    }

    /// The names moved.
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.moved[..self.len].iter().map(|(n, _)| *n)
    }

    /// The shared kernels' rates in this class, with these overrides.
    pub fn kernels(&self) -> KernelRates {
        overridden(
            KernelRates::of(self.code),
            &KernelRates::table(self.code),
            self,
        )
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
    /// Every shared kernel rate in the class `code`: a derived rate by
    /// [`Code::band`], an estimate from half to twice its value, a fitted
    /// rate across the spread of its fits ([`table1_fits`]; in the classes
    /// other than the paper's the SPU partition is derived).
    pub fn table(code: Code) -> Vec<Rate<KernelRates>> {
        let fitted_or = |count| match code {
            Code::Paper => fits(
                table1_fits::SPE_PARTITION_ITEM,
                Self::PS3.spe_partition_item,
            ),
            Code::Compiled | Code::Tuned => code.band(count),
        };
        crate::rate_table!(KernelRates, "", {
            ppe_partition_item: fits(table1_fits::PPE_PARTITION_ITEM, Self::PS3.ppe_partition_item),
            ppe_node: estimate(1000),
            spe_partition_item: fitted_or(counts::SPE_PARTITION_ITEM),
            spe_bounds_item: code.band(counts::SPE_BOUNDS_ITEM),
            spe_job: code.band(counts::SPE_JOB),
            spe_bin_item: code.band(counts::SPE_BIN_ITEM),
            spe_sah_bin: code.band(counts::SPE_SAH_BIN),
            ppe_sah_bin: Band::Between {
                low: Cycles(80),
                high: Cycles(160),
                why: "derived for the PPE",
            },
            ppe_bounds_item: Band::Between {
                low: Cycles(21),
                high: Cycles(64),
                why: "derived for the PPE",
            },
            spe_level_scan: code.band(counts::SPE_LEVEL_SCAN),
            spe_find_slot: code.band(counts::SPE_FIND_SLOT),
            spe_find_moved: code.band(counts::SPE_FIND_MOVED),
        })
        .to_vec()
    }
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
        for code in Code::ALL {
            check_table(KernelRates::of(code), &KernelRates::table(code), "");
            let mut base = KernelRates::of(code);
            for r in KernelRates::table(code) {
                if let Band::Between { low, high, .. } = r.band {
                    let at = *(r.at)(&mut base);
                    assert!(
                        low < at && at < high
                            || low == at && code == Code::Tuned
                            || high == at && r.name == "ppe_partition_item",
                        "{code}: {}: {at:?} not inside its band",
                        r.name
                    );
                }
            }
        }
    }

    #[test]
    fn the_tuned_class_charges_less_than_the_papers_and_the_partition_its_count() {
        let (paper, tuned) = (KernelRates::of(Code::Paper), KernelRates::of(Code::Tuned));
        assert_eq!(paper, KernelRates::PS3);
        assert_eq!(paper.spe_partition_item, Cycles(161));
        assert_eq!(tuned.spe_partition_item, Cycles(44));
        assert!(tuned.spe_job < paper.spe_job && tuned.spe_bin_item < paper.spe_bin_item);
        assert_eq!(paper.ppe_partition_item, tuned.ppe_partition_item);
        assert_eq!(Code::Paper.charge(Count::tenths(75)), Cycles(30));
        assert_eq!(Code::Tuned.charge(Count::tenths(75)), Cycles(8));
        let moved = RateOverrides::default()
            .with_code(Code::Tuned)
            .with("spe_job", Cycles(7));
        assert_eq!(moved.kernels().spe_job, Cycles(7));
        assert_eq!(moved.kernels().spe_bin_item, tuned.spe_bin_item);
    }

    #[test]
    fn the_compiled_class_lies_between_the_kernels_it_is_derived_from() {
        assert_eq!(compiled::FACTOR_PER_MILLE, 3_487);
        let (paper, compiled, tuned) = (
            KernelRates::of(Code::Paper),
            KernelRates::of(Code::Compiled),
            KernelRates::of(Code::Tuned),
        );
        // 40 × 3.487: between the tuned partition and the fitted one.
        assert_eq!(compiled.spe_partition_item, Cycles(139));
        assert!(tuned.spe_job < compiled.spe_job && compiled.spe_job < paper.spe_job);
        // The paper's fitted partition (161, 4.0 × its count) is inside the
        // compiled band: the scalar code the paper fits costs what compiled
        // SIMD C costs.
        let Band::Between { low, high, .. } = Code::Compiled.band(counts::SPE_PARTITION_ITEM)
        else {
            panic!("a derived band")
        };
        assert_eq!((low, high), (Cycles(107), Cycles(181)));
        assert!(low < paper.spe_partition_item && paper.spe_partition_item < high);
        assert_eq!(Code::from_name("compiled"), Some(Code::Compiled));
    }
}
