//! The build options every command that builds a tree shares (`build`,
//! `raycast`, `render`, `update`): the builder, the tree's limits and
//! quality knobs ([`BihConfig`]), the emulated Cell and its mode, and the
//! strategies' knobs ([`Knobs`]). Each flag's help says what it buys.

use clap::ValueEnum;

use cellbih::cell::CellConfig;
use cellbih::kernels::rates::{Code, RateOverrides};
use cellbih::registry::{Build, BuilderKind};
use cellbih::strategy::{Knob, Knobs};

use super::TreeArgs;

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

/// The rates of the model: the code class and rates set by name.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct RateArgs {
    /// The class of code the SPU kernels' rates price: paper (the paper's
    /// scalar code: each derived kernel at 4 times its instruction count,
    /// the partition at its Table 1 fit), compiled (C with SIMD intrinsics
    /// as spu-gcc compiles it: every SPU kernel at 3.49 times its count,
    /// from two compiled kernels timed on a PS3) or tuned (hand-tuned
    /// SIMD: every SPU kernel at 1.1 times its count) [default: paper]
    #[arg(long, value_enum)]
    pub code: Option<CodeArg>,
    #[command(flatten)]
    pub set: RateSetArgs,
}

/// Rates set by name.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct RateSetArgs {
    /// Sets one rate, NAME=VALUE: cycles, or GB/s for a bandwidth
    /// (repeatable; `cellbih rates` lists every name, value and band)
    #[arg(long = "rate", value_name = "NAME=VALUE")]
    pub rate: Vec<String>,
    /// Rates from a file (`-`: the standard input): one `NAME = VALUE` a
    /// line, `#` starts a comment, each name once; a --rate given beside
    /// it wins
    #[arg(long = "rates", value_name = "FILE")]
    pub rates_file: Option<std::path::PathBuf>,
}

/// `--code`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum CodeArg {
    Paper,
    Compiled,
    Tuned,
}

impl CodeArg {
    /// The library's class of this name.
    pub fn code(self) -> Code {
        match self {
            CodeArg::Paper => Code::Paper,
            CodeArg::Compiled => Code::Compiled,
            CodeArg::Tuned => Code::Tuned,
        }
    }
}

impl RateArgs {
    /// The options given, by name.
    pub fn given(&self) -> Vec<&'static str> {
        let code = self.code.map(|_| "--code");
        code.into_iter().chain(self.set.given()).collect()
    }

    /// The code class given.
    pub fn code(&self) -> Code {
        self.code.map_or(Code::Paper, CodeArg::code)
    }

    /// A PS3 of `spes` SPEs with the machine rates given, and the
    /// library's rates given (an experiment's model).
    pub fn ps3(&self, spes: usize) -> Result<(CellConfig, RateOverrides), String> {
        let mut cell = CellConfig::ps3().with_spes(spes);
        let rates = self.apply(&mut cell.cost).map_err(|e| e.to_string())?;
        Ok((cell, rates))
    }

    /// Sets the machine rates given in `cost`; returns the library's
    /// rates given (the code class, and each other name at its value), a
    /// name that is no rate refused by name.
    pub fn apply(&self, cost: &mut cellbih::cell::CostModel) -> Res<RateOverrides> {
        let rates = self.set.apply(cost, self.code())?;
        let mut given: Vec<String> = Vec::new();
        if rates.code() != Code::Paper {
            given.push(format!("--code {}", rates.code()));
        }
        if let Some(file) = &self.set.rates_file {
            given.push(format!("--rates {}", file.display()));
        }
        given.extend(self.set.rate.iter().map(|r| format!("--rate {}", r.trim())));
        if !given.is_empty() {
            name_the_model(given.join(" "));
        }
        Ok(rates)
    }

    /// An experiment's model as a build request every builder of it
    /// shares (the host builder's, on a PS3 of `spes` SPEs with the rates
    /// given); where it simulates nothing (`simulates` false: `--no-sim`)
    /// a rate given is refused, naming it.
    pub fn model(&self, spes: usize, simulates: bool) -> Result<Build, String> {
        if !simulates && !self.given().is_empty() {
            return Err(format!(
                "{}: --no-sim runs nothing on the emulated Cell",
                self.given().join(", ")
            ));
        }
        let (cell, rates) = self.ps3(spes)?;
        Ok(Build::new(BuilderKind::HOST).on(&cell).with_rates(&rates))
    }
}

impl BuildArgs {
    /// The files the build reads besides its scene (`--rates`), by option:
    /// no output may replace one.
    pub fn inputs(&self) -> Vec<(&'static str, &std::path::Path)> {
        let file = self.request.cell.rates.set.rates_file.as_deref();
        file.map(|p| ("--rates", p)).into_iter().collect()
    }
}

impl RateSetArgs {
    /// The options given, by name.
    pub fn given(&self) -> Vec<&'static str> {
        [
            ("--rate", !self.rate.is_empty()),
            ("--rates", self.rates_file.is_some()),
        ]
        .into_iter()
        .filter_map(|(name, given)| given.then_some(name))
        .collect()
    }

    /// Every NAME=VALUE given, the file's first, in order, each with where
    /// it was given (`FILE:LINE` or `--rate`). A name set twice in the
    /// file, or twice by `--rate`, is an error naming both places; a
    /// `--rate` beside the file wins over its line.
    fn entries(&self) -> Res<Vec<RateEntry>> {
        let mut out: Vec<RateEntry> = Vec::new();
        if let Some(path) = &self.rates_file {
            for (line, name, value) in read_rates_file(path)? {
                let at = format!("{}:{line}", shown(path));
                if let Some(first) = out.iter().find(|e| e.name == name) {
                    return Err(format!(
                        "{at}: {name} is set again (first at {}); set each rate once",
                        first.at
                    )
                    .into());
                }
                out.push(RateEntry { at, name, value });
            }
        }
        let from_file = out.len();
        for r in &self.rate {
            let (n, v) = (r.split_once('='))
                .ok_or_else(|| format!("--rate {r}: NAME=VALUE (cycles, or GB/s)"))?;
            let (name, value) = (n.trim().to_string(), v.trim().to_string());
            if name.is_empty() {
                return Err(format!("--rate {r}: the rate's name is missing before '='").into());
            }
            if out[from_file..].iter().any(|e| e.name == name) {
                return Err(format!("--rate {name} is given twice; give each rate once").into());
            }
            out.retain(|e| e.name != name);
            let at = "--rate".to_string();
            out.push(RateEntry { at, name, value });
        }
        Ok(out)
    }

    /// Sets the machine rates given in `cost`, for a command that charges
    /// no kernel (`command`): a kernel's rate is refused.
    pub fn machine_only(
        &self,
        cost: &mut cellbih::cell::CostModel,
        command: &str,
    ) -> Result<(), String> {
        let rates = (self.apply(cost, Code::Paper)).map_err(|e| e.to_string())?;
        let unused: Vec<String> = rates.names().map(|n| format!("--rate {n}")).collect();
        match unused.is_empty() {
            true => Ok(()),
            false => Err(format!(
                "{}: {command} charges the machine's rates only, no kernel's",
                unused.join(", ")
            )),
        }
    }

    /// Sets the machine rates given in `cost`; returns the library's
    /// rates given in the class `code`, a name that is no rate refused by
    /// name.
    pub fn apply(&self, cost: &mut cellbih::cell::CostModel, code: Code) -> Res<RateOverrides> {
        let mut rates = RateOverrides::default().with_code(code);
        for RateEntry { at, name, value } in self.entries()? {
            let with_place = |e: String| match at.as_str() {
                "--rate" => format!("--rate {e}"),
                _ => format!("{at}: {e}"),
            };
            match cost.set_rate(&name, &value) {
                Some(done) => {
                    done.map_err(with_place)?;
                    check_charged(&name, code).map_err(with_place)?;
                }
                None => {
                    let name = BuilderKind::rate_named(&name, code)
                        .map_err(|e| with_place(e.to_string()))?;
                    check_charged(name, code).map_err(with_place)?;
                    let cycles = cellbih::cell::parse_cycles(&value)
                        .map_err(|why| with_place(format!("{name}={value}: {why}")))?;
                    rates = rates.with(name, cycles);
                }
            }
        }
        Ok(rates)
    }
}

/// The model an experiment runs, where it is not the default (`--code
/// tuned --rate …`), once it is known; and whether its text goes to the
/// standard output.
static MODEL: std::sync::OnceLock<String> = std::sync::OnceLock::new();
static TEXT_OUT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether this process prints its tables as text: then a model that is
/// not the default is said first.
pub fn name_the_model_in_text(text: bool) {
    TEXT_OUT.store(text, std::sync::atomic::Ordering::Relaxed);
}

/// The run's model is not the default: `given` names it (the options as
/// typed). An experiment printing text says so first on its standard
/// output, and every plot's title says it ([`model_note`]).
fn name_the_model(given: String) {
    if MODEL.set(given.clone()).is_ok() && TEXT_OUT.load(std::sync::atomic::Ordering::Relaxed) {
        let line = format!(
            "model: {given} (not the default: the paper's class, every rate as calibrated)"
        );
        println!("{}", cellbih::words::wrapped(&line));
    }
}

/// The run's model where it is not the default, as a plot's title says it.
pub fn model_note() -> Option<&'static str> {
    MODEL.get().map(String::as_str)
}

/// What a command charges, so that a `--rate` of a rate it never charges
/// is refused by name (it would move nothing): its builds' kernels, the
/// caster's, the update's PPE share, and the machine's rates for transfers
/// between local stores and for the PPE's atomics (which only `validate`'s
/// kernels exercise). The software cache's rates go with builds (a job
/// cache) and casts alike; every other machine rate with any run.
#[derive(Clone, Copy, Debug)]
pub struct Charges {
    pub builds: bool,
    pub casts: bool,
    pub updates: bool,
    pub fabric_and_ppe_atomics: bool,
}

impl Charges {
    /// Builds, and casts and updates as `casts` and `updates` say.
    pub const fn builds_and(casts: bool, updates: bool) -> Charges {
        Charges {
            casts,
            updates,
            ..Charges::BUILDS
        }
    }

    /// Builds only.
    pub const BUILDS: Charges = Charges {
        builds: true,
        casts: false,
        updates: false,
        fabric_and_ppe_atomics: false,
    };
}

/// The command's name and what it charges, set once before its rates are
/// read (none set: every rate is taken).
static CHARGES: std::sync::OnceLock<(&'static str, Charges)> = std::sync::OnceLock::new();

/// This process runs `command`, which charges `charges`.
pub fn set_charges(command: &'static str, charges: Charges) {
    let _ = CHARGES.set((command, charges));
}

/// What charges the rate `name` (in the class `code`), as `cellbih rates`
/// marks it: `(whether a command charging `c` charges it, the runs that do)`.
pub fn charged_by(name: &str, code: Code, c: Charges) -> (bool, &'static str) {
    use cellbih::cast::{CastRates, Precision};
    use cellbih::kernels::ppe_rates::PpeRates;
    use cellbih::spe::software_cache::CacheRates;
    let named = |v: Vec<&'static str>| v.contains(&name);
    let cast = CastRates::table(Precision::Single, code)
        .iter()
        .map(|r| r.name)
        .collect();
    let cache = CacheRates::table(code).iter().map(|r| r.name).collect();
    let update = PpeRates::table().iter().map(|r| r.name).collect();
    let builds = BuilderKind::rates(code)
        .into_iter()
        .map(|r| r.name)
        .collect();
    if cellbih::cell::cost::FABRIC_AND_PPE_ATOMICS.contains(&name) {
        (c.fabric_and_ppe_atomics, "validate")
    } else if named(cast) {
        (c.casts, "casts")
    } else if named(cache) {
        (c.casts || c.builds, "casts, builds")
    } else if named(update) {
        (c.updates, "updates")
    } else if named(builds) {
        (c.builds, "builds")
    } else {
        (true, "every run")
    }
}

/// Refuses `name` where the command set by [`set_charges`] never charges
/// it, saying which runs do.
fn check_charged(name: &str, code: Code) -> Result<(), String> {
    let Some(&(command, c)) = CHARGES.get() else {
        return Ok(());
    };
    let (charged, runs) = charged_by(name, code, c);
    let runs = match runs {
        "validate" => "validate's kernels (transfers between local stores, the PPE's atomics)",
        "casts" => "casts on the Cell (render and raycast --on-cell, frame, frame_loop, tradeoff)",
        "updates" => "updates (update, frame, table2, partial_rebuild, frame_loop)",
        other => other,
    };
    match charged {
        true => Ok(()),
        false => Err(format!(
            "{name}: {command} never charges it (it moves {runs})"
        )),
    }
}

/// One rate given: where (`FILE:LINE` or `--rate`), its name and value.
struct RateEntry {
    at: String,
    name: String,
    value: String,
}

/// The most bytes a rates file may hold: every rate with a comment is a
/// few kilobytes.
const MAX_RATES_FILE_BYTES: u64 = 1 << 20;

/// A path as messages show it (`-`: the standard input).
fn shown(path: &std::path::Path) -> String {
    match path.as_os_str() == "-" {
        true => "- (the standard input)".into(),
        false => path.display().to_string(),
    }
}

/// The `NAME = VALUE` lines of a rates file (`-`: the standard input),
/// each with its line number: at most [`MAX_RATES_FILE_BYTES`], text
/// (a UTF-8 byte-order mark skipped), `#` starting a comment.
fn read_rates_file(path: &std::path::Path) -> Res<Vec<(usize, String, String)>> {
    use std::io::Read;
    let err = |why: String| format!("--rates {}: {why}", shown(path));
    let input: Box<dyn Read> = match path.as_os_str() == "-" {
        true => Box::new(std::io::stdin()),
        false => Box::new(std::fs::File::open(path).map_err(|e| err(e.to_string()))?),
    };
    let mut bytes = Vec::new();
    (input.take(MAX_RATES_FILE_BYTES + 1))
        .read_to_end(&mut bytes)
        .map_err(|e| err(e.to_string()))?;
    if bytes.len() as u64 > MAX_RATES_FILE_BYTES {
        return Err(err(format!(
            "more than {} MiB: not a rates file",
            MAX_RATES_FILE_BYTES >> 20
        ))
        .into());
    }
    let text = cellbih::text_input::read_text(&bytes[..]).map_err(|e| err(e.to_string()))?;
    let text = String::from_utf8(text).map_err(|_| err("it is not UTF-8 text".into()))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let (n, v) = line.split_once('=').ok_or_else(|| {
            format!(
                "{}:{}: '{line}': a line is NAME = VALUE",
                shown(path),
                i + 1
            )
        })?;
        if n.trim().is_empty() {
            return Err(format!(
                "{}:{}: '{line}': the rate's name is missing",
                shown(path),
                i + 1
            )
            .into());
        }
        out.push((i + 1, n.trim().to_string(), v.trim().to_string()));
    }
    Ok(out)
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
