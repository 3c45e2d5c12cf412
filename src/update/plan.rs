//! Section 5's "metric for estimation of needed time for reorganization
//! steps" starts here: what a local and a deep update would rebuild, and
//! the PPE's work of finding it, counted on a copy before anything is
//! built.

use serde::Serialize;

use super::animation::Move;
use crate::cell::ppe_cache::Loads;

use super::{
    Array, PpeWork, UpdateError, UpdateReport, Updater, deep, enclosing_node, found, interval,
};

/// What a local and a deep update would rebuild ([`Updater::plan`]).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Plan {
    /// The scene box changes: the tree is rebuilt completely.
    pub full_rebuild: bool,
    /// Triangles a local update rebuilds: the enclosing node's interval
    /// (all of them on a complete rebuild).
    pub interval: usize,
    /// Depth of the enclosing node.
    pub depth: u32,
    /// Triangles of the moved objects.
    pub transformed: usize,
    /// The sizes of the subtrees a deep update would rebuild, in tree
    /// order (the whole interval's on a complete rebuild).
    pub deep_pieces: Vec<usize>,
    /// The PPE's work of making this plan: Algorithm 1, the scan of the
    /// interval, the deep update's descent (what either update does
    /// before its rebuilds; none on a complete rebuild).
    pub find: PpeWork,
    /// The scan of the interval's loads and stores through the PPE's
    /// caches, after Algorithm 1's (in `find` too where the plan scanned).
    pub scan_loads: Loads,
    /// Whether the interval was scanned and the deep update's descent
    /// made ([`Updater::plan`]), or only Algorithm 1
    /// ([`Updater::plan_search`]).
    pub deep_planned: bool,
    /// On a complete rebuild: the new scene box (its six bounds' bits),
    /// by which a predictor knows a scene state it has rebuilt before.
    pub scene_box: Option<[u32; 6]>,
}

impl Plan {
    /// Triangles a deep update would rebuild.
    pub fn deep_rebuilt(&self) -> usize {
        self.deep_pieces.iter().sum()
    }
}

impl Updater {
    /// What a local and a deep update after `moves` would rebuild,
    /// counted before any build (section 5's "metric for estimation of
    /// needed time for reorganization steps" starts from it): whether the
    /// scene box changes (a complete rebuild), else Algorithm 1's enclosing
    /// node and the size of its interval, and the subtrees the deep
    /// update's descent would rebuild. Works on a copy: the updater is not
    /// changed.
    pub fn plan(&self, moves: &[Move]) -> Result<Plan, UpdateError> {
        self.plan_to(moves, true)
    }

    /// The first half of [`Updater::plan`], what a local update needs to
    /// be priced: the scene box, Algorithm 1's enclosing node and its
    /// interval, without the scan of the interval and the deep update's
    /// descent (`deep_planned` false, no `deep_pieces`; `find` counts only
    /// Algorithm 1).
    pub fn plan_search(&self, moves: &[Move]) -> Result<Plan, UpdateError> {
        self.plan_to(moves, false)
    }

    fn plan_to(&self, moves: &[Move], descend: bool) -> Result<Plan, UpdateError> {
        let mut probe = self.clone();
        let mut r = UpdateReport::default();
        let m = probe.move_objects(moves, &mut r)?;
        if moves.is_empty() {
            return Ok(Plan {
                deep_planned: true,
                ..Plan::default()
            });
        }
        if probe.scene.bounds() != probe.bih.bounds {
            let b = probe.scene.bounds();
            let (lo, hi) = (b.min.to_array(), b.max.to_array());
            return Ok(Plan {
                scene_box: Some(std::array::from_fn(|i| match i {
                    0..3 => lo[i].to_bits(),
                    _ => hi[i - 3].to_bits(),
                })),
                full_rebuild: true,
                interval: probe.scene.len(),
                depth: 0,
                transformed: r.transformed,
                deep_pieces: vec![probe.scene.len()],
                find: PpeWork::default(),
                scan_loads: Loads::default(),
                deep_planned: true,
            });
        }
        probe.ppe_memory.cold();
        let mem = &probe.ppe_memory;
        let enc = enclosing_node(&mut probe.bih, &m.ebb, &mut |n| {
            mem.load(Array::Nodes, n as u64)
        });
        let (first, end) = interval(&probe.bih, enc.node);
        let mut plan = Plan {
            full_rebuild: false,
            interval: end - first,
            depth: enc.depth,
            transformed: r.transformed,
            deep_pieces: Vec::new(),
            find: found(&enc, 0),
            scan_loads: Loads::default(),
            deep_planned: descend,
            scene_box: None,
        };
        plan.find.loads = probe.ppe_memory.take();
        probe.scan_loads((first, end));
        plan.scan_loads = probe.ppe_memory.take();
        if descend {
            let moved_slots = probe.moved_slots(&m.moved, (first, end));
            plan.find.scanned = (end - first) as u64;
            plan.find.loads += plan.scan_loads;
            plan.deep_pieces =
                deep::pieces(&probe, &enc, (first, end), &moved_slots, &mut plan.find);
            plan.find.loads += probe.ppe_memory.take();
        }
        Ok(plan)
    }
}
