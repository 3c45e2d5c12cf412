//! The PPE builders' passes over their triangle records through the PPE's
//! caches (section 4.1's naive and approximate builds on the PPE,
//! `cell::ppe_cache`): each pass loads every 128-byte line of the records
//! it reads, in the order the build makes its passes, and each load costs
//! the latency of the level that held its line (`kernels::ppe_rates::
//! loads_cycles`: the one PPE memory latency every PPE step pays). A
//! recursion over 48-byte records finds a node's records in the L2 once
//! its parent's fit there (10,922 records), and goes to memory above.
//!
//! These loads come on top of the fitted `ppe_partition_item`, which
//! Table 1's PPE column set with whatever memory stalls its builds had:
//! they move that column (docs/calibration.md says by how much), and the
//! rate is not refitted. A partition's stores find the lines its loads
//! brought; binned SAH's binning pass before a node's partition is not
//! replayed (its loads are the partition's lines, found again).

use crate::bih::BihNode;
use crate::cell::ppe_cache::{Loads, PpeCaches};
use crate::spe::layout::TriRecord;

/// Where the records lie in the PPE's address space, and the scatter's
/// second array (`ppe_approx`).
const RECORDS: u64 = 1 << 40;
const SCATTERED: u64 = 2 << 40;
const RECORD: u64 = size_of::<TriRecord>() as u64;

/// The PPE's caches as a build's passes meet them.
pub struct Passes {
    caches: PpeCaches,
}

impl Passes {
    /// Empty caches.
    pub fn cold() -> Self {
        Passes {
            caches: PpeCaches::ps3(),
        }
    }

    /// A pass over records `first .. end` of the records array.
    pub fn records(&mut self, (first, end): (usize, usize)) {
        let bytes = (end - first) as u64 * RECORD;
        self.caches
            .load_lines(RECORDS + first as u64 * RECORD, bytes);
    }

    /// A pass over the first `n` records of the scatter's second array.
    pub fn scattered(&mut self, n: usize) {
        self.caches.load_lines(SCATTERED, n as u64 * RECORD);
    }

    /// The partitions of the recursion below `nodes[0]`, in its order (a
    /// node, then its left subtree, then its right): every inner node
    /// whose children both hold triangles partitioned its records once
    /// (a clip node of the empty-space cut-off partitions nothing). Only
    /// the nodes `finished` admits are replayed (all, for the naive
    /// build); before the first of a subtree admitted below one that is
    /// not, its records' bounds pass.
    pub fn partitions(&mut self, nodes: &[BihNode], finished: impl Fn(u32) -> bool) {
        let spans = spans(nodes);
        let mut stack = vec![(0u32, false)];
        while let Some((id, inside)) = stack.pop() {
            let n = nodes[id as usize];
            if n.is_leaf() {
                continue;
            }
            let (c, span) = (n.left_child(), spans[id as usize]);
            let split = spans[c as usize].0 < spans[c as usize].1
                && spans[c as usize + 1].0 < spans[c as usize + 1].1;
            let mine = finished(id);
            if mine && !inside {
                self.records(span);
            }
            if mine && split {
                self.records(span);
            }
            stack.push((c + 1, mine));
            stack.push((c, mine));
        }
    }

    /// The loads so far, by level.
    pub fn loads(&self) -> Loads {
        self.caches.loads
    }
}

/// Each node's interval of the triangle order, `(first, end)`.
fn spans(nodes: &[BihNode]) -> Vec<(usize, usize)> {
    let mut spans = vec![(0, 0); nodes.len()];
    // Children come after their parent: a pass from the end sees both
    // children of a node before the node.
    let reachable = reachable(nodes);
    for id in (0..nodes.len()).rev().filter(|&i| reachable[i]) {
        let n = nodes[id];
        spans[id] = if n.is_leaf() {
            let (f, c) = n.leaf_range();
            (f as usize, (f + c) as usize)
        } else {
            let c = n.left_child() as usize;
            match (spans[c], spans[c + 1]) {
                (l, r) if l.0 == l.1 => r,
                (l, r) if r.0 == r.1 => l,
                (l, r) => (l.0.min(r.0), l.1.max(r.1)),
            }
        };
    }
    spans
}

fn reachable(nodes: &[BihNode]) -> Vec<bool> {
    let mut seen = vec![false; nodes.len()];
    let mut stack = vec![0usize];
    while let Some(id) = stack.pop() {
        seen[id] = true;
        let n = nodes[id];
        if !n.is_leaf() {
            stack.extend([n.left_child() as usize, n.left_child() as usize + 1]);
        }
    }
    seen
}
