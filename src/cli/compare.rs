//! `cellbih compare`: every builder side by side on one scene — simulated
//! time on the PS3 model and speedup over the single-SPE baseline
//! `spe_bfs`, host time, SAH, measured ray cost (primary rays of the render
//! camera, one host thread) and the tree's memory. The demo (`cellbih` with
//! no arguments) is this on the embedded default scene.

use std::io::IsTerminal;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;

use cellbih::bih::{BihConfig, RayStats, Tracer};
use cellbih::build::{BuildReport, BuilderKind};
use cellbih::cell::CellConfig;
use cellbih::render::Camera;
use cellbih::scene::Scene;
use cellbih::strategy::Knobs;

use super::Format;

/// One builder's row.
pub struct Row {
    pub builder: BuilderKind,
    pub host_ms: f64,
    pub simulated_ms: Option<f64>,
    pub nodes: usize,
    pub depth: u32,
    pub sah: f64,
    /// Per primary ray: nodes visited, triangles tested.
    pub ray_nodes: f64,
    pub ray_triangles: f64,
    pub mrays: f64,
    pub tree_bytes: usize,
}

/// Builds `s` with every builder on a Cell of `cell`, checks each tree and
/// casts the camera's rays (`width` x `height`) through it; returns the rows
/// and the last build. Progress on stderr when it is a terminal.
pub fn rows(
    s: &Scene,
    cell: &CellConfig,
    width: u32,
    height: u32,
) -> Result<(Vec<Row>, BuildReport), Box<dyn std::error::Error>> {
    let bar = if std::io::stderr().is_terminal() {
        let bar = ProgressBar::new(BuilderKind::ALL.len() as u64);
        bar.set_style(ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}")?);
        bar
    } else {
        ProgressBar::hidden()
    };
    let cam = Camera::framing(&s.bounds(), width, height);
    let rays = cam.rays();
    let mut out = Vec::new();
    let mut last = None;
    for &b in BuilderKind::ALL {
        bar.set_message(b.name());
        let cfg = BihConfig::default();
        let r = b.build_with(s, s.bounds(), &cfg, cell, &Knobs::default())?;
        r.bih.validate(s)?;
        let q = r.bih.quality();
        let tracer = Tracer::new(&r.bih, s);
        let start = Instant::now();
        let mut st = RayStats::default();
        for ray in &rays {
            tracer.closest(ray, &mut st);
        }
        let secs = start.elapsed().as_secs_f64();
        let per = |v: u64| v as f64 / st.rays.max(1) as f64;
        out.push(Row {
            builder: b,
            host_ms: r.host_time.as_secs_f64() * 1e3,
            simulated_ms: r.simulated.as_ref().map(|m| m.run.ms),
            nodes: q.nodes,
            depth: q.max_depth,
            sah: q.sah_cost,
            ray_nodes: per(st.nodes_visited),
            ray_triangles: per(st.triangles_tested),
            mrays: rays.len() as f64 / secs / 1e6,
            tree_bytes: q.memory_bytes,
        });
        last = Some(r);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok((out, last.expect("at least one builder")))
}

/// The baseline's simulated ms, for speedups.
fn baseline_ms(rows: &[Row]) -> Option<f64> {
    let base = rows.iter().find(|r| r.builder == BuilderKind::SPE_BFS)?;
    base.simulated_ms
}

/// Prints the rows as a table or as JSON.
pub fn print(s: &Scene, spes: usize, rows: &[Row], format: Format) {
    let base = baseline_ms(rows);
    let speedup = |r: &Row| Some(base? / r.simulated_ms?);
    if let Format::Json = format {
        let rows: Vec<_> = (rows.iter())
            .map(|r| {
                json!({
                    "builder": r.builder.name(), "host_ms": r.host_ms,
                    "simulated_ms": r.simulated_ms, "speedup_over_spe_bfs": speedup(r),
                    "nodes": r.nodes, "depth": r.depth, "sah_cost": r.sah,
                    "ray_nodes": r.ray_nodes, "ray_triangles": r.ray_triangles,
                    "mrays_per_s": r.mrays, "tree_bytes": r.tree_bytes,
                })
            })
            .collect();
        let doc = json!({ "scene": s.name, "triangles": s.len(), "spes": spes, "rows": rows });
        println!("{doc}");
        return;
    }
    let w = BuilderKind::ALL
        .iter()
        .map(|b| b.name().len())
        .max()
        .unwrap_or(0);
    println!(
        "{:<w$} {:>9} {:>8} {:>8} {:>8} {:>6} {:>9} {:>11} {:>8} {:>10}",
        "builder",
        "Cell ms",
        "speedup",
        "host ms",
        "nodes",
        "depth",
        "SAH",
        "ray cost",
        "Mrays/s",
        "tree KiB"
    );
    for r in rows {
        let opt = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |v| format!("{v:.d$}"));
        println!(
            "{:<w$} {:>9} {:>8} {:>8.2} {:>8} {:>6} {:>9.2} {:>11} {:>8.2} {:>10.1}",
            r.builder.name(),
            opt(r.simulated_ms, 2),
            opt(speedup(r), 2),
            r.host_ms,
            r.nodes,
            r.depth,
            r.sah,
            format!("{:.1}+{:.1}", r.ray_nodes, r.ray_triangles),
            r.mrays,
            r.tree_bytes as f64 / 1024.0
        );
    }
    println!(
        "\ntrees valid; \"Cell ms\": simulated time on the PS3 model (multi-SPE builders on {spes} SPEs); \
         speedup over spe_bfs (one SPE, the paper's baseline); ray cost: nodes visited + triangles \
         tested per primary ray of the render camera; host figures: this machine, one thread"
    );
}
