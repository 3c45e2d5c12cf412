//! Tree quality: what a tree will cost to trace, beside what it cost to
//! build. SAH cost, node and leaf counts, depth, triangles per leaf.
//!
//! SAH cost (Goldsmith & Salmon 1987; MacDonald & Booth 1990) of a BIH: a
//! node's *region* is its parent's region clipped by the node's plane (the
//! root's is the scene box); the probability that a ray through the root
//! visits a node is area(region) / area(root). Then
//!
//! `cost = C_TRAVERSAL · Σ_inner P(n) + C_TRIANGLE · Σ_leaves P(n) · count(n)`.
//!
//! The constants are 1 and 1: one node step and one triangle test cost the
//! same, close to what our traversal measures (both are a handful of `f64`
//! operations and a load), and the convention of many BVH papers. For a
//! scene whose box has zero area (all triangles on a line) every P is 1.

pub mod agree;
pub mod rays;

use serde::Serialize;

use crate::aabb::Aabb;
use crate::bih::Bih;

/// Cost of stepping through one inner node, in SAH units.
pub const C_TRAVERSAL: f64 = 1.0;
/// Cost of one ray/triangle test, in SAH units.
pub const C_TRIANGLE: f64 = 1.0;

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Quality {
    pub sah_cost: f64,
    pub nodes: usize,
    pub inner_nodes: usize,
    pub leaves: usize,
    pub max_depth: u32,
    /// Mean depth of leaves, weighted by triangles (the depth an average
    /// triangle sits at).
    pub mean_leaf_depth: f64,
    pub max_leaf_triangles: u32,
    pub mean_leaf_triangles: f64,
    pub memory_bytes: usize,
}

impl Bih {
    pub fn quality(&self) -> Quality {
        let root_area = self.bounds.surface_area();
        let prob = |b: &Aabb| {
            if root_area > 0.0 {
                b.surface_area() / root_area
            } else {
                1.0
            }
        };
        let mut q = Quality {
            sah_cost: 0.0,
            nodes: 0,
            inner_nodes: 0,
            leaves: 0,
            max_depth: 0,
            mean_leaf_depth: 0.0,
            max_leaf_triangles: 0,
            mean_leaf_triangles: 0.0,
            memory_bytes: self.memory_bytes(),
        };
        let mut depth_sum = 0.0;
        let mut stack = vec![(0u32, 0u32, self.bounds)];
        while let Some((id, depth, region)) = stack.pop() {
            let node = self.nodes[id as usize];
            q.nodes += 1;
            q.max_depth = q.max_depth.max(depth);
            if node.is_leaf() {
                let (_, count) = node.leaf_range();
                q.leaves += 1;
                q.sah_cost += C_TRIANGLE * prob(&region) * count as f64;
                q.max_leaf_triangles = q.max_leaf_triangles.max(count);
                depth_sum += depth as f64 * count as f64;
                continue;
            }
            q.inner_nodes += 1;
            q.sah_cost += C_TRAVERSAL * prob(&region);
            let a = node.axis();
            let [cl, cr] = node.clip();
            let (mut lr, mut rr) = (region, region);
            lr.max[a] = lr.max[a].min(cl);
            rr.min[a] = rr.min[a].max(cr);
            stack.push((node.left_child(), depth + 1, lr));
            stack.push((node.left_child() + 1, depth + 1, rr));
        }
        let tris = self.prim_ids.len().max(1) as f64;
        q.mean_leaf_depth = depth_sum / tris;
        q.mean_leaf_triangles = self.prim_ids.len() as f64 / q.leaves.max(1) as f64;
        q
    }
}

/// The Pareto front of `points` (x, y), both to be minimised: the indices
/// of the points no other point beats or equals on both with one strictly
/// better, in order of increasing x (ties of x: the lower y only). A point
/// with a NaN coordinate is never on it.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| !points[i].0.is_nan() && !points[i].1.is_nan())
        .collect();
    order.sort_by(|&a, &b| {
        (points[a].0.total_cmp(&points[b].0)).then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best_y = f64::INFINITY;
    for i in order {
        if points[i].1 < best_y {
            best_y = points[i].1;
            front.push(i);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_keeps_exactly_the_points_nothing_beats() {
        // (build, ray cost): 0 and 2 and 4 are the trade; 1 is beaten by 0,
        // 3 by 2, 5 ties 4's x with a worse y; 6 is NaN.
        let p = [
            (1.0, 10.0),
            (2.0, 11.0),
            (3.0, 5.0),
            (4.0, 5.0),
            (9.0, 1.0),
            (9.0, 2.0),
            (f64::NAN, 0.0),
        ];
        assert_eq!(pareto_front(&p), vec![0, 2, 4]);
        // Brute force: a point is on the front iff no other dominates it.
        let dominated = |i: usize| {
            (0..6).any(|j| {
                j != i
                    && p[j].0 <= p[i].0
                    && p[j].1 <= p[i].1
                    && (p[j].0 < p[i].0 || p[j].1 < p[i].1)
            })
        };
        for i in 0..6 {
            assert_eq!(pareto_front(&p).contains(&i), !dominated(i), "point {i}");
        }
        assert_eq!(pareto_front(&[]), Vec::<usize>::new());
    }
}
