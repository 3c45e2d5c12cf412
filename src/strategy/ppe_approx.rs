//! `ppe_approx` — Wächter & Keller's construction by approximate sorting on
//! the PPE (section 4.1, Table 1, column 2), nodes of more than 12 triangles
//! finished by the naive method as the paper's system does. The algorithm is
//! [`crate::kernels::approx`]; this program runs it on the triangle records in
//! emulated main memory.
//!
//! Memory: the presort scatters into a second triangle array, which the PPE
//! allocates (the paper's build of the dragon ran out of memory here), and
//! the gather writes the final order back into the first. Compute is charged
//! at the PPE's per-item rate for every triangle the presort touches (count,
//! scatter, gather), every bucket an upper-level partition touches, and every
//! item of the naive finish; and at the per-node rate for every node.

use crate::spe::footprint::Purpose;

use super::ppe_passes::Passes;
use super::{Output, Readback, Setup};
use crate::bih::BihConfig;
use crate::cell::{Cell, CellError, Ea};
use crate::kernels::approx::build_approx;
use crate::kernels::ppe_rates::loads_cycles;
use crate::kernels::recursion::BuildStats;
use crate::spe::layout::TriRecord;

/// `ppe_approx` in the registry of builders.
pub const STRATEGY: super::Strategy = super::Strategy::new(
    "ppe_approx",
    "Wachter & Keller's approximate sorting (bucket presort) on the emulated PPE, nodes over 12 triangles finished naively (Table 1, column 2)",
    spawn,
)
// The scatter's second array of records.
.with_buffers(|n, _, _| (n * size_of::<TriRecord>()) as u64)
.on_the_ppe()
.with_knobs(&[&APPROX_CELLS]);

/// `--approx-cells N`: at most this many cells of the presort's grid per
/// axis (1 to 1024; the default 1024 is the grid of Table 1). Buys
/// (fewer): a smaller count table and fewer buckets for the upper levels.
/// Costs: fuller buckets, so more of the tree is left to the naive finish.
/// The tree is the paper's either way.
pub const APPROX_CELLS: super::Knob = super::Knob::int(
    "approx-cells",
    "at most this many cells of the presort grid per axis",
    crate::kernels::approx::MAX_RESOLUTION,
    (1, crate::kernels::approx::MAX_RESOLUTION),
    &["16", "64"],
);

fn spawn(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Readback, CellError> {
    let (tris, n, region, cfg) = (setup.triangles, setup.count, setup.region, *cfg);
    let rates = setup.rates.kernels();
    let max_cells = setup.knobs.int(&APPROX_CELLS);
    let ppe = cell.spawn_ppe(move |ppe| async move {
        let items: Vec<TriRecord> = ppe.read_pod(tris, n).await?;
        // The root's box of the triangles and of their centers: a bounds
        // pass over the records, as the SPE builds pay for theirs.
        ppe.compute_items(rates.ppe_bounds_item, n as u64);
        let (sorted, bih, a) = build_approx(&items, region, &cfg, max_cells);
        let k = rates;
        let touched = a.items_sorted + a.buckets_partitioned + a.naive.items_partitioned;
        ppe.compute_items(k.ppe_partition_item, touched);
        ppe.compute_items(k.ppe_node, a.nodes);
        // The records through the PPE's caches: the presort's count and
        // scatter read them, the scatter writes the second array, the
        // gather reads it; then the naive finish's bounds passes and
        // partitions, below the upper levels.
        let mut passes = Passes::cold();
        passes.records((0, n));
        passes.records((0, n));
        passes.scattered(n);
        passes.scattered(n);
        let upper = a.upper_nodes as u32;
        passes.partitions(&bih.nodes, |id| {
            let node = bih.nodes[id as usize];
            !node.is_leaf() && node.left_child() >= upper
        });
        ppe.compute(loads_cycles(&passes.loads(), &ppe.cost()));
        // The scatter's second array, written and read back by the gather.
        let size = (n * size_of::<TriRecord>()) as u64;
        let scattered: Ea = ppe
            .alloc(
                Purpose::TriangleRecords.buffer("scattered records"),
                size,
                128,
            )
            .await?;
        ppe.write_pod(scattered, &items).await?;
        let _: Vec<TriRecord> = ppe.read_pod(scattered, n).await?;
        ppe.write_pod(tris, &sorted).await?;
        let node_array = super::write_nodes(&ppe, &bih.nodes).await?;
        let stats = BuildStats {
            items_partitioned: touched,
            nodes: a.nodes,
            partitions: a.naive.partitions,
            ..BuildStats::default()
        };
        Ok(Output {
            nodes: vec![node_array],
            stats,
            ..Output::default()
        })
    });
    Ok(Box::new(move || ppe.take("PPE")))
}
