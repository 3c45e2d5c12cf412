//! `host_shared` — section 5's **one common job queue** on the host's own
//! cores: the host counterpart of `spe_bfs_shared`. The tree is
//! built level by level; the jobs of a level lie in one array and the
//! threads of the current rayon pool take them, largest first, in batches
//! from one atomic counter (guided takes, as the shared queue's: an equal
//! share of what is left, at most [`AGGLOMERATE`]); a level ends when
//! every job of it is made (the barrier is the end of the scope).
//!
//! Each job of a level is one step of the serial recursion ([`step`]: the
//! node decision, binning, the in-place partition of the job's own items),
//! on disjoint slices of the items, so the threads never share an item.
//! The nodes are then written in the level's order by one thread (a few
//! stores a job), breadth first, and at the end renumbered in the serial
//! recursion's order ([`crate::bih::depth_first`], one pass): the tree is
//! the serial host builder's, node for node, for any number of threads.
//!
//! A job of more than 4 × [`super::SUBTREE`] items — or of more than [`super::SUBTREE`]
//! on a level of fewer jobs than threads — is made by every thread
//! together ([`coop::coop_step`]) before the level's queue opens. A job of
//! at most [`super::SUBTREE`] items (the grain) is built to its leaves by the
//! thread that takes it (the serial recursion over its own items, just
//! partitioned and still in that core's cache) and grafted into the tree.
//! (Keeping them for one last round after the last level, so that a level
//! of partitions would not wait on a thread's whole subtree, was tried: no
//! faster in an A/B on a noisy two-vCPU machine, and it gives up that
//! cache.) A leaf holds the same triangles as the serial builder's,
//! perhaps in another order (the cooperative partition's).
//!
//! Threads: the pool the build runs in (`ThreadPool::install`; the global
//! one otherwise). With one thread it is the serial recursion itself (no
//! level, no task: no parallel overhead).

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::{HostBuild, HostBuilder, coop, graft};
use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode, Quality};
use crate::kernels::recursion::{BuildStats, Item, NodeJob, PrimRef, Step, build_node, step};

/// The builder.
pub const BUILDER: HostBuilder = HostBuilder {
    name: "host_shared",
    describe: "the host builder's tree level by level on the host's cores: one shared job queue a level, batches taken atomically (rayon; section 5's shared queue)",
    quality: Quality::ALL,
    how: HostBuild::Parallel(build),
};

/// Jobs one take hands out at most (as `spe_bfs_shared --agglomerate`).
pub const AGGLOMERATE: usize = 16;

/// A job of a level: a node to make over `items[first .. first + count]`.
#[derive(Clone, Copy)]
struct Job {
    id: usize,
    count: usize,
    node: NodeJob,
}

/// Builds level by level on two threads or more (through
/// [`super::on_threads`]): the serial recursion's tree, node for node.
fn build(items: &mut [PrimRef], region: Aabb, cfg: &BihConfig, grain: usize) -> (Bih, BuildStats) {
    let root = super::root_job(items, region);
    let mut nodes = vec![BihNode::default()];
    let mut stats = BuildStats::default();
    let mut level = vec![Job {
        id: 0,
        count: root.side.count,
        node: root,
    }];
    while !level.is_empty() {
        let steps = take_level(items, &level, cfg, grain, &mut stats);
        let mut next = Vec::with_capacity(2 * level.len());
        for (job, made) in level.iter().zip(steps) {
            let made = match made {
                Made::Step(step) => step,
                Made::Subtree(sub) => {
                    graft(&mut nodes, job.id, &sub);
                    continue;
                }
            };
            match made {
                Step::Leaf => {
                    nodes[job.id] = BihNode::leaf(job.node.first as u32, job.count as u32);
                }
                Step::Clip(clip) => {
                    next.push(Job {
                        id: clip.make_in(&mut nodes, job.id),
                        node: job.node.clipped(clip.region),
                        ..*job
                    });
                }
                Step::Split(split) => {
                    for c in split.make_in(&mut nodes, job.id, &job.node) {
                        next.push(Job {
                            id: c.id,
                            count: c.side.count,
                            node: c.job(&job.node),
                        });
                    }
                }
            }
        }
        level = next;
    }
    super::finish(&nodes, items, region, cfg, stats)
}

/// What a job made: one step of the recursion (its children are jobs of
/// the next level), or, for a job of at most the grain's items, its whole
/// subtree (root 0, leaf ranges in the whole array's places).
enum Made {
    Step(Step),
    Subtree(Vec<BihNode>),
}

/// One job's place in a level: its items, and what it made.
struct Slot<'a, T> {
    items: &'a mut [T],
    made: Option<Made>,
    stats: BuildStats,
}

/// Makes every job of `level` (in item order, disjoint), the threads
/// taking batches from one counter; returns what each made, in order, and
/// adds their work to `stats`.
fn take_level<T: Item + Send + Sync>(
    items: &mut [T],
    level: &[Job],
    cfg: &BihConfig,
    grain: usize,
    stats: &mut BuildStats,
) -> Vec<Made> {
    // Each job's own items, carved in order.
    let mut slots = Vec::with_capacity(level.len());
    let (mut rest, mut at) = (items, 0);
    for job in level {
        let (_, tail) = std::mem::take(&mut rest).split_at_mut(job.node.first - at);
        let (mine, tail) = tail.split_at_mut(job.count);
        rest = tail;
        at = job.node.first + job.count;
        slots.push(Mutex::new(Slot {
            items: mine,
            made: None,
            stats: BuildStats::default(),
        }));
    }
    // Above this many items a job is made by every thread together: 4 ×
    // the grain, or the grain itself on a level of fewer jobs than threads
    // (which would leave threads idle until the level ends).
    let coop = match level.len() < rayon::current_num_threads() {
        true => grain,
        false => coop::threshold(grain),
    };
    let make = |k: usize| {
        let mut slot = slots[k].lock().expect("a job's slot");
        let Slot { items, made, stats } = &mut *slot;
        let job = &level[k];
        *made = Some(match job.count {
            n if n <= grain => Made::Subtree(build_node(items, &job.node, cfg, stats)),
            n if n > coop => Made::Step(coop::coop_step(items, &job.node, cfg, grain, stats)),
            _ => Made::Step(step(items, &job.node, cfg, stats)),
        });
    };
    // The large jobs first, one at a time, every thread on each; then the
    // others from the queue, largest first.
    let (large, mut queue): (Vec<usize>, Vec<usize>) =
        (0..level.len()).partition(|&k| level[k].count > coop);
    large.into_iter().for_each(make);
    queue.sort_by_key(|&k| std::cmp::Reverse(level[k].count));
    let threads = rayon::current_num_threads().min(queue.len());
    if threads <= 1 {
        queue.into_iter().for_each(make);
    } else {
        let next = AtomicUsize::new(0);
        let worker = || {
            loop {
                let left = queue.len().saturating_sub(next.load(Ordering::Relaxed));
                let size = left.div_ceil(threads).clamp(1, AGGLOMERATE);
                let first = next.fetch_add(size, Ordering::Relaxed);
                if first >= queue.len() {
                    break;
                }
                queue[first..(first + size).min(queue.len())]
                    .iter()
                    .copied()
                    .for_each(make);
            }
        };
        rayon::scope(|s| {
            for _ in 1..threads {
                s.spawn(|_| worker());
            }
            worker();
        });
    }
    (slots.into_iter())
        .map(|slot| {
            let slot = slot.into_inner().expect("a job's slot");
            stats.add(&slot.stats);
            slot.made.expect("every job of the level was made")
        })
        .collect()
}
