//! The **ObjectArena** (section 2, Fig. 2; section 5): where an SPE writes
//! the nodes it makes. Blocks of [`BLOCK_NODES`] nodes live in main memory;
//! the SPE fills a local-store node buffer and puts it into the current
//! block in 16 KiB puts, two buffers alternating so that one fills while
//! the other's put is under way. Nodes come in the order of their ids, so
//! the SPE computes each node's address itself: the block `id /
//! BLOCK_NODES` of its list, offset `id % BLOCK_NODES`.
//!
//! Where blocks come from ([`BlockSource`]):
//!
//! - `Mailbox`, the paper's: the PPE allocates a block when the SPE asks
//!   (outbound mailbox, [`REQUEST_BLOCK`]); the address comes back in the
//!   inbound mailbox. The SPE asks one block ahead, so the PPE's answer is
//!   usually there before it is needed. [`serve_blocks`] is the PPE's side.
//! - `Pool`: the PPE sizes a pool of blocks in advance and SPEs take blocks
//!   from it by fetch-and-add on a counter (the atomic unit): no PPE work
//!   and no mailbox per block, and several SPEs never queue behind one PPE.
//!   All SPEs' arenas then share one index space (section 5's per-SPE
//!   ObjectArena lists): a node's id is its slot in the pool (its address
//!   is the pool's base + id × 12 bytes), so each SPE computes the ids of
//!   the nodes it allocates alone. A pair of children never straddles two
//!   blocks (the slot it would leave is wasted), so the two stay adjacent
//!   as the node format requires. The pool is sized for the 2n + 1 nodes of
//!   a tree of the paper's settings; an SPE that finds it used up (the
//!   empty-space cut-off's clip nodes) asks the PPE for an overflow block
//!   by mailbox, as the paper's arena does, and the PPE places it at a
//!   whole number of nodes from the base (`pool_server::PoolServer`), so
//!   ids stay slots.
//!
//! Ids are handed out by [`ObjectArena::alloc`] and nodes must be emitted
//! in the order their ids were handed out. A node whose id another arena
//! handed out is written with [`ObjectArena::emit_foreign`] (a lock-line
//! update, since one node is 12 bytes and DMA moves multiples of 16).

use super::arena_words::{ea_word, slot_of};
use crate::bih::BihNode;
use crate::cell::{CellError, Ea, LsAddr, Ppe, Reservation, Spe, WaitMode};
use crate::spe::footprint::Purpose;

pub use super::arena_words::{BLOCK_BYTES, BLOCK_NODES, DONE, NODES_PER_PUT, REQUEST_BLOCK};

/// Where an arena's blocks come from.
#[derive(Clone, Copy, Debug)]
pub enum BlockSource {
    /// The PPE allocates each block on request ([`serve_blocks`]).
    Mailbox,
    /// Blocks `0..blocks` of a pool at `base`, taken by fetch-and-add on
    /// the `u32` counter at `counter` (128-byte aligned line); past them,
    /// overflow blocks from the PPE (`pool_server::PoolServer`) if it `grows`.
    Pool {
        base: Ea,
        blocks: u32,
        counter: Ea,
        grows: bool,
    },
}

/// What an arena used.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ArenaStats {
    /// Blocks taken.
    pub blocks: u64,
    /// Nodes written into its blocks.
    pub nodes: u64,
    /// Slots skipped to keep a pair in one block.
    pub skipped: u64,
    /// Nodes written into other arenas' slots (lock-line updates).
    pub foreign: u64,
    /// Blocks asked of the PPE once the pool was used up.
    pub overflow: u64,
}

/// One SPE's ObjectArena: its node buffers and its list of blocks.
pub struct ObjectArena<'a> {
    spe: &'a Spe,
    source: BlockSource,
    /// The two node buffers, the one being filled, its nodes, and the id of
    /// its first node.
    bufs: [LsAddr; 2],
    buf: usize,
    nodes: Vec<BihNode>,
    nodes_first: usize,
    /// This SPE's blocks, in the order of the node ids they hold.
    blocks: Vec<Ea>,
    /// Pool source: the id of each block's first slot.
    pool_blocks: Vec<u32>,
    /// The next slot of this arena's sequence to hand out.
    alloc_seq: usize,
    /// Slots skipped so that a pair stays in one block (emitted as zero
    /// nodes, never reached), in order.
    wasted: std::collections::VecDeque<usize>,
    pub stats: ArenaStats,
    /// Line buffer for the pool counter's fetch-and-add.
    line: Option<LsAddr>,
    tags: u32,
    /// The block runs come from ([`ObjectArena::alloc_run`]): its first
    /// slot's id and the slots handed out of it.
    run_block: Option<(u32, usize)>,
    /// Nodes handed out as runs (their padding is unused).
    run_nodes: usize,
}

impl<'a> ObjectArena<'a> {
    /// Allocates the node buffers in `spe`'s local store.
    pub fn new(spe: &'a Spe, source: BlockSource) -> Result<Self, CellError> {
        let bytes = (NODES_PER_PUT * size_of::<BihNode>()) as u32;
        let bufs = [spe.ls_alloc(bytes, 128)?, spe.ls_alloc(bytes, 128)?];
        let line = match source {
            BlockSource::Pool { .. } => Some(spe.ls_alloc(128, 128)?),
            BlockSource::Mailbox => None,
        };
        let tags = spe.tags("ObjectArena node puts", 2)?;
        Ok(Self::in_buffers(spe, source, bufs, line, tags))
    }

    /// An empty arena in local-store buffers allocated already.
    fn in_buffers(
        spe: &'a Spe,
        source: BlockSource,
        bufs: [LsAddr; 2],
        line: Option<LsAddr>,
        tags: u32,
    ) -> Self {
        ObjectArena {
            spe,
            source,
            bufs,
            buf: 0,
            nodes: Vec::with_capacity(NODES_PER_PUT),
            nodes_first: 0,
            blocks: Vec::new(),
            pool_blocks: Vec::new(),
            alloc_seq: 0,
            wasted: Default::default(),
            stats: ArenaStats::default(),
            line,
            tags,
            run_block: None,
            run_nodes: 0,
        }
    }

    /// Asks for the first block (with the `Mailbox` source, before any work
    /// so that the answer is there when the first nodes are).
    pub async fn open(&mut self) {
        if let BlockSource::Mailbox = self.source {
            self.spe.write_out_mbox(REQUEST_BLOCK).await;
        }
    }

    /// Hands out `count` (1 or 2) adjacent node ids of this arena.
    pub async fn alloc(&mut self, count: usize) -> Result<u32, CellError> {
        if let BlockSource::Mailbox = self.source {
            // One SPE, blocks in id order: the id is the slot.
            let id = self.alloc_seq;
            self.alloc_seq += count;
            return Ok(id as u32);
        }
        if count == 2 && self.alloc_seq % BLOCK_NODES == BLOCK_NODES - 1 {
            self.wasted.push_back(self.alloc_seq);
            self.stats.skipped += 1;
            self.alloc_seq += 1;
        }
        while self.pool_blocks.len() * BLOCK_NODES < self.alloc_seq + count {
            let (k, ea) = self.take_pool_block().await?;
            self.pool_blocks.push(k);
            self.blocks.push(ea);
        }
        let id = self.id_of(self.alloc_seq);
        self.alloc_seq += count;
        Ok(id)
    }

    /// `count` adjacent slots outside this arena's sequence, their first
    /// 16-byte aligned and their number rounded up to a multiple of 4, so
    /// that nodes made elsewhere in the local store (a subtree finished
    /// there, children in adjacent pairs) go out in whole quadwords by
    /// DMA; returns the first slot's id. They come from a block of their
    /// own, taken from the pool as the sequence's blocks are; what is left
    /// of it when the next run does not fit stays unused. A pool arena
    /// only, `count` at most [`BLOCK_NODES`].
    pub async fn alloc_run(&mut self, count: usize) -> Result<u32, CellError> {
        assert!(count <= BLOCK_NODES, "a run fits one block");
        let slots = count.next_multiple_of(4);
        let (first, used) = match self.run_block {
            Some((first, used)) if used + slots <= BLOCK_NODES => (first, used),
            _ => (self.take_pool_block().await?.0, 0),
        };
        debug_assert!(first.is_multiple_of(4), "blocks start at whole quadwords");
        self.run_block = Some((first, used + slots));
        self.run_nodes += count;
        Ok(first + used as u32)
    }

    /// The pool's base: node `id` lies at base + id × 12 bytes (a pool
    /// arena only).
    pub fn pool_base(&self) -> Ea {
        match self.source {
            BlockSource::Pool { base, .. } => base,
            BlockSource::Mailbox => unreachable!("a mailbox arena's ids are not slots"),
        }
    }

    /// Slots handed out so far (skipped ones included).
    pub fn allocated(&self) -> usize {
        self.alloc_seq
    }

    /// Slots of this arena's blocks that hold no node: skipped ones and
    /// those past the last handed out.
    pub fn unused(&self) -> u64 {
        let slots = self.stats.blocks as usize * BLOCK_NODES;
        (slots.saturating_sub(self.alloc_seq + self.run_nodes)) as u64 + self.stats.skipped
    }

    /// The id of slot `seq` of this arena.
    fn id_of(&self, seq: usize) -> u32 {
        match self.source {
            BlockSource::Mailbox => seq as u32,
            BlockSource::Pool { .. } => {
                self.pool_blocks[seq / BLOCK_NODES] + (seq % BLOCK_NODES) as u32
            }
        }
    }

    /// Records node `id`; nodes come in the order [`ObjectArena::alloc`]
    /// handed their ids out.
    pub async fn emit(&mut self, id: u32, node: BihNode) -> Result<(), CellError> {
        while self.wasted.front() == Some(&(self.nodes_first + self.nodes.len())) {
            self.wasted.pop_front();
            self.push(BihNode::default()).await?;
        }
        debug_assert_eq!(id, self.id_of(self.nodes_first + self.nodes.len()));
        self.stats.nodes += 1;
        self.push(node).await
    }

    async fn push(&mut self, node: BihNode) -> Result<(), CellError> {
        self.nodes.push(node);
        if self.nodes.len() == NODES_PER_PUT {
            self.flush(false).await?;
        }
        Ok(())
    }

    /// Writes node `id`, a slot another arena of the pool handed out, by
    /// lock-line updates of the one or two 128-byte lines it lies in (other
    /// SPEs may write other nodes of those lines at the same time).
    pub async fn emit_foreign(&mut self, id: u32, node: BihNode) -> Result<(), CellError> {
        let BlockSource::Pool { base, .. } = self.source else {
            panic!("foreign nodes exist only in a pool");
        };
        let line = self.line.expect("a line buffer");
        let bytes: [u8; 12] = bytemuck::cast(node);
        let at = base.0 + id as u64 * size_of::<BihNode>() as u64;
        let mut done = 0usize;
        while done < bytes.len() {
            let ea = at + done as u64;
            let line_ea = Ea(ea & !127);
            let off = (ea & 127) as usize;
            let n = (128 - off).min(bytes.len() - done);
            loop {
                self.spe.getllar(line, line_ea).await?;
                self.spe.with_ls_mut(line, 128, |l: &mut [u8]| {
                    l[off..off + n].copy_from_slice(&bytes[done..done + n]);
                })?;
                if self.spe.putllc(line, line_ea).await? == Reservation::Stored {
                    break;
                }
            }
            done += n;
        }
        self.stats.foreign += 1;
        Ok(())
    }

    /// Writes the last nodes, waits for every put, and (`Mailbox`) tells
    /// the PPE that `count` nodes were made. Returns the blocks.
    pub async fn close(&mut self, count: usize) -> Result<Vec<Ea>, CellError> {
        self.flush(true).await?;
        let both = 0b11 << self.tags;
        self.spe.wait_tags(both, WaitMode::All).await?;
        if let BlockSource::Mailbox = self.source {
            self.spe.write_out_mbox(DONE).await;
            self.spe.write_out_mbox(count as u32).await;
        }
        Ok(std::mem::take(&mut self.blocks))
    }

    /// A new, empty list of blocks from `source` in this arena's
    /// local-store buffers (after [`ObjectArena::close`]: every put is
    /// done), so that a second phase costs no second pair of buffers.
    pub fn renew(&mut self, source: BlockSource) {
        debug_assert!(self.nodes.is_empty());
        debug_assert!(matches!(source, BlockSource::Mailbox) || self.line.is_some());
        *self = Self::in_buffers(self.spe, source, self.bufs, self.line, self.tags);
    }

    /// A block of the pool, by fetch-and-add, or once the pool is used up
    /// an overflow block from the PPE: the id of its first slot and its
    /// address.
    async fn take_pool_block(&mut self) -> Result<(u32, Ea), CellError> {
        let BlockSource::Pool {
            base,
            blocks,
            counter,
            grows,
        } = self.source
        else {
            unreachable!("only a pool has blocks to take");
        };
        let line = self.line.expect("a line buffer");
        let k = self.spe.atomic_fetch_add_u32(line, counter, 1).await?;
        self.stats.blocks += 1;
        if k < blocks {
            let first = k as usize * BLOCK_NODES;
            return Ok((first as u32, base.offset(k as u64 * BLOCK_BYTES)));
        }
        if !grows {
            return Err(CellError::Program {
                core: format!("SPE {}", self.spe.id()),
                msg: format!(
                    "the ObjectArena pool of {blocks} blocks is used up (it holds 2n + 1 \
                     nodes, every node a tree without the empty-space cut-off can have)"
                ),
            });
        }
        self.spe.write_out_mbox(REQUEST_BLOCK).await;
        let ea = Ea(self.spe.read_in_mbox().await as u64);
        self.stats.overflow += 1;
        Ok((slot_of(base, ea), ea))
    }

    /// The next block of a `Mailbox` arena: the one asked for ahead
    /// arrives; ask for the one after.
    async fn next_block(&mut self, last: bool) -> Result<Ea, CellError> {
        let ea = Ea(self.spe.read_in_mbox().await as u64);
        if !last {
            self.spe.write_out_mbox(REQUEST_BLOCK).await;
        }
        self.stats.blocks += 1;
        Ok(ea)
    }

    /// Puts the node buffer into its block (padded to whole 48-byte groups
    /// at the end), switching buffers.
    async fn flush(&mut self, last: bool) -> Result<(), CellError> {
        if self.nodes.is_empty() {
            return Ok(());
        }
        let block_index = self.nodes_first / BLOCK_NODES;
        if self.blocks.len() <= block_index {
            // Only a mailbox arena takes blocks as it writes; a pool's were
            // taken when their ids were handed out.
            let ea = self.next_block(last).await?;
            self.blocks.push(ea);
        }
        let ls = self.bufs[self.buf];
        let tag = self.tags + self.buf as u32;
        // The put from this buffer two flushes ago is done before refilling.
        self.spe.wait_tag(tag).await?;
        let mut group = std::mem::take(&mut self.nodes);
        group.resize(group.len().next_multiple_of(4), BihNode::default());
        self.spe.ls_write(ls, &group)?;
        let offset = (self.nodes_first % BLOCK_NODES) * size_of::<BihNode>();
        let ea = self.blocks[block_index].offset(offset as u64);
        let bytes = (group.len() * size_of::<BihNode>()) as u32;
        self.spe.put(ls, ea, bytes, tag).await?;
        self.nodes_first += NODES_PER_PUT;
        self.buf = 1 - self.buf;
        Ok(())
    }
}

/// The PPE's side of the `Mailbox` source for SPE `spe`: allocates a block
/// for each request until the SPE says it is done; returns the blocks and
/// the number of nodes made.
pub async fn serve_blocks(ppe: &Ppe, spe: usize) -> Result<(Vec<Ea>, usize), CellError> {
    let mut blocks = Vec::new();
    loop {
        match ppe.read_out_mbox(spe).await? {
            REQUEST_BLOCK => {
                let ea = ppe
                    .alloc(Purpose::Nodes.buffer("ObjectArena block"), BLOCK_BYTES, 128)
                    .await?;
                blocks.push(ea);
                ppe.write_in_mbox(spe, ea_word(ea)?).await?;
            }
            DONE => return Ok((blocks, ppe.read_out_mbox(spe).await? as usize)),
            w => {
                return Err(CellError::Program {
                    core: "PPE".into(),
                    msg: format!("ObjectArena: unknown request {w} from SPE {spe}"),
                });
            }
        }
    }
}

/// The pieces (address, node count) of `count` nodes written block by
/// block into `blocks`, in node-id order.
pub fn pieces(blocks: &[Ea], count: usize) -> Vec<(Ea, usize)> {
    blocks
        .iter()
        .enumerate()
        .map(|(i, &ea)| (ea, BLOCK_NODES.min(count.saturating_sub(i * BLOCK_NODES))))
        .filter(|&(_, c)| c > 0)
        .collect()
}
