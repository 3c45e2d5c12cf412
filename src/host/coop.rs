//! The cooperative top (section 5's strategies partition the
//! top levels cooperatively, as `spe_bfs_private`'s top does on the SPEs):
//! a job larger than the cooperative threshold is made by every thread of
//! the pool together — the binning and the partition of its one step
//! ([`step_with`]) cut into blocks of the grain's items that rayon deals
//! out — so that no thread waits while another partitions the top of the
//! tree alone.
//!
//! The partition is in place by blocks ([`partition`]): the same sides as
//! the serial partition, the items of a side in another order, the same
//! order for every number of threads (the blocks do not depend on it).
//! Bins are filled per block and merged (a count and a box per bin: the
//! same bins). The block is the grain ([`super::SUBTREE`] items, 512 KiB,
//! for the builders; tests make it small).

use std::collections::VecDeque;
use std::sync::atomic::AtomicUsize;

use rayon::prelude::*;

use crate::bih::BihConfig;
use crate::kernels::recursion::{BuildStats, Item, NodeJob, Step, step_with};
use crate::kernels::sah::Bins;
use crate::kernels::split::{Side, Split};

/// A job above this many items is made cooperatively, for a grain of
/// `grain` (the builders: 4 × [`super::SUBTREE`], 65,536 items).
pub fn threshold(grain: usize) -> usize {
    4 * grain.max(1)
}

/// One step of the recursion ([`step_with`]) with the binning and the
/// partition shared among the current pool's threads.
pub fn coop_step<T: Item + Send + Sync>(
    items: &mut [T],
    node: &NodeJob,
    cfg: &BihConfig,
    block: usize,
    stats: &mut BuildStats,
) -> Step {
    let block = block.max(1);
    let bin = |bins: &mut Bins, items: &[T]| fill(bins, items, block);
    step_with(items, node, (cfg, stats), bin, |items, split| {
        partition(items, split, block)
    })
}

/// Fills `bins` with `items`, by blocks of `block` in parallel.
fn fill<T: Item + Sync>(bins: &mut Bins, items: &[T], block: usize) {
    let empty = bins.clone();
    let filled: Vec<_> = (items.par_chunks(block))
        .map(|block| {
            let mut b = empty.clone();
            b.add(block);
            b.records()
        })
        .collect();
    for records in filled {
        bins.add_records(&records);
    }
}

/// Partitions `items` at `split` in place, in parallel: each block of
/// `block` items is partitioned by the serial partition (its left items
/// first), then the right items that lie where the left side of the whole
/// will be are swapped, in order, with the left items that lie where its
/// right side will be (each pair of runs a task). Returns both sides
/// (merged from the blocks'). No copy, no allocation but the runs; the
/// order of the items depends on `block`, not on the threads.
pub fn partition<T: Item + Send + Sync>(
    items: &mut [T],
    split: Split,
    block: usize,
) -> (Side, Side) {
    let sides: Vec<(Side, Side)> = (items.par_chunks_mut(block))
        .map(|b| crate::kernels::split::partition(b, split))
        .collect();
    let (left, right) = (sides.iter()).fold((Side::EMPTY, Side::EMPTY), |(l, r), (bl, br)| {
        (l.merge(*bl), r.merge(*br))
    });
    // The misplaced runs: right items before `left.count`, left items
    // from it on, each in increasing order.
    let n = left.count;
    let (mut wrong_right, mut wrong_left) = (Vec::new(), Vec::new());
    for (b, (l, _)) in sides.iter().enumerate() {
        let start = b * block;
        let (mid, end) = (start + l.count, (start + block).min(items.len()));
        if start.max(n) < mid {
            wrong_left.push(start.max(n)..mid);
        }
        if mid < end.min(n) {
            wrong_right.push(mid..end.min(n));
        }
    }
    // Pairs of runs of equal length, the k-th misplaced right item with
    // the k-th misplaced left one, carved out of the two halves.
    let (mut lo_rest, mut hi_rest) = items.split_at_mut(n);
    let (mut lo_at, mut hi_at) = (0, n);
    let mut pairs = Vec::new();
    let (mut r_runs, mut l_runs) = (wrong_right.into_iter(), wrong_left.into_iter());
    let (mut r, mut l) = (r_runs.next(), l_runs.next());
    while let (Some(rr), Some(lr)) = (r.clone(), l.clone()) {
        let len = rr.len().min(lr.len());
        let (_, a) = std::mem::take(&mut lo_rest).split_at_mut(rr.start - lo_at);
        let (a, a_rest) = a.split_at_mut(len);
        let (_, b) = std::mem::take(&mut hi_rest).split_at_mut(lr.start - hi_at);
        let (b, b_rest) = b.split_at_mut(len);
        (lo_rest, hi_rest, lo_at, hi_at) = (a_rest, b_rest, rr.start + len, lr.start + len);
        pairs.push((a, b));
        r = if len < rr.len() {
            Some(rr.start + len..rr.end)
        } else {
            r_runs.next()
        };
        l = if len < lr.len() {
            Some(lr.start + len..lr.end)
        } else {
            l_runs.next()
        };
    }
    debug_assert!(r.is_none() && l.is_none(), "as many misplaced on each side");
    pairs
        .into_par_iter()
        .for_each(|(a, b)| a.swap_with_slice(b));
    (left, right)
}

/// A node the cooperative top made: its id, its job, its step and the id
/// of its first child (0 for a leaf).
pub type TopNode = (usize, NodeJob, Step, usize);

/// A job left below the top: its node id, its own items and its job.
pub type Below<'a, T> = (usize, &'a mut [T], NodeJob);

/// Makes every job above [`threshold`]`(grain)` items from `root` (node
/// 0, over all of `items`) down, breadth first, each one cooperatively,
/// children's ids from `ids`; returns the nodes made and the jobs left, in
/// item order.
pub fn top<'a, T: Item + Send + Sync>(
    items: &'a mut [T],
    root: NodeJob,
    cfg: &BihConfig,
    grain: usize,
    ids: &AtomicUsize,
    stats: &mut BuildStats,
) -> (Vec<TopNode>, Vec<Below<'a, T>>) {
    let (mut made, mut below) = (Vec::new(), Vec::new());
    let mut queue = VecDeque::from([(0usize, items, root)]);
    while let Some((id, items, node)) = queue.pop_front() {
        if items.len() <= threshold(grain) {
            below.push((id, items, node));
            continue;
        }
        let step = coop_step(items, &node, cfg, grain, stats);
        let children = super::children_of(&step, ids);
        match step {
            Step::Leaf => {}
            Step::Clip(clip) => {
                queue.push_back((children + 1 - clip.empty, items, node.clipped(clip.region)));
            }
            Step::Split(split) => {
                let [left, right] = split.children(children, &node);
                let (l, r) = items.split_at_mut(split.left.count);
                queue.push_back((left.id, l, left.job(&node)));
                queue.push_back((right.id, r, right.job(&node)));
            }
        }
        made.push((id, node, step, children));
    }
    below.sort_by_key(|(_, _, n)| n.first);
    (made, below)
}
