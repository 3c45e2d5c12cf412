//! The frame loop on the Cell (DESIGN.md "The whole frame on the Cell";
//! issue 27): per frame, the animation moves objects, the tree is brought
//! up to date by a policy — rebuilt with a builder on the SPEs it has,
//! locally updated (section 3, Algorithm 1) or deeply updated (section 5)
//! — and the frame's primary rays are cast on the SPEs ([`crate::cast`]).
//! Update and render are both simulated PS3 time, so a frame's time is
//! their sum or, in the paper's arrangement, their overlap.
//!
//! Two arrangements of `spes` SPEs:
//!
//! - **section 5's** (`build_spes == spes`): every SPE builds, then every
//!   SPE renders: a frame takes update + render;
//! - **the paper's** (`build_spes < spes`, the paper used one): `build_spes`
//!   SPEs update the tree for frame n + 1 while the other SPEs render frame
//!   n: in steady state a frame takes the longer of the two (one frame of
//!   latency, not counted).
//!
//! What is charged: the rebuilds (and a local or deep update's rebuild of
//! its interval) as their builder's programs run them on the emulated Cell;
//! the PPE's own update work (Algorithm 1's few node visits, the scan by
//! geometry id, the graft) is not (no rate is sourced for it: see
//! `docs/update.md`), so an update's time is a lower bound by that much.

use crate::bih::BihConfig;
use crate::cast::{CastConfig, cast_on_cell};
use crate::cell::CellConfig;
use crate::registry::BuilderKind;
use crate::render::Camera;
use crate::scene::Scene;
use crate::update::{Animation, Method, UpdateError, Updater};

/// How the frames are made.
#[derive(Clone, Debug)]
pub struct FrameConfig {
    pub builder: BuilderKind,
    pub tree: BihConfig,
    /// How the tree follows the moves each frame.
    pub policy: Method,
    /// SPEs of the Cell in all.
    pub spes: usize,
    /// SPEs that update the tree; the others render meanwhile (the
    /// paper's arrangement) unless it is all of them (section 5's).
    pub build_spes: usize,
    pub width: u32,
    pub height: u32,
    pub cast: CastConfig,
}

impl FrameConfig {
    /// Section 5's arrangement: every SPE builds, then every SPE renders.
    pub fn all_spes_build(&self) -> bool {
        self.build_spes == self.spes
    }

    /// The SPEs that render.
    pub fn render_spes(&self) -> usize {
        if self.all_spes_build() {
            self.spes
        } else {
            self.spes - self.build_spes
        }
    }
}

/// What one frame did and cost, in simulated PS3 ms.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameReport {
    pub frame: usize,
    /// The policy's choice for this frame: `rebuild`, `local` or `deep`
    /// (a local or deep update that found the scene box changed rebuilt
    /// completely: `full_rebuild`).
    pub choice: &'static str,
    pub full_rebuild: bool,
    /// Triangles the frame's rebuilds sorted.
    pub rebuilt: usize,
    pub update_ms: f64,
    pub render_ms: f64,
    /// update + render (section 5's arrangement) or the longer of the two
    /// (the paper's).
    pub frame_ms: f64,
    /// Nodes + triangles per ray of the frame's cast.
    pub ray_cost: f64,
    pub cache_hit_rate: f64,
}

/// The frames of a run, and what they add up to.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameRun {
    pub frames: Vec<FrameReport>,
    pub total_ms: f64,
    /// Frames per second of simulated time.
    pub fps: f64,
}

/// Why a frame loop cannot run.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[error("{0}")]
    Config(String),
    #[error(transparent)]
    Update(#[from] UpdateError),
    #[error(transparent)]
    Cell(#[from] crate::cell::CellError),
}

/// Plays `anim` on `scene`: the first tree built with the builder, then
/// every frame updated by the policy and cast on the SPEs. `cell` is the
/// Cell's model (its SPE count is the config's); `done` hears of each
/// frame as it ends (a progress bar).
pub fn play(
    scene: &Scene,
    anim: &Animation,
    cfg: &FrameConfig,
    cell: &CellConfig,
    mut done: impl FnMut(&FrameReport),
) -> Result<FrameRun, FrameError> {
    if !cfg.builder.emulated() {
        return Err(FrameError::Config(format!(
            "builder {} runs on the host: a frame on the Cell needs an emulated builder ({})",
            cfg.builder,
            emulated_names()
        )));
    }
    if cfg.build_spes == 0 || cfg.build_spes > cfg.spes {
        return Err(FrameError::Config(format!(
            "--build-spes {}: 1 to --spes ({})",
            cfg.build_spes, cfg.spes
        )));
    }
    let build_cell = cell.clone().with_spes(cfg.build_spes);
    let render_cell = cell.clone().with_spes(cfg.render_spes());
    // The camera frames the scene as it starts, and stays.
    let cam = Camera::framing(&scene.bounds(), cfg.width, cfg.height);
    let rays = cam.rays();
    let mut u = Updater::new_on(
        scene.clone(),
        cfg.builder,
        &cfg.tree,
        build_cell,
        cfg.policy,
    )?;
    let mut frames = Vec::with_capacity(anim.frames.len());
    for (i, moves) in anim.frames.iter().enumerate() {
        let up = u.step(moves)?;
        let update_ms = up.simulated_ms.unwrap_or(0.0);
        let cast = cast_on_cell(&u.bih, &u.scene, &rays, &cfg.cast, &render_cell)?;
        let render_ms = cast.run.ms;
        let st = cast.stats();
        frames.push(FrameReport {
            frame: i,
            choice: cfg.policy.name(),
            full_rebuild: up.full_rebuild,
            rebuilt: up.rebuilt,
            update_ms,
            render_ms,
            frame_ms: if cfg.all_spes_build() {
                update_ms + render_ms
            } else {
                update_ms.max(render_ms)
            },
            ray_cost: (st.nodes_visited + st.triangles_tested) as f64 / st.rays.max(1) as f64,
            cache_hit_rate: cast.cache().hit_rate(),
        });
        done(frames.last().expect("pushed"));
    }
    let total_ms: f64 = frames.iter().map(|f| f.frame_ms).sum();
    let fps = if total_ms > 0.0 {
        frames.len() as f64 / (total_ms / 1e3)
    } else {
        0.0
    };
    Ok(FrameRun {
        frames,
        total_ms,
        fps,
    })
}

fn emulated_names() -> String {
    let v: Vec<&str> = (BuilderKind::ALL.iter())
        .filter(|b| b.emulated())
        .map(|b| b.name())
        .collect();
    v.join(", ")
}
