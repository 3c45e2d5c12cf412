//! Memory modelled to the scene: each emulated builder's
//! main-memory footprint by purpose, in bytes per triangle, and the largest
//! `rtperf:N` it can build in a PS3's 256 MiB — predicted from two builds,
//! then verified: a build just under the prediction fits, one just over it
//! fails with the emulator's out-of-memory error naming the buffer.
//!
//! `cargo run --release --bin footprint -- [--out results]`
//!
//! Builds run in functional mode (no timing: memory does not depend on it)
//! on the PS3's six SPEs. Writes footprint.{csv,json}.
//!
//! The verification builds scenes of the predicted size on the host: the
//! emulated main memory they fill, and about 115 bytes a triangle besides
//! (the scene, the tree read back; measured: 859,704 KiB peak with
//! `ppe_naive`'s 5.35 M triangles at 51 bytes each in 256 MiB; 2 M
//! triangles: `spe_bfs` 166 bytes a triangle in all, `spe_bfs_shared` 228,
//! `spe_morton` 240, each under its footprint + 115). A prediction whose builds would need more
//! than `--host-memory-mib` (default: half of what the host has
//! available) is reported unverified, and says why, instead of running
//! the host out of memory.

use clap::Parser;
use serde_json::{Value, json};

use cellbih::cell::{CellConfig, CellError, CostModel};
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::procedural::rtperf;
use cellbih::spe::footprint::{Footprint, Purpose};
use cellbih_cli::report::OutputArgs;

#[derive(Parser)]
#[command(
    about = "Each emulated builder's main memory by purpose, and the largest rtperf:N it \
             builds in the emulated memory, predicted and verified (default run: about 30 s)",
    after_help = "What to expect: the default run (256 MiB) takes about 30 s and at most \
                  0.85 GB of host memory on a 2-core machine; both grow with --memory-mib \
                  (about 3.3 bytes of host memory per byte emulated, since the verification \
                  builds scenes that fill it). A verification that would take more host \
                  memory than --host-memory-mib is reported as not verified instead."
)]
struct Args {
    /// Main memory of the emulated Cell, MiB (the PS3 model has 256); from
    /// 1 (every builder fits one rtPerf sphere) to 4,096.
    #[arg(long, default_value_t = 256, value_parser = cellbih_cli::args::between::<u64, _>(1..=4096))]
    memory_mib: u64,
    /// Host memory the verification builds may use, MiB (default:
    /// half the host's available memory, /proc/meminfo).
    #[arg(long, value_parser = cellbih_cli::args::at_least_one::<u64>)]
    host_memory_mib: Option<u64>,
    #[command(flatten)]
    output: OutputArgs,
}

/// Host bytes a verification build takes per triangle of its scene beside
/// the emulated memory it fills (the module's note).
const HOST_BYTES_PER_TRIANGLE: f64 = 115.0;
/// The process itself (code, the fitting builds' heap), MiB.
const HOST_BASE_MIB: u64 = 64;

/// Half the host's available memory, MiB, if the host says.
fn host_budget_mib() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024 / 2)
}

/// The two sizes the prediction is fitted on.
const SMALL: usize = 50_000;
const LARGE: usize = 100_000;
/// The smallest rtPerf scene: one sphere.
const TINY: usize = 200;
/// The verification never builds more than this over the prediction (the
/// host memory it may take is judged at that size).
const OVER: f64 = 1.1;

fn main() {
    cellbih_cli::report::main("footprint", |a: &Args| &a.output, run);
}

/// The footprints the prediction is made from, for every emulated builder:
/// (builder, one sphere, SMALL, LARGE), built in a memory large enough for
/// them (a footprint does not depend on the memory's size). A `--memory-mib`
/// that cannot hold one sphere for some builder is an error that says the
/// smallest that works.
fn fit(mib: u64) -> Result<Vec<(BuilderKind, Footprint, Footprint, Footprint)>, String> {
    let mut cell = CellConfig::ps3();
    cell.cost = CostModel::functional();
    cell.main_memory_bytes = mib.max(256) << 20;
    let mut fits = Vec::new();
    for &b in BuilderKind::ALL.iter().filter(|b| b.emulated()) {
        progress(&format!("{b} ..."));
        let at = |n| footprint(b, n, &cell).map_err(|e| format!("{b}, rtperf:{n}: {e}"));
        fits.push((b, at(TINY)?, at(SMALL)?, at(LARGE)?));
    }
    let need = |f: &Footprint| f.total.div_ceil(1 << 20);
    let smallest = fits.iter().map(|(_, t, ..)| need(t)).max().unwrap_or(1);
    if let Some((b, t, ..)) = fits.iter().find(|(_, t, ..)| need(t) > mib) {
        return Err(format!(
            "--memory-mib {mib}: too small for any scene: {b} needs {} MiB for rtperf:{TINY} \
             (one sphere); the smallest --memory-mib that works for every builder is {smallest}",
            need(t)
        ));
    }
    Ok(fits)
}

fn run(args: &Args) -> Result<(), String> {
    let mut cell = CellConfig::ps3();
    cell.cost = CostModel::functional();
    cell.main_memory_bytes = args.memory_mib * 1024 * 1024;
    let budget = args.host_memory_mib.or_else(host_budget_mib);
    let mut rows = Vec::new();
    for (b, _, small, large) in fit(args.memory_mib)? {
        let per_tri = (large.total - small.total) as f64 / (LARGE - SMALL) as f64;
        let fixed = large.total as f64 - per_tri * LARGE as f64;
        let predicted =
            ((cell.main_memory_bytes as f64 - fixed) / per_tri).max(TINY as f64) as usize;
        // The largest build the bracket may try: OVER the prediction.
        let host_bytes = predicted as f64 * OVER * (per_tri + HOST_BYTES_PER_TRIANGLE);
        let host_mib = (host_bytes / 1048576.0).ceil() as u64 + HOST_BASE_MIB;
        let mut row = json!({
            "builder": b.name(), "bytes_per_triangle": per_tri, "fixed_bytes": fixed,
            "predicted_n": predicted, "memory_mib": args.memory_mib,
            "verify_host_mib": host_mib,
        });
        match budget {
            Some(budget) if host_mib > budget => {
                row["fits_n"] = Value::Null;
                row["fails_n"] = Value::Null;
                row["oom_buffer"] = Value::Null;
                row["not_verified"] = json!(format!(
                    "building rtperf:{predicted} on the host needs about {host_mib} MiB; {budget} MiB may be used (--host-memory-mib)"
                ));
            }
            _ => {
                let (fits, failed) = verify(b, predicted, &cell)?;
                row["fits_n"] = json!(fits);
                row["fails_n"] = json!(failed.as_ref().map(|f| f.0));
                row["oom_buffer"] = json!(failed.map(|f| f.1));
            }
        }
        for p in Purpose::ALL {
            let slope = (large.bytes(p) as f64 - small.bytes(p) as f64) / (LARGE - SMALL) as f64;
            row[format!("per_triangle_{}", key(p))] = json!(slope);
        }
        let unused = large.unused_node_bytes as f64 - small.unused_node_bytes as f64;
        row["unused_node_bytes_per_triangle"] = json!(unused / (LARGE - SMALL) as f64);
        rows.push(row);
    }
    progress("");

    let mut keys = vec![
        "builder",
        "bytes_per_triangle",
        "fixed_bytes",
        "predicted_n",
        "fits_n",
        "fails_n",
        "oom_buffer",
        "not_verified",
    ];
    let purposes: Vec<String> = Purpose::ALL
        .iter()
        .map(|&p| format!("per_triangle_{}", key(p)))
        .collect();
    keys.extend(purposes.iter().map(String::as_str));
    keys.push("unused_node_bytes_per_triangle");
    let doc = json!({ "rows": rows, "note": "bytes of emulated main memory per triangle of rtperf, by purpose (fitted on rtperf:50000 and rtperf:100000); fits_n builds, fails_n runs out of memory naming oom_buffer" });
    args.output.report(
        "footprint",
        (&keys, &rows),
        &doc,
        Some(&Build::new(BuilderKind::HOST).on(&cell)),
        |r| print_table(r, args.memory_mib),
    )?;
    Ok(())
}

fn key(p: Purpose) -> &'static str {
    match p {
        Purpose::TriangleRecords => "records",
        Purpose::WorkPpe => "work_ppe",
        Purpose::JobQueues => "job_queues",
        Purpose::Nodes => "nodes",
        Purpose::KeysAndSort => "keys",
    }
}

/// The footprint of building `rtperf:n` with `b`.
fn footprint(b: BuilderKind, n: usize, cell: &CellConfig) -> Result<Footprint, CellError> {
    let r = Build::new(b).on(cell).run(&rtperf(n, 1))?;
    Ok(r.simulated.expect("an emulated builder").footprint)
}

/// Brackets the largest `rtperf:N` that fits around `predicted`: the
/// largest size tried that built, the smallest that ran out of memory, and
/// the buffer the error named; never above OVER the prediction (then the
/// failing size is `None`: the prediction is too low). Sizes are rounded to
/// whole rtPerf spheres.
fn verify(
    b: BuilderKind,
    predicted: usize,
    cell: &CellConfig,
) -> Result<(usize, Option<(usize, String)>), String> {
    let sphere = |n: f64| ((n / 200.0).round() as usize).max(1) * 200;
    let try_n = |n: usize| -> Result<Option<String>, String> {
        progress(&format!("{b} rtperf:{n} ..."));
        match footprint(b, n, cell) {
            Ok(_) => Ok(None),
            Err(CellError::OutOfMemory { what, .. }) => Ok(Some(what)),
            Err(e) => Err(format!("{b}, rtperf:{n}: {e}")),
        }
    };
    let cap = sphere(predicted as f64 * OVER);
    let (mut lo, mut hi) = (
        sphere(predicted as f64 * 0.98),
        sphere(predicted as f64 * 1.02),
    );
    while lo > 200 && try_n(lo)?.is_some() {
        // At least a sphere less (0.9 × a few spheres rounds back).
        (hi, lo) = (lo, sphere(lo as f64 * 0.9).min(lo - 200));
    }
    loop {
        match try_n(hi)? {
            Some(what) => return Ok((lo, Some((hi, what)))),
            None if hi >= cap => return Ok((hi, None)),
            None => (lo, hi) = (hi, sphere(hi as f64 * 1.05).min(cap)),
        }
    }
}

/// One line of progress on stderr, when it is a terminal.
/// What the run is doing, on stderr: over itself on a terminal; a line
/// of its own, with the time so far, anywhere else (a log, CI).
fn progress(what: &str) {
    use std::io::IsTerminal;
    static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    let start = START.get_or_init(std::time::Instant::now);
    if std::io::stderr().is_terminal() {
        eprint!("{:60}\r{what}", "");
    } else if !what.is_empty() {
        eprintln!("footprint: {what} ({:.0} s)", start.elapsed().as_secs_f64());
    }
}

fn print_table(rows: &[Value], mib: u64) {
    // Two tables of 80 columns: bytes a triangle by purpose, then the
    // largest scene that fits.
    println!(
        "{:<16} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7}",
        "builder", "B/tri", "records", "WorkPPE", "queues", "nodes", "unused", "keys",
    );
    let f = |r: &Value, k: &str| r[k].as_f64().unwrap_or(0.0);
    let name = |r: &Value| r["builder"].as_str().unwrap_or("").to_string();
    for r in rows {
        println!(
            "{:<16} {:>7.1} {:>7.1} {:>7.1} {:>7.1} {:>7.1} {:>7.1} {:>7.1}",
            name(r),
            f(r, "bytes_per_triangle"),
            f(r, "per_triangle_records"),
            f(r, "per_triangle_work_ppe"),
            f(r, "per_triangle_job_queues"),
            f(r, "per_triangle_nodes"),
            f(r, "unused_node_bytes_per_triangle"),
            f(r, "per_triangle_keys"),
        );
    }
    println!(
        "\n{:<16} {:>10} {:>10} {:>10}  buffer named",
        "builder", "predicted", "builds", "OOM at",
    );
    for r in rows {
        let columns = format!(
            "{:<16} {:>10} {:>10} {:>10}  ",
            name(r),
            r["predicted_n"].as_u64().unwrap_or(0),
            r["fits_n"].as_u64().map_or("—".into(), |n| n.to_string()),
            r["fails_n"].as_u64().map_or("—".into(), |n| n.to_string()),
        );
        let buffer = match (r["fits_n"].is_null(), r["oom_buffer"].as_str()) {
            (true, _) => "(not verified)",
            (false, Some(b)) => b,
            (false, None) => "(none up to 1.1x the prediction)",
        };
        // The buffer's words wrapped in its own column.
        let width = columns.chars().count();
        let text = cellbih_cli::report::wrap(buffer, 80 - width);
        println!(
            "{columns}{}",
            text.replace('\n', &format!("\n{:width$}", ""))
        );
    }
    for r in rows {
        if let Some(why) = r["not_verified"].as_str() {
            let line = format!("{}: not verified: {why}", name(r));
            println!("{}", cellbih_cli::report::wrap(&line, 80));
        }
    }
    let note = format!(
        "bytes of main memory per triangle of rtperf by purpose (fitted on rtperf:{SMALL} and rtperf:{LARGE}; \
         unused: node slots never written, within nodes); the largest rtperf:N in {mib} MiB: predicted, \
         the largest size that built, the smallest that ran out of memory and the buffer it named (6 SPEs, functional mode)"
    );
    println!("{}", cellbih_cli::report::wrap(&note, 80));
}
