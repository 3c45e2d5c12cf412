//! How many SPEs a breadth-first multi-SPE build uses (section 5: "on the
//! upper tree levels many SPEs would be idle"): before the build, the
//! strategy predicts its own time on every count of SPEs up to those
//! given and runs on the fastest.
//!
//! The prediction replays the strategy's rules on the tree a scene of `n`
//! triangles would have if every split halved its job: the SPEs' starts
//! one after another, the root's bounds and the top levels (each interval
//! partitioned by every SPE where the rule lets them help, else by SPE 0
//! while the others wait, two barriers an interval), the split top's
//! splits, the deal (largest first, or the shared queue's levels), each
//! dealt job streamed level by level or finished in the local store, and
//! the memory interface, which every byte crosses at its sustained rate.
//! Every time in it is a rate in force (the code class's kernels, the
//! machine's DMA, atomics and starts): nothing in it is fitted. What it
//! cannot know is the scene: the real tree's jobs differ in size. So each
//! count is replayed twice, its deals as even as the halving tree's and as
//! uneven as a greedy deal of the jobs the top leaves can be, and the
//! prediction is the middle (docs/many-spes.md, "Small scenes", and
//! `spe_scaling --zoo`'s goals say how far off it is).

use std::collections::HashMap;

use super::breadth_first::{Finish, largest_local};
use super::top::{EndRule, SPLIT_SLACK, TopKnobs, deal_largest_first};
use crate::bih::{BihConfig, SplitChoice};
use crate::cell::CostModel;
use crate::cell::cost::LockLines;
use crate::kernels::rates::KernelRates;
use crate::spe::fig1::BLOCK_BYTES;
use crate::spe::layout::TriRecord;

/// Bytes of one triangle record.
const RECORD: f64 = size_of::<TriRecord>() as f64;

/// How the deal reaches the SPEs, as the forecast sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::strategy) enum Dealing {
    /// Whole jobs to private queues, largest first (stealing moves whole
    /// dealt jobs: predicted as the deal).
    Private,
    /// One shared queue, a level at a time, a barrier at each level's end.
    Shared,
}

/// The strategy's settings the forecast replays.
#[derive(Clone, Copy, Debug)]
pub(in crate::strategy) struct Plan {
    pub top: TopKnobs,
    pub finish: Finish,
    pub dealing: Dealing,
}

/// The predicted time of a build on each count of SPEs, between two
/// deals: the forecast's tree's own, and the worst the real jobs allow.
#[derive(Clone, Debug, PartialEq)]
pub struct Forecast {
    /// `best[k - 1]`: predicted simulated cycles on `k` SPEs, every job
    /// of a level as large as the others.
    pub best: Vec<u64>,
    /// `worst[k - 1]`: the same where every deal the forecast cannot see
    /// (of jobs the split top cannot split further, of a shared level) is
    /// as uneven as a greedy deal of such jobs can be.
    pub worst: Vec<u64>,
}

impl Forecast {
    /// The prediction on each count: the middle of the two, for the real
    /// tree lies somewhere between.
    pub fn cycles(&self) -> Vec<u64> {
        let pairs = self.best.iter().zip(&self.worst);
        pairs.map(|(b, w)| b + (w - b) / 2).collect()
    }

    /// The count predicted fastest (ties: the fewer SPEs). More SPEs given
    /// never run a count predicted slower.
    pub fn chosen(&self) -> usize {
        let cycles = self.cycles();
        let fastest = (cycles.iter().enumerate()).min_by_key(|&(k, &c)| (c, k));
        fastest.map_or(1, |(k, _)| k + 1)
    }

    /// What the build reports of it.
    pub fn prediction(&self) -> crate::strategy::program::Prediction {
        crate::strategy::program::Prediction {
            cycles: self.cycles(),
            best: self.best.clone(),
            worst: self.worst.clone(),
            chosen: self.chosen(),
        }
    }
}

/// The machine a forecast charges on `cell`: its own, or in the
/// functional mode, which charges no time, the PS3's, so that a build
/// runs the count of SPEs a timed run would.
pub(in crate::strategy) fn machine_of(cell: &crate::cell::Cell) -> CostModel {
    let cost = cell.config().cost;
    match cost.charge_compute {
        true => cost,
        false => CostModel::ps3(),
    }
}

/// Predicts the build of `n` triangles with `cfg` on 1 to `spes` SPEs.
pub(in crate::strategy) fn predict(
    n: usize,
    cfg: &BihConfig,
    plan: Plan,
    (kernels, machine): (&KernelRates, &CostModel),
    spes: usize,
) -> Forecast {
    let rates = Rates::new(cfg, plan.finish, kernels, machine);
    let at = |worst: bool| {
        (1..=spes.max(1))
            .map(|k| Replay::new(&rates, plan, k, worst).build(n) as u64)
            .collect()
    };
    Forecast {
        best: at(false),
        worst: at(true),
    }
}

/// The machine's side of a forecast, in cycles and bytes per cycle: the
/// DMA, the memory interface, the SPEs' starts and a barrier's atomics
/// and signals (every multi-SPE strategy's forecast charges these).
#[derive(Clone, Copy, Debug)]
pub(in crate::strategy) struct Machine {
    /// One DMA's latency, from issue to completion.
    pub latency: f64,
    pub spe_bandwidth: f64,
    /// One stream alone on the memory interface; several together.
    pub memory_alone: f64,
    pub memory_shared: f64,
    /// One SPE program's start by the PPE.
    pub start: f64,
    /// One SPE's fetch-and-add on the barrier's line; one signal.
    pub arrive: f64,
    pub signal: f64,
}

impl Machine {
    pub fn new(m: &CostModel) -> Self {
        let c = |x: crate::cell::Cycles| x.0 as f64;
        let claim = match m.lock_lines {
            LockLines::Shared { claim_cycles } => c(claim_cycles),
            LockLines::Exclusive => c(m.getllar_cycles),
        };
        Machine {
            latency: c(m.dma_issue_cycles) + c(m.mfc_command_cycles) + c(m.dma_latency_cycles),
            spe_bandwidth: m.spe_bandwidth.bytes_per_cycle(),
            memory_alone: m.memory_bandwidth.bytes_per_cycle(),
            memory_shared: m.memory_shared_bandwidth.bytes_per_cycle(),
            start: c(m.spe_start_cycles),
            arrive: c(m.getllar_cycles) + claim,
            signal: c(m.dma_issue_cycles) + c(m.signal_latency_cycles),
        }
    }

    /// Cycles to move `bytes` on one SPE while `streams` SPEs stream.
    pub fn moving(&self, bytes: f64, streams: usize) -> f64 {
        let memory = match streams {
            0 | 1 => self.memory_alone,
            s => self.memory_shared / s as f64,
        };
        bytes / self.spe_bandwidth.min(memory)
    }

    /// A barrier of `k` SPEs: every arrival on one line, one after
    /// another, then the last one's signals.
    pub fn barrier(&self, k: usize) -> f64 {
        k as f64 * self.arrive + (k - 1) as f64 * self.signal
    }

    /// `k` SPEs stream an equal share of `n` items at once, `per_item`
    /// cycles and `bytes` each.
    pub fn shared_pass(&self, n: usize, k: usize, per_item: f64, bytes: f64) -> f64 {
        let share = n as f64 / k as f64;
        (share * per_item).max(self.moving(share * bytes, k)) + self.latency
    }
}

/// The rates the replay charges, in cycles and bytes per cycle.
struct Rates {
    leaf: usize,
    /// SPE cycles per record of a streamed level (partition, and binning
    /// where the split bins) and bytes it moves (get and put, and the
    /// binning pass's get).
    per_record: f64,
    bytes_per_record: f64,
    bounds_per_record: f64,
    /// SPE cycles per node: the job's loop and the bin sweep.
    per_node: f64,
    m: Machine,
    /// The largest job finished in the local store (0: none).
    local: usize,
}

impl Rates {
    fn new(cfg: &BihConfig, finish: Finish, k: &KernelRates, m: &CostModel) -> Self {
        let c = |x: crate::cell::Cycles| x.0 as f64;
        let (bin, sweep) = match cfg.split {
            SplitChoice::BinnedSah { bins, .. } => {
                (c(k.spe_bin_item), 3.0 * bins as f64 * c(k.spe_sah_bin))
            }
            SplitChoice::GlobalHeuristic => (0.0, 0.0),
        };
        Rates {
            leaf: cfg.leaf_size.max(1) as usize,
            per_record: c(k.spe_partition_item) + bin,
            bytes_per_record: 2.0 * RECORD + if bin > 0.0 { RECORD } else { 0.0 },
            bounds_per_record: c(k.spe_bounds_item),
            per_node: c(k.spe_job) + sweep,
            m: Machine::new(m),
            local: match finish {
                Finish::Local => largest_local(cfg),
                Finish::Stream => 0,
            },
        }
    }
}

/// One replay of the strategy's schedule on `k` SPEs.
struct Replay<'a> {
    r: &'a Rates,
    plan: Plan,
    k: usize,
    /// Cost of a dealt job's subtree by its size: (cycles, bytes).
    subtrees: HashMap<usize, (f64, f64)>,
    /// Deals the forecast cannot see are as uneven as a greedy deal can be.
    worst: bool,
}

impl<'a> Replay<'a> {
    fn new(r: &'a Rates, plan: Plan, k: usize, worst: bool) -> Self {
        Replay {
            r,
            plan,
            k,
            subtrees: HashMap::new(),
            worst,
        }
    }

    /// The whole build of `n` triangles.
    fn build(mut self, n: usize) -> f64 {
        let (top, dealt, even) = self.top(n);
        let rest = match self.plan.dealing {
            Dealing::Private => self.private(&dealt, even),
            Dealing::Shared => self.shared(&dealt, n),
        };
        // The last SPE starts k starts in; the PPE hears of the end.
        self.k as f64 * self.r.m.start + top + rest + self.r.m.signal
    }

    /// The root's bounds and the top levels: their cycles, the level
    /// they hand over, and whether the split top evens its deal (its
    /// largest job is still one the SPEs help split).
    fn top(&mut self, n: usize) -> (f64, Vec<usize>, bool) {
        let (r, k) = (self.r, self.k);
        let coop = k > 1 && self.plan.top.coop;
        let mut t = match coop {
            true => self.shared_pass(n, r.bounds_per_record, RECORD) + r.m.barrier(k),
            false => n as f64 * r.bounds_per_record + r.m.moving(n as f64 * RECORD, 1),
        };
        let least = self.help_least();
        let helped = |c: usize| coop && c >= least;
        let end = self.plan.top.end(k);
        let mut level = vec![n];
        loop {
            let mut next = Vec::new();
            for &c in level.iter().filter(|&&c| c > r.leaf) {
                t += self.interval(c, helped(c));
                next.extend(halves(c));
            }
            level = next;
            if level.is_empty() || level.len() >= end.jobs {
                break;
            }
        }
        if self.plan.top.end == EndRule::Split {
            // Its largest job split until a largest-first deal is even: of
            // the real tree's jobs, which differ in size, a deal is even
            // once most SPEs hold two (a large job beside a small one);
            // the forecast's jobs, all equal, split until there are 2k.
            while let Some(&largest) = level.iter().max()
                && level.len() < (2 * k).min(end.cap)
                && helped(largest)
            {
                t += self.interval(largest, true);
                let at = level.iter().position(|&c| c == largest).expect("there");
                level.splice(at..=at, halves(largest));
            }
        }
        let splits = self.plan.top.end == EndRule::Split;
        let even = k == 1 || (splits && level.iter().max().is_some_and(|&c| helped(c)));
        (t, level, even)
    }

    /// The fewest triangles of a job the other SPEs help partition: one
    /// Fig. 1 block each.
    fn help_least(&self) -> usize {
        self.k * (BLOCK_BYTES as usize / RECORD as usize)
    }

    /// One interval of the top: by every SPE (an equal share each, Fig. 1
    /// in place, then the misplaced half of the records swapped, two
    /// barriers) or by SPE 0 alone.
    fn interval(&mut self, c: usize, helped: bool) -> f64 {
        let r = self.r;
        match helped {
            true => {
                let chunk = self.shared_pass(c, r.per_record, r.bytes_per_record);
                // About half the records are on the wrong side: a get and
                // a put each, an equal share of them each SPE.
                let swaps = r.m.moving(c as f64 * RECORD / self.k as f64, self.k);
                chunk + swaps + 2.0 * r.m.barrier(self.k) + r.m.signal + r.per_node
            }
            false => {
                let c = c as f64;
                (c * r.per_record).max(r.m.moving(c * r.bytes_per_record, 1))
                    + r.m.latency
                    + r.per_node
            }
        }
    }

    /// Every SPE streams an equal share of `n` records at once.
    fn shared_pass(&self, n: usize, per_record: f64, bytes: f64) -> f64 {
        self.r.m.shared_pass(n, self.k, per_record, bytes)
    }

    /// Private queues: each SPE builds its hand of a largest-first deal;
    /// the memory interface carries every SPE's bytes. The real level's
    /// jobs differ in size: a deal the split top evens gives no SPE more
    /// than 1/16 over an even share; any other, the heaviest hand its
    /// even share and half a job (where the last job placed lands, on
    /// average, over the share).
    fn private(&mut self, dealt: &[usize], even: bool) -> f64 {
        let k = self.k as f64;
        let (mut work, mut largest, mut bytes) = (0.0, 0.0f64, 0.0);
        for &c in dealt {
            let (tc, bc) = self.subtree(c);
            (work, largest, bytes) = (work + tc, largest.max(tc), bytes + bc);
        }
        let heaviest = match (even, self.worst) {
            (true, _) => work / k * (SPLIT_SLACK + 1) as f64 / SPLIT_SLACK as f64,
            (false, true) => {
                // The real jobs differ: each is smaller than the split top
                // would split with help, else it would have.
                let most = (self.help_least() - 1).min(dealt.iter().sum());
                let largest = largest.max(self.subtree(most).0);
                work / k + largest * (1.0 - 1.0 / k)
            }
            (false, false) => {
                let mut heaviest: f64 = 0.0;
                for hand in largest_first_loads(dealt, self.k) {
                    let t = hand.iter().map(|&c| self.subtree(c).0).sum();
                    heaviest = heaviest.max(t);
                }
                heaviest
            }
        };
        let interface = match self.k {
            1 => self.r.m.memory_alone,
            _ => self.r.m.memory_shared,
        };
        let own = bytes / k / self.r.m.spe_bandwidth;
        heaviest.max(own).max(bytes / interface)
    }

    /// The shared queue: level by level, every job of a level taken by
    /// whichever SPE is free, a barrier at each level's end; the jobs that
    /// fit the local store (none over an SPE's share of the `n`
    /// triangles) put aside and finished after the last level, taken one
    /// at a time.
    fn shared(&mut self, dealt: &[usize], n: usize) -> f64 {
        let local = self.r.local.min(n.div_ceil(self.k));
        let (mut t, mut level, mut aside) = (0.0, dealt.to_vec(), Vec::new());
        while !level.is_empty() {
            let mut next = Vec::new();
            let mut taken = Vec::new();
            for c in level {
                match c {
                    c if c > self.r.leaf && c <= local => aside.push(c),
                    c => {
                        taken.push(self.step(c));
                        if c > self.r.leaf {
                            next.extend(halves(c));
                        }
                    }
                }
            }
            t += self.greedy(&taken) + self.r.m.barrier(self.k);
            level = next;
        }
        let subtrees: Vec<_> = aside.into_iter().map(|c| self.subtree(c)).collect();
        t + self.greedy(&subtrees)
    }

    /// Jobs of these (cycles, bytes) taken by whichever SPE is free: no
    /// SPE past an even share or the largest job, nor the memory
    /// interface past its rate.
    fn greedy(&self, jobs: &[(f64, f64)]) -> f64 {
        let work: f64 = jobs.iter().map(|j| j.0).sum();
        let largest = jobs.iter().map(|j| j.0).fold(0.0, f64::max);
        let bytes: f64 = jobs.iter().map(|j| j.1).sum();
        let k = self.k as f64;
        let spread = match self.worst {
            true => work / k + largest * (1.0 - 1.0 / k),
            false => (work / k).max(largest),
        };
        spread.max(bytes / self.r.m.memory_shared)
    }

    /// One job's own level, streamed: its cycles (at its SPE's own
    /// bandwidth; the interface is counted over all) and bytes.
    fn step(&self, c: usize) -> (f64, f64) {
        let r = self.r;
        if c <= r.leaf {
            return (r.per_node, 0.0);
        }
        let bytes = c as f64 * r.bytes_per_record;
        let cycles = (c as f64 * r.per_record).max(bytes / r.m.spe_bandwidth);
        (cycles + r.m.latency + r.per_node, bytes)
    }

    /// A dealt job's whole subtree: streamed level by level until it fits
    /// the local store, then one get, the subtree built there, one put.
    fn subtree(&mut self, c: usize) -> (f64, f64) {
        if let Some(&known) = self.subtrees.get(&c) {
            return known;
        }
        let r = self.r;
        let cost = if c <= r.leaf {
            (r.per_node, 0.0)
        } else if c <= r.local {
            let bytes = 2.0 * c as f64 * RECORD;
            let tree = in_local_store(c, r);
            (2.0 * r.m.latency + bytes / r.m.spe_bandwidth + tree, bytes)
        } else {
            let (t, b) = self.step(c);
            let [lo, hi] = halves(c);
            let (tl, bl) = self.subtree(lo);
            let (th, bh) = self.subtree(hi);
            (t + tl + th, b + bl + bh)
        };
        self.subtrees.insert(c, cost);
        cost
    }
}

/// Compute cycles of a subtree of `c` records built in the local store.
fn in_local_store(c: usize, r: &Rates) -> f64 {
    halving_tree(c, r.leaf, r.per_record, r.per_node)
}

/// Compute cycles of the halving tree of `c` records down to leaves of at
/// most `leaf`: `per_record` for each record at each inner node, and
/// `per_node` a node.
pub(in crate::strategy) fn halving_tree(
    c: usize,
    leaf: usize,
    per_record: f64,
    per_node: f64,
) -> f64 {
    match c <= leaf {
        true => per_node,
        false => {
            let [lo, hi] = halves(c);
            let below = halving_tree(lo, leaf, per_record, per_node)
                + halving_tree(hi, leaf, per_record, per_node);
            c as f64 * per_record + per_node + below
        }
    }
}

/// A job's two halves.
pub(in crate::strategy) fn halves(c: usize) -> [usize; 2] {
    [c / 2, c - c / 2]
}

/// A largest-first deal of jobs of these sizes over `k` SPEs: each SPE's
/// jobs' sizes (the deal's own rule, [`deal_largest_first`]).
fn largest_first_loads(jobs: &[usize], k: usize) -> Vec<Vec<usize>> {
    deal_largest_first(jobs, k, |&c| (c as u64, 0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strategy::machinery::top::TopKnobs;

    fn plan(finish: Finish, dealing: Dealing) -> Plan {
        Plan {
            top: TopKnobs::SPLIT_ONE_PER_SPE,
            finish,
            dealing,
        }
    }

    fn forecast(n: usize, p: Plan) -> Forecast {
        let rates = KernelRates::of(crate::kernels::rates::Code::Paper);
        predict(n, &BihConfig::DEFAULT, p, (&rates, &CostModel::ps3()), 8)
    }

    #[test]
    fn a_large_scene_is_predicted_fastest_on_every_spe() {
        for dealing in [Dealing::Private, Dealing::Shared] {
            let f = forecast(800_000, plan(Finish::Local, dealing));
            assert_eq!(f.chosen(), 8, "{dealing:?}: {f:?}");
            assert!(f.cycles().windows(2).all(|w| w[1] < w[0]), "{f:?}");
        }
    }

    #[test]
    fn a_tiny_scene_runs_on_few_spes() {
        // 100 triangles: the top's levels, the starts and the barriers of
        // more SPEs cost more than the little work they would share.
        let f = forecast(100, plan(Finish::Local, Dealing::Private));
        assert!(f.chosen() <= 2, "{f:?}");
        assert!(f.cycles()[7] > f.cycles()[1], "{f:?}");
    }

    #[test]
    fn a_deal_of_eight_halves_over_six_spes_is_no_faster_than_over_four() {
        // 8 equal jobs too small to split further: 6 SPEs get 2, 2, 1, 1,
        // 1, 1 of them, no better than 4 SPEs' 2 each, and start more.
        let f = forecast(6_000, plan(Finish::Stream, Dealing::Private));
        assert!(f.best[5] > f.best[3], "{f:?}");
    }

    #[test]
    fn the_deal_follows_largest_first() {
        let hands = largest_first_loads(&[5, 4, 3, 3, 1], 2);
        assert_eq!(hands, vec![vec![5, 3], vec![4, 3, 1]]);
    }

    #[test]
    fn the_worst_is_never_faster_and_the_prediction_lies_between() {
        for n in [1_000, 6_000, 20_000, 200_000] {
            for dealing in [Dealing::Private, Dealing::Shared] {
                let f = forecast(n, plan(Finish::Local, dealing));
                let mut bands = f.best.iter().zip(f.cycles()).zip(&f.worst);
                assert!(
                    bands.all(|((b, c), w)| *b <= c && c <= *w),
                    "{n} {dealing:?}: {f:?}"
                );
            }
        }
    }

    #[test]
    fn the_count_chosen_is_the_fastest_predicted_and_the_fewest_of_a_tie() {
        let f = Forecast {
            best: vec![100, 60, 50, 40],
            worst: vec![100, 70, 70, 40],
        };
        // Predicted 100, 65, 60, 40.
        assert_eq!(f.chosen(), 4);
        let f = Forecast {
            best: vec![100, 60, 50, 50],
            worst: vec![100, 70, 70, 70],
        };
        assert_eq!(f.chosen(), 3);
    }
}
