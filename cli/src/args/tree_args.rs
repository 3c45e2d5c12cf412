//! The tree's limits and quality knobs on the command line ([`TreeArgs`]):
//! every command of `cellbih` that builds a tree and the experiments that
//! build with chosen knobs (`host_scaling`) read the same options, with the
//! same checks. Each flag's help says what it buys.

use clap::ValueEnum;

use cellbih::bih::{BihConfig, SplitChoice};
use cellbih::kernels::sah::{DEFAULT_BINS, MAX_BINS};

/// The tree's limits and quality knobs ([`BihConfig`]): the options of
/// every command that builds, `compare` among them.
#[derive(clap::Args)]
pub struct TreeArgs {
    /// Largest leaf, in triangles (at least 1).
    #[arg(long, default_value_t = BihConfig::default().leaf_size,
          value_parser = crate::args::at_least_one::<u32>)]
    pub leaf_size: u32,
    /// How inner nodes choose their plane: gh (the paper's global
    /// heuristic: halve the candidate box) or sah (binned surface-area
    /// heuristic: fewer nodes and triangles per ray, one more pass over
    /// each node's triangles). Every builder but ppe_approx and spe_morton.
    #[arg(long, value_enum, default_value = "gh")]
    pub split: SplitArg,
    /// --split sah: bins per axis (2 to 256) [default: 16].
    #[arg(long, value_parser = crate::args::between::<u32, _>(2..=MAX_BINS))]
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
    #[arg(long, value_parser = percent)]
    pub empty_cut: Option<u32>,
    /// Deepest leaf (root = 0), at most 126 (the traversal stack's depth).
    #[arg(long, default_value_t = BihConfig::default().max_depth,
          value_parser = crate::args::between::<u32, _>(0..=BihConfig::MAX_SUPPORTED_DEPTH))]
    pub max_depth: u32,
}

impl TreeArgs {
    /// The tree configuration asked for; binned SAH's options without
    /// `--split sah` are an error, not ignored.
    pub fn config(&self) -> Result<BihConfig, String> {
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

/// `--empty-cut`: a whole percentage, 1 to 99.
fn percent(v: &str) -> Result<u32, String> {
    match v.parse::<u32>() {
        Ok(p) if (1..=99).contains(&p) => Ok(p),
        Ok(p) => Err(format!("{p} is not between 1 and 99")),
        Err(_) if v.parse::<f64>().is_ok() => Err(format!(
            "a whole percentage is wanted (1 to 99), not {v}: round it"
        )),
        Err(_) => Err(format!("a whole percentage is wanted (1 to 99), not '{v}'")),
    }
}

/// `--split`.
#[derive(Clone, Copy, ValueEnum)]
pub enum SplitArg {
    Gh,
    Sah,
}
