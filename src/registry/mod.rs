//! The registry of builders: the one place a builder is chosen by name,
//! above both families — the host builders ([`crate::host`]) and the
//! strategies that run on the emulated Cell ([`crate::strategy`]) — so that
//! every `--builder` name works in every command, test, bench and
//! experiment.

use std::time::Instant;

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig};
use crate::cast::{CastRates, Precision};
use crate::cell::CellError;
use crate::host::{HostBuild, HostBuilder};
use crate::kernels::ppe_rates::PpeRates;
use crate::kernels::rates::{Code, KernelRates, RateInfo, RateOverrides, Uncertain, infos};
use crate::scene::Scene;
use crate::spe::software_cache::CacheRates;
use crate::strategy::{self, Strategy};

mod build;
pub mod settings;

pub use crate::bih::Quality;
pub use crate::strategy::Simulated;
pub use build::{Build, BuildReport};
pub use settings::{CellSettings, Settings};

/// A handle on one of the registered builders; what `--builder` names.
/// Each is a value its own file defines: a [`HostBuilder`] or a
/// [`Strategy`] of the emulated Cell.
#[derive(Clone, Copy)]
pub struct BuilderKind(Family);

#[derive(Clone, Copy)]
enum Family {
    Host(&'static HostBuilder),
    Cell(&'static Strategy),
}

impl PartialEq for BuilderKind {
    fn eq(&self, o: &Self) -> bool {
        self.name() == o.name()
    }
}
impl Eq for BuilderKind {}

impl std::fmt::Debug for BuilderKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl BuilderKind {
    /// Recursive in-place build on the host, one thread (the reference).
    pub const HOST: BuilderKind = BuilderKind::host(&crate::host::BUILDER);
    /// The paper's naive build on the emulated PPE.
    pub const PPE_NAIVE: BuilderKind = BuilderKind::cell(&strategy::ppe_naive::STRATEGY);
    /// W&K's approximate sorting on the emulated PPE, naive finish.
    pub const PPE_APPROX: BuilderKind = BuilderKind::cell(&strategy::ppe_approx::STRATEGY);
    /// PPE recursion, one SPE partitions each interval (Fig. 1).
    pub const SPE_DFS: BuilderKind = BuilderKind::cell(&strategy::spe_dfs::STRATEGY);
    /// One SPE builds level by level (Fig. 2): the baseline.
    pub const SPE_BFS: BuilderKind = BuilderKind::cell(&strategy::spe_bfs::STRATEGY);

    /// Every builder, the registry: a new builder is one line here.
    pub const ALL: &'static [BuilderKind] = &[
        BuilderKind::HOST,
        BuilderKind::host(&crate::host::shared::BUILDER),
        BuilderKind::host(&crate::host::private::BUILDER),
        BuilderKind::host(&crate::host::morton::BUILDER),
        BuilderKind::PPE_NAIVE,
        BuilderKind::PPE_APPROX,
        BuilderKind::SPE_DFS,
        BuilderKind::SPE_BFS,
        BuilderKind::cell(&strategy::spe_bfs_shared::STRATEGY),
        BuilderKind::cell(&strategy::spe_bfs_private::STRATEGY),
        BuilderKind::cell(&strategy::spe_morton::STRATEGY),
    ];

    const fn host(b: &'static HostBuilder) -> Self {
        BuilderKind(Family::Host(b))
    }

    const fn cell(s: &'static Strategy) -> Self {
        BuilderKind(Family::Cell(s))
    }

    /// The longest name a builder may have: the tables of `compare`, the
    /// demo and the experiments give builder names this many columns of
    /// their 80 (a test holds every name of the registry to it).
    pub const MAX_NAME: usize = 16;

    pub fn name(self) -> &'static str {
        match self.0 {
            Family::Host(b) => b.name,
            Family::Cell(s) => s.name,
        }
    }

    /// Every builder with the paper's settings, then every builder that
    /// builds some of the quality knobs of `knobs` with those it builds:
    /// the runs the extremes, the `f32` tests and the peers' checks make.
    pub fn every_run(knobs: BihConfig) -> Vec<(BuilderKind, BihConfig)> {
        let paper = Self::ALL.iter().map(|&b| (b, BihConfig::default()));
        let quality = (Self::ALL.iter())
            .map(|&b| (b, b.quality().reach(&knobs)))
            .filter(|(_, cfg)| !cfg.paper_quality());
        paper.chain(quality).collect()
    }

    pub fn describe(self) -> &'static str {
        match self.0 {
            Family::Host(b) => b.describe,
            Family::Cell(s) => s.describe,
        }
    }

    /// The strategy knobs the builder takes.
    pub fn knobs(self) -> &'static [&'static strategy::Knob] {
        match self.0 {
            Family::Host(_) => &[],
            Family::Cell(s) => s.knobs,
        }
    }

    /// The knob `--name` of the builder's table, or an error naming the
    /// builders that take it.
    pub fn knob(self, name: &str) -> Result<&'static strategy::Knob, CellError> {
        self.check_knob(name)?;
        Ok(self.knobs().iter().find(|k| k.name == name).unwrap())
    }

    /// Sets the builder's knob `--name` to `value` as the command line
    /// gives it (empty for a flag): an error names a knob it does not take
    /// (and the builders that do), or a value out of the knob's range.
    pub fn set_knob(
        self,
        knobs: &mut strategy::Knobs,
        name: &str,
        value: &str,
    ) -> Result<(), CellError> {
        knobs
            .set(self.knob(name)?, value)
            .map_err(|e| CellError::Config(format!("builder {self}: {e}")))
    }

    /// The knob settings experiments try with this builder, each named by
    /// its options ([`strategy::Knobs::spelled`]): the defaults first,
    /// then each knob's sweep values alone, in table order, then the
    /// strategy's settings of several knobs at once ([`Self::combos`]).
    pub fn sweeps(self) -> Vec<strategy::Knobs> {
        let alone = (self.knobs().iter())
            .flat_map(|&k| k.sweep.iter().map(move |&v| self.knobs_of(&[(k, v)])));
        std::iter::once(strategy::Knobs::default())
            .chain(alone)
            .chain(self.combos())
            .collect()
    }

    /// The strategy's settings of several knobs at once (benches try these
    /// beside the defaults).
    pub fn combos(self) -> Vec<strategy::Knobs> {
        match self.0 {
            Family::Host(_) => Vec::new(),
            Family::Cell(s) => s.combos.iter().map(|c| self.knobs_of(c)).collect(),
        }
    }

    /// Knobs with these values, which the builder's tables declare.
    fn knobs_of(self, pairs: &[(&'static strategy::Knob, &str)]) -> strategy::Knobs {
        let mut k = strategy::Knobs::default();
        for &(knob, value) in pairs {
            (k.set(knob, value)).unwrap_or_else(|e| panic!("{self}'s table: {e}"));
        }
        k
    }

    /// Every kernel rate the builders may charge in the class `code`: the
    /// shared kernels' and each strategy's own, each once, with its band.
    pub fn rates(code: Code) -> Vec<RateInfo> {
        let mut v = infos(KernelRates::of(code), &KernelRates::table(code));
        for b in Self::ALL {
            if let Family::Cell(s) = b.0 {
                for r in (s.rates)(code) {
                    if !v.iter().any(|h| h.name == r.name) {
                        v.push(r);
                    }
                }
            }
        }
        v
    }

    /// Every kernel rate the builders may charge in the class `code` that
    /// no measurement pins, with its band (the sensitivity report moves
    /// each in turn).
    pub fn uncertain_rates(code: Code) -> Vec<Uncertain> {
        Self::rates(code)
            .iter()
            .filter_map(RateInfo::uncertain)
            .collect()
    }

    /// Every rate of the library a run may move by name in the class
    /// `code`: the builders' ([`Self::rates`]), the SPE caster's (in the
    /// default precision) and the PPE's share of an update.
    pub fn every_rate(code: Code) -> Vec<RateInfo> {
        let mut v = Self::rates(code);
        let single = Precision::Single;
        v.extend(infos(single.rates(code), &CastRates::table(single, code)));
        v.extend(infos(CacheRates::of(code), &CacheRates::table(code)));
        v.extend(infos(PpeRates::PS3, &PpeRates::table()));
        v
    }

    /// The rate of [`Self::every_rate`] named `name`; one that is no
    /// rate is refused by name, with the names a slip away.
    pub fn rate_named(name: &str, code: Code) -> Result<&'static str, CellError> {
        let rates = Self::every_rate(code);
        if let Some(r) = rates.iter().find(|r| r.name == name) {
            return Ok(r.name);
        }
        let near: Vec<&str> = (rates.iter().map(|r| r.name))
            .filter(|n| close(name, n))
            .collect();
        Err(CellError::Config(format!(
            "no rate named {name}{}; `cellbih rates` lists them all",
            match near.is_empty() {
                true => String::new(),
                false => format!(" (did you mean {}?)", near.join(", ")),
            }
        )))
    }

    /// Refuses rate overrides that name no rate of [`Self::every_rate`]
    /// (a misspelt name would otherwise move nothing, silently).
    pub fn check_rates(overrides: &RateOverrides) -> Result<(), CellError> {
        for name in overrides.names() {
            Self::rate_named(name, overrides.code())?;
        }
        Ok(())
    }

    /// Refuses a strategy knob (`--NAME`) the builder does not take,
    /// naming the builders that take it.
    pub fn check_knob(self, name: &str) -> Result<(), CellError> {
        if self.knobs().iter().any(|k| k.name == name) {
            return Ok(());
        }
        let takers: Vec<&str> = (Self::ALL.iter())
            .filter(|b| b.knobs().iter().any(|k| k.name == name))
            .map(|b| b.name())
            .collect();
        Err(CellError::Config(format!(
            "--{name} is a knob of {}; builder {self} does not take it",
            if takers.is_empty() {
                "no builder".to_string()
            } else {
                takers.join(", ")
            }
        )))
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|b| b.name() == name)
    }

    /// Whether the builder puts every SPE to work (`--spes` changes its
    /// time; the paper's builders use one).
    pub fn multi_spe(self) -> bool {
        matches!(self.0, Family::Cell(s) if s.multi_spe)
    }

    /// What the builder promises on large scenes, if anything.
    pub fn promise(self) -> Option<strategy::Promise> {
        match self.0 {
            Family::Host(_) => None,
            Family::Cell(s) => s.promise,
        }
    }

    /// The quality knobs the builder builds beyond the paper's tree.
    pub fn quality(self) -> Quality {
        match self.0 {
            Family::Host(b) => b.quality,
            Family::Cell(s) => s.quality,
        }
    }

    /// Whether the builder builds `cfg`'s split choice and cut-off.
    pub fn builds(self, cfg: &BihConfig) -> bool {
        self.quality().builds(cfg)
    }

    /// Whether the builder builds on the host's cores, on the threads of
    /// the current rayon pool (`ThreadPool::install` gives it the caller's):
    /// the host counterparts of section 5's strategies.
    pub fn host_threads(self) -> bool {
        matches!(self.0, Family::Host(b) if matches!(b.how, HostBuild::Parallel(_)))
    }

    /// A host-thread builder's tree of `scene`, a job of at most `grain`
    /// items finished by one thread alone (the builders use
    /// [`crate::host::SUBTREE`]; tests make it small so that the parallel
    /// part runs on small scenes). `None` for every other builder.
    pub fn build_grained(self, scene: &Scene, cfg: &BihConfig, grain: usize) -> Option<Bih> {
        match self.0 {
            Family::Host(HostBuilder {
                how: HostBuild::Parallel(g),
                ..
            }) if self.builds(cfg) => {
                let items = &mut crate::host::prim_refs(scene);
                Some(crate::host::on_threads(*g, items, scene.bounds(), cfg, grain).0)
            }
            _ => None,
        }
    }

    /// Bytes of main memory the builder needs at least for `n` triangles
    /// with `cfg` on `spes` SPEs, known before any work: the records, its
    /// buffers ([`Strategy::buffers`]) and the fewest nodes a tree of
    /// leaves of `cfg.leaf_size` can have (`2⌈n / leaf⌉ − 1`). 0 for a
    /// builder on the host.
    pub fn least_memory(self, n: usize, cfg: &BihConfig, spes: usize) -> u64 {
        let Family::Cell(s) = self.0 else {
            return 0;
        };
        let records = (n * size_of::<crate::spe::layout::TriRecord>()) as u64;
        let nodes = (2 * n.div_ceil(cfg.leaf_size.max(1) as usize)).saturating_sub(1);
        let nodes = (nodes * size_of::<crate::bih::BihNode>()) as u64;
        records + (s.buffers)(n, cfg, spes) + nodes
    }

    /// Whether the builder's work runs on the emulated SPEs (an emulated
    /// builder that builds on the PPE alone does not).
    pub fn on_spes(self) -> bool {
        matches!(self.0, Family::Cell(s) if !s.ppe_only)
    }

    /// Whether the builder runs on the emulated Cell (and so reports
    /// simulated time and can keep a trace).
    pub fn emulated(self) -> bool {
        matches!(self.0, Family::Cell(_))
    }

    /// What spawns the builder's programs on a Cell, for a builder that
    /// runs on the emulated Cell ([`strategy::launch`]).
    pub fn spawn(self) -> Option<strategy::Spawn> {
        match self.0 {
            Family::Cell(s) => Some(s.spawn),
            Family::Host(_) => None,
        }
    }

    /// Refuses a tree `cfg` the builder does not build, naming the
    /// builders that do.
    pub fn check_tree(self, cfg: &BihConfig) -> Result<(), CellError> {
        if self.builds(cfg) {
            return Ok(());
        }
        let with: Vec<&str> = (Self::ALL.iter())
            .filter(|b| b.builds(cfg))
            .map(|b| b.name())
            .collect();
        let builds = match (self.quality().binned_sah, self.quality().empty_cut) {
            (false, false) => {
                "the paper's split choice (global heuristic) without empty-space cut-off"
            }
            (false, true) => "the global heuristic's split choice (with or without the cut-off)",
            _ => "no empty-space cut-off",
        };
        Err(CellError::Config(format!(
            "builder {self} builds {builds} only; {} build these settings",
            with.join(", ")
        )))
    }

    /// Refuses host threads for a builder that builds on one thread,
    /// naming the builders that take them.
    pub fn check_threads(self) -> Result<(), CellError> {
        if self.host_threads() {
            return Ok(());
        }
        let with: Vec<&str> = (Self::ALL.iter())
            .filter(|b| b.host_threads())
            .map(|b| b.name())
            .collect();
        Err(CellError::Config(format!(
            "--threads: builder {self} builds on one thread; the builders that take it: {}",
            with.join(", ")
        )))
    }

    /// Runs a build of `scene` (or of `region`, a box that contains it, as
    /// the scene box): the [`Build`] runs this.
    fn run(self, scene: &Scene, region: Aabb, b: &Build) -> Result<BuildReport, CellError> {
        let start = Instant::now();
        let (bih, simulated) = match self.0 {
            Family::Host(h) => (h.build(scene, region, &b.tree), None),
            Family::Cell(s) => {
                let (bih, simulated) =
                    strategy::run_in(s.spawn, scene, region, &b.tree, &b.cell, &b.knobs, &b.rates)?;
                (bih, Some(simulated))
            }
        };
        Ok(BuildReport {
            builder: self,
            bih,
            host_time: start.elapsed(),
            simulated,
            threads: self.host_threads().then(rayon::current_num_threads),
        })
    }
}

impl std::fmt::Display for BuilderKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Whether two names are a slip apart: one letter changed, added, dropped
/// or two swapped.
fn close(a: &str, b: &str) -> bool {
    strsim::damerau_levenshtein(a, b) <= 1
}

#[cfg(test)]
mod tests {
    use super::BuilderKind;

    /// Every builder that puts every SPE to work promises a speedup on
    /// large scenes (the zoo's goals), a family one promise, of its
    /// builders adjacent in the registry; no other builder promises.
    #[test]
    fn multi_spe_builders_promise_and_a_family_promises_once() {
        let promising: Vec<_> = (BuilderKind::ALL.iter())
            .filter_map(|b| b.promise().map(|p| (*b, p)))
            .collect();
        for b in BuilderKind::ALL {
            assert_eq!(b.multi_spe(), b.promise().is_some(), "{b}");
        }
        for (i, (b, p)) in promising.iter().enumerate() {
            let same = |q: &&(BuilderKind, crate::strategy::Promise)| q.1.family == p.family;
            let family: Vec<_> = promising.iter().filter(same).collect();
            assert!(family.iter().all(|q| q.1 == *p), "{b}: {family:?}");
            let first = promising.iter().position(|q| same(&q)).unwrap();
            assert_eq!(i - first, family.iter().position(|q| q.0 == *b).unwrap());
            assert!(p.speedup > 1.0 && p.triangles > 0, "{b}: {p:?}");
        }
    }

    /// Every builder's name is a word of at most `MAX_NAME` characters, and
    /// no two builders share one.
    #[test]
    fn names_are_short_distinct_words() {
        for b in BuilderKind::ALL {
            let name = b.name();
            assert!(
                name.len() <= BuilderKind::MAX_NAME,
                "builder name '{name}' is {} characters: at most {} keep the \
                 80-column tables whole",
                name.len(),
                BuilderKind::MAX_NAME
            );
            assert!(
                !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            );
            let same = BuilderKind::ALL.iter().filter(|o| o.name() == name).count();
            assert_eq!(same, 1, "two builders named {name}");
        }
    }
}
