//! The software cache an SPE reads main memory through (the frame of
//! DESIGN.md's "The whole frame on the Cell", and section 5's proposal for
//! the job queue): as the IBM SDK's
//! `cache-api.h` and Codeplay's Offload cache do it, 128-byte lines in a
//! set-associative array in the local store, least recently used within a
//! set. The builders and the caster only read through it: what it reads
//! must not change while it may hold it (the tree and the triangles while
//! a frame is cast; a level's job array within the level, the cache
//! emptied at the level's barrier: [`SoftwareCache::invalidate`]). A
//! program may also write through it ([`SoftwareCache::write`], as
//! Codeplay's Offload code writes an outer array): the line is fetched,
//! changed in the local store and put back whole when it leaves the cache
//! or at [`SoftwareCache::flush`]. Nothing keeps it coherent between SPEs,
//! as nothing does the SDK's.
//!
//! Layout in the local store: way `w` of set `s` is the line at
//! `((w × sets) + s) × 128`, so the lines of one way are contiguous and
//! consecutive memory lines (consecutive sets) of one way are contiguous
//! too: a fetch of several lines at once (`fetch_lines`, Bullet's SPU BVH
//! code fetched 2 KiB subtrees) is one get, into one way of consecutive
//! sets.
//!
//! A miss need not wait: [`SoftwareCache::lookup`] starts the get and
//! says which tag group brings the line, so that the caster can go on
//! with another ray meanwhile (Benthin et al. 2006's "software
//! hyperthreading", `--rays-in-flight`); a slot whose get is under way, or
//! which a ray waits to read, is not evicted. [`SoftwareCache::read`]
//! waits for each miss.
//!
//! Costs ([`CacheRates`]): each line an access touches costs `lookup`
//! (Codeplay's cache's measured read hit), each miss `miss` of software
//! bookkeeping on top of the get the machine times.

use crate::cell::{CellError, Cycles, Ea, LsAddr, Spe};
use crate::kernels::rates::{Band, Code, Count, Rate, RateOverrides, overridden};

/// Bytes of a cache line: the DMA's and the atomic unit's line.
pub const LINE: u64 = 128;

/// What the cache's own code costs the SPU (`docs/cost-model.md`, "The
/// ray caster's kernels").
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct CacheRates {
    /// Per cache line an access touches: Codeplay's measured read hit, 28
    /// cycles (a measurement: not scaled).
    pub lookup: Cycles,
    /// Per miss, besides the lookup and the get the machine times: the
    /// published miss (about 600 cycles with its DMA) less the lookup and
    /// a lone 128-byte get on the model (316 cycles).
    pub miss: Cycles,
    /// Per line emptied by [`SoftwareCache::invalidate`]: its 8-byte tag
    /// cleared, two a quadword store (derived: half a cycle, scaled ×4
    /// like every derived kernel: 2).
    pub invalidate_line: Cycles,
}

/// A line emptied: its tag cleared, two tags a quadword store: half a
/// cycle counted.
pub const INVALIDATE_COUNT: Count = Count::tenths(5);

impl CacheRates {
    /// Codeplay's measured lookup and miss; the emptying in the class
    /// `code`.
    pub const fn of(code: Code) -> CacheRates {
        CacheRates {
            lookup: Cycles(28),
            miss: Cycles(600 - 28 - 316),
            invalidate_line: code.charge(INVALIDATE_COUNT),
        }
    }

    /// The software cache's rates, each named (`cache.…`) and banded: one
    /// set for every software cache (the caster's, `spe_bfs_shared`'s job
    /// cache).
    pub fn table(code: Code) -> Vec<Rate<CacheRates>> {
        crate::rate_table!(CacheRates, "cache.", {
            lookup: Band::Fitted,
            miss: Band::Fitted,
            invalidate_line: code.band(INVALIDATE_COUNT),
        })
        .to_vec()
    }

    /// The rates in the class of `rates`, with its overrides.
    pub fn with(rates: &RateOverrides) -> CacheRates {
        let code = rates.code();
        overridden(Self::of(code), &Self::table(code), rates)
    }
}

/// A cache's shape: total size, ways, lines fetched by one miss.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct CacheConfig {
    /// Local store for the lines, KiB (a power of two times `ways`
    /// lines); the SDK's default is 32.
    pub kib: u32,
    /// Lines per set (the SDK's default is 4).
    pub ways: u32,
    /// Consecutive lines one miss fetches in one get (1: the line alone).
    pub fetch_lines: u32,
}

impl CacheConfig {
    /// The IBM SDK's default: 32 KiB, 4-way, one line a miss.
    pub const SDK: CacheConfig = CacheConfig {
        kib: 32,
        ways: 4,
        fetch_lines: 1,
    };

    /// Sets in the cache; an error names a shape that does not divide
    /// into whole sets of whole lines, or fetches more lines than a set
    /// count or a DMA (16 KiB) holds.
    pub fn sets(&self) -> Result<u32, String> {
        let lines = self.kib as u64 * 1024 / LINE;
        if self.ways == 0 || lines == 0 || !lines.is_multiple_of(self.ways as u64) {
            return Err(format!(
                "a software cache of {} KiB in {} ways: the lines ({lines}) must divide into whole sets",
                self.kib, self.ways
            ));
        }
        let sets = (lines / self.ways as u64) as u32;
        if self.fetch_lines == 0
            || self.fetch_lines > sets
            || self.fetch_lines as u64 * LINE > 16 * 1024
        {
            return Err(format!(
                "fetching {} lines a miss: at least 1, at most the {sets} sets of a way and 128 lines (one 16 KiB get)",
                self.fetch_lines
            ));
        }
        Ok(sets)
    }

    /// Bytes of local store the cache takes: its lines and its tag array
    /// (8 bytes a line).
    pub fn ls_bytes(&self) -> u32 {
        self.kib * 1024 / LINE as u32 * (LINE as u32 + 8)
    }
}

/// What a cache did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CacheStats {
    /// Lines looked up (an access touching two lines looks up two).
    pub lookups: u64,
    /// Lookups that missed: each cost a get.
    pub misses: u64,
    /// Times the cache was emptied.
    pub invalidations: u64,
}

impl CacheStats {
    pub fn hit_rate(&self) -> f64 {
        if self.lookups == 0 {
            return 1.0;
        }
        1.0 - self.misses as f64 / self.lookups as f64
    }
}

impl std::ops::AddAssign for CacheStats {
    fn add_assign(&mut self, o: Self) {
        self.lookups += o.lookups;
        self.misses += o.misses;
        self.invalidations += o.invalidations;
    }
}

/// What a lookup found ([`SoftwareCache::lookup`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lookup {
    /// The line is in this slot.
    Ready(u32),
    /// The line is on its way into this slot by tag group `tag`: wait for
    /// the group, then read the slot.
    Fetching { slot: u32, tag: u32 },
    /// A miss whose set has no way to take it: every way is on its way in
    /// or awaited by a ray. Look up again once a fetch has arrived.
    Full,
}

/// One SPE's software cache.
pub struct SoftwareCache {
    data: LsAddr,
    sets: u32,
    ways: u32,
    fetch: u32,
    /// Memory line number + 1 held by each slot (`way × sets + set`); 0:
    /// empty. (The SDK keeps these tags in the local store too; they are
    /// counted in its footprint below.)
    tags: Vec<u64>,
    /// When each slot was last used, for least recently used.
    used: Vec<u64>,
    /// The tag group whose get fills each slot, + 1 (0: nothing under
    /// way): such a slot is not evicted until its get has been waited for.
    pending: Vec<u32>,
    /// The slots each of the cache's tag groups is filling.
    inflight: Vec<Vec<u32>>,
    /// Rays waiting to read each slot: such a slot is not evicted.
    pins: Vec<u32>,
    /// Slots written since they were fetched: put back before they are
    /// reused, and at [`SoftwareCache::flush`].
    dirty: Vec<bool>,
    clock: u64,
    /// The first of the cache's tag groups (one per ray in flight).
    first_tag: u32,
    rates: CacheRates,
    pub stats: CacheStats,
}

impl SoftwareCache {
    /// A cache of shape `cfg` in this SPE's local store (its lines and its
    /// tag array: 8 bytes a line), reading with `groups` DMA tag groups
    /// "software cache" (one for each ray that may have a miss under way).
    pub fn new(
        spe: &Spe,
        cfg: CacheConfig,
        rates: CacheRates,
        groups: u32,
    ) -> Result<Self, CellError> {
        let sets = cfg.sets().map_err(CellError::Config)?;
        let slots = sets * cfg.ways;
        let data = spe.ls_alloc(slots * LINE as u32, 128)?;
        spe.ls_alloc(slots * 8, 16)?;
        Ok(SoftwareCache {
            data,
            sets,
            ways: cfg.ways,
            fetch: cfg.fetch_lines,
            tags: vec![0; slots as usize],
            used: vec![0; slots as usize],
            pending: vec![0; slots as usize],
            inflight: vec![Vec::new(); groups as usize],
            pins: vec![0; slots as usize],
            dirty: vec![false; slots as usize],
            clock: 0,
            first_tag: spe.tags("software cache", groups)?,
            rates,
            stats: CacheStats::default(),
        })
    }

    /// Reads `out.len()` bytes at `ea` through the cache, waiting for each
    /// miss: every line they touch is looked up, and fetched by a get on a
    /// miss. The bytes must lie in memory that whole lines can be read
    /// from (buffers padded to 128 bytes).
    pub async fn read(&mut self, spe: &Spe, ea: Ea, out: &mut [u8]) -> Result<(), CellError> {
        let mut done = 0usize;
        while done < out.len() {
            let at = ea.0 + done as u64;
            let n = ((LINE - at % LINE) as usize).min(out.len() - done);
            let slot = self.ready(spe, at / LINE).await?;
            self.copy(spe, slot, at, &mut out[done..done + n])?;
            done += n;
        }
        Ok(())
    }

    /// Writes `bytes` at `ea` through the cache: every line they touch is
    /// looked up (fetched whole on a miss, waiting for it) and changed in
    /// the local store; it goes back to memory when it leaves the cache or
    /// at [`SoftwareCache::flush`]. The cache must fetch one line a miss.
    pub async fn write(&mut self, spe: &Spe, ea: Ea, bytes: &[u8]) -> Result<(), CellError> {
        assert_eq!(
            self.fetch, 1,
            "a software cache written through fetches one line a miss"
        );
        let mut done = 0usize;
        while done < bytes.len() {
            let at = ea.0 + done as u64;
            let n = ((LINE - at % LINE) as usize).min(bytes.len() - done);
            let slot = self.ready(spe, at / LINE).await?;
            let ls = self.data.offset(slot * LINE as u32 + (at % LINE) as u32);
            spe.with_ls_mut(ls, n, |b: &mut [u8]| {
                b.copy_from_slice(&bytes[done..done + n])
            })?;
            self.dirty[slot as usize] = true;
            done += n;
        }
        Ok(())
    }

    /// Puts every line written since it was fetched back to memory and
    /// waits for the puts (the cache keeps the lines).
    pub async fn flush(&mut self, spe: &Spe) -> Result<(), CellError> {
        let tag = self.first_tag;
        for slot in 0..self.tags.len() {
            if std::mem::take(&mut self.dirty[slot]) {
                let ls = self.data.offset(slot as u32 * LINE as u32);
                spe.put(ls, Ea((self.tags[slot] - 1) * LINE), LINE as u32, tag)
                    .await?;
            }
        }
        spe.wait_tag(tag).await
    }

    /// Memory line `line`'s slot, once the line is in (a lone reader or
    /// writer: it waits for its own miss).
    async fn ready(&mut self, spe: &Spe, line: u64) -> Result<u32, CellError> {
        Ok(match self.lookup(spe, line, 0).await? {
            Lookup::Ready(slot) => slot,
            Lookup::Fetching { slot, tag } => {
                spe.wait_tag(tag).await?;
                self.arrived(1 << tag);
                slot
            }
            Lookup::Full => unreachable!("a lone reader leaves no slot pending"),
        })
    }

    /// Copies `out.len()` bytes at `ea` (within one line) out of `slot`.
    pub fn copy(&self, spe: &Spe, slot: u32, ea: u64, out: &mut [u8]) -> Result<(), CellError> {
        let ls = self.data.offset(slot * LINE as u32 + (ea % LINE) as u32);
        spe.with_ls(ls, out.len(), |b: &[u8]| out.copy_from_slice(b))
    }

    /// Looks memory line `line` up; on a miss starts its get with tag
    /// group `group` (of the cache's) and does not wait for it.
    pub async fn lookup(&mut self, spe: &Spe, line: u64, group: u32) -> Result<Lookup, CellError> {
        spe.compute(self.rates.lookup);
        self.stats.lookups += 1;
        self.clock += 1;
        let set = (line % self.sets as u64) as u32;
        let slot = |w: u32| (w * self.sets + set) as usize;
        if let Some(s) = (0..self.ways).find(|&w| self.tags[slot(w)] == line + 1) {
            let s = slot(s);
            self.used[s] = self.clock;
            return Ok(match self.pending[s] {
                0 => Lookup::Ready(s as u32),
                g => Lookup::Fetching {
                    slot: s as u32,
                    tag: g - 1,
                },
            });
        }
        // A miss: the least recently used way of the line's set that no
        // get and no ray is using; with `fetch_lines` above 1, the same
        // way of the following sets takes the following lines (wrapping at
        // the last set would not be contiguous: the fetch stops there, and
        // before a slot or a line in use).
        let Some(way) = (0..self.ways)
            .filter(|&w| !self.busy(slot(w)))
            .min_by_key(|&w| self.used[slot(w)])
        else {
            return Ok(Lookup::Full);
        };
        self.stats.misses += 1;
        spe.compute(self.rates.miss);
        let first = way * self.sets + set;
        let tag = self.first_tag + group;
        let mut count = 0u32;
        while count < self.fetch.min(self.sets - set) {
            let (k, want) = (first + count, line + count as u64 + 1);
            // A line already in another way of its set leaves it (one
            // copy), unless a get or a ray is using it.
            let copies: Vec<usize> = (0..self.ways)
                .map(|w| (w * self.sets + set + count) as usize)
                .filter(|&o| self.tags[o] == want)
                .collect();
            if count > 0 && (self.busy(k as usize) || copies.iter().any(|&o| self.busy(o))) {
                break;
            }
            for o in copies {
                self.tags[o] = 0;
            }
            self.write_back(spe, k as usize, tag).await?;
            self.tags[k as usize] = want;
            self.used[k as usize] = self.clock;
            self.pending[k as usize] = tag + 1;
            self.inflight[group as usize].push(k);
            count += 1;
        }
        let ls = self.data.offset(first * LINE as u32);
        spe.get(ls, Ea(line * LINE), count * LINE as u32, tag)
            .await?;
        Ok(Lookup::Fetching { slot: first, tag })
    }

    /// A written slot about to be reused goes back to memory first (its
    /// put on `tag`, waited for before the slot is fetched into).
    async fn write_back(&mut self, spe: &Spe, slot: usize, tag: u32) -> Result<(), CellError> {
        if !std::mem::take(&mut self.dirty[slot]) {
            return Ok(());
        }
        let ls = self.data.offset(slot as u32 * LINE as u32);
        spe.put(ls, Ea((self.tags[slot] - 1) * LINE), LINE as u32, tag)
            .await?;
        spe.wait_tag(tag).await
    }

    fn busy(&self, slot: usize) -> bool {
        self.pending[slot] != 0 || self.pins[slot] != 0
    }

    /// The tag groups `done` (a mask) have been waited for: their lines
    /// are in.
    pub fn arrived(&mut self, done: u32) {
        for (g, slots) in self.inflight.iter_mut().enumerate() {
            if done >> (self.first_tag + g as u32) & 1 == 1 {
                for s in slots.drain(..) {
                    self.pending[s as usize] = 0;
                }
            }
        }
    }

    /// The mask of the tag groups with a get under way.
    pub fn outstanding(&self) -> u32 {
        (self.inflight.iter().enumerate())
            .filter(|(_, slots)| !slots.is_empty())
            .fold(0, |m, (g, _)| m | 1 << (self.first_tag + g as u32))
    }

    /// A ray waits to read `slot`: keep it.
    pub fn pin(&mut self, slot: u32) {
        self.pins[slot as usize] += 1;
    }

    /// Empties the cache, for memory that changes after this: every line
    /// dropped (none may be on its way or awaited).
    pub fn invalidate(&mut self, spe: &Spe) {
        assert!(
            self.pending.iter().chain(&self.pins).all(|&p| p == 0),
            "a software cache emptied with reads under way"
        );
        assert!(
            !self.dirty.contains(&true),
            "a software cache emptied with written lines not flushed"
        );
        spe.compute_items(self.rates.invalidate_line, self.tags.len() as u64);
        self.tags.fill(0);
        self.stats.invalidations += 1;
    }

    /// A ray has read the slot it waited for.
    pub fn unpin(&mut self, slot: u32) {
        self.pins[slot as usize] -= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell::{Cell, CellConfig};
    use crate::kernels::rates::Code;

    /// A small cache written through over a region eight times its size:
    /// lines leave it written and come back; after the flush, memory holds
    /// every byte written, and reading through the cache gives them too.
    #[test]
    fn what_is_written_through_the_cache_reaches_memory() {
        let mut cell = Cell::new(CellConfig::ps3().with_spes(1)).unwrap();
        let words = 2048u64;
        let region = cell.memory_mut().alloc("region", words * 4, 128).unwrap();
        let shape = CacheConfig {
            kib: 1,
            ways: 2,
            fetch_lines: 1,
        };
        let run = cell.spawn_spe(0, move |spe| async move {
            let mut cache = SoftwareCache::new(&spe, shape, CacheRates::of(Code::Paper), 1)?;
            // Two passes, the second reading what the first wrote.
            for i in 0..words {
                let at = Ea(region.0 + ((i * 37) % words) * 4);
                cache.write(&spe, at, &(i as u32 * 3).to_le_bytes()).await?;
            }
            let mut back = 0u64;
            for i in 0..words {
                let mut b = [0u8; 4];
                cache.read(&spe, Ea(region.0 + i * 4), &mut b).await?;
                back += u32::from_le_bytes(b) as u64;
            }
            cache.flush(&spe).await?;
            Ok((back, cache.stats))
        });
        cell.run().unwrap();
        let (back, stats) = run.take("spe 0").unwrap();
        let expected: u64 = (0..words).map(|i| i * 3).sum();
        assert_eq!(back, expected);
        let memory: Vec<u32> = cell.memory_mut().read_pod(region, words as usize).unwrap();
        for i in 0..words {
            assert_eq!(
                memory[((i * 37) % words) as usize],
                i as u32 * 3,
                "word {i}"
            );
        }
        // 64 lines through 8 slots: most accesses of the scattered pass miss.
        assert!(stats.misses > words / 2, "{stats:?}");
    }
}
