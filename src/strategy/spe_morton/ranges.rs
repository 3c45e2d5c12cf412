//! The ranges of sorted keys the top of `spe_morton`'s tree splits
//! (section 5's Morton route): each becomes a node, and the top and the
//! re-keying of ranges whose keys ran out both read and write them.

use bytemuck::{Pod, Zeroable};

/// A range of sorted keys still to split: 32 bytes in the sub-top table.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(super) struct Range {
    pub(super) first: u32,
    pub(super) count: u32,
    /// The node it becomes.
    pub(super) id: u32,
    pub(super) depth: u32,
    /// Key bits its cell has consumed.
    pub(super) used: u32,
    /// The keys it is split by: `Program::specs` (0 the scene's, then one
    /// per re-keyed range).
    pub(super) spec: u32,
    pub(super) pad: [u32; 2],
}
pub(super) const RANGE: usize = size_of::<Range>();
