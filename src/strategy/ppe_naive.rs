//! `ppe_naive` — the paper's naive build (section 4.1, Table 1): the
//! recursive build running on the PPE alone, "already vectorized".
//!
//! The PPE reads the triangle array from main memory, runs the recursion
//! of the host builder on it (the same split choice and partition), and
//! writes the sorted array and the nodes back. Memory traffic is charged at
//! the PPE's bandwidth by the machine; the compute is charged per item
//! partitioned (and binned, with binned SAH) and per node, at the PPE
//! kernel rates of the cost model. It builds every quality knob of
//! [`BihConfig`] (the split choice, the empty-space cut-off).

use super::ppe_passes::Passes;
use super::{Output, Readback, Setup};
use crate::bih::{BihConfig, SplitChoice};
use crate::cell::{Cell, CellError};
use crate::kernels::ppe_rates::loads_cycles;
use crate::kernels::recursion::{BuildStats, build_items};
use crate::spe::layout::TriRecord;

/// `ppe_naive` in the registry of builders.
pub const STRATEGY: super::Strategy = super::Strategy::new(
    "ppe_naive",
    "the paper's naive recursive build on the emulated PPE (Table 1, column 1)",
    spawn,
)
.on_the_ppe()
.with_quality(crate::bih::Quality::ALL);

fn spawn(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Readback, CellError> {
    let (tris, n, region, cfg) = (setup.triangles, setup.count, setup.region, *cfg);
    let rates = setup.rates.kernels();
    let ppe = cell.spawn_ppe(move |ppe| async move {
        let mut items: Vec<TriRecord> = ppe.read_pod(tris, n).await?;
        let (bih, stats) = build_items(&mut items, region, &cfg);
        let k = rates;
        // The root's box of the triangles and of their centers: a bounds
        // pass over the records, as the SPE builds pay for theirs.
        ppe.compute_items(k.ppe_bounds_item, n as u64);
        let BuildStats {
            items_partitioned,
            items_binned,
            sah_sweeps,
            nodes,
            ..
        } = stats;
        // Binning (binned SAH) reads each record and updates one bin per
        // axis: charged as one more partition pass over those items, a
        // derivation by analogy (both read the record's box, compute the
        // center and a comparison or bin index per item), not a
        // calibration.
        ppe.compute_items(k.ppe_partition_item, items_partitioned + items_binned);
        if let SplitChoice::BinnedSah { bins, .. } = cfg.split {
            let per_sweep = 3 * crate::kernels::sah::bins_per_axis(bins) as u64;
            ppe.compute_items(k.ppe_sah_bin, sah_sweeps * per_sweep);
        }
        ppe.compute_items(k.ppe_node, nodes);
        // The records through the PPE's caches: the bounds pass, then each
        // partition.
        let mut passes = Passes::cold();
        passes.partitions(&bih.nodes, |_| true);
        ppe.compute(loads_cycles(&passes.loads(), &ppe.cost()));
        ppe.write_pod(tris, &items).await?;
        let node_array = super::write_nodes(&ppe, &bih.nodes).await?;
        Ok(Output {
            nodes: vec![node_array],
            stats,
            ..Output::default()
        })
    });
    Ok(Box::new(move || ppe.take("PPE")))
}
