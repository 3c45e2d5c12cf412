//! `spe_morton`, phases 0 to 3 (section 5: "the Morton code construction
//! [...] can be done totally independent from the others. After the
//! Morton code construction a radix sort needs to be performed"): the
//! scene's box the keys start from, the keys, the radix passes and the
//! permutation of the records, every SPE on its slice, streamed through
//! the local store.

use super::pairs::{KeyRec, PAIRS_PER_BLOCK, gather_list, ls_for, span, stage_list};
use super::{Program, RECORD, RECORDS_PER_BLOCK};
use crate::aabb::Aabb;
use crate::cell::{CellError, Ea, LsAddr, WaitMode};
use crate::kernels::morton::KeySpec;
use crate::kernels::quantise::QuantisedKeys;
use crate::kernels::radix;
use crate::kernels::split::{Boxed, Side, side_of};
use crate::spe::layout::TriRecord;
use glam::{Vec3, Vec3A};

/// `count` elements of `size` bytes at `ea`, read `per_block` a block.
#[derive(Clone, Copy)]
struct Stream {
    ea: Ea,
    size: usize,
    count: usize,
    per_block: usize,
}

impl Stream {
    fn new(ea: Ea, size: usize, count: usize, per_block: usize) -> Self {
        Stream {
            ea,
            size,
            count,
            per_block,
        }
    }

    fn blocks(&self) -> usize {
        self.count.div_ceil(self.per_block)
    }

    /// Block `k`'s first element and length.
    fn block(&self, k: usize) -> (usize, usize) {
        let first = k * self.per_block;
        (first, self.per_block.min(self.count - first))
    }

    /// Block `k`'s address and bytes.
    fn at(&self, k: usize) -> (Ea, usize) {
        let (first, len) = self.block(k);
        (self.ea.offset((first * self.size) as u64), len * self.size)
    }
}

impl Program<'_> {
    /// Issues the get of block `k` of stream `s` into `bufs[k % 2]` (tag
    /// `tags + k % 2`), at its address's low four bits (`pairs::span`).
    async fn get_block(&self, s: Stream, k: usize, bufs: [LsAddr; 4]) -> Result<(), CellError> {
        let (buf, tag) = (bufs[k % 2], self.tags + (k % 2) as u32);
        let (at, bytes) = s.at(k);
        span(self.spe, buf, at, bytes, false, tag).await
    }

    /// Block `k` of stream `s` (its first element, length and buffer):
    /// waits for its get after issuing the next block's, so that the
    /// transfer overlaps this block's work.
    async fn next_block(
        &self,
        s: Stream,
        k: usize,
        bufs: [LsAddr; 4],
    ) -> Result<(usize, usize, LsAddr), CellError> {
        if k == 0 {
            self.get_block(s, 0, bufs).await?;
        }
        if k + 1 < s.blocks() {
            self.get_block(s, k + 1, bufs).await?;
        }
        self.spe.wait_tag(self.tags + (k % 2) as u32).await?;
        let (first, len) = s.block(k);
        Ok((first, len, ls_for(bufs[k % 2], s.at(k).0)))
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

    /// Phase 0: the scene's box, which the keys start from, made on the
    /// SPEs as the baseline makes its own (a bounds pass over every record
    /// at `spe_bounds_item`), not handed over by the host: each SPE streams
    /// its slice, puts its slice's box in its row of the count table, and
    /// after a barrier reads every row.
    pub(super) async fn scene_box(&mut self, bufs: [LsAddr; 4]) -> Result<Aabb, CellError> {
        let (lo, hi) = self.slice_of(0, self.a.n);
        let src = self.a.tris.offset((lo * RECORD) as u64);
        let count = hi - lo;
        let mut side = Side::EMPTY;
        for b in 0..count.div_ceil(RECORDS_PER_BLOCK) {
            let (_, len, buf) = self
                .next_block(Stream::new(src, RECORD, count, RECORDS_PER_BLOCK), b, bufs)
                .await?;
            let block = self
                .spe
                .with_ls(buf, len, |recs: &[TriRecord]| side_of(recs))?;
            side = side.merge(block);
            self.spe
                .compute_items(self.kernels.spe_bounds_item, len as u64);
        }
        self.drain().await?;
        // Each SPE's box, 32 bytes a row.
        let (row, tag, spes) = (bufs[2], self.tags + 2, self.a.spes);
        let mine: [f32; 8] = [
            side.lo.x, side.lo.y, side.lo.z, side.hi.x, side.hi.y, side.hi.z, 0.0, 0.0,
        ];
        self.spe.ls_write(row, &mine)?;
        let at = self.a.counts.offset(self.spe.id() as u64 * 32);
        self.spe.put(row, at, 32, tag).await?;
        self.spe.wait_tag(tag).await?;
        self.barrier().await?;
        self.spe
            .get(row, self.a.counts, 32 * spes as u32, tag)
            .await?;
        self.spe.wait_tag(tag).await?;
        let rows: Vec<[f32; 8]> = self.spe.ls_read(row, spes)?;
        self.spe
            .compute_items(self.kernels.spe_bounds_item, spes as u64);
        let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for r in rows {
            min = min.min(Vec3::new(r[0], r[1], r[2]));
            max = max.max(Vec3::new(r[3], r[4], r[5]));
        }
        Ok(Aabb { min, max })
    }

    /// The quantisation of `spec`'s keys, the halvings it made to find
    /// its axes charged at the key bit's rate.
    pub(super) fn quantised(&self, spec: &KeySpec) -> QuantisedKeys {
        let q = QuantisedKeys::new(spec);
        (self.spe).compute_items(self.rates.key_bit, q.setup_halvings());
        q
    }

    /// Phase 1: a key for every record of this SPE's slice, into keys A.
    pub(super) async fn keys(&mut self, bufs: [LsAddr; 4]) -> Result<(), CellError> {
        let (lo, hi) = self.slice_of(0, self.a.n);
        let quantised = self.quantised(&self.specs[0]);
        let src = self.a.tris.offset((lo * RECORD) as u64);
        let count = hi - lo;
        for b in 0..count.div_ceil(RECORDS_PER_BLOCK) {
            let (first, len, buf) = self
                .next_block(Stream::new(src, RECORD, count, RECORDS_PER_BLOCK), b, bufs)
                .await?;
            let centers: Vec<Vec3A> = self.spe.with_ls(buf, len, |recs: &[TriRecord]| {
                recs.iter().map(|r| r.center()).collect()
            })?;
            let mut codes = vec![0; len];
            let cost = self.rates.keys(&quantised, &centers, &mut codes);
            self.spe.compute(cost);
            let keys: Vec<KeyRec> = (codes.into_iter().enumerate())
                .map(|(i, key)| KeyRec {
                    key,
                    index: (lo + first + i) as u32,
                })
                .collect();
            let (obuf, tag) = self.out_buffer(b, bufs).await?;
            let p = self.a.pairs;
            let to = self.a.keys[0].offset(((lo + first) * p.bytes) as u64);
            p.write(self.spe, ls_for(obuf, to), &keys)?;
            span(self.spe, obuf, to, len * p.bytes, true, tag).await?;
        }
        self.drain().await
    }

    /// Phase 2: one LSD pass over the pairs at places `first..first +
    /// count` (all of them, or a range keyed again) of keys array `from`
    /// into the other: count, share the counts, scatter.
    pub(super) async fn radix_pass(
        &mut self,
        pass: u32,
        bufs: [LsAddr; 4],
        (first, total): (usize, usize),
        from: usize,
    ) -> Result<(), CellError> {
        let (lo, hi) = self.slice_of(first, total);
        let (count, d) = (hi - lo, self.knobs.digit_bits);
        let digits = 1usize << d;
        let (src, dst) = (self.a.keys[from], self.a.keys[1 - from]);
        let p = self.a.pairs;
        let slice = src.offset((lo * p.bytes) as u64);
        let stream = Stream::new(slice, p.bytes, count, PAIRS_PER_BLOCK);
        let mut counts = vec![0u32; digits];
        for b in 0..stream.blocks() {
            let (_, len, buf) = self.next_block(stream, b, bufs).await?;
            let keys: Vec<u64> = p.read(self.spe, buf, len)?.iter().map(|r| r.key).collect();
            radix::histogram(&keys, pass, d, &mut counts);
            self.spe.compute_items(self.rates.radix_count, len as u64);
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
            self.spe
                .compute_items(self.rates.radix_count, digits as u64);
        }
        let mut offsets = radix::offsets(&rows).swap_remove(self.spe.id());
        // Scatter: each block's pairs in order of their places, one putl.
        for b in 0..stream.blocks() {
            let (_, len, buf) = self.next_block(stream, b, bufs).await?;
            let recs: Vec<KeyRec> = p.read(self.spe, buf, len)?;
            let keys: Vec<u64> = recs.iter().map(|r| r.key).collect();
            let to = radix::scatter(&keys, pass, d, &mut offsets);
            // The block's own histogram and prefix sum, which stage its
            // pairs in order of their places, then the scatter.
            (self.spe).compute_items(self.rates.radix_count, (len + digits) as u64);
            self.spe.compute_items(self.rates.radix_scatter, len as u64);
            let mut order: Vec<usize> = (0..len).collect();
            order.sort_by_key(|&i| to[i]);
            // Runs of consecutive places, each its first place's address
            // and its pairs.
            let mut runs: Vec<(Ea, Vec<KeyRec>)> = Vec::new();
            for &i in &order {
                let ea = dst.offset((first as u64 + to[i] as u64) * p.bytes as u64);
                match runs.last_mut() {
                    Some((at, run)) if at.0 + (run.len() * p.bytes) as u64 == ea.0 => {
                        run.push(recs[i])
                    }
                    _ => runs.push((ea, vec![recs[i]])),
                }
            }
            let runs: Vec<(Ea, Vec<u8>)> = (runs.into_iter())
                .map(|(ea, run)| (ea, bytemuck::cast_slice(&p.encode(&run)).to_vec()))
                .collect();
            let (staged, list) = stage_list(&runs);
            let (obuf, tag) = self.out_buffer(b, bufs).await?;
            self.spe.ls_write(obuf, &staged)?;
            self.spe.putl(obuf, &list, tag).await?;
        }
        self.drain().await
    }

    /// Phase 3: gathers this SPE's slice of records in key order (one
    /// getl a block) into the sorted array.
    pub(super) async fn permute(&mut self, keys: Ea, bufs: [LsAddr; 4]) -> Result<(), CellError> {
        let (lo, hi) = self.slice_of(0, self.a.n);
        let count = hi - lo;
        let p = self.a.pairs;
        let slice = keys.offset((lo * p.bytes) as u64);
        for b in 0..count.div_ceil(RECORDS_PER_BLOCK) {
            let (first, len, buf) = self
                .next_block(
                    Stream::new(slice, p.bytes, count, RECORDS_PER_BLOCK),
                    b,
                    bufs,
                )
                .await?;
            let recs: Vec<KeyRec> = p.read(self.spe, buf, len)?;
            let list = gather_list(self.a.tris, &recs);
            self.spe.compute_items(self.rates.radix_scatter, len as u64);
            let (obuf, tag) = self.out_buffer(b, bufs).await?;
            self.spe.getl(obuf, &list, tag).await?;
            self.spe.wait_tag(tag).await?;
            let to = self.sorted().offset(((lo + first) * RECORD) as u64);
            self.spe.put(obuf, to, (len * RECORD) as u32, tag).await?;
        }
        self.drain().await
    }
}
