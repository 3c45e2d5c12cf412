//! The contract between a strategy's programs and the rest (section 2's
//! builders and section 5's strategies alike): what a strategy declares
//! ([`Strategy`]: name, knobs, quality, rates, how it spawns), where it
//! finds its input ([`Setup`]), and what its programs leave for reading
//! back ([`Output`], [`Records`], [`SpeWork`]). The strategies and their
//! shared machinery import it; it imports none of them.

use crate::aabb::Aabb;
use crate::bih::{BihConfig, BihNode, Quality};
use crate::cell::{Cell, CellError, CoreCounters, Cycles, Ea, Ppe, Spe};
use crate::kernels::rates::{Code, RateInfo, RateOverrides};
use crate::kernels::recursion::BuildStats;
use crate::spe::footprint::Purpose;

use super::knob::{Knob, Knobs};

/// How a strategy starts: it spawns its programs on the Cell for the
/// triangles of `Setup`, and returns how to read back what they leave
/// (from what they return: [`crate::cell::Exit`]) once they have ended.
pub type Spawn = fn(&mut Cell, &Setup, &BihConfig) -> Result<Readback, CellError>;

/// A strategy's [`Output`], made once its programs have ended.
pub type Readback = Box<dyn FnOnce() -> Result<Output, CellError>>;

/// A strategy of the emulated Cell: what the registry needs of it. Each
/// strategy's file defines one (`pub const STRATEGY: Strategy = …`).
pub struct Strategy {
    /// The `--builder` name.
    pub name: &'static str,
    /// One line for `cellbih builders`.
    pub describe: &'static str,
    /// It puts every SPE of the machine to work (`--spes` changes its time).
    pub multi_spe: bool,
    /// It builds on the PPE alone: no SPE takes part.
    pub ppe_only: bool,
    /// Bytes of main memory it allocates for a scene of `n` triangles
    /// with `cfg` on `spes` SPEs beside the records and the nodes, before
    /// it builds (job buffers, a second array of records): with them, a
    /// lower bound on its footprint that is known before any work.
    pub buffers: fn(n: usize, cfg: &BihConfig, spes: usize) -> u64,
    /// The quality knobs of [`BihConfig`] it builds beyond the paper's
    /// tree; it refuses the others, by name.
    pub quality: Quality,
    /// The strategy knobs it takes (`--NAME`); the others are refused.
    pub knobs: &'static [&'static Knob],
    /// Settings of several of its knobs at once that experiments and
    /// benches also try (each knob's own sweep values they try alone).
    pub combos: &'static [&'static [(&'static Knob, &'static str)]],
    /// Its own kernels' rates (each with its band: the sensitivity report
    /// moves those not pinned by a measurement).
    pub rates: fn(Code) -> Vec<RateInfo>,
    /// What it promises on large scenes (the zoo's goals read it).
    pub promise: Option<Promise>,
    /// Sets up its programs on the Cell.
    pub spawn: Spawn,
}

/// What a multi-SPE strategy promises: on every scene of at least
/// `triangles` triangles, the fastest of its `family` at least `speedup`
/// times the baseline on 8 SPEs, simulated time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Promise {
    pub family: &'static str,
    pub speedup: f64,
    pub triangles: u64,
}

impl Strategy {
    /// A strategy that builds the paper's tree, takes no knob and uses one
    /// SPE at most.
    pub const fn new(name: &'static str, describe: &'static str, spawn: Spawn) -> Self {
        Strategy {
            name,
            describe,
            multi_spe: false,
            ppe_only: false,
            buffers: |_, _, _| 0,
            quality: Quality::PAPER,
            knobs: &[],
            combos: &[],
            rates: |_| Vec::new(),
            promise: None,
            spawn,
        }
    }

    /// It promises `promise` on large scenes.
    pub const fn promising(self, promise: Promise) -> Self {
        Strategy {
            promise: Some(promise),
            ..self
        }
    }

    /// It puts every SPE of the machine to work.
    pub const fn on_every_spe(self) -> Self {
        Strategy {
            multi_spe: true,
            ..self
        }
    }

    /// It builds on the PPE alone.
    pub const fn on_the_ppe(self) -> Self {
        Strategy {
            ppe_only: true,
            ..self
        }
    }

    /// It allocates `buffers` bytes beside the records and nodes.
    pub const fn with_buffers(self, buffers: fn(usize, &BihConfig, usize) -> u64) -> Self {
        Strategy { buffers, ..self }
    }

    /// It builds the quality knobs `quality`.
    pub const fn with_quality(self, quality: Quality) -> Self {
        Strategy { quality, ..self }
    }

    /// It takes the strategy knobs `knobs`.
    pub const fn with_knobs(self, knobs: &'static [&'static Knob]) -> Self {
        Strategy { knobs, ..self }
    }

    /// Its own kernels' rates, from its rate table.
    pub const fn with_rates(self, rates: fn(Code) -> Vec<RateInfo>) -> Self {
        Strategy { rates, ..self }
    }

    /// Experiments and benches also try these settings of several knobs
    /// at once.
    pub const fn with_combos(
        self,
        combos: &'static [&'static [(&'static Knob, &'static str)]],
    ) -> Self {
        Strategy { combos, ..self }
    }
}

/// Where a strategy finds its input in main memory, and its knobs.
pub struct Setup {
    pub triangles: Ea,
    pub count: usize,
    /// The SPEs the build may use: `0 .. spes` (of the Cell's, all unless
    /// the build runs beside other programs: [`crate::frame`]'s casters).
    pub spes: usize,
    pub region: Aabb,
    pub knobs: Knobs,
    /// The code class and the kernel rates moved from its values (`--code`,
    /// `--rate`, the sensitivity report); a strategy charges
    /// `rates.kernels()` and its own rates with these.
    pub rates: RateOverrides,
}

/// What a strategy's programs leave for reading back: the value its
/// [`Readback`] makes of what they returned.
#[derive(Default)]
pub struct Output {
    /// The node array, in one or more pieces (address, node count) that
    /// concatenate in node-id order.
    pub nodes: Vec<(Ea, usize)>,
    pub stats: BuildStats,
    /// The pieces hold unreachable slots (several arenas in one pool):
    /// drop them on read-back, keeping the tree and its sibling pairs.
    pub compact: bool,
    /// Multi-SPE strategies: what each SPE did, by SPE.
    pub spe_work: Vec<SpeWork>,
    /// The SPEs its programs ran on: the strategy's own decision (a
    /// multi-SPE strategy uses fewer than the machine has on a small
    /// scene; the paper's builders use one or none).
    pub spes: usize,
    /// Where the triangles' final order is, if not in the array of records
    /// they started in.
    pub records: Option<Records>,
    /// A strategy made of phases separated by barriers: each phase's name
    /// and the cycle at which it ended (all SPEs through the barrier).
    pub phases: Vec<(&'static str, u64)>,
    /// A strategy that predicts its time before it chooses how many SPEs
    /// to use: what it predicted and chose.
    pub predicted: Option<Prediction>,
}

/// A strategy's prediction of its time on 1, 2, … up to the SPEs given
/// (`machinery::forecast`), and the count it chose from it.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Prediction {
    /// Predicted simulated cycles on `k` SPEs at `cycles[k - 1]`: the
    /// middle of `best` and `worst`.
    pub cycles: Vec<u64>,
    /// The same where every job of a level is as large as the others.
    pub best: Vec<u64>,
    /// The same where every deal the prediction cannot see is as uneven
    /// as it can be.
    pub worst: Vec<u64>,
    /// The count the prediction chose.
    pub chosen: usize,
}

/// Where a strategy leaves the triangles' final order (the leaves' ranges
/// index it), if not in the array of records they started in.
#[derive(Clone, Copy, Debug)]
pub enum Records {
    /// The records, permuted into another array.
    Moved(Ea),
    /// A column of triangle ids: in an array of `stride`-byte records at
    /// `at`, each record's `u32` number `word`.
    Ids { at: Ea, stride: u64, word: usize },
}

/// What one SPE of a multi-SPE build did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SpeWork {
    /// Jobs (nodes) it made.
    pub jobs: u64,
    /// Dealt jobs it stole from another SPE's list (`Knobs::steal`).
    pub stolen: u64,
    /// Takes from the shared job queue that found jobs (`spe_bfs_shared`),
    /// or regions built (`spe_morton`).
    pub taken: u64,
    /// ObjectArena blocks it took, and their slots that hold no node
    /// (skipped to keep a pair in one block, or never reached at the end).
    pub arena_blocks: u64,
    pub arena_unused: u64,
    /// Its job-queue software cache (`spe_bfs_shared --job-cache`).
    pub job_cache: crate::spe::software_cache::CacheStats,
    /// `--finish local`: jobs it finished as subtrees in its local store,
    /// and the most triangles such a job could have (what its local store
    /// held beside the rest of its program; 0: it finished none there).
    pub subtrees: u64,
    pub subtree_limit: u64,
    /// Breadth-first builds: its run's first phase, the top levels (its
    /// start, building or helping to partition them, the deal), and the
    /// subtrees it finished in the local store; the levels it streamed
    /// are the rest.
    pub top: Phase,
    pub in_subtrees: Phase,
}

/// Part of one SPE's run: its cycles, the cycles of them it waited on
/// DMA, and the bytes it moved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Phase {
    pub cycles: u64,
    pub dma_wait: u64,
    pub bytes: u64,
}

impl Phase {
    /// What `spe` did since `from` (its clock and counters then).
    pub fn since(spe: &Spe, from: &(Cycles, CoreCounters)) -> Phase {
        let (t, c) = (spe.now(), spe.counters());
        let bytes = |c: &CoreCounters| c.bytes_get + c.bytes_put;
        Phase {
            cycles: (t - from.0).0,
            dma_wait: (c.dma_wait - from.1.dma_wait).0,
            bytes: bytes(&c) - bytes(&from.1),
        }
    }

    /// `spe`'s clock and counters now, for [`Phase::since`].
    pub fn mark(spe: &Spe) -> (Cycles, CoreCounters) {
        (spe.now(), spe.counters())
    }
}

impl std::ops::AddAssign for Phase {
    fn add_assign(&mut self, o: Phase) {
        self.cycles += o.cycles;
        self.dma_wait += o.dma_wait;
        self.bytes += o.bytes;
    }
}

/// The PPE allocates a node array in main memory and writes `nodes` into
/// it; returns its address and node count, as [`Output::nodes`] holds them.
pub async fn write_nodes(ppe: &Ppe, nodes: &[BihNode]) -> Result<(Ea, usize), CellError> {
    let ea = ppe
        .alloc(
            Purpose::Nodes.buffer("node array"),
            std::mem::size_of_val(nodes) as u64,
            128,
        )
        .await?;
    ppe.write_pod(ea, nodes).await?;
    Ok((ea, nodes.len()))
}
