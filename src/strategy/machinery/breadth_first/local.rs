//! `--finish local`: the breadth-first loop (section 2, Fig. 2) finishing
//! each job whose records and subtree fit the local store as an
//! independent subtree — section 5's "regions of primitives that then
//! could be built-up totally independent", reached level by level rather
//! than by Morton codes.
//!
//! Such a job is gathered with one DMA list into Fig. 1's five buffers
//! (80 KiB, free between partitions), its whole subtree is built depth
//! first in the local store with the very decisions a level-by-level
//! build makes ([`crate::kernels::recursion::build_below`]: the same
//! leaves, clip nodes and splits, the same partition), its nodes are given
//! ids as one run of this SPE's ObjectArena ([`ObjectArena::alloc_run`])
//! and put back in one DMA, and its records in one DMA list. Larger jobs
//! go on level by level, every level's records through DMA (`stream`, the
//! paper's way).
//!
//! Charged as the loop charges the same work: each node made the loop's
//! per-job rate, each record partitioned (or binned) the partition's (or
//! binning's) rate per item, each bin sweep its rate per bin; the DMA as
//! it moves.
//!
//! [`ObjectArena::alloc_run`]: crate::strategy::machinery::arena::ObjectArena::alloc_run

use super::{Job, SpeBuilder};
use crate::bih::{BihConfig, BihNode};
use crate::cell::{CellError, Ea, ListElement, LsAddr, MAX_TRANSFER, WaitMode};
use crate::kernels::decide::NodeView;
use crate::kernels::recursion::build_below;
use crate::spe::fig1::BLOCK_BYTES;
use crate::spe::layout::TriRecord;
use crate::strategy::knob::{Knob, Knobs};
use crate::strategy::machinery::arena::BLOCK_NODES;
use crate::strategy::program::Phase;

/// `--finish`: how a job ends once it fits the local store.
pub const FINISH: Knob = Knob::word(
    "finish",
    "a job whose records and subtree fit the SPE's free local store: built level by level as the larger ones, every level's records through DMA (stream, the paper's way), or gathered once, its whole subtree built in the local store, its records and nodes put back once (local); auto: local",
    &["auto", "stream", "local"],
    &["stream"],
);

/// How a job that fits the local store ends (`--finish`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::strategy) enum Finish {
    /// Level by level, like every larger job.
    Stream,
    /// Built as a subtree in the local store.
    Local,
}

impl Finish {
    /// The finish `knobs` give (`auto`: `default`).
    pub fn read(knobs: &Knobs, default: Finish) -> Self {
        match knobs.word(&FINISH) {
            "stream" => Finish::Stream,
            "local" => Finish::Local,
            _ => default,
        }
    }
}

/// Bytes of the local store a subtree's nodes take, 12 a node.
const NODE: usize = size_of::<BihNode>();

/// The most nodes a subtree of `count` triangles can have with `cfg`: a
/// split leaves triangles on both sides, so at most `2 count − 1` leaves
/// and splits; with the empty-space cut-off, a node is clipped at most
/// six times before it splits or ends (a clip moves its region's face
/// onto its triangles' box), each clip two nodes more.
pub(in crate::strategy) fn most_nodes(count: usize, cfg: &BihConfig) -> usize {
    let tree = (2 * count).saturating_sub(1).max(1);
    match cfg.empty_cut {
        Some(_) => tree * 13,
        None => tree,
    }
}

/// Where a job finished in the local store lives: its records in Fig. 1's
/// five buffers (one contiguous run of them), its nodes in the local store
/// the SPE program left free.
pub(in crate::strategy) struct LocalArea {
    records: LsAddr,
    /// Records the area holds.
    capacity: usize,
    nodes: LsAddr,
    /// Nodes the node area holds.
    node_capacity: usize,
    /// The records' and the nodes' DMA.
    tag: u32,
    /// The records' put is under way (Fig. 1's buffers wait for it).
    put: bool,
}

impl LocalArea {
    /// The largest job `cfg` lets this area finish: its records fit Fig.
    /// 1's buffers, its most nodes the node area and one arena block.
    pub(in crate::strategy) fn largest(&self, cfg: &BihConfig) -> usize {
        largest_fitting(self.capacity, self.node_capacity, cfg)
    }
}

/// The largest job of at most `records` triangles whose most nodes fit
/// `nodes` and one arena block.
fn largest_fitting(records: usize, nodes: usize, cfg: &BihConfig) -> usize {
    let mut c = records;
    while c > 0 && most_nodes(c, cfg) > nodes.min(BLOCK_NODES) {
        c -= 1;
    }
    c
}

/// The local store the breadth-first programs leave for a subtree's
/// nodes, as a forecast made before the build assumes it
/// (`machinery::forecast`): what both leave with their default knobs,
/// 48,256 bytes (46,720 with the binned SAH's bins, 30,848 with a 16 KiB
/// job cache: there the forecast assumes a little larger subtrees than the
/// build finishes locally).
const NODE_AREA_FORECAST: usize = 48 * 1024;

/// The largest job a build with `cfg` finishes in the local store, as
/// predicted before the build: Fig. 1's five buffers of records and
/// [`NODE_AREA_FORECAST`] of nodes.
pub(in crate::strategy) fn largest_local(cfg: &BihConfig) -> usize {
    let records = 5 * BLOCK_BYTES as usize / size_of::<TriRecord>();
    largest_fitting(records, NODE_AREA_FORECAST / NODE, cfg)
}

impl<'a> SpeBuilder<'a> {
    /// From now on, every job of at most [`LocalArea::largest`] triangles
    /// is finished in the local store: its records in Fig. 1's buffers, its
    /// nodes in every byte of the local store still free. Called once the
    /// SPE program holds all else it needs.
    pub(in crate::strategy) fn finish_locally(&mut self) -> Result<(), CellError> {
        let bufs = (0..5).map(|b| self.fig1.buffer(b).0).collect::<Vec<_>>();
        let contiguous = bufs.windows(2).all(|w| w[1] == w[0] + BLOCK_BYTES);
        debug_assert!(contiguous, "Fig. 1's buffers are allocated together");
        let records_bytes = if contiguous { 5 } else { 1 } * BLOCK_BYTES as usize;
        let free = (self.spe.ls_free_bytes() as usize) & !127;
        let nodes = self.spe.ls_alloc(free as u32, 128)?;
        let area = LocalArea {
            records: self.fig1.buffer(0),
            capacity: records_bytes / size_of::<TriRecord>(),
            nodes,
            node_capacity: free / NODE,
            tag: self.spe.tag("subtrees finished in the local store")?,
            put: false,
        };
        self.local_largest = area.largest(&self.cfg) as u32;
        self.local = Some(area);
        Ok(())
    }

    /// From now on no job of more than `most` triangles is finished in
    /// the local store (a shared queue: none larger than an SPE's share).
    pub(in crate::strategy) fn finish_at_most(&mut self, most: usize) {
        self.local_largest = self.local_largest.min(most.min(u32::MAX as usize) as u32);
    }

    /// Jobs finished in the local store, and the most triangles one could
    /// have.
    pub(in crate::strategy) fn subtrees(&self) -> (u64, u64) {
        (self.local_jobs, self.local_largest as u64)
    }

    /// Whether `job` is finished in the local store: it fits, and is not
    /// a leaf (a leaf moves no record).
    pub(in crate::strategy) fn finishes_locally(&self, job: &Job) -> bool {
        self.local.is_some()
            && job.count <= self.local_largest
            && !self.cfg.ends_in_leaf(job.count as usize, job.depth)
            && !self.helped(job.count)
    }

    /// Waits for the put of the last job finished in the local store,
    /// before Fig. 1's buffers are used again.
    pub(in crate::strategy) async fn settle_local(&mut self) -> Result<(), CellError> {
        if let Some(area) = self.local.as_mut().filter(|a| a.put) {
            area.put = false;
            self.spe.wait_tag(area.tag).await?;
        }
        Ok(())
    }

    /// Finishes `job` in the local store: one gather of its records, its
    /// subtree built there, its nodes put as one run of the arena and its
    /// records put back; its own node written as the loop writes a job's.
    pub(super) async fn finish_local(&mut self, job: &Job) -> Result<(), CellError> {
        let from = Phase::mark(self.spe);
        // Fig. 1's buffers (the batches') and the last subtree's node put
        // are done before their bytes are reused.
        let all = (0..5).fold(0, |m, b| m | 1 << self.fig1.tag(b));
        self.spe.wait_tags(all, WaitMode::All).await?;
        self.settle_local().await?;
        let area = self.local.as_ref().expect("finish_locally first");
        let (ls, tag, count) = (area.records, area.tag, job.count as usize);
        let list = self.record_list(job.first, job.count);
        self.spe.getl(ls, &list, tag).await?;
        self.spe.wait_tag(tag).await?;
        let view = NodeView {
            first: job.first as usize,
            count,
            depth: job.depth,
            region: job.region(),
            bounds: job.bounds(),
            centers: job.centers(),
            candidate: job.candidate(),
        };
        let cfg = self.cfg;
        let mut nodes = std::mem::take(&mut self.subtree);
        let stats = self.spe.with_ls_mut(ls, count, |items: &mut [TriRecord]| {
            build_below(items, &mut nodes, &view, &cfg)
        })?;
        // The job's own node was charged as the loop took it.
        let k = self.rates;
        self.spe.compute_items(k.spe_job, nodes.len() as u64 - 1);
        self.spe
            .compute_items(k.spe_partition_item, stats.items_partitioned);
        self.spe.compute_items(k.spe_bin_item, stats.items_binned);
        if let Some(bins) = cfg.sah_bins(usize::MAX) {
            let sweeps = stats.sah_sweeps * 3 * bins as u64;
            self.spe.compute_items(k.spe_sah_bin, sweeps);
        }
        self.jobs += nodes.len() as u64 - 1;
        self.local_jobs += 1;
        self.stats.add(&stats);
        self.spe.putl(ls, &list, tag).await?;
        self.local.as_mut().expect("open").put = true;
        self.write_subtree(job, &nodes).await?;
        self.subtree = nodes;
        self.in_subtrees += Phase::since(self.spe, &from);
        Ok(())
    }

    /// Writes the nodes of a subtree built in the local store: its
    /// descendants (local pairs (1, 2), (3, 4), …) as one run of the
    /// arena, in one DMA; the job's own node as the loop writes it.
    async fn write_subtree(&mut self, job: &Job, nodes: &[BihNode]) -> Result<(), CellError> {
        let area = self.local.as_ref().expect("open");
        let (at, tag, room) = (area.nodes, area.tag, area.node_capacity);
        if nodes.len() > room {
            return Err(CellError::Program {
                core: format!("SPE {}", self.spe.id()),
                msg: format!(
                    "a subtree of {} triangles made {} nodes; its local store holds {room}",
                    job.count,
                    nodes.len()
                ),
            });
        }
        let first = match nodes.len() {
            1 => 0,
            n => self.arena.alloc_run(n - 1).await?,
        };
        let id = |local: u32| first + local - 1;
        let place = |n: &BihNode| match n.is_leaf() {
            true => {
                let (f, c) = n.leaf_range();
                BihNode::leaf(f + job.first, c)
            }
            false => {
                let [l, r] = n.clip();
                BihNode::inner(id(n.left_child()), n.axis(), l, r)
            }
        };
        if nodes.len() > 1 {
            let mut run: Vec<BihNode> = nodes[1..].iter().map(place).collect();
            run.resize(run.len().next_multiple_of(4), BihNode::default());
            self.spe.ls_write(at, &run)?;
            let base = self.arena.pool_base();
            let ea = base.offset(first as u64 * NODE as u64);
            let list = pieces(ea, (run.len() * NODE) as u32);
            self.spe.putl(at, &list, tag).await?;
        }
        self.emit(job, place(&nodes[0])).await?;
        self.local.as_mut().expect("open").put = true;
        Ok(())
    }

    /// The records `first..first + count` as DMA-list elements of at most
    /// 16 KiB.
    fn record_list(&self, first: u32, count: u32) -> Vec<ListElement> {
        pieces(self.interval(first), count * size_of::<TriRecord>() as u32)
    }
}

/// `bytes` from `ea` as DMA-list elements of at most 16 KiB.
fn pieces(ea: Ea, bytes: u32) -> Vec<ListElement> {
    let max = MAX_TRANSFER;
    (0..bytes.div_ceil(max))
        .map(|k| ListElement {
            ea: ea.offset((k * max) as u64),
            size: (bytes - k * max).min(max),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::most_nodes;
    use crate::bih::{Bih, BihConfig, SplitChoice};
    use crate::scene::{procedural, zoo};

    /// Nodes and triangles of the subtree below `id`, checking every
    /// subtree on the way against the bound.
    fn check(bih: &Bih, id: u32, cfg: &BihConfig) -> (usize, usize) {
        let n = bih.nodes[id as usize];
        let (nodes, tris) = match n.is_leaf() {
            true => (1, n.leaf_range().1 as usize),
            false => {
                let (a, b) = (
                    check(bih, n.left_child(), cfg),
                    check(bih, n.left_child() + 1, cfg),
                );
                (1 + a.0 + b.0, a.1 + b.1)
            }
        };
        assert!(
            nodes <= most_nodes(tris, cfg),
            "a subtree of {tris} triangles has {nodes} nodes, over the bound {}",
            most_nodes(tris, cfg)
        );
        (nodes, tris)
    }

    /// The local store a subtree is finished in holds its most nodes: on
    /// every subtree of trees built with leaves of one triangle, the
    /// cut-off at its most eager and binned SAH, the bound holds.
    #[test]
    fn every_subtree_has_at_most_the_bound_of_nodes() {
        let eager = BihConfig {
            leaf_size: 1,
            empty_cut: Some(1),
            ..BihConfig::DEFAULT
        };
        let sah = BihConfig {
            split: SplitChoice::BinnedSah { bins: 16, above: 0 },
            ..eager
        };
        let one = BihConfig {
            leaf_size: 1,
            ..BihConfig::DEFAULT
        };
        let scenes = [
            procedural::rtperf(3000, 2),
            zoo::soup(2000, 5),
            zoo::clusters(4, 2000, 3),
        ];
        for scene in &scenes {
            for cfg in [BihConfig::DEFAULT, one, eager, sah] {
                let bih = crate::host::build(scene, &cfg);
                let (nodes, tris) = check(&bih, 0, &cfg);
                assert_eq!(nodes, bih.nodes.len());
                assert_eq!(tris, scene.len());
            }
        }
    }
}
