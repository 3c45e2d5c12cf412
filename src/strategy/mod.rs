//! Programs for the emulated Cell, one file (or folder) per strategy, named
//! as the paper names them: the four builders of section 2 and Table 1
//! ([`ppe_naive`], [`ppe_approx`], [`spe_dfs`], [`spe_bfs`], the baseline)
//! and section 5's multi-SPE strategies ([`spe_bfs_shared`],
//! [`spe_bfs_private`], [`spe_morton`]); what they share is in
//! [`machinery`]. Each writes its tree into emulated main memory in the one
//! node format; [`run_in`] reads it back as a [`Bih`].

pub mod machinery;
pub mod ppe_approx;
pub mod ppe_naive;
pub mod spe_bfs;
pub mod spe_bfs_private;
pub mod spe_bfs_shared;
pub mod spe_dfs;
pub mod spe_morton;

use std::cell::RefCell;
use std::rc::Rc;

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode, Quality};
use crate::cell::{Cell, CellConfig, CellError, Ea, Ppe, RunReport, Trace};
pub use crate::kernels::morton::KeyOrder;
use crate::kernels::recursion::BuildStats;
use crate::scene::Scene;
use machinery::layout;

/// How a strategy starts: it spawns its programs on the Cell for the
/// triangles of `Setup`, and they leave the tree's node pieces in `Output`.
pub type Spawn = fn(&mut Cell, &Setup, &BihConfig, Rc<RefCell<Output>>) -> Result<(), CellError>;

/// A strategy of the emulated Cell: what the registry needs of it. Each
/// strategy's file defines one (`pub const STRATEGY: Strategy = …`).
pub struct Strategy {
    /// The `--builder` name.
    pub name: &'static str,
    /// One line for `cellbih builders`.
    pub describe: &'static str,
    /// It puts every SPE of the machine to work (`--spes` changes its time).
    pub multi_spe: bool,
    /// The quality knobs of [`BihConfig`] it builds beyond the paper's
    /// tree; it refuses the others, by name.
    pub quality: Quality,
    /// The strategy knobs it takes (`--NAME`); the others are refused.
    pub knobs: &'static [&'static Knob],
    /// Sets up its programs on the Cell.
    pub spawn: Spawn,
}

impl Strategy {
    /// A strategy that builds the paper's tree, takes no knob and uses one
    /// SPE at most.
    pub const fn new(name: &'static str, describe: &'static str, spawn: Spawn) -> Self {
        Strategy {
            name,
            describe,
            multi_spe: false,
            quality: Quality::PAPER,
            knobs: &[],
            spawn,
        }
    }

    /// It puts every SPE of the machine to work.
    pub const fn on_every_spe(self) -> Self {
        Strategy {
            multi_spe: true,
            ..self
        }
    }

    /// It builds the quality knobs `quality`.
    pub const fn with_quality(self, quality: Quality) -> Self {
        Strategy { quality, ..self }
    }

    /// It takes the strategy knobs `knobs`.
    pub const fn with_knobs(self, knobs: &'static [&'static Knob]) -> Self {
        Strategy { knobs, ..self }
    }
}

/// Where a strategy finds its input in main memory, and its knobs.
pub struct Setup {
    pub triangles: Ea,
    pub count: usize,
    pub region: Aabb,
    pub knobs: Knobs,
}

/// A strategy's knob as the command line names it (`--NAME`), declared
/// beside the code that reads it; a builder's table of these
/// ([`Strategy::knobs`]) is what it takes, and a knob given
/// to a builder that does not take it is refused by name.
#[derive(Debug, PartialEq, Eq)]
pub struct Knob {
    /// The option's name without `--`.
    pub name: &'static str,
    /// One line: what it does.
    pub help: &'static str,
    /// The default value, as the command line spells it ("off" for a
    /// flag); [`Knobs::default`] holds it.
    pub default: &'static str,
    /// A value other than the default, as the command line takes it (empty
    /// for a flag): what tests and experiments try.
    pub other: &'static str,
}

/// The values of the strategies' knobs, each field declared here with what
/// it buys and costs; a builder reads only the knobs of its table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Knobs {
    /// Before the deal, every SPE helps partition each large interval of
    /// the top levels (the cooperative partition, `coop.rs`). Buys: the
    /// other SPEs work instead of waiting for the deal (dragon on 6 SPEs:
    /// 342 → 186 ms). Costs: every record of those levels travels twice
    /// (through a scratch array) and two barriers per interval.
    pub coop_top: bool,
    /// The top levels end at the first level with this many jobs per SPE
    /// (1 to 16: the level must fit `WorkA`). More jobs give the
    /// largest-first deal more room to balance, but more levels are built
    /// before it.
    pub deal_per_spe: usize,
    /// The dealt jobs stay in per-SPE lists in main memory; each SPE takes
    /// its next one when it has built the last, and when its list is empty
    /// it steals from the end of another's (lock-line updates). Buys:
    /// balance when a few dealt jobs hold most of the work. Costs: an
    /// atomic update per job taken, and each dealt job is built alone (its
    /// levels are not batched with the SPE's other jobs).
    pub steal: bool,
    /// `spe_bfs_shared`: jobs taken from the shared queue per atomic
    /// operation (1 to 256). Buys: fewer lock-line updates and larger
    /// batches. Costs: balance at the end of a level (the last takes are
    /// large).
    pub agglomerate: usize,
    /// `spe_bfs_shared`: a take hands out no more than an equal share of
    /// the level's jobs left among the SPEs (guided self-scheduling), so
    /// that a level of few jobs is spread over every SPE. Buys: balance at
    /// the top of the shared levels and at each level's end. Costs: more
    /// takes (lock-line updates) near each level's end.
    pub guided: bool,
    /// Section 5: a second `WorkA` and `WorkB` in the local store, so that a
    /// full `WorkB` is written back while the other fills, and the next
    /// block of a spilled level is read while this one is built (no
    /// synchronous queue DMA). Costs 32 KiB of local store.
    pub double_buffer: bool,
    /// Section 5: DMA lists for agglomerated jobs — a batch gathers the
    /// intervals of jobs that are not adjacent in one `getl` and scatters
    /// them back in one `putl`, and nodes written into other arenas' slots
    /// go out in one `putl` per batch. Off, each adjacent run is its own
    /// batch and each piece of a node its own put.
    pub dma_lists: bool,
    /// The get of the next agglomerated batch is issued before the current
    /// one is partitioned, so the transfer overlaps the partition (three
    /// batch buffers instead of two). Off, a batch's get is waited for
    /// before its partition starts, as in the paper.
    pub prefetch: bool,
    /// `spe_morton`: the order of the keys' bits. The global heuristic's
    /// order gives the baseline's tree; round robin (LBVH) another tree,
    /// its keys cheaper to reason about, its quality the cost.
    pub key_order: KeyOrder,
    /// `spe_morton`: key bits, 32 or 64. Buys: fewer ranges left to the
    /// global heuristic (64). Costs: key time per bit, radix passes.
    pub key_bits: u32,
    /// `spe_morton`: bits per radix pass (4 to 11). Buys: fewer passes
    /// over the keys. Costs: larger count tables (2^bits per SPE) and
    /// more scattered runs per pass.
    pub digit_bits: u32,
    /// `spe_morton`: the top of the tree stops at ranges of at most this
    /// many triangles (regions), each built by one SPE alone. Buys: fewer
    /// top nodes and probes (large); more regions to balance (small).
    pub region_size: usize,
    /// `spe_morton`: regions dealt before the builds (largest first, each
    /// to the least-loaded SPE) instead of taken largest first from an
    /// atomic counter. Buys: no atomics. Costs: balance.
    pub static_regions: bool,
    /// `ppe_approx`: at most this many cells of the presort's grid per axis
    /// (1 to 1024; the default 1024 is the grid of Table 1). Buys (fewer):
    /// a smaller count table and fewer buckets for the upper levels.
    /// Costs: fuller buckets, so more of the tree is left to the naive
    /// finish. The tree is the paper's either way.
    pub approx_max_cells: usize,
}

impl Knobs {
    /// The paper's single-SPE queue: none of section 5's improvements.
    pub const PAPER: Knobs = Knobs {
        coop_top: false,
        deal_per_spe: 4,
        steal: false,
        agglomerate: 16,
        guided: false,
        double_buffer: false,
        dma_lists: false,
        prefetch: false,
        key_order: KeyOrder::GlobalHeuristic,
        key_bits: 32,
        digit_bits: 8,
        region_size: 2048,
        static_regions: false,
        approx_max_cells: crate::kernels::approx::MAX_RESOLUTION,
    };
}

impl Knobs {
    /// Sets the knob `--name` to `value` as the command line gives it (an
    /// empty `value` for a flag). Only parses: each strategy checks the
    /// ranges of its knobs when it starts, in one place, so that a library
    /// caller and the command line get the same refusal.
    pub fn set(&mut self, name: &str, value: &str) -> Result<(), String> {
        let int = || -> Result<usize, String> {
            (value.parse::<usize>())
                .map_err(|_| format!("--{name} takes a whole number, not '{value}'"))
        };
        let flag = || -> Result<bool, String> {
            match value {
                "" => Ok(true),
                _ => Err(format!("--{name} is a flag: it takes no value ('{value}')")),
            }
        };
        match name {
            "no-coop-top" => self.coop_top = !flag()?,
            "deal-per-spe" => self.deal_per_spe = int()?,
            "steal" => self.steal = flag()?,
            "agglomerate" => self.agglomerate = int()?,
            "fixed-takes" => self.guided = !flag()?,
            "double-buffer" => self.double_buffer = flag()?,
            "dma-lists" => self.dma_lists = flag()?,
            "prefetch" => self.prefetch = flag()?,
            "key-order" => {
                self.key_order = match value {
                    "gh" => KeyOrder::GlobalHeuristic,
                    "xyz" => KeyOrder::RoundRobin,
                    _ => return Err(format!("--key-order is gh or xyz, not '{value}'")),
                }
            }
            "key-bits" => self.key_bits = int()? as u32,
            "digit-bits" => self.digit_bits = int()? as u32,
            "region-size" => self.region_size = int()?,
            "static-regions" => self.static_regions = flag()?,
            "approx-cells" => self.approx_max_cells = int()?,
            _ => return Err(format!("no strategy has a knob --{name}")),
        }
        Ok(())
    }
}

impl Default for Knobs {
    fn default() -> Self {
        Knobs {
            coop_top: true,
            guided: true,
            ..Knobs::PAPER
        }
    }
}

/// What a strategy's program leaves for reading back.
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
    /// Where the triangle records end, if not in the array they started
    /// in (a strategy that permuted them into another).
    pub records: Option<Ea>,
    /// A strategy made of phases separated by barriers: each phase's name
    /// and the cycle at which it ended (all SPEs through the barrier).
    pub phases: Vec<(&'static str, u64)>,
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
}

/// The PPE allocates a node array in main memory and writes `nodes` into
/// it; returns its address and node count, as [`Output::nodes`] holds them.
pub(crate) async fn write_nodes(ppe: &Ppe, nodes: &[BihNode]) -> Result<(Ea, usize), CellError> {
    let ea = ppe
        .alloc("node array", std::mem::size_of_val(nodes) as u64, 128)
        .await?;
    ppe.write_pod(ea, nodes).await?;
    Ok((ea, nodes.len()))
}

/// The nodes reachable from node 0, renumbered breadth first (children
/// stay adjacent): what is left of a pool shared by several arenas once its
/// skipped and unused slots are dropped. Done on read-back, on the host,
/// uncharged: the tree in main memory is usable as it is. A child outside
/// the pool, or a slot reached twice (a slot never written reads as an
/// inner node whose children are nodes 0 and 1), is an error, not a hang.
fn compact(nodes: &[BihNode]) -> Result<Vec<BihNode>, CellError> {
    let lost = |msg: String| CellError::Program {
        core: "strategy".into(),
        msg: format!("reading the tree back: {msg} (a node slot never written: a lost job?)"),
    };
    let mut seen = vec![false; nodes.len()];
    seen[0] = true;
    let mut out = vec![nodes[0]];
    let mut queue = std::collections::VecDeque::from([0usize]);
    while let Some(at) = queue.pop_front() {
        let n = out[at];
        if n.is_leaf() {
            continue;
        }
        let c = n.left_child() as usize;
        if c + 1 >= nodes.len() {
            return Err(lost(format!(
                "children {c}, {} past the pool's {} slots",
                c + 1,
                nodes.len()
            )));
        }
        for slot in [c, c + 1] {
            if std::mem::replace(&mut seen[slot], true) {
                return Err(lost(format!("node slot {slot} is reached twice")));
            }
        }
        let first = out.len();
        out.extend([nodes[c], nodes[c + 1]]);
        let [l, r] = n.clip();
        out[at] = BihNode::inner(first as u32, n.axis(), l, r);
        queue.extend([first, first + 1]);
    }
    Ok(out)
}

/// A multi-SPE build: the jobs the SPEs made (one node each) are the
/// nodes read back, or a job was lost (or done twice) and the run fails.
fn check_jobs(work: &[SpeWork], nodes: usize) -> Result<(), CellError> {
    let jobs: u64 = work.iter().map(|w| w.jobs).sum();
    if work.is_empty() || jobs == nodes as u64 {
        return Ok(());
    }
    let by_spe: Vec<String> = (work.iter().enumerate())
        .map(|(i, w)| format!("SPE {i}: {}", w.jobs))
        .collect();
    Err(CellError::Program {
        core: "strategy".into(),
        msg: format!(
            "the SPEs made {jobs} nodes ({}) but the tree read back has {nodes}: a job was lost or made twice",
            by_spe.join(", ")
        ),
    })
}

/// What a build on the emulated Cell cost there: the one result of a
/// strategy beside its tree ([`run_in`]).
#[derive(Clone, Debug)]
pub struct Simulated {
    pub run: RunReport,
    pub stats: BuildStats,
    /// Multi-SPE builders: what each SPE did (jobs, arena blocks).
    pub spe_work: Vec<SpeWork>,
    /// Strategies made of phases: each phase's name and the cycle it
    /// ended at.
    pub phases: Vec<(&'static str, u64)>,
    /// The timeline, if the Cell's config asked for it.
    pub trace: Option<Trace>,
    /// Main memory by purpose, local-store high-water marks.
    pub footprint: machinery::footprint::Footprint,
}

impl Simulated {
    /// Each phase's name and simulated milliseconds, in order (empty for
    /// strategies without phases).
    pub fn phase_ms(&self) -> Vec<(&'static str, f64)> {
        let ms_per_cycle = self.run.ms / self.run.cycles.0.max(1) as f64;
        let mut start = 0;
        (self.phases.iter())
            .map(|&(name, end)| {
                let ms = end.saturating_sub(start) as f64 * ms_per_cycle;
                start = end;
                (name, ms)
            })
            .collect()
    }
}

/// Builds the tree of `scene` with the strategy `spawn` starts, on a Cell
/// configured by `cell_cfg`, and reads the tree back from emulated main
/// memory. `region` is the scene box of the global heuristic: the scene's
/// bounds, or the region of one node when a local update rebuilds that
/// node's interval (section 3); it must contain every triangle of `scene`.
pub fn run_in(
    spawn: Spawn,
    scene: &Scene,
    region: Aabb,
    cfg: &BihConfig,
    cell_cfg: &CellConfig,
    knobs: &Knobs,
) -> Result<(Bih, Simulated), CellError> {
    assert!(
        region.contains_box(&scene.bounds()),
        "the region must contain the scene"
    );
    let mut cell = Cell::new(cell_cfg.clone())?;
    let triangles = layout::upload(&cell, scene)?;
    let setup = Setup {
        triangles,
        count: scene.len(),
        region,
        knobs: *knobs,
    };
    let out = Rc::new(RefCell::new(Output::default()));
    spawn(&mut cell, &setup, cfg, out.clone())?;
    let run = cell.run()?;
    let o = out.borrow();
    if o.nodes.is_empty() {
        return Err(CellError::Program {
            core: "strategy".into(),
            msg: "the program ended without writing a tree".into(),
        });
    }
    let mut nodes: Vec<BihNode> = Vec::new();
    for &(ea, count) in &o.nodes {
        nodes.extend(cell.memory().read_pod::<BihNode>(ea, count)?);
    }
    if o.compact {
        nodes = compact(&nodes)?;
    }
    check_jobs(&o.spe_work, nodes.len())?;
    let at = o.records.unwrap_or(triangles);
    let records: Vec<layout::TriRecord> = cell.memory().read_pod(at, scene.len())?;
    let bih = Bih {
        nodes,
        prim_ids: records.iter().map(|r| r.id).collect(),
        bounds: region,
        config: *cfg,
    };
    let simulated = Simulated {
        footprint: machinery::footprint::Footprint::of(&run, &bih),
        run,
        stats: o.stats,
        spe_work: o.spe_work.clone(),
        phases: o.phases.clone(),
        trace: cell.take_trace(),
    };
    Ok((bih, simulated))
}

#[cfg(test)]
mod tests {
    use super::{BihNode, SpeWork, check_jobs, compact};

    #[test]
    fn compact_renumbers_the_reachable_nodes_and_drops_the_rest() {
        // Root at 0, its children at 4 and 5 (slots 1 to 3 unused), the
        // left child's at 6 and 7.
        let mut pool = vec![BihNode::default(); 8];
        pool[0] = BihNode::inner(4, 0, 1.0, 2.0);
        pool[4] = BihNode::inner(6, 1, 3.0, 4.0);
        pool[5] = BihNode::leaf(0, 1);
        pool[6] = BihNode::leaf(1, 1);
        pool[7] = BihNode::leaf(2, 1);
        let t = compact(&pool).unwrap();
        assert_eq!(t.len(), 5);
        assert_eq!(t[0], BihNode::inner(1, 0, 1.0, 2.0));
        assert_eq!(t[1], BihNode::inner(3, 1, 3.0, 4.0));
        assert_eq!(&t[2..], &[pool[5], pool[6], pool[7]]);
    }

    #[test]
    fn a_slot_never_written_is_an_error_not_a_hang() {
        // Node 4 was never written: a zero slot reads as an inner node
        // whose children are 0 and 1.
        let mut pool = vec![BihNode::default(); 8];
        pool[0] = BihNode::inner(4, 0, 1.0, 2.0);
        pool[5] = BihNode::leaf(0, 1);
        let e = compact(&pool).unwrap_err().to_string();
        assert!(e.contains("reached twice") && e.contains("lost job"), "{e}");
        // A child past the pool.
        pool[0] = BihNode::inner(7, 0, 1.0, 2.0);
        let e = compact(&pool).unwrap_err().to_string();
        assert!(e.contains("past the pool"), "{e}");
    }

    #[test]
    fn jobs_that_do_not_add_up_to_the_nodes_are_an_error_naming_each_spe() {
        let work = |jobs: &[u64]| -> Vec<SpeWork> {
            (jobs.iter())
                .map(|&jobs| SpeWork {
                    jobs,
                    ..Default::default()
                })
                .collect()
        };
        assert!(check_jobs(&work(&[3, 4]), 7).is_ok());
        assert!(
            check_jobs(&[], 7).is_ok(),
            "single-SPE builds count no jobs"
        );
        let e = check_jobs(&work(&[3, 3]), 7).unwrap_err().to_string();
        assert!(
            e.contains("SPE 0: 3, SPE 1: 3") && e.contains("lost"),
            "{e}"
        );
    }
}
