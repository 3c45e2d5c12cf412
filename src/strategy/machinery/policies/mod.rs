//! Section 5's multi-SPE breadth-first program, its policies as values:
//! every SPE runs the baseline's loop (section 2, Fig. 2) after the top
//! levels (`machinery::top`); what differs between section 5's strategies is
//! a value of `Policies` — the **deal** (the top's last level dealt
//! largest first to private queues, `dealt`; those queues as lists an
//! SPE steals from; or one shared job queue, `shared`), the **top's
//! end** (`TopKnobs`), section 5's **queue** improvements
//! (`QueueKnobs`) and the **finish** (`Finish`: jobs that fit the local
//! store streamed level by level or finished there). A strategy is a
//! composition: it reads its knobs into a `Policies` and calls `spawn`.

mod dealt;
mod shared;

use super::breadth_first::{Finish, QueueKnobs};
use super::forecast::{Dealing, Forecast, Plan};
use super::top::TopKnobs;
use crate::bih::BihConfig;
use crate::cell::{Cell, CellError};
use crate::strategy::program::{Readback, Setup};

/// What both breadth-first strategies promise: the faster of them at
/// least 6.5x the baseline on 8 SPEs on every scene of 100,000 triangles
/// or more.
pub(in crate::strategy) const PROMISE: crate::strategy::Promise = crate::strategy::Promise {
    family: "breadth-first",
    speedup: 6.5,
    triangles: 100_000,
};

/// How the top's last level reaches the SPEs and how they take work.
#[derive(Clone, Copy, Debug)]
pub(in crate::strategy) enum Deal {
    /// Section 5's private queues: SPE 0 deals the level largest first,
    /// each job to the SPE with the fewest triangles so far; every SPE
    /// builds its own jobs with no synchronisation.
    LargestFirst,
    /// The dealt jobs stay in per-SPE lists in main memory; an SPE takes
    /// its next one when it has built the last and, its list empty, steals
    /// the last of another's (lock-line updates).
    Steal,
    /// Section 5's one common job queue, a level at a time.
    Shared(SharedQueue),
}

/// The shared queue's policy.
#[derive(Clone, Copy, Debug)]
pub(in crate::strategy) struct SharedQueue {
    /// Jobs taken per atomic operation (1 to 256, and no more than a
    /// `WorkA` holds). Buys: fewer lock-line updates and larger batches.
    /// Costs: balance at the end of a level (the last takes are large).
    pub agglomerate: usize,
    /// A take hands out no more than an equal share of the level's jobs
    /// left among the SPEs (guided self-scheduling), so that a level of
    /// few jobs is spread over every SPE. Buys: balance at the top of the
    /// shared levels and at each level's end. Costs: more takes (lock-line
    /// updates) near each level's end.
    pub guided: bool,
    /// KiB of software cache the jobs are read through (0: explicit gets;
    /// section 5's proposal). Buys: a line shared by two takes of one SPE
    /// is read once. Costs: a lookup per line and a get per missed line,
    /// where a take was one get.
    pub job_cache: usize,
}

/// A breadth-first multi-SPE strategy, as values.
#[derive(Clone, Copy, Debug)]
pub(in crate::strategy) struct Policies {
    pub deal: Deal,
    pub top: TopKnobs,
    pub queue: QueueKnobs,
    pub finish: Finish,
}

/// Sets up and spawns the program `policies` make on the SPEs the build
/// uses, and the pool's server on the PPE.
pub(in crate::strategy) fn spawn(
    cell: &mut Cell,
    setup: &Setup,
    cfg: &BihConfig,
    policies: Policies,
) -> Result<Readback, CellError> {
    let forecast = policies.forecast(cell, setup, cfg);
    let chosen = || forecast.chosen();
    let spes = super::top::spes_used(setup.spes, setup.count, &setup.knobs, chosen);
    let readback = match policies.deal {
        Deal::LargestFirst | Deal::Steal => {
            let p = dealt::Program::set_up(cell, setup, cfg, policies, spes)?;
            let run = move |spe, id| p.run(spe, id);
            p.start.common.pool.spawn_programs(cell, spes, run)
        }
        Deal::Shared(q) => {
            let p = shared::Program::set_up(cell, setup, cfg, (policies, q), spes)?;
            let run = move |spe, id| p.run(spe, id);
            p.start.common.pool.spawn_programs(cell, spes, run)
        }
    };
    Ok(Box::new(move || {
        let mut o = readback()?;
        o.predicted = Some(forecast.prediction());
        Ok(o)
    }))
}

impl Policies {
    /// What both programs read first: the pool and the cooperative
    /// partition's areas for these policies on `spes` SPEs.
    fn start(
        &self,
        cell: &mut Cell,
        setup: &Setup,
        cfg: &BihConfig,
        spes: usize,
    ) -> Result<super::top::Start, CellError> {
        let ends = (&self.top, self.finish);
        super::top::Start::set_up(cell, setup, cfg, ends, spes)
    }

    /// The build's predicted time on each count of SPEs up to those given,
    /// with the rates in force (`machinery::forecast`).
    fn forecast(&self, cell: &Cell, setup: &Setup, cfg: &BihConfig) -> Forecast {
        let plan = Plan {
            top: self.top,
            finish: self.finish,
            dealing: match self.deal {
                Deal::LargestFirst | Deal::Steal => Dealing::Private,
                Deal::Shared(_) => Dealing::Shared,
            },
        };
        let machine = super::forecast::machine_of(cell);
        let rates = (&setup.rates.kernels(), &machine);
        super::forecast::predict(setup.count, cfg, plan, rates, setup.spes)
    }

    /// The SPE program's step once the top levels are built (and dealt):
    /// their phase ends, and with `--finish local` from now on the jobs
    /// that fit are finished in the local store (it holds all else it
    /// needs).
    fn after_the_top(&self, b: &mut super::breadth_first::SpeBuilder<'_>) -> Result<(), CellError> {
        b.end_top();
        match self.finish {
            Finish::Local => b.finish_locally(),
            Finish::Stream => Ok(()),
        }
    }
}
