//! Section 5 measured: every multi-SPE builder (and each setting of its
//! knobs) on 1 to 8 SPEs, beside the single-SPE baseline `spe_bfs`, on the
//! scenes that matter: simulated time, speedup, parallel efficiency, where
//! the SPEs' cycles go, memory-interface use, tree quality.
//!
//! `cargo run --release --bin spe_scaling -- --data DIR [--scenes default,bunny] [--max-spes 8] [--defaults-only] [--threads N] [--out results]`
//!
//! Scenes (default): default, bunny, dragon, sponza-dabrovic, sibenik,
//! rtperf:1000000 and the held-out meshes teapot, iss-nasa, homer,
//! rocker-arm, beast, nefertiti, ogre (those that need the data directory
//! are skipped, said so, when it is missing). Writes
//! spe_scaling.{csv,json}, one SVG per scene of speedup against SPEs (with the ideal line) and one of where the SPEs'
//! time goes on the largest scene.

use clap::Parser;
use serde_json::{Value, json};

use cellbih::bih::BihConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::render::View;
use cellbih::scene::{Scene, zoo};
use cellbih_cli::args::SceneArgs;
use cellbih_cli::args::{RateArgs, RunArgs};
use cellbih_cli::report::{Series, line_plot, output, side_by_side};

mod phases;
mod zoo_summary;
use cellbih::strategy::Knobs;

#[derive(Parser)]
#[command(
    about = "Section 5's strategies on 1 to 8 SPEs beside the single-SPE baseline: simulated time, speedup, where the time goes (default run: about 11 min)"
)]
struct Args {
    /// Scenes, comma-separated [default: default, bunny, dragon,
    /// sponza-dabrovic, sibenik, rtperf:1000000, teapot, iss-nasa, homer,
    /// rocker-arm, beast, nefertiti, ogre]
    #[arg(
        long,
        value_delimiter = ',',
        hide_default_value = true,
        default_value = "default,bunny,dragon,sponza-dabrovic,sibenik,rtperf:1000000,teapot,iss-nasa,homer,rocker-arm,beast,nefertiti,ogre"
    )]
    scenes: Vec<String>,
    /// Most SPEs (1 to 16; above 8 a what-if: more SPEs on the one memory
    /// interface): every count from 1 up to it is run.
    #[arg(long, default_value_t = 8, value_parser = cellbih_cli::args::between::<u64, _>(1..=16))]
    max_spes: u64,
    /// The scene zoo instead of --scenes: scenes nobody tuned a default
    /// on (a model on a floor 10 and 1,000 times its size, the teapot in
    /// a stadium, clusters far apart, a row of copies, a soup of thin
    /// triangles, a city), with the goals checked.
    #[arg(long, conflicts_with = "scenes")]
    zoo: bool,
    /// Only each builder's default knobs (not every setting it sweeps).
    #[arg(long)]
    defaults_only: bool,
    /// Only the builders that take this knob (a name of a knob table,
    /// without `--`), each with its defaults and with each value of the
    /// knob its table sweeps.
    #[arg(long, conflicts_with = "defaults_only")]
    knob: Option<String>,
    /// After the summary, where the time of each builder made of phases
    /// goes on the most SPEs, a column a scene.
    #[arg(long)]
    phases: bool,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    rates: RateArgs,
}

/// A builder with one setting of the knobs, as its rows name it.
struct Variant {
    builder: BuilderKind,
    knobs: Knobs,
    name: String,
}

/// Every multi-SPE builder with each knob setting its registry entry
/// sweeps ([`BuilderKind::sweeps`]: its defaults, each knob's sweep values
/// alone, its settings of several knobs at once), or only its defaults, or
/// (`knob`) those that take that knob with their defaults and its sweep
/// values. Named by their CLI options.
fn variants(defaults_only: bool, knob: Option<&str>) -> Result<Vec<Variant>, String> {
    let mut v = Vec::new();
    for &b in BuilderKind::ALL.iter().filter(|b| b.multi_spe()) {
        let mut sweeps = b.sweeps();
        if defaults_only {
            sweeps.truncate(1);
        }
        if let Some(name) = knob {
            let Some(k) = b.knobs().iter().find(|k| k.name == name) else {
                continue;
            };
            sweeps.truncate(1);
            for value in k.sweep {
                let mut knobs = Knobs::default();
                b.set_knob(&mut knobs, name, value)
                    .map_err(|e| e.to_string())?;
                sweeps.push(knobs);
            }
        }
        for knobs in sweeps {
            let name = format!("{} {}", b.name(), knobs.spelled());
            v.push(Variant {
                builder: b,
                name: name.trim_end().to_string(),
                knobs,
            });
        }
    }
    match (knob, v.is_empty()) {
        (Some(name), true) => Err(format!("--knob {name}: no multi-SPE builder takes it")),
        _ => Ok(v),
    }
}

fn main() {
    cellbih_cli::report::main("spe_scaling", |a: &Args| &a.run.output, run);
}

/// A scene's baseline build (`spe_bfs` on one SPE): what each row is
/// held against.
#[derive(Clone, Copy)]
struct Baseline {
    ms: f64,
    sah: f64,
    hash: u64,
}

/// One build's row.
fn row(
    model: &Build,
    scene: &Scene,
    v: &Variant,
    spes: usize,
    base: Baseline,
) -> Result<(Value, cellbih::bih::Bih), String> {
    let Baseline {
        ms: base_ms,
        sah: base_sah,
        hash: base_hash,
    } = base;
    let cfg = BihConfig::default();
    let cell = model.cell.clone().with_spes(spes);
    let r = (model
        .for_builder(v.builder)
        .with_tree(cfg)
        .on(&cell)
        .with_knobs(&v.knobs))
    .run(scene)
    .map_err(|e| format!("{} / {} / {spes} SPEs: {e}", scene.name, v.name))?;
    let sim = r.simulated.expect("a multi-SPE builder runs on the Cell");
    let cycles = sim.run.cycles.0.max(1) as f64;
    let spe_cores = &sim.run.cores[1..];
    // Each SPE's share of the run, averaged over the SPEs.
    let share = |f: &dyn Fn(&cellbih::cell::CoreCounters) -> u64| {
        spe_cores.iter().map(|(_, c)| f(c) as f64).sum::<f64>() / (spes as f64 * cycles)
    };
    let bytes: u64 = spe_cores
        .iter()
        .map(|(_, c)| c.bytes_get + c.bytes_put)
        .sum();
    let peak = cell.cost.memory_bandwidth.bytes_per_cycle();
    let arena_slots: u64 = sim.spe_work.iter().map(|w| w.arena_blocks).sum::<u64>()
        * cellbih::strategy::machinery::arena::BLOCK_NODES as u64;
    let arena_unused: u64 = sim.spe_work.iter().map(|w| w.arena_unused).sum();
    let ms = sim.run.ms;
    let row = json!({
        "scene": scene.name, "triangles": scene.len(), "builder": v.name, "spes": spes,
        "spes_used": sim.spe_work.len(),
        "prediction": sim.prediction(),
        "simulated_ms": ms, "baseline_ms": base_ms,
        "speedup": base_ms / ms, "efficiency": base_ms / ms / spes as f64,
        "busy": share(&|c| c.busy.0), "dma_wait": share(&|c| c.dma_wait.0),
        "sync_wait": share(&|c| c.mailbox_wait.0), "atomic": share(&|c| c.atomic.0),
        "idle": share(&|c| c.idle.0),
        "memory_shared": share(&|c| c.memory_wait.0),
        "reservations_lost": spe_cores.iter().map(|(_, c)| c.reservations_lost).sum::<u64>(),
        "jobs_taken": sim.spe_work.iter().map(|w| w.taken).sum::<u64>(),
        "jobs_stolen": sim.spe_work.iter().map(|w| w.stolen).sum::<u64>(),
        "arena_waste": arena_unused as f64 / arena_slots.max(1) as f64,
        "memory_mib": sim.footprint.total as f64 / (1024.0 * 1024.0),
        "footprint": sim.footprint.by_purpose.iter()
            .map(|(p, b)| json!({ "purpose": p.name(), "bytes": b })).collect::<Vec<_>>(),
        "memory_utilisation": bytes as f64 / (cycles * peak),
        "sah_over_baseline": r.bih.quality().sah_cost / base_sah,
        "tree_hash": r.bih.tree_hash_hex(),
        "baseline_tree": r.bih.tree_hash() == base_hash,
        "phases": sim.phase_ms().iter().map(|(p, ms)| json!({ "phase": p, "ms": ms })).collect::<Vec<_>>(),
        "host_ms": r.host_time.as_secs_f64() * 1e3,
    });
    Ok((row, r.bih))
}

/// Measured ray cost of `bih`: nodes visited and triangles tested per
/// primary ray of a 128 x 96 view from `view` (one thread).
/// For builders that predict their time to choose how many SPEs to use:
/// each row's fastest count at most the SPEs given and its time
/// (`best_count`, `best_count_ms`), the counts never chosen run with
/// every SPE given (`--tris-per-spe 1`). `jobs` are the rows' (scene,
/// variant, SPEs), in order.
fn best_counts(
    rows: &mut [Value],
    jobs: &[(usize, usize, usize)],
    scenes: &[Scene],
    variants: &[Variant],
    model: &Build,
) -> Result<(), String> {
    let predicts = |r: &Value| !r["prediction"].is_null();
    // Each (scene, variant)'s time on each count it ran on.
    let mut on: std::collections::BTreeMap<(usize, usize, usize), f64> = Default::default();
    for (&(si, vi, _), r) in jobs.iter().zip(rows.iter()).filter(|(_, r)| predicts(r)) {
        let used = r["spes_used"].as_u64().unwrap_or(1) as usize;
        on.insert((si, vi, used), r["simulated_ms"].as_f64().unwrap_or(0.0));
    }
    let mut missing: Vec<_> = (jobs.iter().zip(rows.iter()))
        .filter(|&(&(si, vi, spes), r)| predicts(r) && !on.contains_key(&(si, vi, spes)))
        .map(|(&job, _)| job)
        .collect();
    missing.dedup();
    let forced = side_by_side("every SPE given", &missing, |&(si, vi, spes)| {
        let (scene, v) = (&scenes[si], &variants[vi]);
        let mut knobs = v.knobs.clone();
        (v.builder.set_knob(&mut knobs, "tris-per-spe", "1")).map_err(|e| e.to_string())?;
        let cell = model.cell.clone().with_spes(spes);
        let r = (model.for_builder(v.builder).with_tree(BihConfig::default()))
            .on(&cell)
            .with_knobs(&knobs)
            .run(scene)
            .map_err(|e| format!("{} / {} / {spes} SPEs: {e}", scene.name, v.name))?;
        Ok::<_, String>(r.simulated.expect("emulated").run.ms)
    });
    for (job, ms) in missing.into_iter().zip(forced) {
        on.insert(job, ms?);
    }
    for (&(si, vi, spes), r) in jobs
        .iter()
        .zip(rows.iter_mut())
        .filter(|(_, r)| predicts(r))
    {
        let best = (1..=spes)
            .filter_map(|k| on.get(&(si, vi, k)).map(|&ms| (ms, k)))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((ms, k)) = best {
            r["best_count"] = json!(k);
            r["best_count_ms"] = json!(ms);
        }
    }
    Ok(())
}

fn ray_cost(scene: &Scene, bih: &cellbih::bih::Bih, view: &View) -> (f64, f64) {
    let tracer = cellbih::bih::Tracer::new(bih, scene);
    let cam = (view.camera(&scene.name, &scene.bounds(), 128, 96)).expect("a scene's own view");
    let c = cellbih::quality::rays::measure(&tracer, &cam.rays());
    (c.nodes, c.triangles)
}

fn run(args: &Args) -> Result<(), String> {
    use cellbih_cli::args::{Charges, set_charges};
    set_charges("spe_scaling", Charges::builds_and(false, false));
    args.run.threads.install()?;
    let model = args.rates.model(6, true)?;
    let names: Vec<String> = match args.zoo {
        true => zoo::SET.iter().map(|s| s.to_string()).collect(),
        false => args.scenes.clone(),
    };
    let scenes = cellbih_cli::report::load_scenes(&names, args.scene.data.dir().as_deref())?;
    let view = args.scene.camera.view();
    // Each scene's baseline: simulated ms, SAH cost and ray cost.
    let bases = side_by_side("baselines", &scenes, |scene| {
        let base = (model.for_builder(BuilderKind::SPE_BFS))
            .run(scene)
            .map_err(|e| format!("{} / spe_bfs: {e}", scene.name))?;
        let rays = ray_cost(scene, &base.bih, &view);
        let sim = base.simulated.expect("emulated").run.ms;
        let hash = base.bih.tree_hash();
        let baseline = Baseline {
            ms: sim,
            sah: base.bih.quality().sah_cost,
            hash,
        };
        Ok::<_, String>((baseline, rays))
    });
    let bases = bases.into_iter().collect::<Result<Vec<_>, _>>()?;
    // Every (scene, variant, SPE count), side by side; the tree does not
    // depend on the SPE count, so its rays are cast once (on one SPE).
    let variants = variants(args.defaults_only, args.knob.as_deref())?;
    let mut jobs = Vec::new();
    for si in 0..scenes.len() {
        for vi in 0..variants.len() {
            jobs.extend((1..=args.max_spes as usize).map(|spes| (si, vi, spes)));
        }
    }
    let done = side_by_side("builds", &jobs, |&(si, vi, spes)| {
        let (scene, v) = (&scenes[si], &variants[vi]);
        let (r, bih) = row(&model, scene, v, spes, bases[si].0)?;
        Ok::<_, String>((r, (spes == 1).then(|| ray_cost(scene, &bih, &view))))
    });
    let mut rows = Vec::new();
    let mut cost = None;
    for (&(si, _, _), done) in jobs.iter().zip(done) {
        let (mut r, rays) = done?;
        let (nodes, tris) = *cost.insert(rays.or(cost).expect("the one-SPE row comes first"));
        let base_rays = bases[si].1;
        r["ray_nodes"] = json!(nodes);
        r["ray_triangles"] = json!(tris);
        r["ray_cost_over_baseline"] = json!((nodes + tris) / (base_rays.0 + base_rays.1));
        rows.push(r);
    }
    best_counts(&mut rows, &jobs, &scenes, &variants, &model)?;
    let summary = zoo_summary::summary(&rows, args.zoo);

    let keys = [
        "scene",
        "triangles",
        "builder",
        "spes",
        "spes_used",
        "simulated_ms",
        "baseline_ms",
        "speedup",
        "efficiency",
        "busy",
        "dma_wait",
        "sync_wait",
        "atomic",
        "idle",
        "memory_shared",
        "reservations_lost",
        "jobs_taken",
        "jobs_stolen",
        "arena_waste",
        "memory_mib",
        "memory_utilisation",
        "sah_over_baseline",
        "baseline_tree",
        "ray_nodes",
        "ray_triangles",
        "ray_cost_over_baseline",
        "host_ms",
    ];
    let doc = json!({
        "rows": rows,
        "summary": summary.rows, "goals": summary.goals,
        "note": "simulated ms on the PS3 model; baseline: spe_bfs (one SPE); busy..idle: mean share of the run per SPE; memory_utilisation: bytes moved / (cycles x 25.6 GB/s)",
    });
    args.run
        .output
        .report("spe_scaling", (&keys, &rows), &doc, Some(&model), |rows| {
            print_table(rows);
            zoo_summary::print(&summary);
            if args.phases {
                phases::print(rows, model.rates.code());
            }
        })?;
    plots(&args.run.output.out, &rows).map_err(|e| e.to_string())?;
    zoo_summary::plot(&args.run.output.out, &rows).map_err(|e| e.to_string())?;
    cellbih_cli::report::result_set::say_written(format!(
        "written: {}/spe_scaling.{{csv,json}}, spe_scaling_*.svg",
        args.run.output.out.display()
    ));
    Ok(())
}

fn plots(dir: &std::path::Path, rows: &[Value]) -> Result<(), Box<dyn std::error::Error>> {
    let mut scenes: Vec<&str> = rows.iter().filter_map(|r| r["scene"].as_str()).collect();
    scenes.dedup();
    let pts = |scene: &str, builder: &str, key: &str| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r["scene"] == scene && r["builder"] == builder)
            .filter_map(|r| Some((r["spes"].as_f64()?, r[key].as_f64()?)))
            .collect()
    };
    // The plots show each builder's defaults, the top levels alone, its
    // scheduling knobs and all of section 5's queue knobs (the table and
    // CSV have every variant).
    let plotted = |name: &str| {
        let flags = name.split_once(' ').map_or("", |(_, f)| f);
        [
            "",
            "--no-coop-top",
            "--fixed-takes",
            "--agglomerate 1",
            "--key-order xyz",
        ]
        .contains(&flags)
            || flags.starts_with("--double-buffer --dma-lists")
            || flags.starts_with("--no-double-buffer --no-dma-lists --no-prefetch")
    };
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        let name = r["builder"].as_str().unwrap_or_default();
        if plotted(name) && !names.iter().any(|n| n == name) {
            names.push(name.to_string());
        }
    }
    for &scene in &scenes {
        let mut series: Vec<Series> = names
            .iter()
            .enumerate()
            .map(|(i, b)| Series {
                name: b.clone(),
                points: pts(scene, b, "speedup"),
                color: i,
                dashed: false,
            })
            .collect();
        let max = series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0))
            .fold(1.0, f64::max);
        series.push(Series {
            name: "ideal".into(),
            points: vec![(1.0, 1.0), (max, max)],
            color: names.len(),
            dashed: true,
        });
        let file = format!("spe_scaling_{}.svg", cellbih_cli::report::file_part(scene));
        line_plot(
            &output(dir, &file)?,
            &format!("{scene}: speedup over spe_bfs (one SPE), simulated PS3 time"),
            "SPEs",
            "speedup",
            &series,
            false,
        )?;
    }
    // Where the time goes: the largest scene, the first variant.
    let largest = rows
        .iter()
        .max_by_key(|r| r["triangles"].as_u64())
        .and_then(|r| r["scene"].as_str());
    if let (Some(scene), Some(b)) = (largest, names.first()) {
        let series: Vec<Series> = ["busy", "dma_wait", "sync_wait", "idle", "atomic"]
            .iter()
            .enumerate()
            .map(|(i, k)| Series {
                name: k.to_string(),
                points: pts(scene, b, k),
                color: i,
                dashed: false,
            })
            .collect();
        line_plot(
            &output(dir, "spe_scaling_time.svg")?,
            &format!("{scene}, {b}: where the SPEs' time goes (mean share of the run)"),
            "SPEs",
            "share of the run",
            &series,
            false,
        )?;
    }
    Ok(())
}

/// The rows in 80 columns: a heading for each scene and builder (its
/// knobs), then a line per SPE count; the atomic share, memory-interface
/// utilisation and main memory are in the CSV and JSON.
fn print_table(rows: &[Value]) {
    let pct = |v: &Value| format!("{:.0}%", v.as_f64().unwrap_or(0.0) * 100.0);
    let mut heading = String::new();
    for r in rows {
        let here = format!(
            "{} · {}",
            r["scene"].as_str().unwrap_or(""),
            r["builder"].as_str().unwrap_or("")
        );
        if here != heading {
            println!("\n{}", cellbih_cli::report::wrap(&here, 80));
            println!(
                "{:>5} {:>10} {:>8} {:>6} {:>6} {:>6} {:>6} {:>6} {:>7} {:>9}",
                "SPEs",
                "sim ms",
                "speedup",
                "eff",
                "busy",
                "DMA",
                "sync",
                "idle",
                "lost",
                "host ms"
            );
            heading = here;
        }
        println!(
            "{:>5} {:>10.2} {:>8.2} {:>6.2} {:>6} {:>6} {:>6} {:>6} {:>7} {:>9.0}",
            // SPEs used of those given, where a small scene used fewer.
            match (r["spes_used"].as_u64(), r["spes"].as_u64()) {
                (Some(u), Some(s)) if u < s => format!("{u}/{s}"),
                (_, s) => s.unwrap_or(0).to_string(),
            },
            r["simulated_ms"].as_f64().unwrap_or(0.0),
            r["speedup"].as_f64().unwrap_or(0.0),
            r["efficiency"].as_f64().unwrap_or(0.0),
            pct(&r["busy"]),
            pct(&r["dma_wait"]),
            pct(&r["sync_wait"]),
            pct(&r["idle"]),
            r["reservations_lost"].as_u64().unwrap_or(0),
            r["host_ms"].as_f64().unwrap_or(0.0),
        );
    }
    println!(
        "\n{}",
        cellbih_cli::report::wrap(
            "speedup over spe_bfs on one SPE, simulated PS3 time; SPEs: used/given where a small \
             scene used fewer; busy/DMA/sync/idle: mean share of the run per SPE (sync: mailboxes \
             and signals, a barrier's wait among them); lost: reservations lost; host ms: the \
             emulation, one thread. The atomic share, memory-interface utilisation and main \
             memory used are in spe_scaling.csv and the JSON.",
            80
        )
    );
}
