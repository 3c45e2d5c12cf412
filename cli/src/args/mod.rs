//! Every command-line argument of the front end, in one place: the
//! `cellbih` command's subcommands and the options they share (the scene,
//! the build, the emulated Cell, the cast, the camera, the animation), and
//! the experiments' shared options (threads, output, cameras). One
//! [`Format`] for all.
//!
//! The fields' doc comments are the options' help, written for a
//! terminal: `rtperf:N[:SEED]` is an optional part, not a link.
#![allow(rustdoc::broken_intra_doc_links)]

mod build_args;
mod cast_args;
mod rate_args;
mod scene_arg;
mod tree_args;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

use cellbih::render::View;
use cellbih::update::MAX_FRAMES;

pub use build_args::{
    BuildArgs, CellArgs, HostThreadsArg, KnobArgs, MachineModel, Mailboxes, Mode, RequestArgs,
    parse_build, parse_build_or,
};
pub use cast_args::{CacheArgs, CastArgs};
pub use rate_args::{
    Charges, CodeArg, RateArgs, RateSetArgs, charged_by, model_note, name_the_model_in_text,
    set_charges,
};
pub use scene_arg::{CameraArg, SceneArg, check_built, check_memory};
pub use tree_args::{SplitArg, TreeArgs};

/// The `cellbih` command.
#[derive(Parser)]
#[command(
    term_width = 80,
    name = "cellbih",
    version = cellbih::registry::settings::version_static(),
    about = "Bounding Interval Hierarchies on an emulated Cell Broadband Engine",
    after_help = "With no command, runs the demo: every builder on the embedded default \
                  scene, a table of their times and trees, and the image cellbih-demo.png \
                  written in the current directory."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// How a command or an experiment prints its results (the files an
/// experiment writes are written either way).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// A table for people.
    Text,
    /// The rows as JSON.
    Json,
}

/// The commands; with none, the demo.
#[derive(Subcommand)]
pub enum Command {
    /// Triangles, geometry ids, bounds and degenerate triangles of a scene.
    Info(InfoCommand),
    /// Every builder side by side on one scene: simulated ms and speedup
    /// over spe_bfs, host ms, SAH, measured ray cost, the tree's memory.
    Compare(CompareCommand),
    /// Builds the tree and reports its time and quality.
    Build(BuildCommand),
    /// Casts the rays of a CSV file (ox,oy,oz,dx,dy,dz,tmin,tmax) and writes
    /// the closest hits (ray,prim,t; a miss is prim -1).
    Raycast(RaycastCommand),
    /// Renders a shaded PNG, or with --heatmap the traversal cost per pixel.
    Render(RenderCommand),
    /// Moves objects frame by frame and keeps the tree up to date (the
    /// paper's local update, the deeper update, or complete rebuilds).
    Update(UpdateCommand),
    /// The whole frame on the Cell: per frame, objects move, the tree
    /// follows (rebuilt, or updated locally or deeply), and the primary
    /// rays are cast on the SPEs; every time is simulated PS3 time.
    Frame(FrameCommand),
    /// The names --builder accepts.
    Builders,
    /// Every rate the model charges, by the name --rate takes, at its value
    /// (cycles, or GB/s), with its band.
    Rates(RatesCommand),
}

/// `cellbih rates`.
#[derive(clap::Args)]
pub struct RatesCommand {
    /// The PS3 model whose machine rates are listed [default: measured]
    #[arg(long, value_enum)]
    pub model: Option<MachineModel>,
    #[command(flatten)]
    pub rates: RateArgs,
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
}

/// `cellbih info`.
#[derive(clap::Args)]
pub struct InfoCommand {
    #[command(flatten)]
    pub scene: SceneArg,
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
}

/// `cellbih compare`.
#[derive(clap::Args)]
pub struct CompareCommand {
    #[command(flatten)]
    pub scene: SceneArg,
    /// The tree every builder makes (builders that do not build these
    /// knobs are left out, and named), the Cell the emulated ones run on,
    /// the threads of those that build on the host's cores.
    #[command(flatten)]
    pub request: RequestArgs,
    #[command(flatten)]
    pub camera: CameraArg,
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
}

/// `cellbih build`.
#[derive(clap::Args)]
pub struct BuildCommand {
    #[command(flatten)]
    pub scene: SceneArg,
    #[command(flatten)]
    pub build: BuildArgs,
    #[command(flatten)]
    pub camera: CameraArg,
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
    /// Write the emulated Cell's timeline here as Chrome trace JSON
    /// (open it in ui.perfetto.dev or chrome://tracing). A trace costs
    /// about 100 bytes of file and 75 of memory per span, streamed to
    /// the file: spe_bfs on the default scene writes 0.4 MB, on the
    /// dragon 97 MB (946k spans, 70 MB more memory, 2 s more).
    #[arg(long)]
    pub trace: Option<PathBuf>,
}

/// `cellbih raycast`.
#[derive(clap::Args)]
pub struct RaycastCommand {
    #[command(flatten)]
    pub scene: SceneArg,
    #[command(flatten)]
    pub build: BuildArgs,
    /// The rays: a CSV file with the header ox,oy,oz,dx,dy,dz,tmin,tmax.
    #[arg(long)]
    pub rays: PathBuf,
    /// Where to write the hits (ray,prim,t), one line per ray.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub cast: CastArgs,
}

/// `cellbih render`.
#[derive(clap::Args)]
pub struct RenderCommand {
    #[command(flatten)]
    pub scene: SceneArg,
    #[command(flatten)]
    pub build: BuildArgs,
    /// The image to write (PNG: the name must end in .png).
    #[arg(long)]
    pub out: PathBuf,
    /// Color each pixel by its ray's traversal cost (nodes visited plus
    /// triangles tested) instead of shading it.
    #[arg(long)]
    pub heatmap: bool,
    /// Image width in pixels (1 to 16,384; at most 64 Mi pixels in all).
    #[arg(long, default_value_t = 800)]
    pub width: u32,
    /// Image height in pixels (1 to 16,384).
    #[arg(long, default_value_t = 600)]
    pub height: u32,
    #[command(flatten)]
    pub camera: CameraArg,
    #[command(flatten)]
    pub cast: CastArgs,
}

/// `cellbih update`.
#[derive(clap::Args)]
pub struct UpdateCommand {
    #[command(flatten)]
    pub play: PlayArgs,
    /// Frames to play, 0 to 100,000.
    #[arg(long, default_value_t = 20,
          value_parser = crate::args::between::<u64, _>(0..=MAX_FRAMES as u64))]
    pub frames: u64,
    /// local (Algorithm 1) | deep (section 5) | rebuild (every frame).
    #[arg(long, default_value = "local")]
    pub strategy: String,
    /// With --strategy deep: rebuild a touched subtree whole when it
    /// holds at most this many triangles [default: 48]
    #[arg(long)]
    pub deep_stop_below: Option<usize>,
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
}

/// `cellbih frame`.
#[derive(clap::Args)]
pub struct FrameCommand {
    #[command(flatten)]
    pub play: PlayArgs,
    /// Frames to play, 1 to 100,000.
    #[arg(long, default_value_t = 10,
          value_parser = crate::args::between::<u64, _>(1..=MAX_FRAMES as u64))]
    pub frames: u64,
    /// How the tree follows the moves: rebuild (every frame, with
    /// --builder), local (Algorithm 1), deep (section 5), or auto
    /// (section 5's metric: each frame's options priced before any is
    /// done — what each would build, counted on a copy of the tree, at
    /// the cost of builds timed before the first frame, and the render
    /// of the tree each leaves — the cheapest taken).
    #[arg(long, default_value = "local",
          value_parser = ["rebuild", "local", "deep", "auto"])]
    pub policy: String,
    /// Also run every option from the same state each frame (three
    /// times the work) and report how the policy's choices compare.
    #[arg(long)]
    pub oracle: bool,
    /// SPEs that update the tree; the others render meanwhile (the
    /// paper's arrangement: 1). Default: all of --spes, which build and
    /// then all render (section 5's).
    #[arg(long, value_parser = crate::args::between::<u64, _>(1..=16))]
    pub build_spes: Option<u64>,
    /// Image width in pixels: one primary ray each.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    #[command(flatten)]
    pub camera: CameraArg,
    #[command(flatten)]
    pub cache: CacheArgs,
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
    /// Write the paper's arrangement's one-Cell runs (each frame's update
    /// beside the casters, placed at the frame's start) here as Chrome
    /// trace JSON (open it in ui.perfetto.dev); needs --build-spes fewer
    /// than --spes
    #[arg(long)]
    pub trace: Option<PathBuf>,
}

/// What `update` and `frame` play: a scene, the build that makes (and
/// remakes) its tree, and the animation.
#[derive(clap::Args)]
pub struct PlayArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    #[command(flatten)]
    pub build: BuildArgs,
    #[command(flatten)]
    pub anim: AnimationArg,
    /// Where a local update finds the moved triangles of its interval:
    /// ppe (the paper's scan by geometry id) or spe (the build's SPEs, as
    /// they stream the interval) [default: ppe]
    #[arg(long, value_parser = ["ppe", "spe"])]
    pub find_moved: Option<String>,
}

impl PlayArgs {
    /// `--find-moved`, refused where no local update searches: the deep
    /// update's descent needs the moved triangles before any build, a
    /// rebuild searches nothing, a host builder has no SPEs.
    pub fn find_moved(
        &self,
        local: bool,
        what: &str,
        build: &cellbih::registry::Build,
    ) -> crate::Res<cellbih::update::FindMoved> {
        use cellbih::update::FindMoved;
        let Some(name) = &self.find_moved else {
            return Ok(FindMoved::Ppe);
        };
        let f = FindMoved::from_name(name)
            .ok_or_else(|| format!("unknown --find-moved '{name}': ppe or spe"))?;
        if !local {
            return Err(crate::usage(format!(
                "--find-moved applies to local updates (the deep update's descent needs the \
                 moved triangles before it builds; a rebuild searches nothing): here {what}"
            )));
        }
        if f == FindMoved::Spe && !build.builder.on_spes() {
            let on = match build.builder.emulated() {
                true => "the PPE",
                false => "the host",
            };
            return Err(crate::usage(format!(
                "--find-moved spe: builder {} builds on {on}, without SPEs",
                build.builder
            )));
        }
        Ok(f)
    }
}

/// `--animation` and `--seed` of `update` and `frame`.
#[derive(clap::Args)]
pub struct AnimationArg {
    /// rtperf (one sphere nudged per frame), car (parts out and back), cup
    /// (the glass moved: every real move grows the scene box) or part (any
    /// mesh: 2 % of its triangles split off as a part that moves up and
    /// down).
    #[arg(long)]
    pub animation: String,
    /// Seed of the animation's pseudo-random moves (rtperf).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// `--camera` of an experiment over several scenes: each scene's own
/// viewpoint, or every scene from outside its box.
#[derive(clap::Args, Clone, Debug)]
pub struct ViewsArg {
    /// Where each scene's camera stands: default (the scene's own
    /// viewpoint inside it where it has one — Sponza's atrium, Šibenik's
    /// nave — else the whole scene from outside) or framing (every scene
    /// from outside its box)
    #[arg(long = "camera", value_parser = ["default", "framing"], default_value = "default")]
    pub camera: String,
}

impl ViewsArg {
    /// The viewpoint asked for.
    pub fn view(&self) -> View {
        match self.camera.as_str() {
            "framing" => View::Framing,
            _ => View::Default,
        }
    }
}

/// `--data DIR` of an experiment that loads real meshes by name.
#[derive(clap::Args, Clone, Debug)]
pub struct DataArg {
    /// Directory of the real meshes (default: $CELLBIH_DATA).
    #[arg(long = "data")]
    pub given: Option<PathBuf>,
}

impl DataArg {
    /// The data directory: the one given, else `$CELLBIH_DATA`'s.
    pub fn dir(&self) -> Option<PathBuf> {
        cellbih::scene::data_dir(self.given.as_deref())
    }
}

/// Where an experiment over several scenes finds its meshes and where each
/// scene's camera stands: `--data DIR` and `--camera`.
#[derive(clap::Args, Clone, Debug)]
pub struct SceneArgs {
    #[command(flatten)]
    pub data: DataArg,
    #[command(flatten)]
    pub camera: ViewsArg,
}

/// An experiment's arguments, parsed as every program of the front end
/// parses them: help wrapped at 80 columns, errors printed by clap.
pub fn parse<A: clap::Parser>() -> A {
    // `--version` says which experiment, and the commit it was built from.
    let name = (std::env::args_os().next()).and_then(|a| {
        Some(
            std::path::Path::new(&a)
                .file_name()?
                .to_string_lossy()
                .into_owned(),
        )
    });
    let mut cmd =
        (A::command().term_width(80)).version(cellbih::registry::settings::version_static());
    if let Some(name) = name {
        // Once per process: clap keeps names as `&'static str`.
        cmd = cmd.name(&*Box::leak(name.into_boxed_str()));
    }
    let matches = cmd.clone().get_matches();
    A::from_arg_matches(&matches).unwrap_or_else(|e| e.format(&mut cmd).exit())
}

/// An experiment's `--threads N`.
#[derive(clap::Args, Clone, Debug)]
pub struct ThreadsArg {
    /// Host threads that run the independent emulations side by side
    /// (default: the machine's available parallelism). Simulated figures
    /// do not depend on it; host times measured side by side do.
    #[arg(long, value_parser = crate::args::between::<u64, _>(1..=1024))]
    pub threads: Option<u64>,
}

/// What an experiment that runs emulations side by side takes: its
/// threads and where its results go.
#[derive(clap::Args, Clone, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    pub threads: ThreadsArg,
    #[command(flatten)]
    pub output: OutputArgs,
}

/// The options of every experiment that prints rows and writes files:
/// how the rows are printed and where the files go.
#[derive(clap::Args, Clone, Debug)]
pub struct OutputArgs {
    /// text (tables) or json (the rows).
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
    /// Directory for the experiment's CSV, JSON and SVG files.
    #[arg(long, default_value = "results")]
    pub out: PathBuf,
}

/// A command-line value parser for a whole number of at least 1, whose
/// error says so in words (clap's own range check prints the type's
/// largest value: `1..=4294967295`).
pub fn at_least_one<T>(text: &str) -> Result<T, String>
where
    T: std::str::FromStr + PartialOrd + From<u8>,
{
    match text.trim().parse::<T>() {
        Ok(v) if v >= T::from(1) => Ok(v),
        Ok(_) => Err(format!(
            "{text} is less than 1: give a whole number of at least 1"
        )),
        Err(_) => Err(format!(
            "'{text}' is not a whole number of at least 1 (or it is too large)"
        )),
    }
}

/// A command-line value parser for a whole number in `range`, whose
/// error says so in words ("0 is not between 1 and 16"; clap's own range
/// check says `0 is not in 1..=16`).
pub fn between<T, N>(
    range: std::ops::RangeInclusive<N>,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: TryFrom<i128>,
    N: Into<i128> + Copy,
{
    let (lo, hi): (i128, i128) = ((*range.start()).into(), (*range.end()).into());
    move |text: &str| {
        let v: i128 = text
            .trim()
            .parse()
            .map_err(|_| format!("'{text}' is not a whole number"))?;
        if !(lo..=hi).contains(&v) {
            return Err(format!("{v} is not between {lo} and {hi}"));
        }
        T::try_from(v).map_err(|_| format!("{v} is not between {lo} and {hi}"))
    }
}
