//! Programs for the emulated Cell, one file (or folder) per strategy, named
//! as the paper names them: the four builders of section 2 and Table 1
//! ([`ppe_naive`], [`ppe_approx`], [`spe_dfs`], [`spe_bfs`], the baseline)
//! and section 5's multi-SPE strategies ([`spe_bfs_shared`],
//! [`spe_bfs_private`], [`spe_morton`]); what they share is in
//! [`machinery`]; what a knob table is, in [`knob`]. Each writes its tree
//! into emulated main memory in the one node format; [`run_in`] reads it
//! back as a [`Bih`].

pub mod knob;
pub mod machinery;
pub mod ppe_approx;
pub mod ppe_naive;
pub mod ppe_passes;
pub mod program;
pub mod spe_bfs;
pub mod spe_bfs_private;
pub mod spe_bfs_shared;
pub mod spe_dfs;
pub mod spe_morton;

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode};
use crate::cell::{Cell, CellConfig, CellError, RunReport, Trace};
pub use crate::kernels::morton::KeyOrder;
use crate::kernels::rates::RateOverrides;
use crate::kernels::recursion::BuildStats;
use crate::scene::Scene;
use crate::spe::layout;
pub use knob::{Kind, Knob, Knobs};
pub use program::{
    Output, Phase, Promise, Readback, Records, Setup, Spawn, SpeWork, Strategy, write_nodes,
};

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
    /// The SPEs the strategy ran its programs on (its own decision).
    pub spes_used: usize,
    /// A strategy that predicts its time to choose how many SPEs to use:
    /// what it predicted and chose.
    pub predicted: Option<program::Prediction>,
    /// Strategies made of phases: each phase's name and the cycle it
    /// ended at.
    pub phases: Vec<(&'static str, u64)>,
    /// The timeline, if the Cell's config asked for it.
    pub trace: Option<Trace>,
    /// Main memory by purpose, local-store high-water marks.
    pub footprint: crate::spe::footprint::Footprint,
    /// Where the build left the triangle records.
    pub records: crate::spe::layout::RecordOrder,
}

impl Simulated {
    /// Where the strategy predicts its time to choose how many SPEs to
    /// use: the count chosen and the predicted simulated milliseconds on
    /// 1, 2, … SPEs (the prediction, and its best and worst deals).
    pub fn prediction(&self) -> Option<serde_json::Value> {
        let p = self.predicted.as_ref()?;
        let ms_per_cycle = self.run.ms / self.run.cycles.0.max(1) as f64;
        let ms = |c: &[u64]| {
            c.iter()
                .map(|&c| c as f64 * ms_per_cycle)
                .collect::<Vec<_>>()
        };
        Some(serde_json::json!({
            "chosen": p.chosen, "ms": ms(&p.cycles),
            "best_ms": ms(&p.best), "worst_ms": ms(&p.worst),
        }))
    }

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
    rates: &RateOverrides,
) -> Result<(Bih, Simulated), CellError> {
    let mut cell = Cell::new(cell_cfg.clone())?;
    let on = On {
        spes: cell_cfg.spes,
        knobs,
        rates,
    };
    let launched = launch(spawn, &mut cell, scene, (region, cfg), &on)?;
    let run = cell.run()?;
    let o = (launched.readback)()?;
    let bih = land(&cell, &o, scene.len(), launched.triangles, (region, cfg))?;
    let records = match o.records {
        Some(Records::Ids { .. }) => layout::RecordOrder::InputWithIds,
        _ => layout::RecordOrder::LeafOrder,
    };
    let simulated = Simulated {
        footprint: crate::spe::footprint::Footprint::of(&run, &bih),
        run,
        stats: o.stats,
        spe_work: o.spe_work,
        spes_used: o.spes,
        predicted: o.predicted,
        phases: o.phases,
        trace: cell.take_trace(),
        records,
    };
    Ok((bih, simulated))
}

/// Where and how a build runs on a Cell: on its SPEs `0 .. spes`, with
/// these knobs and rates.
pub struct On<'a> {
    pub spes: usize,
    pub knobs: &'a Knobs,
    pub rates: &'a RateOverrides,
}

/// A build whose programs are spawned: what reads its output back once
/// they have ended, and where its input triangles are.
pub struct Launched {
    pub readback: Readback,
    pub triangles: crate::cell::Ea,
}

/// Puts `scene`'s triangles into `cell`'s main memory and spawns the
/// strategy's programs (the PPE's and those of SPEs `0 .. on.spes`) for a
/// build of its tree over `region` with `cfg`; run the Cell, then read the
/// tree back with [`land`].
pub fn launch(
    spawn: Spawn,
    cell: &mut Cell,
    scene: &Scene,
    (region, cfg): (Aabb, &BihConfig),
    on: &On,
) -> Result<Launched, CellError> {
    assert!(
        region.contains_box(&scene.bounds()),
        "the region must contain the scene"
    );
    let triangles = layout::upload(cell, scene)?;
    let setup = Setup {
        triangles,
        count: scene.len(),
        spes: on.spes,
        region,
        knobs: on.knobs.clone(),
        rates: *on.rates,
    };
    let readback = spawn(cell, &setup, cfg)?;
    Ok(Launched {
        readback,
        triangles,
    })
}

/// The tree a build left in `cell`'s main memory, as its programs' output
/// `o` says where: its nodes (compacted if they share a pool) and its
/// `count` triangle ids in leaf order.
pub fn land(
    cell: &Cell,
    o: &Output,
    count: usize,
    triangles: crate::cell::Ea,
    (region, cfg): (Aabb, &BihConfig),
) -> Result<Bih, CellError> {
    if o.nodes.is_empty() {
        return Err(CellError::Program {
            core: "strategy".into(),
            msg: "the program ended without writing a tree".into(),
        });
    }
    let mut nodes: Vec<BihNode> = Vec::new();
    for &(ea, n) in &o.nodes {
        nodes.extend(cell.memory().read_pod::<BihNode>(ea, n)?);
    }
    if o.compact {
        nodes = compact(&nodes)?;
    }
    check_jobs(&o.spe_work, nodes.len())?;
    let prim_ids = match o.records {
        Some(Records::Ids { at, stride, word }) => {
            let words = stride as usize / 4;
            let column: Vec<u32> = cell.memory().read_pod(at, count * words)?;
            column.iter().skip(word).step_by(words).copied().collect()
        }
        moved => {
            let at = match moved {
                Some(Records::Moved(at)) => at,
                _ => triangles,
            };
            let records: Vec<layout::TriRecord> = cell.memory().read_pod(at, count)?;
            records.iter().map(|r| r.id).collect()
        }
    };
    Ok(Bih {
        nodes,
        prim_ids,
        bounds: region,
        config: *cfg,
    })
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
