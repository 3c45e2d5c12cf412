//! What an update reports: one frame's [`UpdateReport`], and a run of
//! frames summed up as the paper's Table 2 sums them up ([`Summary`]).

use serde::Serialize;

use super::{PpeWork, SpeFind, Stop};

/// What one frame's update did and cost.
#[derive(Clone, Debug, Default, Serialize)]
pub struct UpdateReport {
    /// Moves in the frame, marked-only ones included.
    pub moves: usize,
    /// The tree was rebuilt completely (the method, or the scene box changed).
    pub full_rebuild: bool,
    /// Triangles of the moved objects (the paper's "trans").
    pub transformed: usize,
    /// Triangles the builder sorted (the paper's "rec").
    pub rebuilt: usize,
    /// Depth of the enclosing node (the paper's "trav"); 0 on a rebuild.
    pub depth: u32,
    /// Why Algorithm 1 stopped, if it ran.
    pub stop: Option<Stop>,
    /// Size of the enclosing node's interval.
    pub interval: usize,
    /// Deep update: triangles in subtrees kept as they were.
    pub kept: usize,
    /// Deep update: triangle slots of kept subtrees copied to a new place.
    pub moved_slots: usize,
    /// Deep update: leaves of kept subtrees whose first slot was adjusted.
    pub leaves_adjusted: usize,
    /// Subtrees rebuilt (1 for local, 1 or more for deep).
    pub pieces: usize,
    /// Host wall time of the whole update, moving the triangles included.
    pub host_ms: f64,
    /// Simulated Cell time of the update, for an emulated builder: the
    /// rebuilds on the SPEs and the PPE's share before and after them.
    pub simulated_ms: Option<f64>,
    /// Simulated time of the rebuilds alone.
    pub build_ms: Option<f64>,
    /// The PPE's work before the rebuilds (Algorithm 1, the scan, the deep
    /// descent) and after them (the graft, kept ranges moved), and its
    /// simulated time ([`super::ppe`]).
    pub ppe_find: PpeWork,
    pub ppe_apply: PpeWork,
    pub ppe_find_ms: f64,
    pub ppe_apply_ms: f64,
    /// `--find-moved spe`: the search the SPEs made as the rebuild streamed
    /// the interval ([`super::spe_find`]), and its simulated time (within
    /// `build_ms`).
    pub spe_find: SpeFind,
    pub spe_find_ms: f64,
    /// Bytes the rebuilds' DMA moved (got and put, every core).
    pub dma_bytes: u64,
}

/// A run of frames summed up as the paper's Table 2 sums them up.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Summary {
    pub frames: usize,
    /// Frames brought up to date without a complete rebuild ("updates").
    pub updates: usize,
    /// Frames that rebuilt the tree completely ("rebuilds").
    pub rebuilds: usize,
    /// updates / rebuilds ("ratio"); `None` when no frame was a complete
    /// rebuild.
    pub ratio: Option<f64>,
    /// Host time per frame: min, max, mean ("tmin", "tmax", "t"), in ms.
    pub host_ms: [f64; 3],
    /// Simulated Cell time per frame, same order, for emulated builders.
    pub simulated_ms: Option<[f64; 3]>,
    /// Mean transformed triangles ("trans").
    pub transformed: f64,
    /// Mean triangles used for rebuilds ("rec").
    pub rebuilt: f64,
    /// Mean of rebuilt − transformed ("Δ").
    pub delta: f64,
    /// Mean depth of the enclosing node ("trav"), 0 for complete rebuilds.
    pub depth: f64,
    /// Deep update: mean triangles kept in place, and mean slots moved.
    pub kept: f64,
    pub moved_slots: f64,
}

impl Summary {
    /// Sums up the reports of frames that had moves (empty frames are
    /// no updates at all); `None` when no frame had a move.
    pub fn of(reports: &[UpdateReport]) -> Option<Summary> {
        let r: Vec<&UpdateReport> = reports.iter().filter(|r| r.moves > 0).collect();
        if r.is_empty() {
            return None;
        }
        let n = r.len() as f64;
        let mean = |f: &dyn Fn(&UpdateReport) -> f64| r.iter().map(|x| f(x)).sum::<f64>() / n;
        let spread = |v: Vec<f64>| {
            let min = v.iter().copied().fold(f64::INFINITY, f64::min);
            let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            [min, max, v.iter().sum::<f64>() / v.len() as f64]
        };
        let rebuilds = r.iter().filter(|x| x.full_rebuild).count();
        let updates = r.len() - rebuilds;
        let sim: Option<Vec<f64>> = r.iter().map(|x| x.simulated_ms).collect();
        Some(Summary {
            frames: r.len(),
            updates,
            rebuilds,
            ratio: (rebuilds > 0).then(|| updates as f64 / rebuilds as f64),
            host_ms: spread(r.iter().map(|x| x.host_ms).collect()),
            simulated_ms: sim.filter(|v| !v.is_empty()).map(spread),
            transformed: mean(&|x| x.transformed as f64),
            rebuilt: mean(&|x| x.rebuilt as f64),
            delta: mean(&|x| x.rebuilt as f64 - x.transformed as f64),
            depth: mean(&|x| x.depth as f64),
            kept: mean(&|x| x.kept as f64),
            moved_slots: mean(&|x| x.moved_slots as f64),
        })
    }
}
