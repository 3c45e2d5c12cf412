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

use super::arena::{BlockSource, ObjectArena, pieces, serve_blocks};
use super::fig1::{Fig1Buffers, partition_in_place, stream_bounds};
use super::layout::TriRecord;
use super::work_queue::{Level, WorkQueue};
use super::{Output, Setup};
use crate::aabb::Aabb;
use crate::bih::{BihConfig, BihNode};
use crate::build::host::BuildStats;
use crate::build::kernels::{Side, Split, choose_split, clip_planes, partition};
use crate::cell::{CellError, Ea, Spe, WaitMode};

/// One job: a node to make and its interval of the triangle array. 64 bytes.
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
}
const _: () = assert!(size_of::<Job>() == 64);

impl Job {
    pub(super) fn new(
        first: usize,
        count: usize,
        node: usize,
        depth: u32,
        cand: Aabb,
        side: &Side,
    ) -> Self {
        let c = side.centers();
        Job {
            first: first as u32,
            count: count as u32,
            node: node as u32,
            depth,
            candidate: [cand.min.to_array(), cand.max.to_array()],
            centers: [c.min.to_array(), c.max.to_array()],
        }
    }
    fn candidate(&self) -> Aabb {
        Aabb::new(
            Vec3::from_array(self.candidate[0]),
            Vec3::from_array(self.candidate[1]),
        )
    }
    fn centers(&self) -> Aabb {
        Aabb::new(
            Vec3::from_array(self.centers[0]),
            Vec3::from_array(self.centers[1]),
        )
    }
}

/// `spe_bfs`, the baseline, in the registry of builders.
pub const BUILDER: crate::build::Builder = crate::build::Builder::cell(
    "spe_bfs",
    "breadth first, the baseline: one SPE builds level by level (WorkA/WorkB, Fig. 2), small jobs agglomerated, nodes in an ObjectArena (Table 1, column 4)",
    spawn,
);

fn spawn(
    cell: &mut crate::cell::Cell,
    setup: &Setup,
    cfg: &BihConfig,
    out: Rc<RefCell<Output>>,
) -> Result<(), CellError> {
    let (tris, n, region, cfg) = (setup.triangles, setup.count, setup.region, *cfg);
    // WorkAPPE and WorkBPPE: room for as many jobs as triangles, the upper
    // bound of the jobs of one level.
    let work_ppe_bytes = WorkQueue::<Job>::spill_bytes(n);
    let work_a_ppe = cell.memory_mut().alloc("WorkAPPE", work_ppe_bytes, 128)?;
    let work_b_ppe = cell.memory_mut().alloc("WorkBPPE", work_ppe_bytes, 128)?;
    let work_ppe = [work_a_ppe, work_b_ppe];
    let stats = Rc::new(RefCell::new(BuildStats::default()));
    let spe_stats = stats.clone();

    cell.spawn_spe(0, move |spe| async move {
        let mut b = SpeBuilder::new(&spe, tris, work_ppe, cfg, BlockSource::Mailbox)?;
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

/// A job of the current agglomerated batch and the split it will get.
struct Pending {
    job: Job,
    split: Option<(Split, Aabb)>,
}

/// The SPE program's state: its local-store buffers and counters. The
/// multi-SPE strategies run the same loop on every SPE.
pub(super) struct SpeBuilder<'a> {
    spe: &'a Spe,
    tris: Ea,
    cfg: BihConfig,
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
    /// The other SPEs help partition intervals of at least this many
    /// triangles (multi-SPE strategies, before the deal).
    pub(super) coop: Option<(super::coop::Coop, u32)>,
    /// Which Fig. 1 buffer the next agglomerated batch uses (0 or 1).
    batch_buf: usize,
    /// The interval each batch buffer last put back (its put may still be
    /// under way).
    batch_put: [Option<(u32, u32)>; 2],
    pub(super) stats: BuildStats,
    /// Jobs this SPE made nodes for.
    pub(super) jobs: u64,
}

impl<'a> SpeBuilder<'a> {
    pub(super) fn new(
        spe: &'a Spe,
        tris: Ea,
        work_ppe: [Ea; 2],
        cfg: BihConfig,
        blocks: BlockSource,
    ) -> Result<Self, CellError> {
        Ok(SpeBuilder {
            spe,
            tris,
            cfg,
            fig1: Fig1Buffers::alloc(spe)?,
            queue: WorkQueue::new(spe, work_ppe)?,
            arena: ObjectArena::new(spe, blocks)?,
            foreign_depth: None,
            dealt_starts: Vec::new(),
            coop: None,
            jobs: 0,
            batch_buf: 0,
            batch_put: [None, None],
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
            for k in 0..WorkQueue::<Job>::blocks(level) {
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
        if self.foreign_depth == Some(job.depth) {
            self.arena.emit_foreign(job.node, node).await
        } else {
            self.arena.emit(job.node, node).await
        }
    }

    /// Makes the nodes of `jobs` (consecutive jobs of one level, in node-id
    /// order), agglomerating small intervals.
    async fn process(&mut self, jobs: &[Job]) -> Result<(), CellError> {
        if self.foreign_depth.is_some() && self.foreign_depth == jobs.first().map(|j| j.depth) {
            // The jobs dealt to this SPE (one block: at most 128).
            self.dealt_starts = jobs.iter().map(|j| j.first).collect();
        }
        let k = self.spe.cost().kernels;
        let per_block = (super::fig1::BLOCK_BYTES as usize / size_of::<TriRecord>()) as u32;
        let mut batch: Vec<Pending> = Vec::new();
        // The span of the batch's intervals that need partitioning.
        let mut span: Option<(u32, u32)> = None;
        for &job in jobs {
            self.jobs += 1;
            self.spe.compute(k.spe_job);
            let mut candidate = job.candidate();
            let split = if job.count <= self.cfg.leaf_size || job.depth >= self.cfg.max_depth {
                None
            } else {
                choose_split(&mut candidate, &job.centers()).map(|s| (s, candidate))
            };
            let Some((s, cand)) = split else {
                batch.push(Pending { job, split: None });
                continue;
            };
            if job.count > per_block {
                // A large interval: stream it through Fig. 1's buffers.
                self.flush_batch(&mut batch, &mut span).await?;
                // Fig. 1 reuses the batches' buffers: their puts finish first.
                let batches = (1 << self.fig1.tag(0)) | (1 << self.fig1.tag(1));
                self.spe.wait_tags(batches, WaitMode::All).await?;
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
                    self.split_node(&job, s, cand, &l, &r).await?;
                    continue;
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
                self.split_node(&job, s, cand, &p.left, &p.right).await?;
                continue;
            }
            let end = job.first + job.count;
            let grown = span.map_or((job.first, end), |(f, _)| (f, end));
            // A batch's get and put cover its whole span: it must not reach
            // over records another SPE owns (the start of another dealt
            // interval lies between).
            let foreign = span
                .is_some_and(|(f, _)| self.dealt_starts.iter().any(|&r| f < r && r <= job.first));
            if grown.1 - grown.0 > per_block || foreign {
                self.flush_batch(&mut batch, &mut span).await?;
                span = Some((job.first, end));
            } else {
                span = Some(grown);
            }
            batch.push(Pending {
                job,
                split: Some((s, cand)),
            });
        }
        self.flush_batch(&mut batch, &mut span).await
    }

    /// Partitions the batch's intervals with one get and one put of their
    /// span, then makes the batch's nodes in order.
    async fn flush_batch(
        &mut self,
        batch: &mut Vec<Pending>,
        span: &mut Option<(u32, u32)>,
    ) -> Result<(), CellError> {
        let size = size_of::<TriRecord>() as u32;
        let mut sides = Vec::with_capacity(batch.len());
        if let Some((first, end)) = span.take() {
            let buf = self.batch_buf;
            self.batch_buf = 1 - buf;
            let ls = self.fig1.buffer(buf);
            let (ea, bytes) = (self.interval(first), (end - first) * size);
            // The buffer's previous put must be done before it is reused;
            // and the other buffer's, if it wrote records this batch reads
            // (the MFC does not order commands of different tag groups: a
            // get could overtake that put). The model runs commands in
            // order, so this wait is rare and costs only where needed.
            let tag = self.fig1.tag(buf);
            self.spe.wait_tag(tag).await?;
            if let Some((f, e)) = self.batch_put[1 - buf]
                && f < end
                && first < e
            {
                self.spe.wait_tag(self.fig1.tag(1 - buf)).await?;
            }
            self.spe.get(ls, ea, bytes, tag).await?;
            self.spe.wait_tag(tag).await?;
            let rate = self.spe.cost().kernels.spe_partition_item;
            for p in batch.iter() {
                if let Some((s, _)) = p.split {
                    let at = ls.offset((p.job.first - first) * size);
                    let lr = self.spe.with_ls_mut(
                        at,
                        p.job.count as usize,
                        |items: &mut [TriRecord]| partition(items, s),
                    )?;
                    self.spe.compute_items(rate, p.job.count as u64);
                    sides.push(lr);
                }
            }
            self.spe.put(ls, ea, bytes, tag).await?;
            self.batch_put[buf] = Some((first, end));
        }
        let mut sides = sides.into_iter();
        for p in batch.drain(..) {
            match p.split {
                None => {
                    let leaf = BihNode::leaf(p.job.first, p.job.count);
                    self.emit(&p.job, leaf).await?;
                }
                Some((s, cand)) => {
                    let (l, r) = sides.next().expect("one partition per split job");
                    self.split_node(&p.job, s, cand, &l, &r).await?;
                }
            }
        }
        Ok(())
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
        let first = job.first as usize;
        let d = job.depth + 1;
        self.queue
            .push(Job::new(first, l.count, children, d, lc, l))
            .await?;
        self.queue
            .push(Job::new(first + l.count, r.count, children + 1, d, rc, r))
            .await
    }

    fn interval(&self, first: u32) -> Ea {
        self.tris
            .offset(first as u64 * size_of::<TriRecord>() as u64)
    }
}
