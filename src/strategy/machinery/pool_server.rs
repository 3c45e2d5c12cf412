//! The PPE's side of a growing ObjectArena pool (section 5's per-SPE
//! ObjectArena lists in one index space, grown as the paper's arena grows:
//! a block on request by mailbox). See `arena.rs`.

use super::arena_words::{BLOCK_BYTES, NODE_LINE, REQUEST_BLOCK, ea_word};
use crate::cell::{CellError, Ea, Ppe};
use crate::spe::footprint::Purpose;

/// The PPE's side of a pool's growth: allocates an overflow block for each
/// SPE that asks, at a whole number of nodes (and 128 bytes) past the
/// pool's base so that the SPE computes its ids from its address, until
/// every SPE has stopped. It waits as a PPE thread serving several SPEs
/// does (`Ppe::wait_any_out_mbox_or_stop`).
pub struct PoolServer {
    base: Ea,
    /// The end of the highest block: the pool's reach.
    end: Ea,
    spes: usize,
}

impl PoolServer {
    /// Serving `spes` SPEs, for the pool of `blocks` blocks at `base`.
    pub fn new(base: Ea, blocks: u32, spes: usize) -> Self {
        PoolServer {
            base,
            end: base.offset(blocks as u64 * BLOCK_BYTES),
            spes,
        }
    }

    /// Serves block requests until a word it does not know (returned with
    /// its SPE, for the strategy's own protocol) or until every SPE has
    /// stopped (`None`).
    pub async fn next(&mut self, ppe: &Ppe) -> Result<Option<(usize, u32)>, CellError> {
        let all: Vec<usize> = (0..self.spes).collect();
        while let Some((spe, w)) = ppe.wait_any_out_mbox_or_stop(&all).await? {
            if w != REQUEST_BLOCK {
                return Ok(Some((spe, w)));
            }
            let what = Purpose::Nodes.buffer("ObjectArena overflow block");
            let ea = ppe.alloc(what, BLOCK_BYTES + NODE_LINE, 128).await?;
            let pad = (NODE_LINE - (ea.0 - self.base.0) % NODE_LINE) % NODE_LINE;
            let block = ea.offset(pad);
            self.end = self.end.max(block.offset(BLOCK_BYTES));
            ppe.write_in_mbox(spe, ea_word(block)?).await?;
        }
        Ok(None)
    }

    /// Serves a strategy that has no protocol of its own: a word other than
    /// a request is an error. Returns the pool's reach.
    pub async fn serve(mut self, ppe: &Ppe) -> Result<Ea, CellError> {
        match self.next(ppe).await? {
            None => Ok(self.end),
            Some((spe, w)) => Err(CellError::Program {
                core: "PPE".into(),
                msg: format!("ObjectArena pool: unknown request {w} from SPE {spe}"),
            }),
        }
    }

    /// The end of the highest block handed out so far.
    pub fn end(&self) -> Ea {
        self.end
    }
}
