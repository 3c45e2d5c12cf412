//! Programs for the emulated Cell, one file per strategy, named as the
//! paper names them. Each writes its tree into emulated main memory in the
//! one node format; [`run`] reads it back as a [`Bih`].
//!
//! So far: [`ppe_naive`] and [`spe_dfs`] (Table 1's first and third
//! columns), and the SPE's in-place streaming partition of Fig. 1
//! ([`fig1`]), the kernel of the SPE builders.

pub mod arena;
pub mod coop;
pub mod fig1;
pub mod layout;
pub mod ppe_approx;
pub mod ppe_naive;
pub mod spe_bfs;
pub mod spe_bfs_private;
pub mod spe_dfs;
pub mod work_queue;

use std::cell::RefCell;
use std::rc::Rc;

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode};
use crate::build::host::BuildStats;
use crate::cell::{Cell, CellConfig, CellError, Ea, Ppe, RunReport, Trace};
use crate::scene::Scene;

/// How a strategy starts: it spawns its programs on the Cell for the
/// triangles of `Setup`, and they leave the tree's node pieces in `Output`.
pub type Spawn = fn(&mut Cell, &Setup, &BihConfig, Rc<RefCell<Output>>) -> Result<(), CellError>;

/// Where a strategy finds its input in main memory, and its knobs.
pub struct Setup {
    pub triangles: Ea,
    pub count: usize,
    pub region: Aabb,
    pub knobs: Knobs,
}

/// The knobs of the multi-SPE strategies, each declared here with what it
/// buys and costs. The paper's builders ignore them.
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
}

impl Default for Knobs {
    fn default() -> Self {
        Knobs {
            coop_top: true,
            deal_per_spe: 4,
            steal: false,
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
}

/// What one SPE of a multi-SPE build did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SpeWork {
    /// Jobs (nodes) it made.
    pub jobs: u64,
    /// Dealt jobs it stole from another SPE's list (`Knobs::steal`).
    pub stolen: u64,
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
/// uncharged: the tree in main memory is usable as it is.
fn compact(nodes: &[BihNode]) -> Vec<BihNode> {
    let mut out = vec![nodes[0]];
    let mut queue = std::collections::VecDeque::from([0usize]);
    while let Some(at) = queue.pop_front() {
        let n = out[at];
        if n.is_leaf() {
            continue;
        }
        let (c, first) = (n.left_child() as usize, out.len());
        out.extend([nodes[c], nodes[c + 1]]);
        let [l, r] = n.clip();
        out[at] = BihNode::inner(first as u32, n.axis(), l, r);
        queue.extend([first, first + 1]);
    }
    out
}

/// A tree built on the emulated Cell and what it cost there.
pub struct CellBuild {
    pub bih: Bih,
    pub run: RunReport,
    pub stats: BuildStats,
    /// Multi-SPE strategies: what each SPE did.
    pub spe_work: Vec<SpeWork>,
    /// The timeline, if `cell_cfg.trace` was set.
    pub trace: Option<Trace>,
}

/// Builds the tree of `scene` with the strategy `spawn` starts, on a Cell
/// configured by `cell_cfg`, and reads the tree back from emulated main
/// memory.
pub fn run(
    spawn: Spawn,
    scene: &Scene,
    cfg: &BihConfig,
    cell_cfg: &CellConfig,
) -> Result<CellBuild, CellError> {
    run_in(
        spawn,
        scene,
        scene.bounds(),
        cfg,
        cell_cfg,
        &Knobs::default(),
    )
}

/// [`run`] with `region` as the scene box of the global heuristic: the
/// region of one node, when a local update rebuilds that node's interval
/// (section 3). `region` must contain every triangle of `scene`.
pub fn run_in(
    spawn: Spawn,
    scene: &Scene,
    region: Aabb,
    cfg: &BihConfig,
    cell_cfg: &CellConfig,
    knobs: &Knobs,
) -> Result<CellBuild, CellError> {
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
        nodes = compact(&nodes);
    }
    let records: Vec<layout::TriRecord> = cell.memory().read_pod(triangles, scene.len())?;
    let bih = Bih {
        nodes,
        prim_ids: records.iter().map(|r| r.id).collect(),
        bounds: region,
        config: *cfg,
    };
    Ok(CellBuild {
        bih,
        run,
        stats: o.stats,
        spe_work: o.spe_work.clone(),
        trace: cell.take_trace(),
    })
}
