//! One build request: the builder, the tree it builds, the emulated Cell
//! it runs on, its strategy knobs and kernel rates, and the host threads
//! of a builder that builds on the host's cores — made once (from the
//! command line or by a caller), checked once, carried whole to every
//! command, test, bench and experiment, and named by every report
//! ([`crate::registry::Settings`]).

use std::time::Duration;

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig};
use crate::cell::{CellConfig, CellError};
use crate::kernels::rates::RateOverrides;
use crate::scene::Scene;
use crate::strategy::{Knobs, Simulated};

use super::BuilderKind;

/// A build request. [`Build::new`] gives the paper's settings on the PS3
/// model; the `with_…` methods change one part each. [`Build::run`] builds
/// a scene's tree, [`Build::run_in`] the tree of a region of one (a local
/// update's rebuild); both check the request first ([`Build::check`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Build {
    pub builder: BuilderKind,
    /// The tree's limits and quality knobs.
    pub tree: BihConfig,
    /// The emulated Cell an emulated builder runs on (and a cast on the
    /// Cell, where a command casts there); a host builder ignores it.
    pub cell: CellConfig,
    /// The strategy knobs given (a knob not given reads as its default).
    pub knobs: Knobs,
    /// Kernel rates moved from their PS3 values (the sensitivity report).
    pub rates: RateOverrides,
    /// Host threads of a builder that builds on the host's cores; `None`:
    /// the current rayon pool's.
    pub threads: Option<usize>,
}

impl Build {
    /// `builder` with the paper's tree, on the PS3 model, with its default
    /// knobs and the PS3's rates.
    pub fn new(builder: BuilderKind) -> Self {
        Build {
            builder,
            tree: BihConfig::default(),
            cell: CellConfig::ps3(),
            knobs: Knobs::default(),
            rates: RateOverrides::default(),
            threads: None,
        }
    }

    /// This request with the tree `tree`.
    pub fn with_tree(self, tree: BihConfig) -> Self {
        Build { tree, ..self }
    }

    /// This request on the emulated Cell `cell`.
    pub fn on(self, cell: &CellConfig) -> Self {
        Build {
            cell: cell.clone(),
            ..self
        }
    }

    /// This request with the strategy knobs `knobs`.
    pub fn with_knobs(self, knobs: &Knobs) -> Self {
        Build {
            knobs: knobs.clone(),
            ..self
        }
    }

    /// This request with kernel rates moved from their PS3 values.
    pub fn with_rates(self, rates: &RateOverrides) -> Self {
        Build {
            rates: *rates,
            ..self
        }
    }

    /// This request on `n` host threads (a builder that builds on the
    /// host's cores; the others refuse it).
    pub fn on_threads(self, n: usize) -> Self {
        Build {
            threads: Some(n),
            ..self
        }
    }

    /// The same request for `builder`: this tree, Cell and rates, and this
    /// request's host threads if `builder` builds on the host's cores,
    /// with its default knobs (`compare` and the experiments run every
    /// builder so).
    pub fn for_builder(&self, builder: BuilderKind) -> Build {
        Build {
            builder,
            knobs: Knobs::default(),
            threads: self.threads.filter(|_| builder.host_threads()),
            ..self.clone()
        }
    }

    /// Refuses what does not apply to the builder, naming it: a tree it
    /// does not build (and the builders that do), a strategy knob it does
    /// not take (and the builders that take it), host threads for a builder
    /// that builds on one.
    pub fn check(&self) -> Result<(), CellError> {
        self.builder.check_tree(&self.tree)?;
        for k in self.knobs.given() {
            self.builder.check_knob(k.name)?;
        }
        if self.threads.is_some() {
            self.builder.check_threads()?;
        }
        BuilderKind::check_rates(&self.rates)
    }

    /// Builds the tree of `scene`.
    pub fn run(&self, scene: &Scene) -> Result<BuildReport, CellError> {
        self.run_in(scene, scene.bounds())
    }

    /// Builds the tree of `scene` with `region` (which must contain the
    /// scene) as the scene box of the global heuristic: what a local update
    /// does when it rebuilds one node's interval.
    pub fn run_in(&self, scene: &Scene, region: Aabb) -> Result<BuildReport, CellError> {
        self.check()?;
        self.install(|| self.builder.run(scene, region, self))?
    }

    /// Runs `work` on the request's host threads (a pool of that many,
    /// unless the current pool has that many already), or on the current
    /// pool when it names none.
    pub fn install<T: Send>(&self, work: impl FnOnce() -> T + Send) -> Result<T, CellError> {
        match self.threads {
            Some(n) if n != rayon::current_num_threads() => Ok(rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| CellError::Config(format!("--threads {n}: {e}")))?
                .install(work)),
            _ => Ok(work()),
        }
    }

    /// The host threads a build of this request runs on, for a builder
    /// that builds on the host's cores.
    pub fn threads_used(&self) -> Option<usize> {
        (self.builder.host_threads())
            .then(|| self.threads.unwrap_or_else(rayon::current_num_threads))
    }

    /// "builder B", and where it builds: "on N SPEs" (emulated) or "on N
    /// host threads" (a builder on the host's cores).
    pub fn describe(&self) -> String {
        if self.builder.emulated() {
            let spes = crate::words::count(self.cell.spes as u64, "SPE");
            format!("builder {} on {spes}", self.builder)
        } else if let Some(n) = self.threads_used() {
            let threads = crate::words::count(n as u64, "host thread");
            format!("builder {} on {threads}", self.builder)
        } else {
            format!("builder {}", self.builder)
        }
    }
}

/// What a build produced and what it cost.
#[derive(Clone, Debug)]
pub struct BuildReport {
    pub builder: BuilderKind,
    pub bih: Bih,
    /// Host wall time of the build (of the emulation, for emulated builders).
    pub host_time: Duration,
    /// Simulated time and counters, for builders that run on the Cell.
    pub simulated: Option<Simulated>,
    /// The host threads it built on, for builders that build on the
    /// host's cores ([`BuilderKind::host_threads`]).
    pub threads: Option<usize>,
}

impl BuildReport {
    /// Where the build left the triangle records: a host build's tree is
    /// uploaded in leaf order.
    pub fn record_order(&self) -> crate::spe::layout::RecordOrder {
        self.simulated
            .as_ref()
            .map(|s| s.records)
            .unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::{Build, BuilderKind};
    use crate::bih::BihConfig;

    /// Every builder's request refuses, by name, what does not apply to
    /// it: a tree it does not build, a knob it does not take, threads for
    /// a builder that builds on one; and takes what does.
    #[test]
    fn a_request_refuses_what_does_not_apply_to_its_builder() {
        let s = crate::scene::load("rtperf:500:1", None).unwrap();
        let every_knob: Vec<_> = (BuilderKind::ALL.iter())
            .flat_map(|b| b.knobs().iter().copied())
            .collect();
        for &b in BuilderKind::ALL {
            let plain = Build::new(b);
            assert!(plain.check().is_ok(), "{b}");
            let sah = plain.clone().with_tree(BihConfig::SAH_CUT);
            let e = sah.check().err().map(|e| e.to_string());
            assert_eq!(e.is_none(), b.builds(&BihConfig::SAH_CUT), "{b}: {e:?}");
            for &k in &every_knob {
                let value = k.sweep[0];
                let knobs = crate::strategy::Knobs::default().with(k, value).unwrap();
                let e = plain.clone().with_knobs(&knobs).check().err();
                let takes = b.knobs().iter().any(|t| t.name == k.name);
                match e {
                    None => assert!(takes, "{b} took --{}", k.name),
                    Some(e) => {
                        assert!(!takes, "{b} refused its own --{}: {e}", k.name);
                        assert!(e.to_string().contains(&format!("--{}", k.name)), "{e}");
                    }
                }
            }
            let threads = plain.clone().on_threads(2);
            assert_eq!(threads.check().is_ok(), b.host_threads(), "{b}");
            // A refused request builds nothing.
            if !b.host_threads() {
                assert!(threads.run(&s).is_err(), "{b}");
            }
        }
    }

    /// A rate override naming no rate is refused, naming it, before any
    /// build; every rate of the registry's tables is taken.
    #[test]
    fn a_rate_that_names_no_rate_is_refused() {
        use crate::cell::Cycles;
        use crate::kernels::rates::{Code, RateOverrides};
        let s = crate::scene::load("rtperf:500:1", None).unwrap();
        let typo = RateOverrides::default().with("spe_jbo", Cycles(100));
        let b = Build::new(BuilderKind::SPE_BFS).with_rates(&typo);
        let e = b.check().unwrap_err().to_string();
        assert!(
            e.contains("no rate named spe_jbo (did you mean spe_job?)"),
            "{e}"
        );
        assert!(b.run(&s).is_err());
        for code in Code::ALL {
            let every = BuilderKind::every_rate(code);
            for r in &every {
                let o = RateOverrides::default()
                    .with_code(code)
                    .with(r.name, Cycles(100));
                assert!(
                    Build::new(BuilderKind::SPE_BFS)
                        .with_rates(&o)
                        .check()
                        .is_ok(),
                    "{}",
                    r.name
                );
            }
            for name in ["spe_morton.key_bit", "cast.node_step", "update.scan_slot"] {
                assert!(every.iter().any(|r| r.name == name), "{name}");
            }
        }
    }
}
