//! `host_private` — section 5's **private queues** on the host's own cores:
//! the host counterpart of `spe_bfs_private`, with the work
//! stealing the SPEs' static deal lacks. Each thread of the current rayon
//! pool has its own deque (`crossbeam::deque::Worker`, last in first out:
//! it goes on depth first with the child it just made); a thread whose
//! deque is empty steals the oldest job of another's (`Stealer`, the
//! largest there: the top of its subtree), or takes from the `Injector`
//! that holds the root.
//!
//! A job owns its items (a disjoint slice of the item array, split at
//! each partition), so no two threads touch an item. A job of more than
//! [`super::SUBTREE`] items (the grain) makes one node — one step of the serial recursion
//! ([`step`]) — and pushes its children; a smaller one is built to its
//! leaves by its thread ([`build_node`]). Node ids are handed out by one
//! atomic counter as threads make nodes, in whatever order they run; the
//! nodes are put together at the end and renumbered in the serial
//! recursion's order ([`crate::bih::depth_first`]), so the tree is the
//! serial host builder's node for node, for any number of threads and any
//! schedule.
//!
//! The top levels are made cooperatively first ([`coop::top`]: a job of
//! more than 4 × [`super::SUBTREE`] items by every thread together), breadth
//! first; the jobs below them start in the `Injector`. The cooperative
//! partition leaves the items of a side in another order than the serial
//! one: a leaf holds the same triangles, perhaps in another order (the
//! same on two threads as on eight: the top depends on the grain only).

use std::sync::atomic::{AtomicUsize, Ordering};

use crossbeam::deque::{Injector, Steal, Stealer, Worker};

use super::{HostBuild, HostBuilder, Made, coop};
use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, Quality};
use crate::kernels::recursion::{BuildStats, Item, NodeJob, PrimRef, Step, build_node, step};

/// The builder.
pub const BUILDER: HostBuilder = HostBuilder {
    name: "host_private",
    describe: "the host builder's tree on the host's cores: a deque per thread, work stealing (crossbeam; section 5's private queues)",
    quality: Quality::ALL,
    how: HostBuild::Parallel(build),
};

/// A job: node `id` over its own items.
struct Job<'a, T> {
    id: usize,
    items: &'a mut [T],
    node: NodeJob,
}

/// Builds on two threads or more with per-thread deques (through
/// [`super::on_threads`]): the serial recursion's tree, node for node.
fn build(items: &mut [PrimRef], region: Aabb, cfg: &BihConfig, grain: usize) -> (Bih, BuildStats) {
    let threads = rayon::current_num_threads();
    let root = super::root_job(items, region);
    let ids = AtomicUsize::new(1);
    let mut stats = BuildStats::default();
    // The top, every thread on each job; then the deques.
    let (top, below) = coop::top(&mut *items, root, cfg, grain, &ids, &mut stats);
    let top =
        (top.into_iter()).map(|(id, node, step, children)| (id, Made::Step(step, children, node)));
    let mut made = Vec::from_iter(top);
    for (records, counted) in run(below, cfg, grain, threads, &ids) {
        stats.add(&counted);
        made.extend(records);
    }
    // The nodes, put together: every id handed out, then the subtrees.
    let ids = ids.load(Ordering::Acquire);
    super::assemble(ids, made, items, region, (cfg, stats))
}

/// What each thread made of the jobs `below` the top and their
/// descendants, the threads taking ids from `ids`.
#[allow(clippy::type_complexity)]
fn run<'a, T: Item + Send>(
    below: Vec<coop::Below<'a, T>>,
    cfg: &BihConfig,
    grain: usize,
    threads: usize,
    ids: &AtomicUsize,
) -> Vec<(Vec<(usize, Made)>, BuildStats)> {
    let pending = AtomicUsize::new(below.len());
    let injector = Injector::new();
    for (id, items, node) in below {
        injector.push(Job { id, items, node });
    }
    let workers: Vec<Worker<Job<T>>> = (0..threads).map(|_| Worker::new_lifo()).collect();
    let stealers: Vec<Stealer<Job<T>>> = workers.iter().map(Worker::stealer).collect();
    let made = std::sync::Mutex::new(Vec::with_capacity(threads));
    rayon::scope(|s| {
        for (me, worker) in workers.into_iter().enumerate() {
            let (injector, stealers, pending, made) = (&injector, &stealers, &pending, &made);
            s.spawn(move |_| {
                let mut own = (Vec::new(), BuildStats::default());
                while pending.load(Ordering::Acquire) > 0 {
                    let Some(job) = find(&worker, injector, stealers, me) else {
                        std::thread::yield_now();
                        continue;
                    };
                    make(job, cfg, grain, (&worker, ids, pending), &mut own);
                }
                made.lock().expect("a thread's records").push(own);
            });
        }
    });
    made.into_inner().expect("every thread's records")
}

/// The next job for thread `me`: its own deque's newest, else the oldest
/// of the injector or of another thread's deque.
fn find<'a, T>(
    worker: &Worker<Job<'a, T>>,
    injector: &Injector<Job<'a, T>>,
    stealers: &[Stealer<Job<'a, T>>],
    me: usize,
) -> Option<Job<'a, T>> {
    worker.pop().or_else(|| {
        std::iter::repeat_with(|| {
            injector.steal_batch_and_pop(worker).or_else(|| {
                (stealers.iter().enumerate())
                    .filter(|&(k, _)| k != me)
                    .map(|(_, s)| s.steal())
                    .collect()
            })
        })
        .find(|s| !s.is_retry())
        .and_then(Steal::success)
    })
}

/// Makes `job`: its subtree if small, else one node, its children pushed
/// onto this thread's deque. Records what it made in `own`.
fn make<'a, T: Item>(
    job: Job<'a, T>,
    cfg: &BihConfig,
    grain: usize,
    (worker, ids, pending): (&Worker<Job<'a, T>>, &AtomicUsize, &AtomicUsize),
    own: &mut (Vec<(usize, Made)>, BuildStats),
) {
    let (records, stats) = own;
    let Job { id, items, node } = job;
    if items.len() <= grain {
        records.push((id, Made::Subtree(build_node(items, &node, cfg, stats))));
        pending.fetch_sub(1, Ordering::AcqRel);
        return;
    }
    let made = step(items, &node, cfg, stats);
    let children = super::children_of(&made, ids);
    match made {
        Step::Leaf => {}
        Step::Clip(clip) => {
            pending.fetch_add(1, Ordering::AcqRel);
            worker.push(Job {
                id: children + 1 - clip.empty,
                items,
                node: node.clipped(clip.region),
            });
        }
        Step::Split(split) => {
            pending.fetch_add(2, Ordering::AcqRel);
            let [left, right] = split.children(children, &node);
            let (l, r) = items.split_at_mut(split.left.count);
            // The right child first: the left is popped next (depth first).
            for (c, items) in [(right, r), (left, l)] {
                worker.push(Job {
                    id: c.id,
                    items,
                    node: c.job(&node),
                });
            }
        }
    }
    records.push((id, Made::Step(made, children, node)));
    pending.fetch_sub(1, Ordering::AcqRel);
}
