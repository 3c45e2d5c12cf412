//! Builders that run on the host, and the one place a builder is chosen by
//! name. Builders that run on the emulated Cell live in `strategy/` and are
//! listed here too, so that every `--builder` name works everywhere.

pub mod approx;
pub mod host;
pub mod kernels;

use std::time::{Duration, Instant};

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig};
use crate::cell::{CellConfig, CellError, RunReport};
use crate::scene::Scene;
use crate::strategy::{self, Strategy};

/// Every builder the `--builder` option accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuilderKind {
    /// Recursive in-place build on the host, one thread (the reference).
    Host,
    /// The paper's naive build on the emulated PPE.
    PpeNaive,
    /// W&K's approximate sorting on the emulated PPE, naive finish.
    PpeApprox,
    /// PPE recursion, one SPE partitions each interval (Fig. 1).
    SpeDfs,
    /// One SPE builds level by level (Fig. 2): the baseline.
    SpeBfs,
}

impl BuilderKind {
    pub const ALL: &'static [BuilderKind] = &[
        BuilderKind::Host,
        BuilderKind::PpeNaive,
        BuilderKind::PpeApprox,
        BuilderKind::SpeDfs,
        BuilderKind::SpeBfs,
    ];

    pub fn name(self) -> &'static str {
        match self {
            BuilderKind::Host => "host",
            BuilderKind::PpeNaive => "ppe_naive",
            BuilderKind::PpeApprox => "ppe_approx",
            BuilderKind::SpeDfs => "spe_dfs",
            BuilderKind::SpeBfs => "spe_bfs",
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            BuilderKind::Host => {
                "recursive in-place build, global heuristic, on the host (one thread)"
            }
            BuilderKind::PpeNaive => {
                "the paper's naive recursive build on the emulated PPE (Table 1, column 1)"
            }
            BuilderKind::PpeApprox => {
                "Wachter & Keller's approximate sorting (bucket presort) on the emulated PPE, nodes over 12 triangles finished naively (Table 1, column 2)"
            }
            BuilderKind::SpeDfs => {
                "depth first: PPE recursion, one SPE partitions each interval with Fig. 1's five buffers (Table 1, column 3)"
            }
            BuilderKind::SpeBfs => {
                "breadth first, the baseline: one SPE builds level by level (WorkA/WorkB, Fig. 2), small jobs agglomerated, nodes in an ObjectArena (Table 1, column 4)"
            }
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|b| b.name() == name)
    }

    /// Whether the builder runs on the emulated Cell (and so reports
    /// simulated time and can keep a trace).
    pub fn emulated(self) -> bool {
        self.strategy().is_some()
    }

    fn strategy(self) -> Option<Strategy> {
        match self {
            BuilderKind::Host => None,
            BuilderKind::PpeNaive => Some(Strategy::PpeNaive),
            BuilderKind::PpeApprox => Some(Strategy::PpeApprox),
            BuilderKind::SpeDfs => Some(Strategy::SpeDfs),
            BuilderKind::SpeBfs => Some(Strategy::SpeBfs),
        }
    }

    /// Builds the tree of `scene` (on the PS3 model for emulated builders).
    pub fn build(self, scene: &Scene, cfg: &BihConfig) -> Result<BuildReport, CellError> {
        self.build_on(scene, cfg, &CellConfig::ps3())
    }

    /// Builds the tree of `scene`; emulated builders run on a Cell
    /// configured by `cell`. Host time is measured either way.
    pub fn build_on(
        self,
        scene: &Scene,
        cfg: &BihConfig,
        cell: &CellConfig,
    ) -> Result<BuildReport, CellError> {
        self.build_in(scene, scene.bounds(), cfg, cell)
    }

    /// Builds the tree of `scene` with `region` (which must contain the
    /// scene) as the scene box of the global heuristic: what a local update
    /// does when it rebuilds one node's interval.
    pub fn build_in(
        self,
        scene: &Scene,
        region: Aabb,
        cfg: &BihConfig,
        cell: &CellConfig,
    ) -> Result<BuildReport, CellError> {
        let start = Instant::now();
        let (bih, simulated) = match self.strategy() {
            None => (host::build_in(scene, region, cfg), None),
            Some(s) => {
                let b = strategy::run_in(s, scene, region, cfg, cell)?;
                (
                    b.bih,
                    Some(Simulated {
                        run: b.run,
                        stats: b.stats,
                        trace: b.trace,
                    }),
                )
            }
        };
        Ok(BuildReport {
            builder: self,
            bih,
            host_time: start.elapsed(),
            simulated,
        })
    }
}

impl std::fmt::Display for BuilderKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What an emulated build cost on the Cell.
#[derive(Clone, Debug)]
pub struct Simulated {
    pub run: RunReport,
    pub stats: host::BuildStats,
    /// The timeline, if the Cell's config asked for it.
    pub trace: Option<crate::cell::Trace>,
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
}
