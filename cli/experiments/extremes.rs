//! The numerical extremes: every builder on every case
//! of [`cellbih::scene::extremes`] — scales 1e-15 to 1e15, a tiny cluster
//! 1e7 from the origin, a cluster beside geometry 1e6 away, mixed sizes,
//! flat, collinear, point triangles, stacks, slivers — with the paper's
//! settings, and the builders that build the quality knobs also with
//! binned SAH and the empty-space cut-off. For each: valid or the first
//! violation, rays that disagree with brute force (of N), depth, largest
//! leaf, and the halvings `f32` could not make (the host recursion's count,
//! the same tree as every builder of the paper's tree but ppe_approx).
//!
//! `cargo run --release --bin extremes -- [--rays 1000] [--threads N] [--out results]`
//!
//! Writes extremes.{csv,json}. `tests/extremes.rs` checks each case.

use clap::Parser;
use serde_json::{Value, json};

use cellbih::bih::BihConfig;
use cellbih::cell::CellConfig;
use cellbih::kernels::recursion::{PrimRef, build_items};
use cellbih::quality::agree::{examine, rays_for};
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{Scene, extremes};
use cellbih_cli::args::RunArgs;
use cellbih_cli::report::side_by_side;

#[derive(Parser)]
#[command(
    about = "Every builder at the numerical extremes (1e-15 to 1e15, flat, degenerate, stacks, far clusters), each tree checked against brute force (default run: about 5 s)"
)]
struct Args {
    /// Rays per case and builder, each checked against brute force.
    #[arg(long, default_value_t = 1000, value_parser = cellbih_cli::args::between::<u64, _>(1..=1_000_000))]
    rays: u64,
    #[command(flatten)]
    run: RunArgs,
}

fn main() {
    cellbih_cli::report::main("extremes", |a: &Args| &a.run.output, run);
}

fn run(args: &Args) -> Result<(), String> {
    args.run.threads.install()?;
    let mut cell = CellConfig::ps3();
    cell.checked = true;
    let mut cases = Vec::new();
    for &name in extremes::CASES {
        let scene = extremes::case(name).ok_or(format!("no case {name}"))?;
        let rays = rays_for(&scene, args.rays as usize, 11);
        cases.push((name, scene, rays));
    }
    // Every (case, builder run) side by side.
    let runs = BuilderKind::every_run(BihConfig::SAH_CUT);
    let jobs: Vec<(usize, usize)> = (0..cases.len())
        .flat_map(|c| (0..runs.len()).map(move |k| (c, k)))
        .collect();
    let rows = side_by_side("builds", &jobs, |&(c, k)| {
        let (name, scene, rays) = &cases[c];
        let (b, cfg) = runs[k];
        let e = examine(&Build::new(b).with_tree(cfg).on(&cell), scene, rays);
        json!({
            "case": name, "triangles": scene.len(), "degenerate": scene.degenerate_count(),
            "builder": b.name(), "setting": cfg.flags(),
            "valid": e.invalid.is_none(), "violation": e.invalid,
            "disagree": e.disagree, "rays": e.rays, "depth": e.depth,
            "largest_leaf": e.largest_leaf, "f32_stalls": stalls(scene, &cfg),
        })
    });

    let keys = [
        "case",
        "triangles",
        "degenerate",
        "builder",
        "setting",
        "valid",
        "violation",
        "disagree",
        "rays",
        "depth",
        "largest_leaf",
        "f32_stalls",
    ];
    let doc = json!({ "rows": rows, "note": "disagree: rays whose closest or any hit differs from brute force, of `rays`; f32_stalls: halvings of the global heuristic f32 could not make (host recursion)" });
    args.run.output.report(
        "extremes",
        (&keys, &rows),
        &doc,
        Some(&Build::new(BuilderKind::HOST).on(&cell)),
        print_table,
    )?;
    let bad = rows
        .iter()
        .filter(|r| r["valid"] == false || r["disagree"] != 0)
        .count();
    cellbih_cli::report::result_set::say_written(format!(
        "written: {}/extremes.{{csv,json}}",
        args.run.output.out.display()
    ));
    if bad > 0 {
        return Err(format!(
            "{bad} rows with an invalid tree or rays that disagree with brute force"
        ));
    }
    Ok(())
}

/// The halvings `f32` could not make in the host recursion with `cfg`.
fn stalls(scene: &Scene, cfg: &BihConfig) -> u64 {
    let mut refs: Vec<PrimRef> = (scene.triangles.iter().enumerate())
        .map(|(i, t)| PrimRef::new(i as u32, t.bounds()))
        .collect();
    build_items(&mut refs, scene.bounds(), cfg).1.f32_stalls
}

/// One line per case: how many of its builder runs were valid and agreed,
/// the worst disagreement, depth and largest leaf over the builders, and
/// the stalls of the paper's tree and of the knobs' tree.
fn print_table(rows: &[Value]) {
    println!(
        "{:<25} {:>5} {:>5} {:>5} {:>8} {:>5} {:>8} {:>10}",
        "case", "tris", "degen", "valid", "disagree", "depth", "leaf max", "f32 stalls"
    );
    for &name in extremes::CASES {
        let of: Vec<&Value> = rows.iter().filter(|r| r["case"] == name).collect();
        if of.is_empty() {
            continue;
        }
        let n = |r: &Value, k: &str| r[k].as_u64().unwrap_or(0);
        let valid = of.iter().filter(|r| r["valid"] == true).count();
        let worst = of.iter().map(|r| n(r, "disagree")).max().unwrap_or(0);
        let range = |k: &str| {
            let (lo, hi) = (
                of.iter().map(|r| n(r, k)).min().unwrap_or(0),
                of.iter().map(|r| n(r, k)).max().unwrap_or(0),
            );
            if lo == hi {
                format!("{lo}")
            } else {
                format!("{lo}-{hi}")
            }
        };
        let st = |flags: &str| {
            of.iter()
                .find(|r| r["setting"] == flags)
                .map_or(0, |r| n(r, "f32_stalls"))
        };
        println!(
            "{:<25} {:>5} {:>5} {:>5} {:>8} {:>5} {:>8} {:>10}",
            name,
            n(of[0], "triangles"),
            n(of[0], "degenerate"),
            format!("{valid}/{}", of.len()),
            format!("{worst}/{}", n(of[0], "rays")),
            range("depth"),
            range("largest_leaf"),
            format!("{} / {}", st(""), st(&BihConfig::SAH_CUT.flags())),
        );
        for r in of
            .iter()
            .filter(|r| r["valid"] == false || n(r, "disagree") > 0)
        {
            let line = format!(
                "{} {}: {}",
                r["builder"].as_str().unwrap_or(""),
                r["setting"].as_str().unwrap_or(""),
                r["violation"]
            );
            for l in cellbih_cli::report::wrap(&line, 76).lines() {
                println!("    {l}");
            }
        }
    }
    let knobs: Vec<&str> = (BuilderKind::every_run(BihConfig::SAH_CUT).iter())
        .filter(|(_, cfg)| !cfg.paper_quality())
        .map(|(b, _)| b.name())
        .collect();
    let flags = BihConfig::SAH_CUT.flags();
    let note = format!(
        "valid: builder runs whose tree is valid, of every builder with the paper's settings \
         and {} with {flags}; disagree: the most rays of one run whose hit differs from brute \
         force; depth, leaf max: over the runs; f32 stalls: halvings the global heuristic could \
         not make in f32 (paper's tree / {flags})",
        knobs.join(", "),
    );
    println!("{}", cellbih_cli::report::wrap(&note, 80));
}
