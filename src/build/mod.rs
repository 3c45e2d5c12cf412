//! Builders that run on the host, and the one place a builder is chosen by
//! name. Builders that run on the emulated Cell live in `strategy/` and are
//! listed here too, so that every `--builder` name works everywhere.

pub mod host;
pub mod kernels;

use std::time::{Duration, Instant};

use crate::bih::{Bih, BihConfig};
use crate::scene::Scene;

/// Every builder the `--builder` option accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuilderKind {
    /// Recursive in-place build on the host, one thread (the reference).
    Host,
}

impl BuilderKind {
    pub const ALL: &'static [BuilderKind] = &[BuilderKind::Host];

    pub fn name(self) -> &'static str {
        match self {
            BuilderKind::Host => "host",
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            BuilderKind::Host => {
                "recursive in-place build, global heuristic, on the host (one thread)"
            }
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|b| b.name() == name)
    }

    /// Builds the tree of `scene`, timing it on the host.
    pub fn build(self, scene: &Scene, cfg: &BihConfig) -> BuildReport {
        let start = Instant::now();
        let bih = match self {
            BuilderKind::Host => host::build(scene, cfg),
        };
        BuildReport {
            builder: self,
            bih,
            host_time: start.elapsed(),
        }
    }
}

impl std::fmt::Display for BuilderKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What a build produced and what it cost.
#[derive(Clone, Debug)]
pub struct BuildReport {
    pub builder: BuilderKind,
    pub bih: Bih,
    /// Host wall time of the build.
    pub host_time: Duration,
}
