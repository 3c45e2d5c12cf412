//! What made a report: the settings a build (and a cast) ran with, named
//! in every report — a line of text and a JSON `settings` object — so that
//! two results from different settings are never mistaken for each other.

use serde_json::{Value, json};

use crate::bih::{BihConfig, SplitChoice};
use crate::cast::{CastConfig, Precision};
use crate::registry::BuilderKind;
use crate::strategy::Knobs;

/// The settings of one build, and of a cast on the Cell if there was one.
pub struct Settings<'a> {
    pub builder: BuilderKind,
    pub knobs: &'a Knobs,
    pub tree: &'a BihConfig,
    /// The emulated Cell, where something ran on it.
    pub cell: Option<CellSettings>,
    /// Host threads of a builder that builds on the host's cores.
    pub threads: Option<usize>,
    /// The cast on the Cell's SPEs (`--on-cell`, `frame`).
    pub cast: Option<CastConfig>,
}

/// The emulated Cell's settings, as the command line names them.
#[derive(Clone, Copy)]
pub struct CellSettings {
    pub spes: usize,
    pub memory_mib: u64,
    /// checked, timed or functional.
    pub mode: &'static str,
    /// measured or legacy (none in the functional mode).
    pub model: Option<&'static str>,
    /// raw or ps3-kernel (none in the functional mode).
    pub mailboxes: Option<&'static str>,
}

/// cellbih's version, and the commit it was built from when it was built
/// from a checkout.
pub fn version() -> String {
    match option_env!("CELLBIH_COMMIT") {
        Some(c) if !c.is_empty() => format!("{} ({c})", env!("CARGO_PKG_VERSION")),
        _ => env!("CARGO_PKG_VERSION").to_string(),
    }
}

impl Settings<'_> {
    /// Every knob of the builder with its value, defaults included.
    fn knob_values(&self) -> Vec<(&'static str, String)> {
        (self.builder.knobs().iter())
            .map(|k| (k.name, self.knobs.text(k)))
            .collect()
    }

    /// The settings as JSON: every field, defaults included.
    pub fn to_json(&self) -> Value {
        let t = self.tree;
        let (split, bins, above) = match t.split {
            SplitChoice::GlobalHeuristic => ("gh", None, None),
            SplitChoice::BinnedSah { bins, above } => ("sah", Some(bins), Some(above)),
        };
        let knobs: serde_json::Map<String, Value> = (self.knob_values().into_iter())
            .map(|(k, v)| (k.to_string(), json!(v)))
            .collect();
        json!({
            "builder": self.builder.name(),
            "knobs": knobs,
            "tree": {
                "leaf_size": t.leaf_size, "max_depth": t.max_depth, "split": split,
                "sah_bins": bins, "sah_above": above, "empty_cut": t.empty_cut,
            },
            "cell": self.cell.map(|c| json!({
                "spes": c.spes, "memory_mib": c.memory_mib, "mode": c.mode,
                "model": c.model, "mailboxes": c.mailboxes,
            })),
            "threads": self.threads,
            "cast": self.cast.map(|c| json!({
                "cache_kib": c.cache.kib, "cache_ways": c.cache.ways,
                "fetch_lines": c.cache.fetch_lines, "tile_rays": c.tile_rays,
                "precision": match c.precision {
                    Precision::Single => "single",
                    Precision::Double => "double",
                },
                "rays_in_flight": c.rays_in_flight,
            })),
            "version": version(),
        })
    }

    /// The settings as one line of text: the knobs given (the JSON has every
    /// knob's value), the tree, the Cell and the cast as the command line
    /// spells them, and the version.
    pub fn line(&self) -> String {
        let mut parts = vec![format!("builder {}", self.builder)];
        match self.knobs.spelled().as_str() {
            _ if self.builder.knobs().is_empty() => {}
            "" => parts.push("its default knobs".into()),
            given => parts.push(given.into()),
        }
        parts.push(match self.tree.flags().as_str() {
            "" => "the paper's tree (--leaf-size 12 --max-depth 64 --split gh)".into(),
            flags => format!("tree {flags}"),
        });
        if let Some(c) = self.cell {
            let mut cell = vec![
                format!("--spes {}", c.spes),
                format!("--memory-mib {}", c.memory_mib),
                format!("--mode {}", c.mode),
            ];
            cell.extend(c.model.map(|m| format!("--model {m}")));
            cell.extend(c.mailboxes.map(|m| format!("--mailboxes {m}")));
            parts.push(cell.join(" "));
        }
        if let Some(n) = self.threads {
            parts.push(format!("--threads {n}"));
        }
        if let Some(c) = self.cast {
            parts.push(format!(
                "cast --cache-kib {} --cache-ways {} --fetch-lines {} --tile-rays {} \
                 --precision {} --rays-in-flight {}",
                c.cache.kib,
                c.cache.ways,
                c.cache.fetch_lines,
                c.tile_rays,
                match c.precision {
                    Precision::Single => "single",
                    Precision::Double => "double",
                },
                c.rays_in_flight
            ));
        }
        parts.push(format!("cellbih {}", version()));
        parts.join("; ")
    }
}
