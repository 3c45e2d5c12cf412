//! The model's rates on the command line: the code class (`--code`),
//! rates set by name (`--rate`, `--rates FILE`), which commands charge
//! which rates, and the note an experiment prints when its model is not
//! the default.

use clap::ValueEnum;

use cellbih::cell::CellConfig;
use cellbih::kernels::rates::{Code, RateOverrides};
use cellbih::registry::{Build, BuilderKind};

use crate::Res;

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
    } else if name == "ppe_memory_cycles" {
        // The PPE's loads: its own builds' passes and the updates' steps.
        (c.builds || c.updates, "builds, updates")
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
