//! `spe_morton` — section 5's second proposal: "a pre-processing step
//! using Morton curves is performed to find regions of primitives that then
//! could be built-up totally independent", with the Morton codes computed
//! on the SPEs and "a radix sort [...] on the Cell B. E." (the keys and the
//! passes are the shared kernels of `kernels::morton` and `kernels::radix`).
//!
//! 1. **Keys**: each SPE streams its slice of the triangle records and
//!    writes a (key, record index) pair per triangle (`--key-order`,
//!    `--key-bits`).
//! 2. **Radix sort**, LSD, `--digit-bits` a pass: each SPE counts the
//!    digits of its slice and writes its row of the count table; after a
//!    barrier each reads the table, prefix-sums its offsets and scatters
//!    its pairs to their places, each block's pairs as one DMA list (`putl`)
//!    of runs of consecutive places.
//! 3. **Permutation**: each SPE gathers the records of its slice of sorted
//!    pairs with a DMA list (`getl`) and writes them, in key order, to a
//!    second record array where the tree is built.
//! 4. **The top of the tree** (every SPE, `top`): a node wherever a
//!    range's keys first differ (Karras 2012), found by binary search over
//!    the sorted keys in main memory, down to **regions** of at most
//!    `--region-size` triangles (or ranges that share their whole key, or
//!    leaves): SPE 0 splits the largest ranges until there are a few per
//!    SPE, then every SPE takes them from an atomic counter, each range's
//!    keys read into the local store once they fit a 16 KiB window.
//!    A range that shares its whole key and overflows a local store is
//!    keyed again within its own cell (`rekey`) and the top goes on from
//!    its new keys, in rounds.
//! 5. **Independent subtrees**: every SPE takes regions largest first from
//!    an atomic counter (or, `--static-regions`, from its own dealt
//!    list) and builds each alone: a region that fits in the local store is
//!    loaded once, built there with the global heuristic and written back
//!    once (two slots of the local store: the next region's gather runs
//!    during this one's build, this one's write-back during the next's);
//!    a larger one runs the baseline's breadth-first loop, its
//!    WorkAPPE/WorkBPPE in a spill area the PPE allocates per SPE, sized
//!    for the largest such region. Nodes go straight into slots of the
//!    per-SPE ObjectArena lists of one pool. Each region's bounds go to a
//!    table, from which every SPE finally writes the clip planes of the
//!    top nodes it made.
//!
//! With the global heuristic's order the splits are the baseline's, so the
//! tree is the baseline's tree.

mod areas;
mod forecast;
mod pairs;
mod ranges;
mod rates;
mod regions;
mod rekey;
mod sort;
mod top;

use areas::{Areas, RegionTables, serve};
pub use rates::{COUNTS, MortonRates};

use super::machinery::arena::ObjectArena;
use super::machinery::breadth_first::{DMA_LISTS, DOUBLE_BUFFER, Job, NO_PREFETCH, QueueKnobs};
use super::machinery::node_writes::NodeWrites;
use super::machinery::top::{Pool, SpeExit, TRIS_PER_SPE, spes_used};
use super::{Knob, Knobs, Readback, Records, Setup, SpeWork};
use crate::bih::BihConfig;
use crate::cell::{Cell, CellError, LsAddr, Spe};
use crate::kernels::morton::{KeyOrder, KeySpec, auto_key_bits, auto_region_size};
use crate::kernels::radix;
use crate::kernels::rates::{KernelRates, infos};
use crate::spe::barrier::Barrier;
use crate::spe::layout::TriRecord;

/// `spe_morton` in the registry of builders.
pub const STRATEGY: super::Strategy = super::Strategy::new(
    "spe_morton",
    "section 5: Morton keys and a radix sort on the SPEs, the top of the tree from the sorted keys, then regions built independently, one SPE each, in the local store where they fit (--spes)",
    spawn,
)
.on_every_spe()
.promising(super::Promise {
    family: "Morton",
    speedup: 10.0,
    triangles: 100_000,
})
.with_rates(|code| infos(MortonRates::of(code), &MortonRates::table(code)))
.with_knobs(&[
    &KEY_ORDER,
    &KEY_BITS,
    &DIGIT_BITS,
    &REGION_SIZE,
    &STATIC_REGIONS,
    &PERMUTE,
    &TRIS_PER_SPE,
    // Regions too large for a local store run the breadth-first loop;
    // --no-prefetch also loads each region that fits only when its build
    // starts.
    &DOUBLE_BUFFER,
    &DMA_LISTS,
    &NO_PREFETCH,
]);

/// `--key-order gh|xyz`: `MortonKnobs::key_order`.
pub const KEY_ORDER: Knob = Knob::word(
    "key-order",
    "the keys' bit order: the global heuristic's halvings (gh) or round robin x, y, z (xyz)",
    &["gh", "xyz"],
    &["xyz"],
)
.changing_the_tree();
/// `--key-bits auto|16|24|32|64`: `MortonKnobs::key_bits`.
pub const KEY_BITS: Knob = Knob::word(
    "key-bits",
    "key bits (auto: from the scene, the halvings its regions need: 16 up to about 4 million triangles with --region-size auto)",
    &["auto", "16", "24", "32", "64"],
    &["32", "64"],
);
/// `--digit-bits N`: `MortonKnobs::digit_bits`.
pub const DIGIT_BITS: Knob = Knob::int(
    "digit-bits",
    "bits per radix-sort pass",
    8,
    (4, 11),
    &["4", "11"],
);
/// `--region-size N|auto`: `MortonKnobs::region_size`.
pub const REGION_SIZE: Knob = Knob::int_or_auto(
    "region-size",
    "the largest region built by one SPE alone (triangles; auto: the smallest power of two from 64 to 1,024 that keeps 16-bit keys, n / 4,096 rounded up)",
    (1, usize::MAX),
    &["64", "256", "2048", "8192"],
);
/// `--static-regions`: `MortonKnobs::static_regions`.
pub const STATIC_REGIONS: Knob = Knob::flag(
    "static-regions",
    "regions dealt before the builds, not taken from an atomic counter",
);

/// `--permute`: `MortonKnobs::permute`.
pub const PERMUTE: Knob = Knob::flag(
    "permute",
    "the records gathered into a second array in key order before the top of the tree, each region loaded from there (the older default; now each region gathers its own records by their keys, no second array)",
);

/// The queue knobs of regions too large for a local store: the next
/// batch's get overlaps the partition, as the breadth-first strategies'.
const DEFAULT_QUEUE: QueueKnobs = QueueKnobs {
    double_buffer: false,
    dma_lists: false,
    prefetch: true,
};

/// SPE 0's outbound-mailbox word before the region count and spill size
/// (the pool's block requests share the mailbox: `arena::REQUEST_BLOCK`).
const REGIONS: u32 = 3;

/// This strategy's knobs, read from those given.
#[derive(Clone, Copy)]
struct MortonKnobs {
    /// The order of the keys' bits. The global heuristic's order gives the
    /// baseline's tree; round robin (LBVH) another tree, its keys cheaper
    /// to reason about, its quality the cost.
    key_order: KeyOrder,
    /// Key bits, 16 to 64 (0 until `auto` is resolved). Buys: fewer ranges left to the global
    /// heuristic (64); fewer bits, less key time and fewer radix passes
    /// (16: the dragon's regions are reached within 16 halvings). Costs:
    /// key time per bit, radix passes; too few bits leave ranges larger
    /// than a region, which the breadth-first loop builds (the same tree).
    key_bits: u32,
    /// Bits per radix pass (4 to 11). Buys: fewer passes over the keys.
    /// Costs: larger count tables (2^bits per SPE) and more scattered runs
    /// per pass.
    digit_bits: u32,
    /// The top of the tree stops at ranges of at most this many triangles
    /// (regions), each built by one SPE alone (0 until `auto` is
    /// resolved). Buys: fewer top nodes and probes (large); more regions to
    /// balance and less partitioning inside them (small). Costs: key bits
    /// (small: more halvings reach them).
    region_size: usize,
    /// Regions dealt before the builds (largest first, each to the
    /// least-loaded SPE) instead of taken largest first from an atomic
    /// counter. Buys: no atomics. Costs: balance.
    static_regions: bool,
    /// Every record gathered into a second array in key order (phase 3)
    /// before the regions. Buys: each region one contiguous get. Costs: a
    /// second record array (48 bytes a triangle) and a pass over every
    /// record. Without it each region gathers its records by their keys
    /// and writes their ids, in the tree's order, over its keys' indices.
    permute: bool,
    /// Regions too large for a local store run the breadth-first loop,
    /// with these.
    queue: QueueKnobs,
}

impl MortonKnobs {
    fn read(k: &Knobs) -> Self {
        MortonKnobs {
            key_order: match k.word(&KEY_ORDER) {
                "xyz" => KeyOrder::RoundRobin,
                _ => KeyOrder::GlobalHeuristic,
            },
            key_bits: match k.word(&KEY_BITS) {
                "auto" => 0,
                w => w.parse().expect("a key width of the table"),
            },
            digit_bits: k.int(&DIGIT_BITS) as u32,
            region_size: k.int(&REGION_SIZE),
            static_regions: k.flag(&STATIC_REGIONS),
            permute: k.flag(&PERMUTE),
            queue: QueueKnobs::read(k, DEFAULT_QUEUE),
        }
    }
}

/// Each SPE's WorkAPPE/WorkBPPE for regions too large for the local store
/// is asked for in units of this many bytes (one `WorkAPPE` block), so that
/// one mailbox word holds it.
const SPILL_UNIT: u64 = 16 * 1024;

/// Bytes of a triangle record, of a node.
const RECORD: usize = size_of::<TriRecord>();
const NODE: usize = size_of::<crate::bih::BihNode>();

/// One DMA block of records (341 of 48 bytes).
const RECORDS_PER_BLOCK: usize = (16 * 1024) / size_of::<TriRecord>();

/// Bytes of a region job in main memory: the paper's job.
const JOB: usize = 64;

fn spawn(cell: &mut Cell, setup: &Setup, cfg: &BihConfig) -> Result<Readback, CellError> {
    let (n, mut knobs, cfg) = (setup.count, MortonKnobs::read(&setup.knobs), *cfg);
    if knobs.region_size == 0 {
        knobs.region_size = auto_region_size(n);
    }
    if knobs.key_bits == 0 {
        knobs.key_bits = auto_key_bits(n, knobs.region_size, knobs.digit_bits);
    }
    let (rates, kernels) = (MortonRates::with(&setup.rates), setup.rates.kernels());
    let machine = super::machinery::forecast::machine_of(cell);
    let rated = (&rates, &kernels, &machine);
    let forecast = forecast::predict(n, &cfg, &knobs, rated, setup.spes);
    let spes = spes_used(setup.spes, n, &setup.knobs, || forecast.chosen());
    let pool = Pool::alloc(cell, n, &cfg, (spes, 1))?;
    let a = Areas::alloc(cell, setup, &knobs, &pool, spes)?;
    let spec = KeySpec {
        order: knobs.key_order,
        bits: knobs.key_bits,
        scene: setup.region,
    };
    let exits = (0..spes)
        .map(|id| {
            cell.spawn_spe(id, move |spe| async move {
                let mut p = Program::new(&spe, a, spec, knobs, rates, kernels, cfg)?;
                p.run().await
            })
        })
        .collect();
    let server = pool.server();
    let reach = cell.spawn_ppe(move |ppe| serve(ppe, server, knobs, spes));
    let records = match a.sorted {
        Some(at) => Records::Moved(at),
        None => Records::Ids {
            at: a.sorted_keys,
            stride: a.pairs.bytes as u64,
            word: a.pairs.index_word(),
        },
    };
    let readback = pool.readback(exits, reach, Some(records));
    Ok(Box::new(move || {
        let mut o = readback()?;
        o.predicted = Some(forecast.prediction());
        Ok(o)
    }))
}

/// One SPE's program.
struct Program<'a> {
    spe: &'a Spe,
    a: Areas,
    /// The keys' specs: the scene's, then one per range keyed again
    /// within its cell (`rekey`), in the order of their table.
    specs: Vec<KeySpec>,
    knobs: MortonKnobs,
    /// The rates this run charges: this strategy's and the shared kernels'.
    rates: MortonRates,
    kernels: KernelRates,
    cfg: BihConfig,
    line: LsAddr,
    tags: u32,
    barrier: Barrier,
    /// This SPE's ObjectArena list (lent to the breadth-first loop while
    /// it builds a region too large for the local store).
    arena: Option<ObjectArena<'a>>,
    /// Nodes straight into their slots (lent to the breadth-first loop
    /// while it builds a large region).
    writes: Option<NodeWrites<'a>>,
    items_partitioned: u64,
    partitions: u64,
    regions_built: u64,
    /// SPE 0: each phase and the cycle it ended at.
    phases: Vec<(&'static str, u64)>,
    /// Where the PPE allocated the region tables.
    tables: RegionTables,
    /// Bytes of each SPE's part of the spill area (`tables.spill`).
    spill_per_spe: u64,
    /// The regions this SPE's top made (every round), until their tables;
    /// then where they start in the unsorted table, and how many.
    regions: Vec<Job>,
    region_offset: usize,
    region_count: usize,
    /// Ranges to key again found in this round, and where each range found
    /// so far went (a `top::Top::Rekey` is an index here).
    found: Vec<rekey::Found>,
    placed: Vec<rekey::Placed>,
    /// Ranges keyed again so far (every SPE's), and rounds of the top.
    rekeys: usize,
    rounds: usize,
    /// Takes of the counter of ranges keyed again alone, in past rounds.
    solo_taken: usize,
    /// Triangles of the largest region too large for a local store (0:
    /// none): each SPE's part of the records area holds that many.
    largest: usize,
    /// The keys of the range being split, while the top reads them in the
    /// local store.
    window: Option<top::KeyWindow>,
    /// Bytes of the local store a region's build may take: what is free
    /// once the streamed phases are done. Fixed, so that the top (which
    /// holds a key window meanwhile), the region tables and the builds
    /// agree on which regions fit.
    region_area: u32,
}

/// Names of the radix passes, for the phase list.
const PASSES: [&str; 16] = [
    "radix pass 1",
    "radix pass 2",
    "radix pass 3",
    "radix pass 4",
    "radix pass 5",
    "radix pass 6",
    "radix pass 7",
    "radix pass 8",
    "radix pass 9",
    "radix pass 10",
    "radix pass 11",
    "radix pass 12",
    "radix pass 13",
    "radix pass 14",
    "radix pass 15",
    "radix pass 16",
];

impl<'a> Program<'a> {
    fn new(
        spe: &'a Spe,
        a: Areas,
        spec: KeySpec,
        knobs: MortonKnobs,
        rates: MortonRates,
        kernels: KernelRates,
        cfg: BihConfig,
    ) -> Result<Self, CellError> {
        Ok(Program {
            spe,
            a,
            specs: vec![spec],
            knobs,
            rates,
            kernels,
            cfg,
            line: spe.ls_alloc(128, 128)?,
            tags: spe.tags("spe_morton streams", 4)?,
            barrier: Barrier::new(a.arrivals, a.spes),
            arena: Some(ObjectArena::new(spe, a.blocks)?),
            writes: Some(NodeWrites::new(spe, a.pool, true)?),
            items_partitioned: 0,
            partitions: 0,
            regions_built: 0,
            phases: Vec::new(),
            tables: RegionTables::default(),
            spill_per_spe: 0,
            regions: Vec::new(),
            region_offset: 0,
            region_count: 0,
            found: Vec::new(),
            placed: Vec::new(),
            rekeys: 0,
            rounds: 0,
            solo_taken: 0,
            largest: 0,
            window: None,
            region_area: 0,
        })
    }

    /// This SPE's ObjectArena list.
    fn arena(&mut self) -> &mut ObjectArena<'a> {
        self.arena
            .as_mut()
            .expect("the arena is back from the loop")
    }

    fn w(&mut self) -> &mut NodeWrites<'a> {
        self.writes
            .as_mut()
            .expect("node writes are back from the loop")
    }

    async fn barrier(&mut self) -> Result<(), CellError> {
        self.barrier.wait(self.spe, self.line).await
    }

    /// A barrier that ends a phase (SPE 0 notes when).
    async fn end_phase(&mut self, name: &'static str) -> Result<(), CellError> {
        self.barrier().await?;
        if self.spe.id() == 0 {
            self.phases.push((name, self.spe.now().0));
        }
        Ok(())
    }

    /// The four 16 KiB buffers a streamed phase (keys, radix passes,
    /// permutation) works in: two in, two out.
    fn stream_buffers(&self) -> Result<[LsAddr; 4], CellError> {
        let mut bufs = [LsAddr(0); 4];
        for b in &mut bufs {
            *b = self.spe.ls_alloc(16 * 1024, 128)?;
        }
        Ok(bufs)
    }

    async fn run(&mut self) -> Result<SpeExit, CellError> {
        let mark = self.spe.ls_mark();
        let bufs = self.stream_buffers()?;
        let scene = self.scene_box(bufs).await?;
        // The same box the host would have handed over (tested), now paid for.
        debug_assert_eq!(scene, self.specs[0].scene);
        self.specs[0].scene = scene;
        self.end_phase("scene box").await?;
        self.keys(bufs).await?;
        self.end_phase("Morton keys").await?;
        let passes = radix::passes(self.knobs.key_bits, self.knobs.digit_bits);
        for pass in 0..passes {
            self.radix_pass(pass, bufs, (0, self.a.n), pass as usize % 2)
                .await?;
            self.end_phase(PASSES[pass as usize]).await?;
        }
        let keys = self.a.sorted_keys;
        if self.knobs.permute {
            self.permute(keys, bufs).await?;
            self.end_phase("permutation").await?;
        }
        self.spe.ls_release_to(mark);
        self.region_area = self.spe.ls_free_bytes();
        let mut parts = vec![self.top(keys, &[]).await?];
        loop {
            let found = self.found_this_round().await?;
            if found.is_empty() {
                break;
            }
            let roots = self.rekey_round(&found).await?;
            self.end_phase(if parts.len() == 1 {
                "top, keys within cells"
            } else {
                "more keys within cells"
            })
            .await?;
            parts.push(self.top(keys, &roots).await?);
        }
        self.place_regions().await?;
        self.end_phase("top of the tree").await?;
        self.build_regions().await?;
        self.end_phase("regions").await?;
        self.write_top(&parts).await?;
        self.w().finish().await?;
        let nodes = self.w().nodes;
        let count = self.arena().allocated();
        self.arena().close(count).await?;
        if self.spe.id() == 0 {
            self.phases.push(("top nodes", self.spe.now().0));
        }
        Ok(SpeExit {
            work: SpeWork {
                jobs: nodes,
                taken: self.regions_built,
                arena_blocks: self.arena().stats.blocks,
                arena_unused: self.arena().unused(),
                ..SpeWork::default()
            },
            items_partitioned: self.items_partitioned,
            partitions: self.partitions,
            phases: std::mem::take(&mut self.phases),
        })
    }
}
