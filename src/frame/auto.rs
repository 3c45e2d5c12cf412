//! Section 5's metric: "a metric for estimation of needed time for
//! reorganization steps", so that each frame can choose between a
//! complete rebuild, the local update and the deep update before doing
//! any of them (`--policy auto`).
//!
//! The prediction is made from cheap counts and from what earlier frames
//! measured, in simulated milliseconds:
//!
//! - **update**: the triangles each option would rebuild — all of them for
//!   a rebuild; Algorithm 1's enclosing interval for the local update,
//!   found on a copy of the tree before anything is built
//!   ([`Updater::plan`](crate::update::Updater::plan)); that interval
//!   times the share the deep update has kept rebuilding of it so far —
//!   turned into time by the build's cost per unit of work, `n·log2(n /
//!   leaf size)`, measured on the first tree's build and on every frame
//!   since (all the builds' ms over all their work);
//! - **render**: the render the tree would give — after a rebuild, the
//!   render measured after the last complete rebuild; after an update, the
//!   last render (an update keeps the tree as it is around the moved
//!   objects); before the first frame, the first tree's render.
//!
//! A frame's predicted time combines the two as the arrangement does (sum,
//! or the longer); the least wins, ties going to the lower sum, then to
//! the deep update over the local one (it never rebuilds more).

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
    leaf: f64,
    /// Simulated ms and units of build work of every build seen: their
    /// ratio is the cost of a unit, weighted by work (a large build's
    /// measurement counts for more than a 300-triangle one's, whose fixed
    /// costs would make the rate look high).
    seen_ms: f64,
    seen_work: f64,
    /// The deep update's rebuilt triangles over the local interval.
    deep_share: f64,
    render_fresh: Option<f64>,
    render_now: Option<f64>,
}

/// How much weight a new measurement of the deep update's share gets
/// against what was learned.
const LEARN: f64 = 0.5;

impl Predictor {
    /// A predictor for trees with leaves of `leaf_size`, which learned the
    /// cost of building `triangles` from the first build's
    /// `first_build_ms` (if it was timed).
    pub fn new(leaf_size: u32, triangles: usize, first_build_ms: Option<f64>) -> Self {
        let leaf = leaf_size.max(1) as f64;
        let mut p = Predictor {
            leaf,
            seen_ms: 0.0,
            seen_work: 0.0,
            deep_share: 1.0,
            render_fresh: None,
            render_now: None,
        };
        if let Some(ms) = first_build_ms {
            p.learn_build(triangles, ms);
        }
        p
    }

    /// The render of the first tree, before any frame: what a fresh
    /// tree and an unchanged one cost to cast.
    pub fn seed_render(&mut self, render_ms: f64) {
        self.render_fresh = Some(render_ms);
        self.render_now = Some(render_ms);
    }

    /// A build's work: `n·log2(n / leaf size)` (at least one level).
    fn work(&self, n: usize) -> f64 {
        let n = n as f64;
        n * (n / self.leaf).max(2.0).log2()
    }

    fn learn_build(&mut self, n: usize, ms: f64) {
        if n == 0 {
            return;
        }
        self.seen_ms += ms;
        self.seen_work += self.work(n);
    }

    /// Each option's predicted times for a frame whose local update would
    /// do what `plan` counts, in a scene of `triangles`.
    pub fn predict(&self, plan: &Plan, triangles: usize) -> [(Method, Prediction); 3] {
        let rate = if self.seen_work > 0.0 {
            self.seen_ms / self.seen_work
        } else {
            0.0
        };
        let render_now = self.render_now.unwrap_or(0.0);
        let rebuild = Prediction {
            update_ms: rate * self.work(triangles),
            render_ms: self.render_fresh.unwrap_or(render_now),
        };
        let update = |n: f64| {
            if plan.full_rebuild {
                rebuild
            } else {
                Prediction {
                    update_ms: rate * self.work(n.round() as usize),
                    render_ms: render_now,
                }
            }
        };
        // The deep update before the local one: on a tie it wins (it never
        // rebuilds more than the local update's interval).
        [
            (Method::Rebuild, rebuild),
            (Method::Deep, update(plan.interval as f64 * self.deep_share)),
            (Method::Local, update(plan.interval as f64)),
        ]
    }

    /// Learns from a frame: the option taken, what `plan` counted before
    /// it, the triangles it rebuilt, and its measured update and render.
    pub fn observe(
        &mut self,
        taken: Method,
        plan: &Plan,
        (full_rebuild, rebuilt): (bool, usize),
        update_ms: f64,
        render_ms: f64,
    ) {
        if rebuilt > 0 {
            self.learn_build(rebuilt, update_ms);
        }
        if taken == Method::Deep && !full_rebuild && plan.interval > 0 {
            let share = rebuilt as f64 / plan.interval as f64;
            self.deep_share += LEARN * (share - self.deep_share);
        }
        if full_rebuild {
            self.render_fresh = Some(render_ms);
        }
        self.render_now = Some(render_ms);
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
mod tests {
    use super::*;

    fn plan(full: bool, interval: usize) -> Plan {
        Plan {
            full_rebuild: full,
            interval,
            depth: 3,
            transformed: 10,
        }
    }

    #[test]
    fn a_small_interval_is_predicted_cheaper_than_a_rebuild_and_chosen() {
        let p = Predictor::new(12, 100_000, Some(50.0));
        let pr = p.predict(&plan(false, 2_000), 100_000);
        let (m, best) = choose(&pr, |u, r| u + r);
        // Deep and local are predicted alike before the deep update was
        // seen; the deep one is taken on the tie.
        assert_eq!(m, Method::Deep);
        assert_eq!(pr[1].1, pr[2].1);
        assert!(best.update_ms < pr[0].1.update_ms / 20.0, "{pr:?}");
        // The rate is the first build's: the rebuild is predicted at it.
        assert!((pr[0].1.update_ms - 50.0).abs() < 1e-9);
    }

    #[test]
    fn a_changed_scene_box_predicts_every_option_as_a_rebuild() {
        let p = Predictor::new(12, 10_000, Some(5.0));
        let pr = p.predict(&plan(true, 10_000), 10_000);
        assert!(pr.iter().all(|(_, x)| *x == pr[0].1));
    }

    #[test]
    fn it_learns_the_deep_share_and_the_fresh_render() {
        let mut p = Predictor::new(12, 10_000, Some(5.0));
        p.observe(Method::Deep, &plan(false, 1_000), (false, 200), 0.3, 8.0);
        let pr = p.predict(&plan(false, 1_000), 10_000);
        assert!(pr[1].1.update_ms < pr[2].1.update_ms, "{pr:?}");
        p.observe(
            Method::Rebuild,
            &plan(true, 10_000),
            (true, 10_000),
            5.0,
            6.0,
        );
        p.observe(Method::Local, &plan(false, 1_000), (false, 1_000), 0.5, 7.0);
        let pr = p.predict(&plan(false, 1_000), 10_000);
        assert_eq!(pr[0].1.render_ms, 6.0);
        assert_eq!(pr[2].1.render_ms, 7.0);
    }

    #[test]
    fn the_paper_arrangement_hides_a_cheap_update_behind_the_render() {
        let pr = [
            (
                Method::Rebuild,
                Prediction {
                    update_ms: 5.0,
                    render_ms: 8.0,
                },
            ),
            (
                Method::Deep,
                Prediction {
                    update_ms: 0.5,
                    render_ms: 9.0,
                },
            ),
            (
                Method::Local,
                Prediction {
                    update_ms: 1.0,
                    render_ms: 9.0,
                },
            ),
        ];
        assert_eq!(choose(&pr, f64::max).0, Method::Rebuild);
        assert_eq!(choose(&pr, |u, r| u + r).0, Method::Deep);
    }
}
