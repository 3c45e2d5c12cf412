//! What a frame on the Cell costs beyond its rebuilds (and the PPE's share
//! of an update, [`crate::update::ppe`]) and its cast, as each arrangement
//! of the SPEs needs it:
//!
//! - **section 5's** (every SPE builds, then every SPE renders): each SPE
//!   switches programs twice a frame, builder to caster and back. A switch
//!   is charged as the PPE starting every SPE's program one after another
//!   (`CostModel::spe_start_cycles`: a real PS3 starts, runs and joins a
//!   SPURS task every 2.61 µs) plus every SPE's program image (the local
//!   store kept for code and stack, `CellConfig::ls_reserved_bytes`) got
//!   through the shared memory interface.
//! - **the paper's** (some SPEs update the tree for the next frame while
//!   the others cast this one): the casters read the tree as it was while
//!   the update writes the next one, so there are two copies of the tree in
//!   memory. An update that changes the tree in place (local, deep) works
//!   on the copy the casters are done with, which must first be brought up
//!   to the tree the casters now read: the bytes the previous update
//!   changed are got and put by the builder SPEs' DMA, at the memory
//!   interface's shared bandwidth. A complete rebuild writes a whole new
//!   tree and needs no such copy. Builder and casters share one memory
//!   interface: the frame loop runs them side by side on one Cell
//!   ([`super::one_cell`]), and checks it against a bound: on a
//!   work-conserving interface a side's transfers finish no later than
//!   they would alone plus the time the interface spends on the other
//!   side's bytes ([`sharing_bound_ms`]).

use crate::bih::BihNode;
use crate::cell::CellConfig;
use crate::spe::layout::{RecordOrder, TriRecord};
use crate::update::{Method, UpdateReport};

/// Simulated ms of one program switch on every SPE of `cell`.
pub fn program_switch_ms(cell: &CellConfig) -> f64 {
    let c = &cell.cost;
    if !c.charge_compute {
        return 0.0;
    }
    let spes = cell.spes as u64;
    let starts = c.spe_start_cycles.0 * spes;
    let images = (c.memory_shared_bandwidth)
        .cycles(spes * cell.ls_reserved_bytes as u64)
        .0;
    (starts + images) as f64 / c.clock_hz * 1e3
}

/// Bytes of main memory one copy of a tree of `nodes` nodes over
/// `triangles` takes, as the casters read it: the nodes, and the records
/// in leaf order or (the records in the scene's order) the id column.
pub fn tree_bytes(nodes: usize, triangles: usize, order: RecordOrder) -> u64 {
    let per_triangle = match order {
        RecordOrder::LeafOrder => size_of::<TriRecord>(),
        RecordOrder::InputWithIds => size_of::<TriRecord>() + 4,
    };
    (nodes * size_of::<BihNode>() + triangles * per_triangle) as u64
}

/// Bytes of the tree an update changed (what the other copy must be given
/// before the next in-place update): all of it after a complete rebuild;
/// else the nodes Algorithm 1 and the graft wrote, the slots rewritten in
/// triangle order, and (records in the scene's order) the moved triangles'
/// records.
pub fn changed_bytes(up: &UpdateReport, whole_tree: u64, order: RecordOrder) -> u64 {
    if up.full_rebuild {
        return whole_tree;
    }
    let nodes = up.ppe_find.nodes_visited + up.ppe_apply.nodes_written;
    let slots = (up.rebuilt + up.moved_slots) as u64;
    let node = size_of::<BihNode>() as u64;
    let record = size_of::<TriRecord>() as u64;
    nodes * node
        + match order {
            RecordOrder::LeafOrder => slots * record,
            RecordOrder::InputWithIds => slots * 4 + up.transformed as u64 * record,
        }
}

/// Each byte copied into the second copy crosses the memory interface
/// twice: got into a builder SPE's local store, put back.
pub const COPY_CROSSINGS: u64 = 2;

/// Simulated ms of bringing the other copy up to date: `bytes` got and put
/// at the memory interface's shared bandwidth.
pub fn copy_ms(bytes: u64, cell: &CellConfig) -> f64 {
    let c = &cell.cost;
    if !c.charge_compute {
        return 0.0;
    }
    c.memory_shared_bandwidth.cycles(COPY_CROSSINGS * bytes).0 as f64 / c.clock_hz * 1e3
}

/// The most that sharing the memory interface can add to a frame of the
/// paper's arrangement: the update (`update_ms`, moving `update_bytes`)
/// and the cast (`render_ms`, `render_bytes`) overlap, and each side's
/// transfers can be delayed at most by the interface's time for the
/// other's bytes at its shared bandwidth.
pub fn sharing_bound_ms(
    (update_ms, update_bytes): (f64, u64),
    (render_ms, render_bytes): (f64, u64),
    cell: &CellConfig,
) -> f64 {
    let c = &cell.cost;
    let ms = |bytes: u64| c.memory_shared_bandwidth.cycles(bytes).0 as f64 / c.clock_hz * 1e3;
    let alone = update_ms.max(render_ms);
    (update_ms + ms(render_bytes)).max(render_ms + ms(update_bytes)) - alone
}

/// What a frame's update costs beyond its rebuilds and the PPE's share:
/// the builder's program switch (section 5's arrangement) and the copy
/// into the tree's second copy before an in-place update (the paper's).
#[derive(Clone, Copy)]
pub(super) struct Bill {
    pub switch_ms: f64,
    pub copy_ms: f64,
}

impl Bill {
    /// The extra ms of an update by `m` (`full_rebuild`: the scene box
    /// changed, so it rebuilds completely).
    pub(super) fn update_ms(&self, m: Method, full_rebuild: bool) -> f64 {
        match full_rebuild || m == Method::Rebuild {
            true => self.switch_ms,
            false => self.switch_ms + self.copy_ms,
        }
    }

    /// An update's charged ms: its rebuilds, the PPE's work (with
    /// `plan_find_ms`, the plan's search in place of the update's own), a
    /// switch where something was built, the copy before an in-place
    /// update that built something.
    pub(super) fn charge(&self, up: &UpdateReport, plan_find_ms: Option<f64>) -> Charged {
        let ppe_ms = plan_find_ms.unwrap_or(up.ppe_find_ms) + up.ppe_apply_ms;
        let built = up.pieces > 0;
        let copy_ms = match built && !up.full_rebuild {
            true => self.copy_ms,
            false => 0.0,
        };
        let switch_ms = if built { self.switch_ms } else { 0.0 };
        Charged {
            update_ms: up.build_ms.unwrap_or(0.0) + ppe_ms + copy_ms + switch_ms,
            find_ms: ppe_ms - up.ppe_apply_ms,
            ppe_ms,
            copy_ms,
            switch_ms,
        }
    }
}

/// What [`Bill::charge`] charged an update.
pub(super) struct Charged {
    pub update_ms: f64,
    /// Of `ppe_ms`: the search (Algorithm 1, the scan, the deep descent;
    /// with `auto`, its plan), which needs only the moves and the tree as
    /// the last graft left it.
    pub find_ms: f64,
    pub ppe_ms: f64,
    pub copy_ms: f64,
    pub switch_ms: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_switch_on_six_spes_is_six_starts_and_six_images() {
        let cell = CellConfig::ps3();
        let ms = program_switch_ms(&cell);
        // 6 × 2.61 µs of starts and 6 × 32 KiB at 22.83 GB/s (8.6 µs).
        assert!((0.0240..0.0250).contains(&ms), "{ms}");
        let eight = program_switch_ms(&cell.clone().with_spes(8));
        assert!(eight > ms);
    }

    #[test]
    fn an_in_place_update_changes_its_slots_and_nodes_a_rebuild_the_whole_tree() {
        let whole = tree_bytes(100, 50, RecordOrder::LeafOrder);
        assert_eq!(whole, 100 * 12 + 50 * 48);
        let mut up = UpdateReport {
            rebuilt: 10,
            moved_slots: 5,
            transformed: 3,
            ..UpdateReport::default()
        };
        up.ppe_find.nodes_visited = 4;
        up.ppe_apply.nodes_written = 20;
        assert_eq!(
            changed_bytes(&up, whole, RecordOrder::LeafOrder),
            24 * 12 + 15 * 48
        );
        assert_eq!(
            changed_bytes(&up, whole, RecordOrder::InputWithIds),
            24 * 12 + 15 * 4 + 3 * 48
        );
        up.full_rebuild = true;
        assert_eq!(changed_bytes(&up, whole, RecordOrder::LeafOrder), whole);
    }

    #[test]
    fn sharing_can_add_at_most_the_other_sides_bytes() {
        let cell = CellConfig::ps3();
        // 22.83 MB at 22.83 GB/s: 1 ms.
        let mb = 22_830_000;
        let b = sharing_bound_ms((10.0, mb), (20.0, mb), &cell);
        // The render is the longer; it can lose the update's 1 ms.
        assert!((b - 1.0).abs() < 0.01, "{b}");
        // An update much shorter than the render adds nothing.
        assert_eq!(sharing_bound_ms((1.0, 0), (20.0, 0), &cell), 0.0);
    }
}
