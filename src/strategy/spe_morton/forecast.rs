//! How many SPEs `spe_morton` uses (section 5: "on the upper tree levels
//! many SPEs would be idle"; on a small scene the Morton route's own fixed
//! costs — starts, barriers, probes — outweigh what more SPEs share): before
//! the build, the strategy predicts its time on every count of SPEs up to
//! those given and runs on the fastest, as the breadth-first strategies do
//! (`machinery::forecast`, whose [`Forecast`] and [`Machine`] it shares).
//!
//! The prediction replays the phases of `mod.rs` on a scene of `n`
//! triangles whose every range halves: the SPEs' starts one after another;
//! the scene box, the keys and each radix pass, every SPE an equal slice
//! with the memory interface shared, each pass's count rows read one SPE
//! at a time, a barrier at each phase's end; the top of the tree, SPE 0
//! splitting the largest ranges until [`SUBTOPS_PER_SPE`] an SPE and every
//! SPE the rest from the counter, each split a job and its probes (a DMA
//! each: the two ends and a binary search); the regions taken largest
//! first from the counter, each gathered, built in the local store and
//! written back, the next one's gather during this one's build; and the
//! top's nodes. Every time in it is a rate in force (this strategy's
//! kernels, the shared kernels, the machine's DMA, atomics and starts):
//! nothing in it is fitted. What it cannot see is the scene: ranges that
//! share their whole key (a model in one cell of a floor) make fewer,
//! larger regions, and keys within cells add rounds. So each count is
//! replayed twice, its largest region the halving tree's and as large as
//! a local store holds, and the prediction is the middle
//! (docs/morton.md, "How many SPEs").

use std::collections::HashMap;

use super::pairs::{PAIRS_PER_BLOCK, Pairs};
use super::rates::MortonRates;
use super::top::{SUBTOPS_PER_SPE, WINDOW};
use super::{MortonKnobs, NODE, RECORD};
use crate::bih::BihConfig;
use crate::cell::CostModel;
use crate::kernels::radix;
use crate::kernels::rates::KernelRates;
use crate::strategy::machinery::forecast::{Forecast, Machine, halves, halving_tree};

/// The local store the program leaves for a region's records, key pairs
/// and nodes with its default knobs, as a forecast made before the build
/// assumes it: 163,584 bytes free on every SPE once the streamed phases
/// are done, less the slack `Program::ls_capacity` keeps.
const REGION_AREA_FORECAST: usize = 163_584 - 400;

/// Predicts the build of `n` triangles with `cfg` and `knobs` (their
/// `auto`s resolved) on 1 to `spes` SPEs.
pub(super) fn predict(
    n: usize,
    cfg: &BihConfig,
    knobs: &MortonKnobs,
    (rates, kernels, machine): (&MortonRates, &KernelRates, &CostModel),
    spes: usize,
) -> Forecast {
    let r = Rates::new(cfg, knobs, rates, kernels, machine);
    let at = |worst: bool| {
        (1..=spes.max(1))
            .map(|k| Replay::new(&r, k).build(n, worst) as u64)
            .collect()
    };
    let best: Vec<u64> = at(false);
    // Lumps can be the cheaper tree where the halving tree's regions are
    // larger than a local store holds (`--region-size` past it): the
    // worst is never below the best.
    let worst = (at(true).into_iter().zip(&best))
        .map(|(w, &b)| w.max(b))
        .collect();
    Forecast { best, worst }
}

/// The rates the replay charges, in cycles, and the sizes it needs.
struct Rates {
    m: Machine,
    leaf: usize,
    region: usize,
    /// Records the local store holds in one region's build.
    ls_records: usize,
    pair: f64,
    passes: u32,
    digits: f64,
    permute: bool,
    bounds: f64,
    /// One key: its setup, quantisation and bits spread.
    key: f64,
    count: f64,
    scatter: f64,
    probe: f64,
    job: f64,
    partition: f64,
}

impl Rates {
    fn new(
        cfg: &BihConfig,
        knobs: &MortonKnobs,
        rates: &MortonRates,
        kernels: &KernelRates,
        machine: &CostModel,
    ) -> Self {
        let c = |x: crate::cell::Cycles| x.0 as f64;
        let pair = Pairs::for_bits(knobs.key_bits).bytes;
        let per_bit = c(rates.key_spread) * knobs.key_bits as f64;
        Rates {
            m: Machine::new(machine),
            leaf: cfg.leaf_size.max(1) as usize,
            region: knobs.region_size.max(1),
            ls_records: REGION_AREA_FORECAST / (RECORD + 2 * NODE + pair),
            pair: pair as f64,
            passes: radix::passes(knobs.key_bits, knobs.digit_bits),
            digits: (1u64 << knobs.digit_bits) as f64,
            permute: knobs.permute,
            bounds: c(kernels.spe_bounds_item),
            key: c(rates.key_setup) + c(rates.key_quantise) + per_bit,
            count: c(rates.radix_count),
            scatter: c(rates.radix_scatter),
            probe: c(rates.key_probe),
            job: c(kernels.spe_job),
            partition: c(kernels.spe_partition_item),
        }
    }
}

/// One replay of the build on `k` SPEs.
struct Replay<'a> {
    r: &'a Rates,
    k: usize,
    /// A range's split probes and jobs down to its regions, by its size.
    tops: HashMap<usize, f64>,
}

impl<'a> Replay<'a> {
    fn new(r: &'a Rates, k: usize) -> Self {
        Replay {
            r,
            k,
            tops: HashMap::new(),
        }
    }

    /// The whole build of `n` triangles; `worst`: its largest region as
    /// large as a local store holds.
    fn build(mut self, n: usize, worst: bool) -> f64 {
        let (r, m, k) = (self.r, &self.r.m, self.k);
        let end = m.barrier(k);
        let pass = |per: f64, bytes: f64| m.shared_pass(n, k, per, bytes);
        // Phase 0: the scene box, each SPE's row put, every row read.
        let scene = pass(r.bounds, RECORD as f64) + 2.0 * m.latency + m.barrier(k);
        let scene = scene + k as f64 * r.bounds + end;
        let keys = pass(r.key, RECORD as f64 + r.pair) + end;
        // Each radix pass: the count, this SPE's row put, every row read
        // one at a time, each block's own count and prefix, the scatter.
        let blocks = n.div_ceil(k).div_ceil(PAIRS_PER_BLOCK) as f64;
        let rows = k as f64 * (m.latency + r.count * r.digits);
        let scatter = pass(r.count + r.scatter, 2.0 * r.pair) + blocks * r.digits * r.count;
        let radix = pass(r.count, r.pair) + m.latency + m.barrier(k) + rows + scatter + end;
        let permute = match r.permute {
            true => pass(r.scatter, r.pair + 2.0 * RECORD as f64) + end,
            false => 0.0,
        };
        let sorted = scene + keys + r.passes as f64 * radix + permute;
        let start = k as f64 * m.start;
        start + sorted + self.top(n) + self.regions(n, worst) + m.signal
    }

    /// Phase 4 and the top's nodes at the end: SPE 0 splits the largest
    /// ranges until there are [`SUBTOPS_PER_SPE`] an SPE, every SPE takes
    /// the rest from the counter; the region tables (a word to the PPE
    /// and its answer, SPE 0 sorting them); every SPE writes its sub-tops'
    /// nodes, SPE 0 those above.
    fn top(&mut self, n: usize) -> f64 {
        let (r, m, k) = (self.r, self.r.m, self.k);
        let mut pending = vec![n];
        let mut above = 0.0;
        let mut splits = 0;
        while pending.len() < SUBTOPS_PER_SPE * k {
            let Some(i) = (0..pending.len()).max_by_key(|&i| pending[i]) else {
                break;
            };
            if pending[i] <= r.region {
                break;
            }
            let c = pending.swap_remove(i);
            above += self.split(c);
            pending.extend(halves(c));
            splits += 1;
        }
        let subs: Vec<f64> = pending.iter().map(|&c| self.below(c)).collect();
        let taken = greedy(&subs, k) + (pending.len().div_ceil(k) + 1) as f64 * m.arrive;
        let regions = self.regions_of(n).values().sum::<usize>() as f64;
        let tables = 4.0 * m.barrier(k) + 2.0 * m.signal + 2.0 * m.latency + regions * r.job;
        let nodes = (regions / k as f64) * r.job + splits as f64 * r.job + 2.0 * m.barrier(k);
        above + taken + tables + nodes + m.barrier(k)
    }

    /// One split of a range of `c`: its job and its probes (the two ends
    /// and a binary search), a DMA each or, where its keys fit the key
    /// window, in the local store.
    fn split(&self, c: usize) -> f64 {
        let r = self.r;
        let probes = match c <= r.region {
            true => 1.0,
            false => 2.0 + (c as f64).log2().ceil(),
        };
        let probe = match self.windowed(c) {
            true => r.probe,
            false => r.m.latency,
        };
        r.job + probes * probe
    }

    /// Whether a range of `c` has its keys read into the key window.
    fn windowed(&self, c: usize) -> bool {
        c as f64 * self.r.pair <= WINDOW as f64
    }

    /// A sub-top's splits down to its regions: the window read once at
    /// the first range that fits it.
    fn below(&mut self, c: usize) -> f64 {
        let read = match self.windowed(c) {
            true => self.r.m.latency + c as f64 * self.r.pair / self.r.m.spe_bandwidth,
            false => 0.0,
        };
        read + self.splits(c)
    }

    /// A range's splits down to its regions (its window's read aside).
    fn splits(&mut self, c: usize) -> f64 {
        if let Some(&t) = self.tops.get(&c) {
            return t;
        }
        let t = match c <= self.r.region {
            true => self.split(c),
            false => {
                let [lo, hi] = halves(c);
                let below = |s: &mut Self, h: usize| match s.windowed(c) {
                    true => s.splits(h),
                    false => s.below(h),
                };
                self.split(c) + below(self, lo) + below(self, hi)
            }
        };
        self.tops.insert(c, t);
        t
    }

    /// The halving tree's regions of `n`: each size and how many.
    fn regions_of(&self, n: usize) -> HashMap<usize, usize> {
        let mut level = HashMap::from([(n, 1)]);
        let mut regions = HashMap::new();
        while !level.is_empty() {
            let mut next = HashMap::new();
            for (c, times) in level {
                match c <= self.r.region {
                    true => *regions.entry(c).or_insert(0) += times,
                    false => {
                        for h in halves(c) {
                            *next.entry(h).or_insert(0) += times;
                        }
                    }
                }
            }
            level = next;
        }
        regions
    }

    /// Phase 5: the regions taken from the counter, each gathered (during
    /// the last one's build), built in the local store and written back;
    /// the memory interface carries every SPE's bytes.
    fn regions(&mut self, n: usize, worst: bool) -> f64 {
        let (m, k) = (&self.r.m, self.k);
        let (mut work, mut largest, mut bytes) = (0.0, 0.0f64, 0.0);
        for (c, times) in self.regions_of(n) {
            let (t, b) = self.region(c);
            work += times as f64 * t;
            bytes += times as f64 * b;
            largest = largest.max(t);
        }
        let spread = match worst {
            // Every region as large as a local store holds: equal lumps,
            // the most any SPE takes of them its share.
            true => {
                let lumps = n.div_ceil(self.r.ls_records.max(1));
                let (t, b) = self.region(n.div_ceil(lumps));
                bytes = lumps as f64 * b;
                lumps.div_ceil(k) as f64 * t
            }
            false => (work / k as f64).max(largest),
        };
        let interface = match k {
            1 => m.memory_alone,
            _ => m.memory_shared,
        };
        spread.max(bytes / interface) + m.barrier(k)
    }

    /// One region of `c`: its cycles on its SPE and the bytes it moves
    /// (the records in, the ids and nodes out).
    fn region(&self, c: usize) -> (f64, f64) {
        let (r, m) = (self.r, &self.r.m);
        let nodes = 2.0 * (c as f64 / r.leaf as f64).ceil();
        let bytes = c as f64 * (RECORD as f64 + 4.0) + nodes * NODE as f64;
        let gather = c as f64 * r.scatter + m.latency + bytes / m.spe_bandwidth;
        let tree = halving_tree(c, r.leaf, r.partition, r.job) - c as f64 * r.partition;
        let build = c as f64 * r.bounds + tree.max(0.0);
        // Its take: the counter's update and a get of its job.
        (gather.max(build) + 2.0 * m.latency + m.arrive, bytes)
    }
}

/// Jobs of these cycles taken by whichever SPE is free: no SPE past an
/// even share or the largest job.
fn greedy(jobs: &[f64], k: usize) -> f64 {
    let work: f64 = jobs.iter().sum();
    let largest = jobs.iter().copied().fold(0.0, f64::max);
    (work / k as f64).max(largest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::morton::{auto_key_bits, auto_region_size};
    use crate::kernels::rates::Code;

    fn forecast(n: usize, code: Code) -> Forecast {
        let mut knobs = MortonKnobs::read(&crate::strategy::Knobs::default());
        knobs.region_size = auto_region_size(n);
        knobs.key_bits = auto_key_bits(n, knobs.region_size, knobs.digit_bits);
        let (rates, kernels) = (MortonRates::of(code), KernelRates::of(code));
        let rated = (&rates, &kernels, &CostModel::ps3());
        predict(n, &BihConfig::DEFAULT, &knobs, rated, 8)
    }

    #[test]
    fn a_large_scene_is_predicted_fastest_on_every_spe() {
        for code in Code::ALL {
            let f = forecast(871_414, code);
            assert_eq!(f.chosen(), 8, "{code:?}: {f:?}");
            assert!(f.cycles().windows(2).all(|w| w[1] < w[0]), "{f:?}");
        }
    }

    #[test]
    fn a_tiny_scene_runs_on_few_spes() {
        // 300 triangles: starts, barriers and the rows of every count
        // table cost more SPEs more than the little work they share.
        for code in Code::ALL {
            let f = forecast(300, code);
            assert!(f.chosen() <= 3, "{code:?}: {f:?}");
            assert!(f.cycles()[7] > f.cycles()[f.chosen() - 1], "{f:?}");
        }
    }

    #[test]
    fn regions_as_large_as_a_local_store_are_never_faster() {
        for n in [100, 3_000, 20_000, 300_000] {
            let f = forecast(n, Code::Paper);
            let pairs = f.best.iter().zip(&f.worst);
            assert!(pairs.clone().all(|(b, w)| b <= w), "{n}: {f:?}");
        }
    }

    #[test]
    fn lumpy_regions_stop_paying_for_spes_past_their_count() {
        // 3,000 triangles in regions a local store holds: two of them, so
        // a third SPE shares only the phases before them.
        let f = forecast(3_000, Code::Paper);
        let r = |k: usize| f.worst[k - 1] as f64;
        assert!(r(3) >= r(2) * 0.9, "{f:?}");
        assert!(r(2) < r(1) * 0.75, "{f:?}");
    }
}
