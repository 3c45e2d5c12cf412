//! The frame loop on the Cell (DESIGN.md "The whole frame on the Cell"):
//! per frame, the animation moves objects, the tree is brought
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
//! The policy is fixed (`rebuild`, `local`, `deep`) or section 5's metric
//! ([`auto`]: each frame's options priced with the work each would do and
//! the tree each would leave, the least taken); an oracle can run every
//! option from the same state each frame to judge it.
//!
//! What is charged: the rebuilds (and a local or deep update's rebuild of
//! its interval) as their builder's programs run them on the emulated Cell;
//! the PPE's share of the update ([`crate::update::ppe`]: Algorithm 1, the
//! scan, the deep descent, the graft; with `auto`, its plan in place of
//! the update's own search); in section 5's arrangement the SPEs' two
//! program switches a frame, in the paper's the copy of what the last
//! update changed into the tree's second copy ([`charge`]). In the paper's
//! arrangement the update and the render run side by side on one Cell
//! ([`one_cell`]), contending as on the hardware; each alone, and the bound
//! on their sharing of the memory interface ([`charge::sharing_bound_ms`]),
//! are kept as a check.

mod attempt;
pub mod auto;
pub mod charge;
pub mod one_cell;

pub use attempt::Alone;
use attempt::{Attempt, Times, attempt, times};
use charge::{Bill, Charged};

use crate::cast::{CastConfig, cast_camera};
use crate::cell::CellConfig;
use crate::registry::{Build, BuilderKind};
use crate::render::View;
use crate::scene::Scene;
use crate::update::{Animation, FindMoved, Method, Move, Plan, UpdateError, Updater};

/// How the tree follows the moves each frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Policy {
    /// The same method every frame.
    Fixed(Method),
    /// Section 5's metric chooses each frame ([`auto`]).
    Auto,
}

impl Policy {
    pub fn name(self) -> &'static str {
        match self {
            Policy::Fixed(m) => m.name(),
            Policy::Auto => "auto",
        }
    }

    /// `rebuild`, `local`, `deep` or `auto`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "auto" => Some(Policy::Auto),
            _ => Method::from_name(name).map(Policy::Fixed),
        }
    }
}

/// How the frames are made.
#[derive(Clone, Debug)]
pub struct FrameConfig {
    /// The build request of every build of the frame loop; its Cell
    /// (SPEs in all, the model) is the frame's.
    pub build: Build,
    /// How the tree follows the moves each frame.
    pub policy: Policy,
    /// Also run every option from the same state each frame (three times
    /// the work), to judge the policy's choices.
    pub oracle: bool,
    /// SPEs that update the tree; the others render meanwhile (the
    /// paper's arrangement) unless it is all of them (section 5's).
    pub build_spes: usize,
    pub width: u32,
    pub height: u32,
    /// Where the camera stands (it stays as the scene starts).
    pub view: View,
    pub cast: CastConfig,
    /// Where a local update finds the moved triangles of its interval.
    pub find_moved: FindMoved,
}

impl FrameConfig {
    /// SPEs of the Cell in all.
    pub fn spes(&self) -> usize {
        self.build.cell.spes
    }

    /// Section 5's arrangement: every SPE builds, then every SPE renders.
    pub fn all_spes_build(&self) -> bool {
        self.build_spes == self.spes()
    }

    /// A frame's time from its update's and its render's, as the
    /// arrangement combines them.
    pub fn frame_ms(&self, update_ms: f64, render_ms: f64) -> f64 {
        if self.all_spes_build() {
            update_ms + render_ms
        } else {
            update_ms.max(render_ms)
        }
    }

    /// The SPEs that render.
    pub fn render_spes(&self) -> usize {
        if self.all_spes_build() {
            self.spes()
        } else {
            self.spes() - self.build_spes
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
    /// Of `update_ms`: the PPE's share (with `auto`, its plan and the
    /// graft) and, in the paper's arrangement, the copy into the tree's
    /// second copy; of `update_ms` and `render_ms` together: the SPEs'
    /// program switches (section 5's arrangement).
    pub ppe_ms: f64,
    pub copy_ms: f64,
    pub switch_ms: f64,
    /// The paper's arrangement: the most that sharing the memory interface
    /// could add to the frame alone ([`charge::sharing_bound_ms`]), a check
    /// on the simulation of the two sides on one Cell ([`one_cell`]).
    pub sharing_bound_ms: Option<f64>,
    /// The paper's arrangement: the update and the render each run alone
    /// (on a Cell of their own), as the bound starts from.
    pub alone: Option<Alone>,
    /// The frame with the PPE's search overlapped: made while the frame
    /// before it still ran after its graft (section 5's arrangement: its
    /// render; the paper's: the render's time beyond the update), as an
    /// engine that knows a frame's moves at its start can. The policy
    /// chose by `frame_ms`, the serial frame.
    pub overlap_frame_ms: f64,
    /// Nodes + triangles per ray of the frame's cast.
    pub ray_cost: f64,
    pub cache_hit_rate: f64,
    /// `auto`: the chosen option's predicted update and render ms.
    pub predicted: Option<auto::Prediction>,
    /// With the oracle: the frame ms of rebuild, local and deep, each run
    /// from the frame's starting state (with `auto`, each paying its plan,
    /// as the frame would have had it taken that option).
    pub oracle_ms: Option<[f64; 3]>,
}

impl FrameReport {
    /// What the frame did: its choice, or `rebuild` where the choice's
    /// update found the scene box changed and rebuilt completely.
    pub fn what_ran(&self) -> &'static str {
        match self.full_rebuild {
            true => "rebuild",
            false => self.choice,
        }
    }

    /// With the oracle: this frame's time within `slack` (0.1: 10 %) of the
    /// best option's.
    pub fn near_best(&self, slack: f64) -> Option<bool> {
        let best = self.oracle_ms?.into_iter().fold(f64::INFINITY, f64::min);
        Some(self.frame_ms <= best * (1.0 + slack))
    }
}

/// The frames of a run, and what they add up to.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameRun {
    pub frames: Vec<FrameReport>,
    pub total_ms: f64,
    /// Frames per second of simulated time.
    pub fps: f64,
    /// With the oracle: the share of frames within 10 % of the best
    /// option, and the total had every frame taken its best option.
    pub near_best: Option<f64>,
    pub oracle_total_ms: Option<f64>,
    /// The paper's arrangement: bytes of the tree's second copy (the
    /// largest tree of the run), and the most that sharing the memory
    /// interface could add to `total_ms`.
    pub second_copy_bytes: Option<u64>,
    pub sharing_bound_ms: Option<f64>,
    /// The frames with the PPE's search overlapped
    /// ([`FrameReport::overlap_frame_ms`]): their total and frames per
    /// second.
    pub overlap_total_ms: f64,
    pub overlap_fps: f64,
    /// How the update and the render of a frame share the machine:
    /// `simulated` (the paper's arrangement, side by side on one Cell) or
    /// `none` (section 5's: one after the other).
    pub contention: &'static str,
    /// The paper's arrangement: the frames' total with the update and the
    /// render each run alone ([`FrameReport::alone`]).
    pub alone_total_ms: Option<f64>,
    /// With the frame's Cell's `trace` on, the paper's arrangement: each
    /// frame's one-Cell run, placed at the frame's start.
    #[serde(skip)]
    pub trace: Option<crate::cell::Trace>,
}

impl FrameRun {
    fn of(frames: Vec<FrameReport>, second_copy_bytes: Option<u64>) -> FrameRun {
        let total_ms: f64 = frames.iter().map(|f| f.frame_ms).sum();
        let overlap_total_ms: f64 = frames.iter().map(|f| f.overlap_frame_ms).sum();
        let per_second = |ms: f64| match ms > 0.0 {
            true => frames.len() as f64 / (ms / 1e3),
            false => 0.0,
        };
        let (fps, overlap_fps) = (per_second(total_ms), per_second(overlap_total_ms));
        let near: Option<Vec<bool>> = frames.iter().map(|f| f.near_best(0.1)).collect();
        let best: Option<f64> = (frames.iter())
            .map(|f| Some(f.oracle_ms?.into_iter().fold(f64::INFINITY, f64::min)))
            .sum();
        let sharing: Option<f64> = frames.iter().map(|f| f.sharing_bound_ms).sum();
        let alone: Option<f64> = (frames.iter())
            .map(|f| f.alone.as_ref().map(|a| a.frame_ms))
            .sum();
        let alone_total_ms = alone.filter(|_| !frames.is_empty());
        FrameRun {
            contention: match alone_total_ms {
                Some(_) => "simulated",
                None => "none",
            },
            alone_total_ms,
            second_copy_bytes,
            sharing_bound_ms: sharing.filter(|_| !frames.is_empty()),
            overlap_total_ms,
            overlap_fps,
            near_best: near
                .filter(|v| !v.is_empty())
                .map(|v| v.iter().filter(|&&b| b).count() as f64 / v.len() as f64),
            oracle_total_ms: best,
            frames,
            total_ms,
            fps,
            trace: None,
        }
    }
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
/// every frame updated by the policy and cast on the SPEs, all on the
/// config's Cell; `done` hears of each frame as it ends (a progress bar).
pub fn play(
    scene: &Scene,
    anim: &Animation,
    cfg: &FrameConfig,
    mut done: impl FnMut(&FrameReport),
) -> Result<FrameRun, FrameError> {
    // The cast is charged in the build's code class, with its rates.
    let cfg = &FrameConfig {
        cast: cfg.cast.with_rates(&cfg.build.rates),
        ..cfg.clone()
    };
    if !cfg.build.builder.emulated() {
        return Err(FrameError::Config(format!(
            "builder {} runs on the host: a frame on the Cell needs an emulated builder ({})",
            cfg.build.builder,
            emulated_names()
        )));
    }
    if cfg.build_spes == 0 || cfg.build_spes > cfg.spes() {
        return Err(FrameError::Config(format!(
            "--build-spes {}: 1 to --spes ({})",
            cfg.build_spes,
            cfg.spes()
        )));
    }
    let cell = &cfg.build.cell;
    // Only the one-Cell runs are traced (`cell.trace`).
    let untraced = CellConfig {
        trace: false,
        ..cell.clone()
    };
    let build = cfg
        .build
        .clone()
        .on(&untraced.clone().with_spes(cfg.build_spes));
    // The loop's SPE programs are started once, with its first build, and
    // stay resident: no frame pays their start (`CostModel::spe_start_cycles`),
    // as a renderer keeps its programs running between frames.
    let render_cell = CellConfig {
        resident: true,
        ..untraced.with_spes(cfg.render_spes())
    };
    let mut timeline = one_cell::Timeline::of(cfg);
    // The camera frames the scene as it starts, and stays.
    let cam = (cfg.view)
        .camera(&scene.name, &scene.bounds(), cfg.width, cfg.height)
        .map_err(FrameError::Config)?;
    let mut u = Updater::new(scene.clone(), build, Method::Rebuild)?;
    u.build.cell.resident = true;
    u.find_moved = cfg.find_moved;
    // Section 5's arrangement: one switch before the update, one before
    // the cast. The paper's: two copies of the tree, and the first in-place
    // update first copies the whole first tree.
    let switch_ms = match cfg.all_spes_build() {
        true => charge::program_switch_ms(cell),
        false => 0.0,
    };
    let whole_tree = |u: &Updater| charge::tree_bytes(u.bih.nodes.len(), u.scene.len(), u.records);
    let mut changed = whole_tree(&u);
    let mut second_copy = (!cfg.all_spes_build()).then_some(changed);
    let mut predictor = auto::Predictor::new(scene.len(), u.first_build_ms);
    let mut routing = Routing(None);
    if cfg.policy == Policy::Auto {
        // Before the first frame, as a running renderer has them: the
        // first tree's render, and builds of a few sizes as an update's
        // pieces are built, so that the first prediction has both
        // (neither is counted in the frames).
        let before = cast_camera(&u.bih, &u.scene, &cam, &cfg.cast, &render_cell, u.records)?;
        predictor.seed_render(before.run.ms + switch_ms);
        // What the tree a local update leaves renders: the first frame's
        // moving objects updated in place, unmoved (a renderer knows its
        // dynamic objects at load).
        if let Some(first) = anim.frames.first().filter(|f| !f.is_empty()) {
            let mut probe = u.clone();
            probe.method = Method::Local;
            let marked: Vec<Move> = first.iter().map(|m| Move::marked(m.geometry)).collect();
            let r = probe.step(&marked)?;
            if !r.full_rebuild && r.rebuilt > 0 {
                let (b, sc) = (&probe.bih, &probe.scene);
                let left = cast_camera(b, sc, &cam, &cfg.cast, &render_cell, probe.records)?;
                predictor.seed_local_render(left.run.ms + switch_ms);
            }
        }
        for n in auto::probe_sizes(scene.len()) {
            if let Some(ms) = u.probe_piece(n)? {
                predictor.seed_build(n, ms);
            }
        }
    }
    let mut frames = Vec::with_capacity(anim.frames.len());
    // The time the PPE had after the last graft while the frame before
    // still ran: none before the first frame.
    let mut slack_ms = 0.0;
    for (i, moves) in anim.frames.iter().enumerate() {
        let bill = Bill {
            switch_ms,
            copy_ms: match cfg.all_spes_build() {
                true => 0.0,
                false => charge::copy_ms(changed, cell),
            },
        };
        let (taken, plan, predicted) = match cfg.policy {
            Policy::Fixed(m) => (m, None, None),
            Policy::Auto => {
                // Algorithm 1 first (local and rebuild priced); the scan
                // and the deep descent only if the deep update, its builds
                // estimated and cut by `DESCEND`, would be the best.
                let mut plan = u.plan_search(moves)?;
                let combine = |a, b| cfg.frame_ms(a, b);
                let options = |plan: &Plan| {
                    let r = routing.per_moved(plan, u.deep_stop_below);
                    let known =
                        |m| plan_find_ms(plan, m, cfg, r) + bill.update_ms(m, plan.full_rebuild);
                    predictor.predict(plan, u.scene.len(), known)
                };
                let first = options(&plan);
                let mut chosen = predictor.choose(&first, combine);
                let frame = |p: &auto::Prediction| combine(p.update_ms, p.render_ms);
                let deep = (first.iter())
                    .find(|(m, _)| *m == Method::Deep)
                    .expect("three")
                    .1;
                let hopeful = auto::Prediction {
                    update_ms: deep.update_ms - auto::DESCEND * predictor.deep_estimate(&plan),
                    ..deep
                };
                if !plan.deep_planned && frame(&hopeful) <= frame(&chosen.1) {
                    plan = u.plan(moves)?;
                    chosen = predictor.choose(&options(&plan), combine);
                }
                (chosen.0, Some(plan), Some(chosen.1))
            }
        };
        // The PPE's search charged to an option: the plan's, unless it
        // stopped before the deep update's descent (then the update's own).
        let find_ms = |m: Method| {
            (plan.as_ref())
                .filter(|p| p.deep_planned || p.full_rebuild || m != Method::Deep)
                .map(|p| plan_find_ms(p, m, cfg, 0.0))
        };
        // What this frame costs had it taken `m`: with `auto`, its plan's
        // search in place of the update's own.
        let try_out = |m: Method| -> Result<(Attempt, Charged, Times), FrameError> {
            let a = attempt(&u, m, moves, &cam, cfg, &render_cell)?;
            let c = bill.charge(&a.report, find_ms(m));
            let t = times(&a, &c, changed, &cam, cfg)?;
            Ok((a, c, t))
        };
        let mut tried: Vec<(Method, (Attempt, Charged, Times))> = Vec::new();
        if cfg.oracle {
            for m in Method::ALL {
                tried.push((*m, try_out(*m)?));
            }
        }
        let oracle_ms = cfg.oracle.then(|| {
            let ms = |m: Method| {
                let t = &(tried.iter())
                    .find(|(t, _)| *t == m)
                    .expect("every option tried")
                    .1
                    .2;
                cfg.frame_ms(t.update_ms, t.render_ms)
            };
            [ms(Method::Rebuild), ms(Method::Local), ms(Method::Deep)]
        });
        let done_now = match tried.into_iter().find(|(m, _)| *m == taken) {
            Some((_, a)) => a,
            None => try_out(taken)?,
        };
        let (
            Attempt {
                updater,
                report: up,
                cast,
            },
            charged,
            Times {
                update_ms,
                render_ms,
                beside,
            },
        ) = done_now;
        u = updater;
        // The cast alone (section 5's arrangement: the only one), and
        // beside the update on one Cell (the paper's).
        let alone = beside.as_ref().map(|b| Alone {
            update_ms: charged.update_ms,
            render_ms: cast.run.ms,
            frame_ms: cfg.frame_ms(charged.update_ms, cast.run.ms),
            render_same_deal_ms: b.render_same_deal_ms,
        });
        let mut cast = beside.map_or(cast, |b| b.cast);
        timeline.add(cast.trace.take());
        if let Some(plan) = &plan {
            let known =
                plan_find_ms(plan, taken, cfg, 0.0) + bill.update_ms(taken, up.full_rebuild);
            routing.learn(plan);
            predictor.observe(
                taken,
                plan,
                (up.full_rebuild, u.scene.len()),
                update_ms - known,
                render_ms,
            );
        }
        let sharing_bound_ms = alone.as_ref().map(|a| {
            let copied = match charged.copy_ms > 0.0 {
                true => charge::COPY_CROSSINGS * changed,
                false => 0,
            };
            let cast_bytes = (cast.run.cores.iter())
                .map(|(_, c)| c.bytes_get + c.bytes_put)
                .sum();
            charge::sharing_bound_ms(
                (a.update_ms, up.dma_bytes + copied),
                (a.render_ms, cast_bytes),
                cell,
            )
        });
        // The PPE's search overlapped with the frame before's slack.
        let overlapped_update = update_ms - charged.find_ms.min(slack_ms);
        let overlap_frame_ms = cfg.frame_ms(overlapped_update, render_ms);
        slack_ms = overlap_frame_ms - overlapped_update;
        let whole = whole_tree(&u);
        let now_changed = charge::changed_bytes(&up, whole, u.records);
        changed = match charged.copy_ms > 0.0 || up.full_rebuild {
            true => now_changed,
            // Nothing was copied: the other copy still lacks both.
            false => changed + now_changed,
        };
        if let Some(b) = &mut second_copy {
            *b = (*b).max(whole);
        }
        let st = cast.stats();
        frames.push(FrameReport {
            frame: i,
            choice: taken.name(),
            full_rebuild: up.full_rebuild,
            rebuilt: up.rebuilt,
            update_ms,
            render_ms,
            frame_ms: cfg.frame_ms(update_ms, render_ms),
            ppe_ms: charged.ppe_ms,
            copy_ms: charged.copy_ms,
            switch_ms: 2.0 * charged.switch_ms,
            sharing_bound_ms,
            alone,
            overlap_frame_ms,
            ray_cost: (st.nodes_visited + st.triangles_tested) as f64 / st.rays.max(1) as f64,
            cache_hit_rate: cast.cache().hit_rate(),
            predicted,
            oracle_ms,
        });
        timeline.next_frame(cfg.frame_ms(update_ms, render_ms));
        done(frames.last().expect("pushed"));
    }
    Ok(FrameRun {
        trace: timeline.trace,
        ..FrameRun::of(frames, second_copy)
    })
}

/// The PPE's search of a frame that took `m` after `plan` (`auto`): what
/// the plan did, and the scan of the interval a local or deep update
/// still needs if the plan did not make it (a local update whose SPEs
/// find the moved triangles needs none).
/// The deep update's descent, where the plan did not make it, is
/// estimated at `routed` routings per moved triangle ([`Routing`]).
fn plan_find_ms(plan: &Plan, m: Method, cfg: &FrameConfig, routed: f64) -> f64 {
    let mut find = plan.find;
    let spes_find = m == Method::Local && cfg.find_moved == FindMoved::Spe;
    if !plan.deep_planned && !plan.full_rebuild && m != Method::Rebuild && !spes_find {
        find.scanned += plan.interval as u64;
        find.loads += plan.scan_loads;
        if m == Method::Deep {
            // Each routing's triangle taken as an L1 hit: the descent
            // reads the same moved triangles at every level.
            let n = (routed * plan.transformed as f64).round() as u64;
            find.routed += n;
            find.loads.l1 += n;
        }
    }
    find.ms(&cfg.build.cell.cost, &cfg.build.rates)
}

/// How many times the deep update's descent routes each moved triangle:
/// as the last whole plan counted, or, before one, once a level from the
/// enclosing node down to pieces of `deep_stop_below` triangles.
struct Routing(Option<f64>);

impl Routing {
    fn per_moved(&self, plan: &Plan, stop_below: usize) -> f64 {
        self.0
            .unwrap_or_else(|| (plan.interval as f64 / stop_below as f64).max(1.0).log2())
    }

    fn learn(&mut self, plan: &Plan) {
        if plan.deep_planned && !plan.full_rebuild && plan.transformed > 0 {
            self.0 = Some(plan.find.routed as f64 / plan.transformed as f64);
        }
    }
}

fn emulated_names() -> String {
    let v: Vec<&str> = (BuilderKind::ALL.iter())
        .filter(|b| b.emulated())
        .map(|b| b.name())
        .collect();
    v.join(", ")
}
