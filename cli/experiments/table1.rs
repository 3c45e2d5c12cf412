//! Table 1 of the paper: the four builders on the PS3 model, for the four
//! models, beside the paper's figures.
//!
//! `cargo run --release --bin table1 -- --data DIR [--format json] [--threads N] [--out results]`
//!
//! Bunny and dragon come from the data directory. The paper's ISS (17,633
//! triangles) and Fairy Forest (174,117) are used when the data directory
//! holds them with exactly those counts (`iss.obj.gz`, `fairyforest.obj.gz`);
//! otherwise an rtPerf stand-in of the same triangle count is used, and the
//! output says so. Times are simulated milliseconds (deterministic); the host
//! time the emulation took is reported beside them. Writes table1.csv and
//! table1.json to the output directory.
//!
//! `--fits`: each of the calibration's two fitted rates refitted on every
//! real-mesh cell of its column (table1_fits.csv, .json): the spread of
//! its fits is the band `cellbih rates` shows and `sensitivity` sweeps.
//! The rates themselves stay as fitted (`docs/calibration.md`).

use clap::Parser;
use serde_json::json;

use cellbih::bih::BihConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{self, Scene};
use cellbih_cli::args::DataArg;
use cellbih_cli::args::{RateArgs, RunArgs};
use cellbih_cli::report::side_by_side;

#[derive(Parser)]
#[command(
    about = "Table 1: the paper's four builders (and section 5's) on the paper's models, simulated PS3 ms (default run: a few seconds)"
)]
struct Args {
    #[command(flatten)]
    data: DataArg,
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    rates: RateArgs,
    /// Instead of the table: refit each fitted rate (the naive PPE
    /// build's partition, the baseline's) on every real-mesh cell of its
    /// column, the spread the rate's band is set from (a few seconds)
    #[arg(long)]
    fits: bool,
}

/// The calibration's fitted rates and the column each is fitted in
/// (`docs/calibration.md`): the rate's name and that column's place in
/// [`METHODS`].
const FITTED: [(&str, usize); 2] = [("ppe_partition_item", 0), ("spe_partition_item", 3)];

/// The paper's Table 1: model, triangles, file name, milliseconds for
/// naive / approximate sorting / SPE depth first / SPE breadth first
/// (`None`: out of memory).
const PAPER: [(&str, usize, &str, [Option<f64>; 4]); 4] = [
    (
        "ISS",
        17_633,
        "iss",
        [Some(106.0), Some(63.0), Some(47.0), Some(24.0)],
    ),
    (
        "Bunny",
        69_451,
        "bunny",
        [Some(340.0), Some(201.0), Some(133.0), Some(68.0)],
    ),
    (
        "Fairy Forest",
        174_117,
        "fairyforest",
        [Some(1478.0), Some(781.0), Some(385.0), Some(195.0)],
    ),
    (
        "Dragon",
        871_414,
        "dragon",
        [Some(5956.0), None, Some(1828.0), Some(897.0)],
    ),
];

const METHODS: [BuilderKind; 4] = [
    BuilderKind::PPE_NAIVE,
    BuilderKind::PPE_APPROX,
    BuilderKind::SPE_DFS,
    BuilderKind::SPE_BFS,
];

/// The model's mesh, or a stand-in of the same triangle count.
fn model(
    name: &str,
    count: usize,
    file: &str,
    data: Option<&std::path::Path>,
) -> Result<(Scene, Option<String>), String> {
    if let Some(dir) = data
        && let Ok(s) = scene::load(file, Some(dir))
        && s.len() == count
    {
        return Ok((s, None));
    }
    if file == "bunny" || file == "dragon" {
        return Err(format!(
            "{name} needs the data directory (--data DIR or CELLBIH_DATA) with {file}.obj.gz"
        ));
    }
    let spec = format!("rtperf:{count}");
    let s = scene::load(&spec, None).map_err(|e| e.to_string())?;
    Ok((s, Some(spec)))
}

fn main() {
    cellbih_cli::report::main("table1", |a: &Args| &a.run.output, run);
}

fn run(args: &Args) -> Result<(), String> {
    use cellbih_cli::args::{Charges, set_charges};
    set_charges("table1", Charges::builds_and(false, false));
    args.run.threads.install()?;
    let cfg = BihConfig::default();
    let mut models = Vec::new();
    for (name, count, file, paper) in PAPER {
        let (scene, stand_in) = model(name, count, file, args.data.dir().as_deref())?;
        if let Some(spec) = &stand_in {
            eprintln!(
                "{name}: not in the data directory; stand-in `{spec}` ({})",
                cellbih_cli::report::count(count as u64, "triangle")
            );
        }
        models.push((name, scene, stand_in, paper));
    }
    // The paper's four methods on the PS3 (6 SPEs: the multi-SPE builders
    // use them all), and section 5's strategies beside them (the paper has
    // no figure for them): every build side by side.
    let (six, rates) = args.rates.ps3(6)?;
    if args.fits {
        return fits(args, &models, &six, &rates);
    }
    let builders: Vec<BuilderKind> = (METHODS.iter().copied())
        .chain(BuilderKind::ALL.iter().copied().filter(|b| b.multi_spe()))
        .collect();
    let jobs: Vec<(usize, usize)> = (0..models.len())
        .flat_map(|mi| (0..builders.len()).map(move |bi| (mi, bi)))
        .collect();
    let done = side_by_side("builds", &jobs, |&(mi, bi)| {
        let (name, scene, ..) = &models[mi];
        let b = builders[bi];
        let r = Build::new(b)
            .with_tree(cfg)
            .on(&six)
            .with_rates(&rates)
            .run(scene)
            .map_err(|e| format!("{name}, {b}: {e}"))?;
        let sim = r
            .simulated
            .expect("every Table 1 method runs on the emulated Cell");
        let mib = sim.footprint.total as f64 / MIB;
        Ok::<_, String>((
            sim.run.ms,
            mib,
            r.host_time.as_secs_f64() * 1e3,
            r.bih.nodes.len(),
        ))
    });
    let mut rows = Vec::new();
    let mut naive_ms = None;
    for (&(mi, bi), done) in jobs.iter().zip(done) {
        let (name, scene, stand_in, paper) = &models[mi];
        let (ms, mib, host_ms, nodes) = done?;
        if bi == 0 {
            naive_ms = Some(ms);
        }
        let naive = naive_ms.expect("the naive build is each model's first");
        let paper_naive = paper[0].expect("the paper's naive figure");
        let (method, paper_ms) = match bi < METHODS.len() {
            true => (builders[bi].name().to_string(), paper[bi]),
            false => (format!("{} (6 SPEs)", builders[bi].name()), None),
        };
        rows.push(json!({
            "model": name,
            "triangles": scene.len(),
            "stand_in": stand_in,
            "method": method,
            "simulated_ms": ms,
            "paper_ms": paper_ms,
            "ratio": paper_ms.map(|p| ms / p),
            "speedup": naive / ms,
            "paper_speedup": paper_ms.map(|p| paper_naive / p),
            "host_ms": host_ms,
            "nodes": nodes,
            "memory_mib": mib,
        }));
    }

    let doc = json!({ "rows": rows, "note": "simulated_ms on the PS3 model; paper_ms null = out of memory in the paper" });
    args.run.output.report(
        "table1",
        (
            &[
                "model",
                "triangles",
                "stand_in",
                "method",
                "simulated_ms",
                "paper_ms",
                "ratio",
                "speedup",
                "paper_speedup",
                "host_ms",
                "memory_mib",
            ],
            &rows,
        ),
        &doc,
        Some(
            &Build::new(BuilderKind::HOST)
                .with_tree(cfg)
                .on(&six)
                .with_rates(&rates),
        ),
        print_table,
    )?;
    Ok(())
}

/// A model of the table: its name, scene, stand-in spec and the paper's
/// milliseconds.
type Model<'a> = (&'a str, Scene, Option<String>, [Option<f64>; 4]);

/// `--fits`: each fitted rate refitted on every real-mesh cell of its
/// column. A build's time is close to linear in the rate: two builds (at
/// the rate and at a quarter more) give the line, its value at the
/// paper's milliseconds the fit (whole cycles), a third build the time
/// at the fit.
fn fits(
    args: &Args,
    models: &[Model],
    six: &cellbih::cell::CellConfig,
    rates: &cellbih::kernels::rates::RateOverrides,
) -> Result<(), String> {
    if rates.code() != cellbih::kernels::rates::Code::Paper {
        return Err(format!(
            "--fits refits the paper class's fitted rates; with --code {} the SPU partition is derived, not fitted",
            rates.code()
        ));
    }
    let cfg = BihConfig::default();
    let every = BuilderKind::every_rate(rates.code());
    let cells: Vec<(&str, usize, usize)> = (FITTED.iter())
        .flat_map(|&(rate, column)| {
            (models.iter().enumerate())
                .filter(move |(_, m)| m.2.is_none() && m.3[column].is_some())
                .map(move |(mi, _)| (rate, column, mi))
        })
        .collect();
    let done = side_by_side("fits", &cells, |&(rate, column, mi)| {
        let (name, scene, _, paper) = &models[mi];
        // The rate in force: as fitted, or as --rate moved it.
        let value = (every.iter().find(|r| r.name == rate))
            .map(|r| rates.get(rate).unwrap_or(r.value))
            .ok_or(format!("no rate named {rate}"))?;
        let ms = |cycles: u64| {
            let moved = rates.with(rate, cellbih::cell::Cycles(cycles));
            Build::new(METHODS[column])
                .with_tree(cfg)
                .on(six)
                .with_rates(&moved)
                .run(scene)
                .map_err(|e| format!("{name}, {}: {e}", METHODS[column]))
                .map(|r| r.simulated.expect("an emulated build").run.ms)
        };
        let step = (value.0 / 4).max(1);
        let (at_value, at_step) = (ms(value.0)?, ms(value.0 + step)?);
        let per_cycle = (at_step - at_value) / step as f64;
        let paper_ms = paper[column].expect("a cell with a figure");
        let fit = (value.0 as f64 + (paper_ms - at_value) / per_cycle).round() as u64;
        Ok::<_, String>(json!({
            "rate": rate, "model": name, "method": METHODS[column].name(),
            "paper_ms": paper_ms, "value": value.0, "ms_at_value": at_value,
            "fit": fit, "ms_at_fit": ms(fit)?,
        }))
    });
    let rows: Vec<serde_json::Value> = done.into_iter().collect::<Result<_, _>>()?;
    args.run.output.report(
        "table1_fits",
        (
            &["rate", "model", "method", "paper_ms", "value", "ms_at_value", "fit", "ms_at_fit"],
            &rows,
        ),
        &json!({ "rows": rows, "note": "each fitted rate refitted on each real-mesh cell of its column; the rates stay as fitted" }),
        Some(&Build::new(BuilderKind::HOST).with_tree(cfg).on(six).with_rates(rates)),
        print_fits,
    )
}

/// The fits' table: a row a cell, then each rate's spread.
fn print_fits(rows: &[serde_json::Value]) {
    println!(
        "{:<20} {:<6} {:<10} {:>9} {:>6} {:>9} {:>5} {:>9}",
        "rate", "model", "method", "paper ms", "value", "ms", "fit", "ms at fit"
    );
    for r in rows {
        println!(
            "{:<20} {:<6} {:<10} {:>9.0} {:>6} {:>9.1} {:>5} {:>9.1}",
            r["rate"].as_str().unwrap_or(""),
            r["model"].as_str().unwrap_or(""),
            r["method"].as_str().unwrap_or(""),
            r["paper_ms"].as_f64().unwrap_or(0.0),
            r["value"].as_u64().unwrap_or(0),
            r["ms_at_value"].as_f64().unwrap_or(0.0),
            r["fit"].as_u64().unwrap_or(0),
            r["ms_at_fit"].as_f64().unwrap_or(0.0),
        );
    }
    for (rate, _) in FITTED {
        let of_rate = || rows.iter().filter(|r| r["rate"] == rate);
        let fits: Vec<u64> = of_rate().filter_map(|r| r["fit"].as_u64()).collect();
        let value = of_rate().find_map(|r| r["value"].as_u64());
        if let (Some(lo), Some(hi), Some(v)) = (fits.iter().min(), fits.iter().max(), value) {
            println!(
                "{rate}: fits {lo}-{hi}; with the value as fitted, {}-{} (its band)",
                lo.min(&v),
                hi.max(&v)
            );
        }
    }
    println!(
        "{}",
        cellbih_cli::report::wrap(
            "Simulated PS3 ms on the default model; value: the rate as fitted (it stays); fit: the rate that would meet the paper's cell, from two builds (the line through the rate and a quarter more); ms at fit: a third build there.",
            80
        )
    );
}

/// Bytes per MiB, for the footprint column (main memory in use at the
/// end of the build: every buffer by purpose, see `cellbih build`).
const MIB: f64 = 1024.0 * 1024.0;

fn print_table(rows: &[serde_json::Value]) {
    // Two tables of 80 columns: the times beside the paper's, then the
    // ratio, the host's time, the memory and the triangles. Each row is
    // led by its model
    // (on its first row) and method.
    let mut last = "";
    let leads: Vec<String> = (rows.iter())
        .map(|r| {
            let model = r["model"].as_str().unwrap_or("");
            let label = if model != last {
                last = model;
                let star = if r["stand_in"].is_null() { "" } else { "*" };
                format!("{model}{star}")
            } else {
                String::new()
            };
            format!("{label:<13} {:<24}", r["method"].as_str().unwrap_or(""))
        })
        .collect();
    // No paper figure: out of memory for the paper's methods; the
    // multi-SPE strategies are not in the paper.
    let opt = |r: &serde_json::Value, k: &str, w: usize, p: usize| {
        let paper_method = METHODS.iter().any(|m| r["method"] == m.name());
        match r[k].as_f64() {
            Some(v) => format!("{v:>w$.p$}"),
            None if paper_method => format!("{:>w$}", "OOM"),
            None => format!("{:>w$}", "—"),
        }
    };
    // A table: its header, then each row's lead and cells.
    let table = |head: String, cells: &dyn Fn(&serde_json::Value) -> String| {
        println!("{head}");
        for (r, lead) in rows.iter().zip(&leads) {
            println!("{lead} {}", cells(r));
        }
    };
    let f = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap_or(0.0);
    table(
        format!(
            "{:<13} {:<24} {:>10} {:>10} {:>7} {:>7}",
            "model", "method", "ours (ms)", "paper (ms)", "speedup", "paper"
        ),
        &|r| {
            let (ms, paper) = (f(r, "simulated_ms"), opt(r, "paper_ms", 10, 0));
            let (speedup, paper_speedup) = (f(r, "speedup"), opt(r, "paper_speedup", 7, 2));
            format!("{ms:>10.1} {paper} {speedup:>7.2} {paper_speedup}")
        },
    );
    println!();
    table(
        format!(
            "{:<13} {:<24} {:>10} {:>9} {:>8} {:>9}",
            "model", "method", "ours/paper", "host (ms)", "MiB", "triangles"
        ),
        &|r| {
            let (ratio, host, mib) = (opt(r, "ratio", 10, 2), f(r, "host_ms"), f(r, "memory_mib"));
            let n = r["triangles"].as_u64().unwrap_or(0);
            format!("{ratio} {host:>9.0} {mib:>8.1} {n:>9}")
        },
    );
    let wrap = |text: &str| println!("{}", cellbih_cli::report::wrap(text, 80));
    let mut models: Vec<&str> = rows.iter().filter_map(|r| r["model"].as_str()).collect();
    models.dedup();
    for name in models {
        let model: Vec<&serde_json::Value> = rows
            .iter()
            .filter(|r| r["model"] == name)
            .filter(|r| METHODS.iter().any(|m| r["method"] == m.name()))
            .collect();
        let ms: Vec<f64> = model
            .iter()
            .map(|r| r["simulated_ms"].as_f64().unwrap_or(0.0))
            .collect();
        let ordered = ms.windows(2).all(|w| w[0] > w[1]);
        wrap(&format!(
            "{}: {}",
            model[0]["model"].as_str().unwrap_or(""),
            if ordered {
                "the paper's order (naive > approximate > depth first > breadth first)"
            } else {
                "NOT the paper's order"
            }
        ));
    }
    if rows.iter().any(|r| !r["stand_in"].is_null()) {
        wrap(
            "* stand-in: an rtPerf scene of the model's triangle count (the model is not in the data directory)",
        );
    }
    wrap(
        "OOM: the paper's build ran out of memory; —: not in the paper (section 5's strategies, on 6 SPEs). Simulated ms are deterministic; host ms is the emulation's wall time, one thread; MiB: the build's main memory (every buffer; by purpose: cellbih build).",
    );
}
