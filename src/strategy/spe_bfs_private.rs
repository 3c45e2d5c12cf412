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

use crate::spe::footprint::Purpose;

use super::machinery::breadth_first::{
    FINISH, Finish, Job, NO_DMA_LISTS, NO_DOUBLE_BUFFER, NO_PREFETCH, QueueKnobs, SpeBuilder,
};
use super::machinery::coop::Coop;
use super::machinery::top::{
    COOP_PARTITION, DEAL_PER_SPE, NO_COOP_TOP, SpeExit, Start, TOP_END, TRIS_PER_SPE, TopKnobs,
    WorkPerSpe, build_top, help_top, largest_first,
};
use super::machinery::work_queue::{Level, WORK_BYTES, WorkPpe};
use super::{Knob, Readback, Setup, SpeWork};
use crate::bih::BihConfig;
use crate::cell::{Cell, CellError, Ea, Spe};

/// `spe_bfs_private` in the registry of builders.
pub const STRATEGY: super::Strategy = super::Strategy::new(
    "spe_bfs_private",
    "section 5: SPE 0 builds the top levels (the other SPEs help partition them unless --no-coop-top), deals the jobs largest first, then every SPE builds its own jobs breadth first with its own ObjectArena list (--spes)",
    spawn,
)
// Every SPE's WorkAPPE and WorkBPPE (without the per-part slack).
.with_buffers(|n, cfg, _| 2 * Job::spill_bytes_for(n, cfg))
.on_every_spe()
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

/// `--tris-per-spe auto`: the record steps of the partition
/// (`machinery::top::partition_work`) each SPE must get before the build
/// runs on 1, 2, … 8 SPEs: just above the most, on 34 small scenes (the
/// data directory's, procedural and zoo scenes of 1,000 to 23,000
/// triangles), at which that many SPEs were slower than fewer
/// (docs/many-spes.md, "Small scenes").
const AUTO_WORK_PER_SPE: WorkPerSpe = &[0, 0, 5_600, 5_600, 15_000, 15_000, 18_000, 21_700];

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

/// This strategy's knobs, read from those given.
#[derive(Clone, Copy)]
struct PrivateKnobs {
    queue: QueueKnobs,
    top: TopKnobs,
    steal: bool,
    finish: Finish,
}

/// A deal record in main memory, one 128-byte line per SPE: jobs dealt,
/// the SPE's `WorkAPPE` and `WorkBPPE` (a fourth word unused: a DMA of 32
/// bytes).
const RECORD_BYTES: u64 = 128;

fn spawn(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Readback, CellError> {
    let p = Program::set_up(cell, setup, cfg)?;
    let run = move |spe, id| p.run(spe, id);
    Ok(p.start.common.pool.spawn_programs(cell, p.start.spes, run))
}

/// What every SPE's program reads: the triangles, the tree's settings,
/// the knobs, the pool, every SPE's `WorkAPPE`/`WorkBPPE` and the deal's
/// records and lists.
#[derive(Clone, Copy)]
struct Program {
    start: Start,
    knobs: PrivateKnobs,
    /// `WorkAPPE`/`WorkBPPE` of every SPE, carved in proportion to its
    /// triangles.
    work_ppe: Ea,
    /// One deal record per SPE.
    records: Ea,
    /// The dealt jobs and their per-SPE lists (`--steal`).
    dealt_jobs: Ea,
    lists: Ea,
}

impl Program {
    /// Reads the knobs, decides the SPEs to use and allocates the pool,
    /// the SPEs' `WorkAPPE`/`WorkBPPE` and the deal's records.
    fn set_up(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Self, CellError> {
        let (n, cfg) = (setup.count, *cfg);
        let knobs = PrivateKnobs {
            queue: QueueKnobs::read(&setup.knobs, DEFAULT_QUEUE),
            top: TopKnobs::read(&setup.knobs, DEFAULT_TOP),
            steal: setup.knobs.flag(&STEAL),
            finish: Finish::read(&setup.knobs, DEFAULT_FINISH),
        };
        let start = Start::set_up(
            cell,
            setup,
            &cfg,
            (&knobs.top, knobs.finish),
            AUTO_WORK_PER_SPE,
        )?;
        let spes = start.spes;
        // WorkAPPE and WorkBPPE of every SPE, carved in proportion to its
        // triangles: room for one level of as many jobs as triangles each.
        // (With stealing, areas go with the dealt jobs: fewer than twice
        // the deal level's size of them.)
        let parts = if knobs.steal {
            knobs.top.max_deal(spes)
        } else {
            spes
        };
        // Each part's area rounds up to whole buffers and adds one; its
        // bound adds two jobs.
        let per_part_slack = 3 * WORK_BYTES as u64;
        let work_bytes = 2 * (Job::spill_bytes_for(n, &cfg) + parts as u64 * per_part_slack);
        let alloc = |purpose: Purpose, what: &str, bytes: u64| {
            cell.memory_mut().alloc(purpose.buffer(what), bytes, 128)
        };
        Ok(Program {
            start,
            knobs,
            work_ppe: alloc(
                Purpose::WorkPpe,
                "WorkAPPE/WorkBPPE of every SPE",
                work_bytes,
            )?,
            records: alloc(
                Purpose::JobQueues,
                "deal records",
                spes as u64 * RECORD_BYTES,
            )?,
            dealt_jobs: alloc(Purpose::JobQueues, "dealt jobs", WORK_BYTES as u64)?,
            lists: alloc(Purpose::JobQueues, "dealt job lists", spes as u64 * 128)?,
        })
    }

    /// One SPE's program: SPE 0 builds the top levels, deals their last
    /// level and builds its own jobs; the others help partition the top,
    /// then build the jobs dealt to them (or take and steal them).
    async fn run(self, spe: Spe, id: usize) -> Result<SpeExit, CellError> {
        let mut b = SpeBuilder::new(
            &spe,
            self.start.tris,
            WorkPpe {
                areas: [self.work_ppe; 2],
                bytes: 0,
            },
            self.start.cfg,
            self.start.common.pool.blocks,
            self.knobs.queue,
            self.start.rates,
        )?;
        let record = spe.ls_alloc(RECORD_BYTES as u32, 128)?;
        let tag = spe.tag("deal")?;
        let mut helper = Coop::new(&spe, self.start.common.coop, self.knobs.queue.prefetch)?;
        // SPE 0's top arena is counted by build_top.
        let mut work = SpeWork::default();
        if id == 0 {
            let top = self.knobs.top;
            let dealt = build_top(
                &mut b,
                helper,
                self.start.n,
                self.start.region,
                top,
                &mut work,
            )
            .await?;
            self.deal_and_build(&spe, &mut b, dealt, (record, tag), &mut work)
                .await?;
        } else {
            // Help partition the top levels until the deal comes.
            help_top(&spe, &b, &mut helper, self.start.n, self.knobs.top).await?;
            self.build_dealt(&spe, &mut b, (record, tag), &mut work)
                .await?;
        }
        if b.builds_dealt() {
            // The arena of its own jobs.
            work.arena_blocks += b.arena.stats.blocks;
            work.arena_unused += b.arena.unused();
        }
        Ok(SpeExit::of(&b, work))
    }

    /// SPE 0 deals the top's last level `dealt` (to each SPE's record, or,
    /// `--steal`, to per-SPE lists; nothing if the tree ended in the top)
    /// and builds its own share.
    async fn deal_and_build(
        self,
        spe: &Spe,
        b: &mut SpeBuilder<'_>,
        dealt: Option<Level>,
        (record, tag): (crate::cell::LsAddr, u32),
        work: &mut SpeWork,
    ) -> Result<(), CellError> {
        let (spes, records) = (self.start.spes, self.records);
        let own = match dealt {
            Some(level) if self.knobs.steal => {
                let to = Lists {
                    jobs: self.dealt_jobs,
                    lists: self.lists,
                    records,
                };
                deal_to_lists(spe, b, level, spes, to, record, tag).await?;
                None
            }
            Some(level) => deal(spe, b, level, spes, self.work_ppe, records, record, tag).await?,
            None => {
                // The tree ended in the top levels: nothing to deal.
                tell_nothing(spe, spes, records, record, tag).await?;
                None
            }
        };
        self.finish(b)?;
        if let Some((jobs, areas)) = own {
            b.arena.renew(self.start.common.pool.blocks);
            b.queue.set_spill(WorkPpe::between(areas[0], areas[1]));
            b.take_dealt();
            let level = b.queue.restart_local(&jobs)?;
            b.levels(level, None).await?;
            let count = b.arena.allocated();
            b.arena.close(count).await?;
        } else if self.knobs.steal && dealt.is_some() {
            b.arena.renew(self.start.common.pool.blocks);
            work.stolen = take_and_steal(spe, b, spes, self.work_ppe, record, records, tag).await?;
        }
        Ok(())
    }

    /// `--finish local`: the jobs dealt to this SPE finish in its local
    /// store once they fit (it holds all else it needs by now).
    fn finish(&self, b: &mut SpeBuilder<'_>) -> Result<(), CellError> {
        match self.knobs.finish {
            Finish::Local => b.finish_locally(),
            Finish::Stream => Ok(()),
        }
    }

    /// Every other SPE reads its deal record and builds the jobs dealt to
    /// it (or, `--steal`, takes them from its list and steals).
    async fn build_dealt(
        self,
        spe: &Spe,
        b: &mut SpeBuilder<'_>,
        (record, tag): (crate::cell::LsAddr, u32),
        work: &mut SpeWork,
    ) -> Result<(), CellError> {
        let at = self.records.offset(spe.id() as u64 * RECORD_BYTES);
        spe.get(record, at, 32, tag).await?;
        spe.wait_tag(tag).await?;
        let [count, a, bb, _] = spe.ls_read::<u64>(record, 4)?[..] else {
            unreachable!("four words")
        };
        self.finish(b)?;
        if self.knobs.steal && count > 0 {
            work.stolen = take_and_steal(
                spe,
                b,
                self.start.spes,
                self.work_ppe,
                record,
                self.records,
                tag,
            )
            .await?;
        } else if count > 0 {
            b.queue.set_spill(WorkPpe::between(Ea(a), Ea(bb)));
            b.take_dealt();
            b.levels(Level::InMemory(count as usize), None).await?;
            let count = b.arena.allocated();
            b.arena.close(count).await?;
        }
        Ok(())
    }
}

/// SPE 0 deals the jobs of `level` (in `WorkA`): largest first, each to the
/// SPE with the fewest triangles so far. Writes every other SPE's jobs and
/// record and signals it; returns SPE 0's own jobs and its
/// spill areas (or `None` if it got none).
#[allow(clippy::too_many_arguments)]
async fn deal(
    spe: &Spe,
    b: &mut SpeBuilder<'_>,
    level: Level,
    spes: usize,
    work: Ea,
    records: Ea,
    record: crate::cell::LsAddr,
    tag: u32,
) -> Result<Option<(Vec<Job>, [Ea; 2])>, CellError> {
    let jobs = b.queue.load(level, 0).await?;
    // Sorting and dealing: the per-job bookkeeping rate of the SPE loop for
    // each job (docs/cost-model.md).
    spe.compute_items(b.rates.spe_job, jobs.len() as u64);
    let hands = largest_first(&jobs, spes);
    let mut own = None;
    let mut at = work;
    for (to, hand) in hands.into_iter().enumerate() {
        let triangles: usize = hand.iter().map(|j| j.count as usize).sum();
        let area = Job::spill_bytes_for(triangles.max(1), &b.cfg) + WORK_BYTES as u64;
        let areas = [at, at.offset(area)];
        at = at.offset(2 * area);
        if to == 0 {
            own = (!hand.is_empty()).then_some((hand, areas));
            continue;
        }
        if !hand.is_empty() {
            b.queue.write_jobs(&hand, areas[0]).await?;
        }
        let words = [hand.len() as u64, areas[0].0, areas[1].0, 0];
        spe.ls_write(record, &words)?;
        spe.put(record, records.offset(to as u64 * RECORD_BYTES), 32, tag)
            .await?;
        spe.wait_tag(tag).await?;
        spe.send_signal(to, 1, 1).await?;
    }
    Ok(own)
}

/// The top levels made the whole tree: every other SPE is told it has no
/// jobs.
async fn tell_nothing(
    spe: &Spe,
    spes: usize,
    records: Ea,
    record: crate::cell::LsAddr,
    tag: u32,
) -> Result<(), CellError> {
    spe.ls_write(record, &[0u64; 4])?;
    for to in 1..spes {
        spe.put(record, records.offset(to as u64 * RECORD_BYTES), 32, tag)
            .await?;
        spe.wait_tag(tag).await?;
        spe.send_signal(to, 1, 1).await?;
    }
    Ok(())
}

/// Where the dealt jobs go when SPEs take them one at a time.
#[derive(Clone, Copy)]
struct Lists {
    /// Every dealt job, grouped by the SPE it was dealt to.
    jobs: Ea,
    /// One line per SPE: `head << 16 | tail`, its range in `jobs` not yet
    /// taken.
    lists: Ea,
    records: Ea,
}

/// SPE 0 deals the jobs of `level` largest first into per-SPE lists in main
/// memory (`--steal`), writes every SPE's deal record (job count, the
/// jobs, the lists) and signals the others.
async fn deal_to_lists(
    spe: &Spe,
    b: &mut SpeBuilder<'_>,
    level: Level,
    spes: usize,
    to: Lists,
    record: crate::cell::LsAddr,
    tag: u32,
) -> Result<(), CellError> {
    let jobs = b.queue.load(level, 0).await?;
    spe.compute_items(b.rates.spe_job, jobs.len() as u64);
    let hands = largest_first(&jobs, spes);
    let mut grouped = Vec::with_capacity(jobs.len());
    let mut ranges = Vec::with_capacity(spes);
    for hand in &hands {
        let start = grouped.len() as u32;
        grouped.extend(hand.iter().copied());
        ranges.push((start, grouped.len() as u32));
    }
    b.queue.write_jobs(&grouped, to.jobs).await?;
    for (k, &(h, t)) in ranges.iter().enumerate() {
        let mut line = [0u32; 32];
        line[0] = (h << 16) | t;
        spe.ls_write(record, &line)?;
        spe.put(record, to.lists.offset(k as u64 * 128), 128, tag)
            .await?;
        spe.wait_tag(tag).await?;
    }
    let words = [grouped.len() as u64, to.jobs.0, to.lists.0, 0];
    spe.ls_write(record, &words)?;
    for k in 0..spes {
        spe.put(record, to.records.offset(k as u64 * RECORD_BYTES), 32, tag)
            .await?;
        spe.wait_tag(tag).await?;
        if k > 0 {
            spe.send_signal(k, 1, 1).await?;
        }
    }
    Ok(())
}

/// Every SPE with `--steal`: reads the dealt jobs, then takes the next
/// job of its own list, or steals the last of another's, and builds it,
/// until every list is empty. Each job's `WorkAPPE`/`WorkBPPE` are carved
/// from `work` in the jobs' order, so any SPE can build any job. Returns
/// the jobs it stole.
async fn take_and_steal(
    spe: &Spe,
    b: &mut SpeBuilder<'_>,
    spes: usize,
    work: Ea,
    record: crate::cell::LsAddr,
    records: Ea,
    tag: u32,
) -> Result<u64, CellError> {
    let id = spe.id();
    spe.get(record, records.offset(id as u64 * RECORD_BYTES), 32, tag)
        .await?;
    spe.wait_tag(tag).await?;
    let [count, jobs_ea, lists, _] = spe.ls_read::<u64>(record, 4)?[..] else {
        unreachable!("four words")
    };
    let (count, lists) = (count as usize, Ea(lists));
    b.queue.set_spill(WorkPpe {
        areas: [Ea(jobs_ea); 2],
        bytes: 0,
    });
    let jobs = b.queue.load(Level::InMemory(count), 0).await?;
    let mut areas = Vec::with_capacity(count);
    let mut at = work;
    for j in &jobs {
        let area = Job::spill_bytes_for(j.count as usize, &b.cfg) + WORK_BYTES as u64;
        areas.push([at, at.offset(area)]);
        at = at.offset(2 * area);
    }
    b.take_dealt();
    let mut stolen = 0;
    loop {
        // Choosing where to take from: the per-job bookkeeping rate.
        spe.compute(b.rates.spe_job);
        let Some((k, from_other)) = take(spe, record, lists, id, spes).await? else {
            break;
        };
        stolen += from_other as u64;
        b.queue
            .set_spill(WorkPpe::between(areas[k][0], areas[k][1]));
        let level = b.queue.restart_local(&jobs[k..k + 1])?;
        b.levels(level, None).await?;
    }
    let n = b.arena.allocated();
    b.arena.close(n).await?;
    Ok(stolen)
}

/// The next job for SPE `id`: the head of its own list, else the tail of
/// the first other list (from `id + 1` on) that has one. Each is one
/// lock-line update of the list's `head << 16 | tail` word. Returns the
/// job's index and whether it was stolen.
async fn take(
    spe: &Spe,
    line: crate::cell::LsAddr,
    lists: Ea,
    id: usize,
    spes: usize,
) -> Result<Option<(usize, bool)>, CellError> {
    let split = |w: u32| (w >> 16, w & 0xffff);
    let own = lists.offset(id as u64 * 128);
    let old = spe
        .atomic_update_u32(line, own, |w| {
            let (h, t) = split(w);
            if h < t { ((h + 1) << 16) | t } else { w }
        })
        .await?;
    let (h, t) = split(old);
    if h < t {
        return Ok(Some((h as usize, false)));
    }
    for v in 1..spes {
        let victim = lists.offset(((id + v) % spes) as u64 * 128);
        let old = spe
            .atomic_update_u32(line, victim, |w| {
                let (h, t) = split(w);
                if h < t { (h << 16) | (t - 1) } else { w }
            })
            .await?;
        let (h, t) = split(old);
        if h < t {
            return Ok(Some((t as usize - 1, true)));
        }
    }
    Ok(None)
}
