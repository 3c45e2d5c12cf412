//! `spe_morton`, phase 4 (section 5's "regions of primitives that then
//! could be built-up totally independent", on every SPE): the top
//! of the tree from the sorted keys. A node splits where its range's keys
//! first differ (Karras 2012), found by binary search over the sorted keys
//! in main memory, down to **regions** of at most `--region-size`
//! triangles (or ranges that share their whole key, or leaves).
//!
//! 1. SPE 0 splits the largest range first until there are
//!    [`SUBTOPS_PER_SPE`] ranges per SPE (the **sub-tops**), and writes
//!    them to a table, largest first;
//! 2. every SPE takes sub-tops from an atomic counter and splits each down
//!    to regions (its probes are the phase's time: a get each);
//! 3. every SPE writes its count of regions; SPE 0 asks the PPE for the
//!    region tables; every SPE writes its regions there; SPE 0 sorts them
//!    largest first (the order they are taken in) and writes where each
//!    went;
//! 4. last ([`Program::write_top`]), once the regions' bounds are known:
//!    every SPE writes its sub-tops' nodes, their clip planes from the
//!    regions' bounds, bottom up, and each sub-top's bounds; then SPE 0
//!    the nodes above the sub-tops.

use bytemuck::Pod;
use glam::Vec3;

use super::pairs::{ls_for, span};
use super::ranges::{RANGE, Range};
use super::rekey::{Found, Placed};
use super::{JOB, Program, REGIONS, SPILL_UNIT};
use crate::aabb::Aabb;
use crate::bih::BihNode;
use crate::cell::{CellError, Ea, LsAddr};
use crate::kernels::morton::KeyOrder;
use crate::kernels::split::Side;
use crate::strategy::machinery::breadth_first::Job;
use crate::strategy::machinery::work_queue::{from_wire, to_wire};

/// Ranges SPE 0 splits the top into before every SPE takes a part, per
/// SPE: enough that taking them largest first balances the probes.
pub(super) const SUBTOPS_PER_SPE: usize = 4;

/// One node of the top of the tree, as an SPE keeps it until the regions'
/// bounds are known. Children come after their parents.
pub(super) enum Top {
    Inner {
        id: u32,
        children: u32,
        axis: usize,
        /// Top indices of the two children.
        kids: [usize; 2],
    },
    /// A region, by its index in this SPE's list.
    Region(usize),
    /// A range keyed again within its cell (`rekey`), by its index in this
    /// SPE's list of those it found: its own top comes in a later round.
    Rekey(usize),
    /// SPE 0's nodes above the sub-tops: a sub-top, by its index.
    Sub(usize),
}

/// What an SPE keeps of the top of the tree for [`Program::write_top`].
#[derive(Default)]
pub(super) struct TopPart {
    /// The nodes of the sub-tops this SPE split.
    nodes: Vec<Top>,
    /// (sub-top index, index of its root in `nodes`).
    roots: Vec<(usize, usize)>,
    /// SPE 0: the nodes above the sub-tops.
    above: Vec<Top>,
    /// SPE 0, a round after the first: (re-keyed range, index of its root
    /// in `above`).
    rekey_roots: Vec<(usize, usize)>,
}

/// No parent: the root.
const NO_PARENT: usize = usize::MAX;

/// The word of the regions' line that holds the largest region too large
/// for a local store (after the SPEs' first places, at most 16).
const LARGEST: usize = 31;

/// The slots of a later round's roots (the re-keyed ranges): `ROOT + j`.
const ROOT: usize = usize::MAX / 2;

/// Hooks child `slot` (2 parent + side) of a top list to index `at`;
/// notes where a re-keyed range's root went.
fn link(list: &mut [Top], slot: usize, at: usize, roots: &mut Vec<(usize, usize)>) {
    if slot == NO_PARENT {
        return;
    }
    if slot >= ROOT {
        roots.push((slot - ROOT, at));
    } else if let Top::Inner { kids, .. } = &mut list[slot / 2] {
        kids[slot % 2] = at;
    }
}

/// Bytes of key pairs a split reads in one get once its range fits: the
/// splits below it probe them in the local store.
pub(super) const WINDOW: usize = 16 * 1024;

/// The keys of one range in the local store: sorted positions `first`
/// to `first + count`, the first at `ls`.
#[derive(Clone, Copy)]
pub(super) struct KeyWindow {
    first: usize,
    count: usize,
    ls: LsAddr,
}

impl KeyWindow {
    fn covers(&self, first: usize, count: usize) -> bool {
        self.first <= first && first + count <= self.first + self.count
    }
}

impl Program<'_> {
    /// The key at sorted position `i`: in the key window's local store
    /// where it covers `i` (a probe's instructions), else one small get
    /// from main memory.
    async fn key_at(&self, keys: Ea, i: usize) -> Result<u64, CellError> {
        let (tag, p) = (self.tags, self.a.pairs);
        if let Some(w) = self.window.filter(|w| w.covers(i, 1)) {
            self.spe.compute(self.rates.key_probe);
            let at = w.ls.offset(((i - w.first) * p.bytes) as u32);
            return Ok(p.read(self.spe, at, 1)?[0].key);
        }
        let at = keys.offset((i * p.bytes) as u64);
        span(self.spe, self.line, at, p.bytes, false, tag).await?;
        self.spe.wait_tag(tag).await?;
        Ok(p.read(self.spe, ls_for(self.line, at), 1)?[0].key)
    }

    /// Before splitting `r`: where its keys fit [`WINDOW`] and the window
    /// does not hold them yet, reads them into it (`buf`) in one get.
    async fn window_for(&mut self, keys: Ea, r: Range, buf: LsAddr) -> Result<(), CellError> {
        let (first, count, p) = (r.first as usize, r.count as usize, self.a.pairs);
        let held = self.window.is_some_and(|w| w.covers(first, count));
        if held || count * p.bytes > WINDOW {
            return Ok(());
        }
        let at = keys.offset((first * p.bytes) as u64);
        span(self.spe, buf, at, count * p.bytes, false, self.tags).await?;
        self.spe.wait_tag(self.tags).await?;
        let ls = ls_for(buf, at);
        self.window = Some(KeyWindow { first, count, ls });
        Ok(())
    }

    /// Splits `r` (charged one job and its probes) into `list`: a region,
    /// a range to key again within its cell (one that shares its whole key
    /// and is too large for a local store), or an inner node whose two
    /// child ranges it returns (their parent slots `2 at` and `2 at + 1`).
    async fn split(
        &mut self,
        keys: Ea,
        r: Range,
        list: &mut Vec<Top>,
    ) -> Result<Option<[Range; 2]>, CellError> {
        self.spe.compute(self.kernels.spe_job);
        let spec = self.specs[r.spec as usize];
        let (first, count, depth) = (r.first as usize, r.count as usize, r.depth);
        let bits = spec.bits;
        let key_first = self.key_at(keys, first).await?;
        let leafish = count <= self.knobs.region_size || self.cfg.ends_in_leaf(count, depth);
        let mut whole_key = false;
        let split = if leafish {
            None
        } else {
            let key_last = self.key_at(keys, first + count - 1).await?;
            let diff = key_first ^ key_last;
            whole_key = diff == 0;
            if diff == 0 {
                None
            } else {
                let bit = diff.leading_zeros() - (64 - bits);
                let mask = 1u64 << (bits - 1 - bit);
                // The first key with the bit set: binary search.
                let (mut l, mut h) = (first + 1, first + count - 1);
                while l < h {
                    let m = l + (h - l) / 2;
                    if self.key_at(keys, m).await? & mask == 0 {
                        l = m + 1;
                    } else {
                        h = m;
                    }
                }
                Some((bit, (l - first) as u32))
            }
        };
        let Some((bit, left)) = split else {
            if whole_key && count > self.ls_capacity() && self.rekeys_on() {
                let cell = spec.cell(key_first, bits);
                if crate::kernels::morton::can_halve(&cell) {
                    list.push(Top::Rekey(self.placed.len() + self.found.len()));
                    self.found.push(Found::new(r, cell));
                    return Ok(None);
                }
            }
            let cell = spec.cell(key_first, r.used);
            let job = Job::new(first, count, r.id as usize, depth, cell, &Side::EMPTY);
            list.push(Top::Region(self.regions.len()));
            self.regions.push(job);
            return Ok(None);
        };
        let axis = match spec.order {
            KeyOrder::GlobalHeuristic => spec.cell(key_first, bit).longest_axis(),
            KeyOrder::RoundRobin => (bit % 3) as usize,
        };
        let children = self.arena().alloc(2).await?;
        list.push(Top::Inner {
            id: r.id,
            children,
            axis,
            kids: [0, 0],
        });
        let child = |first, count, id| Range {
            first,
            count,
            id,
            depth: depth + 1,
            used: bit + 1,
            spec: r.spec,
            pad: [0; 2],
        };
        Ok(Some([
            child(r.first, left, children),
            child(r.first + left, r.count - left, children + 1),
        ]))
    }

    /// Phase 4, every SPE: one round of the top of the tree — from the
    /// root (`rekeyed` empty), or from the ranges just keyed again
    /// (`rekeyed`: each its index among them and its range) — down to
    /// regions and ranges to key again.
    pub(super) async fn top(
        &mut self,
        keys: Ea,
        rekeyed: &[(usize, Range)],
    ) -> Result<TopPart, CellError> {
        let mut part = TopPart::default();
        // 1. SPE 0: the largest ranges first, until there are enough.
        if self.spe.id() == 0 {
            let mut pending = Vec::new();
            if rekeyed.is_empty() {
                let root = self.arena().alloc(1).await?;
                let whole = Range {
                    first: 0,
                    count: self.a.n as u32,
                    id: root,
                    ..Range::default()
                };
                pending.push((NO_PARENT, whole));
            }
            pending.extend(rekeyed.iter().map(|&(j, r)| (ROOT + j, r)));
            let target = SUBTOPS_PER_SPE * self.a.spes;
            let mut above = Vec::new();
            while !pending.is_empty() && pending.len() < target {
                // The largest, the first of equals: deterministic.
                let i = (0..pending.len())
                    .max_by_key(|&i| (pending[i].1.count, std::cmp::Reverse(i)))
                    .expect("a range");
                let (slot, r) = pending.remove(i);
                let at = above.len();
                link(&mut above, slot, at, &mut part.rekey_roots);
                if let Some([l, r]) = self.split(keys, r, &mut above).await? {
                    pending.extend([(2 * at, l), (2 * at + 1, r)]);
                }
            }
            pending.sort_by_key(|p| std::cmp::Reverse(p.1.count));
            for (k, &(slot, _)) in pending.iter().enumerate() {
                let at = above.len();
                link(&mut above, slot, at, &mut part.rekey_roots);
                above.push(Top::Sub(k));
            }
            let subs: Vec<Range> = pending.iter().map(|p| p.1).collect();
            self.write_array(self.a.subtops, &subs).await?;
            let (line, take, total) = (self.line, self.a.take, subs.len() as u32);
            self.spe
                .atomic_update_line(line, take, |w| (w[0], w[1]) = (0, total))
                .await?;
            part.above = above;
        }
        self.barrier().await?;
        self.split_subtops(keys, &mut part).await?;
        self.publish_found().await?;
        self.barrier().await?;
        Ok(part)
    }

    /// Step 2 of a round, every SPE: sub-tops from the counter, each split
    /// to regions, the keys of each range that fits read into a window
    /// once.
    async fn split_subtops(&mut self, keys: Ea, part: &mut TopPart) -> Result<(), CellError> {
        let mark = self.spe.ls_mark();
        let window = self.spe.ls_alloc((WINDOW + 16) as u32, 128)?;
        let (line, take, tag) = (self.line, self.a.take, self.tags);
        self.spe.get(line, take, 128, tag).await?;
        self.spe.wait_tag(tag).await?;
        let subs = self.spe.ls_read::<u32>(line, 2)?[1] as usize;
        loop {
            let k = self.spe.atomic_fetch_add_u32(line, take, 1).await? as usize;
            if k >= subs {
                break;
            }
            let at = self.a.subtops.offset((k * RANGE) as u64);
            self.spe.get(line, at, RANGE as u32, tag).await?;
            self.spe.wait_tag(tag).await?;
            let sub = self.spe.ls_read::<Range>(line, 1)?[0];
            part.roots.push((k, part.nodes.len()));
            let mut stack = vec![(NO_PARENT, sub)];
            while let Some((slot, r)) = stack.pop() {
                self.window_for(keys, r, window).await?;
                let at = part.nodes.len();
                link(&mut part.nodes, slot, at, &mut part.rekey_roots);
                if let Some([l, r]) = self.split(keys, r, &mut part.nodes).await? {
                    stack.extend([(2 * at + 1, r), (2 * at, l)]);
                }
            }
        }
        self.window = None;
        self.spe.ls_release_to(mark);
        Ok(())
    }

    /// After the last round, every SPE: the region tables, the regions
    /// largest first.
    pub(super) async fn place_regions(&mut self) -> Result<(), CellError> {
        let regions = std::mem::take(&mut self.regions);
        self.region_offset = self.region_tables(&regions).await?;
        self.region_count = regions.len();
        if self.spe.id() == 0 {
            self.sort_regions().await?;
        }
        Ok(())
    }

    /// Every SPE: its count of regions to SPE 0, which asks the PPE for the
    /// region tables; its regions written to their unsorted places.
    /// Returns where they start.
    async fn region_tables(&mut self, regions: &[Job]) -> Result<usize, CellError> {
        let (line, tag, spes) = (self.line, self.tags, self.a.spes);
        // Each SPE's count and largest region in its row of the (idle)
        // radix count table.
        let (counts, stride) = (self.a.counts, 4u64 << self.knobs.digit_bits);
        let row = move |s: usize| counts.offset(s as u64 * stride);
        let largest = regions.iter().map(|j| j.count).max().unwrap_or(0);
        self.spe
            .ls_write(line, &[regions.len() as u32, largest, 0, 0])?;
        self.spe.put(line, row(self.spe.id()), 16, tag).await?;
        self.spe.wait_tag(tag).await?;
        self.barrier().await?;
        if self.spe.id() == 0 {
            let mut offsets = Vec::with_capacity(spes);
            let (mut total, mut largest) = (0u32, 0u32);
            for s in 0..spes {
                self.spe.get(line, row(s), 16, tag).await?;
                self.spe.wait_tag(tag).await?;
                let w = self.spe.ls_read::<u32>(line, 2)?;
                offsets.push(total);
                total += w[0];
                largest = largest.max(w[1]);
            }
            // Regions too large for the local store run the breadth-first
            // loop: each SPE gets WorkAPPE and WorkBPPE for the largest.
            let cap = self.ls_capacity();
            self.spill_per_spe = match largest as usize > cap {
                true => (2 * Job::spill_bytes_for(largest as usize, &self.cfg))
                    .next_multiple_of(SPILL_UNIT),
                false => 0,
            };
            let spill = (self.spill_per_spe / SPILL_UNIT) as u32;
            // Their records, gathered while each is built, in a part of
            // its own for each SPE, sized for the largest.
            let large = if spill > 0 { largest } else { 0 };
            self.spe.write_out_mbox(REGIONS).await;
            self.spe.write_out_mbox(total).await;
            self.spe.write_out_mbox(spill).await;
            self.spe.write_out_mbox(large).await;
            for t in self.tables.in_order() {
                *t = Ea(self.spe.read_in_mbox().await as u64);
            }
            let mut tables = self.tables;
            self.spe
                .atomic_update_line(line, self.a.take, |w| {
                    (w[0], w[1]) = (0, total);
                    for (i, t) in tables.in_order().into_iter().enumerate() {
                        w[2 + i] = t.0 as u32;
                    }
                    w[8] = spill;
                    w[9..9 + spes].copy_from_slice(&offsets);
                    w[LARGEST] = large;
                })
                .await?;
        }
        self.barrier().await?;
        self.read_take_line().await?;
        let offset = self.spe.ls_read::<u32>(line, 32)?[9 + self.spe.id()] as usize;
        let at = self.tables.jobs.offset((offset * JOB) as u64);
        self.write_array(at, &to_wire(regions, JOB)).await?;
        self.barrier().await?;
        Ok(offset)
    }

    /// Reads the regions' line: their count, the tables, the spill size.
    /// Returns the count.
    pub(super) async fn read_take_line(&mut self) -> Result<u32, CellError> {
        let (line, tag) = (self.line, self.tags);
        self.spe.get(line, self.a.take, 128, tag).await?;
        self.spe.wait_tag(tag).await?;
        let w = self.spe.ls_read::<u32>(line, 9)?;
        for (i, t) in self.tables.in_order().into_iter().enumerate() {
            *t = Ea(w[2 + i] as u64);
        }
        self.spill_per_spe = w[8] as u64 * SPILL_UNIT;
        self.largest = self.spe.ls_read::<u32>(line, 32)?[LARGEST] as usize;
        Ok(w[1])
    }

    /// SPE 0: every region job read back, sorted largest first (ties by
    /// place: deterministic), written back; each unsorted place's sorted
    /// position written to the positions table (and the static deal).
    async fn sort_regions(&mut self) -> Result<(), CellError> {
        let total = self.read_take_line().await? as usize;
        let wire: Vec<u8> = self.read_array(self.tables.jobs, total * JOB).await?;
        let jobs: Vec<Job> = from_wire(&wire, JOB);
        let mut order: Vec<usize> = (0..total).collect();
        order.sort_by_key(|&r| std::cmp::Reverse(jobs[r].count));
        self.spe.compute_items(self.kernels.spe_job, total as u64);
        let mut position = vec![0u32; total];
        for (pos, &r) in order.iter().enumerate() {
            position[r] = pos as u32;
        }
        let sorted: Vec<Job> = order.iter().map(|&r| jobs[r]).collect();
        self.write_array(self.tables.jobs, &to_wire(&sorted, JOB))
            .await?;
        self.write_array(self.tables.positions, &position).await?;
        if self.knobs.static_regions {
            self.deal(&sorted).await?;
        }
        Ok(())
    }

    /// Reads `count` items at `ea` in gets of at most 16 KiB.
    pub(super) async fn read_array<T: Pod>(
        &self,
        ea: Ea,
        count: usize,
    ) -> Result<Vec<T>, CellError> {
        let per = (16 * 1024) / size_of::<T>();
        let tag = self.tags;
        let mark = self.spe.ls_mark();
        let buf = self.spe.ls_alloc(16 * 1024, 128)?;
        let mut out = Vec::with_capacity(count);
        for c in (0..count).step_by(per.max(1)) {
            let len = per.min(count - c);
            let at = ea.offset((c * size_of::<T>()) as u64);
            let bytes = (len * size_of::<T>()).next_multiple_of(16) as u32;
            self.spe.get(buf, at, bytes, tag).await?;
            self.spe.wait_tag(tag).await?;
            out.extend(self.spe.ls_read::<T>(buf, len)?);
        }
        self.spe.ls_release_to(mark);
        Ok(out)
    }

    /// Last, every SPE, a round at a time from the last: its sub-tops'
    /// nodes, their clip planes from the bounds of the regions and of the
    /// ranges keyed again, and each sub-top's bounds; after a barrier,
    /// SPE 0 the nodes above the sub-tops and the bounds of the round's
    /// roots (a range keyed again, for the round before).
    pub(super) async fn write_top(&mut self, parts: &[TopPart]) -> Result<(), CellError> {
        let total = self.read_take_line().await? as usize;
        let mut region_bounds = Vec::new();
        if self.region_count > 0 {
            let bounds: Vec<[f32; 8]> = self.read_array(self.tables.bounds, total).await?;
            let at = self
                .tables
                .positions
                .offset((4 * self.region_offset as u64) & !15);
            let skip = self.region_offset % 4;
            let positions: Vec<u32> = self.read_array(at, skip + self.region_count).await?;
            region_bounds = positions[skip..]
                .iter()
                .map(|&p| to_aabb(&bounds[p as usize]))
                .collect();
        }
        for (round, part) in parts.iter().enumerate().rev() {
            let mut rekeyed = Vec::new();
            if round + 1 < parts.len() {
                let b: Vec<[f32; 8]> = self.read_array(self.a.rekey_bounds, self.rekeys).await?;
                rekeyed = b.iter().map(to_aabb).collect();
            }
            let known = (&region_bounds[..], &rekeyed[..]);
            let of = self.write_nodes(&part.nodes, known, &[]).await?;
            for &(k, root) in &part.roots {
                self.put_bounds(self.a.sub_bounds.offset((k * 32) as u64), of[root])
                    .await?;
            }
            self.w().flush().await?;
            self.barrier().await?;
            if self.spe.id() == 0 {
                let subs = part
                    .above
                    .iter()
                    .filter(|t| matches!(t, Top::Sub(_)))
                    .count();
                let sub: Vec<[f32; 8]> = self.read_array(self.a.sub_bounds, subs).await?;
                let sub: Vec<Aabb> = sub.iter().map(to_aabb).collect();
                let of = self.write_nodes(&part.above, known, &sub).await?;
                for &(j, at) in &part.rekey_roots {
                    self.put_bounds(self.a.rekey_bounds.offset((j * 32) as u64), of[at])
                        .await?;
                }
            }
            self.w().flush().await?;
            if round > 0 {
                self.barrier().await?;
            }
        }
        Ok(())
    }

    /// Puts `b` as a 32-byte bounds record at `at`, and waits.
    async fn put_bounds(&self, at: Ea, b: Aabb) -> Result<(), CellError> {
        let rec: [f32; 8] = [
            b.min.x, b.min.y, b.min.z, 0.0, b.max.x, b.max.y, b.max.z, 0.0,
        ];
        self.spe.ls_write(self.line, &rec)?;
        self.spe.put(self.line, at, 32, self.tags).await?;
        self.spe.wait_tag(self.tags).await.map(|_| ())
    }

    /// Writes the inner nodes of `list`, bottom up, their clip planes from
    /// the bounds of its regions, ranges keyed again (`known`) and
    /// sub-tops; returns every node's bounds.
    async fn write_nodes(
        &mut self,
        list: &[Top],
        (regions, rekeyed): (&[Aabb], &[Aabb]),
        subs: &[Aabb],
    ) -> Result<Vec<Aabb>, CellError> {
        let mut of = vec![Aabb::EMPTY; list.len()];
        for (i, t) in list.iter().enumerate().rev() {
            of[i] = match *t {
                Top::Region(r) => regions[r],
                Top::Rekey(l) => match self.placed[l] {
                    Placed::Rekey(j) => rekeyed[j],
                    Placed::Region(r) => regions[r],
                },
                Top::Sub(k) => subs[k],
                Top::Inner {
                    id,
                    children,
                    axis,
                    kids,
                } => {
                    let (l, r) = (of[kids[0]], of[kids[1]]);
                    self.w()
                        .push(id, BihNode::inner(children, axis, l.max[axis], r.min[axis]));
                    self.spe.compute(self.kernels.spe_job);
                    l.union(r)
                }
            };
        }
        Ok(of)
    }
}

/// A 32-byte bounds record as a box.
fn to_aabb(b: &[f32; 8]) -> Aabb {
    Aabb::new(Vec3::new(b[0], b[1], b[2]), Vec3::new(b[4], b[5], b[6]))
}
