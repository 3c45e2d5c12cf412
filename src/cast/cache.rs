//! The software cache an SPE reads main memory through (the frame of
//! DESIGN.md's "The whole frame on the Cell"; issue 27): as the IBM SDK's
//! `cache-api.h` and Codeplay's Offload cache do it, 128-byte lines in a
//! set-associative array in the local store, least recently used within a
//! set. Read-only: the tracer never writes through it, so there is
//! nothing to write back and nothing to keep coherent between SPEs (the
//! tree and the triangles do not change while a frame is cast).
//!
//! Layout in the local store: way `w` of set `s` is the line at
//! `((w × sets) + s) × 128`, so the lines of one way are contiguous and
//! consecutive memory lines (consecutive sets) of one way are contiguous
//! too: a fetch of several lines at once (`fetch_lines`, Bullet's SPU BVH
//! code fetched 2 KiB subtrees) is one get, into one way of consecutive
//! sets.
//!
//! Costs: each line an access touches costs `cache_lookup` (the SDK
//! cache's read hit, measured), each miss `cache_miss` of software
//! bookkeeping on top of the get the machine times ([`CastRates`]).

use super::CastRates;
use crate::cell::{CellError, Ea, LsAddr, Spe};

/// Bytes of a cache line: the DMA's and the atomic unit's line.
pub const LINE: u64 = 128;

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
}

/// What a cache did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CacheStats {
    /// Lines looked up (an access touching two lines looks up two).
    pub lookups: u64,
    /// Lookups that missed: each cost a get.
    pub misses: u64,
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
    }
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
    clock: u64,
    tag: u32,
    rates: CastRates,
    pub stats: CacheStats,
}

impl SoftwareCache {
    /// A cache of shape `cfg` in this SPE's local store (its lines and its
    /// tag array: 8 bytes a line), reading with DMA tag group "software
    /// cache".
    pub fn new(spe: &Spe, cfg: CacheConfig, rates: CastRates) -> Result<Self, CellError> {
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
            clock: 0,
            tag: spe.tag("software cache")?,
            rates,
            stats: CacheStats::default(),
        })
    }

    /// Reads `out.len()` bytes at `ea` through the cache: every line they
    /// touch is looked up, and fetched by a get on a miss. The bytes must
    /// lie in memory that whole lines can be read from (buffers padded to
    /// 128 bytes).
    pub async fn read(&mut self, spe: &Spe, ea: Ea, out: &mut [u8]) -> Result<(), CellError> {
        let mut done = 0usize;
        while done < out.len() {
            let at = ea.0 + done as u64;
            let (line, offset) = (at / LINE, at % LINE);
            let n = ((LINE - offset) as usize).min(out.len() - done);
            let slot = self.slot(spe, line).await?;
            let ls = self.data.offset(slot * LINE as u32 + offset as u32);
            spe.with_ls(ls, n, |b: &[u8]| out[done..done + n].copy_from_slice(b))?;
            done += n;
        }
        Ok(())
    }

    /// The slot holding memory line `line`, fetched if it is not there.
    async fn slot(&mut self, spe: &Spe, line: u64) -> Result<u32, CellError> {
        spe.compute(self.rates.cache_lookup);
        self.stats.lookups += 1;
        self.clock += 1;
        let set = (line % self.sets as u64) as u32;
        let hit = (0..self.ways)
            .map(|w| w * self.sets + set)
            .find(|&s| self.tags[s as usize] == line + 1);
        if let Some(s) = hit {
            self.used[s as usize] = self.clock;
            return Ok(s);
        }
        // A miss: the least recently used way of the line's set; with
        // `fetch_lines` above 1, the same way of the following sets takes
        // the following lines (wrapping at the last set would not be
        // contiguous: the fetch stops there).
        self.stats.misses += 1;
        spe.compute(self.rates.cache_miss);
        let way = (0..self.ways)
            .min_by_key(|&w| self.used[(w * self.sets + set) as usize])
            .expect("a cache has at least one way");
        let count = self.fetch.min(self.sets - set) as u64;
        let first = way * self.sets + set;
        for k in 0..count as u32 {
            // A line already in another way of its set leaves it: one copy.
            for w in 0..self.ways {
                let other = (w * self.sets + set + k) as usize;
                if self.tags[other] == line + k as u64 + 1 {
                    self.tags[other] = 0;
                }
            }
            self.tags[(first + k) as usize] = line + k as u64 + 1;
            self.used[(first + k) as usize] = self.clock;
        }
        let ls = self.data.offset(first * LINE as u32);
        spe.get(ls, Ea(line * LINE), (count * LINE) as u32, self.tag)
            .await?;
        spe.wait_tag(self.tag).await?;
        Ok(first)
    }
}
