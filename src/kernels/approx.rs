//! Construction by approximate sorting (Wächter & Keller, 2006), as the
//! paper's `ppe_approx` uses it (section 4.1, Table 1).
//!
//! 1. **Bucket presort**: a regular grid over the scene box, its resolution
//!    the scene's extent over the average triangle extent on each axis
//!    (scaled down to at most one cell per triangle); one pass counts the
//!    triangles per cell by the center of their box (W&K count one corner;
//!    the center is the point this project's partition tests), a prefix sum
//!    gives each cell its interval, a second pass scatters the triangles into
//!    a second array, bucket by bucket.
//! 2. **Upper levels over buckets**: the non-empty buckets, each with the
//!    box of its triangles, are the objects of the global heuristic; a node
//!    stops at one bucket, at the leaf size, or when no split separates its
//!    buckets' centers.
//! 3. **Finish**: the triangles are gathered in the final bucket order; a
//!    node left with more than the leaf size (12) is subdivided by the naive
//!    recursion ([`build_subtree`]), as the paper's system does — the reason
//!    the paper saw 1.8x where W&K report 3–4x.

use glam::Vec3A;

use super::recursion::{BuildStats, Item, build_subtree};
use super::split::{Boxed, Side, choose_split, clip_planes, partition, side_of};
use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, BihNode};

/// At most this many cells per axis (the default of `--approx-cells`).
pub const MAX_RESOLUTION: usize = 1024;

/// The work an approximate build did, for the PPE's cost model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ApproxStats {
    /// Cells of the grid per axis.
    pub grid: [u32; 3],
    /// Non-empty buckets.
    pub buckets: u64,
    /// Triangles looked at by the presort: counting, scattering, gathering.
    pub items_sorted: u64,
    /// Buckets looked at by the partitions of the upper levels.
    pub buckets_partitioned: u64,
    /// The naive finish below the buckets (its bounds passes included).
    pub naive: BuildStats,
    /// Nodes of the whole tree.
    pub nodes: u64,
    /// Nodes of the upper levels: the naive finish's nodes come after.
    pub upper_nodes: u64,
}

/// A bucket as an object of the upper levels: the box of its triangles and
/// its interval of the scattered array.
#[derive(Clone, Copy, Debug)]
struct Bucket {
    lo: Vec3A,
    hi: Vec3A,
    first: u32,
    count: u32,
}

impl Boxed for Bucket {
    fn lo(&self) -> Vec3A {
        self.lo
    }
    fn hi(&self) -> Vec3A {
        self.hi
    }
}

/// Builds a tree over `items` with `region` as the scene box and at most
/// `max_cells` grid cells per axis (1 to [`MAX_RESOLUTION`]). Returns the
/// items in their final order (the tree's leaves index it), the tree, and
/// the work done.
pub fn build_approx<T: Item>(
    items: &[T],
    region: Aabb,
    cfg: &BihConfig,
    max_cells: usize,
) -> (Vec<T>, Bih, ApproxStats) {
    assert!(!items.is_empty(), "a scene has at least one triangle");
    let n = items.len();
    let mut stats = ApproxStats::default();

    // 1. Bucket presort.
    let res = resolution(items, region, max_cells.clamp(1, MAX_RESOLUTION));
    stats.grid = res.map(|r| r as u32);
    // In f64: a scene may span more than f32::MAX.
    let (lo, ext) = (region.min.as_dvec3(), region.extent_f64());
    let cell_of = |c: Vec3A| -> usize {
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let t = if ext[a] > 0.0 {
                (c[a] as f64 - lo[a]) / ext[a]
            } else {
                0.0
            };
            idx[a] = ((t * res[a] as f64) as usize).min(res[a] - 1);
        }
        (idx[2] * res[1] + idx[1]) * res[0] + idx[0]
    };
    let cells: Vec<usize> = items.iter().map(|it| cell_of(it.center())).collect();
    let mut start = vec![0u32; res[0] * res[1] * res[2] + 1];
    for &c in &cells {
        start[c + 1] += 1;
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut next = start.clone();
    let mut scattered = items.to_vec();
    let mut boxes = vec![(Vec3A::INFINITY, Vec3A::NEG_INFINITY); start.len() - 1];
    for (it, &c) in items.iter().zip(&cells) {
        scattered[next[c] as usize] = *it;
        next[c] += 1;
        boxes[c] = (boxes[c].0.min(it.lo()), boxes[c].1.max(it.hi()));
    }
    let mut buckets: Vec<Bucket> = (0..start.len() - 1)
        .filter(|&c| start[c + 1] > start[c])
        .map(|c| Bucket {
            lo: boxes[c].0,
            hi: boxes[c].1,
            first: start[c],
            count: start[c + 1] - start[c],
        })
        .collect();
    stats.buckets = buckets.len() as u64;

    // 2. Upper levels over the buckets.
    let mut nodes = vec![BihNode::default()];
    // Nodes to finish: (node, bucket interval, candidate, depth).
    let mut open: Vec<(usize, usize, usize, Aabb, u32)> = Vec::new();
    let mut stack = vec![(0usize, 0usize, buckets.len(), region, 0u32)];
    while let Some((id, first, count, mut candidate, depth)) = stack.pop() {
        let range = first..first + count;
        let triangles: u32 = buckets[range.clone()].iter().map(|b| b.count).sum();
        let side = side_of(&buckets[range.clone()]);
        let split = if count == 1 || triangles <= cfg.leaf_size || depth >= cfg.max_depth {
            None
        } else {
            choose_split(&mut candidate, &side.centers())
        };
        let Some(split) = split else {
            open.push((id, first, count, candidate, depth));
            continue;
        };
        let (l, r): (Side, Side) = partition(&mut buckets[range], split);
        stats.buckets_partitioned += count as u64;
        let children = nodes.len();
        nodes.extend([BihNode::default(); 2]);
        let [cl, cr] = clip_planes(split.axis, &l, &r);
        nodes[id] = BihNode::inner(children as u32, split.axis, cl, cr);
        let [lc, rc] = split.candidates(candidate);
        stack.push((children + 1, first + l.count, r.count, rc, depth + 1));
        stack.push((children, first, l.count, lc, depth + 1));
    }

    stats.upper_nodes = nodes.len() as u64;
    // 3. Gather in bucket order, then finish every open node.
    let mut sorted = Vec::with_capacity(n);
    let mut bucket_first = Vec::with_capacity(buckets.len() + 1);
    for b in &buckets {
        bucket_first.push(sorted.len());
        sorted.extend_from_slice(&scattered[b.first as usize..(b.first + b.count) as usize]);
    }
    bucket_first.push(sorted.len());
    stats.items_sorted = 3 * n as u64;
    for (id, first, count, candidate, depth) in open {
        let (tf, tl) = (bucket_first[first], bucket_first[first + count]);
        if cfg.ends_in_leaf(tl - tf, depth) {
            nodes[id] = BihNode::leaf(tf as u32, (tl - tf) as u32);
            continue;
        }
        let s = build_subtree(
            &mut sorted,
            &mut nodes,
            id,
            tf,
            tl - tf,
            candidate,
            depth,
            cfg,
        );
        stats.naive.items_partitioned += s.items_partitioned;
        stats.naive.partitions += s.partitions;
    }
    stats.nodes = nodes.len() as u64;
    let bih = Bih {
        nodes,
        prim_ids: sorted.iter().map(T::id).collect(),
        bounds: region,
        config: *cfg,
    };
    (sorted, bih, stats)
}

/// Cells per axis: the scene's extent over the average triangle extent,
/// scaled down so that there are at most as many cells as triangles.
fn resolution<T: Boxed>(items: &[T], region: Aabb, max_cells: usize) -> [usize; 3] {
    let n = items.len();
    let mut sum = [0f64; 3];
    for it in items {
        let (lo, hi) = (it.lo(), it.hi());
        for (a, s) in sum.iter_mut().enumerate() {
            *s += hi[a] as f64 - lo[a] as f64;
        }
    }
    let ext = region.extent_f64();
    let mut res = [1f64; 3];
    for a in 0..3 {
        let avg = sum[a] / n as f64;
        if ext[a] > 0.0 {
            res[a] = if avg > 0.0 {
                (ext[a] / avg).ceil()
            } else {
                max_cells as f64
            };
            res[a] = res[a].clamp(1.0, max_cells as f64);
        }
    }
    let cells = res[0] * res[1] * res[2];
    if cells > n as f64 {
        let f = (n as f64 / cells).cbrt();
        for r in &mut res {
            *r = (*r * f).floor().max(1.0);
        }
    }
    res.map(|r| r as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::recursion::PrimRef;
    use glam::Vec3;

    fn refs(boxes: &[(Vec3, Vec3)]) -> Vec<PrimRef> {
        boxes
            .iter()
            .enumerate()
            .map(|(i, &(a, b))| PrimRef::new(i as u32, Aabb::new(a, b)))
            .collect()
    }

    #[test]
    fn the_grid_has_at_most_one_cell_per_triangle() {
        // 1,000 unit boxes on a line 1,000 long: extent / size = 1,000 on x.
        let items = refs(
            &(0..1000)
                .map(|i| {
                    (
                        Vec3::new(i as f32, 0.0, 0.0),
                        Vec3::new(i as f32 + 1.0, 1.0, 1.0),
                    )
                })
                .collect::<Vec<_>>(),
        );
        let region = Aabb::new(Vec3::ZERO, Vec3::new(1000.0, 1.0, 1.0));
        assert_eq!(resolution(&items, region, MAX_RESOLUTION), [1000, 1, 1]);
        assert_eq!(resolution(&items, region, 64), [64, 1, 1]);
        // A cube of 1,000 boxes of size 1 in a 100-unit cube: 100³ cells
        // scaled down to 10³.
        let items = refs(
            &(0..1000)
                .map(|i| {
                    let p =
                        Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32) * 10.0;
                    (p, p + Vec3::ONE)
                })
                .collect::<Vec<_>>(),
        );
        let region = Aabb::new(Vec3::ZERO, Vec3::splat(100.0));
        let r = resolution(&items, region, MAX_RESOLUTION);
        assert!(r.iter().product::<usize>() <= 1000, "{r:?}");
        assert!(r.iter().all(|&x| x >= 9), "{r:?}");
    }

    #[test]
    fn every_triangle_lands_in_one_leaf_and_big_buckets_are_finished_naively() {
        // 100 stacks of 30 boxes, 0.01 apart in z: every bucket holds 30
        // triangles, more than the leaf size, so the naive finish must
        // split them.
        let mut boxes = Vec::new();
        for s in 0..100 {
            let p = Vec3::new((s % 10) as f32 * 10.0, (s / 10) as f32 * 10.0, 0.0);
            for k in 0..30 {
                let q = p + Vec3::new(0.0, 0.0, k as f32 * 0.01);
                boxes.push((q, q + Vec3::ONE));
            }
        }
        let items = refs(&boxes);
        let region = items
            .iter()
            .fold(Aabb::new(Vec3::INFINITY, Vec3::NEG_INFINITY), |b, it| {
                b.union(Aabb::new(it.lo().into(), it.hi().into()))
            });
        let (sorted, bih, stats) =
            build_approx(&items, region, &BihConfig::default(), MAX_RESOLUTION);
        let mut ids: Vec<u32> = sorted.iter().map(|t| t.id()).collect();
        ids.sort_unstable();
        assert_eq!(ids, (0..3000).collect::<Vec<u32>>());
        assert_eq!(stats.items_sorted, 9000);
        assert!(stats.buckets >= 2);
        assert!(stats.naive.partitions > 0, "{stats:?}");
        let mut leaf_total = 0;
        for n in bih.nodes.iter().filter(|n| n.is_leaf()) {
            leaf_total += n.leaf_range().1;
            assert!(n.leaf_range().1 <= 12, "leaf of {}", n.leaf_range().1);
        }
        assert_eq!(leaf_total, 3000);
    }
}
