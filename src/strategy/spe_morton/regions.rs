//! `spe_morton`, phase 5 (section 5: "regions of primitives that then
//! could be built-up totally independent"): the regions built by every
//! SPE alone, each in its local store where it fits: through two slots,
//! the next region's gather overlapping this one's build.

use bytemuck::Pod;

use super::pairs::{KeyRec, Pairs, gather_list, ls_for, span};
use super::{JOB, NODE, Program, RECORD, RECORDS_PER_BLOCK};
use crate::bih::BihNode;
use crate::cell::{CellError, Ea, LsAddr};
use crate::kernels::recursion::build_subtree;
use crate::kernels::split::{Side, side_of};
use crate::spe::fig1::stream_bounds;
use crate::spe::layout::TriRecord;
use crate::strategy::machinery::breadth_first::{Job, SpeBuilder};
use crate::strategy::machinery::work_queue::{WorkPpe, from_wire};

impl Program<'_> {
    /// Writes `items` to `ea` in puts of at most 16 KiB, and waits.
    pub(super) async fn write_array<T: Pod>(&self, ea: Ea, items: &[T]) -> Result<(), CellError> {
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
    pub(super) async fn deal(&mut self, regions: &[Job]) -> Result<(), CellError> {
        let spes = self.a.spes;
        let mut load = vec![0u64; spes];
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); spes];
        for (pos, r) in regions.iter().enumerate() {
            let s = (0..spes).min_by_key(|&s| (load[s], s)).expect("an SPE");
            load[s] += r.count as u64;
            lists[s].push(pos as u32);
        }
        self.spe
            .compute_items(self.kernels.spe_job, regions.len() as u64);
        let mut header = vec![0u32; 32];
        let mut all = Vec::with_capacity(regions.len());
        for (s, l) in lists.iter().enumerate() {
            header[2 * s] = all.len() as u32;
            header[2 * s + 1] = l.len() as u32;
            all.extend_from_slice(l);
        }
        self.write_array(self.tables.deal, &all).await?;
        self.write_array(self.a.deal_header, &header).await
    }

    /// Phase 5, every SPE: builds regions until none is left.
    pub(super) async fn build_regions(&mut self) -> Result<(), CellError> {
        let tag = self.line_tag();
        let line = self.line;
        let total = self.read_take_line().await?;
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
                let at = self.tables.deal.offset(((start + i) * 4) as u64);
                self.spe.get(line, Ea(at.0 & !15), 16, tag).await?;
                self.spe.wait_tag(tag).await?;
                v.push(self.spe.ls_read::<u32>(line, 4)?[(at.0 as usize & 15) / 4]);
            }
            Some(v)
        } else {
            None
        };
        debug_assert_eq!(self.spe.ls_free_bytes(), self.region_area);
        let mut next = 0;
        // Regions that fit half the local store go through two slots: the
        // next one is taken and its gather issued before this one's build
        // (unless `--no-prefetch`, or while it would take a region another
        // SPE would start sooner: fewer than four left per SPE), and this
        // one's write-back is waited for only when its slot is loaded again.
        let spes = self.a.spes;
        let mut slots = Slots::two(self)?;
        let mut current = self.take_region(mine.as_deref(), &mut next, total).await?;
        let mut loaded = None;
        while let Some((pos, job)) = current {
            let early = (self.knobs.queue.prefetch && slots.fits(job.count as usize))
                && (mine.is_some() || pos as usize + 4 * spes < total as usize);
            let mut following = None;
            if early {
                following = self.take_region(mine.as_deref(), &mut next, total).await?;
            }
            let side = match slots.fits(job.count as usize) {
                true => {
                    let s = match loaded.take() {
                        Some(s) => s,
                        None => self.load(&slots, 0, &job).await?,
                    };
                    if let Some((_, f)) = following.filter(|(_, f)| slots.fits(f.count as usize)) {
                        loaded = Some(self.load(&slots, 1 - s, &f).await?);
                    }
                    self.build_loaded(&slots, s, &job).await?
                }
                false => {
                    slots.release(self).await?;
                    let side = self.region(&job).await?;
                    slots = Slots::two(self)?;
                    side
                }
            };
            let bounds: [f32; 8] = [
                side.lo.x, side.lo.y, side.lo.z, 0.0, side.hi.x, side.hi.y, side.hi.z, 0.0,
            ];
            self.spe.ls_write(line, &bounds)?;
            let at = self.tables.bounds.offset(pos as u64 * 32);
            self.spe.put(line, at, 32, tag).await?;
            self.spe.wait_tag(tag).await?;
            self.regions_built += 1;
            current = match early {
                true => following,
                false => self.take_region(mine.as_deref(), &mut next, total).await?,
            };
        }
        slots.release(self).await
    }

    /// The tag of the regions phase's small transfers through `line` (the
    /// first two are the slots').
    fn line_tag(&self) -> u32 {
        self.tags + 2
    }

    /// The next region this SPE builds, and its position: from its dealt
    /// list (`mine`, at `next`) or from the atomic counter of `total`.
    async fn take_region(
        &mut self,
        mine: Option<&[u32]>,
        next: &mut usize,
        total: u32,
    ) -> Result<Option<(u32, Job)>, CellError> {
        let (tag, line) = (self.line_tag(), self.line);
        let pos = match mine {
            Some(v) => match v.get(*next) {
                Some(&p) => p,
                None => return Ok(None),
            },
            None => {
                let p = (self.spe)
                    .atomic_fetch_add_u32(line, self.a.take, 1)
                    .await?;
                if p >= total {
                    return Ok(None);
                }
                p
            }
        };
        *next += 1;
        let at = self.tables.jobs.offset(pos as u64 * JOB as u64);
        self.spe.get(line, at, JOB as u32, tag).await?;
        self.spe.wait_tag(tag).await?;
        Ok(Some((
            pos,
            from_wire(&self.spe.ls_read::<u8>(line, JOB)?, JOB)[0],
        )))
    }

    /// Records the local store can hold with their nodes in the regions'
    /// area ([`Program::region_area`]: 48 bytes, at
    /// most two 12-byte nodes each and, unless `--permute`, a key pair),
    /// beside the allocations' rounding: the records' and the nodes' (256
    /// bytes), and the key pairs' buffer (16 bytes more than they take,
    /// rounded to a line: 144).
    pub(super) fn ls_capacity(&self) -> usize {
        let (pair, slack) = match self.knobs.permute {
            true => (0, 256),
            false => (self.a.pairs.bytes, 256 + 144),
        };
        let free = self.region_area.saturating_sub(slack);
        free as usize / (RECORD + 2 * NODE + pair)
    }

    /// The key pairs' width, and where sorted pair `i` lies.
    pub(super) fn sorted_pair(&self, i: usize) -> (Pairs, Ea) {
        let p = self.a.pairs;
        (p, self.a.sorted_keys.offset((i * p.bytes) as u64))
    }

    /// The records in key order: `--permute`'s array, or this SPE's part
    /// of the area the PPE allocates for regions too large for a local
    /// store (place `first` of the region it builds at its start).
    pub(super) fn sorted(&self) -> Ea {
        self.a.sorted.unwrap_or(self.tables.sorted)
    }

    /// Where the records of a region too large for a local store, from
    /// sorted place `first`, lie while it is built.
    fn large_at(&self, first: usize) -> Ea {
        match self.a.sorted {
            Some(all) => all.offset((first * RECORD) as u64),
            None => {
                let part = (self.largest * RECORD).next_multiple_of(128) as u64;
                self.tables.sorted.offset(self.spe.id() as u64 * part)
            }
        }
    }

    /// Gets the key pairs of sorted positions `first..first + count` into
    /// `pairs` (at their address's low four bits: 16 bytes more than
    /// they take), then their records, by their indices, into `recs` (a
    /// getl of a block's records at a time, at the permutation's rate a
    /// record: `MortonRates::radix_scatter`), and waits.
    pub(super) async fn gather(
        &self,
        bufs: (LsAddr, LsAddr),
        first: usize,
        count: usize,
    ) -> Result<(), CellError> {
        self.issue_gather(bufs, first, count, self.tags).await?;
        self.spe.wait_tag(self.tags).await.map(|_| ())
    }

    /// [`Program::gather`] under `tag`, without waiting for the records
    /// (it waits for the pairs, which name them).
    pub(super) async fn issue_gather(
        &self,
        (pairs, recs): (LsAddr, LsAddr),
        first: usize,
        count: usize,
        tag: u32,
    ) -> Result<(), CellError> {
        let (p, at) = self.sorted_pair(first);
        span(self.spe, pairs, at, count * p.bytes, false, tag).await?;
        self.spe.wait_tag(tag).await?;
        let keys: Vec<KeyRec> = p.read(self.spe, ls_for(pairs, at), count)?;
        for (c, chunk) in keys.chunks(RECORDS_PER_BLOCK).enumerate() {
            let list = gather_list(self.a.tris, chunk);
            let ls = recs.offset((c * RECORDS_PER_BLOCK * RECORD) as u32);
            self.spe.getl(ls, &list, tag).await?;
        }
        self.spe
            .compute_items(self.rates.radix_scatter, count as u64);
        Ok(())
    }

    /// Writes the ids of the `count` records at `recs` over the indices of
    /// their key pairs at `pairs` and puts the pairs back to sorted
    /// positions `first..`: the triangles in the tree's order.
    async fn ids_back(
        &self,
        (pairs, recs): (LsAddr, LsAddr),
        first: usize,
        count: usize,
        tag: u32,
    ) -> Result<(), CellError> {
        let ids: Vec<u32> = (self.spe).with_ls(recs, count, |r: &[TriRecord]| {
            r.iter().map(|r| r.id).collect()
        })?;
        let (p, at) = self.sorted_pair(first);
        let mut keys: Vec<KeyRec> = p.read(self.spe, ls_for(pairs, at), count)?;
        for (k, id) in keys.iter_mut().zip(ids) {
            k.index = id;
        }
        p.write(self.spe, ls_for(pairs, at), &keys)?;
        span(self.spe, pairs, at, count * p.bytes, true, tag).await
    }

    /// A region too large for the local store, without `--permute`: its
    /// records gathered into their places of the sorted array (`back`:
    /// after its build, their ids written over its key pairs' indices), a
    /// block at a time.
    async fn large_region_records(
        &self,
        first: usize,
        count: usize,
        back: bool,
    ) -> Result<(), CellError> {
        let mark = self.spe.ls_mark();
        let p = self.a.pairs;
        let pairs = (self.spe).ls_alloc((RECORDS_PER_BLOCK * p.bytes + 16) as u32, 128)?;
        let recs = self
            .spe
            .ls_alloc((RECORDS_PER_BLOCK * RECORD) as u32, 128)?;
        let tag = self.tags;
        for c in (first..first + count).step_by(RECORDS_PER_BLOCK) {
            let len = RECORDS_PER_BLOCK.min(first + count - c);
            let at = self.large_at(first).offset(((c - first) * RECORD) as u64);
            let bytes = (len * RECORD) as u32;
            if back {
                self.spe.get(recs, at, bytes, tag).await?;
                let (_, keys) = self.sorted_pair(c);
                span(self.spe, pairs, keys, len * p.bytes, false, tag).await?;
                self.spe.wait_tag(tag).await?;
                self.ids_back((pairs, recs), c, len, tag).await?;
            } else {
                self.gather((pairs, recs), c, len).await?;
                self.spe.put(recs, at, bytes, tag).await?;
            }
            self.spe.wait_tag(tag).await?;
        }
        self.spe.ls_release_to(mark);
        Ok(())
    }

    /// Builds one region; returns its bounds.
    async fn region(&mut self, job: &Job) -> Result<Side, CellError> {
        let (first, count) = (job.first as usize, job.count as usize);
        if count <= self.ls_capacity() {
            return self.in_local_store(job).await;
        }
        // Too large for the local store: the baseline's breadth-first loop
        // on the records in key order (in `--permute`'s array, or gathered
        // into this SPE's part of the records area, places from 0 there),
        // its WorkAPPE/WorkBPPE in this SPE's part of the spill area.
        let (base, place) = match self.knobs.permute {
            true => (self.sorted(), first),
            false => {
                self.large_region_records(first, count, false).await?;
                (self.large_at(first), 0)
            }
        };
        let at = base.offset((place * RECORD) as u64);
        let mine = self
            .tables
            .spill
            .offset(self.spe.id() as u64 * self.spill_per_spe);
        let half = self.spill_per_spe / 2;
        let work_ppe = WorkPpe::between(mine, mine.offset(half));
        let mark = self.spe.ls_mark();
        // This SPE's own arena list and node writes go on in the loop.
        let arena = self.arena.take().expect("the arena is lent only here");
        let mut b = SpeBuilder::with_arena(
            self.spe,
            base,
            work_ppe,
            self.cfg,
            arena,
            self.knobs.queue,
            self.kernels,
        )?;
        let mut writes = self.writes.take().expect("node writes are here");
        writes.leaf_base = (first - place) as u32;
        b.lend_node_writes(Some(writes));
        let k = self.kernels;
        let side =
            stream_bounds::<TriRecord>(self.spe, &b.fig1, at, count as u64, k.spe_bounds_item)
                .await?;
        let root = Job::new(
            place,
            count,
            job.node as usize,
            job.depth,
            job.candidate(),
            &side,
        );
        let level = b.queue.start(root)?;
        b.levels(level, None).await?;
        b.drain().await?;
        self.items_partitioned += b.stats.items_partitioned;
        self.partitions += b.stats.partitions;
        self.writes = b.lend_node_writes(None);
        if let Some(w) = self.writes.as_mut() {
            w.leaf_base = 0;
        }
        self.arena = Some(b.arena);
        self.spe.ls_release_to(mark);
        if !self.knobs.permute {
            self.large_region_records(first, count, true).await?;
        }
        Ok(side)
    }

    /// Issues the gets (`into_ls`) or puts of `count` records between the
    /// local store at `recs` and main memory at `at`, 16 KiB at a time,
    /// under `tag`.
    async fn move_records(
        &self,
        (recs, at): (LsAddr, Ea),
        count: usize,
        into_ls: bool,
        tag: u32,
    ) -> Result<(), CellError> {
        for c in (0..count).step_by(RECORDS_PER_BLOCK) {
            let len = RECORDS_PER_BLOCK.min(count - c);
            let (ls, ea) = (
                recs.offset((c * RECORD) as u32),
                at.offset((c * RECORD) as u64),
            );
            let bytes = (len * RECORD) as u32;
            match into_ls {
                true => self.spe.get(ls, ea, bytes, tag).await?,
                false => self.spe.put(ls, ea, bytes, tag).await?,
            }
        }
        Ok(())
    }

    /// A region (or piece) larger than a slot of two that still fits the
    /// local store: one slot of its size, loaded, built, written back.
    async fn in_local_store(&mut self, job: &Job) -> Result<Side, CellError> {
        let slots = Slots::new(self, 1, job.count as usize)?;
        let s = self.load(&slots, 0, job).await?;
        let side = self.build_loaded(&slots, s, job).await?;
        slots.release(self).await?;
        Ok(side)
    }

    /// Issues the load of region `job` into slot `s` (once the slot's last
    /// write-back is done): gathered by its keys, or with `--permute` from
    /// the sorted array. Returns `s`.
    async fn load(&self, slots: &Slots, s: usize, job: &Job) -> Result<usize, CellError> {
        let (first, count) = (job.first as usize, job.count as usize);
        let slot = slots.at[s];
        self.spe.wait_tag(slot.tag).await?;
        match slot.pairs {
            Some(pairs) => (self.issue_gather((pairs, slot.recs), first, count, slot.tag)).await?,
            None => {
                let at = self.sorted().offset((first * RECORD) as u64);
                (self.move_records((slot.recs, at), count, true, slot.tag)).await?
            }
        }
        Ok(s)
    }

    /// Region `job`, loaded into slot `s`: built in the local store with
    /// the global heuristic, its write-back issued (its ids over its keys'
    /// indices, or its records) and its nodes written; returns its bounds.
    async fn build_loaded(
        &mut self,
        slots: &Slots,
        s: usize,
        job: &Job,
    ) -> Result<Side, CellError> {
        let (first, count) = (job.first as usize, job.count as usize);
        let (k, cfg, slot) = (self.kernels, self.cfg, slots.at[s]);
        let (depth, cand) = (job.depth, job.candidate());
        self.spe.wait_tag(slot.tag).await?;
        let (side, nodes, stats) =
            self.spe
                .with_ls_mut(slot.recs, count, |items: &mut [TriRecord]| {
                    let side = side_of(items);
                    let mut nodes = vec![BihNode::default()];
                    let stats = build_subtree(items, &mut nodes, 0, 0, count, cand, depth, &cfg);
                    (side, nodes, stats)
                })?;
        // The nodes take their room in the local store too.
        let mark = self.spe.ls_mark();
        self.spe
            .ls_alloc((nodes.len() * NODE).next_multiple_of(16) as u32, 16)?;
        self.spe.ls_release_to(mark);
        self.spe.compute_items(k.spe_bounds_item, count as u64);
        let partitioned = stats.items_partitioned - count as u64;
        self.spe.compute_items(k.spe_partition_item, partitioned);
        self.spe.compute_items(k.spe_job, nodes.len() as u64);
        self.items_partitioned += partitioned;
        self.partitions += stats.partitions;
        match slot.pairs {
            Some(pairs) => (self.ids_back((pairs, slot.recs), first, count, slot.tag)).await?,
            None => {
                let at = self.sorted().offset((first * RECORD) as u64);
                (self.move_records((slot.recs, at), count, false, slot.tag)).await?
            }
        }
        // Local pairs (1, 2), (3, 4), ... take pairs of this SPE's arena.
        let mut global = vec![job.node; nodes.len()];
        for pair in (1..nodes.len()).step_by(2) {
            let g = self.arena().alloc(2).await?;
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
            self.w().push(global[i], node);
        }
        self.w().flush().await?;
        Ok(side)
    }
}

/// One slot of the local store a region is loaded into and built in: its
/// records, its key pairs (none with `--permute`), the tag of its DMA.
#[derive(Clone, Copy)]
struct Slot {
    recs: LsAddr,
    pairs: Option<LsAddr>,
    tag: u32,
}

/// The slots of the regions phase (two, on the first two stream tags, for
/// regions that fit half the local store; or one for a larger region), and
/// the local store's mark before them.
struct Slots {
    at: Vec<Slot>,
    capacity: usize,
    mark: u32,
}

impl Slots {
    /// `n` slots of `capacity` records (0: as many as fit beside the
    /// room of one build's nodes, `NODE` twice a record).
    fn new(p: &Program, n: usize, capacity: usize) -> Result<Self, CellError> {
        let pair = if p.knobs.permute { 0 } else { p.a.pairs.bytes };
        let capacity = match capacity {
            0 => {
                let slack = (256 + 144) * n + 16;
                let free = (p.spe.ls_free_bytes() as usize).saturating_sub(slack);
                free / (n * (RECORD + pair) + 2 * NODE)
            }
            c => c,
        };
        let mark = p.spe.ls_mark();
        let mut at = Vec::with_capacity(n);
        for i in 0..n {
            let recs = (p.spe).ls_alloc((capacity * RECORD).next_multiple_of(128) as u32, 128)?;
            let pairs = match p.knobs.permute {
                true => None,
                false => {
                    let bytes = (capacity * pair + 16).next_multiple_of(128);
                    Some(p.spe.ls_alloc(bytes as u32, 128)?)
                }
            };
            let tag = p.tags + i as u32;
            at.push(Slot { recs, pairs, tag });
        }
        Ok(Slots { at, capacity, mark })
    }

    /// Two slots as large as the local store allows.
    fn two(p: &Program) -> Result<Self, CellError> {
        Self::new(p, 2, 0)
    }

    /// Whether a region of `count` triangles fits a slot.
    fn fits(&self, count: usize) -> bool {
        self.at.len() == 2 && count <= self.capacity
    }

    /// Waits for the slots' write-backs and gives their room back.
    async fn release(self, p: &Program<'_>) -> Result<(), CellError> {
        for s in &self.at {
            p.spe.wait_tag(s.tag).await?;
        }
        p.spe.ls_release_to(self.mark);
        Ok(())
    }
}
