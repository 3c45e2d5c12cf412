//! The PPE's data caches, as its loads meet them: a 32 KiB L1 data cache
//! (4-way set-associative, write-through, no allocation on a store miss)
//! and the 512 KiB L2 (8-way, write-back, allocating on stores), both with
//! 128-byte lines and least-recently-used replacement (the CBE
//! Programming Handbook, §6.1). A program of the PPE feeds it the
//! addresses it reads and writes; the model answers, for each access,
//! where its line was found ([`Level`]) and tallies the answers
//! ([`Loads`]). It prices nothing: the latency of each level is the
//! program's rate to charge (the PPE's measured L1 and L2 hits, and one
//! memory latency derived from this machine's memory interface), so the
//! same scan costs little on a scene whose columns fit the caches and the
//! memory latency where they do not.
//!
//! Both of the PPE's hardware threads share these caches; the model runs
//! one thread's accesses. Addresses are the program's own (any `u64`
//! layout of its arrays): only their lines and sets matter.

/// The bytes of a line of either cache.
pub const LINE: u64 = 128;

/// Where an access found its line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    L1,
    L2,
    /// Neither cache: the line came from main memory.
    Memory,
}

/// Accesses tallied by where their lines were found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Loads {
    pub l1: u64,
    pub l2: u64,
    pub memory: u64,
}

impl Loads {
    /// All accesses tallied.
    pub fn total(&self) -> u64 {
        self.l1 + self.l2 + self.memory
    }

    fn count(&mut self, level: Level) {
        match level {
            Level::L1 => self.l1 += 1,
            Level::L2 => self.l2 += 1,
            Level::Memory => self.memory += 1,
        }
    }
}

impl std::ops::AddAssign for Loads {
    fn add_assign(&mut self, o: Loads) {
        self.l1 += o.l1;
        self.l2 += o.l2;
        self.memory += o.memory;
    }
}

/// One set-associative cache with LRU replacement.
#[derive(Clone, Debug)]
struct SetAssoc {
    ways: usize,
    sets: u64,
    /// `sets × ways` lines (`u64::MAX`: empty), each with the access count
    /// at its last use.
    tags: Vec<u64>,
    used: Vec<u64>,
    clock: u64,
}

impl SetAssoc {
    fn new(bytes: u64, ways: usize) -> Self {
        let sets = bytes / LINE / ways as u64;
        assert!(sets.is_power_of_two(), "{bytes} bytes in {ways} ways");
        SetAssoc {
            ways,
            sets,
            tags: vec![u64::MAX; sets as usize * ways],
            used: vec![0; sets as usize * ways],
            clock: 0,
        }
    }

    fn range(&self, line: u64) -> std::ops::Range<usize> {
        let set = (line % self.sets) as usize;
        set * self.ways..(set + 1) * self.ways
    }

    /// Whether `line` is held; a hit becomes the set's most recent.
    fn touch(&mut self, line: u64) -> bool {
        self.clock += 1;
        let r = self.range(line);
        match self.tags[r.clone()].iter().position(|&t| t == line) {
            Some(w) => {
                self.used[r.start + w] = self.clock;
                true
            }
            None => false,
        }
    }

    /// Puts `line` in place of its set's least recently used.
    fn fill(&mut self, line: u64) {
        let r = self.range(line);
        let lru = (r.clone())
            .min_by_key(|&i| (self.tags[i] != u64::MAX, self.used[i]))
            .expect("a set has ways");
        self.tags[lru] = line;
        self.used[lru] = self.clock;
    }
}

/// The PPE's L1 data cache and L2, empty at the start.
#[derive(Clone, Debug)]
pub struct PpeCaches {
    l1: SetAssoc,
    l2: SetAssoc,
    /// Every access so far, by where it found its line.
    pub loads: Loads,
}

impl PpeCaches {
    /// The PS3's: 32 KiB 4-way L1, 512 KiB 8-way L2.
    pub fn ps3() -> Self {
        PpeCaches {
            l1: SetAssoc::new(32 << 10, 4),
            l2: SetAssoc::new(512 << 10, 8),
            loads: Loads::default(),
        }
    }

    /// A load of the bytes at `ea` (within one line): where its line was;
    /// the line is then in both caches.
    pub fn load(&mut self, ea: u64) -> Level {
        let line = ea / LINE;
        let level = if self.l1.touch(line) {
            Level::L1
        } else if self.l2.touch(line) {
            self.l1.fill(line);
            Level::L2
        } else {
            self.l2.fill(line);
            self.l1.fill(line);
            Level::Memory
        };
        self.loads.count(level);
        level
    }

    /// A store at `ea`: where its line was. The L1 writes through and
    /// takes no line on a miss; the L2 brings a missing line in from
    /// memory to write it.
    pub fn store(&mut self, ea: u64) -> Level {
        let line = ea / LINE;
        let in_l1 = self.l1.touch(line);
        let level = if self.l2.touch(line) {
            if in_l1 { Level::L1 } else { Level::L2 }
        } else {
            self.l2.fill(line);
            Level::Memory
        };
        self.loads.count(level);
        level
    }

    /// Loads every line of `bytes` bytes from `ea` once, in order (a pass
    /// over an array); returns their tally.
    pub fn load_lines(&mut self, ea: u64, bytes: u64) -> Loads {
        let before = self.loads;
        if bytes > 0 {
            for line in ea / LINE..=(ea + bytes - 1) / LINE {
                self.load(line * LINE);
            }
        }
        let mut d = self.loads;
        d.l1 -= before.l1;
        d.l2 -= before.l2;
        d.memory -= before.memory;
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pass_over_a_column_larger_than_the_l2_misses_every_line_each_time() {
        let mut c = PpeCaches::ps3();
        let mb = 3 << 19; // 1.5 MiB
        for _ in 0..2 {
            let t = c.load_lines(0, mb);
            assert_eq!(t.memory, mb / LINE, "{t:?}");
            assert_eq!(t.l1 + t.l2, 0);
        }
    }

    #[test]
    fn what_fits_a_cache_is_found_there_the_second_time() {
        let mut c = PpeCaches::ps3();
        // 16 KiB: the L1's.
        assert_eq!(c.load_lines(0, 16 << 10).memory, 128);
        assert_eq!(c.load_lines(0, 16 << 10).l1, 128);
        // 256 KiB from elsewhere: past the L1, inside the L2.
        let at = 1 << 30;
        assert_eq!(c.load_lines(at, 256 << 10).memory, 2048);
        let again = c.load_lines(at, 256 << 10);
        assert_eq!((again.l2, again.l1, again.memory), (2048, 0, 0));
        // Bytes of one line: one access.
        assert_eq!(c.load_lines(5, 100).total(), 1);
        assert_eq!(c.load_lines(120, 16).total(), 2);
        assert_eq!(c.load_lines(0, 0).total(), 0);
    }

    #[test]
    fn a_set_holds_as_many_lines_as_it_has_ways_and_drops_the_least_recent() {
        let mut c = PpeCaches::ps3();
        // Lines 32 KiB apart share an L1 set (64 sets of 128 B x 4 ways).
        let step = 64 * LINE;
        for i in 0..4 {
            c.load(i * step);
        }
        assert_eq!(c.load(0), Level::L1);
        // A fifth line evicts the least recently used (line 1), not line 0.
        c.load(4 * step);
        assert_eq!(c.load(0), Level::L1);
        assert_eq!(c.load(step), Level::L2);
    }

    #[test]
    fn stores_allocate_in_the_l2_only() {
        let mut c = PpeCaches::ps3();
        assert_eq!(c.store(0), Level::Memory);
        assert_eq!(c.store(0), Level::L2);
        assert_eq!(c.load(0), Level::L2);
        assert_eq!(c.store(0), Level::L1);
        assert_eq!(c.loads.total(), 4);
    }
}
