//! The compact BIH node of Wächter & Keller ("Instant ray tracing: the
//! bounding interval hierarchy", EGSR 2006): 12 bytes, plain old data, so it
//! can travel by DMA between main memory and an SPE's local store as is.
//!
//! Layout (three little-endian 32-bit words):
//!
//! | word | inner node                                   | leaf                      |
//! |------|----------------------------------------------|---------------------------|
//! | 0    | `left_child << 2 \| axis` (axis 0, 1 or 2)   | `first << 2 \| 3`         |
//! | 1    | `clip[0]`: f32 bits, the left child's max    | triangle count            |
//! | 2    | `clip[1]`: f32 bits, the right child's min   | 0                         |
//!
//! The two children of an inner node are adjacent: the right child is at
//! `left_child + 1`. A leaf's triangles are `prim_ids[first .. first + count]`.

/// Value of the two low bits of word 0 that marks a leaf.
const LEAF: u32 = 3;
/// Largest child index or first triangle that fits in 30 bits.
pub const MAX_INDEX: u32 = (1 << 30) - 1;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BihNode {
    word: u32,
    a: u32,
    b: u32,
}
const _: () = assert!(std::mem::size_of::<BihNode>() == 12);

impl BihNode {
    /// An inner node splitting on `axis`, whose children are at `left_child`
    /// and `left_child + 1`; `clip_left` bounds the left child from above,
    /// `clip_right` bounds the right child from below.
    pub fn inner(left_child: u32, axis: usize, clip_left: f32, clip_right: f32) -> Self {
        assert!(
            left_child <= MAX_INDEX,
            "child index {left_child} does not fit in 30 bits"
        );
        assert!(axis < 3, "axis {axis} is not 0, 1 or 2");
        BihNode {
            word: (left_child << 2) | axis as u32,
            a: clip_left.to_bits(),
            b: clip_right.to_bits(),
        }
    }

    /// A leaf holding `prim_ids[first .. first + count]`.
    pub fn leaf(first: u32, count: u32) -> Self {
        assert!(
            first <= MAX_INDEX,
            "first triangle {first} does not fit in 30 bits"
        );
        BihNode {
            word: (first << 2) | LEAF,
            a: count,
            b: 0,
        }
    }

    /// A leaf as [`BihNode::leaf`] with `number` in word 2 (zero in a
    /// tree): the host tracer numbers its leaves there, the index of the
    /// leaf's box in its own table.
    pub fn numbered_leaf(first: u32, count: u32, number: u32) -> Self {
        BihNode {
            b: number,
            ..Self::leaf(first, count)
        }
    }

    /// Word 2 of a leaf: its number where the host tracer gave one.
    pub fn leaf_number(&self) -> u32 {
        debug_assert!(self.is_leaf());
        self.b
    }

    pub fn is_leaf(&self) -> bool {
        self.word & 3 == LEAF
    }

    /// Split axis of an inner node.
    pub fn axis(&self) -> usize {
        debug_assert!(!self.is_leaf());
        (self.word & 3) as usize
    }

    /// Index of the left child; the right child is the next node.
    pub fn left_child(&self) -> u32 {
        debug_assert!(!self.is_leaf());
        self.word >> 2
    }

    /// `[left child's max, right child's min]` on the split axis.
    pub fn clip(&self) -> [f32; 2] {
        debug_assert!(!self.is_leaf());
        [f32::from_bits(self.a), f32::from_bits(self.b)]
    }

    /// `(first, count)` of a leaf.
    pub fn leaf_range(&self) -> (u32, u32) {
        debug_assert!(self.is_leaf());
        (self.word >> 2, self.a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inner_and_leaf_round_trip_through_their_words() {
        let n = BihNode::inner(12345, 2, -1.5, 2.25);
        assert!(!n.is_leaf());
        assert_eq!(
            (n.left_child(), n.axis(), n.clip()),
            (12345, 2, [-1.5, 2.25])
        );
        let words: [u32; 3] = bytemuck::cast(n);
        assert_eq!(
            words,
            [12345 << 2 | 2, (-1.5f32).to_bits(), 2.25f32.to_bits()]
        );
        let l = BihNode::leaf(MAX_INDEX, 7);
        assert!(l.is_leaf());
        assert_eq!(l.leaf_range(), (MAX_INDEX, 7));
        assert_eq!(
            bytemuck::cast::<BihNode, [u32; 3]>(l),
            [MAX_INDEX << 2 | 3, 7, 0]
        );
    }

    #[test]
    #[should_panic(expected = "does not fit in 30 bits")]
    fn an_index_past_30_bits_is_refused() {
        BihNode::leaf(MAX_INDEX + 1, 1);
    }
}
