//! Section 5's one common job queue ([`Deal::Shared`]): every SPE takes
//! jobs from one queue in main memory, a tree level at a time,
//! synchronised only by the atomic unit (getllar/putllc on 128-byte lock
//! lines; the PPE does nothing per job); children's jobs are pushed into
//! the next level's array at places reserved by fetch-and-add; a level
//! ends at a barrier; every node goes straight into the slot its parent's
//! SPE handed out ([`NodeWrites`]). A take's jobs may be read through
//! section 5's software cache for the job queue.
//!
//! [`Deal::Shared`]: super::Deal::Shared

use super::{Policies, SharedQueue};
use crate::bih::BihConfig;
use crate::cell::{Cell, CellError, Ea, LsAddr, Spe};
use crate::spe::barrier::Barrier;
use crate::spe::footprint::Purpose;
use crate::spe::software_cache::{CacheConfig, CacheRates, LINE, SoftwareCache};
use crate::strategy::machinery::breadth_first::{Job, SpeBuilder};
use crate::strategy::machinery::coop::Coop;
use crate::strategy::machinery::node_writes::NodeWrites;
use crate::strategy::machinery::top::{SpeExit, Start, build_top, help_top};
use crate::strategy::machinery::work_queue::{Level, SharedSpill, WorkPpe, from_wire};
use crate::strategy::program::{Setup, SpeWork};

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
    /// Jobs that fit the local store (`--finish local`), put aside as the
    /// levels reach them and finished after the last level.
    subtrees: Ea,
    /// Words 0 and 1: the next put-aside job to take, and their count.
    subtree_line: Ea,
    spes: usize,
}

/// What every SPE's program reads: the triangles, the tree's settings,
/// the knobs, the pool and the shared queue.
#[derive(Clone, Copy)]
pub(super) struct Program {
    pub start: Start,
    policies: Policies,
    shared: SharedQueue,
    queue: Queue,
}

impl Program {
    /// Decides the SPEs to use and allocates the pool and the shared
    /// queue in main memory.
    pub fn set_up(
        cell: &mut Cell,
        setup: &Setup,
        cfg: &BihConfig,
        (policies, shared): (Policies, SharedQueue),
        spes: usize,
    ) -> Result<Self, CellError> {
        let (n, cfg) = (setup.count, *cfg);
        let start = policies.start(cell, setup, &cfg, spes)?;
        Ok(Program {
            start,
            policies,
            shared,
            queue: Queue::alloc(cell, n, &cfg, shared.job_cache > 0, start.spes)?,
        })
    }

    /// One SPE's program: the top levels (SPE 0 builds them and hands
    /// their last level to the queue; the others help partition), then
    /// the shared levels, then its arena closed.
    pub async fn run(self, spe: Spe, id: usize) -> Result<SpeExit, CellError> {
        let (q, policies, shared) = (self.queue, self.policies, self.shared);
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
            policies.queue,
            self.start.rates,
        )?;
        let mut helper = Coop::new(&spe, self.start.common.coop, policies.queue.prefetch)?;
        let line = spe.ls_alloc(128, 128)?;
        let mut work = SpeWork::default();
        if id == 0 {
            let top = build_top(
                &mut b,
                helper,
                self.start.n,
                self.start.region,
                policies.top,
                &mut work,
            )
            .await?;
            q.open(&spe, &mut b, top, line).await?;
        } else {
            help_top(&spe, &b, &mut helper, self.start.n, policies.top).await?;
        }
        b.arena.renew(blocks);
        let writes = NodeWrites::new(&spe, self.start.common.pool.base, policies.queue.dma_lists)?;
        b.share_queue(writes);
        let mut cache = match shared.job_cache {
            0 => None,
            kib => Some(job_cache(&spe, kib as u32, self.start.cache)?),
        };
        policies.after_the_top(&mut b)?;
        // A subtree built by one SPE while the others have nothing left
        // to take: none larger than an SPE's share of the triangles.
        b.finish_at_most(self.start.n.div_ceil(self.start.spes));
        work.taken = shared_levels(&spe, &mut b, q, shared, line, cache.as_mut()).await?;
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
            subtrees: alloc("subtrees put aside", level_bytes)?,
            subtree_line: alloc("subtrees line", 128)?,
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
    knobs: SharedQueue,
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
                    // An empty level: the levels are done; the subtrees
                    // put aside are what is left.
                    q.finish_subtrees(spe, b, line).await?;
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
            let (subtrees, jobs): (Vec<Job>, Vec<Job>) =
                jobs.into_iter().partition(|j| b.finishes_locally(j));
            q.put_aside(spe, b, &subtrees, line).await?;
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

impl Queue {
    /// Puts `jobs`, which fit the local store, aside: a level's barrier
    /// would otherwise wait for the SPE that builds the longest of them
    /// while the others idle. Places are reserved by one lock-line update.
    async fn put_aside(
        &self,
        spe: &Spe,
        b: &mut SpeBuilder<'_>,
        jobs: &[Job],
        line: LsAddr,
    ) -> Result<(), CellError> {
        if jobs.is_empty() {
            return Ok(());
        }
        let count = jobs.len() as u32;
        let at = spe
            .atomic_update_line(line, self.subtree_line, |w| {
                w[1] += count;
                w[1] - count
            })
            .await?;
        let job_bytes = b.queue.stride() as u64;
        b.queue
            .put_taken(jobs, self.subtrees.offset(at as u64 * job_bytes))
            .await
    }

    /// After the last level: every SPE takes the jobs put aside one at a
    /// time and finishes each in its local store, with no barrier between
    /// them (`SpeWork::subtrees` counts them).
    async fn finish_subtrees(
        &self,
        spe: &Spe,
        b: &mut SpeBuilder<'_>,
        line: LsAddr,
    ) -> Result<(), CellError> {
        let job_bytes = b.queue.stride() as u64;
        loop {
            let next = spe
                .atomic_update_line(line, self.subtree_line, |w| {
                    let next = w[0];
                    w[0] = w[1].min(next + 1);
                    (next < w[1]).then_some(next)
                })
                .await?;
            let Some(at) = next else {
                return b.settle_local().await;
            };
            let jobs = b
                .queue
                .read_jobs(self.subtrees.offset(at as u64 * job_bytes), 1)
                .await?;
            b.process(&jobs).await?;
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
