//! The builders that run on the host's own cores: `host`, the serial
//! reference, which runs the shared recursion
//! ([`crate::kernels::recursion`]) on the scene's triangle boxes in one
//! thread, and the host counterparts of section 5's strategies (issue 29),
//! which build its tree on the threads of the current rayon pool:
//! [`shared`] (one job queue a level) and [`private`] (per-thread deques
//! with work stealing).

pub mod private;
pub mod shared;

use crate::bih::BihNode;

/// A job of at most this many items is built to its leaves by the thread
/// that takes it (the serial recursion: its items, 32 bytes each, stay in
/// that core's cache); a larger one makes one node and leaves its children
/// to the others. 16,384 items are 512 KiB.
pub const SUBTREE: usize = 16_384;

/// Puts the subtree `sub` (root 0) in node `id` of `nodes`, its other
/// nodes appended in their order.
fn graft(nodes: &mut Vec<BihNode>, id: usize, sub: &[BihNode]) {
    let off = nodes.len() - 1;
    let moved = |n: BihNode| match n.is_leaf() {
        true => n,
        false => {
            let [l, r] = n.clip();
            BihNode::inner(n.left_child() + off as u32, n.axis(), l, r)
        }
    };
    nodes[id] = moved(sub[0]);
    nodes.extend(sub[1..].iter().map(|&n| moved(n)));
}

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
