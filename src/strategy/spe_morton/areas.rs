//! What `spe_morton` lays out in main memory ([`Areas`]) and the PPE's
//! program ([`serve`]): the pool's overflow blocks and the region tables,
//! allocated when SPE 0 asks (section 5's Morton route, docs/morton.md).

use super::pairs::Pairs;
use super::{MortonKnobs, RECORD, REGIONS, SPILL_UNIT};
use super::{rekey, top};
use crate::cell::{Cell, CellError, Ea, Ppe};
use crate::kernels::radix;
use crate::spe::footprint::Purpose;
use crate::strategy::Setup;
use crate::strategy::machinery::arena::BlockSource;
use crate::strategy::machinery::pool_server::PoolServer;
use crate::strategy::machinery::top::Pool;

/// What the PPE lays out in main memory for the SPEs.
#[derive(Clone, Copy)]
pub(super) struct Areas {
    pub(super) n: usize,
    pub(super) spes: usize,
    pub(super) tris: Ea,
    /// `--permute`: the records in key order (else the PPE allocates them
    /// only if a region is too large for a local store: `Program::tables`).
    pub(super) sorted: Option<Ea>,
    /// The key pairs' width, and their two arrays.
    pub(super) pairs: Pairs,
    pub(super) keys: [Ea; 2],
    /// The keys array that holds them sorted (and, unless `--permute`, the
    /// triangle ids in the tree's order).
    pub(super) sorted_keys: Ea,
    /// The radix count table: a row of `1 << digit_bits` words per SPE.
    pub(super) counts: Ea,
    /// The static deal's header line: per SPE, the start and count of its
    /// positions in the deal array.
    pub(super) deal_header: Ea,
    /// The sub-tops of the top of the tree, and their bounds.
    pub(super) subtops: Ea,
    pub(super) sub_bounds: Ea,
    /// The ranges keyed again within their cells (`rekey`): their table,
    /// their subtrees' bounds, and the lock line whose word 0 counts them.
    pub(super) rekeys: Ea,
    pub(super) rekey_bounds: Ea,
    pub(super) rekey_line: Ea,
    /// Lock lines: barrier arrivals; the regions' line: word 0 the next
    /// sub-top, then region, to take, word 1 how many, words 2 to 7 where
    /// the PPE put the region tables (`Program::tables`), word 8 the spill
    /// units, words 9 on each SPE's first place in the region jobs.
    pub(super) arrivals: Ea,
    pub(super) take: Ea,
    pub(super) pool: Ea,
    pub(super) blocks: BlockSource,
}

impl Areas {
    /// The keys, the radix count table, the deal and barrier lines and
    /// (`--permute`) the records in key order, in main memory.
    pub(super) fn alloc(
        cell: &mut Cell,
        setup: &Setup,
        knobs: &MortonKnobs,
        pool: &Pool,
        spes: usize,
    ) -> Result<Self, CellError> {
        let (n, mut mem) = (setup.count, cell.memory_mut());
        let n64 = n as u64;
        let line = 128;
        let subtops = ((top::SUBTOPS_PER_SPE * spes + 1) * super::ranges::RANGE) as u64;
        let pairs = Pairs::for_bits(knobs.key_bits);
        let key_bytes = n64 * pairs.bytes as u64;
        let keys = [
            mem.alloc(Purpose::KeysAndSort.buffer("keys A"), key_bytes, 128)?,
            mem.alloc(Purpose::KeysAndSort.buffer("keys B"), key_bytes, 128)?,
        ];
        Ok(Areas {
            n,
            spes,
            tris: setup.triangles,
            sorted: match knobs.permute {
                true => Some(mem.alloc(
                    Purpose::TriangleRecords.buffer("records in key order"),
                    n64 * RECORD as u64,
                    128,
                )?),
                false => None,
            },
            pairs,
            keys,
            sorted_keys: keys[radix::passes(knobs.key_bits, knobs.digit_bits) as usize % 2],
            counts: mem.alloc(
                Purpose::KeysAndSort.buffer("radix count table"),
                spes as u64 * (4 << knobs.digit_bits),
                128,
            )?,
            deal_header: mem.alloc(Purpose::JobQueues.buffer("region deal header"), line, 128)?,
            subtops: mem.alloc(Purpose::JobQueues.buffer("sub-tops"), subtops, 128)?,
            sub_bounds: mem.alloc(Purpose::JobQueues.buffer("sub-top bounds"), subtops, 128)?,
            rekeys: mem.alloc(
                Purpose::JobQueues.buffer("ranges keyed again"),
                (rekey::MAX_REKEYS * size_of::<rekey::Found>()) as u64,
                128,
            )?,
            rekey_bounds: mem.alloc(
                Purpose::JobQueues.buffer("bounds of ranges keyed again"),
                rekey::MAX_REKEYS as u64 * 32,
                128,
            )?,
            rekey_line: mem.alloc(
                Purpose::JobQueues.buffer("ranges keyed again: count"),
                line,
                128,
            )?,
            arrivals: mem.alloc(Purpose::JobQueues.buffer("barrier arrivals"), line, 128)?,
            take: mem.alloc(Purpose::JobQueues.buffer("region counter"), line, 128)?,
            pool: pool.base,
            blocks: pool.blocks,
        })
    }
}

/// The region tables the PPE allocates once SPE 0 knows how many regions
/// the top of the tree made, in the order the PPE sends their addresses.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct RegionTables {
    /// The region jobs, largest first.
    pub(super) jobs: Ea,
    /// Their bounds, by the same position.
    pub(super) bounds: Ea,
    /// The static deal.
    pub(super) deal: Ea,
    /// Each unsorted place's sorted position.
    pub(super) positions: Ea,
    /// The large regions' WorkAPPE/WorkBPPE, a part for each SPE.
    pub(super) spill: Ea,
    /// Unless `--permute`: the large regions' records in key order, a
    /// part for each SPE.
    pub(super) sorted: Ea,
}

impl RegionTables {
    /// The tables, in the order the PPE allocates them and sends their
    /// addresses (and the take line holds them).
    pub(super) fn in_order(&mut self) -> [&mut Ea; 6] {
        [
            &mut self.jobs,
            &mut self.bounds,
            &mut self.deal,
            &mut self.positions,
            &mut self.spill,
            &mut self.sorted,
        ]
    }
}

/// The PPE's program: it only allocates — the pool's overflow blocks, and
/// the region tables once SPE 0 knows how many regions the top of the
/// tree made (memory to what the scene needs); returns the pool's reach.
pub(super) async fn serve(
    ppe: Ppe,
    mut server: PoolServer,
    knobs: MortonKnobs,
    spes: usize,
) -> Result<Ea, CellError> {
    while let Some((spe, word)) = server.next(&ppe).await? {
        if (spe, word) != (0, REGIONS) {
            return Err(CellError::Program {
                core: "PPE".into(),
                msg: format!("spe_morton: unknown request {word} from SPE {spe}"),
            });
        }
        let regions = ppe.read_out_mbox(0).await? as u64;
        // Per SPE: room for the largest region's two levels of jobs.
        let spill = ppe.read_out_mbox(0).await? as u64 * SPILL_UNIT * spes as u64;
        // Regions too large for a local store are built in key order, each
        // SPE's in its part of a records area sized for the largest.
        let largest = ppe.read_out_mbox(0).await? as u64;
        let sorted = match knobs.permute {
            false => spes as u64 * (largest * RECORD as u64).next_multiple_of(128),
            true => 0,
        };
        use Purpose::{JobQueues, TriangleRecords, WorkPpe};
        let slots = (regions * 4).next_multiple_of(16);
        for (purpose, what, bytes) in [
            (JobQueues, "spe_morton: region jobs", regions * 64),
            (JobQueues, "spe_morton: region bounds", regions * 32),
            (JobQueues, "spe_morton: region deal", slots),
            (JobQueues, "spe_morton: region positions", slots),
            (
                WorkPpe,
                "spe_morton: WorkAPPE/WorkBPPE of large regions",
                spill,
            ),
            (
                TriangleRecords,
                "spe_morton: records of the regions too large for a local store, a part for each SPE",
                sorted,
            ),
        ] {
            if bytes == 0 {
                ppe.write_in_mbox(0, 0).await?;
                continue;
            }
            let ea = ppe.alloc(purpose.buffer(what), bytes, 128).await?;
            let word = u32::try_from(ea.0).map_err(|_| CellError::Program {
                core: "PPE".into(),
                msg: format!("{what} at {ea} does not fit a mailbox word"),
            })?;
            ppe.write_in_mbox(0, word).await?;
        }
    }
    Ok(server.end())
}
