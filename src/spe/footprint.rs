//! Memory modelled to the scene: an emulated build's
//! main-memory footprint by purpose, made of the allocations its programs
//! labelled with a [`Purpose`] ([`Purpose::buffer`], carried by the
//! emulator as an opaque group: [`crate::cell::Allocation`]), and each
//! SPE's local-store high-water mark.
//!
//! Purposes: the triangle records (and every second copy of them: a
//! scatter, a key-ordered permutation, the cooperative partition's
//! scratch); `WorkAPPE`/`WorkBPPE` (Fig. 2's spill of the job queues to
//! main memory); the other job queues and synchronisation lines (shared and
//! dealt queues, descriptors, counters, barriers); the nodes (ObjectArena
//! pool and blocks, node arrays — their unused slots counted apart); keys
//! and sort buffers (Morton keys, radix count tables). The paper sizes
//! `WorkAPPE` and `WorkBPPE` "as the primitives count": a level never holds
//! more jobs than twice the nodes split in the level before, each of which
//! has more than a leaf's triangles, so `2 ⌊n / (leaf + 1)⌋ + 2` jobs
//! always suffice ([`work_ppe_jobs`]); [`Footprint::work_ppe_needed`] is
//! what the widest level of the tree actually held.

use crate::bih::Bih;
use crate::cell::{Allocation, Label, RunReport};

/// What a buffer of main memory is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Purpose {
    TriangleRecords,
    WorkPpe,
    JobQueues,
    Nodes,
    KeysAndSort,
}

impl Purpose {
    pub const ALL: [Purpose; 5] = [
        Purpose::TriangleRecords,
        Purpose::WorkPpe,
        Purpose::JobQueues,
        Purpose::Nodes,
        Purpose::KeysAndSort,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Purpose::TriangleRecords => "triangle records",
            Purpose::WorkPpe => "WorkAPPE/WorkBPPE",
            Purpose::JobQueues => "job queues and sync",
            Purpose::Nodes => "nodes (arena, arrays)",
            Purpose::KeysAndSort => "keys and sort",
        }
    }

    /// The label of a buffer named `name` for this purpose: a strategy
    /// allocates every buffer with one, and the footprint adds them up by
    /// purpose.
    pub fn buffer(self, name: impl Into<String>) -> Label {
        Label::new(self.name(), name)
    }

    /// The purpose a buffer was allocated for (its label's group).
    fn of(group: &str) -> Option<Purpose> {
        Purpose::ALL.into_iter().find(|p| p.name() == group)
    }
}

/// Jobs `WorkAPPE` (and `WorkBPPE`) must hold for `n` triangles and leaves
/// of `leaf_size`: at most `2 ⌊n / (leaf + 1)⌋` children of one level's
/// splits, and the root's level.
pub fn work_ppe_jobs(n: usize, leaf_size: u32) -> usize {
    2 * (n / (leaf_size as usize + 1)) + 2
}

/// A build's memory, by purpose.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Footprint {
    /// Bytes of main memory by purpose, in [`Purpose::ALL`]'s order.
    pub by_purpose: Vec<(Purpose, u64)>,
    /// Main memory in use at the end: every buffer, padding included.
    pub total: u64,
    /// Bytes of node buffers that hold no node of the tree (ObjectArena
    /// blocks' unused slots, pairs skipped to stay in one block, blocks
    /// reserved per SPE and never reached).
    pub unused_node_bytes: u64,
    /// Jobs the widest level of the tree held: what a level-by-level
    /// build's `WorkAPPE` must hold.
    pub work_ppe_needed: u64,
    /// Each SPE's local-store high-water mark, bytes (code and stack
    /// reserve included).
    pub ls_high_water: Vec<u32>,
    /// Buffers allocated without a purpose (empty unless a strategy adds a
    /// buffer and forgets to say what it is for).
    pub unknown: Vec<String>,
}

impl Footprint {
    /// The footprint of a run that built `bih`.
    pub fn of(run: &RunReport, bih: &Bih) -> Self {
        let mut by_purpose: Vec<(Purpose, u64)> = Purpose::ALL.iter().map(|&p| (p, 0)).collect();
        let mut unknown = Vec::new();
        for Allocation {
            what, group, bytes, ..
        } in &run.memory
        {
            match Purpose::of(group) {
                Some(p) => by_purpose.iter_mut().find(|(q, _)| *q == p).unwrap().1 += bytes,
                None => unknown.push(what.clone()),
            }
        }
        let nodes = by_purpose
            .iter()
            .find(|(p, _)| *p == Purpose::Nodes)
            .map_or(0, |x| x.1);
        let tree = (bih.nodes.len() * size_of::<crate::bih::BihNode>()) as u64;
        Footprint {
            by_purpose,
            total: run.memory_bytes,
            unused_node_bytes: nodes.saturating_sub(tree),
            work_ppe_needed: widest_level(bih),
            ls_high_water: (run.cores.iter().skip(1))
                .map(|(_, c)| c.ls_high_water)
                .collect(),
            unknown,
        }
    }

    pub fn bytes(&self, p: Purpose) -> u64 {
        self.by_purpose
            .iter()
            .find(|(q, _)| *q == p)
            .map_or(0, |x| x.1)
    }
}

/// The most nodes at one depth of `bih`: the jobs of its widest level.
pub fn widest_level(bih: &Bih) -> u64 {
    let mut per_depth: Vec<u64> = Vec::new();
    let mut stack = vec![(0u32, 0usize)];
    while let Some((id, d)) = stack.pop() {
        if per_depth.len() <= d {
            per_depth.resize(d + 1, 0);
        }
        per_depth[d] += 1;
        let n = bih.nodes[id as usize];
        if !n.is_leaf() {
            stack.extend([(n.left_child(), d + 1), (n.left_child() + 1, d + 1)]);
        }
    }
    per_depth.into_iter().max().unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bound_on_a_level_holds_for_every_leaf_size() {
        // The bound is tight for a full tree of leaves of one triangle:
        // n = 8, leaf 1: the last level has 8 jobs, the bound 2·4 + 2.
        assert_eq!(work_ppe_jobs(8, 1), 10);
        assert_eq!(work_ppe_jobs(1_000_000, 12), 2 * 76_923 + 2);
        assert!(work_ppe_jobs(5, 12) >= 1);
    }

    #[test]
    fn a_buffer_is_counted_for_the_purpose_it_was_allocated_for() {
        for p in Purpose::ALL {
            assert_eq!(Purpose::of(p.buffer("any name").group), Some(p));
        }
        let plain: Label = "a buffer with no purpose".into();
        assert_eq!(Purpose::of(plain.group), None);
    }
}
