//! The breadth-first loop of the paper's baseline (section 2, Fig. 2,
//! Table 1), which `spe_bfs` runs on one SPE and section 5's multi-SPE
//! strategies run on every SPE (`SpeBuilder`): the tree is built level by
//! level "almost entirely independent from the PPE".
//!
//! - **Jobs** (the intervals of the next tree level, 64 bytes each, [`Job`])
//!   live in `WorkA` (the current level) and `WorkB` (the next), spilled to
//!   `WorkAPPE`/`WorkBPPE`: the two-phase queue of Fig. 2
//!   ([`super::work_queue`]).
//! - **Partitions**: an interval over 16 KiB streams through the five
//!   buffers of Fig. 1; smaller ones are **agglomerated**: consecutive jobs
//!   whose intervals span at most 16 KiB of the triangle array travel in one
//!   get and one put.
//! - **Nodes** go into an **ObjectArena** ([`super::arena`]) whose blocks
//!   the PPE (or a pool) hands out. Every job is one node, made in the
//!   order of node ids, so the SPE computes each node's address itself.
//!
//! What a job makes is the one node decision ([`crate::kernels::decide`]),
//! so the tree is the host tree with its nodes numbered breadth first. So
//! with the quality knobs (not in the paper): with the
//! empty-space cut-off ([`crate::kernels::cutoff`]) a job carries its region
//! and its triangles' box (128 bytes) and a clip node is a job that moves
//! no triangle; with binned SAH ([`crate::kernels::sah`]) a split job bins
//! its triangles in the local store (or in one more stream through Fig. 1's
//! buffers) before its partition. Section 5's improvements of the queue
//! are knobs (`QueueKnobs`) of the strategies that take them.

mod batch;
mod job;
mod local;

use crate::kernels::rates::KernelRates;

use super::arena::{BlockSource, ObjectArena};
use super::node_writes::NodeWrites;
use super::work_queue::{Level, WorkPpe, WorkQueue};
use crate::aabb::Aabb;
use crate::bih::{BihConfig, BihNode, SplitChoice};
use crate::cell::{CellError, Ea, LsAddr, Spe, WaitMode};
use crate::kernels::cutoff::{Clip, child_regions};
use crate::kernels::recursion::BuildStats;
use crate::kernels::sah::Bins;
use crate::kernels::split::{Side, Split, clip_planes};
use crate::spe::fig1::{Fig1Buffers, stream_bounds};
use crate::spe::layout::TriRecord;
use crate::strategy::knob::{Knob, Knobs};
use crate::strategy::program::Phase;
pub use job::Job;
use local::LocalArea;
pub(in crate::strategy) use local::{FINISH, Finish, largest_local};

/// `--double-buffer`: `QueueKnobs::double_buffer`.
pub const DOUBLE_BUFFER: Knob = Knob::flag(
    "double-buffer",
    "double-buffered WorkA/WorkB: no synchronous job-queue DMA (section 5)",
);
/// `--dma-lists`: `QueueKnobs::dma_lists`.
pub const DMA_LISTS: Knob = Knob::flag(
    "dma-lists",
    "DMA lists gather and scatter the intervals of agglomerated jobs (section 5)",
);
/// `--prefetch`: `QueueKnobs::prefetch` where it is off by default.
pub const PREFETCH: Knob = Knob::flag(
    "prefetch",
    "the next batch's get overlaps this batch's partition",
);
/// `--no-prefetch`: `QueueKnobs::prefetch` off where it is on by default.
pub const NO_PREFETCH: Knob = Knob::flag(
    "no-prefetch",
    "each batch's get is waited for before its partition, as in the paper (default: the next batch's get overlaps this batch's partition)",
);
/// `--no-double-buffer`: `QueueKnobs::double_buffer` off where it is on by
/// default.
pub const NO_DOUBLE_BUFFER: Knob = Knob::flag(
    "no-double-buffer",
    "one WorkA/WorkB, synchronous job-queue DMA, as in the paper (default: double-buffered, section 5)",
);
/// `--no-dma-lists`: `QueueKnobs::dma_lists` off where it is on by default.
pub const NO_DMA_LISTS: Knob = Knob::flag(
    "no-dma-lists",
    "no DMA lists for agglomerated jobs, as in the paper (default: one getl/putl per batch, section 5)",
);

/// Section 5's improvements of the job queue, which the multi-SPE
/// strategies take as knobs (the baseline runs without them).
#[derive(Clone, Copy, Debug)]
pub(in crate::strategy) struct QueueKnobs {
    /// Section 5: a second `WorkA` and `WorkB` in the local store, so that a
    /// full `WorkB` is written back while the other fills, and the next
    /// block of a spilled level is read while this one is built (no
    /// synchronous queue DMA). Costs 32 KiB of local store.
    pub double_buffer: bool,
    /// Section 5: DMA lists for agglomerated jobs — a batch gathers the
    /// intervals of jobs that are not adjacent in one `getl` and scatters
    /// them back in one `putl`, and nodes written into other arenas' slots
    /// go out in one `putl` per batch. Off, each adjacent run is its own
    /// batch and each piece of a node its own put.
    pub dma_lists: bool,
    /// The get of the next agglomerated batch is issued before the current
    /// one is partitioned, so the transfer overlaps the partition (three
    /// batch buffers instead of two). Off, a batch's get is waited for
    /// before its partition starts, as in the paper.
    pub prefetch: bool,
}

impl QueueKnobs {
    /// The paper's single-SPE queue: none of section 5's improvements.
    pub const PAPER: QueueKnobs = QueueKnobs {
        double_buffer: false,
        dma_lists: false,
        prefetch: false,
    };

    /// The values `knobs` gives them, each improvement on by default where
    /// `on` has it (then its `--no-…` knob turns it off) and off otherwise
    /// (then its knob turns it on).
    pub fn read(knobs: &Knobs, on: QueueKnobs) -> Self {
        let pick = |default: bool, yes: &Knob, no: &Knob| match default {
            true => !knobs.flag(no),
            false => knobs.flag(yes),
        };
        QueueKnobs {
            double_buffer: pick(on.double_buffer, &DOUBLE_BUFFER, &NO_DOUBLE_BUFFER),
            dma_lists: pick(on.dma_lists, &DMA_LISTS, &NO_DMA_LISTS),
            prefetch: pick(on.prefetch, &PREFETCH, &NO_PREFETCH),
        }
    }
}

/// Where the top levels end (`machinery::top`): at the first level in
/// `WorkA` of at least `jobs` jobs, or if `balanced` the first such level
/// where also no job holds more than one SPE's share of the level's
/// triangles (each SPE can get a fair share of whole jobs) or the jobs
/// average under [`COOP_MIN_MEAN`] triangles; at the latest at `cap` jobs
/// (the most `WorkA` keeps at the top).
#[derive(Clone, Copy, Debug)]
pub(in crate::strategy) struct TopEnd {
    pub jobs: usize,
    pub cap: usize,
    pub spes: usize,
    pub balanced: bool,
}

/// Below this many triangles a job on average, a balanced top ends: the
/// cooperative partition of so few does not pay for its barriers
/// (measured: homer and the teapot on 8 SPEs, docs/many-spes.md).
const COOP_MIN_MEAN: u64 = 1024;

impl TopEnd {
    /// Whether a balanced top ends before `jobs`.
    pub fn ends(&self, jobs: &[Job]) -> bool {
        let total: u64 = jobs.iter().map(|j| j.count as u64).sum();
        let largest = jobs.iter().map(|j| j.count as u64).max().unwrap_or(0);
        largest * self.spes as u64 <= total || total < COOP_MIN_MEAN * jobs.len() as u64
    }
}

/// The SPE program's state: its local-store buffers and counters. The
/// multi-SPE strategies run the same loop on every SPE.
pub(in crate::strategy) struct SpeBuilder<'a> {
    pub(in crate::strategy) spe: &'a Spe,
    tris: Ea,
    pub(in crate::strategy) cfg: BihConfig,
    /// The kernels' rates this run charges.
    pub(in crate::strategy) rates: KernelRates,
    pub(in crate::strategy) fig1: Fig1Buffers,
    /// `WorkA`/`WorkB` and their spill areas.
    pub(in crate::strategy) queue: WorkQueue<'a, Job>,
    pub(in crate::strategy) arena: ObjectArena<'a>,
    /// Jobs were dealt to this SPE: the first level of each
    /// [`Self::levels`] is made of them, and their nodes' slots belong to
    /// another arena (multi-SPE strategies). The jobs of a dealt level may
    /// be of different depths (the top's `--top-end split`).
    dealt: bool,
    /// The level being built is the dealt one.
    dealt_level: bool,
    /// Nodes of jobs split from a level about to be dealt, written once
    /// the top's arena is closed ([`Self::split_dealt`]).
    held: Vec<(u32, BihNode)>,
    /// Where the intervals of the jobs dealt to this SPE start: a batch of
    /// agglomerated jobs never spans two of them.
    dealt_starts: Vec<u32>,
    /// A shared queue: records between two jobs this SPE took may be
    /// another SPE's, so a batch's span never crosses a gap.
    strict_spans: bool,
    /// A shared queue: every node goes straight into its slot.
    node_writes: Option<NodeWrites<'a>>,
    /// Batches gather non-adjacent intervals with DMA lists.
    dma_lists: bool,
    /// Binned SAH: the bins' place in the local store (filled there, then
    /// swept).
    bins: Option<LsAddr>,
    /// The next batch's get is issued before this one is partitioned.
    prefetch: bool,
    /// The other SPEs help partition intervals of at least this many
    /// triangles (multi-SPE strategies, before the deal).
    coop: Option<(super::coop::Coop, u32)>,
    /// Which Fig. 1 buffer the next agglomerated batch uses (0 or 1; 0 to
    /// 2 when prefetching).
    batch_buf: usize,
    /// The interval each batch buffer last put back (its put may still be
    /// under way).
    batch_put: [Option<(u32, u32)>; 3],
    pub(in crate::strategy) stats: BuildStats,
    /// Jobs this SPE made nodes for.
    pub(in crate::strategy) jobs: u64,
    /// `--finish local`: where jobs that fit are finished, the largest
    /// that fits, and the node list a subtree is built in.
    local: Option<LocalArea>,
    local_largest: u32,
    local_jobs: u64,
    subtree: Vec<BihNode>,
    /// Its run's phases: the top levels, the subtrees finished locally.
    pub(in crate::strategy) top: Phase,
    pub(in crate::strategy) in_subtrees: Phase,
}

impl<'a> SpeBuilder<'a> {
    pub(in crate::strategy) fn new(
        spe: &'a Spe,
        tris: Ea,
        work_ppe: WorkPpe,
        cfg: BihConfig,
        blocks: BlockSource,
        knobs: QueueKnobs,
        rates: KernelRates,
    ) -> Result<Self, CellError> {
        let arena = ObjectArena::new(spe, blocks)?;
        Self::with_arena(spe, tris, work_ppe, cfg, arena, knobs, rates)
    }

    /// [`Self::new`] with the ObjectArena of a program that builds around
    /// the loop (no second arena's buffers in the local store); the
    /// program takes it back from [`Self::arena`] when the loop is done.
    pub(in crate::strategy) fn with_arena(
        spe: &'a Spe,
        tris: Ea,
        work_ppe: WorkPpe,
        cfg: BihConfig,
        arena: ObjectArena<'a>,
        knobs: QueueKnobs,
        rates: KernelRates,
    ) -> Result<Self, CellError> {
        Ok(SpeBuilder {
            spe,
            tris,
            cfg,
            rates,
            fig1: Fig1Buffers::alloc(spe)?,
            queue: WorkQueue::new(spe, work_ppe, knobs.double_buffer, Job::bytes(&cfg))?,
            arena,
            dealt: false,
            dealt_level: false,
            held: Vec::new(),
            dealt_starts: Vec::new(),
            strict_spans: false,
            node_writes: None,
            dma_lists: knobs.dma_lists,
            bins: match cfg.split {
                SplitChoice::BinnedSah { bins, .. } => {
                    Some(spe.ls_alloc(Bins::ls_bytes(bins), 128)?)
                }
                SplitChoice::GlobalHeuristic => None,
            },
            prefetch: knobs.prefetch,
            coop: None,
            jobs: 0,
            batch_buf: 0,
            batch_put: [None; 3],
            stats: BuildStats::default(),
            local: None,
            local_largest: 0,
            local_jobs: 0,
            subtree: Vec::new(),
            top: Phase::default(),
            in_subtrees: Phase::default(),
        })
    }

    /// The top levels end here for this SPE: its run so far is their
    /// phase.
    pub(in crate::strategy) fn end_top(&mut self) {
        let start = (crate::cell::Cycles::ZERO, Default::default());
        self.top = Phase::since(self.spe, &start);
    }

    /// Jobs were dealt to this SPE: from now on the first level of each
    /// [`Self::levels`] holds them, their nodes' slots belong to other
    /// arenas, and a batch of agglomerated jobs never spans two of them
    /// (multi-SPE strategies).
    pub(in crate::strategy) fn take_dealt(&mut self) {
        self.dealt = true;
    }

    /// Makes the node of `job`, one of a level SPE 0 is about to deal (the
    /// top's `--top-end split`); its children join the next level. Its slot
    /// lies among the level's, which the SPEs the jobs go to write, so it
    /// is written as they write theirs, by lock-line update, and only after
    /// the arena is closed ([`Self::write_held`]): the arena's last put
    /// rounds up over the slots after its last node.
    pub(in crate::strategy) async fn split_dealt(&mut self, job: Job) -> Result<(), CellError> {
        self.dealt_level = true;
        let made = self.process(&[job]).await;
        self.dealt_level = false;
        self.dealt_starts.clear();
        made
    }

    /// Writes the nodes [`Self::split_dealt`] made (the arena is closed).
    pub(in crate::strategy) async fn write_held(&mut self) -> Result<(), CellError> {
        for (id, node) in std::mem::take(&mut self.held) {
            self.arena.emit_foreign(id, node).await?;
        }
        Ok(())
    }

    /// Whether this SPE builds jobs dealt to it (see [`Self::take_dealt`]).
    pub(in crate::strategy) fn builds_dealt(&self) -> bool {
        self.dealt
    }

    /// From now on the jobs come from a queue shared with other SPEs: every
    /// node goes straight into its slot through `writes`, and a batch's
    /// span never crosses a gap (the records between two jobs this SPE
    /// took may be another SPE's).
    pub(in crate::strategy) fn share_queue(&mut self, writes: NodeWrites<'a>) {
        self.node_writes = Some(writes);
        self.strict_spans = true;
    }

    /// Lends the loop the node writes of a program that builds around it
    /// (every node straight into its slot), and returns those it had.
    pub(in crate::strategy) fn lend_node_writes(
        &mut self,
        writes: Option<NodeWrites<'a>>,
    ) -> Option<NodeWrites<'a>> {
        std::mem::replace(&mut self.node_writes, writes)
    }

    /// Waits for the node writes of a shared queue (the tree is done).
    pub(in crate::strategy) async fn finish_node_writes(&mut self) -> Result<(), CellError> {
        match self.node_writes.as_mut() {
            Some(w) => w.finish().await,
            None => Ok(()),
        }
    }

    /// Intervals of at least `min` triangles are partitioned with the other
    /// SPEs' help through `coop` (`None`: alone again).
    pub(in crate::strategy) fn help_with(&mut self, coop: Option<(super::coop::Coop, u32)>) {
        self.coop = coop;
    }

    /// Whether an interval of `count` triangles is partitioned with the
    /// other SPEs' help.
    pub(in crate::strategy) fn helped(&self, count: u32) -> bool {
        self.coop.as_ref().is_some_and(|&(_, min)| count >= min)
    }

    /// The bounds of all `n` triangle records (one streaming pass), for
    /// the root job.
    pub(in crate::strategy) async fn bounds_of_all(&self, n: usize) -> Result<Side, CellError> {
        let rate = self.rates.spe_bounds_item;
        stream_bounds::<TriRecord>(self.spe, &self.fig1, self.tris, n as u64, rate).await
    }

    /// Builds the tree below `root`, level by level (Fig. 2).
    pub(in crate::strategy) async fn run(&mut self, root: Job) -> Result<(), CellError> {
        // Ask for the first arena block before anything else.
        self.arena.open().await;
        let root_id = self.arena.alloc(1).await?;
        debug_assert_eq!(root_id, root.node);
        let level = self.queue.start(root)?;
        self.levels(level, None).await?;
        let count = self.arena.allocated();
        self.arena.close(count).await?;
        self.stats.nodes = count as u64;
        Ok(())
    }

    /// Builds level by level from `level`. With `stop_at`, stops before the
    /// first level where it [`TopEnd::ends`] (still in `WorkA`) and returns
    /// it; otherwise runs to the end.
    pub(in crate::strategy) async fn levels(
        &mut self,
        mut level: Level,
        stop_at: Option<TopEnd>,
    ) -> Result<Option<Level>, CellError> {
        self.dealt_level = self.dealt;
        loop {
            for k in 0..self.queue.blocks(level) {
                let jobs = self.queue.load(level, k).await?;
                self.process(&jobs).await?;
            }
            self.dealt_level = false;
            match self.queue.end_level().await? {
                Some(Level::Local(len)) if stop_at.is_some_and(|s| len >= s.jobs) => {
                    let end = stop_at.expect("checked");
                    let local = Level::Local(len);
                    if len >= end.cap || !end.balanced {
                        return Ok(Some(local));
                    }
                    // Look at the level's jobs in WorkA
                    // (`KernelRates::spe_level_scan` a job).
                    let jobs = self.queue.load(local, 0).await?;
                    self.spe
                        .compute_items(self.rates.spe_level_scan, jobs.len() as u64);
                    if end.ends(&jobs) {
                        return Ok(Some(local));
                    }
                    level = local;
                }
                Some(next) => level = next,
                None => {
                    self.settle_local().await?;
                    return Ok(None);
                }
            }
        }
    }

    /// Writes `job`'s node: into this SPE's arena, or, for a job dealt to
    /// it, into the slot its parent's SPE handed out.
    async fn emit(&mut self, job: &Job, node: BihNode) -> Result<(), CellError> {
        if let Some(w) = self.node_writes.as_mut() {
            w.push(job.node, node);
            return Ok(());
        }
        if self.dealt_level && !self.dealt {
            // A split of the level about to be dealt: held for later.
            self.held.push((job.node, node));
            Ok(())
        } else if self.dealt_level {
            self.arena.emit_foreign(job.node, node).await
        } else {
            self.arena.emit(job.node, node).await
        }
    }

    /// Waits until every partitioned record this SPE put back is in main
    /// memory (Fig. 1's buffers, which the batches use too).
    pub(in crate::strategy) async fn drain(&self) -> Result<(), CellError> {
        let all = (0..5).fold(0, |m, b| m | 1 << self.fig1.tag(b));
        self.spe.wait_tags(all, WaitMode::All).await.map(|_| ())
    }

    /// Makes the clip node of `job` (the empty-space cut-off) and pushes
    /// its children's jobs: a leaf of no triangles, and the job again in
    /// its cut region, one level down.
    async fn clip_node(&mut self, job: &Job, clip: Clip) -> Result<(), CellError> {
        self.stats.clip_nodes += 1;
        let children = self.arena.alloc(2).await? as usize;
        let [cl, cr] = clip.planes;
        self.emit(job, BihNode::inner(children as u32, clip.axis, cl, cr))
            .await?;
        let depth = job.depth + 1;
        let full = Job {
            node: (children + 1 - clip.empty) as u32,
            depth,
            ..*job
        }
        .in_region(clip.region);
        let empty = Job {
            first: clip.leaf_at as u32,
            count: 0,
            node: (children + clip.empty) as u32,
            depth,
            ..*job
        };
        let [a, b] = if clip.empty == 0 {
            [empty, full]
        } else {
            [full, empty]
        };
        self.queue.push(a).await?;
        self.queue.push(b).await
    }

    /// Makes the inner node of `job` and pushes its children's jobs.
    async fn split_node(
        &mut self,
        job: &Job,
        s: Split,
        cand: Aabb,
        l: &Side,
        r: &Side,
    ) -> Result<(), CellError> {
        self.stats.items_partitioned += job.count as u64;
        self.stats.partitions += 1;
        let children = self.arena.alloc(2).await? as usize;
        let [cl, cr] = clip_planes(s.axis, l, r);
        self.emit(job, BihNode::inner(children as u32, s.axis, cl, cr))
            .await?;
        let [lc, rc] = s.candidates(cand);
        let [lr, rr] = child_regions(job.region(), s.axis, [cl, cr]);
        let first = job.first as usize;
        let d = job.depth + 1;
        let left = Job::new(first, l.count, children, d, lc, l).in_region(lr);
        self.queue.push(left).await?;
        let right = Job::new(first + l.count, r.count, children + 1, d, rc, r).in_region(rr);
        self.queue.push(right).await
    }

    fn interval(&self, first: u32) -> Ea {
        self.tris
            .offset(first as u64 * size_of::<TriRecord>() as u64)
    }
}
