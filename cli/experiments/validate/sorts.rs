//! `validate`'s sorts: Codeplay's quicksort ("Optimizing Sort Algorithms
//! for the PS3", parts 1 and 4, 2011: the textbook quicksort, the middle
//! item the pivot, Hoare's two scans), timed on a retail PS3 on one SPU —
//! the array left in main memory, read and written through Offload's
//! software cache — and on the PPU. Both are held out: the SPU's is
//! emulated through the model's software cache with its instruction
//! counts in the paper's class (scalar compiled C++, like the paper's
//! partition); the PPU's is written with the PPE's measured latencies
//! that its update rates are built from (`kernels::ppe_rates::latency`).
//! The input: `n` floats, uniform in [0, 1), from a fixed seed.

use cellbih::cell::ppe_cache::PpeCaches;
use cellbih::cell::{Cell, CellConfig, CellError, CostModel, Cycles, Ea};
use cellbih::kernels::ppe_rates::{latency, loads_cycles};
use cellbih::kernels::rates::{Code, Count};
use cellbih::spe::software_cache::{CacheConfig, CacheRates, SoftwareCache};

/// An access the sort made to its array, in order.
#[derive(Clone, Copy)]
enum Access {
    Read(u32),
    Write(u32, f32),
}

/// What the sort did, counted, and its accesses in order.
#[derive(Default)]
struct Sorted {
    accesses: Vec<Access>,
    /// Items compared with the pivot by the two scans.
    compares: u64,
    /// Rounds of the partition loop (each ends both scans once).
    rounds: u64,
    swaps: u64,
    /// Calls that partitioned a range of at least two items.
    partitions: u64,
}

/// `n` floats uniform in [0, 1) from a fixed seed (splitmix64).
fn floats(n: usize) -> Vec<f32> {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    (0..n)
        .map(|_| {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect()
}

/// The quicksort, on the host, logging every access to `data`: the
/// recursion as an explicit stack of ranges, in the same order.
fn quicksort(data: &mut [f32]) -> Sorted {
    let mut s = Sorted::default();
    let read = |s: &mut Sorted, d: &[f32], i: i64| {
        s.accesses.push(Access::Read(i as u32));
        d[i as usize]
    };
    let mut ranges = vec![(0i64, data.len() as i64 - 1)];
    while let Some((start, end)) = ranges.pop() {
        if end - start + 1 < 2 {
            continue;
        }
        s.partitions += 1;
        let pivot = read(&mut s, data, start + ((end - start) >> 1));
        let (mut i, mut j) = (start, end);
        while i <= j {
            s.rounds += 1;
            loop {
                s.compares += 1;
                if read(&mut s, data, i) >= pivot {
                    break;
                }
                i += 1;
            }
            loop {
                s.compares += 1;
                if read(&mut s, data, j) <= pivot {
                    break;
                }
                j -= 1;
            }
            if i <= j {
                s.swaps += 1;
                data.swap(i as usize, j as usize);
                s.accesses.push(Access::Write(i as u32, data[i as usize]));
                s.accesses.push(Access::Write(j as u32, data[j as usize]));
                i += 1;
                j -= 1;
            }
        }
        // The first call's range is sorted first: pushed last.
        ranges.push((i, end));
        ranges.push((start, j));
    }
    s
}

/// The SPU's instructions besides the software cache's own (its lookup,
/// Codeplay's measured 28 cycles, and misses, which the model charges):
/// an item compared — its index stepped, its address (a shift, an add),
/// the compare and the branch: 5; a swap — the two values stored into
/// their lines (a load, a mask, a shuffle, a store: 4 each), the indices
/// stepped, their compare and branch: 12; a partition — the range's size
/// and test, the pivot's index, the call's frame (the link and four
/// values saved and restored), the two branches: 20.
const SPU_COMPARE: Count = Count::of(5);
const SPU_SWAP: Count = Count::of(12);
const SPU_PARTITION: Count = Count::of(20);

/// The quicksort of `n` floats on one emulated SPE, the array in main
/// memory read and written through the software cache (the IBM SDK's
/// shape, 32 KiB in 4 ways: Offload's is not published), the
/// instructions charged by `charge` (their count, or the paper's class).
/// Returns ms.
fn spu(cost: &CostModel, n: usize, charge: fn(Count) -> u64) -> Result<f64, CellError> {
    let mut data = floats(n);
    let sorted = quicksort(&mut data);
    let mut cfg = CellConfig::ps3().with_spes(1);
    cfg.cost = cost.clone();
    // Offload's block timed from its start: the SPU's own time.
    cfg.resident = true;
    let mut cell = Cell::new(cfg)?;
    let bytes = (n as u64 * 4).div_ceil(128) * 128;
    let array = cell.memory_mut().alloc("array", bytes, 128)?;
    cell.memory_mut().write_pod(array, &floats(n))?;
    let steps = charge(SPU_COMPARE) * sorted.compares
        + charge(SPU_SWAP) * sorted.swaps
        + charge(SPU_PARTITION) * sorted.partitions;
    let accesses = sorted.accesses;
    cell.spawn_spe(0, move |spe| async move {
        let rates = CacheRates::of(Code::Paper);
        let mut cache = SoftwareCache::new(&spe, CacheConfig::SDK, rates, 1)?;
        let at = |i: u32| Ea(array.0 + i as u64 * 4);
        for a in accesses {
            match a {
                Access::Read(i) => cache.read(&spe, at(i), &mut [0u8; 4]).await?,
                Access::Write(i, v) => cache.write(&spe, at(i), &v.to_le_bytes()).await?,
            }
        }
        spe.compute(Cycles(steps));
        cache.flush(&spe).await
    });
    let run = cell.run()?;
    let back: Vec<f32> = cell.memory_mut().read_pod(array, n)?;
    assert_eq!(back, data, "the emulated sort left the host's order");
    Ok(run.cycles.0 as f64 / cost.clock_hz * 1e3)
}

/// The quicksort of `n` floats on the PPU (256 KB for 64K floats: in the
/// 512 KB L2), priced as the PPE's update steps are: every read of the
/// array through the PPE's caches (`cell::ppe_cache`, empty at the start),
/// each at the latency of the level that held its line — a chained L1
/// load (its load-to-use latency, since the compare waits for it), an L2
/// hit, or the machine's memory latency; the writes go through the caches
/// too, unpriced (the store queue takes them). Besides: an item compared,
/// the compare the branch waits for (a dependent floating-point
/// operation) and the index stepped; each scan's end a mispredicted branch
/// (the loop's branch is predicted to go on); a swap, two stores and the
/// indices stepped, 4; a partition, the call's frame (10) and its return
/// mispredicted. Returns ms.
fn ppu(n: usize) -> f64 {
    use latency::*;
    let s = quicksort(&mut floats(n));
    let mut caches = PpeCaches::ps3();
    for a in &s.accesses {
        match *a {
            Access::Read(i) => {
                caches.load(4 * i as u64);
            }
            Access::Write(i, _) => {
                // Through the caches, not tallied: the reads are priced.
                let reads = caches.loads;
                caches.store(4 * i as u64);
                caches.loads = reads;
            }
        }
    }
    let loads = caches.loads;
    let cost = CostModel::ps3();
    let cycles = s.compares as f64 * (DEPENDENT_FP + 1.0)
        + (2 * s.rounds) as f64 * MISPREDICT
        + s.swaps as f64 * 4.0
        + s.partitions as f64 * (10.0 + MISPREDICT)
        + loads_cycles(&loads, &cost).0 as f64;
    cycles / cost.clock_hz * 1e3
}

/// A sort timed on a PS3.
pub struct Timed {
    pub what: &'static str,
    pub n: usize,
    pub published_ms: f64,
}

/// Part 4's SPU figures.
pub const SPU: [Timed; 2] = [
    Timed {
        what: "quicksort of 64K floats on one SPU, through a software cache",
        n: 65536,
        published_ms: 39.7,
    },
    Timed {
        what: "quicksort of 20K floats on one SPU, through a software cache",
        n: 20000,
        published_ms: 10.7,
    },
];

/// Part 4's PPU figure (parts 1–3 tuned it).
pub const PPU: Timed = Timed {
    what: "quicksort of 64K floats on the PPU",
    n: 65536,
    published_ms: 16.8,
};

pub const SOURCE: &str = "Codeplay, Optimizing Sort Algorithms for the PS3, part 4";

impl Timed {
    /// ms with the SPU's instructions at their count and in the paper's
    /// class (the cache's measured costs as they are in both).
    pub fn spu(&self, cost: &CostModel) -> Result<(f64, f64), CellError> {
        Ok((
            spu(cost, self.n, |c| c.0 / 10)?,
            spu(cost, self.n, |c| Code::Paper.charge(c).0)?,
        ))
    }

    pub fn ppu(&self) -> f64 {
        ppu(self.n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_logged_sort_sorts_and_counts_like_a_quicksort() {
        let mut d = floats(4096);
        let s = quicksort(&mut d);
        assert!(d.windows(2).all(|w| w[0] <= w[1]));
        // About 1.4 n log2 n compares for a random input.
        let nlogn = 4096.0 * 12.0;
        let per = s.compares as f64 / nlogn;
        assert!((1.0..2.0).contains(&per), "{per}");
        assert!(s.swaps > 0 && s.partitions > 1000, "{}", s.partitions);
    }
}
