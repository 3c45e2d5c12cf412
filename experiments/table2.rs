//! Table 2 of the paper: the local update on carVis and cupVis, beside the
//! paper's rows, and the deeper update of section 5 on the same frames.
//!
//! `cargo run --release --bin table2 -- [--format json] [--no-sim] [--out results]`
//!
//! The scenes are the procedural stand-ins `car` (22,152 triangles in 17
//! parts; the paper's carVis has 22,106) and `cup` (7,040 triangles, as
//! cupVis). They run as many frames as the paper's rows count (carVis
//! 383 + 112 = 495, cupVis 6 + 148 = 154). Times: host milliseconds (host
//! builder, one thread) and simulated milliseconds on the PS3 model with
//! every rebuild on the breadth-first SPE builder (the paper's times are
//! PS3 milliseconds). Writes table2.csv and table2.json.

use std::io::IsTerminal;
use std::path::PathBuf;

use clap::Parser;
use serde_json::{Value, json};

use cellbih::bih::BihConfig;
use cellbih::build::BuilderKind;
use cellbih::report::{output, write_json, write_rows_csv};
use cellbih::scene;
use cellbih::update::{Animation, Method, Summary, UpdateReport, Updater};

#[derive(Parser)]
struct Args {
    /// text (a table) or json (the rows).
    #[arg(long, default_value = "text")]
    format: String,
    /// Host times only: skip the emulated (simulated-time) runs.
    #[arg(long)]
    no_sim: bool,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Directory for table2.csv and table2.json.
    #[arg(long, default_value = "results")]
    out: PathBuf,
}

/// The paper's Table 2: scene, our stand-in and animation, then tris,
/// updates, rebuilds, ratio, tmin, tmax, t (ms), trans, rec, Δ, trav.
const PAPER: [(&str, &str, [f64; 11]); 2] = [
    (
        "carVis",
        "car",
        [
            22_106.0, 383.0, 112.0, 3.42, 0.48, 154.09, 69.71, 468.47, 7_549.25, 7_080.78, 2.22,
        ],
    ),
    (
        "cupVis",
        "cup",
        [
            7_040.0, 6.0, 148.0, 0.04, 26.89, 35.43, 29.1, 7_040.0, 7_040.0, 2_181.66, 0.0,
        ],
    ),
];

fn main() {
    let args = Args::parse();
    if let Err(e) = run(&args) {
        eprintln!("table2: {e}");
        std::process::exit(1);
    }
}

fn frames(
    scene: &scene::Scene,
    anim: &Animation,
    builder: BuilderKind,
    method: Method,
) -> Result<Vec<UpdateReport>, String> {
    let mut u = Updater::new(scene.clone(), builder, &BihConfig::default(), method)
        .map_err(|e| e.to_string())?;
    anim.frames
        .iter()
        .map(|m| u.step(m).map_err(|e| e.to_string()))
        .collect()
}

fn run(args: &Args) -> Result<(), String> {
    let progress = std::io::stderr().is_terminal();
    let mut rows = Vec::new();
    for (paper_name, spec, p) in PAPER {
        let s = scene::load(spec, None).map_err(|e| e.to_string())?;
        let anim = Animation::named(spec, &s, (p[1] + p[2]) as usize, args.seed)?;
        rows.push(json!({
            "scene": paper_name, "source": "paper (PS3)", "method": "local",
            "triangles": p[0], "updates": p[1], "rebuilds": p[2], "ratio": p[3],
            "tmin_ms": p[4], "tmax_ms": p[5], "t_ms": p[6],
            "trans": p[7], "rec": p[8], "delta": p[9], "trav": p[10],
        }));
        for method in [Method::Local, Method::Deep] {
            if progress {
                eprint!("{spec:>4} {:<5}\r", method.name());
            }
            let host = Summary::of(&frames(&s, &anim, BuilderKind::Host, method)?);
            let sim = if args.no_sim {
                None
            } else {
                Summary::of(&frames(&s, &anim, BuilderKind::SpeBfs, method)?).simulated_ms
            };
            rows.push(json!({
                "scene": paper_name, "source": format!("ours ({spec})"), "method": method.name(),
                "triangles": s.len(), "updates": host.updates, "rebuilds": host.rebuilds,
                "ratio": host.ratio,
                "tmin_ms": host.host_ms[0], "tmax_ms": host.host_ms[1], "t_ms": host.host_ms[2],
                "sim_tmin_ms": sim.map(|t| t[0]), "sim_tmax_ms": sim.map(|t| t[1]),
                "sim_t_ms": sim.map(|t| t[2]),
                "trans": host.transformed, "rec": host.rebuilt, "delta": host.delta,
                "trav": host.depth, "kept": host.kept,
            }));
        }
    }
    if progress {
        eprint!("{:40}\r", "");
    }
    let io = |e: std::io::Error| e.to_string();
    let keys = [
        "scene",
        "source",
        "method",
        "triangles",
        "updates",
        "rebuilds",
        "ratio",
        "tmin_ms",
        "tmax_ms",
        "t_ms",
        "sim_tmin_ms",
        "sim_tmax_ms",
        "sim_t_ms",
        "trans",
        "rec",
        "delta",
        "trav",
        "kept",
    ];
    write_rows_csv(&output(&args.out, "table2.csv").map_err(io)?, &keys, &rows).map_err(io)?;
    let doc = json!({
        "rows": rows,
        "note": "ours: t*_ms host (host builder, one thread), sim_t*_ms simulated PS3 ms with rebuilds on spe_bfs; paper: PS3 ms",
    });
    write_json(&output(&args.out, "table2.json").map_err(io)?, &doc).map_err(io)?;
    if args.format == "json" {
        println!(
            "{}",
            serde_json::to_string_pretty(&rows).map_err(|e| e.to_string())?
        );
    } else {
        print_table(&rows);
    }
    Ok(())
}

fn print_table(rows: &[Value]) {
    println!(
        "{:<7} {:<12} {:<6} {:>6} {:>5} {:>5} {:>6} {:>7} {:>8} {:>7} {:>8} {:>8} {:>8} {:>8} {:>8} {:>5}",
        "scene",
        "source",
        "method",
        "tris",
        "upd",
        "rebld",
        "ratio",
        "tmin",
        "tmax",
        "t",
        "sim t",
        "trans",
        "rec",
        "delta",
        "kept",
        "trav"
    );
    let f = |v: &Value, d: usize| v.as_f64().map_or("-".into(), |x| format!("{x:.d$}"));
    for r in rows {
        println!(
            "{:<7} {:<12} {:<6} {:>6} {:>5} {:>5} {:>6} {:>7} {:>8} {:>7} {:>8} {:>8} {:>8} {:>8} {:>8} {:>5}",
            r["scene"].as_str().unwrap_or(""),
            r["source"].as_str().unwrap_or(""),
            r["method"].as_str().unwrap_or(""),
            f(&r["triangles"], 0),
            f(&r["updates"], 0),
            f(&r["rebuilds"], 0),
            f(&r["ratio"], 2),
            f(&r["tmin_ms"], 3),
            f(&r["tmax_ms"], 2),
            f(&r["t_ms"], 3),
            f(&r["sim_t_ms"], 2),
            f(&r["trans"], 1),
            f(&r["rec"], 1),
            f(&r["delta"], 1),
            f(&r["kept"], 1),
            f(&r["trav"], 2),
        );
    }
    println!(
        "times in ms: paper = PS3; ours tmin/tmax/t = host (one thread), sim t = simulated PS3 (rebuilds on spe_bfs)"
    );
}
