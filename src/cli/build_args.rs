//! The build options every command that builds a tree shares (`build`,
//! `raycast`, `render`, `update`): the builder, the tree's limits and
//! quality knobs ([`BihConfig`]), the emulated Cell and its mode, and the
//! strategies' knobs ([`Knobs`]). Each flag's help says what it buys.

use clap::ValueEnum;

use cellbih::bih::{BihConfig, SplitChoice};
use cellbih::cell::CellConfig;
use cellbih::kernels::sah::{DEFAULT_BINS, MAX_BINS};
use cellbih::registry::{BuildReport, BuilderKind};
use cellbih::scene::Scene;
use cellbih::strategy::Knobs;

use super::Res;

/// The tree's limits and quality knobs ([`BihConfig`]): the options of
/// every command that builds, `compare` among them.
#[derive(clap::Args)]
pub struct TreeArgs {
    /// Largest leaf, in triangles (at least 1).
    #[arg(long, default_value_t = BihConfig::default().leaf_size,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub leaf_size: u32,
    /// How inner nodes choose their plane: gh (the paper's global
    /// heuristic: halve the candidate box) or sah (binned surface-area
    /// heuristic: fewer nodes and triangles per ray, one more pass over
    /// each node's triangles). Every builder but ppe_approx and spe_morton.
    #[arg(long, value_enum, default_value = "gh")]
    pub split: SplitArg,
    /// --split sah: bins per axis (2 to 256) [default: 16].
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=MAX_BINS as i64))]
    pub sah_bins: Option<u32>,
    /// --split sah: nodes of at most this many triangles take the global
    /// heuristic's halving instead of binning (0: every node bins). A
    /// faster build for a little quality: the small nodes are most of the
    /// bin sweeps.
    /// [default: 0]
    #[arg(long)]
    pub sah_above: Option<u32>,
    /// Empty-space cut-off: a gap of more than this percentage of a node's
    /// extent beside its triangles is cut off by a clip node (1 to 99;
    /// off by default). Every builder but ppe_approx and spe_morton.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=99))]
    pub empty_cut: Option<u32>,
    /// Deepest leaf (root = 0), at most 126 (the traversal stack's depth).
    #[arg(long, default_value_t = BihConfig::default().max_depth,
          value_parser = clap::value_parser!(u32).range(0..=BihConfig::MAX_SUPPORTED_DEPTH as i64))]
    pub max_depth: u32,
}

impl TreeArgs {
    /// The tree configuration asked for; binned SAH's options without
    /// `--split sah` are an error, not ignored.
    pub fn config(&self) -> Res<BihConfig> {
        let split = match self.split {
            SplitArg::Gh => {
                if self.sah_bins.is_some() || self.sah_above.is_some() {
                    return Err("--sah-bins and --sah-above apply to --split sah only \
                                (the global heuristic bins nothing)"
                        .into());
                }
                SplitChoice::GlobalHeuristic
            }
            SplitArg::Sah => SplitChoice::BinnedSah {
                bins: self.sah_bins.unwrap_or(DEFAULT_BINS),
                above: self.sah_above.unwrap_or(0),
            },
        };
        Ok(BihConfig {
            leaf_size: self.leaf_size,
            max_depth: self.max_depth,
            split,
            empty_cut: self.empty_cut,
        })
    }
}

#[derive(clap::Args)]
pub struct BuildArgs {
    /// Which builder makes the tree (see `cellbih builders`).
    #[arg(long, default_value = "host")]
    pub builder: String,
    #[command(flatten)]
    pub tree: TreeArgs,
    /// ppe_approx: at most this many cells of the presort grid per axis
    /// (1 to 1024) [default: 1024].
    #[arg(long)]
    pub approx_cells: Option<u64>,
    /// SPEs of the emulated Cell, 1 to 8 (a PS3 program gets 6; 8 is a
    /// whole Cell). Builders that use fewer leave the others idle.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u64).range(1..=8))]
    pub spes: u64,
    /// Main memory of the emulated Cell, MiB (a PS3 has 256). A build
    /// that does not fit fails, naming the buffer.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u64).range(1..=4096))]
    pub memory_mib: u64,
    /// How the Cell is emulated: checked (timed, every DMA rule and race
    /// checked: the reference), timed (the same cycles, no race checks),
    /// or functional (no timing: fastest, for correctness runs).
    #[arg(long, value_enum, default_value = "checked")]
    pub mode: Mode,
    /// Multi-SPE builders: the SPEs do not help partition the top levels
    /// (they wait for the deal instead).
    #[arg(long)]
    pub no_coop_top: bool,
    /// Multi-SPE builders: the top levels end at the first level with this
    /// many jobs per SPE (1 to 16) [default: 4].
    #[arg(long)]
    pub deal_per_spe: Option<u64>,
    /// Multi-SPE builders: the dealt jobs stay in per-SPE lists and an SPE
    /// whose list is empty steals from another's (the atomic unit).
    #[arg(long)]
    pub steal: bool,
    /// spe_bfs_shared: jobs taken from the shared queue per atomic
    /// operation (1 to 256) [default: 16].
    #[arg(long)]
    pub agglomerate: Option<u64>,
    /// spe_bfs_shared: every take is --agglomerate jobs, not an SPE's
    /// share of the jobs left (guided self-scheduling, the default).
    #[arg(long)]
    pub fixed_takes: bool,
    /// Multi-SPE builders: double-buffered WorkA/WorkB (no synchronous
    /// job-queue DMA; section 5).
    #[arg(long)]
    pub double_buffer: bool,
    /// Multi-SPE builders: DMA lists for agglomerated jobs (section 5).
    #[arg(long)]
    pub dma_lists: bool,
    /// Multi-SPE builders: the next batch's get overlaps this batch's
    /// partition.
    #[arg(long)]
    pub prefetch: bool,
    /// spe_morton: the keys' bit order: the global heuristic's halvings
    /// (gh: the baseline's tree) or round robin x, y, z (xyz: LBVH)
    /// [default: gh].
    #[arg(long, value_enum)]
    pub key_order: Option<KeyOrderArg>,
    /// spe_morton: key bits, 32 or 64 [default: 32].
    #[arg(long)]
    pub key_bits: Option<u64>,
    /// spe_morton: bits per radix-sort pass (4 to 11) [default: 8].
    #[arg(long)]
    pub digit_bits: Option<u64>,
    /// spe_morton: the largest region built by one SPE alone (triangles)
    /// [default: 2048].
    #[arg(long)]
    pub region_size: Option<u64>,
    /// spe_morton: regions dealt before the builds, not taken from an
    /// atomic counter.
    #[arg(long)]
    pub static_regions: bool,
}

/// `--mode`: the emulator's own speed/accuracy trade.
#[derive(Clone, Copy, ValueEnum)]
pub enum Mode {
    Checked,
    Timed,
    Functional,
}

/// `--split`.
#[derive(Clone, Copy, ValueEnum)]
pub enum SplitArg {
    Gh,
    Sah,
}

/// `--key-order`.
#[derive(Clone, Copy, ValueEnum)]
pub enum KeyOrderArg {
    Gh,
    Xyz,
}

/// What `--builder` and its options ask for.
pub struct Chosen {
    pub builder: BuilderKind,
    pub cfg: BihConfig,
    pub cell: CellConfig,
    pub knobs: Knobs,
}

impl Chosen {
    pub fn build(&self, s: &Scene) -> Res<BuildReport> {
        Ok(self
            .builder
            .build_with(s, s.bounds(), &self.cfg, &self.cell, &self.knobs)?)
    }

    /// "builder B" and, for an emulated one, "on N SPEs".
    pub fn describe(&self) -> String {
        if self.builder.emulated() {
            format!("builder {} on {} SPEs", self.builder, self.cell.spes)
        } else {
            format!("builder {}", self.builder)
        }
    }
}

pub fn parse_build(args: &BuildArgs) -> Res<Chosen> {
    let builder = BuilderKind::from_name(&args.builder).ok_or_else(|| {
        let names: Vec<_> = BuilderKind::ALL.iter().map(|b| b.name()).collect();
        format!(
            "unknown builder '{}'; the builders are: {}",
            args.builder,
            names.join(", ")
        )
    })?;
    let cfg = args.tree.config()?;
    let mut cell = CellConfig::ps3().with_spes(args.spes as usize);
    cell.main_memory_bytes = args.memory_mib * 1024 * 1024;
    cell.checked = matches!(args.mode, Mode::Checked);
    if let Mode::Functional = args.mode {
        cell.cost = cellbih::cell::CostModel::functional();
    }
    // The strategy knobs given, as the command line spells them: one the
    // builder does not take is an error, not ignored; the strategy checks
    // the values' ranges when it starts.
    let flag = |on: bool| on.then(String::new);
    let num = |v: Option<u64>| v.map(|v| v.to_string());
    let given = [
        ("no-coop-top", flag(args.no_coop_top)),
        ("deal-per-spe", num(args.deal_per_spe)),
        ("steal", flag(args.steal)),
        ("agglomerate", num(args.agglomerate)),
        ("fixed-takes", flag(args.fixed_takes)),
        ("double-buffer", flag(args.double_buffer)),
        ("dma-lists", flag(args.dma_lists)),
        ("prefetch", flag(args.prefetch)),
        (
            "key-order",
            (args.key_order).map(|o| o.to_possible_value().unwrap().get_name().to_string()),
        ),
        ("key-bits", num(args.key_bits)),
        ("digit-bits", num(args.digit_bits)),
        ("region-size", num(args.region_size)),
        ("static-regions", flag(args.static_regions)),
        ("approx-cells", num(args.approx_cells)),
    ];
    let mut knobs = Knobs::default();
    for (name, value) in given.iter().filter_map(|(n, v)| Some((n, v.as_ref()?))) {
        builder.check_knob(name)?;
        knobs.set(name, value)?;
    }
    Ok(Chosen {
        builder,
        cfg,
        cell,
        knobs,
    })
}
