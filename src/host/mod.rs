//! The builders that run on the host's own cores: `host`, the serial
//! reference, which runs the shared recursion
//! ([`crate::kernels::recursion`]) on the scene's triangle boxes in one
//! thread, and the host counterparts of section 5's strategies,
//! which build its tree on the threads of the current rayon pool:
//! [`shared`] (one job queue a level), [`private`] (per-thread deques
//! with work stealing) and [`morton`] (Morton keys, a parallel radix sort,
//! independent subtrees).

pub mod coop;
pub mod morton;
pub mod private;
pub mod shared;

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode, Quality, depth_first};
use crate::kernels::recursion::{BuildStats, Item, NodeJob, PrimRef, Step, build_items};
use crate::kernels::split::{Side, side_of};
use crate::scene::Scene;

/// A job of at most this many items is built to its leaves by the thread
/// that takes it (the serial recursion: its items, 32 bytes each, stay in
/// that core's cache); a larger one makes one node and leaves its children
/// to the others. 16,384 items are 512 KiB.
pub const SUBTREE: usize = 16_384;

/// Puts the subtree `sub` (root 0) in node `id` of `nodes`, its other
/// nodes appended in their order.
fn graft(nodes: &mut Vec<BihNode>, id: usize, sub: &[BihNode]) {
    let off = nodes.len() - 1;
    let moved = |n: BihNode| match n.is_leaf() {
        true => n,
        false => {
            let [l, r] = n.clip();
            BihNode::inner(n.left_child() + off as u32, n.axis(), l, r)
        }
    };
    nodes[id] = moved(sub[0]);
    nodes.extend(sub[1..].iter().map(|&n| moved(n)));
}

/// The root's job over all of `items`, `region` its region and candidate;
/// its side found by the current pool's threads (by blocks of
/// [`SUBTREE`]: the same bounds and count, merged).
fn root_job<T: Item + Sync>(items: &[T], region: Aabb) -> NodeJob {
    let side = (items.par_chunks(SUBTREE))
        .map(side_of)
        .reduce(|| Side::EMPTY, |a, b| a.merge(b));
    NodeJob {
        first: 0,
        depth: 0,
        region,
        candidate: region,
        side,
    }
}

/// [`prim_refs`] made by the current pool's threads, for the parallel
/// builders (the same items in the same order).
fn par_prim_refs(scene: &Scene) -> Vec<PrimRef> {
    (scene.triangles.par_iter().enumerate())
        .map(|(i, t)| PrimRef::new(i as u32, t.bounds()))
        .collect()
}

/// What a parallel builder made in one node id, in whatever order its
/// threads made them (`host_private`, `host_morton`). (One a node above
/// the grain, a few thousand on the dragon: the size of a step's record
/// does not matter.)
#[allow(clippy::large_enum_variant)]
enum Made {
    /// A node as it is (`host_morton`'s nodes of the key tree).
    Node(BihNode),
    /// A step of the recursion for this job; its children took the ids
    /// from the `usize`.
    Step(Step, usize, NodeJob),
    /// The job's whole subtree (root 0).
    Subtree(Vec<BihNode>),
}

/// The id of the first of the two children slots a node that made `step`
/// takes from `ids` (0 for a leaf, which has none): a clip node's and a
/// split's children are adjacent.
fn children_of(step: &Step, ids: &AtomicUsize) -> usize {
    match step {
        Step::Leaf => 0,
        _ => ids.fetch_add(2, Ordering::Relaxed),
    }
}

/// The tree of the nodes a parallel builder `made` (`ids` node ids handed
/// out, root 0), over `items` in their final order: every node put in its
/// place, then the subtrees grafted in id order (the array before
/// renumbering is then the same on every run with the same schedule; the
/// renumbered one always is), then [`finish`].
fn assemble<T: Item>(
    ids: usize,
    made: impl IntoIterator<Item = (usize, Made)>,
    items: &[T],
    region: Aabb,
    (cfg, stats): (&BihConfig, BuildStats),
) -> (Bih, BuildStats) {
    let mut nodes = vec![BihNode::default(); ids];
    let mut subtrees = Vec::new();
    for (id, m) in made {
        match m {
            Made::Node(n) => nodes[id] = n,
            Made::Step(Step::Leaf, _, node) => {
                nodes[id] = BihNode::leaf(node.first as u32, node.side.count as u32);
            }
            Made::Step(Step::Clip(clip), children, _) => {
                clip.make_at(&mut nodes, id, children);
            }
            Made::Step(Step::Split(split), children, node) => {
                split.make_at(&mut nodes, id, children, &node);
            }
            Made::Subtree(sub) => subtrees.push((id, sub)),
        }
    }
    subtrees.sort_by_key(|(id, _)| *id);
    for (id, sub) in subtrees {
        graft(&mut nodes, id, &sub);
    }
    finish(&nodes, items, region, cfg, stats)
}

/// The tree a parallel builder made: its `nodes` (root 0, in the order it
/// made them) renumbered in the serial recursion's order, over `items` in
/// their final order.
fn finish<T: Item>(
    nodes: &[BihNode],
    items: &[T],
    region: Aabb,
    cfg: &BihConfig,
    mut stats: BuildStats,
) -> (Bih, BuildStats) {
    stats.nodes = nodes.len() as u64;
    let bih = Bih {
        nodes: depth_first(nodes),
        prim_ids: items.iter().map(T::id).collect(),
        bounds: region,
        config: *cfg,
    };
    (bih, stats)
}

/// The scene's triangles as the host builders sort them: box and id.
pub fn prim_refs(scene: &Scene) -> Vec<PrimRef> {
    (scene.triangles.iter().enumerate())
        .map(|(i, t)| PrimRef::new(i as u32, t.bounds()))
        .collect()
}

/// A builder that runs on the host: what the registry needs of it.
pub struct HostBuilder {
    /// The `--builder` name.
    pub name: &'static str,
    /// One line for `cellbih builders`.
    pub describe: &'static str,
    /// The quality knobs of [`BihConfig`] it builds.
    pub quality: Quality,
    /// How it builds.
    pub how: HostBuild,
}

/// How a host builder builds.
#[derive(Clone, Copy)]
pub enum HostBuild {
    /// On one thread: `build(scene, region, cfg)`, the tree of `scene`
    /// with `region` as the scene box of the global heuristic.
    Serial(fn(&Scene, Aabb, &BihConfig) -> Bih),
    /// On the threads of the current rayon pool (the caller's, with
    /// `ThreadPool::install`), the serial builder's tree on any number:
    /// its build over the items, with the grain as a parameter (the
    /// builders use [`SUBTREE`]; tests make it small to run the parallel
    /// part on small scenes).
    Parallel(Grained),
}

impl HostBuilder {
    /// The tree of `scene` with `region` as the scene box of the global
    /// heuristic.
    pub fn build(&self, scene: &Scene, region: Aabb, cfg: &BihConfig) -> Bih {
        match self.how {
            HostBuild::Serial(build) => build(scene, region, cfg),
            HostBuild::Parallel(parallel) => {
                on_threads(parallel, &mut par_prim_refs(scene), region, cfg, SUBTREE).0
            }
        }
    }
}

/// A parallel builder's tree of `items` (sorted in place) with `region` as
/// the scene box, a job of at most `grain` items built by one thread alone
/// (the builders use [`SUBTREE`]). It is called through [`on_threads`]:
/// on two threads or more, with more than `grain` (at least 1) items.
pub type Grained = fn(&mut [PrimRef], Aabb, &BihConfig, usize) -> (Bih, BuildStats);

/// A parallel builder's tree of `items`, sorted in place, on the current
/// rayon pool's threads: the serial recursion's tree
/// ([`build_items`]). On one thread, or where one job of `grain` items
/// holds them all, it is the serial recursion itself: no task, no key.
pub fn on_threads(
    parallel: Grained,
    items: &mut [PrimRef],
    region: Aabb,
    cfg: &BihConfig,
    grain: usize,
) -> (Bih, BuildStats) {
    assert!(cfg.max_depth <= BihConfig::MAX_SUPPORTED_DEPTH);
    let grain = grain.max(1);
    match rayon::current_num_threads() == 1 || items.len() <= grain {
        true => build_items(items, region, cfg),
        false => parallel(items, region, cfg, grain),
    }
}

/// The host builder, the serial reference.
pub const BUILDER: HostBuilder = HostBuilder {
    name: "host",
    describe: "recursive in-place build, global heuristic, on the host (one thread)",
    quality: Quality::ALL,
    how: HostBuild::Serial(build_in),
};

/// Builds the tree of `scene` in one host thread.
pub fn build(scene: &Scene, cfg: &BihConfig) -> Bih {
    build_in(scene, scene.bounds(), cfg)
}

/// [`build`] with `region` as the scene box of the global heuristic.
pub fn build_in(scene: &Scene, region: Aabb, cfg: &BihConfig) -> Bih {
    build_items(&mut prim_refs(scene), region, cfg).0
}
