//! `host_morton` — section 5's **Morton route** on the host's own cores:
//! the host counterpart of `spe_morton` ("a pre-processing
//! step using Morton curves is performed to find regions of primitives
//! that then could be built-up totally independent"; "a radix sort needs
//! to be performed"), with the shared kernels of [`crate::kernels::morton`]
//! and [`crate::kernels::radix`]:
//!
//! 1. **Keys** in the global heuristic's halving order ([`KeyOrder`]), one
//!    per item, computed in parallel from a table of the halvings
//!    ([`HalvingTable`]: usually three one-dimensional trees of planes in
//!    L1; eight items' descents side by side; dragon, 2 threads: 7.2–7.5
//!    ms, against 34.5 one halving a bit).
//! 2. **Radix sort**, LSD, 8 bits a pass, of (key, item index) pairs, by
//!    blocks of [`BLOCK`] pairs in parallel: every block counts its digits;
//!    the output is carved, digit by digit and block by block, into one
//!    run per (block, digit); every block scatters its pairs into its own
//!    runs (stable, and no two threads write one place). (Moving the
//!    32-byte items with their keys in every pass instead cost more than
//!    the sort and a gather, measured on the dragon.)
//! 3. **The top of the tree from the sorted keys**: a node where a range's
//!    keys first differ ([`split_of`]), its two sides made side by side
//!    (`rayon::join`), down to ranges of at most the grain's items
//!    ([`super::SUBTREE`]) or whose keys are all equal. Without the empty-space
//!    cut-off it is made bottom up (`Top::gathered`): each such range
//!    **gathers its own items** in key order from a copy of them, and a
//!    node's planes come from its sides' bounds as they return. With the
//!    cut-off a node's decision needs its bounds and its region first: the
//!    ranges are gathered and their sides found bottom up (`Top::sides`),
//!    then the decisions — clip nodes among the keys' splits — made top
//!    down (`Top::decided`), each range built as it is reached.
//! 4. **Independent subtrees**: each such range built by the serial
//!    recursion from its candidate cell ([`KeySpec::cell`]), as a rayon
//!    task, while its gathered items are in its core's cache.
//!
//! With keys in the global heuristic's order, a node of the key tree is a
//! halving the serial builder makes with items on both sides (the Morton
//! kernel's own proof, tested in `tests/morton.rs`), so the tree is the
//! serial host builder's: the same nodes, the same leaves with the same
//! triangles. Within a leaf the triangles may come in another order (the
//! sort is stable where the serial partition swaps), the same for every
//! number of threads.
//!
//! The quality knobs, with the serial tree still: the **empty-space
//! cut-off** decides at each node of the key tree as in the serial
//! recursion ([`decide`]); a clip node leaves its candidate cell, so the
//! keys still give the splits below it. **Binned SAH** chooses planes keys
//! cannot hold: a node SAH splits (more than `--sah-above` triangles) is
//! one step of the recursion with the binning and the partition shared by
//! the threads ([`coop::coop_step`]), its children made side by side; a
//! node the global heuristic splits gets keys in the halving order of its
//! own candidate box, and the route above runs on its items alone. With
//! SAH at every node (`--sah-above 0`) no key is computed.
//!
//! Threads: the pool the build runs in; with one thread it is the serial
//! recursion itself (no keys, no sort: no parallel overhead).

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use super::{HostBuild, HostBuilder, Made, coop};
use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode, Quality};
use crate::kernels::cutoff::child_regions;
use crate::kernels::decide::{Decision, NodeView, decide};
use crate::kernels::halving::HalvingTable;
use crate::kernels::morton::{KeyOrder, KeySpec, auto_key_bits, split_of};
use crate::kernels::radix;
use crate::kernels::recursion::{BuildStats, Item, NodeJob, PrimRef, Step, build_node};
use crate::kernels::split::{Side, clip_planes, side_of};

/// The builder.
pub const BUILDER: HostBuilder = HostBuilder {
    name: "host_morton",
    describe: "the host builder's tree on the host's cores: Morton keys in the global heuristic's order, a parallel radix sort, the top from the keys, independent subtrees as rayon tasks (section 5's Morton route)",
    quality: Quality::ALL,
    how: HostBuild::Parallel(build),
};

/// Pairs a block of the radix sort counts and scatters: 64 Ki pairs, 768
/// KiB of keys and indices, a block a task.
pub const BLOCK: usize = 1 << 16;

/// Items whose keys one task computes.
const KEY_CHUNK: usize = 4096;

/// Bits a radix pass sorts by (256 counters a block).
pub const DIGIT_BITS: u32 = 8;

/// Builds by the Morton route on two threads or more (through
/// [`super::on_threads`]): the serial recursion's tree, leaf for leaf,
/// ranges of at most `grain` items built by one thread.
fn build(items: &mut [PrimRef], region: Aabb, cfg: &BihConfig, grain: usize) -> (Bih, BuildStats) {
    let route = Route {
        cfg,
        grain,
        ids: AtomicUsize::new(1),
    };
    let root = super::root_job(items, region);
    let (made, stats) = route.node(items, root, 0);
    let ids = route.ids.load(Ordering::Acquire);
    super::assemble(ids, made, items, region, (cfg, stats))
}

/// The build above the keys: node ids handed out by one counter.
struct Route<'a> {
    cfg: &'a BihConfig,
    grain: usize,
    ids: AtomicUsize,
}

/// What a part of the build made (node id and what is there), and the
/// work it counted.
type Built = (Vec<(usize, Made)>, BuildStats);

impl Route<'_> {
    /// Makes node `id` of `job` (over `items`, the job's own items) and
    /// its subtree: by the keys where the global heuristic splits it
    /// ([`Self::keyed`]); where binned SAH does (a node of more than
    /// `--sah-above` triangles), one step of the recursion with its
    /// binning and partition shared by the threads ([`coop::coop_step`]),
    /// its children side by side (`rayon::join`).
    fn node<T: Item + Send + Sync>(&self, items: &mut [T], job: NodeJob, id: usize) -> Built {
        let mut stats = BuildStats::default();
        if items.len() <= self.grain {
            let sub = build_node(items, &job, self.cfg, &mut stats);
            return (vec![(id, Made::Subtree(sub))], stats);
        }
        if self.cfg.sah_bins(items.len()).is_none() {
            // The global heuristic from here down (a node's children have
            // fewer triangles): keys in its halving order of this
            // candidate.
            return self.keyed(items, job, id);
        }
        let step = coop::coop_step(items, &job, self.cfg, self.grain, &mut stats);
        let children = super::children_of(&step, &self.ids);
        let mut made = match step {
            Step::Leaf => Vec::new(),
            Step::Clip(clip) => {
                let (made, s) =
                    self.node(items, job.clipped(clip.region), children + 1 - clip.empty);
                stats.add(&s);
                made
            }
            Step::Split(split) => {
                let [left, right] = split.children(children, &job);
                let (l, r) = items.split_at_mut(split.left.count);
                let ((mut made, ls), (rm, rs)) = rayon::join(
                    || self.node(l, left.job(&job), left.id),
                    || self.node(r, right.job(&job), right.id),
                );
                made.extend(rm);
                stats.add(&ls);
                stats.add(&rs);
                made
            }
        };
        made.push((id, Made::Step(step, children, job)));
        (made, stats)
    }

    /// [`Self::node`] for a job the global heuristic splits, and so every
    /// node below it: 1. keys in its halving order of the job's candidate,
    /// 2. the sort of (key, index) pairs, 3. the top from the keys
    /// ([`Top`]) and 4. the subtrees, each range gathering its own items
    /// from a copy: without the cut-off in one pass, bottom up; with it in
    /// two, the sides bottom up and the decisions top down.
    fn keyed<T: Item + Send + Sync>(&self, items: &mut [T], job: NodeJob, id: usize) -> Built {
        let spec = KeySpec {
            order: KeyOrder::GlobalHeuristic,
            bits: auto_key_bits(items.len(), self.grain, DIGIT_BITS),
            scene: job.candidate,
        };
        let mut keys = vec![0u64; items.len()];
        match HalvingTable::new(&spec) {
            Some(table) => (items
                .par_chunks(KEY_CHUNK)
                .zip(keys.par_chunks_mut(KEY_CHUNK)))
            .for_each(|(ts, ks)| {
                let centers: Vec<_> = ts.iter().map(|t| t.center()).collect();
                table.keys(&centers, ks);
            }),
            None => (items.par_iter().zip(&mut keys)).for_each(|(t, k)| *k = spec.key(t.center())),
        }
        let mut order: Vec<u32> = (0..items.len() as u32).collect();
        sort_pairs(&mut keys, &mut order, spec.bits);
        let top = Top {
            keys: &keys,
            base: job.first,
            spec,
            route: self,
        };
        let unsorted: Vec<T> = items.par_iter().copied().collect();
        let from = (unsorted.as_slice(), order.as_slice());
        if self.cfg.empty_cut.is_none() {
            // No node of the key tree needs its items' bounds before its
            // children are made: each range gathers its own items and is
            // built at once.
            let at = (job.first, job.depth, job.candidate);
            let (made, _, stats) = top.gathered(items, from, at, id);
            return (made, stats);
        }
        // The cut-off decides a node by its bounds and region: the key
        // tree's ranges gathered and their sides found first, bottom up,
        // then the decisions top down.
        let tree = top.sides(items, from, (job.first, job.depth));
        drop(unsorted);
        top.decided(&tree, items, job, id)
    }
}

/// Sorts `keys` (of `bits` bits) and their `values` together, stably, by
/// LSD passes of [`DIGIT_BITS`], each pass by blocks of [`BLOCK`] pairs on
/// the current pool's threads (the passes of [`radix`]), between `values`
/// and one copy of them.
pub fn sort_pairs<V: Copy + Send + Sync>(keys: &mut Vec<u64>, values: &mut [V], bits: u32) {
    assert_eq!(keys.len(), values.len());
    let mut other_keys = vec![0u64; keys.len()];
    let mut other: Vec<V> = values.par_iter().copied().collect();
    // Where the pairs are now: `keys` and `values`, or the other two.
    let mut home = true;
    for pass in 0..radix::passes(bits, DIGIT_BITS) {
        let moved = match home {
            true => radix_pass((keys, values), (&mut other_keys, &mut other), pass),
            false => radix_pass((&other_keys, &other), (keys, values), pass),
        };
        home ^= moved;
    }
    if !home {
        keys.par_iter_mut()
            .zip(&other_keys)
            .for_each(|(to, k)| *to = *k);
        values
            .par_iter_mut()
            .zip(&other)
            .for_each(|(to, v)| *to = *v);
    }
}

/// One stable pass by digit `pass` from `src` to `dst`; `false` (and
/// nothing moved) when every key has the same digit.
fn radix_pass<V: Copy + Send + Sync>(
    (src_keys, src): (&[u64], &[V]),
    (dst_keys, dst): (&mut [u64], &mut [V]),
    pass: u32,
) -> bool {
    let digits = 1usize << DIGIT_BITS;
    let counts: Vec<Vec<u32>> = (src_keys.par_chunks(BLOCK))
        .map(|block| {
            let mut c = vec![0u32; digits];
            radix::histogram(block, pass, DIGIT_BITS, &mut c);
            c
        })
        .collect();
    let all = src_keys.len();
    if counts
        .iter()
        .all(|c| c.iter().all(|&n| n == 0 || n as usize == all))
    {
        return false;
    }
    // The output carved into one run per (block, digit), digit-major:
    // where the stable scatter puts them ([`radix::offsets`]).
    let mut runs: Vec<Vec<(&mut [u64], &mut [V])>> = (0..counts.len())
        .map(|_| Vec::with_capacity(digits))
        .collect();
    let (mut k_rest, mut v_rest) = (dst_keys, dst);
    for d in 0..digits {
        for (b, c) in counts.iter().enumerate() {
            let (k, kt) = std::mem::take(&mut k_rest).split_at_mut(c[d] as usize);
            let (v, vt) = std::mem::take(&mut v_rest).split_at_mut(c[d] as usize);
            (k_rest, v_rest) = (kt, vt);
            runs[b].push((k, v));
        }
    }
    (src_keys.par_chunks(BLOCK).zip(src.par_chunks(BLOCK)))
        .zip(runs)
        .for_each(|((ks, vs), mut runs)| {
            let mut at = vec![0usize; digits];
            for (&k, &v) in ks.iter().zip(vs) {
                let d = radix::digit(k, pass, DIGIT_BITS);
                runs[d].0[at[d]] = k;
                runs[d].1[at[d]] = v;
                at[d] += 1;
            }
        });
    true
}

/// The top of a keyed job's subtree from its sorted keys.
struct Top<'a> {
    /// The keys of the job's items, the first that of item `base`.
    keys: &'a [u64],
    base: usize,
    spec: KeySpec,
    route: &'a Route<'a>,
}

impl Top<'_> {
    /// Where the range of `items`' places from `first`, at `depth`, splits:
    /// the first bit at which its keys differ and the first item on its
    /// right ([`split_of`]); `None` for a range of at most the grain's
    /// items, a leaf's, or keys all equal — whose items are then gathered
    /// from `unsorted` in key order (`order`) into its places.
    fn split_or_gather<T: Item>(
        &self,
        items: &mut [T],
        (unsorted, order): (&[T], &[u32]),
        (first, depth): (usize, u32),
    ) -> Option<(u32, usize)> {
        let (cfg, grain) = (self.route.cfg, self.route.grain);
        let from = first - self.base;
        let keys = &self.keys[from..from + items.len()];
        let split = match items.len() <= grain || cfg.ends_in_leaf(items.len(), depth) {
            true => None,
            false => split_of(keys, self.spec.bits),
        };
        if split.is_none() {
            for (to, &i) in items.iter_mut().zip(&order[from..]) {
                *to = unsorted[i as usize];
            }
        }
        split
    }

    /// Makes node `id` (over `items`' places, from `first`, at `depth`, its
    /// candidate cell `candidate`) and its subtree without the empty-space
    /// cut-off, bottom up: a split where its keys first differ, both sides
    /// side by side, its planes from their bounds once they are made; a
    /// range of at most the grain's items (or a leaf, or keys all equal)
    /// gathers its items from `unsorted` in key order (`order`) into its
    /// places and is built by the serial recursion while they are in this
    /// core's cache. Returns what it made, its items' side, the work.
    fn gathered<T: Item + Send + Sync>(
        &self,
        items: &mut [T],
        (unsorted, order): (&[T], &[u32]),
        (first, depth, candidate): (usize, u32, Aabb),
        id: usize,
    ) -> (Vec<(usize, Made)>, Side, BuildStats) {
        let cfg = self.route.cfg;
        debug_assert!(cfg.empty_cut.is_none(), "regions are not followed");
        let Some((bit, at)) = self.split_or_gather(items, (unsorted, order), (first, depth)) else {
            let side = side_of(items);
            // Its region is followed for the cut-off only.
            let (region, mut stats) = (candidate, BuildStats::default());
            let job = NodeJob {
                first,
                depth,
                region,
                candidate,
                side,
            };
            let sub = build_node(items, &job, cfg, &mut stats);
            return (vec![(id, Made::Subtree(sub))], side, stats);
        };
        let axis = self
            .spec
            .cell(self.keys[first - self.base], bit)
            .longest_axis();
        let children = self.route.ids.fetch_add(2, Ordering::Relaxed);
        let (l_items, r_items) = items.split_at_mut(at);
        let child = |first: usize| {
            (
                first,
                depth + 1,
                self.spec.cell(self.keys[first - self.base], bit + 1),
            )
        };
        let from = (unsorted, order);
        let ((mut made, l, ls), (rm, r, rs)) = rayon::join(
            || self.gathered(l_items, from, child(first), children),
            || self.gathered(r_items, from, child(first + at), children + 1),
        );
        made.extend(rm);
        let planes = clip_planes(axis, &l, &r);
        made.push((
            id,
            Made::Node(BihNode::inner(children as u32, axis, planes[0], planes[1])),
        ));
        let mut stats = ls;
        stats.add(&rs);
        stats.items_partitioned += (l.count + r.count) as u64;
        stats.partitions += 1;
        (made, l.merge(r), stats)
    }

    /// The key tree of a range (over `items`' places, from `first`, at
    /// least at `depth`): a split where its keys first differ, both sides
    /// side by side, down to ranges of at most the grain's items (or a
    /// leaf's, or keys all equal), each of which gathers its items from
    /// `unsorted` in key order (`order`) into its places and finds their
    /// side. Nothing is decided or built yet.
    fn sides<T: Item + Send + Sync>(
        &self,
        items: &mut [T],
        (unsorted, order): (&[T], &[u32]),
        (first, depth): (usize, u32),
    ) -> Keyed {
        let Some((bit, at)) = self.split_or_gather(items, (unsorted, order), (first, depth)) else {
            return Keyed::Range(side_of(items));
        };
        let (l_items, r_items) = items.split_at_mut(at);
        let gather = (unsorted, order);
        let (l, r) = rayon::join(
            || self.sides(l_items, gather, (first, depth + 1)),
            || self.sides(r_items, gather, (first + at, depth + 1)),
        );
        Keyed::Split {
            bit,
            at,
            side: l.side().merge(r.side()),
            kids: Box::new([l, r]),
        }
    }

    /// Makes node `id` of `job` (over `items`, the job's own items, `tree`
    /// their key tree from [`Self::sides`]) and its subtree, top down: the
    /// node decision ([`decide`]) as the serial recursion makes it — a
    /// clip node where the empty-space cut-off finds a gap, a leaf where
    /// the clip nodes above reach the depth limit, else the keys' split,
    /// both sides side by side; a range built by the serial recursion.
    fn decided<T: Item + Send + Sync>(
        &self,
        tree: &Keyed,
        items: &mut [T],
        job: NodeJob,
        id: usize,
    ) -> Built {
        let (cfg, mut stats) = (self.route.cfg, BuildStats::default());
        let Keyed::Split { bit, at, kids, .. } = tree else {
            let sub = build_node(items, &job, cfg, &mut stats);
            return (vec![(id, Made::Subtree(sub))], stats);
        };
        let view = NodeView::of_side(
            (job.first, items.len(), job.depth),
            job.region,
            &job.side,
            job.candidate,
        );
        match decide(cfg, &view, &mut 0) {
            Decision::Split(..) => {}
            Decision::Leaf => {
                let leaf = BihNode::leaf(job.first as u32, items.len() as u32);
                return (vec![(id, Made::Node(leaf))], stats);
            }
            Decision::Clip(clip) => {
                stats.clip_nodes += 1;
                let children = self.route.ids.fetch_add(2, Ordering::Relaxed);
                let full = children + 1 - clip.empty;
                let (mut made, s) = self.decided(tree, items, job.clipped(clip.region), full);
                stats.add(&s);
                made.push((id, Made::Step(Step::Clip(clip), children, job)));
                return (made, stats);
            }
            Decision::Bin(_) => unreachable!("a keyed job's nodes are the global heuristic's"),
        }
        let from = job.first - self.base;
        let axis = self.spec.cell(self.keys[from], *bit).longest_axis();
        let [l, r] = [kids[0].side(), kids[1].side()];
        let planes = clip_planes(axis, &l, &r);
        let children = self.route.ids.fetch_add(2, Ordering::Relaxed);
        let regions = child_regions(job.region, axis, planes);
        let child = |k: usize, first: usize| NodeJob {
            first,
            depth: job.depth + 1,
            region: regions[k],
            candidate: self.spec.cell(self.keys[first - self.base], bit + 1),
            side: kids[k].side(),
        };
        let (lj, rj) = (child(0, job.first), child(1, job.first + at));
        let (l_items, r_items) = items.split_at_mut(*at);
        let ((mut made, ls), (rm, rs)) = rayon::join(
            || self.decided(&kids[0], l_items, lj, children),
            || self.decided(&kids[1], r_items, rj, children + 1),
        );
        made.extend(rm);
        made.push((
            id,
            Made::Node(BihNode::inner(children as u32, axis, planes[0], planes[1])),
        ));
        stats.add(&ls);
        stats.add(&rs);
        stats.items_partitioned += (l.count + r.count) as u64;
        stats.partitions += 1;
        (made, stats)
    }
}

/// A keyed range's key tree, its ranges gathered ([`Top::sides`]).
enum Keyed {
    /// A range built by the serial recursion: its items' side.
    Range(Side),
    /// Where its keys first differ: the bit, the first item on its right,
    /// the side of all its items, and its two halves.
    Split {
        bit: u32,
        at: usize,
        side: Side,
        kids: Box<[Keyed; 2]>,
    },
}

impl Keyed {
    fn side(&self) -> Side {
        match self {
            Keyed::Range(side) | Keyed::Split { side, .. } => *side,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parallel passes sort by key, stably, over several blocks and
    /// with passes that move nothing (keys that share a digit), on 1 and 3
    /// threads.
    #[test]
    fn the_parallel_radix_sort_is_a_stable_sort() {
        let n = 3 * BLOCK + 1234;
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for (bits, mask) in [(16, 0xff00u64), (32, 0xffff_ffff), (64, u64::MAX)] {
            let keys: Vec<u64> = (0..n).map(|_| next() & mask).collect();
            let mut want: Vec<(u64, u32)> = keys.iter().copied().zip(0..).collect();
            want.sort_by_key(|&(k, _)| k);
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let (mut k, mut v) = (keys.clone(), (0..n as u32).collect::<Vec<_>>());
                pool.install(|| sort_pairs(&mut k, &mut v, bits));
                let got: Vec<(u64, u32)> = k.into_iter().zip(v).collect();
                assert!(got == want, "{bits} bits, {threads} threads");
            }
        }
    }
}
