//! Section 5's metric: "a metric for estimation of needed time for
//! reorganization steps", so that each frame can choose between a
//! complete rebuild, the local update and the deep update before doing
//! any of them (`--policy auto`).
//!
//! Each option is priced with the work it would do and the tree it would
//! leave, in simulated milliseconds, from cheap counts and from what
//! earlier frames measured:
//!
//! - **update**: the subtrees each option would build — the whole scene
//!   for a rebuild; Algorithm 1's enclosing interval for the local update;
//!   the pieces the deep update's descent would rebuild — all counted on a
//!   copy of the tree before anything is built
//!   ([`Updater::plan`](crate::update::Updater::plan)), each priced by the
//!   cost of one build of its size. That cost is measured, not assumed to
//!   follow `n log n`: a build has fixed costs, and a builder runs a small
//!   build on fewer SPEs (`--tris-per-spe`), so a small update can cost
//!   several times a large build's per triangle. Before the first
//!   frame, small builds of 48, 96, 192, … triangles are timed
//!   ([`Updater::probe_piece`](crate::update::Updater::probe_piece)); with
//!   the first tree's build they make a curve of build time against size,
//!   read between its points on log scales. Each option's measured update
//!   over its price is then learned as it is taken (a correction per
//!   option and per octave of its largest piece: a few small pieces and
//!   one large piece miss the curve by different amounts), so a
//!   deep update of many small pieces is priced by its pieces, and what
//!   the curve misses is learned.
//! - **what is known before it runs**: the PPE's search (the plan's:
//!   Algorithm 1, and where it was made the scan of the interval and the
//!   deep descent; `crate::update::ppe`), a program switch, a copy into
//!   the tree's second copy (`super::charge`): added to the update as
//!   counted, not learned. The plan stops at Algorithm 1 unless the deep
//!   update could win ([`DESCEND`]): a descent made in vain costs its PPE
//!   time.
//! - **render**: the render the tree each option leaves would give: the
//!   last after a complete rebuild; an average of the last ones after the
//!   local update, which rebuilds the moved objects' whole interval fresh;
//!   for the deep update, which keeps the tree it is given, the render
//!   before it times an average of what a deep update changed a fresh
//!   tree's render by (a tree a deep update left keeps its render).
//!   Before the local update is first taken its render is the one its
//!   tree gave before the first frame (the moving objects' interval
//!   rebuilt on a copy, nothing moved: what it would leave); an option not
//!   yet seen whose predicted frame is within [`EXPLORE`] of the best is
//!   taken once, to learn what its tree renders.
//!
//! A frame's predicted time combines the two as the arrangement does (sum,
//! or the longer). An option is chosen by that frame plus the tree it
//! leaves priced for a few frames after it ([`HORIZON`]), kept by the
//! cheapest update at the render that update would leave of it (a tree a
//! slower update left stays slow until something rebuilds it, and a fresh
//! tree kept by deep updates loses a step — until a deep update has kept
//! one, it is priced no faster than the tree they keep now: one frame's
//! choice costs the frames after it); the least
//! wins, ties going to the lower sum, then to the deep update over the
//! local one (it never rebuilds more).

use std::collections::BTreeMap;

use crate::update::{Method, Plan};

/// One option's predicted times.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Prediction {
    pub update_ms: f64,
    pub render_ms: f64,
}

/// What the predictor has learned.
#[derive(Clone, Debug)]
pub struct Predictor {
    /// Builds timed (triangles, simulated ms), by size: the cost curve.
    curve: Vec<(usize, f64)>,
    /// Each option's measured update over its curve-priced one, as taken,
    /// by option and by the octave of its largest piece (an update of a
    /// few small pieces and one of a large piece miss the curve by
    /// different amounts).
    correction: BTreeMap<(usize, u32), f64>,
    render_fresh: Option<f64>,
    render_now: Option<f64>,
    /// The render after the local update, once taken.
    render_local: Option<f64>,
    /// The render after the deep update over the render before it (the
    /// deep update keeps the tree it is given, so its render follows the
    /// tree's), once taken on a fresh tree (the one a rebuild or a local
    /// update left): a deep update spoils a fresh tree once; on a tree a
    /// deep update left it keeps the render (what a run of deep updates
    /// shows: the render steps up after the first, then holds).
    render_deep: Option<f64>,
    /// Whether the tree now is one a deep update left.
    deep_tree: bool,
    /// Whether `render_now` was measured in a frame (not the first tree's
    /// render before the frames, of the scene before anything moved): the
    /// deep update's ratio is learned only against a frame's.
    now_in_frame: bool,
    /// The deep update's builds as last priced from a whole plan, and the
    /// interval they were planned in: its price in a frame whose plan
    /// stops at Algorithm 1, scaled by the interval.
    deep_last: Option<(f64, usize)>,
    /// Complete rebuilds the scene box forced, by the box they rebuilt
    /// for: what the update cost beyond what was known before it, and the
    /// render after it. A scene box seen before is rebuilt for what it
    /// cost then (a part that moves back and forth across the box gives
    /// builds of two shapes, alternately).
    forced: Vec<([u32; 6], f64, f64)>,
}

/// How much weight a new render measured after an update, or a new
/// correction, gets against what was learned.
const LEARN: f64 = 0.5;

/// The sizes of the builds timed before the first frame: 48 triangles (the
/// size below which the deep update stops descending), doubled, below the
/// scene's size. Doubling, because a builder's cost can step between
/// sizes (it takes more SPEs past a threshold).
pub fn probe_sizes(triangles: usize) -> impl Iterator<Item = usize> {
    std::iter::successors(Some(48usize), |n| n.checked_mul(2)).take_while(move |&n| n < triangles)
}

/// An update not taken yet is tried once when its predicted frame is
/// within this share of the best option's.
pub const EXPLORE: f64 = 0.1;

/// A frame's plan makes the scan and the deep update's descent (PPE
/// time, [`crate::update::ppe`]) only where the deep update would be the
/// best option with its builds, estimated without the descent
/// ([`Predictor::deep_estimate`]), cut by this share: the builds are the
/// uncertain part of the estimate (the scan is counted, the descent's
/// routing learned), and a descent made in vain costs its PPE time;
/// otherwise the plan stops at Algorithm 1, which prices the local update
/// and the rebuild.
pub const DESCEND: f64 = 0.35;

/// Frames after this one over which an option's tree is priced: a tree
/// the deep update then keeps renders at its own speed until something
/// rebuilds it.
pub const HORIZON: f64 = 3.0;

impl Predictor {
    /// A predictor that knows the first tree's build of `triangles` took
    /// `first_build_ms` (if it was timed).
    pub fn new(triangles: usize, first_build_ms: Option<f64>) -> Self {
        let mut p = Predictor {
            curve: Vec::new(),
            correction: BTreeMap::new(),
            render_fresh: None,
            render_now: None,
            render_local: None,
            render_deep: None,
            deep_tree: false,
            now_in_frame: false,
            deep_last: None,
            forced: Vec::new(),
        };
        if let Some(ms) = first_build_ms {
            p.seed_build(triangles, ms);
        }
        p
    }

    /// The render of the first tree, before any frame: what a fresh
    /// tree and an unchanged one cost to cast.
    pub fn seed_render(&mut self, render_ms: f64) {
        self.render_fresh = Some(render_ms);
        self.render_now = Some(render_ms);
    }

    /// The render of the tree a local update leaves, measured before the
    /// first frame on a copy: the moving objects' interval rebuilt, nothing
    /// moved (`play`). It prices the local update until it is taken.
    pub fn seed_local_render(&mut self, render_ms: f64) {
        self.render_local = Some(render_ms);
    }

    /// A build of one piece of `triangles`, timed before the first frame
    /// (`Updater::probe_piece`): a point of the cost curve.
    pub fn seed_build(&mut self, triangles: usize, ms: f64) {
        if triangles == 0 || ms.is_nan() || ms <= 0.0 {
            return;
        }
        let at = self.curve.partition_point(|&(n, _)| n < triangles);
        match self.curve.get(at) {
            Some(&(n, _)) if n == triangles => self.curve[at].1 = ms,
            _ => self.curve.insert(at, (triangles, ms)),
        }
    }

    /// The cost curve's ms for one build of `n` triangles: read between
    /// the two timed sizes around `n` on log scales; below the smallest,
    /// the smallest's (fixed costs dominate there); above the largest,
    /// along the last segment's slope. With one point, in proportion to
    /// `n`.
    fn piece_ms(&self, n: usize) -> f64 {
        let c = &self.curve;
        if n == 0 || c.is_empty() {
            return 0.0;
        }
        let at = c.partition_point(|&(m, _)| m < n);
        if at < c.len() && c[at].0 == n {
            return c[at].1;
        }
        if c.len() == 1 {
            return c[0].1 * n as f64 / c[0].0 as f64;
        }
        if at == 0 {
            return c[0].1;
        }
        let (a, b) = if at < c.len() {
            (c[at - 1], c[at])
        } else {
            (c[c.len() - 2], c[c.len() - 1])
        };
        let slope = (b.1 / a.1).ln() / (b.0 as f64 / a.0 as f64).ln();
        a.1 * (n as f64 / a.0 as f64).powf(slope)
    }

    /// The curve's ms for building `pieces` (triangles each).
    fn build_ms(&self, pieces: &[usize]) -> f64 {
        pieces.iter().map(|&n| self.piece_ms(n)).sum()
    }

    fn index(m: Method) -> usize {
        match m {
            Method::Rebuild => 0,
            Method::Local => 1,
            Method::Deep => 2,
        }
    }

    /// Where an update of `m` that builds `pieces` keeps its correction:
    /// by the octave of its largest piece.
    fn key(m: Method, pieces: &[usize]) -> (usize, u32) {
        let largest = pieces.iter().copied().max().unwrap_or(1);
        (Self::index(m), largest.max(1).ilog2())
    }

    /// The deep update's builds after `plan` when its descent was not
    /// made: as last priced, in proportion to the interval; before any,
    /// one build of the moved triangles, at the least correction learned
    /// for the deep update (at most 1).
    pub fn deep_estimate(&self, plan: &Plan) -> f64 {
        match self.deep_last {
            Some((ms, then)) => ms * plan.interval as f64 / then.max(1) as f64,
            None => {
                let least = (self.correction.iter())
                    .filter(|((i, _), _)| *i == Self::index(Method::Deep))
                    .fold(1.0f64, |m, (_, &c)| m.min(c));
                self.piece_ms(plan.transformed) * least
            }
        }
    }

    /// The correction learned for `m` at the octave of `pieces`, else at
    /// the nearest octave `m` was seen at, else none (1).
    fn correction(&self, m: Method, pieces: &[usize]) -> f64 {
        let (i, octave) = Self::key(m, pieces);
        (self.correction.iter())
            .filter(|((j, _), _)| *j == i)
            .min_by_key(|((_, o), _)| o.abs_diff(octave))
            .map_or(1.0, |(_, &c)| c)
    }

    /// What a deep update multiplies the render of the tree it is given
    /// by: a fresh tree's as learned in the frames (else 1), one a deep
    /// update left 1.
    fn deep_ratio(&self, deep_tree: bool) -> f64 {
        match deep_tree {
            true => 1.0,
            false => self.render_deep.unwrap_or(1.0),
        }
    }

    /// Each option's predicted times for a frame whose updates would do
    /// what `plan` counts, in a scene of `triangles`; `known` is what an
    /// option's update costs beyond its builds and what follows them, known
    /// before it runs (the plan's search, a program switch, a copy).
    pub fn predict(
        &self,
        plan: &Plan,
        triangles: usize,
        known: impl Fn(Method) -> f64,
    ) -> [(Method, Prediction); 3] {
        let render_now = self.render_now.unwrap_or(0.0);
        let render_fresh = self.render_fresh.unwrap_or(render_now);
        let corrected = |m: Method, pieces: &[usize]| {
            self.build_ms(pieces) * self.correction(m, pieces) + known(m)
        };
        let seen = (plan.scene_box.filter(|_| plan.full_rebuild))
            .and_then(|b| self.forced.iter().find(|f| f.0 == b));
        let rebuild = match seen {
            Some(&(_, update_ms, render_ms)) => Prediction {
                update_ms: update_ms + known(Method::Rebuild),
                render_ms,
            },
            None => Prediction {
                update_ms: corrected(Method::Rebuild, &[triangles]),
                render_ms: render_fresh,
            },
        };
        let update = |m: Method, pieces: &[usize], render_ms: f64| {
            if plan.full_rebuild {
                rebuild
            } else {
                Prediction {
                    update_ms: corrected(m, pieces),
                    render_ms,
                }
            }
        };
        // The deep update before the local one: on a tie it wins (it never
        // rebuilds more than the local update's interval).
        [
            (Method::Rebuild, rebuild),
            (
                Method::Deep,
                match plan.deep_planned {
                    true => update(
                        Method::Deep,
                        &plan.deep_pieces,
                        render_now * self.deep_ratio(self.deep_tree),
                    ),
                    // Not planned: its builds as estimated, and its search.
                    false => Prediction {
                        update_ms: self.deep_estimate(plan) + known(Method::Deep),
                        render_ms: render_now * self.deep_ratio(self.deep_tree),
                    },
                },
            ),
            (
                Method::Local,
                update(
                    Method::Local,
                    &[plan.interval],
                    self.render_local.unwrap_or(render_fresh),
                ),
            ),
        ]
    }

    /// The option to take: the least predicted frame counting the tree it
    /// leaves for [`HORIZON`] frames after it (each kept by the cheapest
    /// update, the deep one, at the render that update would leave of that
    /// tree), unless an update not taken yet is predicted within
    /// [`EXPLORE`] of it (the least such, then).
    pub fn choose(
        &self,
        predictions: &[(Method, Prediction); 3],
        combine: impl Fn(f64, f64) -> f64,
    ) -> (Method, Prediction) {
        let keep = (predictions.iter())
            .find(|(m, _)| *m == Method::Deep)
            .map_or(0.0, |(_, p)| p.update_ms);
        // A fresh tree kept by deep updates: as learned; until a deep
        // update has kept one, no faster than the tree they keep now.
        let kept = |m: Method, r: f64| match (m, self.render_deep, self.deep_tree) {
            (Method::Deep, ..) => r * self.deep_ratio(true),
            (_, None, true) => r.max(self.render_now.unwrap_or(r)),
            _ => r * self.deep_ratio(false),
        };
        let best = *predictions
            .iter()
            .min_by(|(a, pa), (b, pb)| {
                let ahead = |m: Method, p: &Prediction| {
                    let now = combine(p.update_ms, p.render_ms);
                    (now + HORIZON * combine(keep, kept(m, p.render_ms)), now)
                };
                (ahead(*a, pa).partial_cmp(&ahead(*b, pb))).expect("finite predictions")
            })
            .expect("three options");
        let frame = |p: &Prediction| combine(p.update_ms, p.render_ms);
        let unseen = |m: Method| match m {
            Method::Local => self.render_local.is_none(),
            Method::Deep => self.render_deep.is_none() && !self.deep_tree,
            Method::Rebuild => false,
        };
        (predictions.iter())
            .filter(|(m, p)| unseen(*m) && frame(p) <= frame(&best.1) * (1.0 + EXPLORE))
            .min_by(|a, b| frame(&a.1).total_cmp(&frame(&b.1)))
            .copied()
            .unwrap_or(best)
    }

    /// Learns from a frame: the option taken, what `plan` counted before
    /// it, whether it rebuilt completely and the scene's triangles, its
    /// measured update beyond what was `known` before it ran (its builds
    /// and what follows them), and its render.
    pub fn observe(
        &mut self,
        taken: Method,
        plan: &Plan,
        (full_rebuild, triangles): (bool, usize),
        update_ms: f64,
        render_ms: f64,
    ) {
        // The deep update's builds as this plan priced them.
        if plan.deep_planned && !plan.full_rebuild && !plan.deep_pieces.is_empty() {
            let pieces = &plan.deep_pieces;
            let ms = self.build_ms(pieces) * self.correction(Method::Deep, pieces);
            self.deep_last = Some((ms, plan.interval));
        }
        let (m, pieces) = match (full_rebuild, taken) {
            (true, _) | (_, Method::Rebuild) => (Method::Rebuild, vec![triangles]),
            (false, Method::Local) => (Method::Local, vec![plan.interval]),
            (false, Method::Deep) => (Method::Deep, plan.deep_pieces.clone()),
        };
        let priced = self.build_ms(&pieces);
        if priced > 0.0 && update_ms > 0.0 {
            let seen = update_ms / priced;
            (self.correction.entry(Self::key(m, &pieces)))
                .and_modify(|c| *c += LEARN * (seen - *c))
                .or_insert(seen);
        }
        if let Some(b) = plan.scene_box.filter(|_| full_rebuild) {
            self.forced.retain(|f| f.0 != b);
            self.forced.push((b, update_ms, render_ms));
        }
        let learn = |learned: &mut Option<f64>, seen: f64| {
            *learned = Some(learned.map_or(seen, |l| l + LEARN * (seen - l)));
        };
        match (full_rebuild, taken) {
            (false, Method::Local) => learn(&mut self.render_local, render_ms),
            (false, Method::Deep) => match self.render_now {
                Some(before) if before > 0.0 && !self.deep_tree && self.now_in_frame => {
                    learn(&mut self.render_deep, render_ms / before)
                }
                _ => {}
            },
            _ => self.render_fresh = Some(render_ms),
        }
        self.deep_tree = !full_rebuild && taken == Method::Deep;
        self.render_now = Some(render_ms);
        self.now_in_frame = true;
    }
}

/// The option whose predicted frame time is least (`combine`: how the
/// arrangement combines update and render), ties to the lower sum.
pub fn choose(
    predictions: &[(Method, Prediction); 3],
    combine: impl Fn(f64, f64) -> f64,
) -> (Method, Prediction) {
    let key = |p: &Prediction| (combine(p.update_ms, p.render_ms), p.update_ms + p.render_ms);
    *predictions
        .iter()
        .min_by(|a, b| {
            key(&a.1)
                .partial_cmp(&key(&b.1))
                .expect("finite predictions")
        })
        .expect("three options")
}

#[cfg(test)]
mod tests;
