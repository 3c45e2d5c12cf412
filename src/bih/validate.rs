//! Tree invariants: [`Bih::validate`] checks them all and its error names
//! the first violation, for property tests and people alike.
//!
//! Checked: node indices in range and no node reached twice; leaf ranges in
//! range and every triangle in exactly one leaf; each triangle's box on its
//! side of every ancestor's clip plane (left: `max <= clip[0]`, right:
//! `min >= clip[1]`) and inside the root region; no NaN plane; depth within
//! the limit; the leaf-size limit kept unless no split could separate the
//! leaf's triangles (their box centers all coincide) or the depth limit was
//! reached.

use glam::Vec3;
use thiserror::Error;

use super::Bih;
use crate::aabb::Aabb;
use crate::scene::Scene;

#[derive(Debug, Error, PartialEq)]
pub enum Violation {
    #[error("the tree has no nodes")]
    NoNodes,
    #[error("the tree indexes {tree} triangles but the scene has {scene}")]
    SizeMismatch { tree: usize, scene: usize },
    #[error("node {node}: child index {child} is out of range ({nodes} nodes)")]
    ChildOutOfRange { node: u32, child: u32, nodes: usize },
    #[error("node {node} is reached twice")]
    ReachedTwice { node: u32 },
    #[error("node {node}: leaf range {first}..{end} is out of range ({len} triangles)")]
    LeafOutOfRange {
        node: u32,
        first: u32,
        end: u64,
        len: usize,
    },
    #[error("node {node}: a clip plane is NaN")]
    NanPlane { node: u32 },
    #[error("node {node} is at depth {depth}, deeper than the limit {max_depth}")]
    TooDeep {
        node: u32,
        depth: u32,
        max_depth: u32,
    },
    #[error("slot {slot} of the triangle order is in no leaf or in two")]
    SlotCoverage { slot: usize },
    #[error("triangle {prim} is in {count} leaves, not exactly one")]
    TriangleCoverage { prim: u32, count: u32 },
    #[error("triangle id {prim} is out of range")]
    PrimOutOfRange { prim: u32 },
    #[error(
        "triangle {prim} in leaf {node}: its box {lo:?}..{hi:?} crosses an ancestor's clip plane or leaves the root region (allowed {min:?}..{max:?})"
    )]
    OutsidePlanes {
        prim: u32,
        node: u32,
        lo: Vec3,
        hi: Vec3,
        min: Vec3,
        max: Vec3,
    },
    #[error(
        "leaf {node} holds {count} triangles, over the limit {limit}, though a split could separate them"
    )]
    LeafTooBig { node: u32, count: u32, limit: u32 },
}

impl Bih {
    /// Checks every invariant; the error names the first violation found.
    pub fn validate(&self, scene: &Scene) -> Result<(), Violation> {
        let n = scene.len();
        if self.nodes.is_empty() {
            return Err(Violation::NoNodes);
        }
        if self.prim_ids.len() != n {
            return Err(Violation::SizeMismatch {
                tree: self.prim_ids.len(),
                scene: n,
            });
        }
        let mut prim_seen = vec![0u32; n];
        for &p in &self.prim_ids {
            let Some(c) = prim_seen.get_mut(p as usize) else {
                return Err(Violation::PrimOutOfRange { prim: p });
            };
            *c += 1;
        }
        if let Some((prim, &count)) = prim_seen.iter().enumerate().find(|(_, c)| **c != 1) {
            return Err(Violation::TriangleCoverage {
                prim: prim as u32,
                count,
            });
        }

        let mut node_seen = vec![false; self.nodes.len()];
        let mut slot_seen = vec![false; n];
        // (node, depth, allowed region: max of ancestors' right planes ..
        // min of ancestors' left planes, within the root region)
        let mut stack = vec![(0u32, 0u32, self.bounds)];
        while let Some((id, depth, region)) = stack.pop() {
            if std::mem::replace(&mut node_seen[id as usize], true) {
                return Err(Violation::ReachedTwice { node: id });
            }
            if depth > self.config.max_depth {
                return Err(Violation::TooDeep {
                    node: id,
                    depth,
                    max_depth: self.config.max_depth,
                });
            }
            let node = self.nodes[id as usize];
            if node.is_leaf() {
                self.check_leaf(scene, id, depth, region, &mut slot_seen)?;
                continue;
            }
            let [cl, cr] = node.clip();
            if cl.is_nan() || cr.is_nan() {
                return Err(Violation::NanPlane { node: id });
            }
            let left = node.left_child();
            if left as usize + 1 >= self.nodes.len() {
                return Err(Violation::ChildOutOfRange {
                    node: id,
                    child: left + 1,
                    nodes: self.nodes.len(),
                });
            }
            let a = node.axis();
            let mut lr = region;
            lr.max[a] = lr.max[a].min(cl);
            let mut rr = region;
            rr.min[a] = rr.min[a].max(cr);
            stack.push((left + 1, depth + 1, rr));
            stack.push((left, depth + 1, lr));
        }
        if let Some(slot) = slot_seen.iter().position(|s| !s) {
            return Err(Violation::SlotCoverage { slot });
        }
        Ok(())
    }

    fn check_leaf(
        &self,
        scene: &Scene,
        id: u32,
        depth: u32,
        region: Aabb,
        slot_seen: &mut [bool],
    ) -> Result<(), Violation> {
        let (first, count) = self.nodes[id as usize].leaf_range();
        let end = first as u64 + count as u64;
        if end > slot_seen.len() as u64 {
            return Err(Violation::LeafOutOfRange {
                node: id,
                first,
                end,
                len: slot_seen.len(),
            });
        }
        let slots = first as usize..end as usize;
        if slot_seen[slots.clone()].iter().any(|&s| s) {
            return Err(Violation::SlotCoverage {
                slot: slots.clone().find(|&s| slot_seen[s]).unwrap(),
            });
        }
        slot_seen[slots.clone()].fill(true);
        let mut centers = Aabb::EMPTY;
        for &prim in &self.prim_ids[slots] {
            let b = scene.triangles[prim as usize].bounds();
            if !region.contains_box(&b) {
                return Err(Violation::OutsidePlanes {
                    prim,
                    node: id,
                    lo: b.min,
                    hi: b.max,
                    min: region.min,
                    max: region.max,
                });
            }
            centers = centers.grow(b.min * 0.5 + b.max * 0.5);
        }
        let separable = count > 1 && centers.min != centers.max;
        if count > self.config.leaf_size && separable && depth < self.config.max_depth {
            return Err(Violation::LeafTooBig {
                node: id,
                count,
                limit: self.config.leaf_size,
            });
        }
        Ok(())
    }
}
