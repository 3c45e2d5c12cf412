//! What an ObjectArena's SPE side (`arena`) and the PPE that serves its
//! blocks (`arena::serve_blocks`, `pool_server`) agree on (section 2,
//! Fig. 2; section 5): the blocks' sizes, the outbound-mailbox words, how
//! an address travels in a mailbox word, and where a pool's slot lies.

use crate::bih::BihNode;
use crate::cell::{CellError, Ea};

/// Nodes per local-store node buffer: 16,320 bytes, a multiple of 48 so
/// that every put is a multiple of 16 bytes.
pub const NODES_PER_PUT: usize = 1360;
/// Nodes per ObjectArena block: three puts (48,960 bytes).
pub const BLOCK_NODES: usize = 3 * NODES_PER_PUT;
/// Bytes of one block.
pub const BLOCK_BYTES: u64 = (BLOCK_NODES * size_of::<BihNode>()) as u64;

/// Outbound-mailbox words from the SPE to the PPE (`Mailbox` source, and
/// a pool's overflow blocks).
pub const REQUEST_BLOCK: u32 = 1;
pub const DONE: u32 = 2;

/// Bytes between overflow blocks' starts and the pool's base are a
/// multiple of this: whole nodes (12 bytes) and whole lines (128).
pub const NODE_LINE: u64 = 384;

/// An effective address as one 32-bit mailbox word.
pub fn ea_word(ea: Ea) -> Result<u32, CellError> {
    u32::try_from(ea.0).map_err(|_| CellError::Program {
        core: "PPE".into(),
        msg: format!("address {:#x} does not fit a mailbox word", ea.0),
    })
}

/// The slot (node id) at address `ea` of the pool at `base`.
pub fn slot_of(base: Ea, ea: Ea) -> u32 {
    debug_assert!(ea.0 >= base.0 && (ea.0 - base.0).is_multiple_of(NODE_LINE));
    ((ea.0 - base.0) / size_of::<BihNode>() as u64) as u32
}
