//! The top levels of the multi-SPE strategies (section 5: "on the upper
//! tree levels many SPEs would be idle"), and what those strategies share
//! in main memory.
//!
//! SPE 0 builds the first levels with the baseline's loop until a level
//! holds `--deal-per-spe` jobs per SPE; unless `--no-coop-top`, the
//! other SPEs help partition each large interval of those levels (the
//! cooperative partition of section 2, [`super::coop`]), otherwise they
//! wait. Then `spe_bfs_private` deals that level and `spe_bfs_shared` puts
//! it in its shared queue.

use super::arena::{BLOCK_BYTES, BLOCK_NODES, BlockSource};
use super::breadth_first::Finish;
use super::coop::{Coop, CoopArea, GO};
use super::pool_server::PoolServer;
use super::work_queue::Level;
use crate::aabb::Aabb;
use crate::bih::BihConfig;
use crate::cell::Exit;
use crate::cell::{Cell, CellError, Ea, Spe};
use crate::spe::footprint::Purpose;
use crate::spe::layout::TriRecord;
use crate::strategy::knob::{Knob, Knobs};
use crate::strategy::machinery::breadth_first::{Job, SpeBuilder, TopEnd};
use crate::strategy::program::{Output, Readback, Records, Setup, SpeWork};

/// `--no-coop-top`: `TopKnobs::coop` off.
pub const NO_COOP_TOP: Knob = Knob::flag(
    "no-coop-top",
    "the SPEs do not help partition the top levels (they wait for the deal)",
);
/// `--deal-per-spe N|auto`: `TopKnobs::deal_per_spe`.
pub const DEAL_PER_SPE: Knob = Knob::int_or_auto(
    "deal-per-spe",
    "the top levels end at the first level with this many jobs per SPE (auto: the strategies' measured best, 1)",
    (1, 16),
    &["4", "16"],
);
/// `--top-end count|balanced|split|auto`: `TopKnobs::end`.
pub const TOP_END: Knob = Knob::word(
    "top-end",
    "where the top levels end: at the first level of --deal-per-spe jobs per SPE (count); or the first such level where no job holds more than one SPE's share of the triangles or the jobs average under 1,024 (balanced); or the count level, then its largest job split until a largest-first deal gives no SPE more than 1/16 over an even share (split); auto: split",
    &["auto", "count", "balanced", "split"],
    &["count", "balanced", "split"],
);

/// Where the top levels end (`--top-end`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::strategy) enum EndRule {
    /// At the first level of `--deal-per-spe` jobs per SPE.
    Count,
    /// At the first such level where no job holds more than one SPE's
    /// share ([`TopEnd::ends`]).
    Balanced,
    /// At the count level, then its largest job split until the deal is
    /// even ([`split_largest`]).
    Split,
}

/// `--coop-partition in-place|scratch`: `TopKnobs::in_place`. In place is
/// the default: faster on every scene and SPE count measured (1–10 %,
/// docs/many-spes.md) and no scratch array (48 bytes a triangle).
pub const COOP_PARTITION: Knob = Knob::word(
    "coop-partition",
    "how the SPEs partition a top level's interval together: Fig. 1 in place on each chunk, then only the misplaced records swapped (in-place), or each chunk through a scratch array and back (scratch, the older default)",
    &["in-place", "scratch"],
    &["scratch"],
);

/// `--tris-per-spe N|auto`: `spes_used`.
pub const TRIS_PER_SPE: Knob = Knob::int_or_auto(
    "tris-per-spe",
    "each SPE used gets at least this many triangles (auto: the count of SPEs the builder predicts fastest); more SPEs given run on that many (1: every SPE)",
    (1, usize::MAX),
    &["1", "4000"],
);

/// The SPEs a strategy runs on for `n` triangles when `available` are
/// given: with `--tris-per-spe N` the most SPEs that each get at least N
/// triangles, else the strategy's own choice `auto`; at least one, at
/// most those given.
pub(in crate::strategy) fn spes_used(
    available: usize,
    n: usize,
    knobs: &Knobs,
    auto: impl FnOnce() -> usize,
) -> usize {
    match knobs.int(&TRIS_PER_SPE) {
        0 => auto(),
        t => n / t.max(1),
    }
    .clamp(1, available.max(1))
}

/// How the top levels are built.
#[derive(Clone, Copy, Debug)]
pub(in crate::strategy) struct TopKnobs {
    /// Before the deal, every SPE helps partition each large interval of
    /// the top levels (the cooperative partition, `coop.rs`). Buys: the
    /// other SPEs work instead of waiting for the deal (docs/many-spes.md,
    /// "Which of the paper's worries are real"). Costs: every record of those levels travels twice
    /// (through a scratch array; in place, only the misplaced ones) and two
    /// barriers per interval.
    pub coop: bool,
    /// The top levels end at the first level with this many jobs per SPE
    /// (1 to 16: the level must fit `WorkA`). More jobs give the
    /// largest-first deal more room to balance, but more levels are built
    /// before it.
    pub deal_per_spe: usize,
    /// Where the top ends once a level holds `deal_per_spe` jobs per SPE.
    pub end: EndRule,
    /// The cooperative partition works in place (no scratch array).
    pub in_place: bool,
}

impl TopKnobs {
    /// Both breadth-first strategies' measured best (their files say why):
    /// the first level of one job per SPE, then its largest jobs split
    /// (every SPE helping, in place) until a largest-first deal is even.
    pub(in crate::strategy) const SPLIT_ONE_PER_SPE: TopKnobs = TopKnobs {
        coop: true,
        deal_per_spe: 1,
        end: EndRule::Split,
        in_place: true,
    };

    /// Where the top ends on `spes` SPEs.
    pub fn end(&self, spes: usize) -> TopEnd {
        let jobs = self.deal_per_spe * spes;
        TopEnd {
            jobs,
            cap: jobs.max((16 * spes).min(128)),
            spes,
            balanced: self.end == EndRule::Balanced,
        }
    }

    /// The most jobs the level the top hands over can hold on `spes` SPEs:
    /// under twice the level it ends at (a level at most doubles).
    pub fn max_deal(&self, spes: usize) -> usize {
        let end = self.end(spes);
        2 * match self.end {
            EndRule::Count => end.jobs,
            EndRule::Balanced | EndRule::Split => end.cap,
        }
    }

    /// The values `knobs` gives them; `auto` is the strategy's default.
    pub fn read(knobs: &Knobs, auto: TopKnobs) -> Self {
        TopKnobs {
            coop: !knobs.flag(&NO_COOP_TOP),
            deal_per_spe: match knobs.int(&DEAL_PER_SPE) {
                0 => auto.deal_per_spe,
                n => n,
            },
            end: match knobs.word(&TOP_END) {
                "count" => EndRule::Count,
                "balanced" => EndRule::Balanced,
                "split" => EndRule::Split,
                _ => auto.end,
            },
            in_place: knobs.word(&COOP_PARTITION) == "in-place",
        }
    }
}

/// What the SPE programs of both breadth-first multi-SPE strategies read
/// first: the triangles, the tree's settings and kernel rates, the SPEs
/// the strategy uses and the pool with the cooperative partition's areas.
#[derive(Clone, Copy)]
pub(in crate::strategy) struct Start {
    pub tris: Ea,
    pub n: usize,
    pub region: Aabb,
    pub cfg: BihConfig,
    pub rates: crate::kernels::rates::KernelRates,
    /// The software cache's rates in the run's class, with its overrides
    /// (`spe_bfs_shared --job-cache`).
    pub cache: crate::spe::software_cache::CacheRates,
    pub spes: usize,
    pub common: Common,
}

impl Start {
    /// Allocates the pool and the areas for the top knobs `top` on `spes`
    /// SPEs.
    pub fn set_up(
        cell: &mut Cell,
        setup: &Setup,
        cfg: &BihConfig,
        (top, finish): (&TopKnobs, Finish),
        spes: usize,
    ) -> Result<Self, CellError> {
        let n = setup.count;
        Ok(Start {
            tris: setup.triangles,
            n,
            region: setup.region,
            cfg: *cfg,
            rates: setup.rates.kernels(),
            cache: crate::spe::software_cache::CacheRates::with(&setup.rates),
            spes,
            common: Common::alloc(cell, setup.triangles, n, (cfg, top, finish), spes)?,
        })
    }
}

/// The ObjectArena pool and the cooperative partition's areas.
#[derive(Clone, Copy)]
pub(in crate::strategy) struct Common {
    pub pool: Pool,
    pub coop: CoopArea,
}

impl Common {
    /// Allocates them for `n` triangle records at `tris` built with `cfg`
    /// on `spes` SPEs (a scratch array unless the top partitions in place).
    pub fn alloc(
        cell: &mut Cell,
        tris: Ea,
        n: usize,
        (cfg, top, finish): (&BihConfig, &TopKnobs, Finish),
        spes: usize,
    ) -> Result<Self, CellError> {
        let open = if finish == Finish::Local { 2 } else { 1 };
        let pool = Pool::alloc(cell, n, cfg, (spes, open))?;
        let mut mem = cell.memory_mut();
        let scratch = match top.in_place || !top.coop || spes == 1 {
            true => None,
            false => Some(mem.alloc(
                Purpose::TriangleRecords.buffer("cooperative partition scratch"),
                (n * size_of::<TriRecord>()) as u64,
                128,
            )?),
        };
        let coop = CoopArea {
            spes,
            tris,
            scratch,
            descriptor: mem.alloc(
                Purpose::JobQueues.buffer("cooperative partition descriptor"),
                128,
                128,
            )?,
            table: mem.alloc(
                Purpose::JobQueues.buffer("cooperative partition table"),
                spes as u64 * 128,
                128,
            )?,
            arrivals: mem.alloc(
                Purpose::JobQueues.buffer("cooperative partition arrivals"),
                128,
                128,
            )?,
        };
        Ok(Common { pool, coop })
    }
}

/// Nodes a tree of `n` triangles built with `cfg` is expected to have, an
/// upper estimate: a BIH of leaves of up to L triangles has about 0.27 n
/// nodes at L = 12 on every scene measured (0.25–0.29: the default scene,
/// the teapot, homer, iss-nasa, the bunny, Sibenik, Sponza, the ogre, the
/// beast, the dragon, rtPerf), about 3.3 n / L; 4 n / L leaves a margin.
/// The empty-space cut-off's clip nodes add up to as many again (0.4–0.55
/// n on the dragon at thresholds of 10–30 %). Never more than the 2n + 1
/// nodes a tree without the cut-off can have. More than expected (a scene
/// of stacks, the cut-off at tiny thresholds) takes overflow blocks.
pub(in crate::strategy) fn expected_nodes(n: usize, cfg: &BihConfig) -> usize {
    let per_leaf = if cfg.empty_cut.is_some() { 8 } else { 4 };
    (per_leaf * n)
        .div_ceil(cfg.leaf_size.max(1) as usize)
        .min(2 * n + 1)
}

/// One ObjectArena pool in main memory for every SPE's arena; past it, the
/// PPE's overflow blocks ([`PoolServer`]).
#[derive(Clone, Copy)]
pub(in crate::strategy) struct Pool {
    pub base: Ea,
    /// Blocks in the pool.
    pub pool_blocks: u32,
    /// The SPEs whose arenas take blocks from it.
    pub spes: usize,
    /// Where the SPEs' arenas take their blocks.
    pub blocks: BlockSource,
}

impl Pool {
    /// The pool for `n` triangles built with `cfg`, sized to the tree
    /// expected ([`expected_nodes`]) plus `open` part-filled blocks per
    /// SPE (its sequence's, and its runs' where it finishes subtrees in its
    /// local store: `ObjectArena::alloc_run`); an
    /// SPE that finds it used up takes the PPE's overflow blocks after it
    /// (the PPE's program must be [`Pool::spawn_server`] or use
    /// [`Pool::server`]).
    pub fn alloc(
        cell: &mut Cell,
        n: usize,
        cfg: &BihConfig,
        (spes, open): (usize, usize),
    ) -> Result<Self, CellError> {
        let mut mem = cell.memory_mut();
        let pool_blocks = expected_nodes(n, cfg).div_ceil(BLOCK_NODES) + spes * open;
        let base = mem.alloc(
            Purpose::Nodes.buffer("ObjectArena pool"),
            pool_blocks as u64 * BLOCK_BYTES,
            128,
        )?;
        let counter = mem.alloc(
            Purpose::JobQueues.buffer("ObjectArena pool counter"),
            128,
            128,
        )?;
        let blocks = BlockSource::Pool {
            base,
            blocks: pool_blocks as u32,
            counter,
            grows: true,
        };
        Ok(Pool {
            base,
            pool_blocks: pool_blocks as u32,
            spes,
            blocks,
        })
    }

    /// The PPE's side of the pool's growth.
    pub fn server(&self) -> PoolServer {
        PoolServer::new(self.base, self.pool_blocks, self.spes)
    }

    /// The PPE program of a strategy whose PPE only serves the pool: it
    /// returns the pool's reach.
    pub fn spawn_server(&self, cell: &mut Cell) -> Exit<Ea> {
        let server = self.server();
        cell.spawn_ppe(move |ppe| async move { server.serve(&ppe).await })
    }

    /// Spawns `program` on SPEs `0..spes` (it is given the SPE and its
    /// number) and the pool's server on the PPE; how the build is read back
    /// ([`Pool::readback`], the records where the strategy left them).
    pub fn spawn_programs<F, Fut>(self, cell: &mut Cell, spes: usize, program: F) -> Readback
    where
        F: Fn(Spe, usize) -> Fut + Copy,
        Fut: std::future::Future<Output = Result<SpeExit, CellError>> + 'static,
    {
        let exits = (0..spes)
            .map(|id| cell.spawn_spe(id, move |spe| program(spe, id)))
            .collect();
        let reach = self.spawn_server(cell);
        self.readback(exits, reach, None)
    }

    /// How a build whose SPEs return `exits` (in SPE order) and whose PPE
    /// returns the pool's reach is read back: the pool and its overflow
    /// blocks, compacted (the arenas' unused slots and whatever lies
    /// between the blocks dropped), what each SPE did, and the triangle
    /// records at `records` if the strategy moved them.
    pub fn readback(
        self,
        exits: Vec<Exit<SpeExit>>,
        reach: Exit<Ea>,
        records: Option<Records>,
    ) -> Readback {
        Box::new(move || {
            let end = reach.take("PPE")?;
            let slots = ((end.0 - self.base.0) / size_of::<crate::bih::BihNode>() as u64) as usize;
            let mut o = Output {
                nodes: vec![(self.base, slots)],
                compact: true,
                records,
                spes: exits.len(),
                ..Output::default()
            };
            for (id, exit) in exits.iter().enumerate() {
                let e = exit.take(&format!("SPE {id}"))?;
                o.stats.items_partitioned += e.items_partitioned;
                o.stats.partitions += e.partitions;
                o.spe_work.push(e.work);
                o.phases.extend(e.phases);
            }
            Ok(o)
        })
    }
}

/// What one SPE of a multi-SPE build returns.
#[derive(Default)]
pub(in crate::strategy) struct SpeExit {
    pub work: SpeWork,
    pub items_partitioned: u64,
    pub partitions: u64,
    /// A strategy made of phases: each phase's name and the cycle it
    /// ended at (SPE 0 reports them).
    pub phases: Vec<(&'static str, u64)>,
}

impl SpeExit {
    /// What `b`'s loop did, as SPE work `work` (its jobs set from the loop).
    pub fn of(b: &SpeBuilder<'_>, mut work: SpeWork) -> Self {
        work.jobs = b.jobs;
        (work.subtrees, work.subtree_limit) = b.subtrees();
        (work.top, work.in_subtrees) = (b.top, b.in_subtrees);
        SpeExit {
            work,
            items_partitioned: b.stats.items_partitioned,
            partitions: b.stats.partitions,
            phases: Vec::new(),
        }
    }
}

/// SPE 0: builds the top levels of the `n` records in `region`, helped by
/// the others with `TopKnobs::coop`; returns the first level of at least
/// `deal_per_spe` jobs per SPE (in `WorkA`), or `None` if the tree ended
/// before. The top levels' arena is closed; its blocks are counted in
/// `work`.
pub(in crate::strategy) async fn build_top(
    b: &mut SpeBuilder<'_>,
    helper: Coop,
    n: usize,
    region: Aabb,
    knobs: TopKnobs,
    work: &mut SpeWork,
) -> Result<Option<Level>, CellError> {
    let spes = helper.area.spes;
    let mut helper = helper;
    let all = match spes > 1 && knobs.coop {
        true => {
            let rate = b.rates.spe_bounds_item;
            helper.bounds(b.spe, &b.fig1, n as u64, rate).await?
        }
        false => b.bounds_of_all(n).await?,
    };
    if spes > 1 && knobs.coop {
        let per_block = crate::spe::fig1::BLOCK_BYTES / size_of::<TriRecord>() as u32;
        b.help_with(Some((helper, spes as u32 * per_block)));
    }
    let root_id = b.arena.alloc(1).await?;
    let level = b
        .queue
        .start(Job::new(0, n, root_id as usize, 0, region, &all))?;
    let end = knobs.end(spes);
    let mut top = b.levels(level, Some(end)).await?;
    if knobs.end == EndRule::Split
        && let Some(level) = top
    {
        top = split_largest(b, level, end).await?;
    }
    // From here on, every SPE works on whole jobs.
    b.help_with(None);
    let top_nodes = b.arena.allocated();
    b.arena.close(top_nodes).await?;
    b.write_held().await?;
    work.arena_blocks += b.arena.stats.blocks;
    work.arena_unused += b.arena.unused();
    Ok(top)
}

/// A largest-first deal's heaviest hand may hold this share more than an
/// even share of the triangles (`--top-end split`): 1/16.
pub(in crate::strategy) const SPLIT_SLACK: u64 = 16;

/// `--top-end split`: SPE 0 splits the largest job of `level` (in `WorkA`,
/// with the other SPEs' help while it is large) until a largest-first
/// deal of its jobs ([`largest_first`]) gives no SPE more than
/// 1/[`SPLIT_SLACK`] over an even share of the triangles, the level holds
/// `end.cap` jobs, or the largest is too small for the other SPEs to help
/// partition it (SPE 0 would split it alone while they wait: measured
/// slower on the teapot and the default scene, docs/many-spes.md). Unlike
/// a whole level more, only the jobs that unbalance the deal are split.
/// Returns the level to deal (its jobs of different depths: a split job's
/// children are one level deeper than the jobs beside them), or `None` if
/// the tree ended.
async fn split_largest(
    b: &mut SpeBuilder<'_>,
    mut level: Level,
    end: TopEnd,
) -> Result<Option<Level>, CellError> {
    loop {
        let Level::Local(len) = level else {
            return Ok(Some(level));
        };
        let jobs = b.queue.load(level, 0).await?;
        // Dealing them largest first (`KernelRates::spe_level_scan` a job
        // a hand looked at: the deal's loop).
        let hands = largest_first(&jobs, end.spes);
        b.spe
            .compute_items(b.rates.spe_level_scan, (len * end.spes) as u64);
        let weight = |h: &[Job]| h.iter().map(|j| j.count as u64).sum::<u64>();
        let heaviest = hands.iter().map(|h| weight(h)).max().unwrap_or(0);
        let total = weight(&jobs);
        let (k, largest) = (jobs.iter().enumerate())
            .max_by_key(|(_, j)| (j.count, std::cmp::Reverse(j.node)))
            .expect("a level has jobs");
        let even = heaviest * (end.spes as u64) * SPLIT_SLACK <= total * (SPLIT_SLACK + 1);
        if even || len >= end.cap || !b.helped(largest.count) {
            return Ok(Some(level));
        }
        // The level again in `WorkB`, the largest job's children in its
        // place.
        for &j in &jobs[..k] {
            b.queue.push(j).await?;
        }
        b.split_dealt(*largest).await?;
        for &j in &jobs[k + 1..] {
            b.queue.push(j).await?;
        }
        match b.queue.end_level().await? {
            Some(next) => level = next,
            None => return Ok(None),
        }
    }
}

/// Deals `jobs` largest first, each to the SPE with the fewest triangles
/// so far (ties: the lower SPE), each hand in node order.
pub(in crate::strategy) fn largest_first(jobs: &[Job], spes: usize) -> Vec<Vec<Job>> {
    let mut hands = deal_largest_first(jobs, spes, |j| (j.count as u64, j.node));
    for hand in &mut hands {
        hand.sort_by_key(|j| j.node);
    }
    hands
}

/// The largest-first rule on any items: by `weight` (its size, and the
/// order among equal sizes: the lower first), each to the SPE with the
/// least weight so far (ties: the lower SPE). The forecast deals its
/// jobs' sizes by it too.
pub(in crate::strategy) fn deal_largest_first<T: Copy>(
    items: &[T],
    spes: usize,
    weight: impl Fn(&T) -> (u64, u32),
) -> Vec<Vec<T>> {
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by_key(|&i| {
        let (w, tie) = weight(&items[i]);
        (std::cmp::Reverse(w), tie)
    });
    let mut load = vec![0u64; spes];
    let mut hands: Vec<Vec<T>> = vec![Vec::new(); spes];
    for i in order {
        let to = (0..spes).min_by_key(|&s| (load[s], s)).expect("an SPE");
        load[to] += weight(&items[i]).0;
        hands[to].push(items[i]);
    }
    hands
}

/// Every SPE but 0: with `TopKnobs::coop`, helps with the root's bounds
/// and partition the top levels until SPE 0 signals their end (signal
/// register 1, anything but `GO`).
pub(in crate::strategy) async fn help_top(
    spe: &Spe,
    b: &SpeBuilder<'_>,
    helper: &mut Coop,
    n: usize,
    knobs: TopKnobs,
) -> Result<(), CellError> {
    if knobs.coop {
        helper
            .bounds(spe, &b.fig1, n as u64, b.rates.spe_bounds_item)
            .await?;
    }
    let rate = b.rates.spe_partition_item;
    while spe.read_signal(1).await? == GO {
        helper.help(spe, &b.fig1, rate).await?;
    }
    Ok(())
}
