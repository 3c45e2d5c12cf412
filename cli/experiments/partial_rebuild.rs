//! Fig. 3 of the paper: the local update on rtPerf from 10k to 100k
//! triangles, and the same for the deeper update of section 5.
//!
//! `cargo run --release --bin partial_rebuild -- [--frames 100] [--no-sim] [--out results]`
//!
//! For each size, one sphere (200 triangles) is nudged per frame (every
//! fifth move marked only), as `Animation::named("rtperf")` gives it.
//! Panel (a): triangles transformed, triangles used for reconstruction, and
//! their difference (means over the frames). Panel (b): minimum, mean and
//! maximum update time beside the time of a complete rebuild — host time
//! (host builder, one thread) and simulated Cell time with the rebuilds on
//! the PPE (`ppe_naive`: the paper's update ran on the PPE) and on one SPE
//! (`spe_bfs`, the baseline). Writes partial_rebuild.{csv,json} and
//! fig3a_{local,deep}.svg, fig3b_{local,deep}{,_ppe,_spe_bfs}.svg.

use std::io::IsTerminal;
use std::path::Path;
use std::time::Instant;

use clap::Parser;
use serde_json::{Value, json};

use cellbih::bih::BihConfig;
use cellbih::host;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::procedural::rtperf;
use cellbih::update::{
    Animation, MAX_FRAMES, Method, SIMULATED_BUILDERS, Summary, UpdateReport, play,
};
use cellbih_cli::args::RateArgs;
use cellbih_cli::report::{OutputArgs, Series, line_plot, output};

/// The largest scene the experiment takes (it plays every frame on every
/// size, with brute-force-free checks only).
const MAX_TRIANGLES: u64 = 10_000_000;

#[derive(Parser)]
#[command(
    about = "Fig. 3: the local and the deep update against complete rebuilds over scene sizes (default run: about 6 s)"
)]
struct Args {
    /// Smallest scene, in triangles (1 to 10,000,000).
    #[arg(long, default_value_t = 10_000, value_parser = cellbih_cli::args::between::<u64, _>(1..=MAX_TRIANGLES))]
    from: u64,
    /// Largest scene, in triangles (at least --from, at most 10,000,000).
    #[arg(long, default_value_t = 100_000, value_parser = cellbih_cli::args::between::<u64, _>(1..=MAX_TRIANGLES))]
    to: u64,
    /// Triangles added from one size to the next (at least 1).
    #[arg(long, default_value_t = 10_000, value_parser = cellbih_cli::args::at_least_one::<u64>)]
    step: u64,
    /// Frames (moves) per scene size, 1 to 100,000.
    #[arg(long, default_value_t = 100, value_parser = cellbih_cli::args::between::<u64, _>(1..=MAX_FRAMES as u64))]
    frames: u64,
    /// Seed of the scenes and of the moves.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Host times only: skip the emulated (simulated-time) runs.
    #[arg(long)]
    no_sim: bool,
    #[command(flatten)]
    output: OutputArgs,
    #[command(flatten)]
    rates: RateArgs,
}

fn main() {
    cellbih_cli::report::main("partial_rebuild", |a: &Args| &a.output, run);
}

/// Plays `anim` on a fresh updater; returns every frame's report and the
/// SAH cost of the last tree over that of a fresh build of the last scene.
fn frames(
    scene: &cellbih::scene::Scene,
    anim: &Animation,
    build: &Build,
    method: Method,
) -> Result<(Vec<UpdateReport>, f64), String> {
    let (u, reports) = play(scene, anim, build, method).map_err(|e| e.to_string())?;
    let fresh = host::build(&u.scene, &u.bih.config).quality().sah_cost;
    Ok((reports, u.bih.quality().sah_cost / fresh))
}

/// Mean triangles rebuilt over the frames that were not complete rebuilds.
fn mean_partial_rebuilt(reports: &[UpdateReport]) -> Option<f64> {
    let p: Vec<f64> = reports
        .iter()
        .filter(|r| !r.full_rebuild && r.moves > 0)
        .map(|r| r.rebuilt as f64)
        .collect();
    (!p.is_empty()).then(|| p.iter().sum::<f64>() / p.len() as f64)
}

/// Median of the host times of frames that were not complete rebuilds.
fn median_partial_ms(reports: &[UpdateReport]) -> Option<f64> {
    let mut t: Vec<f64> = reports
        .iter()
        .filter(|r| !r.full_rebuild && r.moves > 0)
        .map(|r| r.host_ms)
        .collect();
    t.sort_by(f64::total_cmp);
    (!t.is_empty()).then(|| t[t.len() / 2])
}

fn run(args: &Args) -> Result<(), String> {
    use cellbih_cli::args::{Charges, set_charges};
    set_charges("partial_rebuild", Charges::builds_and(false, true));
    let base = args.rates.model(6, !args.no_sim)?;
    if args.from > args.to {
        return Err(format!(
            "--from {} is larger than --to {}",
            args.from, args.to
        ));
    }
    let progress = std::io::stderr().is_terminal();
    let cfg = BihConfig::default();
    let mut rows = Vec::new();
    for n in (args.from..=args.to).step_by(args.step as usize) {
        let n = n as usize;
        let scene = rtperf(n, args.seed);
        let anim = Animation::named("rtperf", &scene, args.frames as usize, args.seed)?;
        // A complete rebuild: median of five host builds; simulated once
        // (it is deterministic).
        let mut t: Vec<f64> = (0..5)
            .map(|_| {
                let s = Instant::now();
                std::hint::black_box(host::build(&scene, &cfg));
                s.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        t.sort_by(f64::total_cmp);
        let full_host = t[2];
        for method in [Method::Local, Method::Deep] {
            if progress {
                eprint!("{n:>7} triangles, {:<5}\r", method.name());
            }
            let (host, sah_ratio) =
                frames(&scene, &anim, &base.for_builder(BuilderKind::HOST), method)?;
            let sum = Summary::of(&host).ok_or("no frame moved anything")?;
            let median = median_partial_ms(&host);
            let mut row = json!({
                "triangles": n,
                "method": method.name(),
                "frames": sum.frames,
                "updates": sum.updates,
                "rebuilds": sum.rebuilds,
                "transformed": sum.transformed,
                "rebuilt": sum.rebuilt,
                "rebuilt_partial": mean_partial_rebuilt(&host),
                "sah_over_fresh": sah_ratio,
                "delta": sum.delta,
                "kept": sum.kept,
                "moved_slots": sum.moved_slots,
                "depth": sum.depth,
                "host_min_ms": sum.host_ms[0],
                "host_max_ms": sum.host_ms[1],
                "host_mean_ms": sum.host_ms[2],
                "host_median_partial_ms": median,
                "full_rebuild_host_ms": full_host,
                "partial_over_full": median.map(|m| m / full_host),
            });
            for (p, builder) in SIMULATED_BUILDERS.iter().filter(|_| !args.no_sim) {
                let full = (base.for_builder(*builder))
                    .with_tree(cfg)
                    .run(&scene)
                    .map_err(|e| e.to_string())?;
                let s = Summary::of(&frames(&scene, &anim, &base.for_builder(*builder), method)?.0)
                    .and_then(|s| s.simulated_ms);
                row[format!("{p}_min_ms")] = json!(s.map(|s| s[0]));
                row[format!("{p}_max_ms")] = json!(s.map(|s| s[1]));
                row[format!("{p}_mean_ms")] = json!(s.map(|s| s[2]));
                row[format!("full_rebuild_{p}_ms")] = json!(full.simulated.map(|s| s.run.ms));
            }
            rows.push(row);
        }
    }
    if progress {
        eprint!("{:40}\r", "");
    }

    let keys = [
        "triangles",
        "method",
        "frames",
        "updates",
        "rebuilds",
        "transformed",
        "rebuilt",
        "rebuilt_partial",
        "sah_over_fresh",
        "delta",
        "kept",
        "moved_slots",
        "depth",
        "host_min_ms",
        "host_max_ms",
        "host_mean_ms",
        "host_median_partial_ms",
        "full_rebuild_host_ms",
        "partial_over_full",
        "ppe_min_ms",
        "ppe_max_ms",
        "ppe_mean_ms",
        "full_rebuild_ppe_ms",
        "bfs_min_ms",
        "bfs_max_ms",
        "bfs_mean_ms",
        "full_rebuild_bfs_ms",
    ];
    let doc = json!({
        "rows": rows,
        "animation": "rtperf: one sphere (200 triangles) per frame, every fifth move marked only",
        "frames": args.frames, "seed": args.seed,
        "host": "host builder, one thread; full rebuild = median of 5",
        "simulated": "ppe_*: rebuilds on ppe_naive (the paper's update ran on the PPE), bfs_*: on spe_bfs; PS3 model, the PPE's share of each update included",
    });
    args.output.report(
        "partial_rebuild",
        (&keys, &rows),
        &doc,
        Some(&base.clone().with_tree(cfg)),
        print_table,
    )?;
    for method in ["local", "deep"] {
        plots(&args.output.out, method, &rows).map_err(|e| e.to_string())?;
    }
    cellbih_cli::report::result_set::say_written(format!(
        "written: {}/partial_rebuild.{{csv,json}}, fig3a_*.svg, fig3b_*.svg",
        args.output.out.display()
    ));
    Ok(())
}

/// The points (thousands of triangles, `key`) of `method`'s rows.
fn series(
    rows: &[Value],
    method: &str,
    key: &str,
    name: &str,
    color: usize,
    dashed: bool,
) -> Series {
    Series {
        name: name.into(),
        points: rows
            .iter()
            .filter(|r| r["method"] == method)
            .filter_map(|r| Some((r["triangles"].as_f64()? / 1e3, r[key].as_f64()?)))
            .collect(),
        color,
        dashed,
    }
}

fn plots(dir: &Path, method: &str, rows: &[Value]) -> Result<(), Box<dyn std::error::Error>> {
    let x = "number of triangles in thousands";
    let what = if method == "local" {
        "local update (Algorithm 1)"
    } else {
        "deeper update (section 5)"
    };
    line_plot(
        &output(dir, &format!("fig3a_{method}.svg"))?,
        &format!("Number of rebuilt triangles in scene \"rtPerf\", {what}"),
        x,
        "triangles (mean per frame)",
        &[
            series(rows, method, "transformed", "transformed", 0, false),
            series(rows, method, "rebuilt", "used for reconstruction", 1, false),
            series(rows, method, "delta", "delta", 2, true),
        ],
        false,
    )?;
    for (suffix, unit, p) in [
        ("", "host ms, one thread", "host"),
        (
            "_ppe",
            "simulated ms, PS3 model, rebuilds on the PPE (ppe_naive)",
            "ppe",
        ),
        (
            "_spe_bfs",
            "simulated ms, PS3 model, rebuilds on one SPE (spe_bfs)",
            "bfs",
        ),
    ] {
        let full = format!("full_rebuild_{p}_ms");
        let full = full.as_str();
        let s = [
            series(
                rows,
                method,
                &format!("{p}_min_ms"),
                "minimum time",
                0,
                false,
            ),
            series(
                rows,
                method,
                &format!("{p}_mean_ms"),
                "average time",
                1,
                false,
            ),
            series(
                rows,
                method,
                &format!("{p}_max_ms"),
                "maximum time",
                2,
                false,
            ),
            series(rows, method, full, "complete rebuild", 3, true),
        ];
        if s.iter().all(|s| s.points.is_empty()) {
            continue;
        }
        line_plot(
            &output(dir, &format!("fig3b_{method}{suffix}.svg"))?,
            &format!("Rebuild and update times for scene \"rtPerf\", {what}"),
            x,
            unit,
            &s,
            false,
        )?;
    }
    Ok(())
}

/// The rows in 80 columns: three tables (triangles per update, host times,
/// simulated times and tree quality), each row named by update and size.
fn print_table(rows: &[Value]) {
    let tables: [(&str, &[cellbih_cli::report::Column]); 3] = [
        (
            "triangles per update",
            &[
                ("full", "rebuilds", 0, 6),
                ("trans", "transformed", 0, 8),
                ("rec", "rebuilt", 0, 8),
                ("rec/part", "rebuilt_partial", 0, 9),
                ("delta", "delta", 0, 8),
                ("kept", "kept", 0, 8),
                ("depth", "depth", 1, 6),
            ],
        ),
        (
            "host ms (one thread)",
            &[
                ("min ms", "host_min_ms", 3, 9),
                ("mean ms", "host_mean_ms", 3, 9),
                ("max ms", "host_max_ms", 2, 9),
                ("rebuild", "full_rebuild_host_ms", 2, 9),
                ("med/full", "partial_over_full", 4, 9),
            ],
        ),
        (
            "simulated PS3 ms, and the tree",
            &[
                ("ppe mean", "ppe_mean_ms", 2, 9),
                ("ppe full", "full_rebuild_ppe_ms", 1, 9),
                ("bfs mean", "bfs_mean_ms", 3, 9),
                ("bfs full", "full_rebuild_bfs_ms", 2, 9),
                ("SAH", "sah_over_fresh", 3, 7),
            ],
        ),
    ];
    // The size as text, so that it leads each row.
    let rows: Vec<Value> = (rows.iter())
        .map(|r| {
            let mut r = r.clone();
            r["tris"] = Value::String(r["triangles"].to_string());
            r
        })
        .collect();
    let keys = [("update", "method", 6), ("tris", "tris", 8)];
    cellbih_cli::report::print_tables(&rows, &keys, &tables);
    let note = "rec: mean over all frames; rec/part: over partial updates only; med/full: \
                median partial update over a complete rebuild (host); SAH: last tree over a \
                fresh build";
    println!("{}", cellbih_cli::report::wrap(note, 80));
}
