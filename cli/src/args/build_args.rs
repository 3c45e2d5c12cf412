//! The build options every command that builds a tree shares (`build`,
//! `raycast`, `render`, `update`): the builder, the tree's limits and
//! quality knobs ([`BihConfig`]), the emulated Cell and its mode, and the
//! strategies' knobs ([`Knobs`]). Each flag's help says what it buys.

use clap::ValueEnum;

use cellbih::cell::CellConfig;
use cellbih::kernels::rates::RateOverrides;
use cellbih::registry::{Build, BuilderKind};
use cellbih::strategy::{Knob, Knobs};

use super::{RateArgs, TreeArgs};

use crate::Res;

#[derive(clap::Args)]
pub struct BuildArgs {
    /// Which builder makes the tree (see `cellbih builders`) [default:
    /// host; for `frame`, timed on the Cell: spe_bfs, the baseline]
    #[arg(long)]
    pub builder: Option<String>,
    #[command(flatten)]
    pub request: RequestArgs,
    /// The strategies' knobs, as the registry's tables declare them.
    #[command(flatten)]
    pub knobs: KnobArgs,
}

/// What every builder of a request shares (`compare` runs every builder
/// with them): the tree, the emulated Cell, the host threads.
#[derive(clap::Args)]
pub struct RequestArgs {
    #[command(flatten)]
    pub tree: TreeArgs,
    #[command(flatten)]
    pub cell: CellArgs,
    #[command(flatten)]
    pub host: HostThreadsArg,
}

/// The options of the emulated Cell that every command running on it
/// takes (`compare`, `build`, `raycast`, `render`, `update`, `frame`).
#[derive(clap::Args)]
pub struct CellArgs {
    /// SPEs of the emulated Cell, 1 to 16 (a PS3 program gets 6; 8 is a
    /// whole Cell; 9 to 16 is a what-if: more SPEs on the same memory
    /// interface, docs/many-spes.md). Builders that use fewer leave the
    /// others idle [default: 6]
    #[arg(long, value_parser = crate::args::between::<u64, _>(1..=16))]
    pub spes: Option<u64>,
    /// Main memory of the emulated Cell, MiB (a PS3 has 256). A build
    /// that does not fit fails, naming the buffer [default: 256]
    #[arg(long, value_parser = crate::args::between::<u64, _>(1..=4096))]
    pub memory_mib: Option<u64>,
    /// How the Cell is emulated: checked (timed, every DMA rule and race
    /// checked: the reference), timed (the same cycles, no race checks),
    /// or functional (no timing: fastest, for correctness runs)
    /// [default: checked]
    #[arg(long, value_enum)]
    pub mode: Option<Mode>,
    /// The PS3 model: measured (held against real PS3s with several SPEs,
    /// docs/validation.md; every figure of the README and docs/ is
    /// measured on it) or legacy (the model before that validation)
    /// [default: measured]
    #[arg(long, value_enum)]
    pub model: Option<MachineModel>,
    /// How the PPE and the SPEs reach their mailboxes: raw (MMIO, as
    /// libspe2 under Linux) or ps3-kernel (system calls and an event queue,
    /// 11.6 µs a round trip: docs/validation.md) [default: raw]
    #[arg(long, value_enum)]
    pub mailboxes: Option<Mailboxes>,
    #[command(flatten)]
    pub rates: RateArgs,
}

impl BuildArgs {
    /// The files the build reads besides its scene (`--rates`), by option:
    /// no output may replace one.
    pub fn inputs(&self) -> Vec<(&'static str, &std::path::Path)> {
        let file = self.request.cell.rates.set.rates_file.as_deref();
        file.map(|p| ("--rates", p)).into_iter().collect()
    }
}

impl CellArgs {
    /// The options given, by name.
    pub fn given(&self) -> Vec<&'static str> {
        [
            ("--spes", self.spes.is_some()),
            ("--memory-mib", self.memory_mib.is_some()),
            ("--mode", self.mode.is_some()),
            ("--model", self.model.is_some()),
            ("--mailboxes", self.mailboxes.is_some()),
        ]
        .into_iter()
        .filter_map(|(name, given)| given.then_some(name))
        .chain(self.rates.given())
        .collect()
    }

    /// The Cell the options ask for (a PS3 with 6 SPEs and 256 MiB where
    /// none is given); `--model` and `--mailboxes` with `--mode
    /// functional` are refused (it has no timing).
    pub fn config(&self) -> Res<CellConfig> {
        Ok(self.config_and_rates()?.0)
    }

    /// The Cell the options ask for, its machine rates set, and the
    /// library's rates given (`--code`, `--rate`, `--rates`); rates with
    /// `--mode functional` are refused (it has no timing).
    pub fn config_and_rates(&self) -> Res<(CellConfig, RateOverrides)> {
        let mode = self.mode.unwrap_or(Mode::Checked);
        let mut cell = CellConfig::ps3().with_spes(self.spes.unwrap_or(6) as usize);
        cell.main_memory_bytes = self.memory_mib.unwrap_or(256) * 1024 * 1024;
        cell.checked = matches!(mode, Mode::Checked);
        cell.cost = match self.model.unwrap_or(MachineModel::Measured) {
            MachineModel::Legacy => cellbih::cell::CostModel::ps3_legacy(),
            MachineModel::Measured => cellbih::cell::CostModel::ps3(),
        };
        if let Some(Mailboxes::Ps3Kernel) = self.mailboxes {
            cell.cost = cell.cost.with_ps3_kernel_mailboxes();
        }
        if let Mode::Functional = mode {
            let mut timing = vec![];
            timing.extend(self.model.map(|_| "--model"));
            timing.extend(self.mailboxes.map(|_| "--mailboxes"));
            timing.extend(self.rates.given());
            if !timing.is_empty() {
                let verb = match timing.len() {
                    1 => "does",
                    _ => "do",
                };
                return Err(format!(
                    "--mode functional has no timing: {} {verb} not apply",
                    timing.join(", ")
                )
                .into());
            }
            cell.cost = cellbih::cell::CostModel::functional();
            return Ok((cell, RateOverrides::default()));
        }
        let rates = self.rates.apply(&mut cell.cost)?;
        Ok((cell, rates))
    }
}

/// `--threads N` of the commands that build: the threads of a builder
/// that builds on the host's cores.
#[derive(clap::Args)]
pub struct HostThreadsArg {
    /// Threads of a builder that builds on the host's cores (host_shared,
    /// …), 1 to 1024 [default: the machine's available parallelism]. The
    /// others build on one thread (the emulator runs one): `compare` builds
    /// them so, the other commands refuse --threads for them
    #[arg(long, value_parser = crate::args::between::<u64, _>(1..=1024))]
    pub threads: Option<u64>,
}

impl HostThreadsArg {
    /// The threads given, else the machine's available parallelism.
    pub fn or_all(&self) -> usize {
        self.threads.map_or_else(
            || std::thread::available_parallelism().map_or(1, |n| n.get()),
            |n| n as usize,
        )
    }
}

/// `--mode`: the emulator's own speed/accuracy trade.
#[derive(Clone, Copy, ValueEnum)]
pub enum Mode {
    Checked,
    Timed,
    Functional,
}

/// `--model`.
#[derive(Clone, Copy, ValueEnum)]
pub enum MachineModel {
    Legacy,
    Measured,
}

/// `--mailboxes`.
#[derive(Clone, Copy, ValueEnum)]
pub enum Mailboxes {
    Raw,
    Ps3Kernel,
}

/// What the options ask for, with `host` where `--builder` is not given;
/// `casts_on_cell`: whether the command uses the emulated Cell whatever
/// builds the tree (`--on-cell`).
pub fn parse_build(args: &BuildArgs, casts_on_cell: bool) -> Res<Build> {
    parse_build_or(args, BuilderKind::HOST, casts_on_cell)
}

/// What the options ask for, with `default` where `--builder` is not given;
/// an option of the emulated Cell where nothing runs on it (a host builder,
/// no cast on the Cell) is an error that names it.
pub fn parse_build_or(args: &BuildArgs, default: BuilderKind, casts_on_cell: bool) -> Res<Build> {
    let builder = match &args.builder {
        None => default,
        Some(name) => BuilderKind::from_name(name).ok_or_else(|| {
            let names: Vec<_> = BuilderKind::ALL.iter().map(|b| b.name()).collect();
            format!(
                "unknown builder '{name}'; the builders are: {}",
                names.join(", ")
            )
        })?,
    };
    let given = args.request.cell.given();
    if !builder.emulated() && !casts_on_cell && !given.is_empty() {
        return Err(format!(
            "{}: builder {builder} builds on the host and nothing here runs on the emulated \
             Cell (an emulated builder, or --on-cell, would)",
            given.join(", ")
        )
        .into());
    }
    let (cell, rates) = args.request.cell.config_and_rates()?;
    // A knob the builder does not take is an error, not ignored, and so
    // is a value out of the knob's range (its table says which).
    let mut knobs = Knobs::default();
    for (name, value) in &args.knobs.given {
        builder.set_knob(&mut knobs, name, value)?;
    }
    let mut build = Build::new(builder)
        .with_tree(args.request.tree.config()?)
        .on(&cell)
        .with_knobs(&knobs)
        .with_rates(&rates);
    if args.request.host.threads.is_some() || builder.host_threads() {
        build = build.on_threads(args.request.host.or_all());
    }
    build.check()?;
    Ok(build)
}

/// The options of every strategy knob of the registry (`--NAME` for a
/// flag, `--NAME VALUE` otherwise), made from the builders' tables, and the
/// ones given.
#[derive(Default)]
pub struct KnobArgs {
    /// (name, value) of each knob given; an empty value for a flag.
    pub given: Vec<(&'static str, String)>,
}

/// Every knob of the registry's tables, once each, in table order.
fn every_knob() -> Vec<&'static Knob> {
    let mut seen: Vec<&'static Knob> = Vec::new();
    for k in BuilderKind::ALL
        .iter()
        .flat_map(|b| b.knobs().iter().copied())
    {
        if !seen.iter().any(|s| s.name == k.name) {
            seen.push(k);
        }
    }
    seen
}

impl clap::FromArgMatches for KnobArgs {
    fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let mut args = KnobArgs::default();
        args.update_from_arg_matches(m)?;
        Ok(args)
    }

    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        for k in every_knob() {
            if k.is_flag() {
                if m.get_flag(k.name) {
                    self.given.push((k.name, String::new()));
                }
            } else if let Some(v) = m.get_one::<String>(k.name) {
                self.given.push((k.name, v.clone()));
            }
        }
        Ok(())
    }
}

impl clap::Args for KnobArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        let mut cmd = cmd;
        for k in every_knob() {
            let takers: Vec<&str> = (BuilderKind::ALL.iter())
                .filter(|b| b.knobs().iter().any(|t| t.name == k.name))
                .map(|b| b.name())
                .collect();
            let help = if k.is_flag() {
                format!("{}: {}", takers.join(", "), k.help)
            } else {
                format!(
                    "{}: {} ({}) [default: {}]",
                    takers.join(", "),
                    k.help,
                    k.range(),
                    k.default_text()
                )
            };
            let arg = clap::Arg::new(k.name).long(k.name).help(help);
            cmd = cmd.arg(if k.is_flag() {
                arg.action(clap::ArgAction::SetTrue)
            } else {
                arg.value_name("VALUE").action(clap::ArgAction::Set)
            });
        }
        cmd
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}
