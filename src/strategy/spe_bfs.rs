//! `spe_bfs` — the paper's breadth-first construction (section 2, Fig. 2,
//! Table 1), the **baseline** of this project: one SPE builds the tree
//! level by level "almost entirely independent from the PPE", which only
//! allocates memory: the breadth-first loop
//! ([`super::machinery::breadth_first`]) with the paper's queue (none of
//! section 5's improvements), its ObjectArena's blocks served by the PPE
//! through mailboxes.

use super::machinery::arena::{BlockSource, pieces, serve_blocks};
use super::machinery::breadth_first::{Job, QueueKnobs, SpeBuilder};
use super::machinery::work_queue::WorkPpe;
use super::{Output, Readback, Setup};
use crate::bih::BihConfig;
use crate::cell::CellError;
use crate::spe::footprint::Purpose;

/// `spe_bfs`, the baseline, in the registry of builders.
pub const STRATEGY: super::Strategy = super::Strategy::new(
    "spe_bfs",
    "breadth first, the baseline: one SPE builds level by level (WorkA/WorkB, Fig. 2), small jobs agglomerated, nodes in an ObjectArena (Table 1, column 4)",
    spawn,
)
// WorkAPPE and WorkBPPE.
.with_buffers(|n, cfg, _| 2 * Job::spill_bytes_for(n, cfg).next_multiple_of(128))
.with_quality(crate::bih::Quality::ALL);

fn spawn(
    cell: &mut crate::cell::Cell,
    setup: &Setup,
    cfg: &BihConfig,
) -> Result<Readback, CellError> {
    let (tris, n, region, cfg) = (setup.triangles, setup.count, setup.region, *cfg);
    // WorkAPPE and WorkBPPE: room for the widest level the tree can have
    // (the paper sized them for as many jobs as triangles, 6.5 times more
    // with leaves of 12; see strategy/machinery/footprint.rs).
    let work_ppe_bytes = Job::spill_bytes_for(n, &cfg);
    let work_a_ppe =
        cell.memory_mut()
            .alloc(Purpose::WorkPpe.buffer("WorkAPPE"), work_ppe_bytes, 128)?;
    let work_b_ppe =
        cell.memory_mut()
            .alloc(Purpose::WorkPpe.buffer("WorkBPPE"), work_ppe_bytes, 128)?;
    let work_ppe = [work_a_ppe, work_b_ppe];
    let rates = setup.rates.kernels();

    let spe = cell.spawn_spe(0, move |spe| async move {
        let mut b = SpeBuilder::new(
            &spe,
            tris,
            WorkPpe {
                areas: work_ppe,
                bytes: work_ppe_bytes,
            },
            cfg,
            BlockSource::Mailbox,
            QueueKnobs::PAPER,
            rates,
        )?;
        let all = b.bounds_of_all(n).await?;
        b.run(Job::new(0, n, 0, 0, region, &all)).await?;
        Ok(b.stats)
    });

    let ppe = cell.spawn_ppe(move |ppe| async move {
        // The PPE only allocates the arena's blocks.
        let (blocks, count) = serve_blocks(&ppe, 0).await?;
        Ok(pieces(&blocks, count))
    });
    Ok(Box::new(move || {
        Ok(Output {
            nodes: ppe.take("PPE")?,
            stats: spe.take("SPE 0")?,
            spes: 1,
            ..Output::default()
        })
    }))
}
