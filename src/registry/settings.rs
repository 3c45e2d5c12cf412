//! What made a report: the settings a build (and a cast) ran with, named
//! in every report — a line of text and a JSON `settings` object — so that
//! two results from different settings are never mistaken for each other.

use serde_json::{Value, json};

use crate::bih::SplitChoice;
use crate::cast::{CastConfig, Precision};
use crate::cell::{CellConfig, CostModel};
use crate::registry::Build;

/// The settings of one build, and of a cast on the Cell if there was one.
pub struct Settings<'a> {
    pub build: &'a Build,
    /// The cast on the Cell's SPEs (`--on-cell`, `frame`).
    pub cast: Option<CastConfig>,
    /// The settings of a run of several builders (`compare`, the
    /// experiments): `build` holds what they share (tree, Cell, threads
    /// of those that build on the host's cores, rates); each row names
    /// its builder and knobs.
    pub several: bool,
    /// Where the camera stood (`--camera`), where rays were cast or
    /// measured from one.
    pub view: Option<crate::render::View>,
    /// The command's own inputs that change its figures, by option name
    /// (`update`'s `--animation`, `--seed`, `--frames`; `frame`'s
    /// `--policy`; `render`'s `--width`; …), in the order given.
    pub run: Vec<(&'static str, Value)>,
}

/// The emulated Cell's settings, as the command line names them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CellSettings {
    pub spes: usize,
    pub memory_mib: u64,
    /// checked, timed or functional.
    pub mode: &'static str,
    /// measured or legacy (none in the functional mode; "custom" for a
    /// cost model a caller made).
    pub model: Option<&'static str>,
    /// raw or ps3-kernel (none in the functional mode; "custom" as above).
    pub mailboxes: Option<&'static str>,
    /// The machine rates moved from the named model (`--rate`), as
    /// `--rate` spells them.
    pub moved: Vec<(&'static str, String)>,
}

impl CellSettings {
    /// The names of `cell`'s settings: its cost model is named by the
    /// model and mailbox path it equals.
    pub fn of(cell: &CellConfig) -> Self {
        let named = [
            ("measured", "raw", CostModel::ps3()),
            (
                "measured",
                "ps3-kernel",
                CostModel::ps3().with_ps3_kernel_mailboxes(),
            ),
            ("legacy", "raw", CostModel::ps3_legacy()),
            (
                "legacy",
                "ps3-kernel",
                CostModel::ps3_legacy().with_ps3_kernel_mailboxes(),
            ),
        ];
        let functional = cell.cost == CostModel::functional();
        // The named model this one is, or differs from by named rates
        // only (the fewest): a model a caller made otherwise is "custom".
        let nearest = (named.iter())
            .filter_map(|(model, mailboxes, base)| {
                let moved = cell.cost.moved_from(base);
                let mut back = cell.cost.clone();
                for (name, _) in &moved {
                    back.set_rate(name, &base.rate_text(name)?);
                }
                (back == *base).then_some((model, mailboxes, moved))
            })
            .min_by_key(|(.., moved)| moved.len());
        let (model, mailboxes, moved) = match nearest {
            _ if functional => (None, None, Vec::new()),
            Some((&model, &mailboxes, moved)) => (Some(model), Some(mailboxes), moved),
            None => (Some("custom"), Some("custom"), Vec::new()),
        };
        CellSettings {
            spes: cell.spes,
            memory_mib: cell.main_memory_bytes >> 20,
            mode: match (functional, cell.checked) {
                (true, _) => "functional",
                (false, true) => "checked",
                (false, false) => "timed",
            },
            model,
            mailboxes,
            moved,
        }
    }
}

/// [`version`] for the lifetime of the program (what `--version` prints).
pub fn version_static() -> &'static str {
    static V: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    V.get_or_init(version)
}

/// cellbih's version, and the commit it was built from when it was built
/// from a checkout, `-dirty` when the sources differed from it.
pub fn version() -> String {
    match option_env!("CELLBIH_COMMIT") {
        Some(c) if !c.is_empty() => format!("{} ({c})", env!("CARGO_PKG_VERSION")),
        _ => env!("CARGO_PKG_VERSION").to_string(),
    }
}

impl<'a> Settings<'a> {
    /// The settings of `build`, with `cast` the cast on the Cell if there
    /// was one.
    pub fn new(build: &'a Build, cast: Option<CastConfig>) -> Self {
        Settings {
            build,
            cast,
            several: false,
            view: None,
            run: Vec::new(),
        }
    }

    /// These settings with the command's own input `--name value`.
    pub fn with(mut self, name: &'static str, value: impl Into<Value>) -> Self {
        self.run.push((name, value.into()));
        self
    }

    /// These settings with the camera `view`.
    pub fn with_view(mut self, view: &crate::render::View) -> Self {
        self.view = Some(view.clone());
        self
    }

    /// The settings several builders share (`compare`, an experiment):
    /// the tree, the Cell, the host-thread builders' threads and the
    /// rates of `build`; its builder and knobs are not named.
    pub fn shared(build: &'a Build) -> Self {
        Settings {
            build,
            cast: None,
            several: true,
            view: None,
            run: Vec::new(),
        }
    }

    /// Every knob of the builder with its value, defaults included.
    fn knob_values(&self) -> Vec<(&'static str, String)> {
        (self.build.builder.knobs().iter())
            .map(|k| (k.name, self.build.knobs.text(k)))
            .collect()
    }

    /// The emulated Cell's settings, where something ran on it (an
    /// emulated builder, or a cast on the Cell).
    fn cell(&self) -> Option<CellSettings> {
        (self.several || self.build.builder.emulated() || self.cast.is_some())
            .then(|| CellSettings::of(&self.build.cell))
    }

    /// The host threads of the builder (for several: of the builders that
    /// build on the host's cores, where the request names them).
    fn threads(&self) -> Option<usize> {
        match self.several {
            true => Some(
                self.build
                    .threads
                    .unwrap_or_else(rayon::current_num_threads),
            ),
            false => self.build.threads_used(),
        }
    }

    /// The kernel rates moved from their PS3 values, by name.
    fn rates(&self) -> Vec<(&'static str, u64)> {
        (self.build.rates.names())
            .map(|n| (n, self.build.rates.get(n).map_or(0, |c| c.0)))
            .collect()
    }

    /// The settings as JSON: every field, defaults included.
    pub fn to_json(&self) -> Value {
        let t = &self.build.tree;
        let (split, bins, above) = match t.split {
            SplitChoice::GlobalHeuristic => ("gh", None, None),
            SplitChoice::BinnedSah { bins, above } => ("sah", Some(bins), Some(above)),
        };
        let knobs: serde_json::Map<String, Value> = (self.knob_values().into_iter())
            .map(|(k, v)| (k.to_string(), json!(v)))
            .collect();
        let (builder, knobs) = match self.several {
            true => (json!("each row's"), json!("each row's")),
            false => (json!(self.build.builder.name()), json!(knobs)),
        };
        json!({
            "builder": builder,
            "knobs": knobs,
            "tree": {
                "leaf_size": t.leaf_size, "max_depth": t.max_depth, "split": split,
                "sah_bins": bins, "sah_above": above, "empty_cut": t.empty_cut,
            },
            "cell": self.cell().map(|c| json!({
                "spes": c.spes, "memory_mib": c.memory_mib, "mode": c.mode,
                "model": c.model, "mailboxes": c.mailboxes,
                "code": self.build.rates.code().name(),
                "machine_rates": (!c.moved.is_empty()).then(|| {
                    c.moved.iter().map(|(n, v)| (n.to_string(), rate_json(v)))
                        .collect::<serde_json::Map<String, Value>>()
                }),
            })),
            "threads": self.threads(),
            "rates": self.build.rates.names().next().is_some().then(|| {
                self.rates().into_iter().map(|(n, v)| (n.to_string(), json!(v)))
                    .collect::<serde_json::Map<String, Value>>()
            }),
            "cast": self.cast.map(|c| json!({
                "cache_kib": c.cache.kib, "cache_ways": c.cache.ways,
                "fetch_lines": c.cache.fetch_lines, "tile_rays": c.tile_rays,
                "precision": match c.precision {
                    Precision::Single => "single",
                    Precision::Double => "double",
                },
                "rays_in_flight": c.rays_in_flight,
                "packet": c.packet.to_string(),
            })),
            "camera": self.view.as_ref().map(|v| v.spelled()),
            "run": (!self.run.is_empty()).then(|| {
                self.run.iter().map(|(n, v)| (n.to_string(), v.clone()))
                    .collect::<serde_json::Map<String, Value>>()
            }),
            "version": version(),
        })
    }

    /// The settings as one line of text: the knobs given (the JSON has every
    /// knob's value), the tree, the Cell and the cast as the command line
    /// spells them, and the version (without the commit, which the JSON
    /// names).
    pub fn line(&self) -> String {
        let b = self.build;
        let mut parts = vec![match self.several {
            true => "each builder with its default knobs".to_string(),
            false => format!("builder {}", b.builder),
        }];
        match b.knobs.spelled().as_str() {
            _ if self.several || b.builder.knobs().is_empty() => {}
            "" => parts.push("its default knobs".into()),
            given => parts.push(given.into()),
        }
        parts.push(match b.tree.flags().as_str() {
            "" => "the paper's tree (--leaf-size 12 --max-depth 64 --split gh)".into(),
            flags => format!("tree {flags}"),
        });
        if let Some(c) = self.cell() {
            let mut cell = vec![
                format!("--spes {}", c.spes),
                format!("--memory-mib {}", c.memory_mib),
                format!("--mode {}", c.mode),
            ];
            cell.extend(c.model.map(|m| format!("--model {m}")));
            cell.extend(c.mailboxes.map(|m| format!("--mailboxes {m}")));
            cell.push(format!("--code {}", b.rates.code()));
            cell.extend(c.moved.iter().map(|(n, v)| format!("--rate {n}={v}")));
            parts.push(cell.join(" "));
        }
        if let Some(n) = self.threads() {
            parts.push(format!("--threads {n}"));
        }
        let rates: Vec<String> = (self.rates().into_iter())
            .map(|(name, cycles)| format!("--rate {name}={cycles}"))
            .collect();
        if !rates.is_empty() {
            parts.push(rates.join(" "));
        }
        if let Some(c) = self.cast {
            parts.push(format!(
                "cast --cache-kib {} --cache-ways {} --fetch-lines {} --tile-rays {} \
                 --precision {} --rays-in-flight {} --packet {}",
                c.cache.kib,
                c.cache.ways,
                c.cache.fetch_lines,
                c.tile_rays,
                match c.precision {
                    Precision::Single => "single",
                    Precision::Double => "double",
                },
                c.rays_in_flight,
                c.packet
            ));
        }
        if let Some(v) = &self.view {
            parts.push(format!("--camera {}", v.spelled()));
        }
        if !self.run.is_empty() {
            let given: Vec<String> = (self.run.iter())
                .filter(|(_, v)| *v != Value::Bool(false))
                .map(|(n, v)| match v {
                    Value::Bool(true) => format!("--{n}"),
                    Value::String(s) => format!("--{n} {s}"),
                    v => format!("--{n} {v}"),
                })
                .collect();
            parts.push(given.join(" "));
        }
        // The version without its commit: a report's text stays the same
        // from commit to commit (the JSON's `version` names the commit).
        parts.push(format!("cellbih {}", env!("CARGO_PKG_VERSION")));
        parts.join("; ")
    }
}

/// A machine rate as `--rate` spells it, as JSON: a number (cycles or
/// GB/s), as the kernel rates are; `null` for an absent ceiling
/// (`unlimited`).
fn rate_json(text: &str) -> Value {
    match (text.parse::<u64>(), text.parse::<f64>()) {
        (Ok(c), _) => json!(c),
        (_, Ok(g)) => json!(g),
        _ => Value::Null,
    }
}
