//! `spe_morton`, between rounds of the top of the tree: **ranges keyed
//! again within their own cell**. Keys of a fixed width run out where a
//! scene is uneven — a model on a floor a thousand times its size, dense
//! clusters far apart: the model's triangles all share one key, and
//! without this one SPE would build the whole model while the others wait.
//! A range whose keys are all equal and that is too large for a local
//! store is found by the top of the tree; every SPE then helps key it
//! again:
//!
//! 1. each SPE gathers the records of its slice of the range (by the pairs'
//!    indices, a DMA list a block) and reduces their centers to a box;
//! 2. from the range's cell, every halving that box lies wholly on one side
//!    of is carried out once (an empty halving: no node, no key bit); the
//!    first halving that parts the centers starts the new keys
//!    (`KeySpec::within`: with the global heuristic's order the builder's
//!    own candidate box there, so the tree stays the baseline's);
//! 3. each SPE keys its slice again (as many halvings as the range's
//!    count needs to reach regions, [`rekey_bits`], from that cell), and
//!    the range is radix-sorted in place by every SPE;
//! 4. the next round of the top splits the range by its new keys.
//!
//! A range whose key pairs fit in a local store is keyed again by one SPE
//! alone (taken largest first from an atomic counter, no barrier): its
//! pairs loaded once, its records gathered twice (the box, the keys), the
//! pairs sorted in the local store and put back — unless the round ends
//! sooner with the largest of them keyed by every SPE
//! ([`share_to_balance`]), as where one SPE would key two while the others
//! wait.
//!
//! So the keys' width follows the spread of the triangles, not their
//! count: bits are spent where the triangles are. A range that cannot be
//! halved any more, or past [`MAX_REKEYS`] ranges or [`MAX_ROUNDS`] rounds,
//! stays one region (built by the breadth-first loop where it overflows a
//! local store). With `--permute` the records are already in key order,
//! and ranges are not keyed again.

use bytemuck::{Pod, Zeroable};
use glam::Vec3A;

use super::pairs::{KeyRec, gather_list, ls_for, span};
use super::ranges::Range;
use super::{Program, RECORD, RECORDS_PER_BLOCK};
use crate::aabb::Aabb;
use crate::cell::CellError;
use crate::kernels::morton::KeySpec;
use crate::kernels::quantise::QuantisedKeys;
use crate::kernels::split::{Boxed, Side};
use crate::spe::layout::TriRecord;
use crate::strategy::machinery::breadth_first::Job;

/// The most ranges keyed again in one build (their table: 64 bytes each,
/// their bounds 32).
pub(super) const MAX_REKEYS: usize = 1024;

/// The most rounds of the top of the tree (the first and those after
/// ranges were keyed again).
pub(super) const MAX_ROUNDS: usize = 8;

/// A range to key again, as its table holds it: 96 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct Found {
    pub range: Range,
    /// Its cell: the candidate box where its keys ran out.
    cell: [f32; 8],
    /// Where its new keys start (`KeySpec::within`), once keyed again.
    start: [f32; 8],
}
const FOUND: usize = size_of::<Found>();

fn record(b: Aabb) -> [f32; 8] {
    let (a, c) = (b.min, b.max);
    [a.x, a.y, a.z, 0.0, c.x, c.y, c.z, 0.0]
}

fn aabb(c: &[f32; 8]) -> Aabb {
    Aabb::new(
        glam::Vec3::new(c[0], c[1], c[2]),
        glam::Vec3::new(c[4], c[5], c[6]),
    )
}

impl Found {
    pub fn new(range: Range, cell: Aabb) -> Self {
        Found {
            range,
            cell: record(cell),
            start: [0.0; 8],
        }
    }

    fn cell(&self) -> Aabb {
        aabb(&self.cell)
    }
}

/// The key bits a range of `count` keyed again gets: as the scene's own
/// keys (`kernels::morton::auto_key_bits`), the halvings that bring it to
/// regions of `region` triangles were it even, and four more; at most
/// `most` (what its pairs hold).
pub(super) fn rekey_bits(count: usize, region: usize, most: u32) -> u32 {
    let halvings = (count as f64 / region.max(1) as f64).log2().ceil().max(0.0) as u32;
    (halvings + 4).clamp(1, most)
}

/// A range keyed again by every SPE costs each SPE this share of what
/// keying it alone costs one SPE, in thousandths (on the model, both
/// classes' rates alike: 31 ns a record over 8 SPEs against 200 ns a
/// record alone, the paper's class).
const SHARED_PER_RECORD: u64 = 160;

/// And this much besides, in records keyed alone (its barriers and the
/// box exchanged: 46 µs, about 230 records alone).
const SHARED_FIXED: u64 = 230;

/// How many of the largest ranges that fit one local store (`counts`,
/// largest first) to key by every SPE rather than alone, so that the
/// round ends soonest: each choice priced in records keyed alone — the
/// shared ones' share on every SPE ([`SHARED_PER_RECORD`],
/// [`SHARED_FIXED`]) plus the longest SPE's of the rest dealt largest
/// first to the least loaded (as the counter hands them out). Ties keep
/// more ranges alone.
pub(super) fn share_to_balance(counts: &[u64], spes: usize) -> usize {
    let cost = |k: usize| {
        let shared: u64 = (counts[..k].iter())
            .map(|&c| c * SHARED_PER_RECORD / 1000 + SHARED_FIXED)
            .sum();
        let mut load = vec![0u64; spes.max(1)];
        for &c in &counts[k..] {
            *load.iter_mut().min().expect("an SPE") += c;
        }
        shared + load.iter().max().copied().unwrap_or(0)
    };
    (0..=counts.len())
        .min_by_key(|&k| (cost(k), k))
        .unwrap_or(0)
}

/// Where a range an SPE found went: keyed again (its index among every
/// SPE's), or left one region (its index in the SPE's regions).
#[derive(Clone, Copy, Debug)]
pub(super) enum Placed {
    Rekey(usize),
    Region(usize),
}

impl Program<'_> {
    /// Whether ranges may be keyed again: not with `--permute`, not past
    /// the last round.
    pub(super) fn rekeys_on(&self) -> bool {
        !self.knobs.permute && self.rounds < MAX_ROUNDS
    }

    /// Every SPE, before the barrier that ends a round of the top: the
    /// ranges it found get places in the table (one fetch-and-add) and are
    /// written there; those past [`MAX_REKEYS`] become regions.
    pub(super) async fn publish_found(&mut self) -> Result<(), CellError> {
        let found = std::mem::take(&mut self.found);
        if found.is_empty() {
            return Ok(());
        }
        let (line, at) = (self.line, self.a.rekey_line);
        let base = (self.spe)
            .atomic_fetch_add_u32(line, at, found.len() as u32)
            .await? as usize;
        let fits = MAX_REKEYS.saturating_sub(base).min(found.len());
        for (i, f) in found.iter().enumerate() {
            if i < fits {
                self.placed.push(Placed::Rekey(base + i));
                continue;
            }
            let r = f.range;
            let (first, count) = (r.first as usize, r.count as usize);
            let job = Job::new(first, count, r.id as usize, r.depth, f.cell(), &Side::EMPTY);
            self.placed.push(Placed::Region(self.regions.len()));
            self.regions.push(job);
        }
        if fits > 0 {
            let to = self.a.rekeys.offset((base * FOUND) as u64);
            self.write_array(to, &found[..fits]).await?;
        }
        Ok(())
    }

    /// Every SPE, after a round of the top: the ranges found in it (each
    /// with its index), read from the table.
    pub(super) async fn found_this_round(&mut self) -> Result<Vec<(usize, Found)>, CellError> {
        self.rounds += 1;
        let (line, tag) = (self.line, self.tags);
        self.spe.get(line, self.a.rekey_line, 128, tag).await?;
        self.spe.wait_tag(tag).await?;
        let total = (self.spe.ls_read::<u32>(line, 1)?[0] as usize).min(MAX_REKEYS);
        let (from, new) = (self.rekeys, total - self.rekeys);
        if new == 0 {
            return Ok(Vec::new());
        }
        let at = self.a.rekeys.offset((from * FOUND) as u64);
        let found: Vec<Found> = self.read_array(at, new).await?;
        self.rekeys = total;
        Ok((from..total).zip(found).collect())
    }

    /// This SPE's slice of `first..first + count`.
    pub(super) fn slice_of(&self, first: usize, count: usize) -> (usize, usize) {
        let (s, id) = (self.a.spes, self.spe.id());
        let bound = |k: usize| first + if k == s { count } else { (count * k / s) & !1 };
        (bound(id), bound(id + 1))
    }

    /// Every SPE, after a round of the top: keys again every range found
    /// in it — those too large for one local store by every SPE together,
    /// one after another, the others each by one SPE alone — and returns
    /// them as the next round's roots (each with its index).
    pub(super) async fn rekey_round(
        &mut self,
        found: &[(usize, Found)],
    ) -> Result<Vec<(usize, Range)>, CellError> {
        let alone = self.alone_capacity();
        let (mut shared, mut solo): (Vec<&(usize, Found)>, Vec<_>) = found
            .iter()
            .partition(|(_, f)| f.range.count as usize > alone);
        // The rest largest first (ties by index); the largest of them
        // keyed by every SPE too where that evens the round out.
        solo.sort_by_key(|(j, f)| (std::cmp::Reverse(f.range.count), *j));
        let counts: Vec<u64> = solo.iter().map(|(_, f)| f.range.count as u64).collect();
        shared.extend(solo.drain(..share_to_balance(&counts, self.a.spes)));
        for &&(j, f) in &shared {
            self.rekey_shared(j, &f).await?;
        }
        // The rest from a counter, largest first.
        let (line, at) = (self.line, self.a.rekey_line);
        loop {
            let k = self.spe.atomic_fetch_add_u32(line, at.offset(4), 1).await? as usize;
            let Some(k) = k.checked_sub(self.solo_taken).filter(|&k| k < solo.len()) else {
                break;
            };
            let &(j, f) = solo[k];
            self.rekey_alone(j, &f).await?;
        }
        self.barrier().await?;
        // Past this round's takes (every SPE took once in vain).
        self.solo_taken += solo.len() + self.a.spes;
        // Every range's start, as the SPE that keyed it wrote it.
        let first = found.first().map_or(0, |f| f.0);
        let at = self.a.rekeys.offset((first * FOUND) as u64);
        let table: Vec<Found> = self.read_array(at, found.len()).await?;
        let mut roots = Vec::with_capacity(found.len());
        for ((j, _), f) in found.iter().zip(table) {
            let r = f.range;
            let bits = self.rekey_bits(r.count as usize);
            let spec = KeySpec {
                bits,
                scene: aabb(&f.start),
                ..self.specs[r.spec as usize]
            };
            debug_assert_eq!(self.specs.len(), 1 + j);
            self.specs.push(spec);
            roots.push((
                *j,
                Range {
                    used: 0,
                    spec: (1 + j) as u32,
                    ..r
                },
            ));
        }
        Ok(roots)
    }

    /// The key bits of a range of `count` keyed again.
    fn rekey_bits(&self, count: usize) -> u32 {
        let most = (self.a.pairs.bytes as u32 - 4) * 8;
        rekey_bits(count, self.knobs.region_size, most.min(64))
    }

    /// The new start of range `j` (`f`) from the box of its centers:
    /// written to its entry of the table.
    /// Every SPE of a shared range computes it; `write`: this one writes it.
    async fn start_from(
        &mut self,
        (j, f): (usize, &Found),
        (lo, hi): (Vec3A, Vec3A),
        write: bool,
    ) -> Result<KeySpec, CellError> {
        let r = f.range;
        let parent = self.specs[r.spec as usize];
        let (spec, skipped) = parent
            .within(f.cell(), lo, hi)
            .expect("a range is keyed again only where its cell halves");
        self.spe
            .compute_items(self.rates.key_bit, skipped as u64 + 1);
        let spec = KeySpec {
            bits: self.rekey_bits(r.count as usize),
            ..spec
        };
        let entry = Found {
            start: record(spec.scene),
            ..*f
        };
        if write {
            let at = self.a.rekeys.offset((j * FOUND) as u64);
            self.write_array(at, &[entry]).await?;
        }
        Ok(spec)
    }

    /// Every SPE: keys the range `f` (index `j`) again within its cell and
    /// sorts it in place.
    async fn rekey_shared(&mut self, j: usize, f: &Found) -> Result<(), CellError> {
        let r = f.range;
        let (first, count) = (r.first as usize, r.count as usize);
        // 1. The box of this slice's centers, then of everyone's.
        let side = self.sweep(f, None).await?;
        let (lo_c, hi_c) = self.share_box(side).await?;
        // 2. The range's own start: its cell past the empty halvings.
        let spec = (self.start_from((j, f), (lo_c, hi_c), self.spe.id() == 0)).await?;
        // 3. Its new keys, over the old ones, into the keys array from which
        // its passes end in the sorted one; then its sort.
        let passes = crate::kernels::radix::passes(spec.bits, self.knobs.digit_bits) as usize;
        let all =
            crate::kernels::radix::passes(self.knobs.key_bits, self.knobs.digit_bits) as usize;
        let from = (all + passes) % 2;
        self.sweep(f, Some((spec, from))).await?;
        self.barrier().await?;
        let mark = self.spe.ls_mark();
        let bufs = self.stream_buffers()?;
        for pass in 0..passes {
            let at = (from + pass) % 2;
            self.radix_pass(pass as u32, bufs, (first, count), at)
                .await?;
            self.barrier().await?;
        }
        self.spe.ls_release_to(mark);
        Ok(())
    }

    /// Key pairs one SPE keys again alone in its local store: the pairs
    /// (twice: sorted into a second buffer) beside two record blocks.
    fn alone_capacity(&self) -> usize {
        let blocks = 2 * (RECORDS_PER_BLOCK * RECORD + 128);
        let free = self.spe.ls_free_bytes().saturating_sub(blocks as u32 + 512) as usize;
        free / (2 * self.a.pairs.bytes)
    }

    /// One SPE: keys the range `f` (index `j`) again alone: its pairs
    /// loaded once, its records gathered for the box of their centers and
    /// again for their keys, the pairs sorted in the local store at the
    /// radix sort's rates, and put back.
    async fn rekey_alone(&mut self, j: usize, f: &Found) -> Result<(), CellError> {
        let r = f.range;
        let (first, count) = (r.first as usize, r.count as usize);
        let (p, tag) = (self.a.pairs, self.tags);
        let mark = self.spe.ls_mark();
        let buf = self.spe.ls_alloc((count * p.bytes + 16) as u32, 128)?;
        let recs = self
            .spe
            .ls_alloc((RECORDS_PER_BLOCK * RECORD) as u32, 128)?;
        let (_, at) = self.sorted_pair(first);
        span(self.spe, buf, at, count * p.bytes, false, tag).await?;
        self.spe.wait_tag(tag).await?;
        let mut pairs: Vec<KeyRec> = p.read(self.spe, ls_for(buf, at), count)?;
        let tris = self.a.tris;
        let list_of = move |pairs: &[KeyRec]| gather_list(tris, pairs);
        let mut side = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        let mut spec = None;
        for sweep in 0..2 {
            for c in (0..count).step_by(RECORDS_PER_BLOCK) {
                let len = RECORDS_PER_BLOCK.min(count - c);
                let list = list_of(&pairs[c..c + len]);
                self.spe.getl(recs, &list, tag).await?;
                self.spe.compute_items(self.rates.radix_scatter, len as u64);
                self.spe.wait_tag(tag).await?;
                let cs: Vec<Vec3A> = (self.spe).with_ls(recs, len, |rs: &[TriRecord]| {
                    rs.iter().map(|t| t.center()).collect()
                })?;
                match spec {
                    None => {
                        side = cs.iter().fold(side, |(a, b), &c| (a.min(c), b.max(c)));
                        self.spe
                            .compute_items(self.kernels.spe_bounds_item, len as u64);
                    }
                    Some((_, ref q)) => self.key_pairs(q, &cs, &mut pairs[c..c + len]),
                }
            }
            if sweep == 0 {
                let s: KeySpec = self.start_from((j, f), side, true).await?;
                spec = Some((s, self.quantised(&s)));
            }
        }
        // The sort, LSD in the local store (stable, as the passes are):
        // per pass a histogram step a key and an entry, a scatter step a key.
        let bits = spec.expect("the second sweep has its spec").0.bits;
        let passes = crate::kernels::radix::passes(bits, self.knobs.digit_bits) as u64;
        let digits = 1u64 << self.knobs.digit_bits;
        pairs.sort_by_key(|k| k.key);
        let (rc, rs) = (self.rates.radix_count, self.rates.radix_scatter);
        self.spe.compute_items(rc, passes * (count as u64 + digits));
        self.spe.compute_items(rs, passes * count as u64);
        self.spe.ls_alloc((count * p.bytes + 16) as u32, 128)?;
        p.write(self.spe, ls_for(buf, at), &pairs)?;
        span(self.spe, buf, at, count * p.bytes, true, tag).await?;
        self.spe.wait_tag(tag).await?;
        self.spe.ls_release_to(mark);
        Ok(())
    }

    /// The new keys of `pairs`, whose records' centers are `centers`, by
    /// `q`; their cost charged.
    fn key_pairs(&self, q: &QuantisedKeys, centers: &[Vec3A], pairs: &mut [KeyRec]) {
        let mut keys = vec![0; centers.len()];
        self.spe.compute(self.rates.keys(q, centers, &mut keys));
        for (p, k) in pairs.iter_mut().zip(keys) {
            p.key = k;
        }
    }

    /// One sweep over this SPE's slice of the range `f`, its records
    /// gathered by their pairs a block at a time (the next block's gather
    /// overlapping this one's work): with `keys` (a spec and a keys array)
    /// each pair's new key written to that array, at its place; without,
    /// the box of the records' centers, which it returns.
    async fn sweep(
        &mut self,
        f: &Found,
        keys: Option<(KeySpec, usize)>,
    ) -> Result<(Vec3A, Vec3A), CellError> {
        let (lo, hi) = self.slice_of(f.range.first as usize, f.range.count as usize);
        let blocks: Vec<(usize, usize)> = (lo..hi)
            .step_by(RECORDS_PER_BLOCK)
            .map(|c| (c, RECORDS_PER_BLOCK.min(hi - c)))
            .collect();
        let mark = self.spe.ls_mark();
        let p = self.a.pairs;
        let quantised = keys.map(|(spec, _)| self.quantised(&spec));
        let mut sets = Vec::new();
        for _ in 0..2 {
            let pairs = (self.spe).ls_alloc((RECORDS_PER_BLOCK * p.bytes + 16) as u32, 128)?;
            let recs = (self.spe).ls_alloc((RECORDS_PER_BLOCK * RECORD) as u32, 128)?;
            sets.push((pairs, recs));
        }
        let tag = |k: usize| self.tags + (k % 2) as u32;
        let mut side = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        if let Some(&(c, len)) = blocks.first() {
            self.issue_gather(sets[0], c, len, tag(0)).await?;
        }
        for (k, &(c, len)) in blocks.iter().enumerate() {
            if let Some(&(next, n)) = blocks.get(k + 1) {
                self.spe.wait_tag(tag(k + 1)).await?;
                self.issue_gather(sets[(k + 1) % 2], next, n, tag(k + 1))
                    .await?;
            }
            self.spe.wait_tag(tag(k)).await?;
            let (pairs, recs) = sets[k % 2];
            let centers: Vec<Vec3A> = (self.spe).with_ls(recs, len, |rs: &[TriRecord]| {
                rs.iter().map(|t| t.center()).collect()
            })?;
            let Some((_, into)) = keys else {
                side = centers.iter().fold(side, |(a, b), &c| (a.min(c), b.max(c)));
                self.spe
                    .compute_items(self.kernels.spe_bounds_item, len as u64);
                continue;
            };
            let (_, at) = self.sorted_pair(c);
            let mut pairs_here: Vec<KeyRec> = p.read(self.spe, ls_for(pairs, at), len)?;
            let quantised = quantised.as_ref().expect("a spec");
            self.key_pairs(quantised, &centers, &mut pairs_here);
            let to = self.a.keys[into].offset((c * p.bytes) as u64);
            p.write(self.spe, ls_for(pairs, to), &pairs_here)?;
            span(self.spe, pairs, to, len * p.bytes, true, tag(k)).await?;
        }
        self.spe
            .wait_tags(0b11 << self.tags, crate::cell::WaitMode::All)
            .await?;
        self.spe.ls_release_to(mark);
        Ok(side)
    }

    /// Every SPE: its box `side` through its row of the (idle) radix count
    /// table; returns the union of every SPE's.
    async fn share_box(&mut self, side: (Vec3A, Vec3A)) -> Result<(Vec3A, Vec3A), CellError> {
        let (line, tag, spes) = (self.line, self.tags, self.a.spes);
        let stride = 4u64 << self.knobs.digit_bits;
        let counts = self.a.counts;
        let row = move |s: usize| counts.offset(s as u64 * stride);
        let (a, b) = side;
        self.spe
            .ls_write(line, &[a.x, a.y, a.z, 0.0, b.x, b.y, b.z, 0.0])?;
        self.spe.put(line, row(self.spe.id()), 32, tag).await?;
        self.spe.wait_tag(tag).await?;
        self.barrier().await?;
        let mut all = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        for s in 0..spes {
            self.spe.get(line, row(s), 32, tag).await?;
            self.spe.wait_tag(tag).await?;
            let w = self.spe.ls_read::<f32>(line, 8)?;
            all.0 = all.0.min(Vec3A::new(w[0], w[1], w[2]));
            all.1 = all.1.max(Vec3A::new(w[4], w[5], w[6]));
        }
        Ok(all)
    }
}

#[cfg(test)]
mod tests {
    use super::share_to_balance;

    /// As many equal ranges as SPEs: each keys one alone. One range far
    /// larger than the rest: every SPE keys it, the rest alone. Nothing to
    /// gain: alone.
    #[test]
    fn the_largest_ranges_are_shared_only_where_that_evens_the_round() {
        assert_eq!(share_to_balance(&[3000; 8], 8), 0);
        assert_eq!(
            share_to_balance(&[8000, 900, 800, 700, 600, 500, 400, 300], 8),
            1
        );
        assert_eq!(share_to_balance(&[], 8), 0);
        assert_eq!(share_to_balance(&[100], 1), 0);
        // Nine equal ranges on eight SPEs: one SPE would key two; sharing
        // one of them costs every SPE a sixth of it and its barriers.
        assert_eq!(share_to_balance(&[5000; 9], 8), 1);
    }
}
