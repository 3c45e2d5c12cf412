//! `spe_bfs` — the paper's breadth-first construction (section 2, Fig. 2,
//! Table 1), the **baseline** of this project: one SPE builds the tree
//! level by level "almost entirely independent from the PPE", which only
//! allocates memory.
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
//!   the PPE allocates on request. Every job is one node, made in the order
//!   of node ids, so the SPE computes each node's address itself.
//!
//! The splits are the host builder's (same heuristic, same sets on each
//! side), so the tree is the host tree with its nodes numbered breadth first.

use std::cell::RefCell;
use std::rc::Rc;

use glam::Vec3;

use super::arena::{BlockSource, NodeWrites, ObjectArena, pieces, serve_blocks};
use super::fig1::{Fig1Buffers, partition_in_place, stream_bounds, stream_fold};
use super::layout::TriRecord;
use super::work_queue::{Level, WorkQueue};
use super::{Knobs, Output, Setup};
use crate::aabb::Aabb;
use crate::bih::{BihConfig, BihNode, SplitChoice};
use crate::build::cutoff::{Clip, child_regions, empty_gap};
use crate::build::host::BuildStats;
use crate::build::kernels::{Side, Split, choose_split, clip_planes, partition};
use crate::build::sah::Bins;
use crate::cell::{CellError, Ea, ListElement, LsAddr, Spe, WaitMode};

/// One job: a node to make and its interval of the triangle array. Its
/// first 64 bytes are the paper's job and all that travels, unless the
/// empty-space cut-off is on: then the node's region and its triangles' box
/// travel too, 128 bytes a job ([`Job::bytes`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Job {
    pub first: u32,
    pub count: u32,
    /// The node id this job fills.
    pub node: u32,
    pub depth: u32,
    /// The candidate box of the global heuristic.
    pub candidate: [[f32; 3]; 2],
    /// Bounds of the interval's box centers.
    pub centers: [[f32; 3]; 2],
    /// The empty-space cut-off only: the node's region (the box its
    /// ancestors' planes leave it) ...
    region: [[f32; 3]; 2],
    /// ... and the union of its triangles' boxes.
    bounds: [[f32; 3]; 2],
    pad: [u32; 4],
}
const _: () = assert!(size_of::<Job>() == 128);

/// An `Aabb` as two arrays, and back.
fn pack(b: Aabb) -> [[f32; 3]; 2] {
    [b.min.to_array(), b.max.to_array()]
}
fn unpack(b: [[f32; 3]; 2]) -> Aabb {
    Aabb::new(Vec3::from_array(b[0]), Vec3::from_array(b[1]))
}

impl Job {
    /// A job whose region is its candidate box (the root's; others get
    /// theirs with [`Job::in_region`]).
    pub(super) fn new(
        first: usize,
        count: usize,
        node: usize,
        depth: u32,
        cand: Aabb,
        side: &Side,
    ) -> Self {
        Job {
            first: first as u32,
            count: count as u32,
            node: node as u32,
            depth,
            candidate: pack(cand),
            centers: pack(side.centers()),
            region: pack(cand),
            bounds: pack(side.bounds()),
            pad: [0; 4],
        }
    }

    /// This job with the region `region`.
    fn in_region(self, region: Aabb) -> Self {
        Job {
            region: pack(region),
            ..self
        }
    }

    /// Bytes one job takes in `WorkA`/`WorkB` and main memory with `cfg`:
    /// the paper's 64, or 128 with the empty-space cut-off.
    pub(super) fn bytes(cfg: &BihConfig) -> usize {
        if cfg.empty_cut.is_some() { 128 } else { 64 }
    }

    /// Bytes `WorkAPPE` (and `WorkBPPE`) need for a subtree of
    /// `triangles` with `cfg` ([`WorkQueue::spill_bytes_for`]).
    pub(super) fn spill_bytes_for(triangles: usize, cfg: &BihConfig) -> u64 {
        WorkQueue::<Job>::spill_bytes_for(triangles, cfg.leaf_size, Job::bytes(cfg))
    }

    pub(super) fn candidate(&self) -> Aabb {
        unpack(self.candidate)
    }
    fn centers(&self) -> Aabb {
        unpack(self.centers)
    }
    fn region(&self) -> Aabb {
        unpack(self.region)
    }
    fn bounds(&self) -> Aabb {
        unpack(self.bounds)
    }
}

/// `spe_bfs`, the baseline, in the registry of builders.
pub const BUILDER: crate::build::Builder = crate::build::Builder::cell(
    "spe_bfs",
    "breadth first, the baseline: one SPE builds level by level (WorkA/WorkB, Fig. 2), small jobs agglomerated, nodes in an ObjectArena (Table 1, column 4)",
    spawn,
)
.with_quality(crate::build::Quality::ALL);

fn spawn(
    cell: &mut crate::cell::Cell,
    setup: &Setup,
    cfg: &BihConfig,
    out: Rc<RefCell<Output>>,
) -> Result<(), CellError> {
    let (tris, n, region, cfg) = (setup.triangles, setup.count, setup.region, *cfg);
    // WorkAPPE and WorkBPPE: room for the widest level the tree can have
    // (the paper sized them for as many jobs as triangles, 6.5 times more
    // with leaves of 12; see strategy/footprint.rs).
    let work_ppe_bytes = Job::spill_bytes_for(n, &cfg);
    let work_a_ppe = cell.memory_mut().alloc("WorkAPPE", work_ppe_bytes, 128)?;
    let work_b_ppe = cell.memory_mut().alloc("WorkBPPE", work_ppe_bytes, 128)?;
    let work_ppe = [work_a_ppe, work_b_ppe];
    let stats = Rc::new(RefCell::new(BuildStats::default()));
    let spe_stats = stats.clone();

    cell.spawn_spe(0, move |spe| async move {
        let paper = Knobs::PAPER;
        let mut b = SpeBuilder::new(
            &spe,
            tris,
            (work_ppe, work_ppe_bytes),
            cfg,
            BlockSource::Mailbox,
            &paper,
        )?;
        let all = b.bounds_of_all(n).await?;
        b.run(Job::new(0, n, 0, 0, region, &all)).await?;
        *spe_stats.borrow_mut() = b.stats;
        Ok(())
    });

    cell.spawn_ppe(move |ppe| async move {
        // The PPE only allocates the arena's blocks.
        let (blocks, count) = serve_blocks(&ppe, 0).await?;
        let mut o = out.borrow_mut();
        o.nodes = pieces(&blocks, count);
        o.stats = *stats.borrow();
        Ok::<(), CellError>(())
    });
    Ok(())
}

/// What a job makes: a leaf, a clip node (the empty-space cut-off: no
/// triangle moves), or an inner node that splits its interval (with the
/// candidate box the split was chosen in), its plane chosen by the global
/// heuristic from the job alone, or by binned SAH once its triangles are
/// in the local store (`Sah`).
enum Make {
    Leaf,
    Clip(Clip),
    Split(Split, Aabb),
    Sah(Aabb),
}

impl Make {
    /// A split's plane (`None`: binned SAH, not chosen yet) and candidate.
    fn split(&self) -> Option<(Option<Split>, Aabb)> {
        match *self {
            Make::Split(s, cand) => Some((Some(s), cand)),
            Make::Sah(cand) => Some((None, cand)),
            Make::Leaf | Make::Clip(_) => None,
        }
    }
}

/// A job of the current agglomerated batch and what it will make.
struct Pending {
    job: Job,
    make: Make,
}

/// An agglomerated batch: its jobs, and the runs of the triangle array it
/// moves (record ranges). One run, the span of its intervals, unless DMA
/// lists gather several.
#[derive(Default)]
struct Batch {
    jobs: Vec<Pending>,
    runs: Vec<(u32, u32)>,
}

impl Batch {
    /// Records the runs move.
    fn records(&self) -> u32 {
        self.runs.iter().map(|(f, e)| e - f).sum()
    }

    /// The smallest range holding every run.
    fn extent(&self) -> Option<(u32, u32)> {
        let first = self.runs.iter().map(|r| r.0).min()?;
        Some((first, self.runs.iter().map(|r| r.1).max()?))
    }
}

/// What a block of jobs comes to: batches, and large intervals streamed
/// through Fig. 1, in job order.
enum Step {
    Batch(Batch),
    Large(Job, Option<Split>, Aabb),
}

/// The SPE program's state: its local-store buffers and counters. The
/// multi-SPE strategies run the same loop on every SPE.
pub(super) struct SpeBuilder<'a> {
    spe: &'a Spe,
    tris: Ea,
    pub(super) cfg: BihConfig,
    pub(super) fig1: Fig1Buffers,
    /// `WorkA`/`WorkB` and their spill areas.
    pub(super) queue: WorkQueue<'a, Job>,
    pub(super) arena: ObjectArena<'a>,
    /// Jobs of this depth were dealt to this SPE: their nodes' slots belong
    /// to another arena (multi-SPE strategies).
    pub(super) foreign_depth: Option<u32>,
    /// Where the intervals of the jobs dealt to this SPE start: a batch of
    /// agglomerated jobs never spans two of them.
    pub(super) dealt_starts: Vec<u32>,
    /// A shared queue: records between two jobs this SPE took may be
    /// another SPE's, so a batch's span never crosses a gap.
    pub(super) strict_spans: bool,
    /// A shared queue: every node goes straight into its slot.
    pub(super) node_writes: Option<NodeWrites<'a>>,
    /// Batches gather non-adjacent intervals with DMA lists.
    dma_lists: bool,
    /// Binned SAH: the bins' place in the local store (filled there, then
    /// swept).
    bins: Option<LsAddr>,
    /// The next batch's get is issued before this one is partitioned.
    prefetch: bool,
    /// The other SPEs help partition intervals of at least this many
    /// triangles (multi-SPE strategies, before the deal).
    pub(super) coop: Option<(super::coop::Coop, u32)>,
    /// Which Fig. 1 buffer the next agglomerated batch uses (0 or 1; 0 to
    /// 2 when prefetching).
    batch_buf: usize,
    /// The interval each batch buffer last put back (its put may still be
    /// under way).
    batch_put: [Option<(u32, u32)>; 3],
    pub(super) stats: BuildStats,
    /// Jobs this SPE made nodes for.
    pub(super) jobs: u64,
}

impl<'a> SpeBuilder<'a> {
    pub(super) fn new(
        spe: &'a Spe,
        tris: Ea,
        (work_ppe, work_ppe_bytes): ([Ea; 2], u64),
        cfg: BihConfig,
        blocks: BlockSource,
        knobs: &Knobs,
    ) -> Result<Self, CellError> {
        Ok(SpeBuilder {
            spe,
            tris,
            cfg,
            fig1: Fig1Buffers::alloc(spe)?,
            queue: WorkQueue::new(
                spe,
                work_ppe,
                work_ppe_bytes,
                knobs.double_buffer,
                Job::bytes(&cfg),
            )?,
            arena: ObjectArena::new(spe, blocks)?,
            foreign_depth: None,
            dealt_starts: Vec::new(),
            strict_spans: false,
            node_writes: None,
            dma_lists: knobs.dma_lists,
            bins: match cfg.split {
                SplitChoice::BinnedSah { bins } => Some(spe.ls_alloc(Bins::ls_bytes(bins), 128)?),
                SplitChoice::GlobalHeuristic => None,
            },
            prefetch: knobs.prefetch,
            coop: None,
            jobs: 0,
            batch_buf: 0,
            batch_put: [None; 3],
            stats: BuildStats::default(),
        })
    }

    /// The bounds of all `n` triangle records (one streaming pass), for
    /// the root job.
    pub(super) async fn bounds_of_all(&self, n: usize) -> Result<Side, CellError> {
        let rate = self.spe.cost().kernels.spe_bounds_item;
        stream_bounds::<TriRecord>(self.spe, &self.fig1, self.tris, n as u64, rate).await
    }

    /// Builds the tree below `root`, level by level (Fig. 2).
    async fn run(&mut self, root: Job) -> Result<(), CellError> {
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
    /// first level of at least that many jobs (at most 128, so that it is
    /// still in `WorkA`) and returns it; otherwise runs to the end.
    pub(super) async fn levels(
        &mut self,
        mut level: Level,
        stop_at: Option<usize>,
    ) -> Result<Option<Level>, CellError> {
        debug_assert!(stop_at.is_none_or(|s| s <= 128));
        loop {
            for k in 0..self.queue.blocks(level) {
                let jobs = self.queue.load(level, k).await?;
                self.process(&jobs).await?;
            }
            match self.queue.end_level().await? {
                Some(Level::Local(len)) if stop_at.is_some_and(|s| len >= s) => {
                    return Ok(Some(Level::Local(len)));
                }
                Some(next) => level = next,
                None => return Ok(None),
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
        if self.foreign_depth == Some(job.depth) {
            self.arena.emit_foreign(job.node, node).await
        } else {
            self.arena.emit(job.node, node).await
        }
    }

    /// Makes the nodes of `jobs` (consecutive jobs of one level, in node-id
    /// order), agglomerating small intervals. Each batch runs as soon as
    /// it is complete, or, prefetching, once the block is planned.
    pub(super) async fn process(&mut self, jobs: &[Job]) -> Result<(), CellError> {
        if self.foreign_depth.is_some() && self.foreign_depth == jobs.first().map(|j| j.depth) {
            // The jobs dealt to this SPE (one block: at most 128).
            self.dealt_starts = jobs.iter().map(|j| j.first).collect();
        }
        let k = self.spe.cost().kernels;
        let per_block = (super::fig1::BLOCK_BYTES as usize / size_of::<TriRecord>()) as u32;
        let mut steps = Vec::new();
        let mut batch = Batch::default();
        for &job in jobs {
            self.jobs += 1;
            self.spe.compute(k.spe_job);
            let mut candidate = job.candidate();
            let (region, bounds) = (job.region(), job.bounds());
            let make = if self.cfg.ends_in_leaf(job.count as usize, job.depth) {
                Make::Leaf
            } else if let Some(cut) =
                (self.cfg.empty_cut).and_then(|p| empty_gap(&region, &bounds, p))
            {
                let (first, count) = (job.first as usize, job.count as usize);
                Make::Clip(cut.clip(region, &bounds, first, count))
            } else if let SplitChoice::BinnedSah { .. } = self.cfg.split {
                let c = job.centers();
                if c.min == c.max {
                    Make::Leaf
                } else {
                    Make::Sah(candidate)
                }
            } else {
                match choose_split(&mut candidate, &job.centers()) {
                    Some(s) => Make::Split(s, candidate),
                    None => Make::Leaf,
                }
            };
            let Some((s, cand)) = make.split() else {
                batch.jobs.push(Pending { job, make });
                continue;
            };
            if job.count > per_block {
                // A large interval: stream it through Fig. 1's buffers.
                self.step(Step::Batch(std::mem::take(&mut batch)), &mut steps)
                    .await?;
                self.step(Step::Large(job, s, cand), &mut steps).await?;
                continue;
            }
            let end = job.first + job.count;
            if self.dma_lists {
                // Any intervals, up to one block in all: adjacent ones
                // merge into one run.
                if batch.records() + job.count > per_block
                    || batch.runs.len() == crate::cell::MAX_LIST_ELEMENTS
                {
                    self.step(Step::Batch(std::mem::take(&mut batch)), &mut steps)
                        .await?;
                }
                match batch.runs.last_mut() {
                    Some(run) if run.1 == job.first => run.1 = end,
                    _ => batch.runs.push((job.first, end)),
                }
            } else {
                // One span: it grows over the leaves between, but must not
                // reach over records another SPE owns (the start of
                // another dealt interval, or any gap in a shared queue).
                let span = batch.runs.first().copied();
                let grown = span.map_or((job.first, end), |(f, _)| (f, end));
                let foreign = span.is_some_and(|(f, e)| {
                    (self.strict_spans && job.first != e)
                        || self.dealt_starts.iter().any(|&r| f < r && r <= job.first)
                });
                if grown.1 - grown.0 > per_block || foreign {
                    self.step(Step::Batch(std::mem::take(&mut batch)), &mut steps)
                        .await?;
                    batch.runs = vec![(job.first, end)];
                } else {
                    batch.runs = vec![grown];
                }
            }
            batch.jobs.push(Pending { job, make });
        }
        self.step(Step::Batch(batch), &mut steps).await?;
        self.run_prefetching(steps).await?;
        if let Some(w) = self.node_writes.as_mut() {
            w.flush().await?;
        }
        Ok(())
    }

    /// Runs `step` now, or, prefetching, keeps it for
    /// [`SpeBuilder::run_prefetching`].
    async fn step(&mut self, step: Step, later: &mut Vec<Step>) -> Result<(), CellError> {
        if self.prefetch {
            later.push(step);
            return Ok(());
        }
        match step {
            Step::Batch(mut b) => {
                let buf = self.get_batch(&b).await?;
                self.finish_batch(&mut b, buf).await
            }
            Step::Large(job, s, cand) => self.large(&job, s, cand).await,
        }
    }

    /// Runs planned steps, issuing each batch's get before the batch ahead
    /// of it is partitioned.
    async fn run_prefetching(&mut self, steps: Vec<Step>) -> Result<(), CellError> {
        let mut steps = steps.into_iter().peekable();
        let mut ready = None;
        while let Some(step) = steps.next() {
            match step {
                Step::Large(job, s, cand) => self.large(&job, s, cand).await?,
                Step::Batch(mut b) => {
                    let buf = match ready.take() {
                        Some(buf) => buf,
                        None => self.get_batch(&b).await?,
                    };
                    if let Some(Step::Batch(next)) = steps.peek() {
                        ready = Some(self.get_batch(next).await?);
                    }
                    self.finish_batch(&mut b, buf).await?;
                }
            }
        }
        Ok(())
    }

    /// Partitions a large interval: streamed through Fig. 1's buffers, or
    /// cooperatively by every SPE.
    async fn large(&mut self, job: &Job, s: Option<Split>, cand: Aabb) -> Result<(), CellError> {
        let k = self.spe.cost().kernels;
        // Fig. 1 reuses the batches' buffers: their puts finish first.
        let batches = (0..self.batch_buffers()).fold(0, |m, b| m | 1 << self.fig1.tag(b));
        self.spe.wait_tags(batches, WaitMode::All).await?;
        let (s, cand) = match s {
            Some(s) => (s, cand),
            None => {
                // Binned SAH: one more pass, through two of Fig. 1's
                // buffers, to bin the interval.
                let bins = self.new_bins(job)?;
                let at = self.interval(job.first);
                let (spe, fig1) = (self.spe, &self.fig1);
                let add = |b: &mut Bins, items: &[TriRecord]| b.add(items);
                let n = job.count as u64;
                let bins = stream_fold(spe, fig1, at, n, k.spe_bin_item, bins, add).await?;
                self.sah_choose(job, &bins, cand)
            }
        };
        if let Some((coop, min)) = self.coop.as_mut()
            && job.count >= *min
        {
            // Every SPE partitions a share of it.
            let (l, r) = coop
                .lead(
                    self.spe,
                    &self.fig1,
                    job.first,
                    job.count,
                    s,
                    k.spe_partition_item,
                )
                .await?;
            return self.split_node(job, s, cand, &l, &r).await;
        }
        let p = partition_in_place::<TriRecord>(
            self.spe,
            &self.fig1,
            self.interval(job.first),
            job.count as u64,
            s,
            k.spe_partition_item,
        )
        .await?;
        self.split_node(job, s, cand, &p.left, &p.right).await
    }

    /// Waits until every partitioned record this SPE put back is in main
    /// memory (Fig. 1's buffers, which the batches use too).
    pub(super) async fn drain(&self) -> Result<(), CellError> {
        let all = (0..5).fold(0, |m, b| m | 1 << self.fig1.tag(b));
        self.spe.wait_tags(all, WaitMode::All).await.map(|_| ())
    }

    /// Fig. 1 buffers the batches take turns in: two, three when
    /// prefetching (the next batch's get must not wait for the put of the
    /// batch before).
    fn batch_buffers(&self) -> usize {
        if self.prefetch { 3 } else { 2 }
    }

    /// Issues the get of the batch's runs (one get, or a DMA list) into the
    /// next batch buffer; returns the buffer (`None`: only leaves).
    async fn get_batch(&mut self, batch: &Batch) -> Result<Option<usize>, CellError> {
        let Some((first, end)) = batch.extent() else {
            return Ok(None);
        };
        let buf = self.batch_buf;
        self.batch_buf = (buf + 1) % self.batch_buffers();
        // The buffer's previous put must be done before it is reused; and
        // another buffer's, if it wrote records this batch reads (the MFC
        // does not order commands of different tag groups: a get could
        // overtake that put). The model runs commands in order, so this
        // wait is rare and costs only where needed.
        let tag = self.fig1.tag(buf);
        self.spe.wait_tag(tag).await?;
        for other in (0..self.batch_buffers()).filter(|&b| b != buf) {
            if let Some((f, e)) = self.batch_put[other]
                && f < end
                && first < e
            {
                self.spe.wait_tag(self.fig1.tag(other)).await?;
            }
        }
        let ls = self.fig1.buffer(buf);
        match &self.run_list(batch)[..] {
            [one] => self.spe.get(ls, one.ea, one.size, tag).await?,
            list => self.spe.getl(ls, list, tag).await?,
        }
        Ok(Some(buf))
    }

    /// The batch's runs as DMA-list elements.
    fn run_list(&self, batch: &Batch) -> Vec<ListElement> {
        let size = size_of::<TriRecord>() as u32;
        let run = |&(f, e): &(u32, u32)| ListElement {
            ea: self.interval(f),
            size: (e - f) * size,
        };
        batch.runs.iter().map(run).collect()
    }

    /// Waits for the batch's get (into `buf`), partitions its intervals,
    /// puts them back, then makes the batch's nodes in order.
    async fn finish_batch(
        &mut self,
        batch: &mut Batch,
        buf: Option<usize>,
    ) -> Result<(), CellError> {
        let size = size_of::<TriRecord>() as u32;
        let mut sides = Vec::with_capacity(batch.jobs.len());
        if let Some(buf) = buf {
            let (ls, tag) = (self.fig1.buffer(buf), self.fig1.tag(buf));
            self.spe.wait_tag(tag).await?;
            let rate = self.spe.cost().kernels.spe_partition_item;
            // Where each run starts in the local store. Runs are in job
            // order (a job extends the last run or starts one), not in
            // address order: jobs a shared queue hands out need not be.
            let mut run = 0;
            let mut run_at = 0u32;
            for p in batch.jobs.iter() {
                if let Some((s, cand)) = p.make.split() {
                    while !(batch.runs[run].0..batch.runs[run].1).contains(&p.job.first) {
                        run_at += (batch.runs[run].1 - batch.runs[run].0) * size;
                        run += 1;
                    }
                    let at = ls.offset(run_at + (p.job.first - batch.runs[run].0) * size);
                    let count = p.job.count as usize;
                    let (s, cand) = match s {
                        Some(s) => (s, cand),
                        None => {
                            // Binned SAH on the records in the local store.
                            let mut bins = self.new_bins(&p.job)?;
                            self.spe
                                .with_ls(at, count, |items: &[TriRecord]| bins.add(items))?;
                            let k = self.spe.cost().kernels;
                            self.spe.compute_items(k.spe_bin_item, count as u64);
                            self.sah_choose(&p.job, &bins, cand)
                        }
                    };
                    let (l, r) = self
                        .spe
                        .with_ls_mut(at, count, |items: &mut [TriRecord]| partition(items, s))?;
                    self.spe.compute_items(rate, count as u64);
                    sides.push((l, r, s, cand));
                }
            }
            match &self.run_list(batch)[..] {
                [one] => self.spe.put(ls, one.ea, one.size, tag).await?,
                list => self.spe.putl(ls, list, tag).await?,
            }
            self.batch_put[buf] = batch.extent();
        }
        let mut sides = sides.into_iter();
        for p in batch.jobs.drain(..) {
            match p.make {
                Make::Leaf => {
                    let leaf = BihNode::leaf(p.job.first, p.job.count);
                    self.emit(&p.job, leaf).await?;
                }
                Make::Clip(clip) => self.clip_node(&p.job, clip).await?,
                Make::Split(..) | Make::Sah(_) => {
                    let (l, r, s, cand) = sides.next().expect("one partition per split job");
                    self.split_node(&p.job, s, cand, &l, &r).await?;
                }
            }
        }
        Ok(())
    }

    /// Empty bins for `job`'s binned SAH choice (they live in the local
    /// store at `self.bins`).
    fn new_bins(&self, job: &Job) -> Result<Bins, CellError> {
        let SplitChoice::BinnedSah { bins } = self.cfg.split else {
            unreachable!("binned SAH jobs only");
        };
        debug_assert!(self.bins.is_some());
        Ok(Bins::new(&job.centers(), bins))
    }

    /// Sweeps `job`'s filled bins for the cheapest plane (charged per bin
    /// and axis); the global heuristic in `cand` where no binned plane
    /// separates in `f32`, as the host builder does.
    fn sah_choose(&mut self, job: &Job, bins: &Bins, cand: Aabb) -> (Split, Aabb) {
        let k = self.spe.cost().kernels;
        self.spe
            .compute_items(k.spe_sah_bin, 3 * bins.per_axis() as u64);
        self.stats.items_binned += job.count as u64;
        if let Some(s) = bins.choose() {
            return (s, cand);
        }
        let mut cand = cand;
        let s = choose_split(&mut cand, &job.centers()).expect("the job's centers differ");
        (s, cand)
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
