//! The cooperative partition of one large interval by every SPE — the
//! scheme section 2 of the paper describes and rejects for one SPE, used
//! here for the top levels of a multi-SPE build, where there are fewer
//! jobs than SPEs:
//!
//! 1. every SPE takes an equal chunk of the interval, partitions it block by
//!    block in its local store (the baseline's kernel and rate), and writes
//!    each block's left part upward from its chunk's start and its right
//!    part downward from its chunk's end in a scratch array;
//! 2. it writes its two counts and bounds to a table (one line per SPE);
//!    a barrier; every SPE reads the table: prefix sums over the counts
//!    give where its parts go;
//! 3. it copies its left part to the left side of the interval and its
//!    right part to the right side, at those places; a barrier.
//!
//! Barriers count arrivals with fetch-and-add; the last to arrive signals
//! the others (signal register 2), so no SPE spins. The coordinator (SPE 0)
//! hands out each interval by a descriptor line and signal register 1.
//! Traffic: every record is read twice and written twice, against once
//! and once for Fig. 1 — the price of the parallelism, charged as DMA.
//!
//! In place (`CoopArea::scratch` `None`, `--coop-partition
//! in-place`): step 1 is Fig. 1's own in-place partition of the chunk
//! (buffers A–D and OUT, [`partition_in_place`]), which leaves each chunk
//! as its left part then its right part; step 3 then moves only the
//! records on the wrong side of the interval's final boundary: the i-th
//! right record left of it swaps with the i-th left record right of it,
//! each SPE an equal share of the swaps (a get of both, a put of both).
//! Traffic: every record read and written once, and the misplaced ones
//! (at most half) once more; no scratch array.
//!
//! Before the first level, the root's bounds ([`Coop::bounds`]):
//! every SPE streams an equal chunk of the records and writes its chunk's
//! bounds to the table; after a barrier every SPE merges the table (min
//! and max: the same bounds as one SPE's pass over all of them).

use bytemuck::{Pod, Zeroable};
use glam::Vec3A;

use crate::cell::{CellError, Cycles, Ea, LsAddr, Spe, WaitMode};
use crate::kernels::split::{Side, Split, partition};
use crate::spe::barrier::Barrier;
use crate::spe::fig1::{BLOCK_BYTES, Fig1Buffers, partition_in_place, stream_bounds};
use crate::spe::layout::TriRecord;

/// Signal-register-1 values from the coordinator.
pub const GO: u32 = 2;

/// One side as the table holds it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct SideRec {
    count: u32,
    lo: [f32; 3],
    hi: [f32; 3],
    center_lo: [f32; 3],
    center_hi: [f32; 3],
}

impl SideRec {
    fn of(s: &Side) -> Self {
        SideRec {
            count: s.count as u32,
            lo: s.lo.to_array(),
            hi: s.hi.to_array(),
            center_lo: s.center_lo.to_array(),
            center_hi: s.center_hi.to_array(),
        }
    }

    fn side(&self) -> Side {
        Side {
            count: self.count as usize,
            lo: Vec3A::from_array(self.lo),
            hi: Vec3A::from_array(self.hi),
            center_lo: Vec3A::from_array(self.center_lo),
            center_hi: Vec3A::from_array(self.center_hi),
        }
    }
}

/// One SPE's line of the table: its left and right side. 128 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Entry {
    left: SideRec,
    right: SideRec,
    _pad: [u32; 6],
}
const _: () = assert!(size_of::<Entry>() == 128);

/// The descriptor of the interval to partition: first, count, axis and
/// plane (as bits). One line.
const DESCRIPTOR_WORDS: usize = 32;

/// What the coordinator hands every helper: partition records
/// `first..first + count` around `split`.
#[derive(Clone, Copy, Debug)]
pub struct Descriptor {
    pub first: u32,
    pub count: u32,
    pub split: Split,
}

impl Descriptor {
    /// Its line in the local store.
    fn words(&self) -> [u32; DESCRIPTOR_WORDS] {
        let mut words = [0u32; DESCRIPTOR_WORDS];
        let (first, count, split) = (self.first, self.count, self.split);
        words[..4].copy_from_slice(&[first, count, split.axis as u32, split.plane.to_bits()]);
        words
    }

    /// The descriptor its first four words hold.
    fn of_words(w: &[u32]) -> Self {
        let split = Split {
            axis: w[2] as usize,
            plane: f32::from_bits(w[3]),
        };
        Descriptor {
            first: w[0],
            count: w[1],
            split,
        }
    }

    /// SPE `j`'s chunk of the interval shared by `n`: records `lo..hi`.
    fn chunk(&self, j: u64, n: u64) -> (u64, u64) {
        let (first, count) = (self.first as u64, self.count as u64);
        (first + count * j / n, first + count * (j + 1) / n)
    }
}

/// What the SPEs share in main memory, set up by the host.
#[derive(Clone, Copy, Debug)]
pub struct CoopArea {
    pub spes: usize,
    pub tris: Ea,
    /// A scratch array as large as the triangle records; `None`: the
    /// partition is done in place.
    pub scratch: Option<Ea>,
    /// The descriptor line, the table (one line per SPE), the arrival
    /// counter line.
    pub descriptor: Ea,
    pub table: Ea,
    pub arrivals: Ea,
}

/// One SPE's side of the cooperation: its local-store lines and the
/// barriers it has passed.
pub struct Coop {
    pub area: CoopArea,
    line: LsAddr,
    table_ls: LsAddr,
    barrier: Barrier,
    tag: u32,
    /// `Knobs::prefetch`: each block's get overlaps the block before.
    prefetch: bool,
}

impl Coop {
    pub fn new(spe: &Spe, area: CoopArea, prefetch: bool) -> Result<Self, CellError> {
        Ok(Coop {
            area,
            line: spe.ls_alloc(128, 128)?,
            table_ls: spe.ls_alloc(128 * area.spes as u32, 128)?,
            barrier: Barrier::new(area.arrivals, area.spes),
            tag: spe.tag("cooperative partition")?,
            prefetch,
        })
    }

    /// The coordinator: hands `d` to every other SPE and does its own
    /// share.
    pub async fn lead(
        &mut self,
        spe: &Spe,
        bufs: &Fig1Buffers,
        d: Descriptor,
        rate: Cycles,
    ) -> Result<(Side, Side), CellError> {
        spe.ls_write(self.line, &d.words())?;
        spe.put(self.line, self.area.descriptor, 128, self.tag)
            .await?;
        spe.wait_tag(self.tag).await?;
        for to in 1..self.area.spes {
            spe.send_signal(to, 1, GO).await?;
        }
        self.share(spe, bufs, d, rate).await
    }

    /// A helper, signalled `GO`: reads the descriptor and does its share.
    pub async fn help(
        &mut self,
        spe: &Spe,
        bufs: &Fig1Buffers,
        rate: Cycles,
    ) -> Result<(), CellError> {
        spe.get(self.line, self.area.descriptor, 128, self.tag)
            .await?;
        spe.wait_tag(self.tag).await?;
        let d = Descriptor::of_words(&spe.ls_read::<u32>(self.line, 4)?);
        self.share(spe, bufs, d, rate).await?;
        Ok(())
    }

    /// This SPE's share of partitioning `d`'s interval around its split;
    /// returns both whole sides.
    async fn share(
        &mut self,
        spe: &Spe,
        bufs: &Fig1Buffers,
        d: Descriptor,
        rate: Cycles,
    ) -> Result<(Side, Side), CellError> {
        let (n, k) = (self.area.spes as u64, spe.id() as u64);
        let (lo, hi) = d.chunk(k, n);
        let (first, split) = (d.first, d.split);
        let size = size_of::<TriRecord>() as u64;
        let per_block = BLOCK_BYTES as u64 / size;
        let Some(scratch) = self.area.scratch else {
            return self.share_in_place(spe, bufs, d, rate).await;
        };
        let rec = |base: Ea, i: u64| base.offset(i * size);
        // 1. Partition the chunk block by block into the scratch array
        //    (prefetching: the next block's get is issued before this one
        //    is partitioned).
        let (mut left, mut right) = (Side::EMPTY, Side::EMPTY);
        let (mut up, mut down) = (lo, hi);
        let nbuf = self.buffers();
        let tris = self.area.tris;
        let blocks = (hi - lo).div_ceil(per_block);
        let block = |i: u64| (lo + i * per_block, per_block.min(hi - lo - i * per_block));
        let get = |i: u64| {
            let (at, len) = block(i);
            let b = i as usize % nbuf;
            let (buf, tag) = (bufs.buffer(b), bufs.tag(b));
            async move {
                spe.wait_tag(tag).await?; // its last puts are done
                spe.get(buf, rec(tris, at), (len * size) as u32, tag).await
            }
        };
        if blocks > 0 {
            get(0).await?;
        }
        for i in 0..blocks {
            if let Some(k) = self.get_before(i, blocks) {
                get(k).await?;
            }
            let (_, len) = block(i);
            let b = i as usize % nbuf;
            let (buf, tag) = (bufs.buffer(b), bufs.tag(b));
            spe.wait_tag(tag).await?;
            let (l, r) = spe.with_ls_mut(buf, len as usize, |items: &mut [TriRecord]| {
                partition(items, split)
            })?;
            spe.compute_items(rate, len);
            let (lc, rc) = (l.count as u64, r.count as u64);
            if lc > 0 {
                spe.put(buf, rec(scratch, up), (lc * size) as u32, tag)
                    .await?;
            }
            if rc > 0 {
                let from = buf.offset((lc * size) as u32);
                down -= rc;
                spe.put(from, rec(scratch, down), (rc * size) as u32, tag)
                    .await?;
            }
            up += lc;
            left = left.merge(l);
            right = right.merge(r);
        }
        spe.wait_tags(self.all_tags(bufs), WaitMode::All).await?;
        // 2. The table, a barrier, the prefix sums.
        let entries = self.exchange_table(spe, &left, &right).await?;
        let total_left: u64 = entries.iter().map(|e| e.left.count as u64).sum();
        let left_at: u64 = entries[..k as usize]
            .iter()
            .map(|e| e.left.count as u64)
            .sum();
        let right_at: u64 = entries[..k as usize]
            .iter()
            .map(|e| e.right.count as u64)
            .sum();
        // 3. Each part to its place.
        let (lc, rc) = (up - lo, hi - down);
        let dst_left = first as u64 + left_at;
        let dst_right = first as u64 + total_left + right_at;
        self.copy(spe, bufs, scratch, (lo, dst_left, lc), per_block)
            .await?;
        self.copy(spe, bufs, scratch, (down, dst_right, rc), per_block)
            .await?;
        self.barrier(spe).await?;
        Ok(both_sides(&entries))
    }

    /// The bounds of all `n` records, every SPE streaming an equal chunk
    /// at `rate` (each SPE calls it, before the first level). A second
    /// barrier after the table is read keeps the table from being
    /// overwritten by a fast SPE's first partition before a slow one read it.
    pub async fn bounds(
        &mut self,
        spe: &Spe,
        bufs: &Fig1Buffers,
        n: u64,
        rate: Cycles,
    ) -> Result<Side, CellError> {
        let (s, k) = (self.area.spes as u64, spe.id() as u64);
        let (lo, hi) = (n * k / s, n * (k + 1) / s);
        let size = size_of::<TriRecord>() as u64;
        let at = self.area.tris.offset(lo * size);
        let mine = stream_bounds::<TriRecord>(spe, bufs, at, hi - lo, rate).await?;
        let entries = self.exchange_table(spe, &mine, &Side::EMPTY).await?;
        self.barrier(spe).await?;
        Ok(both_sides(&entries).0)
    }

    /// Writes this SPE's two sides to its line of the table, waits for
    /// every SPE, and reads the whole table.
    async fn exchange_table(
        &mut self,
        spe: &Spe,
        left: &Side,
        right: &Side,
    ) -> Result<Vec<Entry>, CellError> {
        let n = self.area.spes;
        let entry = Entry {
            left: SideRec::of(left),
            right: SideRec::of(right),
            _pad: [0; 6],
        };
        spe.ls_write(self.line, &[entry])?;
        let mine = self.area.table.offset(spe.id() as u64 * 128);
        spe.put(self.line, mine, 128, self.tag).await?;
        spe.wait_tag(self.tag).await?;
        self.barrier(spe).await?;
        let bytes = (128 * n) as u32;
        spe.get(self.table_ls, self.area.table, bytes, self.tag)
            .await?;
        spe.wait_tag(self.tag).await?;
        spe.ls_read(self.table_ls, n)
    }

    /// This SPE's share in place: Fig. 1's partition of its chunk, the
    /// table, then its share of the swaps across the final boundary.
    async fn share_in_place(
        &mut self,
        spe: &Spe,
        bufs: &Fig1Buffers,
        d: Descriptor,
        rate: Cycles,
    ) -> Result<(Side, Side), CellError> {
        let (n, k) = (self.area.spes as u64, spe.id() as u64);
        let chunk = |j: u64| d.chunk(j, n);
        let (first, split) = (d.first, d.split);
        let size = size_of::<TriRecord>() as u64;
        let (lo, hi) = chunk(k);
        // 1. Fig. 1 in place: the chunk becomes its left part, then its right.
        let tris = self.area.tris;
        let part = partition_in_place::<TriRecord>(
            spe,
            bufs,
            tris.offset(lo * size),
            hi - lo,
            split,
            rate,
        )
        .await?;
        // 2. The table, a barrier.
        let entries = self.exchange_table(spe, &part.left, &part.right).await?;
        // 3. The swaps: right records left of the boundary (`a`) with left
        //    records right of it (`b`), in order, each SPE an equal share.
        let total_left: u64 = entries.iter().map(|e| e.left.count as u64).sum();
        let boundary = first as u64 + total_left;
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for (j, e) in entries.iter().enumerate() {
            let (lo, hi) = chunk(j as u64);
            let mid = lo + e.left.count as u64;
            push_range(&mut a, mid, hi.min(boundary));
            push_range(&mut b, lo.max(boundary), mid);
        }
        let misplaced: u64 = a.iter().map(|r| r.1).sum();
        debug_assert_eq!(misplaced, b.iter().map(|r| r.1).sum::<u64>());
        let (from, to) = (misplaced * k / n, misplaced * (k + 1) / n);
        let per_swap = BLOCK_BYTES as u64 / size;
        let mut step = 0usize;
        let mut at = from;
        while at < to {
            let end = (at + per_swap).min(to);
            // Two buffers a step, two steps in turn: a step's gets go out
            // while the step before puts.
            let (x, y) = (2 * (step % 2), 2 * (step % 2) + 1);
            let (pa, pb) = (pieces(&a, at, end), pieces(&b, at, end));
            for (buf, ps) in [(x, &pa), (y, &pb)] {
                spe.wait_tag(bufs.tag(buf)).await?; // its puts of two steps ago
                transfer(spe, (bufs.buffer(buf), bufs.tag(buf)), tris, ps, Dir::Get).await?;
            }
            // Both gets are in before either side is overwritten; then each
            // buffer's records go to the other side's places.
            let both = 1 << bufs.tag(x) | 1 << bufs.tag(y);
            spe.wait_tags(both, WaitMode::All).await?;
            for (buf, ps) in [(x, &pb), (y, &pa)] {
                transfer(spe, (bufs.buffer(buf), bufs.tag(buf)), tris, ps, Dir::Put).await?;
            }
            at = end;
            step += 1;
        }
        let all = (0..4).fold(0, |m, b| m | 1 << bufs.tag(b));
        spe.wait_tags(all, WaitMode::All).await?;
        self.barrier(spe).await?;
        Ok(both_sides(&entries))
    }

    /// Copies `count` records from `scratch` record `from` to the records
    /// at `to` (prefetching: the next block's get is issued before this
    /// one's put).
    async fn copy(
        &self,
        spe: &Spe,
        bufs: &Fig1Buffers,
        scratch: Ea,
        (from, to, count): (u64, u64, u64),
        per_block: u64,
    ) -> Result<(), CellError> {
        let size = size_of::<TriRecord>() as u64;
        let nbuf = self.buffers();
        let blocks = count.div_ceil(per_block);
        let len = |i: u64| per_block.min(count - i * per_block);
        let get = |i: u64| {
            let b = i as usize % nbuf;
            let (buf, tag) = (bufs.buffer(b), bufs.tag(b));
            let ea = scratch.offset((from + i * per_block) * size);
            async move {
                spe.wait_tag(tag).await?;
                spe.get(buf, ea, (len(i) * size) as u32, tag).await
            }
        };
        if blocks > 0 {
            get(0).await?;
        }
        for i in 0..blocks {
            if let Some(k) = self.get_before(i, blocks) {
                get(k).await?;
            }
            let b = i as usize % nbuf;
            let (buf, tag) = (bufs.buffer(b), bufs.tag(b));
            spe.wait_tag(tag).await?;
            let ea = self.area.tris.offset((to + i * per_block) * size);
            spe.put(buf, ea, (len(i) * size) as u32, tag).await?;
        }
        spe.wait_tags(self.all_tags(bufs), WaitMode::All)
            .await
            .map(|_| ())
    }

    /// The block whose get is issued just before block `i` of `blocks` is
    /// worked on (block 0's is issued before the loop): the next one when
    /// prefetching, so that its transfer overlaps block `i`'s work; else
    /// block `i` itself.
    fn get_before(&self, i: u64, blocks: u64) -> Option<u64> {
        match self.prefetch {
            true => Some(i + 1).filter(|&k| k < blocks),
            false => Some(i).filter(|&k| k > 0),
        }
    }

    /// Fig. 1 buffers the blocks take turns in: two, three when
    /// prefetching.
    fn buffers(&self) -> usize {
        if self.prefetch { 3 } else { 2 }
    }

    fn all_tags(&self, bufs: &Fig1Buffers) -> u32 {
        (0..self.buffers()).fold(0, |m, b| m | 1 << bufs.tag(b))
    }

    /// Waits until every SPE has arrived: the last to arrive signals the
    /// others.
    async fn barrier(&mut self, spe: &Spe) -> Result<(), CellError> {
        self.barrier.wait(spe, self.line).await
    }
}

enum Dir {
    Get,
    Put,
}

/// Gets the records of `pieces` (first record, count) of the array at
/// `tris` one after another into the buffer `ls`, or puts them from it,
/// under `tag`.
async fn transfer(
    spe: &Spe,
    (ls, tag): (LsAddr, u32),
    tris: Ea,
    pieces: &[(u64, u64)],
    dir: Dir,
) -> Result<(), CellError> {
    let size = size_of::<TriRecord>() as u64;
    let mut off = 0u32;
    for &(i, len) in pieces {
        let bytes = (len * size) as u32;
        let (at, ea) = (ls.offset(off), tris.offset(i * size));
        match dir {
            Dir::Get => spe.get(at, ea, bytes, tag).await?,
            Dir::Put => spe.put(at, ea, bytes, tag).await?,
        }
        off += bytes;
    }
    Ok(())
}

/// Both whole sides of the interval: every SPE's, merged.
fn both_sides(entries: &[Entry]) -> (Side, Side) {
    let whole = |f: fn(&Entry) -> Side| {
        (entries.iter())
            .map(f)
            .fold(Side::EMPTY, |a: Side, s| a.merge(s))
    };
    (whole(|e| e.left.side()), whole(|e| e.right.side()))
}

/// Adds the records `from..to` (if any) to a list of (first, count) ranges.
fn push_range(list: &mut Vec<(u64, u64)>, from: u64, to: u64) {
    if to > from {
        list.push((from, to - from));
    }
}

/// The pieces (first record, count) of positions `from..to` of the
/// sequence the ranges `list` make, in order.
fn pieces(list: &[(u64, u64)], from: u64, to: u64) -> Vec<(u64, u64)> {
    let mut out = Vec::new();
    let mut seen = 0u64;
    for &(first, len) in list {
        let (lo, hi) = (from.max(seen), to.min(seen + len));
        if lo < hi {
            out.push((first + lo - seen, hi - lo));
        }
        seen += len;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::pieces;

    #[test]
    fn pieces_cut_a_sequence_of_ranges() {
        let list = [(10, 3), (20, 2), (30, 4)];
        assert_eq!(pieces(&list, 0, 9), vec![(10, 3), (20, 2), (30, 4)]);
        assert_eq!(pieces(&list, 2, 6), vec![(12, 1), (20, 2), (30, 1)]);
        assert_eq!(pieces(&list, 5, 6), vec![(30, 1)]);
        assert_eq!(pieces(&list, 4, 4), vec![]);
    }
}
