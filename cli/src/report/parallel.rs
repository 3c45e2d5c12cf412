//! Experiments run their independent emulations side by side:
//! `--threads N` sets the threads ([`crate::args::ThreadsArg`]), and
//! [`side_by_side`] runs a list of independent jobs (scenes, builders, SPE
//! counts) on them with rayon, the results in the list's order. Simulated
//! time is deterministic — the same cycles and the same tree with any
//! number of host threads — so the simulated figures are the same,
//! byte for byte, as a one-thread run's (tested in `cli/tests/cli/experiments.rs`);
//! host times measured side by side share the host's cores and say so.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

/// The stack of each thread that runs jobs side by side: an emulation's
/// deep recursions overflowed the default 2 MiB. Reserved, not used,
/// memory.
pub const JOB_STACK_BYTES: usize = 64 << 20;

impl crate::args::ThreadsArg {
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
/// threads; the results in the jobs' order, with [`Progress`] counting the
/// jobs done on stderr (`what` names them).
pub fn side_by_side<J: Sync, R: Send>(
    what: &str,
    jobs: &[J],
    f: impl Fn(&J) -> R + Sync,
) -> Vec<R> {
    let progress = Progress::new(what, jobs.len() as u64);
    let out = (jobs.par_iter())
        .map(|j| {
            let r = f(j);
            progress.inc();
            r
        })
        .collect();
    progress.finish();
    out
}

/// [`side_by_side`] for jobs whose own work must run on one thread (a
/// host figure measured alone, a host-thread builder in a pool of one):
/// as many jobs at once as the current pool has threads, each on a thread
/// of its own with a rayon pool of one thread for whatever it runs inside.
/// (A pool of one made inside a [`side_by_side`] job would not bound
/// them: the waiting worker runs the next jobs of its own pool meanwhile,
/// so every job starts at once and their memory adds up.) The results in
/// the jobs' order.
pub fn one_thread_each<J: Sync, R: Send>(
    what: &str,
    jobs: &[J],
    f: impl Fn(&J) -> R + Sync,
) -> Result<Vec<R>, String> {
    let progress = Progress::new(what, jobs.len() as u64);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let workers = rayon::current_num_threads().clamp(1, jobs.len().max(1));
    let done: Vec<Vec<(usize, R)>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                scope.spawn(|| -> Result<Vec<(usize, R)>, String> {
                    let one = rayon::ThreadPoolBuilder::new()
                        .num_threads(1)
                        .stack_size(JOB_STACK_BYTES)
                        .build()
                        .map_err(|e| e.to_string())?;
                    let mut out = Vec::new();
                    loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some(job) = jobs.get(i) else {
                            return Ok(out);
                        };
                        out.push((i, one.install(|| f(job))));
                        progress.inc();
                    }
                })
            })
            .collect();
        (handles.into_iter())
            .map(|h| h.join().map_err(|_| format!("{what}: a job panicked"))?)
            .collect::<Result<_, String>>()
    })?;
    progress.finish();
    let mut all: Vec<(usize, R)> = done.into_iter().flatten().collect();
    all.sort_by_key(|(i, _)| *i);
    Ok(all.into_iter().map(|(_, r)| r).collect())
}

/// How often a long run's progress line is repeated on a stderr that is
/// not a terminal (a log file, CI): often enough to see it move, rarely
/// enough to read.
pub const PROGRESS_EVERY: Duration = Duration::from_secs(10);

/// Work counted as it is done, on stderr: a bar on a terminal; elsewhere,
/// once the work has run for [`super::step::QUIET_FOR`], a line such as
/// `spe_scaling runs: 12/80 done (45 s)` every [`PROGRESS_EVERY`], and a
/// last one when all is done. Quick work prints nothing.
pub struct Progress {
    bar: Option<ProgressBar>,
    what: String,
    total: u64,
    done: AtomicU64,
    start: Instant,
    /// When the last line was printed (not a terminal), if one was.
    last: Mutex<Option<Instant>>,
}

impl Progress {
    pub fn new(what: &str, total: u64) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::new(total);
            if let Ok(style) =
                ProgressStyle::with_template("{bar:30} {pos}/{len} {msg} ({elapsed})")
            {
                bar.set_style(style);
            }
            bar.set_message(what.to_string());
            bar
        });
        Progress {
            bar,
            what: what.to_string(),
            total,
            done: AtomicU64::new(0),
            start: Instant::now(),
            last: Mutex::new(None),
        }
    }

    /// One more piece of the work is done.
    pub fn inc(&self) {
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if let Some(bar) = &self.bar {
            bar.inc(1);
            return;
        }
        let now = Instant::now();
        if now - self.start < super::step::QUIET_FOR {
            return;
        }
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        if last.is_none_or(|t| now - t >= PROGRESS_EVERY) {
            *last = Some(now);
            self.line(done);
        }
    }

    fn line(&self, done: u64) {
        eprintln!(
            "{}: {done}/{} done ({:.0} s)",
            self.what,
            self.total,
            self.start.elapsed().as_secs_f64()
        );
    }

    /// All done: the bar is cleared; where lines were printed, a last one.
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
            return;
        }
        let last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        let done = self.done.load(Ordering::Relaxed);
        if last.is_some() && done > 0 {
            self.line(done);
        }
    }
}
