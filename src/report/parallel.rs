//! Experiments run their independent emulations side by side:
//! `--threads N` sets the threads ([`ThreadsArg`]), and
//! [`side_by_side`] runs a list of independent jobs (scenes, builders, SPE
//! counts) on them with rayon, the results in the list's order. Simulated
//! time is deterministic — the same cycles and the same tree with any
//! number of host threads — so the simulated figures are the same,
//! byte for byte, as a one-thread run's (tested in `tests/experiments.rs`);
//! host times measured side by side share the host's cores and say so.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

/// The stack of each thread that runs jobs side by side. A thread that
/// waits for a job it handed to another pool (a build in a pool of one)
/// runs other jobs of its own pool meanwhile, on the same stack, so one
/// stack may hold several emulations at once: the default 2 MiB
/// overflowed in a full `tradeoff` run. Reserved, not used, memory.
pub const JOB_STACK_BYTES: usize = 64 << 20;

/// An experiment's `--threads N`.
#[derive(clap::Args, Clone, Debug)]
pub struct ThreadsArg {
    /// Host threads that run the independent emulations side by side
    /// (default: the machine's available parallelism). Simulated figures
    /// do not depend on it; host times measured side by side do.
    #[arg(long, value_parser = crate::report::between::<u64, _>(1..=1024))]
    pub threads: Option<u64>,
}

impl ThreadsArg {
    /// Makes the global rayon pool of the threads asked for; returns how
    /// many.
    pub fn install(&self) -> Result<usize, String> {
        let n = match self.threads {
            Some(n) => n as usize,
            None => std::thread::available_parallelism().map_or(1, |n| n.get()),
        };
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .stack_size(JOB_STACK_BYTES)
            .build_global()
            .map_err(|e| format!("--threads {n}: {e}"))?;
        Ok(n)
    }
}

/// Runs `f` on every one of `jobs` side by side on the current pool's
/// threads; the results in the jobs' order. A bar on stderr, when it is a
/// terminal, counts the jobs done (`what` names them).
pub fn side_by_side<J: Sync, R: Send>(
    what: &str,
    jobs: &[J],
    f: impl Fn(&J) -> R + Sync,
) -> Vec<R> {
    let bar = match std::io::stderr().is_terminal() {
        true => {
            let bar = ProgressBar::new(jobs.len() as u64);
            if let Ok(style) =
                ProgressStyle::with_template("{bar:30} {pos}/{len} {msg} ({elapsed})")
            {
                bar.set_style(style);
            }
            bar.set_message(what.to_string());
            bar
        }
        false => ProgressBar::hidden(),
    };
    let out = (jobs.par_iter())
        .map(|j| {
            let r = f(j);
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    out
}
