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
//!    ([`NodeWrites`]: one `putl` per batch with `--dma-lists`).
//!
//! 4. **Section 5's software cache for the job queue** (`--job-cache KiB`):
//!    a take's jobs are read through a [`SoftwareCache`] in the local
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

use crate::spe::footprint::Purpose;

use super::machinery::breadth_first::{
    DMA_LISTS, DOUBLE_BUFFER, FINISH, Finish, Job, NO_PREFETCH, QueueKnobs, SpeBuilder,
};
use super::machinery::coop::Coop;
use super::machinery::node_writes::NodeWrites;
use super::machinery::top::{
    COOP_PARTITION, DEAL_PER_SPE, NO_COOP_TOP, SpeExit, Start, TOP_END, TRIS_PER_SPE, TopKnobs,
    WorkPerSpe, build_top, help_top,
};
use super::machinery::work_queue::{Level, SharedSpill, WorkPpe, WorkQueue, from_wire};
use super::{Knob, Readback, Setup, SpeWork};
use crate::bih::BihConfig;
use crate::cell::{Cell, CellError, Ea, LsAddr, Spe};
use crate::spe::barrier::Barrier;
use crate::spe::software_cache::{CacheConfig, CacheRates, LINE, SoftwareCache};

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

/// `--tris-per-spe auto`: the record steps of the partition
/// (`machinery::top::partition_work`) each SPE must get before the build
/// runs on 1, 2, … 8 SPEs: just above the most, on 34 small scenes (the
/// data directory's, procedural and zoo scenes of 1,000 to 23,000
/// triangles), at which that many SPEs were slower than fewer. A fifth SPE
/// is the dear one: it pays a cooperative top level more (docs/many-spes.md,
/// "Small scenes").
const AUTO_WORK_PER_SPE: WorkPerSpe = &[0, 0, 5_600, 5_600, 15_000, 15_500, 15_500, 15_500];

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

/// This strategy's knobs, read from those given.
#[derive(Clone, Copy)]
struct SharedKnobs {
    queue: QueueKnobs,
    top: TopKnobs,
    finish: Finish,
    /// Jobs taken from the shared queue per atomic operation (1 to 256,
    /// and no more than a `WorkA` holds). Buys: fewer lock-line updates
    /// and larger batches. Costs: balance at the end of a level (the last
    /// takes are large).
    agglomerate: usize,
    /// A take hands out no more than an equal share of the level's jobs
    /// left among the SPEs (guided self-scheduling), so that a level of
    /// few jobs is spread over every SPE. Buys: balance at the top of the
    /// shared levels and at each level's end. Costs: more takes (lock-line
    /// updates) near each level's end.
    guided: bool,
    /// KiB of software cache the jobs are read through (0: explicit gets,
    /// the default; section 5's proposal). Buys: a line shared by two
    /// takes of one SPE is read once. Costs: a lookup per line and a get
    /// per missed line, where a take was one get.
    job_cache: usize,
}

/// The queue's lock lines in main memory.
#[derive(Clone, Copy)]
struct Queue {
    /// The two level arrays (the shared `WorkAPPE`/`WorkBPPE`).
    levels: [Ea; 2],
    /// Bytes of each level's array.
    level_bytes: u64,
    /// Jobs each level array holds.
    capacity: u32,
    /// Words 0 and 1: the next job to take, and the level's job count.
    take: Ea,
    /// Word 0: jobs reserved in the next level's array.
    push: Ea,
    /// Word 0: SPEs arrived at a level's end, counted over all levels.
    arrivals: Ea,
    spes: usize,
}

fn spawn(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Readback, CellError> {
    let p = Program::set_up(cell, setup, cfg)?;
    let run = move |spe, id| p.run(spe, id);
    Ok(p.start.common.pool.spawn_programs(cell, p.start.spes, run))
}

/// What every SPE's program reads: the triangles, the tree's settings,
/// the knobs, the pool and the shared queue.
#[derive(Clone, Copy)]
struct Program {
    start: Start,
    knobs: SharedKnobs,
    queue: Queue,
}

impl Program {
    /// Reads the knobs, decides the SPEs to use and allocates the pool and
    /// the shared queue in main memory.
    fn set_up(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Self, CellError> {
        let (n, cfg) = (setup.count, *cfg);
        let knobs = SharedKnobs {
            queue: QueueKnobs::read(&setup.knobs, DEFAULT_QUEUE),
            top: TopKnobs::read(&setup.knobs, DEFAULT_TOP),
            finish: Finish::read(&setup.knobs, DEFAULT_FINISH),
            agglomerate: setup.knobs.int(&AGGLOMERATE),
            guided: !setup.knobs.flag(&FIXED_TAKES),
            job_cache: setup.knobs.int(&JOB_CACHE),
        };
        let job_bytes = Job::bytes(&cfg);
        let per_buffer = WorkQueue::<Job>::per_buffer(job_bytes);
        if knobs.agglomerate > per_buffer {
            return Err(CellError::Config(format!(
                "spe_bfs_shared: --agglomerate {}: a take must fit WorkA, which holds {per_buffer} jobs of {job_bytes} bytes with these settings",
                knobs.agglomerate,
            )));
        }
        let start = Start::set_up(
            cell,
            setup,
            &cfg,
            (&knobs.top, knobs.finish),
            AUTO_WORK_PER_SPE,
        )?;
        Ok(Program {
            start,
            knobs,
            queue: Queue::alloc(cell, n, &cfg, knobs.job_cache > 0, start.spes)?,
        })
    }

    /// One SPE's program: the top levels (SPE 0 builds them and hands
    /// their last level to the queue; the others help partition), then
    /// the shared levels, then its arena closed.
    async fn run(self, spe: Spe, id: usize) -> Result<SpeExit, CellError> {
        let (q, knobs) = (self.queue, self.knobs);
        let blocks = self.start.common.pool.blocks;
        let mut b = SpeBuilder::new(
            &spe,
            self.start.tris,
            WorkPpe {
                areas: q.levels,
                bytes: q.level_bytes,
            },
            self.start.cfg,
            blocks,
            knobs.queue,
            self.start.rates,
        )?;
        let mut helper = Coop::new(&spe, self.start.common.coop, knobs.queue.prefetch)?;
        let line = spe.ls_alloc(128, 128)?;
        let mut work = SpeWork::default();
        if id == 0 {
            let top = build_top(
                &mut b,
                helper,
                self.start.n,
                self.start.region,
                knobs.top,
                &mut work,
            )
            .await?;
            q.open(&spe, &mut b, top, line).await?;
        } else {
            help_top(&spe, &b, &mut helper, self.start.n, knobs.top).await?;
        }
        b.arena.renew(blocks);
        let writes = NodeWrites::new(&spe, self.start.common.pool.base, knobs.queue.dma_lists)?;
        b.share_queue(writes);
        let mut cache = match knobs.job_cache {
            0 => None,
            kib => Some(job_cache(&spe, kib as u32, self.start.cache)?),
        };
        if knobs.finish == Finish::Local {
            // It holds all else it needs by now.
            b.finish_locally()?;
        }
        work.taken = shared_levels(&spe, &mut b, q, knobs, line, cache.as_mut()).await?;
        if let Some(c) = cache {
            work.job_cache += c.stats;
        }
        let count = b.arena.allocated();
        b.arena.close(count).await?;
        work.arena_blocks += b.arena.stats.blocks;
        work.arena_unused += b.arena.unused();
        Ok(SpeExit::of(&b, work))
    }
}

impl Queue {
    /// The shared queue of `spes` SPEs for `n` triangles in main memory:
    /// two level arrays and three lock lines.
    fn alloc(
        cell: &mut Cell,
        n: usize,
        cfg: &BihConfig,
        cached: bool,
        spes: usize,
    ) -> Result<Self, CellError> {
        let job_bytes = Job::bytes(cfg);
        // A level's jobs: two per job of the level before with more than a
        // leaf's triangles (disjoint intervals), at most 2n / (leaf size +
        // 1) (footprint::work_ppe_jobs); the level handed over from the top
        // is under 32 jobs per SPE.
        let jobs = crate::spe::footprint::work_ppe_jobs(n, cfg.leaf_size).max(32 * spes);
        let capacity = u32::try_from(jobs).map_err(|_| {
            CellError::Config(format!(
                "spe_bfs_shared: {n} triangles are too many for one queue"
            ))
        })?;
        let mut level_bytes = (jobs * job_bytes) as u64;
        if cached {
            // The cache reads whole lines: the arrays end on one.
            level_bytes = level_bytes.next_multiple_of(LINE);
        }
        let alloc = |what: &str, bytes: u64| {
            let label = Purpose::JobQueues.buffer(format!("shared job queue: {what}"));
            cell.memory_mut().alloc(label, bytes, 128)
        };
        Ok(Queue {
            levels: [
                alloc("level A", level_bytes)?,
                alloc("level B", level_bytes)?,
            ],
            level_bytes,
            capacity,
            take: alloc("take line", 128)?,
            push: alloc("push line", 128)?,
            arrivals: alloc("arrivals line", 128)?,
            spes,
        })
    }

    /// SPE 0 writes the top's last level (if the tree did not end there)
    /// into the first level array, opens it for taking and signals the
    /// other SPEs.
    async fn open(
        self,
        spe: &Spe,
        b: &mut SpeBuilder<'_>,
        top: Option<Level>,
        line: LsAddr,
    ) -> Result<(), CellError> {
        let job_bytes = b.queue.stride() as u64;
        let mut count = 0u64;
        if let Some(level) = top {
            for k in 0..b.queue.blocks(level) {
                let jobs = b.queue.load(level, k).await?;
                let at = self.levels[0].offset(count * job_bytes);
                b.queue.write_jobs(&jobs, at).await?;
                count += jobs.len() as u64;
            }
        }
        spe.atomic_update_line(line, self.take, |w| {
            (w[0], w[1]) = (0, count as u32);
        })
        .await?;
        for to in 1..self.spes {
            spe.send_signal(to, 1, 1).await?;
        }
        Ok(())
    }
}

/// The job queue's software cache of `kib` KiB in `spe`'s local store
/// (4-way); an error says how much room the other buffers left.
fn job_cache(spe: &Spe, kib: u32, rates: CacheRates) -> Result<SoftwareCache, CellError> {
    let shape = CacheConfig {
        kib,
        ways: 4,
        fetch_lines: 1,
    };
    let free = spe.ls_free_bytes();
    if shape.ls_bytes() > free {
        return Err(CellError::Config(format!(
            "spe_bfs_shared: --job-cache {kib}: the cache takes {} bytes of local store, and {free} are left beside this build's other buffers",
            shape.ls_bytes()
        )));
    }
    SoftwareCache::new(spe, shape, rates, 1)
}

/// Every SPE: takes jobs from the shared queue level by level until a
/// level is empty; returns how many takes found jobs.
async fn shared_levels(
    spe: &Spe,
    b: &mut SpeBuilder<'_>,
    q: Queue,
    knobs: SharedKnobs,
    line: LsAddr,
    mut cache: Option<&mut SoftwareCache>,
) -> Result<u64, CellError> {
    let (agglomerate, guided) = (knobs.agglomerate, knobs.guided);
    let job_bytes = b.queue.stride() as u64;
    let mut taken = 0u64;
    let mut level = 0usize;
    let mut barrier = Barrier::new(q.arrivals, q.spes);
    loop {
        let (this, next) = (q.levels[level % 2], q.levels[1 - level % 2]);
        b.queue.share(Some(SharedSpill {
            to: next,
            capacity: q.capacity,
            counter: q.push,
            line,
        }));
        loop {
            // One lock-line update takes up to `agglomerate` jobs; guided,
            // no more than an SPE's share of the jobs left.
            let (first, len, size) = spe
                .atomic_update_line(line, q.take, |w| {
                    let (first, len) = (w[0], w[1]);
                    let size = take_size(len.saturating_sub(first), q.spes, agglomerate, guided);
                    w[0] = len.min(first + size);
                    (first, len, size)
                })
                .await?;
            if first >= len {
                if len == 0 {
                    // An empty level: the tree is done.
                    b.finish_node_writes().await?;
                    return Ok(taken);
                }
                break;
            }
            let count = (len - first).min(size) as usize;
            let at = this.offset(first as u64 * job_bytes);
            let jobs = match cache.as_deref_mut() {
                Some(c) => {
                    let mut bytes = vec![0u8; count * job_bytes as usize];
                    c.read(spe, at, &mut bytes).await?;
                    from_wire(&bytes, job_bytes as usize)
                }
                None => b.queue.read_jobs(at, count).await?,
            };
            b.process(&jobs).await?;
            taken += 1;
        }
        // The next level reads what this SPE wrote: its children's jobs
        // and its partitioned records are in main memory first.
        b.queue.flush_shared().await?;
        b.drain().await?;
        level += 1;
        level_end(spe, q, &mut barrier, line).await?;
        // The next level but one rewrites this level's array.
        if let Some(c) = cache.as_deref_mut() {
            c.invalidate(spe);
        }
    }
}

/// Jobs one take hands out when `left` jobs of the level are left:
/// `agglomerate`, or, guided (guided self-scheduling, Polychronopoulos &
/// Kuck 1987), an equal share of what is left among the `spes` SPEs,
/// capped at `agglomerate`, so that a level's first takes are large and
/// its last ones small and no SPE takes a level's few jobs alone.
fn take_size(left: u32, spes: usize, agglomerate: usize, guided: bool) -> u32 {
    let most = agglomerate as u32;
    if guided {
        left.div_ceil(spes as u32).clamp(1, most)
    } else {
        most
    }
}

/// The end of a level: the last SPE to arrive makes the next level the one
/// to take from (its job count is what was pushed) and signals the others.
async fn level_end(
    spe: &Spe,
    q: Queue,
    barrier: &mut Barrier,
    line: LsAddr,
) -> Result<(), CellError> {
    if !barrier.arrive(spe, line).await? {
        return spe.read_signal(2).await.map(|_| ());
    }
    let pushed = spe.atomic_update_u32(line, q.push, |_| 0).await?;
    spe.atomic_update_line(line, q.take, |w| {
        (w[0], w[1]) = (0, pushed);
    })
    .await?;
    barrier.release(spe).await
}

#[cfg(test)]
mod tests {
    use super::take_size;

    #[test]
    fn guided_takes_shrink_to_a_share_of_what_is_left() {
        // 24 jobs among 6 SPEs, 16 a take: 4 each, not 16 and 8.
        assert_eq!(take_size(24, 6, 16, true), 4);
        assert_eq!(take_size(24, 6, 16, false), 16);
        assert_eq!(take_size(1000, 6, 16, true), 16);
        assert_eq!(take_size(5, 6, 16, true), 1);
        assert_eq!(take_size(0, 6, 16, true), 1);
    }
}
