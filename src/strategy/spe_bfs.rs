//! `spe_bfs` — the paper's breadth-first construction (section 2, Fig. 2,
//! Table 1), the **baseline** of this project: one SPE builds the tree
//! level by level "almost entirely independent from the PPE", which only
//! allocates memory.
//!
//! - **Jobs** (the intervals of the next tree level, 64 bytes each, [`Job`])
//!   live in two local-store buffers, `WorkA` (the current level) and
//!   `WorkB` (the next). A full `WorkB` is written to main memory
//!   (`WorkBPPE`), synchronously as in the paper; when a level spilled,
//!   the next one reads its jobs back block by block, and `WorkAPPE` and
//!   `WorkBPPE` swap roles (the two phases of Fig. 2). While a whole level
//!   fits in `WorkB` — the first levels — nothing travels: the local-store
//!   buffers swap.
//! - **Partitions**: an interval over 16 KiB streams through the five
//!   buffers of Fig. 1; smaller ones are **agglomerated**: consecutive jobs
//!   whose intervals span at most 16 KiB of the triangle array travel in one
//!   get and one put.
//! - **Nodes** go into an **ObjectArena**: blocks of [`BLOCK_NODES`] nodes
//!   that the PPE allocates on request (outbound mailbox; the block's
//!   address comes back in the inbound mailbox, asked for one block ahead).
//!   Every job is one node, made in the order of node ids, so the SPE
//!   computes each node's address itself (block `id / BLOCK_NODES`, offset
//!   `id % BLOCK_NODES`) and writes the nodes in 16 KiB puts.
//!
//! The splits are the host builder's (same heuristic, same sets on each
//! side), so the tree is the host tree with its nodes numbered breadth first.

use std::cell::RefCell;
use std::rc::Rc;

use glam::Vec3;

use super::fig1::{Fig1Buffers, partition_in_place, stream_bounds};
use super::layout::TriRecord;
use super::{Output, Setup};
use crate::aabb::Aabb;
use crate::bih::{BihConfig, BihNode};
use crate::build::host::BuildStats;
use crate::build::kernels::{Side, Split, choose_split, clip_planes, partition};
use crate::cell::{CellError, Cycles, Ea, LsAddr, Spe, WaitMode};

/// Outbound-mailbox words from the SPE to the PPE.
const REQUEST_BLOCK: u32 = 1;
const DONE: u32 = 2;

/// Jobs per `WorkA`/`WorkB` buffer: 16 KiB of 64-byte jobs.
const JOBS_PER_BUFFER: usize = 256;
const WORK_BYTES: u32 = (JOBS_PER_BUFFER * size_of::<Job>()) as u32;
/// Nodes per local-store node buffer: 16,320 bytes, a multiple of 48 so
/// that every put is a multiple of 16 bytes.
const NODES_PER_PUT: usize = 1360;
/// Nodes per ObjectArena block: three puts (48,960 bytes).
pub const BLOCK_NODES: usize = 3 * NODES_PER_PUT;
/// Tags: Fig. 1 uses 0–4 (buffer `i` on tag `i`); jobs and nodes use these.
const WORK_TAG: u32 = 10;
const NODE_TAG: u32 = 11;

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
    fn new(first: usize, count: usize, node: usize, depth: u32, cand: Aabb, side: &Side) -> Self {
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

pub(super) fn spawn(
    cell: &mut crate::cell::Cell,
    setup: &Setup,
    cfg: &BihConfig,
    out: Rc<RefCell<Output>>,
) -> Result<(), CellError> {
    let (tris, n, region, cfg) = (setup.triangles, setup.count, setup.region, *cfg);
    // WorkAPPE and WorkBPPE: room for as many jobs as triangles, the upper
    // bound of the jobs of one level.
    let work_ppe_bytes = (n.div_ceil(JOBS_PER_BUFFER) * WORK_BYTES as usize) as u64;
    let work_a_ppe = cell.memory_mut().alloc("WorkAPPE", work_ppe_bytes, 128)?;
    let work_b_ppe = cell.memory_mut().alloc("WorkBPPE", work_ppe_bytes, 128)?;
    let work_ppe = [work_a_ppe, work_b_ppe];
    let stats = Rc::new(RefCell::new(BuildStats::default()));
    let spe_stats = stats.clone();

    cell.spawn_spe(0, move |spe| async move {
        let mut b = SpeBuilder::new(&spe, tris, work_ppe, cfg)?;
        let all = stream_bounds::<TriRecord>(
            &spe,
            &b.fig1,
            tris,
            n as u64,
            spe.cost().kernels.spe_bounds_item,
        )
        .await?;
        b.run(Job::new(0, n, 0, 0, region, &all)).await?;
        *spe_stats.borrow_mut() = b.stats;
        Ok(())
    });

    cell.spawn_ppe(move |ppe| async move {
        // The PPE only allocates the arena's blocks.
        let mut blocks = Vec::new();
        let count = loop {
            match ppe.read_out_mbox(0).await? {
                REQUEST_BLOCK => {
                    let ea = ppe
                        .alloc(
                            "ObjectArena block",
                            (BLOCK_NODES * size_of::<BihNode>()) as u64,
                            128,
                        )
                        .await?;
                    blocks.push(ea);
                    ppe.write_in_mbox(0, ea_word(ea)?).await?;
                }
                DONE => break ppe.read_out_mbox(0).await? as usize,
                w => {
                    return Err(CellError::Program {
                        core: "PPE".into(),
                        msg: format!("spe_bfs: unknown request {w} from SPE 0"),
                    });
                }
            }
        };
        let mut o = out.borrow_mut();
        o.nodes = blocks
            .iter()
            .enumerate()
            .map(|(i, &ea)| (ea, BLOCK_NODES.min(count.saturating_sub(i * BLOCK_NODES))))
            .filter(|&(_, c)| c > 0)
            .collect();
        o.stats = *stats.borrow();
        Ok::<(), CellError>(())
    });
    Ok(())
}

/// An effective address as one 32-bit mailbox word.
fn ea_word(ea: Ea) -> Result<u32, CellError> {
    u32::try_from(ea.0).map_err(|_| CellError::Program {
        core: "PPE".into(),
        msg: format!("address {:#x} does not fit a mailbox word", ea.0),
    })
}

/// Where the jobs of the level being built are.
enum Level {
    /// All in `WorkA` in the local store.
    Local(usize),
    /// In `WorkAPPE`, this many.
    InMemory(usize),
}

/// A job of the current agglomerated batch and the split it will get.
struct Pending {
    job: Job,
    split: Option<(Split, Aabb)>,
}

/// The SPE program's state: its local-store buffers and counters.
struct SpeBuilder<'a> {
    spe: &'a Spe,
    tris: Ea,
    cfg: BihConfig,
    fig1: Fig1Buffers,
    /// `WorkA` is `work[a]`, `WorkB` is `work[1 - a]`.
    work: [LsAddr; 2],
    a: usize,
    /// `WorkAPPE` is `work_ppe[a_ppe]`, `WorkBPPE` the other.
    work_ppe: [Ea; 2],
    a_ppe: usize,
    /// Jobs in `WorkB` now, and blocks of it written to `WorkBPPE` this level.
    b_len: usize,
    b_spilled: usize,
    /// The next node id to hand out.
    next_id: usize,
    /// Node buffers (two, alternating), the nodes in the current one, and the
    /// id of its first node.
    node_bufs: [LsAddr; 2],
    node_buf: usize,
    nodes: Vec<BihNode>,
    nodes_first: usize,
    /// Arena blocks: the one being filled and the one asked for ahead.
    block: Option<Ea>,
    block_index: usize,
    next_block_requested: bool,
    /// Which Fig. 1 buffer the next agglomerated batch uses (0 or 1).
    batch_buf: usize,
    stats: BuildStats,
}

impl<'a> SpeBuilder<'a> {
    fn new(spe: &'a Spe, tris: Ea, work_ppe: [Ea; 2], cfg: BihConfig) -> Result<Self, CellError> {
        Ok(SpeBuilder {
            spe,
            tris,
            cfg,
            fig1: Fig1Buffers::alloc(spe)?,
            work: [
                spe.ls_alloc(WORK_BYTES, 128)?,
                spe.ls_alloc(WORK_BYTES, 128)?,
            ],
            a: 0,
            work_ppe,
            a_ppe: 0,
            b_len: 0,
            b_spilled: 0,
            next_id: 1,
            node_bufs: [
                spe.ls_alloc((NODES_PER_PUT * size_of::<BihNode>()) as u32, 128)?,
                spe.ls_alloc((NODES_PER_PUT * size_of::<BihNode>()) as u32, 128)?,
            ],
            node_buf: 0,
            nodes: Vec::with_capacity(NODES_PER_PUT),
            nodes_first: 0,
            block: None,
            block_index: 0,
            next_block_requested: false,
            batch_buf: 0,
            stats: BuildStats::default(),
        })
    }

    /// Builds the tree below `root`, level by level (Fig. 2).
    async fn run(&mut self, root: Job) -> Result<(), CellError> {
        // Ask for the first arena block before anything else.
        self.spe.write_out_mbox(REQUEST_BLOCK).await;
        self.next_block_requested = true;
        self.spe.ls_write(self.work[self.a], &[root])?;
        let mut level = Level::Local(1);
        loop {
            match level {
                Level::Local(len) => {
                    let jobs: Vec<Job> = self.spe.ls_read(self.work[self.a], len)?;
                    self.process(&jobs).await?;
                }
                Level::InMemory(total) => {
                    for k in 0..total.div_ceil(JOBS_PER_BUFFER) {
                        let len = JOBS_PER_BUFFER.min(total - k * JOBS_PER_BUFFER);
                        let from =
                            self.work_ppe[self.a_ppe].offset((k * WORK_BYTES as usize) as u64);
                        let bytes = (len * size_of::<Job>()) as u32;
                        self.spe
                            .get(self.work[self.a], from, bytes, WORK_TAG)
                            .await?;
                        self.spe.wait_tag(WORK_TAG).await?;
                        let jobs: Vec<Job> = self.spe.ls_read(self.work[self.a], len)?;
                        self.process(&jobs).await?;
                    }
                }
            }
            // The level is done: the next one is what WorkB collected.
            let next = self.b_spilled * JOBS_PER_BUFFER + self.b_len;
            if next == 0 {
                break;
            }
            level = if self.b_spilled == 0 {
                // The first levels: the jobs stay in the local store.
                Level::Local(next)
            } else {
                if self.b_len > 0 {
                    self.spill_work_b().await?;
                }
                self.a_ppe = 1 - self.a_ppe;
                Level::InMemory(next)
            };
            self.a = 1 - self.a;
            self.b_len = 0;
            self.b_spilled = 0;
        }
        self.flush_nodes(true).await?;
        let both = (1 << NODE_TAG) | (1 << (NODE_TAG + 1));
        self.spe.wait_tags(both, WaitMode::All).await?;
        self.spe.write_out_mbox(DONE).await;
        self.spe.write_out_mbox(self.next_id as u32).await;
        self.stats.nodes = self.next_id as u64;
        Ok(())
    }

    /// Makes the nodes of `jobs` (consecutive jobs of one level, in node-id
    /// order), agglomerating small intervals.
    async fn process(&mut self, jobs: &[Job]) -> Result<(), CellError> {
        let k = self.spe.cost().kernels;
        let per_block = (super::fig1::BLOCK_BYTES as usize / size_of::<TriRecord>()) as u32;
        let mut batch: Vec<Pending> = Vec::new();
        // The span of the batch's intervals that need partitioning.
        let mut span: Option<(u32, u32)> = None;
        for &job in jobs {
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
                self.spe.wait_tags(0b11, WaitMode::All).await?;
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
            if grown.1 - grown.0 > per_block {
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
            // The buffer's previous put must be done before it is reused.
            self.spe.wait_tag(buf as u32).await?;
            self.spe.get(ls, ea, bytes, buf as u32).await?;
            self.spe.wait_tag(buf as u32).await?;
            let rate = self.spe.cost().kernels.spe_partition_item;
            for p in batch.iter() {
                if let Some((s, _)) = p.split {
                    let at = ls.offset((p.job.first - first) * size);
                    let lr = self.spe.with_ls_mut(
                        at,
                        p.job.count as usize,
                        |items: &mut [TriRecord]| partition(items, s),
                    )?;
                    self.spe.compute(Cycles(rate.0 * p.job.count as u64));
                    sides.push(lr);
                }
            }
            self.spe.put(ls, ea, bytes, buf as u32).await?;
        }
        let mut sides = sides.into_iter();
        for p in batch.drain(..) {
            match p.split {
                None => {
                    let leaf = BihNode::leaf(p.job.first, p.job.count);
                    self.emit(p.job.node, leaf).await?;
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
        let children = self.next_id;
        self.next_id += 2;
        let [cl, cr] = clip_planes(s.axis, l, r);
        self.emit(job.node, BihNode::inner(children as u32, s.axis, cl, cr))
            .await?;
        let [lc, rc] = s.candidates(cand);
        let first = job.first as usize;
        let d = job.depth + 1;
        self.push_job(Job::new(first, l.count, children, d, lc, l))
            .await?;
        self.push_job(Job::new(first + l.count, r.count, children + 1, d, rc, r))
            .await
    }

    /// Appends a job to `WorkB`, writing `WorkB` to `WorkBPPE` when full.
    async fn push_job(&mut self, job: Job) -> Result<(), CellError> {
        let at = self.work[1 - self.a].offset((self.b_len * size_of::<Job>()) as u32);
        self.spe.ls_write(at, &[job])?;
        self.b_len += 1;
        if self.b_len == JOBS_PER_BUFFER {
            self.spill_work_b().await?;
        }
        Ok(())
    }

    /// Writes `WorkB` to the next block of `WorkBPPE` and waits (the paper's
    /// write-back is synchronous).
    async fn spill_work_b(&mut self) -> Result<(), CellError> {
        let to =
            self.work_ppe[1 - self.a_ppe].offset((self.b_spilled * WORK_BYTES as usize) as u64);
        let bytes = (self.b_len * size_of::<Job>()) as u32;
        self.spe
            .put(self.work[1 - self.a], to, bytes, WORK_TAG)
            .await?;
        self.spe.wait_tag(WORK_TAG).await?;
        self.b_spilled += 1;
        self.b_len = 0;
        Ok(())
    }

    /// Records node `id`; nodes come in id order.
    async fn emit(&mut self, id: u32, node: BihNode) -> Result<(), CellError> {
        debug_assert_eq!(id as usize, self.nodes_first + self.nodes.len());
        self.nodes.push(node);
        if self.nodes.len() == NODES_PER_PUT {
            self.flush_nodes(false).await?;
        }
        Ok(())
    }

    /// Puts the node buffer into its arena block (padded to whole 48-byte
    /// groups at the end), switching buffers.
    async fn flush_nodes(&mut self, last: bool) -> Result<(), CellError> {
        if self.nodes.is_empty() {
            return Ok(());
        }
        let block_index = self.nodes_first / BLOCK_NODES;
        if self.block.is_none() || self.block_index != block_index {
            // The block asked for ahead arrives; ask for the one after it.
            let ea = self.spe.read_in_mbox().await;
            self.block = Some(Ea(ea as u64));
            self.block_index = block_index;
            if !last {
                self.spe.write_out_mbox(REQUEST_BLOCK).await;
            }
        }
        let ls = self.node_bufs[self.node_buf];
        // The put from this buffer two flushes ago is done before refilling.
        self.spe.wait_tag(NODE_TAG + self.node_buf as u32).await?;
        let mut group = std::mem::take(&mut self.nodes);
        group.resize(group.len().next_multiple_of(4), BihNode::default());
        self.spe.ls_write(ls, &group)?;
        let offset = (self.nodes_first % BLOCK_NODES) * size_of::<BihNode>();
        let ea = self.block.expect("a block").offset(offset as u64);
        let bytes = (group.len() * size_of::<BihNode>()) as u32;
        self.spe
            .put(ls, ea, bytes, NODE_TAG + self.node_buf as u32)
            .await?;
        self.nodes_first += NODES_PER_PUT;
        self.node_buf = 1 - self.node_buf;
        Ok(())
    }

    fn interval(&self, first: u32) -> Ea {
        self.tris
            .offset(first as u64 * size_of::<TriRecord>() as u64)
    }
}
