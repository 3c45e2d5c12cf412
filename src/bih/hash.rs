//! The tree's identity as one number: a hash of its shape, whatever the
//! node numbering. Two builders built the same tree exactly when their
//! hashes agree (up to a 64-bit collision): the same nodes reached the same
//! way from the root — kind, axis, clip planes, leaf range — and every leaf
//! the same set of triangles (their order inside a leaf is the partition's
//! business and left out). Printed in every build's JSON so that a reader
//! can see two reports name one tree.

use super::Bih;

/// FNV-1a, 64 bits (Fowler, Noll, Vo): fixed by its definition, so a tree
/// hashes alike on every host and with every version of every dependency.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn word(&mut self, w: u32) {
        for b in w.to_le_bytes() {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// A clip plane's bits, −0 as +0: the same plane (builders that compute
/// a bound in another order may reach either zero; `f32`'s `==` and every
/// ray's answer treat them alike).
fn plane_bits(x: f32) -> u32 {
    if x == 0.0 { 0 } else { x.to_bits() }
}

impl Bih {
    /// The hash of the tree's shape, walked from the root, left before
    /// right, each leaf's triangles as a sorted set.
    pub fn tree_hash(&self) -> u64 {
        let mut h = Fnv::new();
        let mut stack = vec![0u32];
        let mut ids = Vec::new();
        while let Some(i) = stack.pop() {
            let n = self.nodes[i as usize];
            if n.is_leaf() {
                let (first, count) = n.leaf_range();
                h.word(u32::MAX);
                h.word(first);
                h.word(count);
                ids.clear();
                ids.extend_from_slice(&self.prim_ids[first as usize..(first + count) as usize]);
                ids.sort_unstable();
                ids.iter().for_each(|&t| h.word(t));
            } else {
                let [lo, hi] = n.clip();
                h.word(n.axis() as u32);
                h.word(plane_bits(lo));
                h.word(plane_bits(hi));
                stack.push(n.left_child() + 1);
                stack.push(n.left_child());
            }
        }
        h.0
    }

    /// [`Bih::tree_hash`] as 16 hex digits, as reports print it.
    pub fn tree_hash_hex(&self) -> String {
        format!("{:016x}", self.tree_hash())
    }
}

#[cfg(test)]
mod tests {
    use crate::bih::{Bih, BihConfig, BihNode};

    fn tree(nodes: Vec<BihNode>, prim_ids: Vec<u32>) -> Bih {
        Bih {
            nodes,
            prim_ids,
            bounds: crate::aabb::Aabb::EMPTY,
            config: BihConfig::DEFAULT,
        }
    }

    #[test]
    fn the_hash_sees_the_shape_not_the_numbering_or_the_order_in_a_leaf() {
        // Root splitting on x; its children two leaves.
        let a = tree(
            vec![
                BihNode::inner(1, 0, 0.5, 0.4),
                BihNode::leaf(0, 2),
                BihNode::leaf(2, 1),
            ],
            vec![0, 1, 2],
        );
        let same_leaf_reordered = tree(a.nodes.clone(), vec![1, 0, 2]);
        assert_eq!(a.tree_hash(), same_leaf_reordered.tree_hash());
        let other_triangles = tree(a.nodes.clone(), vec![0, 2, 1]);
        assert_ne!(a.tree_hash(), other_triangles.tree_hash());
        let other_plane = tree(
            vec![BihNode::inner(1, 0, 0.5, 0.3), a.nodes[1], a.nodes[2]],
            a.prim_ids.clone(),
        );
        assert_ne!(a.tree_hash(), other_plane.tree_hash());
        let other_axis = tree(
            vec![BihNode::inner(1, 1, 0.5, 0.4), a.nodes[1], a.nodes[2]],
            a.prim_ids.clone(),
        );
        assert_ne!(a.tree_hash(), other_axis.tree_hash());
        // −0 and +0 are one plane.
        let negative_zero = tree(
            vec![BihNode::inner(1, 0, -0.0, 0.4), a.nodes[1], a.nodes[2]],
            a.prim_ids.clone(),
        );
        let zero = tree(
            vec![BihNode::inner(1, 0, 0.0, 0.4), a.nodes[1], a.nodes[2]],
            a.prim_ids.clone(),
        );
        assert_eq!(zero.tree_hash(), negative_zero.tree_hash());
        assert_ne!(zero.tree_hash(), a.tree_hash());
        // The same tree with its children stored elsewhere (a spare slot
        // at 1, the children at 2 and 3).
        let renumbered = tree(
            vec![
                BihNode::inner(2, 0, 0.5, 0.4),
                BihNode::leaf(0, 0),
                BihNode::leaf(0, 2),
                BihNode::leaf(2, 1),
            ],
            a.prim_ids.clone(),
        );
        assert_eq!(a.tree_hash(), renumbered.tree_hash());
        assert_eq!(a.tree_hash_hex().len(), 16);
    }
}
