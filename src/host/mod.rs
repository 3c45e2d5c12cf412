//! The builders that run on the host's own cores: `host`, the serial
//! reference, which runs the shared recursion
//! ([`crate::kernels::recursion`]) on the scene's triangle boxes in one
//! thread, and the host counterparts of section 5's strategies (issue 29),
//! which build its tree on the threads of the current rayon pool:
//! [`shared`] (one job queue a level).

pub mod shared;

use crate::aabb::Aabb;
use crate::bih::{Bih, BihConfig, Quality};
use crate::kernels::recursion::{PrimRef, build_items};
use crate::scene::Scene;

/// A builder that runs on the host: what the registry needs of it.
pub struct HostBuilder {
    /// The `--builder` name.
    pub name: &'static str,
    /// One line for `cellbih builders`.
    pub describe: &'static str,
    /// The quality knobs of [`BihConfig`] it builds.
    pub quality: Quality,
    /// `build(scene, region, cfg)`: the tree of `scene` with `region` as
    /// the scene box of the global heuristic.
    pub build: fn(&Scene, Aabb, &BihConfig) -> Bih,
    /// It builds on the threads of the current rayon pool (the caller's,
    /// with `ThreadPool::install`), the serial builder's tree on any number.
    pub threads: bool,
}

/// The host builder, the serial reference.
pub const BUILDER: HostBuilder = HostBuilder {
    name: "host",
    describe: "recursive in-place build, global heuristic, on the host (one thread)",
    quality: Quality::ALL,
    build: build_in,
    threads: false,
};

/// Builds the tree of `scene` in one host thread.
pub fn build(scene: &Scene, cfg: &BihConfig) -> Bih {
    build_in(scene, scene.bounds(), cfg)
}

/// [`build`] with `region` as the scene box of the global heuristic.
pub fn build_in(scene: &Scene, region: Aabb, cfg: &BihConfig) -> Bih {
    let mut refs: Vec<PrimRef> = (scene.triangles.iter().enumerate())
        .map(|(i, t)| PrimRef::new(i as u32, t.bounds()))
        .collect();
    let (bih, _) = build_items(&mut refs, region, cfg);
    bih
}
