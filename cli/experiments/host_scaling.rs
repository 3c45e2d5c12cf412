//! Section 5's strategies on the host's own cores. Every
//! builder of the registry that builds on the host's threads, beside the
//! serial host builder and a peer (obvhs's CWBVH with its `parallel`
//! feature, its fastest preset), on each scene and thread count: wall time
//! and total CPU time (user + sys of the whole process, every thread), so
//! that work efficiency shows even where there are few cores. Beside them
//! the machine's own ceiling: as many independent serial builds at once as
//! threads (its speedup: builds × serial time / its time), which no
//! parallel builder can beat on the same machine at the same moment. Each
//! contender in turn, in its own warm pool, its builds timed back to back
//! (a second vCPU of a virtual machine comes up to speed only after some
//! work: `WARM_UP`); beside each row the share of the CPUs' time the
//! hypervisor stole during its builds (/proc/stat), which slows a parallel
//! build more than independent ones.
//!
//! `CELLBIH_DATA=../shared/data cargo run --release --example host_scaling -- [--scenes bunny,dragon] [--threads 1,2] [--runs 7] [--rounds 3] [--split sah --empty-cut 10 …] [--out results]`
//!
//! The tree is the paper's unless the tree's options (`cellbih build`'s:
//! `report::TreeArgs`) ask for the quality knobs; every builder that
//! builds them is measured with them.
//!
//! An example, not a `[[bin]]`: obvhs is a dev-dependency only. Each build
//! runs in a rayon pool of the row's threads (`ThreadPool::install`), for
//! `WARM_UP` and then `--runs` times, in each of `--rounds` rounds over the
//! contenders; the table gives medians over the rounds' builds. Each
//! parallel builder's tree is checked against the serial builder's (the
//! same nodes). Writes host_scaling.{csv,json} and host_scaling.svg
//! (speedup against threads on the largest scene).

use std::time::{Duration, Instant};

use clap::Parser;
use serde_json::{Value, json};

use cellbih::bih::{BihConfig, BihNode};
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::Scene;
use cellbih_cli::args::DataArg;
use cellbih_cli::report::{OutputArgs, Series, TreeArgs, line_plot, output};

#[derive(Parser)]
#[command(
    about = "Section 5's strategies on the host's own cores, 1 to N threads, the machine's ceiling and obvhs beside them (default run: about 7 min)"
)]
struct Args {
    /// Scenes, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "bunny,dragon,sponza-dabrovic,sibenik,rtperf:4000000"
    )]
    scenes: Vec<String>,
    /// Thread counts, comma-separated (default: 1, 2, 4, … up to the
    /// machine's available parallelism, and it).
    #[arg(long, value_delimiter = ',', value_parser = cellbih_cli::args::between::<u64, _>(1..=1024))]
    threads: Vec<u64>,
    /// Timed builds per row and round (after a warm-up); the table gives
    /// medians over every round's.
    #[arg(long, default_value_t = 7, value_parser = cellbih_cli::args::between::<u64, _>(1..=1000))]
    runs: u64,
    /// Rounds over the contenders of a scene, each contender warmed up
    /// and timed once a round: a slow stretch of a shared machine then
    /// falls on one round of each rather than on all of one contender's
    /// builds.
    #[arg(long, default_value_t = 3, value_parser = cellbih_cli::args::between::<u64, _>(1..=100))]
    rounds: u64,
    /// The tree every builder makes (the peer, obvhs, has its own): the
    /// paper's by default; the quality knobs as `cellbih build` takes them.
    #[command(flatten)]
    tree: TreeArgs,
    #[command(flatten)]
    data: DataArg,
    #[command(flatten)]
    output: OutputArgs,
}

fn main() {
    let mut args: Args = cellbih_cli::args::parse();
    if args.threads.is_empty() {
        let most = hardware_threads() as u64;
        args.threads = std::iter::successors(Some(1u64), |t| Some(t * 2))
            .take_while(|&t| t < most)
            .chain([most])
            .collect();
    }
    cellbih_cli::report::experiment_main("host_scaling", &args.output.out, || run(&args));
}

fn hardware_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The CPU time (user + sys) this process has used, every thread.
fn cpu_time() -> Duration {
    // SAFETY: getrusage writes the struct it is given and nothing else.
    let usage = unsafe {
        let mut u = std::mem::zeroed::<libc::rusage>();
        libc::getrusage(libc::RUSAGE_SELF, &mut u);
        u
    };
    let tv = |t: libc::timeval| Duration::new(t.tv_sec as u64, t.tv_usec as u32 * 1000);
    tv(usage.ru_utime) + tv(usage.ru_stime)
}

/// The time the hypervisor gave this machine's CPUs to others ("steal",
/// summed over the CPUs, from /proc/stat), where the kernel reports it: a
/// virtual machine's vCPUs may stand still while the host runs something
/// else, and a parallel build waits for the one that stands.
fn stolen() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/stat").ok()?;
    let cpu = stat.lines().find(|l| l.starts_with("cpu "))?;
    let ticks: u64 = cpu.split_whitespace().nth(8)?.parse().ok()?;
    // SAFETY: sysconf reads a constant of the system.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    (hz > 0).then(|| Duration::from_secs_f64(ticks as f64 / hz as f64))
}

/// The pause before each contender (see [`scene_rows`]).
const SETTLE: Duration = Duration::from_millis(20);

/// How long each contender builds before it is timed: on the VM of
/// docs/host-parallel.md an idle second vCPU came up to speed only after
/// some 50 ms of back-to-back builds (the bunny on two threads ran at the
/// serial builder's speed for its first 6 to 9 builds, then at 0.6 of it).
const WARM_UP: Duration = Duration::from_millis(300);

/// One timed call: wall and CPU milliseconds.
fn timed<R>(f: impl FnOnce() -> R) -> (f64, f64, R) {
    let (w, c) = (Instant::now(), cpu_time());
    let r = f();
    let cpu = (cpu_time() - c).as_secs_f64() * 1e3;
    (w.elapsed().as_secs_f64() * 1e3, cpu, r)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The builders measured: the serial host builder and every builder that
/// builds on the host's threads and builds `cfg`.
fn builders(cfg: &BihConfig) -> Vec<BuilderKind> {
    (BuilderKind::ALL.iter().copied())
        .filter(|b| *b == BuilderKind::HOST || b.host_threads())
        .filter(|b| b.builds(cfg))
        .collect()
}

fn run(args: &Args) -> Result<(), String> {
    let cfg = args.tree.config()?;
    let scenes = cellbih_cli::report::load_scenes(&args.scenes, args.data.dir().as_deref())?;
    let machine = json!({
        "hardware_threads": hardware_threads(),
        "cpu": cpu_model(),
        "runs": args.runs,
        "rounds": args.rounds,
        "statistic": "median",
    });
    eprintln!(
        "host_scaling: {} hardware threads ({}); medians of {} of {}; tree: {}",
        machine["hardware_threads"],
        machine["cpu"],
        cellbih_cli::report::count(args.rounds, "round"),
        cellbih_cli::report::count(args.runs, "warm build"),
        match cfg.flags().as_str() {
            "" => "the paper's",
            flags => flags,
        }
    );
    let mut rows = Vec::new();
    for s in &scenes {
        rows.extend(scene_rows(s, &cfg, args)?);
    }
    let mut doc = machine.clone();
    doc["rows"] = Value::Array(rows.clone());
    let keys = [
        "scene",
        "triangles",
        "builder",
        "threads",
        "wall_ms",
        "cpu_ms",
        "speedup",
        "cpu_over_serial",
        "same_tree",
        "stolen",
    ];
    args.output.report(
        "host_scaling",
        (&keys, &rows),
        &doc,
        Some(&Build::new(BuilderKind::HOST).with_tree(cfg)),
        |rows| {
            println!(
                "{:<16} {:<14} {:>7} {:>10} {:>10} {:>8} {:>9} {:>5} {:>7}",
                "scene",
                "builder",
                "threads",
                "wall ms",
                "cpu ms",
                "speedup",
                "cpu/ser.",
                "same",
                "stolen"
            );
            for r in rows {
                println!(
                    "{:<16} {:<14} {:>7} {:>10.2} {:>10.2} {:>7.2}x {:>8.2}x {:>5} {:>7}",
                    r["scene"].as_str().unwrap_or(""),
                    r["builder"].as_str().unwrap_or(""),
                    r["threads"].as_u64().unwrap_or(0),
                    r["wall_ms"].as_f64().unwrap_or(0.0),
                    r["cpu_ms"].as_f64().unwrap_or(0.0),
                    r["speedup"].as_f64().unwrap_or(0.0),
                    r["cpu_over_serial"].as_f64().unwrap_or(0.0),
                    match r["same_tree"].as_bool() {
                        Some(true) => "yes",
                        Some(false) => "NO",
                        None => "-",
                    },
                    match r["stolen"].as_f64() {
                        Some(f) => format!("{:.1}%", 100.0 * f),
                        None => "-".into(),
                    }
                );
            }
            println!(
                "host time on {}, {} hardware threads; medians of {} runs x {} rounds",
                machine["cpu"].as_str().unwrap_or("an unnamed CPU"),
                machine["hardware_threads"],
                args.runs,
                args.rounds
            );
        },
    )?;
    plot(&rows, &args.output.out)?;
    Ok(())
}

/// A contender of one scene: its name, threads and one build (returning
/// the tree's nodes for the host builders).
struct Contender<'a> {
    builder: String,
    threads: u64,
    /// Serial builds one call makes (the ceiling's: one per thread).
    builds: u64,
    pool: rayon::ThreadPool,
    build: Box<dyn Fn() -> Result<Option<Vec<BihNode>>, String> + Sync + 'a>,
}

/// The rows of one scene: the serial builder, each parallel builder and
/// the peer on each thread count, each built for [`WARM_UP`] and then
/// `--runs` times back to back, every round; each row gives its medians.
fn scene_rows(s: &Scene, cfg: &BihConfig, args: &Args) -> Result<Vec<Value>, String> {
    let pool = |threads: u64| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads as usize)
            .build()
            .map_err(|e| e.to_string())
    };
    let tris: Vec<obvhs::triangle::Triangle> = (s.triangles.iter())
        .map(|t| obvhs::triangle::Triangle {
            v0: t.v[0].into(),
            v1: t.v[1].into(),
            v2: t.v[2].into(),
        })
        .collect();
    let ours =
        |b: BuilderKind| -> Box<dyn Fn() -> Result<Option<Vec<BihNode>>, String> + Sync + '_> {
            Box::new(move || {
                Build::new(b)
                    .with_tree(*cfg)
                    .run(s)
                    .map(|r| Some(r.bih.nodes))
                    .map_err(|e| e.to_string())
            })
        };
    let mut contenders = vec![Contender {
        builder: BuilderKind::HOST.name().into(),
        threads: 1,
        builds: 1,
        pool: pool(1)?,
        build: ours(BuilderKind::HOST),
    }];
    for &threads in &args.threads {
        for b in builders(cfg).into_iter().filter(|b| b.host_threads()) {
            contenders.push(Contender {
                builder: b.name().into(),
                threads,
                builds: 1,
                pool: pool(threads)?,
                build: ours(b),
            });
        }
        if threads > 1 {
            // The machine's own ceiling: as many serial builds as threads
            // at once, no sharing between them.
            contenders.push(Contender {
                builder: "ceiling".into(),
                threads,
                builds: threads,
                pool: pool(threads)?,
                build: Box::new(move || {
                    rayon::scope(|sc| {
                        for _ in 0..threads {
                            sc.spawn(|_| {
                                drop(Build::new(BuilderKind::HOST).with_tree(*cfg).run(s))
                            });
                        }
                    });
                    Ok(None)
                }),
            });
        }
        let tris = &tris;
        contenders.push(Contender {
            builder: "obvhs fastest".into(),
            threads,
            builds: 1,
            pool: pool(threads)?,
            build: Box::new(move || {
                let params = obvhs::BvhBuildParams::fastest_build();
                obvhs::cwbvh::builder::build_cwbvh_from_tris(
                    tris,
                    params,
                    &mut Duration::default(),
                );
                Ok(None)
            }),
        });
    }
    // Each round, each contender in turn: after a pause (the last
    // contender's idle threads spin a little before they sleep, and the
    // process's CPU time would count it), builds for [`WARM_UP`] (the very
    // first one's tree checked against the serial builder's), then the
    // timed builds back to back, in a warm pool.
    let mut trees = Vec::new();
    let mut times = vec![(Vec::new(), Vec::new()); contenders.len()];
    // Per contender: CPU time stolen and CPU time there was, seconds.
    let mut steal = vec![Some((0.0, 0.0)); contenders.len()];
    for round in 0..args.rounds {
        for ((c, t), steal) in contenders.iter().zip(&mut times).zip(&mut steal) {
            std::thread::sleep(SETTLE);
            let first = c.pool.install(|| (c.build)())?;
            if round == 0 {
                trees.push(first);
            }
            let warm = Instant::now();
            while warm.elapsed() < WARM_UP {
                c.pool.install(|| (c.build)())?;
            }
            let (before, timing) = (stolen(), Instant::now());
            for _ in 0..args.runs {
                let (wall, cpu, built) = c.pool.install(|| timed(|| (c.build)()));
                built?;
                t.0.push(wall);
                t.1.push(cpu);
            }
            // The CPUs' time during the timed builds, and how much of it
            // was stolen (in /proc/stat's ticks: 10 ms on Linux).
            let all = timing.elapsed().as_secs_f64() * hardware_threads() as f64;
            let took = before.zip(stolen()).map(|(b, a)| (a - b).as_secs_f64());
            *steal = steal.zip(took).map(|((s, a), took)| (s + took, a + all));
        }
    }
    let steal = steal.into_iter().map(|s| s.map(|(s, all)| s / all));
    let medians: Vec<(f64, f64)> = (times.into_iter())
        .map(|(w, c)| (median(w), median(c)))
        .collect();
    let (serial_wall, serial_cpu) = medians[0];
    let rows = (contenders.iter().zip(medians).zip(&trees).zip(steal))
        .map(|(((c, (wall, cpu)), tree), stolen)| {
            eprintln!(
                "  {} {} {} threads: {wall:.2} ms",
                s.name, c.builder, c.threads
            );
            json!({
                "scene": s.name, "triangles": s.len(), "builder": c.builder, "threads": c.threads,
                "wall_ms": wall, "cpu_ms": cpu,
                "speedup": c.builds as f64 * serial_wall / wall,
                "cpu_over_serial": cpu / (c.builds as f64 * serial_cpu),
                "same_tree": tree.as_ref().map(|t| Some(t) == trees[0].as_ref()),
                "stolen": stolen,
            })
        })
        .collect();
    Ok(rows)
}

/// Speedup over the serial host builder against threads, one line a
/// builder, on the largest scene.
fn plot(rows: &[Value], out: &std::path::Path) -> Result<(), String> {
    let Some(largest) = rows.iter().max_by_key(|r| r["triangles"].as_u64()) else {
        return Ok(());
    };
    let scene = largest["scene"].as_str().unwrap_or("");
    let mut names: Vec<&str> = Vec::new();
    for r in rows.iter().filter(|r| r["scene"] == scene) {
        let n = r["builder"].as_str().unwrap_or("");
        if !names.contains(&n) {
            names.push(n);
        }
    }
    let series: Vec<Series> = (names.iter().enumerate())
        .map(|(i, &n)| Series {
            name: n.to_string(),
            points: (rows.iter())
                .filter(|r| r["scene"] == scene && r["builder"] == n)
                .map(|r| {
                    (
                        r["threads"].as_f64().unwrap_or(1.0),
                        r["speedup"].as_f64().unwrap_or(0.0),
                    )
                })
                .collect(),
            color: i,
            dashed: n.starts_with("obvhs"),
        })
        .collect();
    line_plot(
        &output(out, "host_scaling.svg").map_err(|e| e.to_string())?,
        &format!("{scene}: build speedup over the serial host builder (host wall time, medians)"),
        "host threads",
        "speedup",
        &series,
        true,
    )
    .map_err(|e| e.to_string())
}

/// The CPU's model name, from /proc/cpuinfo where there is one.
fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|c| {
            c.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}
