//! `spe_morton` — section 5's second proposal: "a pre-processing step
//! using Morton curves is performed to find regions of primitives that then
//! could be built-up totally independent", with the Morton codes computed
//! on the SPEs and "a radix sort [...] on the Cell B. E." (the keys and the
//! passes are the shared kernels of `build::morton` and `build::radix`).
//!
//! 1. **Keys**: each SPE streams its slice of the triangle records and
//!    writes a (key, record index) pair per triangle (`Knobs::key_order`,
//!    `Knobs::key_bits`).
//! 2. **Radix sort**, LSD, `Knobs::digit_bits` a pass: each SPE counts the
//!    digits of its slice and writes its row of the count table; after a
//!    barrier each reads the table, prefix-sums its offsets and scatters
//!    its pairs to their places, each block's pairs as one DMA list (`putl`)
//!    of runs of consecutive places.
//! 3. **Permutation**: each SPE gathers the records of its slice of sorted
//!    pairs with a DMA list (`getl`) and writes them, in key order, to a
//!    second record array where the tree is built.
//! 4. **The top of the tree** (SPE 0): a node wherever a range's keys first
//!    differ (Karras 2012), found by binary search over the sorted keys in
//!    main memory, down to **regions** of at most `Knobs::region_size`
//!    triangles (or ranges that share their whole key, or leaves).
//! 5. **Independent subtrees**: every SPE takes regions largest first from
//!    an atomic counter (or, `Knobs::static_regions`, from its own dealt
//!    list) and builds each alone: a region that fits in the local store is
//!    loaded once, built there with the global heuristic and written back
//!    once; a larger one is split depth first by Fig. 1's streaming
//!    partition until its pieces fit. Nodes go straight into slots of the
//!    per-SPE ObjectArena lists of one pool. Each region's bounds go to a
//!    table, from which SPE 0 finally writes the top nodes' clip planes.
//!
//! With the global heuristic's order the splits are the baseline's, so the
//! tree is the baseline's tree.

use std::cell::RefCell;
use std::rc::Rc;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::arena::{BlockSource, NodeWrites, ObjectArena};
use super::fig1::{Fig1Buffers, partition_in_place, stream_bounds};
use super::layout::TriRecord;
use super::spe_bfs::Job;
use super::top::alloc_pool;
use super::{Knobs, Output, Setup};
use crate::aabb::Aabb;
use crate::bih::{BihConfig, BihNode};
use crate::build::Builder;
use crate::build::host::build_subtree;
use crate::build::kernels::{Boxed, Side, choose_split, clip_planes, side_of};
use crate::build::morton::{KeyOrder, KeySpec};
use crate::build::radix;
use crate::cell::{Cell, CellError, Cycles, Ea, ListElement, LsAddr, Spe, WaitMode};

/// `spe_morton` in the registry of builders.
pub const BUILDER: Builder = Builder::multi_spe(
    "spe_morton",
    "section 5: Morton keys and a radix sort on the SPEs, the top of the tree from the sorted keys, then regions built independently, one SPE each, in the local store where they fit (--spes)",
    spawn,
);

/// A key and the index of its triangle record: 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct KeyRec {
    key: u64,
    index: u32,
    pad: u32,
}

/// One DMA block of records (341 of 48 bytes) and of key pairs (1,024).
const RECORDS_PER_BLOCK: usize = (16 * 1024) / size_of::<TriRecord>();
const KEYS_PER_BLOCK: usize = (16 * 1024) / size_of::<KeyRec>();

/// What the PPE lays out in main memory for the SPEs.
#[derive(Clone, Copy)]
struct Areas {
    n: usize,
    spes: usize,
    tris: Ea,
    sorted: Ea,
    keys: [Ea; 2],
    /// The radix count table: a row of `1 << digit_bits` words per SPE.
    counts: Ea,
    /// Region jobs, largest first; their bounds (32 bytes each), by the
    /// same position; the static deal (per SPE: start and count in the
    /// header line, then positions).
    regions: Ea,
    bounds: Ea,
    deal_header: Ea,
    deal: Ea,
    /// Lock lines: barrier arrivals; word 0 the next region to take,
    /// word 1 the number of regions.
    arrivals: Ea,
    take: Ea,
    pool: Ea,
    blocks: BlockSource,
}

fn spawn(
    cell: &mut Cell,
    setup: &Setup,
    cfg: &BihConfig,
    out: Rc<RefCell<Output>>,
) -> Result<(), CellError> {
    let (n, knobs, cfg) = (setup.count, setup.knobs, *cfg);
    let bad = |msg: String| Err(CellError::Config(format!("spe_morton: {msg}")));
    if knobs.key_bits != 32 && knobs.key_bits != 64 {
        return bad(format!("{}-bit keys; 32 or 64", knobs.key_bits));
    }
    if !(4..=11).contains(&knobs.digit_bits) {
        return bad(format!("{}-bit digits; 4 to 11", knobs.digit_bits));
    }
    if knobs.region_size == 0 {
        return bad("regions of 0 triangles".into());
    }
    let spes = cell.config().spes;
    let (pool, blocks) = alloc_pool(cell, n, &out)?;
    // Regions: every top leaf holds a triangle, and a range is split only
    // above the region size: at most n regions, and fewer than
    // 2 n / region size + 1 where no leaf or depth limit cuts in.
    let max_regions = n.max(1);
    let mut mem = cell.memory_mut();
    let n64 = n as u64;
    let line = 128;
    let a = Areas {
        n,
        spes,
        tris: setup.triangles,
        sorted: mem.alloc("records in key order", n64 * 48, 128)?,
        keys: [
            mem.alloc("keys A", n64 * 16, 128)?,
            mem.alloc("keys B", n64 * 16, 128)?,
        ],
        counts: mem.alloc(
            "radix count table",
            spes as u64 * (4 << knobs.digit_bits),
            128,
        )?,
        regions: mem.alloc("regions", max_regions as u64 * 64, 128)?,
        bounds: mem.alloc("region bounds", max_regions as u64 * 32, 128)?,
        deal_header: mem.alloc("region deal header", line, 128)?,
        deal: mem.alloc(
            "region deal",
            (max_regions as u64 * 4).next_multiple_of(16),
            128,
        )?,
        arrivals: mem.alloc("barrier arrivals", line, 128)?,
        take: mem.alloc("region counter", line, 128)?,
        pool,
        blocks,
    };
    drop(mem);
    out.borrow_mut().records = Some(a.sorted);
    let spec = KeySpec {
        order: knobs.key_order,
        bits: knobs.key_bits,
        scene: setup.region,
    };
    for id in 0..spes {
        let out = out.clone();
        cell.spawn_spe(id, move |spe| async move {
            let mut p = Program::new(&spe, a, spec, knobs, cfg)?;
            p.run(&out).await
        });
    }
    Ok(())
}

/// A barrier of every SPE on one lock line: arrivals counted by
/// fetch-and-add; the last to arrive signals the others (register 2).
struct Barrier {
    rounds: u32,
}

impl Barrier {
    async fn wait(&mut self, spe: &Spe, line: LsAddr, a: &Areas) -> Result<(), CellError> {
        self.rounds += 1;
        let old = spe.atomic_fetch_add_u32(line, a.arrivals, 1).await?;
        if old + 1 == self.rounds * a.spes as u32 {
            for to in (0..a.spes).filter(|&s| s != spe.id()) {
                spe.send_signal(to, 2, 1).await?;
            }
        } else {
            spe.read_signal(2).await?;
        }
        Ok(())
    }
}

/// One node of the top of the tree, as SPE 0 keeps it until the regions'
/// bounds are known.
enum Top {
    Inner {
        id: u32,
        children: u32,
        axis: usize,
        /// Top indices of the two children.
        kids: [usize; 2],
    },
    Region(usize),
}

/// One SPE's program.
struct Program<'a> {
    spe: &'a Spe,
    a: Areas,
    spec: KeySpec,
    knobs: Knobs,
    cfg: BihConfig,
    line: LsAddr,
    tags: u32,
    barrier: Barrier,
    arena: ObjectArena<'a>,
    writes: NodeWrites<'a>,
    items_partitioned: u64,
    partitions: u64,
    regions_built: u64,
    /// SPE 0: each phase and the cycle it ended at.
    phases: Vec<(&'static str, u64)>,
}

/// Names of the radix passes, for the phase list.
const PASSES: [&str; 16] = [
    "radix pass 1",
    "radix pass 2",
    "radix pass 3",
    "radix pass 4",
    "radix pass 5",
    "radix pass 6",
    "radix pass 7",
    "radix pass 8",
    "radix pass 9",
    "radix pass 10",
    "radix pass 11",
    "radix pass 12",
    "radix pass 13",
    "radix pass 14",
    "radix pass 15",
    "radix pass 16",
];

impl<'a> Program<'a> {
    fn new(
        spe: &'a Spe,
        a: Areas,
        spec: KeySpec,
        knobs: Knobs,
        cfg: BihConfig,
    ) -> Result<Self, CellError> {
        Ok(Program {
            spe,
            a,
            spec,
            knobs,
            cfg,
            line: spe.ls_alloc(128, 128)?,
            tags: spe.tags("spe_morton streams", 4)?,
            barrier: Barrier { rounds: 0 },
            arena: ObjectArena::new(spe, a.blocks)?,
            writes: NodeWrites::new(spe, a.pool, true)?,
            items_partitioned: 0,
            partitions: 0,
            regions_built: 0,
            phases: Vec::new(),
        })
    }

    /// This SPE's slice of `0..n`.
    fn slice(&self) -> (usize, usize) {
        let (n, s, id) = (self.a.n, self.a.spes, self.spe.id());
        (n * id / s, n * (id + 1) / s)
    }

    async fn barrier(&mut self) -> Result<(), CellError> {
        let (spe, line, a) = (self.spe, self.line, self.a);
        self.barrier.wait(spe, line, &a).await
    }

    /// A barrier that ends a phase (SPE 0 notes when).
    async fn end_phase(&mut self, name: &'static str) -> Result<(), CellError> {
        self.barrier().await?;
        if self.spe.id() == 0 {
            self.phases.push((name, self.spe.now().0));
        }
        Ok(())
    }

    async fn run(&mut self, out: &RefCell<Output>) -> Result<(), CellError> {
        let mark = self.spe.ls_mark();
        let bufs = [
            self.spe.ls_alloc(16 * 1024, 128)?,
            self.spe.ls_alloc(16 * 1024, 128)?,
            self.spe.ls_alloc(16 * 1024, 128)?,
            self.spe.ls_alloc(16 * 1024, 128)?,
        ];
        self.keys(bufs).await?;
        self.end_phase("Morton keys").await?;
        let passes = radix::passes(self.knobs.key_bits, self.knobs.digit_bits);
        for pass in 0..passes {
            self.radix_pass(pass, bufs).await?;
            self.end_phase(PASSES[pass as usize]).await?;
        }
        let keys = self.a.keys[passes as usize % 2];
        self.permute(keys, bufs).await?;
        self.end_phase("permutation").await?;
        self.spe.ls_release_to(mark);
        let top = if self.spe.id() == 0 {
            Some(self.top(keys).await?)
        } else {
            None
        };
        self.end_phase("top of the tree").await?;
        self.build_regions().await?;
        self.end_phase("regions").await?;
        if let Some(top) = top {
            self.write_top(&top).await?;
        }
        self.writes.finish().await?;
        let count = self.arena.allocated();
        self.arena.close(count).await?;
        let mut o = out.borrow_mut();
        if self.spe.id() == 0 {
            self.phases.push(("top nodes", self.spe.now().0));
            o.phases = std::mem::take(&mut self.phases);
        }
        o.stats.items_partitioned += self.items_partitioned;
        o.stats.partitions += self.partitions;
        let w = &mut o.spe_work[self.spe.id()];
        w.jobs = self.writes.nodes;
        w.taken = self.regions_built;
        w.arena_blocks = self.arena.stats.blocks;
        w.arena_unused = self.arena.unused();
        Ok(())
    }

    /// Issues the get of block `k` of `count` elements of `size` bytes at
    /// `ea`, `per_block` a block, into `bufs[k % 2]` (tag `tags + k % 2`);
    /// returns the block's first element and length.
    async fn get_block(
        &self,
        ea: Ea,
        size: usize,
        count: usize,
        per_block: usize,
        k: usize,
        bufs: [LsAddr; 4],
    ) -> Result<(usize, usize), CellError> {
        let first = k * per_block;
        let len = per_block.min(count - first);
        let (buf, tag) = (bufs[k % 2], self.tags + (k % 2) as u32);
        let at = ea.offset((first * size) as u64);
        self.spe.get(buf, at, (len * size) as u32, tag).await?;
        Ok((first, len))
    }

    /// Block `k` of a stream: waits for its get after issuing the next
    /// block's (so that the transfer overlaps this block's work).
    async fn next_block(
        &self,
        ea: Ea,
        size: usize,
        count: usize,
        per_block: usize,
        k: usize,
        bufs: [LsAddr; 4],
    ) -> Result<(usize, usize, LsAddr), CellError> {
        let blocks = count.div_ceil(per_block);
        if k == 0 {
            self.get_block(ea, size, count, per_block, 0, bufs).await?;
        }
        if k + 1 < blocks {
            self.get_block(ea, size, count, per_block, k + 1, bufs)
                .await?;
        }
        self.spe.wait_tag(self.tags + (k % 2) as u32).await?;
        let first = k * per_block;
        Ok((first, per_block.min(count - first), bufs[k % 2]))
    }

    /// The output buffer `k % 2` of `bufs[2..]`, once its last put is done.
    async fn out_buffer(&self, k: usize, bufs: [LsAddr; 4]) -> Result<(LsAddr, u32), CellError> {
        let tag = self.tags + 2 + (k % 2) as u32;
        self.spe.wait_tag(tag).await?;
        Ok((bufs[2 + k % 2], tag))
    }

    async fn drain(&self) -> Result<(), CellError> {
        let all = 0b1111 << self.tags;
        self.spe.wait_tags(all, WaitMode::All).await.map(|_| ())
    }

    /// Phase 1: a key for every record of this SPE's slice, into keys A.
    async fn keys(&mut self, bufs: [LsAddr; 4]) -> Result<(), CellError> {
        let (lo, hi) = self.slice();
        let k = self.spe.cost().kernels;
        let rate = Cycles(k.spe_morton_bit.0 * self.spec.bits as u64);
        let src = self.a.tris.offset(lo as u64 * 48);
        let count = hi - lo;
        for b in 0..count.div_ceil(RECORDS_PER_BLOCK) {
            let (first, len, buf) = self
                .next_block(src, 48, count, RECORDS_PER_BLOCK, b, bufs)
                .await?;
            let spec = self.spec;
            let keys: Vec<KeyRec> = self.spe.with_ls(buf, len, |recs: &[TriRecord]| {
                (recs.iter().enumerate())
                    .map(|(i, r)| KeyRec {
                        key: spec.key(r.center()),
                        index: (lo + first + i) as u32,
                        pad: 0,
                    })
                    .collect()
            })?;
            self.spe.compute_items(rate, len as u64);
            let (obuf, tag) = self.out_buffer(b, bufs).await?;
            self.spe.ls_write(obuf, &keys)?;
            let to = self.a.keys[0].offset(((lo + first) * 16) as u64);
            self.spe.put(obuf, to, (len * 16) as u32, tag).await?;
        }
        self.drain().await
    }

    /// Phase 2: one LSD pass: count, share the counts, scatter.
    async fn radix_pass(&mut self, pass: u32, bufs: [LsAddr; 4]) -> Result<(), CellError> {
        let (lo, hi) = self.slice();
        let (count, d) = (hi - lo, self.knobs.digit_bits);
        let digits = 1usize << d;
        let k = self.spe.cost().kernels;
        let (src, dst) = (
            self.a.keys[pass as usize % 2],
            self.a.keys[1 - pass as usize % 2],
        );
        let slice = src.offset(lo as u64 * 16);
        let mut counts = vec![0u32; digits];
        for b in 0..count.div_ceil(KEYS_PER_BLOCK) {
            let (_, len, buf) = self
                .next_block(slice, 16, count, KEYS_PER_BLOCK, b, bufs)
                .await?;
            self.spe.with_ls(buf, len, |keys: &[KeyRec]| {
                let keys: Vec<u64> = keys.iter().map(|r| r.key).collect();
                radix::histogram(&keys, pass, d, &mut counts);
            })?;
            self.spe.compute_items(k.spe_radix_count, len as u64);
        }
        // This SPE's row of the table, then everyone's.
        let (row, tag) = (bufs[2], self.tags + 2);
        self.spe.wait_tag(tag).await?;
        self.spe.ls_write(row, &counts)?;
        let row_bytes = (digits * 4) as u64;
        let me = self.a.counts.offset(self.spe.id() as u64 * row_bytes);
        self.spe.put(row, me, row_bytes as u32, tag).await?;
        self.spe.wait_tag(tag).await?;
        self.barrier().await?;
        let mut rows = Vec::with_capacity(self.a.spes);
        for s in 0..self.a.spes {
            let at = self.a.counts.offset(s as u64 * row_bytes);
            self.spe.get(row, at, row_bytes as u32, tag).await?;
            self.spe.wait_tag(tag).await?;
            rows.push(self.spe.ls_read::<u32>(row, digits)?);
            self.spe.compute_items(k.spe_radix_count, digits as u64);
        }
        let mut offsets = radix::offsets(&rows).swap_remove(self.spe.id());
        // Scatter: each block's pairs in order of their places, one putl.
        for b in 0..count.div_ceil(KEYS_PER_BLOCK) {
            let (_, len, buf) = self
                .next_block(slice, 16, count, KEYS_PER_BLOCK, b, bufs)
                .await?;
            let recs: Vec<KeyRec> = self.spe.ls_read(buf, len)?;
            let keys: Vec<u64> = recs.iter().map(|r| r.key).collect();
            let to = radix::scatter(&keys, pass, d, &mut offsets);
            self.spe.compute_items(k.spe_radix_scatter, len as u64);
            let mut order: Vec<usize> = (0..len).collect();
            order.sort_by_key(|&i| to[i]);
            let staged: Vec<KeyRec> = order.iter().map(|&i| recs[i]).collect();
            let mut list: Vec<ListElement> = Vec::new();
            for &i in &order {
                let ea = dst.offset(to[i] as u64 * 16);
                match list.last_mut() {
                    Some(e) if e.ea.0 + e.size as u64 == ea.0 => e.size += 16,
                    _ => list.push(ListElement { ea, size: 16 }),
                }
            }
            let (obuf, tag) = self.out_buffer(b, bufs).await?;
            self.spe.ls_write(obuf, &staged)?;
            self.spe.putl(obuf, &list, tag).await?;
        }
        self.drain().await
    }

    /// Phase 3: gathers this SPE's slice of records in key order (one
    /// getl a block) into the sorted array.
    async fn permute(&mut self, keys: Ea, bufs: [LsAddr; 4]) -> Result<(), CellError> {
        let (lo, hi) = self.slice();
        let count = hi - lo;
        let k = self.spe.cost().kernels;
        let slice = keys.offset(lo as u64 * 16);
        for b in 0..count.div_ceil(RECORDS_PER_BLOCK) {
            let (first, len, buf) = self
                .next_block(slice, 16, count, RECORDS_PER_BLOCK, b, bufs)
                .await?;
            let recs: Vec<KeyRec> = self.spe.ls_read(buf, len)?;
            let list: Vec<ListElement> = (recs.iter())
                .map(|r| ListElement {
                    ea: self.a.tris.offset(r.index as u64 * 48),
                    size: 48,
                })
                .collect();
            self.spe.compute_items(k.spe_radix_scatter, len as u64);
            let (obuf, tag) = self.out_buffer(b, bufs).await?;
            self.spe.getl(obuf, &list, tag).await?;
            self.spe.wait_tag(tag).await?;
            let to = self.a.sorted.offset(((lo + first) * 48) as u64);
            self.spe.put(obuf, to, (len * 48) as u32, tag).await?;
        }
        self.drain().await
    }

    /// The key at sorted position `i` (one small get from main memory).
    async fn key_at(&self, keys: Ea, i: usize) -> Result<u64, CellError> {
        let tag = self.tags;
        self.spe
            .get(self.line, keys.offset(i as u64 * 16), 16, tag)
            .await?;
        self.spe.wait_tag(tag).await?;
        Ok(self.spe.ls_read::<KeyRec>(self.line, 1)?[0].key)
    }

    /// Phase 4, SPE 0: the top of the tree from the sorted keys, down to
    /// regions; writes the regions largest first (and their static deal).
    async fn top(&mut self, keys: Ea) -> Result<Vec<Top>, CellError> {
        let k = self.spe.cost().kernels;
        let bits = self.spec.bits;
        let root = self.arena.alloc(1).await?;
        let mut top: Vec<Top> = Vec::new();
        let mut regions: Vec<Job> = Vec::new();
        // (top index, node id, first, count, depth, key bits the cell has
        // consumed)
        let mut stack = vec![(usize::MAX, root, 0usize, self.a.n, 0u32, 0u32)];
        while let Some((parent_slot, id, first, count, depth, used)) = stack.pop() {
            self.spe.compute(k.spe_job);
            let at = top.len();
            if parent_slot != usize::MAX {
                let (kid, slot) = (parent_slot / 2, parent_slot % 2);
                if let Top::Inner { kids, .. } = &mut top[kid] {
                    kids[slot] = at;
                }
            }
            let key_first = self.key_at(keys, first).await?;
            let leafish = count <= self.knobs.region_size
                || count <= self.cfg.leaf_size as usize
                || depth >= self.cfg.max_depth;
            let split = if leafish {
                None
            } else {
                let key_last = self.key_at(keys, first + count - 1).await?;
                let diff = key_first ^ key_last;
                if diff == 0 {
                    None
                } else {
                    let bit = diff.leading_zeros() - (64 - bits);
                    let mask = 1u64 << (bits - 1 - bit);
                    // The first key with the bit set: binary search.
                    let (mut l, mut r) = (first + 1, first + count - 1);
                    while l < r {
                        let m = l + (r - l) / 2;
                        if self.key_at(keys, m).await? & mask == 0 {
                            l = m + 1;
                        } else {
                            r = m;
                        }
                    }
                    Some((bit, l - first))
                }
            };
            let Some((bit, left)) = split else {
                let cell = self.spec.cell(key_first, used);
                let job = Job::new(first, count, id as usize, depth, cell, &Side::EMPTY);
                top.push(Top::Region(regions.len()));
                regions.push(job);
                continue;
            };
            let axis = match self.spec.order {
                KeyOrder::GlobalHeuristic => self.spec.cell(key_first, bit).longest_axis(),
                KeyOrder::RoundRobin => (bit % 3) as usize,
            };
            let children = self.arena.alloc(2).await?;
            top.push(Top::Inner {
                id,
                children,
                axis,
                kids: [0, 0],
            });
            stack.push((
                2 * at + 1,
                children + 1,
                first + left,
                count - left,
                depth + 1,
                bit + 1,
            ));
            stack.push((2 * at, children, first, left, depth + 1, bit + 1));
        }
        // Largest first (ties by position: deterministic).
        let mut order: Vec<usize> = (0..regions.len()).collect();
        order.sort_by_key(|&r| std::cmp::Reverse(regions[r].count));
        self.spe.compute_items(k.spe_job, regions.len() as u64);
        let mut position = vec![0; regions.len()];
        for (pos, &r) in order.iter().enumerate() {
            position[r] = pos;
        }
        for t in &mut top {
            if let Top::Region(r) = t {
                *r = position[*r];
            }
        }
        let sorted: Vec<Job> = order.iter().map(|&r| regions[r]).collect();
        self.write_array(self.a.regions, &sorted).await?;
        if self.knobs.static_regions {
            self.deal(&sorted).await?;
        }
        let (line, take) = (self.line, self.a.take);
        let total = sorted.len() as u32;
        self.spe
            .atomic_update_line(line, take, |w| (w[0], w[1]) = (0, total))
            .await?;
        Ok(top)
    }

    /// Writes `items` to `ea` in puts of at most 16 KiB, and waits.
    async fn write_array<T: Pod>(&self, ea: Ea, items: &[T]) -> Result<(), CellError> {
        let per = (16 * 1024) / size_of::<T>();
        let tag = self.tags;
        let mark = self.spe.ls_mark();
        let buf = self.spe.ls_alloc(16 * 1024, 128)?;
        for (i, chunk) in items.chunks(per).enumerate() {
            self.spe.wait_tag(tag).await?;
            self.spe.ls_write(buf, chunk)?;
            let bytes = size_of_val(chunk).next_multiple_of(16) as u32;
            let at = ea.offset((i * per * size_of::<T>()) as u64);
            self.spe.put(buf, at, bytes, tag).await?;
        }
        self.spe.wait_tag(tag).await?;
        self.spe.ls_release_to(mark);
        Ok(())
    }

    /// The static deal: each region, largest first, to the SPE with the
    /// fewest triangles so far; per SPE its positions, contiguous.
    async fn deal(&mut self, regions: &[Job]) -> Result<(), CellError> {
        let spes = self.a.spes;
        let mut load = vec![0u64; spes];
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); spes];
        for (pos, r) in regions.iter().enumerate() {
            let s = (0..spes).min_by_key(|&s| (load[s], s)).expect("an SPE");
            load[s] += r.count as u64;
            lists[s].push(pos as u32);
        }
        self.spe
            .compute_items(self.spe.cost().kernels.spe_job, regions.len() as u64);
        let mut header = vec![0u32; 32];
        let mut all = Vec::with_capacity(regions.len());
        for (s, l) in lists.iter().enumerate() {
            header[2 * s] = all.len() as u32;
            header[2 * s + 1] = l.len() as u32;
            all.extend_from_slice(l);
        }
        self.write_array(self.a.deal, &all).await?;
        self.write_array(self.a.deal_header, &header).await
    }

    /// Phase 5, every SPE: builds regions until none is left.
    async fn build_regions(&mut self) -> Result<(), CellError> {
        let tag = self.tags;
        let (line, take) = (self.line, self.a.take);
        self.spe.get(line, take, 128, tag).await?;
        self.spe.wait_tag(tag).await?;
        let total = self.spe.ls_read::<u32>(line, 2)?[1];
        let mine: Option<Vec<u32>> = if self.knobs.static_regions {
            self.spe.get(line, self.a.deal_header, 128, tag).await?;
            self.spe.wait_tag(tag).await?;
            let h = self.spe.ls_read::<u32>(line, 32)?;
            let (start, len) = (
                h[2 * self.spe.id()] as usize,
                h[2 * self.spe.id() + 1] as usize,
            );
            let mut v = Vec::with_capacity(len);
            for i in 0..len {
                let at = self.a.deal.offset(((start + i) * 4) as u64);
                self.spe.get(line, Ea(at.0 & !15), 16, tag).await?;
                self.spe.wait_tag(tag).await?;
                v.push(self.spe.ls_read::<u32>(line, 4)?[(at.0 as usize & 15) / 4]);
            }
            Some(v)
        } else {
            None
        };
        let mut next = 0;
        loop {
            let pos = match &mine {
                Some(v) => match v.get(next) {
                    Some(&p) => p,
                    None => break,
                },
                None => {
                    let p = self.spe.atomic_fetch_add_u32(line, take, 1).await?;
                    if p >= total {
                        break;
                    }
                    p
                }
            };
            next += 1;
            self.spe
                .get(line, self.a.regions.offset(pos as u64 * 64), 64, tag)
                .await?;
            self.spe.wait_tag(tag).await?;
            let job = self.spe.ls_read::<Job>(line, 1)?[0];
            let side = self.region(&job).await?;
            let bounds: [f32; 8] = [
                side.lo.x, side.lo.y, side.lo.z, 0.0, side.hi.x, side.hi.y, side.hi.z, 0.0,
            ];
            self.spe.ls_write(line, &bounds)?;
            let at = self.a.bounds.offset(pos as u64 * 32);
            self.spe.put(line, at, 32, tag).await?;
            self.spe.wait_tag(tag).await?;
            self.regions_built += 1;
        }
        Ok(())
    }

    /// Records the local store can hold with their nodes (48 bytes and at
    /// most two 12-byte nodes each).
    fn ls_capacity(&self) -> usize {
        let free = self.spe.ls_free_bytes().saturating_sub(256);
        free as usize / (48 + 24)
    }

    /// Builds one region; returns its bounds.
    async fn region(&mut self, job: &Job) -> Result<Side, CellError> {
        let (first, count) = (job.first as usize, job.count as usize);
        if count <= self.ls_capacity() {
            return self
                .in_local_store(first, count, job.node, job.depth, job.candidate())
                .await;
        }
        // Too large: split depth first by Fig. 1's streaming partition
        // until the pieces fit.
        let k = self.spe.cost().kernels;
        let mark = self.spe.ls_mark();
        let fig1 = Fig1Buffers::alloc(self.spe)?;
        let at = self.a.sorted.offset(first as u64 * 48);
        let whole =
            stream_bounds::<TriRecord>(self.spe, &fig1, at, count as u64, k.spe_bounds_item)
                .await?;
        self.spe.ls_release_to(mark);
        let mut stack = vec![(first, count, job.node, job.depth, job.candidate(), whole)];
        while let Some((first, count, id, depth, mut cand, side)) = stack.pop() {
            if count <= self.ls_capacity() {
                self.in_local_store(first, count, id, depth, cand).await?;
                continue;
            }
            self.spe.compute(k.spe_job);
            let leaf = BihNode::leaf(first as u32, count as u32);
            let split = (count > self.cfg.leaf_size as usize && depth < self.cfg.max_depth)
                .then(|| choose_split(&mut cand, &side.centers()))
                .flatten();
            let Some(s) = split else {
                self.writes.push(id, leaf);
                continue;
            };
            let mark = self.spe.ls_mark();
            let fig1 = Fig1Buffers::alloc(self.spe)?;
            let at = self.a.sorted.offset(first as u64 * 48);
            let p = partition_in_place::<TriRecord>(
                self.spe,
                &fig1,
                at,
                count as u64,
                s,
                k.spe_partition_item,
            )
            .await?;
            self.spe.ls_release_to(mark);
            self.items_partitioned += count as u64;
            self.partitions += 1;
            let children = self.arena.alloc(2).await?;
            let [cl, cr] = clip_planes(s.axis, &p.left, &p.right);
            self.writes
                .push(id, BihNode::inner(children, s.axis, cl, cr));
            let [lc, rc] = s.candidates(cand);
            let l = p.left.count;
            stack.push((
                first + l,
                p.right.count,
                children + 1,
                depth + 1,
                rc,
                p.right,
            ));
            stack.push((first, l, children, depth + 1, lc, p.left));
        }
        self.writes.flush().await?;
        Ok(whole)
    }

    /// A region (or piece) that fits: loaded once, built in the local store
    /// with the global heuristic, written back once; returns its bounds.
    async fn in_local_store(
        &mut self,
        first: usize,
        count: usize,
        id: u32,
        depth: u32,
        cand: Aabb,
    ) -> Result<Side, CellError> {
        let k = self.spe.cost().kernels;
        let tag = self.tags;
        let mark = self.spe.ls_mark();
        let recs = self
            .spe
            .ls_alloc((count * 48).next_multiple_of(128) as u32, 128)?;
        let at = self.a.sorted.offset(first as u64 * 48);
        for (i, c) in (0..count).step_by(RECORDS_PER_BLOCK).enumerate() {
            let len = RECORDS_PER_BLOCK.min(count - c);
            let ls = recs.offset((i * RECORDS_PER_BLOCK * 48) as u32);
            self.spe
                .get(ls, at.offset((c * 48) as u64), (len * 48) as u32, tag)
                .await?;
        }
        self.spe.wait_tag(tag).await?;
        let cfg = self.cfg;
        let (side, nodes, stats) =
            self.spe
                .with_ls_mut(recs, count, |items: &mut [TriRecord]| {
                    let side = side_of(items);
                    let mut nodes = vec![BihNode::default()];
                    let stats = build_subtree(items, &mut nodes, 0, 0, count, cand, depth, &cfg);
                    (side, nodes, stats)
                })?;
        // The nodes take their room in the local store too.
        self.spe
            .ls_alloc((nodes.len() * 12).next_multiple_of(16) as u32, 16)?;
        self.spe.compute_items(k.spe_bounds_item, count as u64);
        let partitioned = stats.items_partitioned - count as u64;
        self.spe.compute_items(k.spe_partition_item, partitioned);
        self.spe.compute_items(k.spe_job, nodes.len() as u64);
        self.items_partitioned += partitioned;
        self.partitions += stats.partitions;
        for (i, c) in (0..count).step_by(RECORDS_PER_BLOCK).enumerate() {
            let len = RECORDS_PER_BLOCK.min(count - c);
            let ls = recs.offset((i * RECORDS_PER_BLOCK * 48) as u32);
            self.spe
                .put(ls, at.offset((c * 48) as u64), (len * 48) as u32, tag)
                .await?;
        }
        // Local pairs (1, 2), (3, 4), ... take pairs of this SPE's arena.
        let mut global = vec![id; nodes.len()];
        for pair in (1..nodes.len()).step_by(2) {
            let g = self.arena.alloc(2).await?;
            global[pair] = g;
            global[pair + 1] = g + 1;
        }
        for (i, n) in nodes.iter().enumerate() {
            let node = if n.is_leaf() {
                let (f, c) = n.leaf_range();
                BihNode::leaf(f + first as u32, c)
            } else {
                let [l, r] = n.clip();
                BihNode::inner(global[n.left_child() as usize], n.axis(), l, r)
            };
            self.writes.push(global[i], node);
        }
        self.writes.flush().await?;
        self.spe.wait_tag(tag).await?;
        self.spe.ls_release_to(mark);
        Ok(side)
    }

    /// Last, SPE 0: the top nodes, their clip planes from the regions' bounds.
    async fn write_top(&mut self, top: &[Top]) -> Result<(), CellError> {
        let regions = top.iter().filter(|t| matches!(t, Top::Region(_))).count();
        let tag = self.tags;
        let mut bounds: Vec<Aabb> = Vec::with_capacity(regions);
        let mark = self.spe.ls_mark();
        let buf = self.spe.ls_alloc(16 * 1024, 128)?;
        for c in (0..regions).step_by(512) {
            let len = 512.min(regions - c);
            self.spe
                .get(
                    buf,
                    self.a.bounds.offset(c as u64 * 32),
                    (len * 32) as u32,
                    tag,
                )
                .await?;
            self.spe.wait_tag(tag).await?;
            let b: Vec<[f32; 8]> = self.spe.ls_read(buf, len)?;
            bounds.extend(
                b.iter()
                    .map(|b| Aabb::new(Vec3::new(b[0], b[1], b[2]), Vec3::new(b[4], b[5], b[6]))),
            );
        }
        self.spe.ls_release_to(mark);
        // Children come after their parents: bounds bottom-up in reverse.
        let mut of = vec![Aabb::EMPTY; top.len()];
        for (i, t) in top.iter().enumerate().rev() {
            of[i] = match *t {
                Top::Region(pos) => bounds[pos],
                Top::Inner {
                    id,
                    children,
                    axis,
                    kids,
                } => {
                    let (l, r) = (of[kids[0]], of[kids[1]]);
                    self.writes
                        .push(id, BihNode::inner(children, axis, l.max[axis], r.min[axis]));
                    self.spe.compute(self.spe.cost().kernels.spe_job);
                    l.union(r)
                }
            };
        }
        self.writes.flush().await
    }
}
