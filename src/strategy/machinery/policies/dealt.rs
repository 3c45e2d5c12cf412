//! The private queues' deal (section 5): SPE 0 deals the top's last
//! level largest first, each job to the SPE with the fewest triangles so
//! far, and every SPE builds its own jobs with the baseline's loop, its
//! own `WorkAPPE`/`WorkBPPE` and ObjectArena list, with no
//! synchronisation ([`Deal::LargestFirst`]); or the dealt jobs stay in
//! per-SPE lists in main memory that an SPE takes from and, its own list
//! empty, steals from ([`Deal::Steal`]).

use super::{Deal, Policies};
use crate::bih::BihConfig;
use crate::cell::{Cell, CellError, Ea, Spe};
use crate::spe::footprint::Purpose;
use crate::strategy::machinery::breadth_first::{Job, SpeBuilder};
use crate::strategy::machinery::coop::Coop;
use crate::strategy::machinery::top::{SpeExit, Start, build_top, help_top, largest_first};
use crate::strategy::machinery::work_queue::{Level, WORK_BYTES, WorkPpe};
use crate::strategy::program::{Setup, SpeWork};

/// A deal record in main memory, one 128-byte line per SPE: jobs dealt,
/// the SPE's `WorkAPPE` and `WorkBPPE` (a fourth word unused: a DMA of 32
/// bytes).
const RECORD_BYTES: u64 = 128;

/// What every SPE's program reads: the triangles, the tree's settings,
/// the knobs, the pool, every SPE's `WorkAPPE`/`WorkBPPE` and the deal's
/// records and lists.
#[derive(Clone, Copy)]
pub(super) struct Program {
    pub start: Start,
    policies: Policies,
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
    /// Decides the SPEs to use and allocates the pool, the SPEs'
    /// `WorkAPPE`/`WorkBPPE` and the deal's records.
    pub fn set_up(
        cell: &mut Cell,
        setup: &Setup,
        cfg: &BihConfig,
        policies: Policies,
        spes: usize,
    ) -> Result<Self, CellError> {
        let (n, cfg) = (setup.count, *cfg);
        let start = policies.start(cell, setup, &cfg, spes)?;
        let steal = matches!(policies.deal, Deal::Steal);
        let spes = start.spes;
        // WorkAPPE and WorkBPPE of every SPE, carved in proportion to its
        // triangles: room for one level of as many jobs as triangles each.
        // (With stealing, areas go with the dealt jobs: fewer than twice
        // the deal level's size of them.)
        let parts = if steal {
            policies.top.max_deal(spes)
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
            policies,
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
    pub async fn run(self, spe: Spe, id: usize) -> Result<SpeExit, CellError> {
        let mut b = SpeBuilder::new(
            &spe,
            self.start.tris,
            WorkPpe {
                areas: [self.work_ppe; 2],
                bytes: 0,
            },
            self.start.cfg,
            self.start.common.pool.blocks,
            self.policies.queue,
            self.start.rates,
        )?;
        let record = spe.ls_alloc(RECORD_BYTES as u32, 128)?;
        let tag = spe.tag("deal")?;
        let mut helper = Coop::new(&spe, self.start.common.coop, self.policies.queue.prefetch)?;
        // SPE 0's top arena is counted by build_top.
        let mut work = SpeWork::default();
        if id == 0 {
            let top = self.policies.top;
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
            help_top(&spe, &b, &mut helper, self.start.n, self.policies.top).await?;
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
            Some(level) if self.steals() => {
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
        self.policies.after_the_top(b)?;
        if let Some((jobs, areas)) = own {
            b.arena.renew(self.start.common.pool.blocks);
            b.queue.set_spill(WorkPpe::between(areas[0], areas[1]));
            b.take_dealt();
            let level = b.queue.restart_local(&jobs)?;
            b.levels(level, None).await?;
            let count = b.arena.allocated();
            b.arena.close(count).await?;
        } else if self.steals() && dealt.is_some() {
            b.arena.renew(self.start.common.pool.blocks);
            work.stolen = take_and_steal(spe, b, spes, self.work_ppe, record, records, tag).await?;
        }
        Ok(())
    }

    /// Whether the dealt jobs stay in lists SPEs steal from.
    fn steals(&self) -> bool {
        matches!(self.policies.deal, Deal::Steal)
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
        self.policies.after_the_top(b)?;
        if self.steals() && count > 0 {
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
