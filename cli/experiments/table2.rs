//! Table 2 of the paper: the local update on carVis and cupVis, beside the
//! paper's rows, and the deeper update of section 5 on the same frames.
//!
//! `cargo run --release --bin table2 -- [--format json] [--no-sim] [--out results]`
//!
//! The scenes are the procedural stand-ins `car` (22,152 triangles: a body
//! and 18 movable parts; the paper's carVis has 22,106) and `cup` (7,040 triangles, as
//! cupVis). They run as many frames as the paper's rows count (carVis
//! 383 + 112 = 495, cupVis 6 + 148 = 154). Times: host milliseconds (host
//! builder, one thread) and simulated milliseconds on the PS3 model with the
//! rebuilds on the PPE (`ppe_naive`; the paper's update ran on the PPE,
//! section 3) and on one SPE (`spe_bfs`, the baseline). The paper's times
//! are PS3 milliseconds. Writes table2.csv and table2.json.

use std::io::IsTerminal;

use clap::Parser;
use serde_json::{Value, json};

use cellbih::registry::{Build, BuilderKind};
use cellbih::scene;
use cellbih::update::{Animation, Method, SIMULATED_BUILDERS, Summary, UpdateReport, play};
use cellbih_cli::args::RateArgs;
use cellbih_cli::report::OutputArgs;

#[derive(Parser)]
#[command(
    about = "Table 2: the paper's local update on the car and the cup, host and simulated PS3 times (default run: about 8 s)"
)]
struct Args {
    /// Host times only: skip the emulated (simulated-time) runs.
    #[arg(long)]
    no_sim: bool,
    /// Seed of the animations' pseudo-random moves.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[command(flatten)]
    output: OutputArgs,
    #[command(flatten)]
    rates: RateArgs,
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
    cellbih_cli::report::main("table2", |a: &Args| &a.output, run);
}

/// The summary of `anim` played on a fresh updater.
fn summary(
    s: &scene::Scene,
    anim: &Animation,
    build: &Build,
    method: Method,
) -> Result<Summary, String> {
    let reports: Vec<UpdateReport> = play(s, anim, build, method).map_err(|e| e.to_string())?.1;
    Summary::of(&reports).ok_or_else(|| format!("{}: no frame moved anything", anim.name))
}

fn run(args: &Args) -> Result<(), String> {
    use cellbih_cli::args::{Charges, set_charges};
    set_charges("table2", Charges::builds_and(false, true));
    let base = args.rates.model(6, !args.no_sim)?;
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
            let host = summary(&s, &anim, &base.for_builder(BuilderKind::HOST), method)?;
            let mut row = json!({
                "scene": paper_name, "source": format!("ours ({spec})"), "method": method.name(),
                "triangles": s.len(), "updates": host.updates, "rebuilds": host.rebuilds,
                "ratio": host.ratio,
                "tmin_ms": host.host_ms[0], "tmax_ms": host.host_ms[1], "t_ms": host.host_ms[2],
                "trans": host.transformed, "rec": host.rebuilt, "delta": host.delta,
                "trav": host.depth, "kept": host.kept,
            });
            for (p, builder) in SIMULATED_BUILDERS.iter().filter(|_| !args.no_sim) {
                let t = summary(&s, &anim, &base.for_builder(*builder), method)?.simulated_ms;
                row[format!("{p}_tmin_ms")] = json!(t.map(|t| t[0]));
                row[format!("{p}_tmax_ms")] = json!(t.map(|t| t[1]));
                row[format!("{p}_t_ms")] = json!(t.map(|t| t[2]));
            }
            rows.push(row);
        }
    }
    if progress {
        eprint!("{:40}\r", "");
    }

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
        "ppe_tmin_ms",
        "ppe_tmax_ms",
        "ppe_t_ms",
        "bfs_tmin_ms",
        "bfs_tmax_ms",
        "bfs_t_ms",
        "trans",
        "rec",
        "delta",
        "trav",
        "kept",
    ];
    let doc = json!({
        "rows": rows,
        "note": "ours: t*_ms host (host builder, one thread); ppe_t*_ms / bfs_t*_ms simulated PS3 ms with the rebuilds on ppe_naive / spe_bfs; paper: PS3 ms (its update ran on the PPE)",
    });
    args.output
        .report("table2", (&keys, &rows), &doc, Some(&base), print_table)?;
    Ok(())
}

/// The rows in 80 columns: three tables (updates and host times, simulated
/// times, triangles per update), each row named by scene, source and method.
fn print_table(rows: &[Value]) {
    // (title, [(header, key, decimals, width)])
    let tables: [(&str, &[cellbih_cli::report::Column]); 3] = [
        (
            "updates and times (ms; ours on the host)",
            &[
                ("tris", "triangles", 0, 6),
                ("upd", "updates", 0, 5),
                ("rebld", "rebuilds", 0, 5),
                ("ratio", "ratio", 2, 5),
                ("host tmin", "tmin_ms", 3, 9),
                ("host tmax", "tmax_ms", 2, 9),
                ("host t", "t_ms", 3, 7),
            ],
        ),
        (
            "simulated PS3 times (ms)",
            &[
                ("ppe tmin", "ppe_tmin_ms", 2, 7),
                ("ppe tmax", "ppe_tmax_ms", 2, 7),
                ("ppe t", "ppe_t_ms", 2, 7),
                ("bfs t", "bfs_t_ms", 2, 7),
            ],
        ),
        (
            "triangles per update",
            &[
                ("trans", "trans", 1, 7),
                ("rec", "rec", 1, 7),
                ("delta", "delta", 1, 7),
                ("kept", "kept", 1, 7),
                ("trav", "trav", 2, 7),
            ],
        ),
    ];
    let keys = [
        ("scene", "scene", 6),
        ("source", "source", 11),
        ("method", "method", 6),
    ];
    cellbih_cli::report::print_tables(rows, &keys, &tables);
    println!(
        "{}",
        cellbih_cli::report::wrap(
            "ms: paper = PS3 (update on the PPE); ours host tmin/tmax/t = one host thread; ppe/bfs = \
             simulated PS3 with the rebuilds on ppe_naive/spe_bfs",
            80
        )
    );
}
