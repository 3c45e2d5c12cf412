//! `spe_bfs_private` — section 5's private per-SPE queues: breadth first on
//! all the machine's SPEs, each on its own jobs, with no synchronisation
//! once the work is dealt.
//!
//! 1. **The top levels**: SPE 0 builds alone with the baseline's loop
//!    (`spe_bfs`: WorkA/WorkB, Fig. 1, agglomeration) until a level holds
//!    at least `--deal-per-spe` jobs per SPE. Alone, the other SPEs
//!    would wait — the paper's worry that on the upper levels most SPEs sit
//!    idle; unless `--no-coop-top`, they help partition every large interval
//!    of those levels ([`super::machinery::coop`]). By default
//!    (`--top-end split`) SPE 0 then splits that level's largest jobs,
//!    with their help, until a largest-first deal of it is even: a dealt
//!    job is never split later.
//! 2. **The deal** (static, largest first): SPE 0 sorts that level's jobs
//!    by triangle count and gives each, in turn, to the SPE with the fewest
//!    triangles so far. It writes each SPE's jobs and a deal record (job
//!    count, its `WorkAPPE`/`WorkBPPE`, carved from one area in proportion
//!    to its triangles) to main memory and signals it.
//! 3. **Private queues**: every SPE runs the baseline's WorkA/WorkB loop on
//!    its own jobs, writing nodes into its own **ObjectArena** list: blocks
//!    taken from one pool by fetch-and-add, so every SPE computes node ids
//!    itself in one index space (a pair of children stays adjacent). The
//!    dealt jobs' own nodes lie in SPE 0's blocks, where their parents put
//!    them; each SPE writes those few by lock-line updates.
//!
//! The splits are the baseline's, so the tree is the baseline's tree; only
//! the numbering differs (nodes read back are renumbered breadth first).
//!
//! The program is the machinery's ([`super::machinery::policies`]); this
//! file is its knobs, their defaults, and the policies they make.

use super::machinery::breadth_first::{
    FINISH, Finish, Job, NO_DMA_LISTS, NO_DOUBLE_BUFFER, NO_PREFETCH, QueueKnobs,
};
use super::machinery::policies::{self, Deal, Policies};
use super::machinery::top::{
    COOP_PARTITION, DEAL_PER_SPE, NO_COOP_TOP, TOP_END, TRIS_PER_SPE, TopKnobs,
};
use super::{Knob, Readback, Setup};
use crate::bih::BihConfig;
use crate::cell::{Cell, CellError};

/// `spe_bfs_private` in the registry of builders.
pub const STRATEGY: super::Strategy = super::Strategy::new(
    "spe_bfs_private",
    "section 5: SPE 0 builds the top levels (the other SPEs help partition them unless --no-coop-top), deals the jobs largest first, then every SPE builds its own jobs breadth first with its own ObjectArena list (--spes)",
    spawn,
)
// Every SPE's WorkAPPE and WorkBPPE (without the per-part slack).
.with_buffers(|n, cfg, _| 2 * Job::spill_bytes_for(n, cfg))
.on_every_spe()
.promising(super::machinery::policies::PROMISE)
.with_quality(crate::bih::Quality::ALL)
.with_knobs(&[
    &NO_DOUBLE_BUFFER,
    &NO_DMA_LISTS,
    &NO_PREFETCH,
    &NO_COOP_TOP,
    &COOP_PARTITION,
    &DEAL_PER_SPE,
    &TOP_END,
    &TRIS_PER_SPE,
    &STEAL,
    &FINISH,
])
// The paper's queue (none of section 5's three improvements), and the
// older defaults of the knobs (docs/many-spes.md).
.with_combos(&[
    &[(&NO_DOUBLE_BUFFER, ""), (&NO_DMA_LISTS, ""), (&NO_PREFETCH, "")],
    &[
        (&NO_DOUBLE_BUFFER, ""),
        (&NO_DMA_LISTS, ""),
        (&NO_PREFETCH, ""),
        (&DEAL_PER_SPE, "4"),
        (&TOP_END, "count"),
        (&COOP_PARTITION, "scratch"),
        (&TRIS_PER_SPE, "1"),
    ],
]);

/// The queue's defaults, the best measured (docs/many-spes.md,
/// "Defaults"): section 5's three improvements together.
const DEFAULT_QUEUE: QueueKnobs = QueueKnobs {
    double_buffer: true,
    dma_lists: true,
    prefetch: true,
};
/// The top's defaults: the first level of one job per SPE, then its
/// largest jobs split until a largest-first deal is even: a dealt job is
/// never split later, so the deal must be balanced. Measured best of five
/// (split or balanced, 1, 2 or 4 jobs per SPE) over 13 scenes on 2–8 SPEs:
/// 5.7 % faster in geometric mean than the balanced end at two jobs per
/// SPE, the older default (sibenik and the ogre on 8 SPEs 35 %,
/// the default scene 4 % slower; docs/many-spes.md, "Balance").
const DEFAULT_TOP: TopKnobs = TopKnobs::SPLIT_ONE_PER_SPE;

/// The finish's default (docs/many-spes.md, "Subtrees in the local
/// store").
const DEFAULT_FINISH: Finish = Finish::Local;

/// `--steal`: the dealt jobs stay in per-SPE lists in main memory; each
/// SPE takes its next one when it has built the last, and when its list is
/// empty it steals from the end of another's (lock-line updates). Buys:
/// balance when a few dealt jobs hold most of the work. Costs: an atomic
/// update per job taken, and each dealt job is built alone (its levels are
/// not batched with the SPE's other jobs).
pub const STEAL: Knob = Knob::flag(
    "steal",
    "dealt jobs stay in per-SPE lists; an SPE whose list is empty steals from another's",
);

fn spawn(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Readback, CellError> {
    let k = &setup.knobs;
    let policies = Policies {
        deal: match k.flag(&STEAL) {
            true => Deal::Steal,
            false => Deal::LargestFirst,
        },
        top: TopKnobs::read(k, DEFAULT_TOP),
        queue: QueueKnobs::read(k, DEFAULT_QUEUE),
        finish: Finish::read(k, DEFAULT_FINISH),
    };
    policies::spawn(cell, setup, cfg, policies)
}
