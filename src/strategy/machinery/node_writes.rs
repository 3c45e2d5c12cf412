//! Nodes written straight into their slots (section 5's shared job queue:
//! a node's id comes from the arena of the SPE that split its parent, so
//! the SPE that makes it writes it wherever that arena put its slot).

use crate::bih::BihNode;
use crate::cell::{CellError, Ea, LsAddr, Spe, WaitMode};

/// Nodes written straight into their slots, wherever the slots lie: the
/// shared queue's nodes (`spe_bfs_shared`), whose ids the SPE that split
/// their parent handed out from its own arena. An SPE computes each
/// slot's address itself (pool base + id × 12 bytes) and writes the nodes
/// of a batch together: each run of consecutive ids as DMA-legal pieces
/// (4 or 8 bytes up to a 16-byte boundary, whole quadwords, 8 or 4 bytes
/// after), all in one `putl` (`Knobs::dma_lists`) or one put per piece.
/// No two SPEs write the same bytes, so no lock line is needed.
pub struct NodeWrites<'a> {
    spe: &'a Spe,
    base: Ea,
    pending: Vec<(u32, BihNode)>,
    staging: [LsAddr; 2],
    buf: usize,
    tags: u32,
    lists: bool,
    /// Nodes written, and DMA commands they took.
    pub nodes: u64,
    pub commands: u64,
    /// Added to every leaf's first place: a loop that builds a piece of
    /// the triangle order in an area of its own (places from 0) writes
    /// leaves of the whole order.
    pub leaf_base: u32,
}

/// Bytes of each of the two staging buffers.
const STAGING_BYTES: u32 = 16 * 1024;

impl<'a> NodeWrites<'a> {
    /// Node writes into the pool at `base`, as lists if `lists`.
    pub fn new(spe: &'a Spe, base: Ea, lists: bool) -> Result<Self, CellError> {
        Ok(NodeWrites {
            spe,
            base,
            pending: Vec::new(),
            staging: [
                spe.ls_alloc(STAGING_BYTES, 128)?,
                spe.ls_alloc(STAGING_BYTES, 128)?,
            ],
            buf: 0,
            tags: spe.tags("node writes", 2)?,
            lists,
            nodes: 0,
            commands: 0,
            leaf_base: 0,
        })
    }

    /// Node `id` is to be written (by the next [`NodeWrites::flush`]).
    pub fn push(&mut self, id: u32, node: BihNode) {
        let node = match node.is_leaf() {
            true => {
                let (first, count) = node.leaf_range();
                BihNode::leaf(first + self.leaf_base, count)
            }
            false => node,
        };
        self.pending.push((id, node));
    }

    /// Nodes waiting for [`NodeWrites::flush`].
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Writes the pending nodes (their puts may still be under way).
    pub async fn flush(&mut self) -> Result<(), CellError> {
        let mut nodes = std::mem::take(&mut self.pending);
        nodes.sort_by_key(|&(id, _)| id);
        self.nodes += nodes.len() as u64;
        // (effective address, bytes) of every piece, and the pieces' bytes.
        let mut pieces: Vec<(u64, u32)> = Vec::new();
        let mut bytes: Vec<u8> = Vec::new();
        let node_bytes = size_of::<BihNode>() as u64;
        let mut k = 0;
        while k < nodes.len() {
            let mut end = k + 1;
            while end < nodes.len() && nodes[end].0 == nodes[end - 1].0 + 1 {
                end += 1;
            }
            let start = self.base.0 + nodes[k].0 as u64 * node_bytes;
            for (_, n) in &nodes[k..end] {
                bytes.extend_from_slice(bytemuck::bytes_of(n));
            }
            dma_pieces(start, start + (end - k) as u64 * node_bytes, &mut pieces);
            k = end;
        }
        // Fill staging buffers: each piece at the next quadword with its
        // address's low four bits (the DMA-list rule, fine for puts too).
        let mut from = 0usize;
        let mut done = 0usize;
        while done < pieces.len() {
            let (ls, tag) = (self.staging[self.buf], self.tags + self.buf as u32);
            self.spe.wait_tag(tag).await?;
            let mut image = vec![0u8; STAGING_BYTES as usize];
            let mut list = Vec::new();
            let mut at = 0u32;
            while done < pieces.len() && list.len() < crate::cell::MAX_LIST_ELEMENTS {
                let (ea, size) = pieces[done];
                let slot = size.max(16);
                if at + slot > STAGING_BYTES {
                    break;
                }
                let place = (at | (ea & 15) as u32) as usize;
                image[place..place + size as usize]
                    .copy_from_slice(&bytes[from..from + size as usize]);
                list.push(crate::cell::ListElement { ea: Ea(ea), size });
                from += size as usize;
                at += slot;
                done += 1;
            }
            self.spe.ls_write(ls, &image[..at as usize])?;
            if self.lists {
                self.spe.putl(ls, &list, tag).await?;
                self.commands += 1;
            } else {
                let mut at = 0u32;
                for e in &list {
                    let place = LsAddr(ls.0 + (at | (e.ea.0 & 15) as u32));
                    self.spe.put(place, e.ea, e.size, tag).await?;
                    at += e.size.max(16);
                }
                self.commands += list.len() as u64;
            }
            self.buf = 1 - self.buf;
        }
        Ok(())
    }

    /// Flushes and waits until every node is in main memory.
    pub async fn finish(&mut self) -> Result<(), CellError> {
        self.flush().await?;
        let both = 0b11 << self.tags;
        self.spe.wait_tags(both, WaitMode::All).await.map(|_| ())
    }
}

/// Splits the bytes `start..end` of main memory (multiples of 4) into
/// transfers the MFC accepts: 4 or 8 bytes naturally aligned, or whole
/// 16-byte-aligned quadwords of at most 16 KiB.
fn dma_pieces(start: u64, end: u64, out: &mut Vec<(u64, u32)>) {
    debug_assert!(start.is_multiple_of(4) && end.is_multiple_of(4));
    let mut at = start;
    while at < end {
        let left = end - at;
        let size = if at.is_multiple_of(16) && left >= 16 {
            (left & !15).min(crate::cell::MAX_TRANSFER as u64)
        } else if at.is_multiple_of(8) && left >= 8 {
            8
        } else {
            4
        };
        out.push((at, size as u32));
        at += size;
    }
}

#[cfg(test)]
mod tests {
    use super::dma_pieces;

    #[test]
    fn pieces_cover_a_range_in_legal_transfers() {
        for start in (0..64u64).step_by(4) {
            for len in (4..200u64).step_by(4) {
                let mut p = Vec::new();
                dma_pieces(start, start + len, &mut p);
                let mut at = start;
                for &(ea, size) in &p {
                    assert_eq!(ea, at, "pieces are contiguous");
                    match size {
                        4 | 8 => assert!(ea.is_multiple_of(size as u64)),
                        n => assert!(n % 16 == 0 && ea.is_multiple_of(16)),
                    }
                    at += size as u64;
                }
                assert_eq!(at, start + len);
                assert!(p.len() <= 5, "{start}+{len}: {} pieces", p.len());
            }
        }
    }
}
