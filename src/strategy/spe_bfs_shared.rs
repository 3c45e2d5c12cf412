//! `spe_bfs_shared` — section 5's **one common job queue**: breadth first
//! on all the machine's SPEs, every SPE taking jobs from one queue in main
//! memory, synchronised only by the atomic unit (getllar/putllc on
//! 128-byte lock lines; the PPE does nothing per job).
//!
//! 1. **The top levels** ([`super::machinery::top`]): SPE 0 builds until a level holds
//!    `--deal-per-spe` jobs per SPE (the others help partition unless
//!    `--no-coop-top`), then writes that level into the queue.
//! 2. **The shared queue**, one tree level at a time: the level's jobs lie
//!    in one array (the shared `WorkAPPE`); an SPE takes up to
//!    `--agglomerate` jobs per lock-line update of the *take* line
//!    (unless `--fixed-takes`, no more than its share of the jobs left),
//!    builds them with the baseline's loop (Fig. 1, agglomeration), and
//!    collects their children in its own `WorkB`, which it writes into the
//!    next level's array (the shared `WorkBPPE`) at places reserved by
//!    fetch-and-add on the *push* line. A level ends at a **barrier**
//!    (fetch-and-add on the *arrivals* line; the last SPE to arrive opens
//!    the next level and signals the others), so idle time at the end of
//!    each level is measured, not hidden.
//! 3. **Per-SPE ObjectArena lists**: the SPE that splits a job takes the
//!    children's two adjacent ids from its own arena (blocks from one pool
//!    by fetch-and-add); the SPE that later takes a child writes its node
//!    straight into that slot, computing the address itself
//!    (`machinery::node_writes`: one `putl` per batch with `--dma-lists`).
//!
//! 4. **Section 5's software cache for the job queue** (`--job-cache KiB`):
//!    a take's jobs are read through a `SoftwareCache` in the local
//!    store instead of one explicit get. Safe without coherence: a level's
//!    array is written only during the level before (every SPE's puts
//!    done before it arrives at the barrier) and only read during its own,
//!    and each SPE empties its cache after every barrier, so no line of an
//!    array is kept into the level that rewrites it.
//!
//! A batch of agglomerated jobs moves only records of jobs this SPE took:
//! two jobs adjacent in the queue need not be adjacent in the triangle
//! array, and the records between may be another SPE's.
//!
//! The splits are the baseline's, so the tree is the baseline's tree; only
//! the numbering differs (nodes read back are renumbered breadth first).
//!
//! The program is the machinery's ([`super::machinery::policies`]); this
//! file is its knobs, their defaults, and the policies they make.

use super::machinery::breadth_first::{
    DMA_LISTS, DOUBLE_BUFFER, FINISH, Finish, Job, NO_PREFETCH, QueueKnobs,
};
use super::machinery::policies::{self, Deal, Policies, SharedQueue};
use super::machinery::top::{
    COOP_PARTITION, DEAL_PER_SPE, NO_COOP_TOP, TOP_END, TRIS_PER_SPE, TopKnobs,
};
use super::machinery::work_queue::WorkQueue;
use super::{Knob, Readback, Setup};
use crate::bih::BihConfig;
use crate::cell::{Cell, CellError};

/// `spe_bfs_shared` in the registry of builders.
pub const STRATEGY: super::Strategy = super::Strategy::new(
    "spe_bfs_shared",
    "section 5: every SPE takes jobs from one shared job queue (lock-line atomics, --agglomerate jobs per take), a barrier per level, each SPE's nodes in its own ObjectArena list (--spes)",
    spawn,
)
// The shared queue's two level arrays.
.with_buffers(|n, cfg, spes| {
    let jobs = crate::spe::footprint::work_ppe_jobs(n, cfg.leaf_size).max(32 * spes);
    2 * ((jobs * Job::bytes(cfg)) as u64).next_multiple_of(128)
})
.on_every_spe()
.promising(super::machinery::policies::PROMISE)
.with_quality(crate::bih::Quality::ALL)
.with_knobs(&[
    &DOUBLE_BUFFER,
    &DMA_LISTS,
    &NO_PREFETCH,
    &NO_COOP_TOP,
    &COOP_PARTITION,
    &DEAL_PER_SPE,
    &TOP_END,
    &TRIS_PER_SPE,
    &AGGLOMERATE,
    &FIXED_TAKES,
    &JOB_CACHE,
    &FINISH,
])
// Section 5's three queue improvements together, and the older defaults
// of the knobs (docs/many-spes.md).
.with_combos(&[
    &[(&DOUBLE_BUFFER, ""), (&DMA_LISTS, "")],
    &[
        (&NO_PREFETCH, ""),
        (&DEAL_PER_SPE, "4"),
        (&TOP_END, "count"),
        (&COOP_PARTITION, "scratch"),
        (&TRIS_PER_SPE, "1"),
    ],
]);

/// The queue's defaults, the best measured (docs/many-spes.md, "Defaults"):
/// the next batch's get overlaps the partition (3–12 % faster on every
/// scene); double buffers and DMA lists cost the shared queue a little.
const DEFAULT_QUEUE: QueueKnobs = QueueKnobs {
    double_buffer: false,
    dma_lists: false,
    prefetch: true,
};
/// The top's defaults: the first level of one job per SPE (the shared
/// queue balances whole jobs as it goes; each cooperative level is dear),
/// then its largest jobs split while the other SPEs can help: a job that
/// holds more than an SPE's share would keep the others waiting at the
/// shared levels' barriers. Measured over 13 scenes on 2–8 SPEs: 3.4 %
/// faster in geometric mean than the count end (sibenik on 8 SPEs 32 %,
/// the worst 4 % slower; docs/many-spes.md, "Balance").
const DEFAULT_TOP: TopKnobs = TopKnobs::SPLIT_ONE_PER_SPE;
/// The finish's default (docs/many-spes.md, "Subtrees in the local
/// store").
const DEFAULT_FINISH: Finish = Finish::Local;

/// `--agglomerate N`: `SharedKnobs::agglomerate`.
pub const AGGLOMERATE: Knob = Knob::int(
    "agglomerate",
    "jobs taken from the shared queue per atomic operation",
    16,
    (1, 256),
    &["1", "64"],
);
/// `--fixed-takes`: `SharedKnobs::guided` off.
pub const FIXED_TAKES: Knob = Knob::flag(
    "fixed-takes",
    "every take is --agglomerate jobs, not an SPE's share of the jobs left",
);

/// `--job-cache KiB`: `SharedKnobs::job_cache`.
pub const JOB_CACHE: Knob = Knob::int(
    "job-cache",
    "KiB of software cache (4-way, 128-byte lines) each SPE reads the level's jobs through, instead of one get a take (section 5); 0: off",
    0,
    (0, 32),
    &["4"],
);

fn spawn(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Readback, CellError> {
    let k = &setup.knobs;
    let shared = SharedQueue {
        agglomerate: k.int(&AGGLOMERATE),
        guided: !k.flag(&FIXED_TAKES),
        job_cache: k.int(&JOB_CACHE),
    };
    let job_bytes = Job::bytes(cfg);
    let per_buffer = WorkQueue::<Job>::per_buffer(job_bytes);
    if shared.agglomerate > per_buffer {
        return Err(CellError::Config(format!(
            "spe_bfs_shared: --agglomerate {}: a take must fit WorkA, which holds {per_buffer} jobs of {job_bytes} bytes with these settings",
            shared.agglomerate,
        )));
    }
    let policies = Policies {
        deal: Deal::Shared(shared),
        top: TopKnobs::read(k, DEFAULT_TOP),
        queue: QueueKnobs::read(k, DEFAULT_QUEUE),
        finish: Finish::read(k, DEFAULT_FINISH),
    };
    policies::spawn(cell, setup, cfg, policies)
}
