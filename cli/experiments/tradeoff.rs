//! The speed/accuracy trade, measured: every builder, and each
//! setting of the knobs it has, on the scenes that matter — build cost
//! against tree quality, the quality measured on real rays.
//!
//! `cargo run --release --bin tradeoff -- --data DIR [--scenes bunny,dragon] [--spes 6] [--threads N] [--out results]`
//!
//! Build cost: simulated ms on the PS3 model for the emulated builders
//! (timed mode: the cycles of the checked mode), host ms (median of three,
//! one thread) for the host builder. Quality: SAH, and the measured cost of
//! the standard ray sets ([`RaySets`]: primary rays of the render camera,
//! incoherent rays), closest hit, one host thread (rays per second: median
//! of three). Prints each scene's
//! Pareto fronts (PS3 builds, host builds; build ms against nodes +
//! triangles per primary ray) and, for a frame of R rays (10^4 to 10^8),
//! which host setting gives the least build + trace time. Writes
//! tradeoff.{csv,json} and `tradeoff_<scene>.svg` (the scatter, the fronts
//! drawn).

use clap::Parser;
use serde_json::{Value, json};

use cellbih::bih::{BihConfig, SplitChoice, Tracer};

/// The `--sah-above` setting the grid tries beside binning every node.
const SAH_ABOVE: u32 = 4096;
use cellbih::cast::{CastConfig, cast_on_cell};
use cellbih::quality::pareto_front;
use cellbih::quality::rays::RaySets;
use cellbih::registry::{Build, BuilderKind, Quality};
use cellbih::scene::Scene;
use cellbih::strategy::Knobs;
use cellbih_cli::args::SceneArgs;
use cellbih_cli::args::{RateArgs, RunArgs};
use cellbih_cli::report::{Series, one_thread_each, output, scatter_plot};

#[derive(Parser)]
#[command(
    about = "Build time against tree quality: every builder and quality setting on five scenes, the Pareto fronts (default run: 13 min and 0.8 GB of memory at its peak, on a 2-core machine)"
)]
struct Args {
    /// Scenes, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "bunny,dragon,sponza-dabrovic,sibenik,rtperf:200000"
    )]
    scenes: Vec<String>,
    /// SPEs of the emulated Cell for the multi-SPE builders (1 to 16; above
    /// 8 a what-if).
    #[arg(long, default_value_t = 6, value_parser = cellbih_cli::args::between::<u64, _>(1..=16))]
    spes: u64,
    /// Print only each scene's settings on the Pareto front of PS3 builds
    /// and the PS3 frames (every setting still goes to the CSV and JSON).
    #[arg(long)]
    ps3_summary: bool,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    rates: RateArgs,
}

/// A builder with one setting, named by its CLI options.
struct Setting {
    builder: BuilderKind,
    cfg: BihConfig,
    knobs: Knobs,
    flags: String,
}

/// Every builder with leaf size 12 and 4 × the quality knobs it builds
/// (global heuristic and binned SAH × no cut-off, 10 % and 30 %), a depth
/// limit of 16 for the builders that run the host recursion, and each
/// knob setting the registry sweeps for the builder
/// ([`BuilderKind::sweeps`]) at the paper's tree settings.
fn settings() -> Vec<Setting> {
    let (d, k) = (BihConfig::default(), Knobs::default());
    let mut v = Vec::new();
    let mut push = |builder, cfg, knobs, flags: &str| {
        v.push(Setting {
            builder,
            cfg,
            knobs,
            flags: flags.to_string(),
        })
    };
    for &b in BuilderKind::ALL {
        let q = b.quality();
        let gh = SplitChoice::GlobalHeuristic;
        let sah = |above| SplitChoice::BinnedSah { bins: 16, above };
        let splits: &[SplitChoice] = if q.binned_sah {
            &[gh, sah(0), sah(SAH_ABOVE)]
        } else {
            &[gh]
        };
        let cuts: &[Option<u32>] = if q.empty_cut {
            &[None, Some(10), Some(30)]
        } else {
            &[None]
        };
        for leaf in [12, 4] {
            for &split in splits {
                for &cut in cuts {
                    let cfg = BihConfig {
                        leaf_size: leaf,
                        split,
                        empty_cut: cut,
                        ..d
                    };
                    push(b, cfg, k.clone(), &cfg.flags());
                }
            }
        }
        if q == Quality::ALL {
            let deep = BihConfig { max_depth: 16, ..d };
            push(b, deep, k.clone(), &deep.flags());
        }
        // Each knob setting the registry sweeps for the builder, at the
        // paper's tree settings (the defaults are the first, built above).
        for knobs in b.sweeps().into_iter().skip(1) {
            let flags = knobs.spelled();
            push(b, d, knobs, &flags);
        }
    }
    v
}

fn main() {
    cellbih_cli::report::main("tradeoff", |a: &Args| &a.run.output, run);
}

fn run(args: &Args) -> Result<(), String> {
    use cellbih_cli::args::{Charges, set_charges};
    set_charges("tradeoff", Charges::builds_and(true, false));
    args.run.threads.install()?;
    let settings = settings();
    let scenes = cellbih_cli::report::load_scenes(&args.scenes, args.scene.data.dir().as_deref())?;
    let (mut cell, rates) = args.rates.ps3(args.spes as usize)?;
    cell.checked = false;
    let model = Build::new(BuilderKind::HOST).on(&cell).with_rates(&rates);
    let sets: Vec<_> = (scenes.iter())
        .map(|s| {
            let view = args.scene.camera.view();
            let rays = RaySets::for_scene(s, &view).expect("a scene's own view");
            let cam = (view.camera(&s.name, &s.bounds(), CAST_SIZE.0, CAST_SIZE.1))
                .expect("a scene's own view");
            // In blocks of the cast's packets, the order they take.
            let p = CastConfig::DEFAULT.packet;
            (rays, cam.rays_in_blocks(p.w, p.h))
        })
        .collect();
    // Every (scene, setting) side by side, then each scene's fronts.
    let jobs: Vec<(usize, usize)> = (0..scenes.len())
        .flat_map(|si| (0..settings.len()).map(move |k| (si, k)))
        .collect();
    // Each setting's host figures are one thread's, and at most one job a
    // thread runs at once: memory stays that of a few builds.
    let done = one_thread_each("settings", &jobs, |&(si, k)| {
        let (s, st) = (&scenes[si], &settings[k]);
        let (rays, cam) = &sets[si];
        measure(s, st, &model, (rays, cam)).map_err(|e| {
            let label = format!("{} {}", st.builder, st.flags);
            format!("{}, {}: {e}", s.name, label.trim())
        })
    })?;
    let mut rows: Vec<Value> = done.into_iter().collect::<Result<_, _>>()?;
    for scene_rows in rows.chunks_mut(settings.len()) {
        mark_fronts(scene_rows);
    }

    let keys = [
        "scene",
        "triangles",
        "builder",
        "setting",
        "simulated_ms",
        "host_ms",
        "sah",
        "nodes",
        "tree_bytes",
        "primary_nodes",
        "primary_triangles",
        "primary_cost",
        "primary_mrays_per_s",
        "incoherent_nodes",
        "incoherent_triangles",
        "incoherent_cost",
        "incoherent_mrays_per_s",
        "cell_render_ms",
        "front_ps3",
        "front_host",
    ];
    let doc = json!({
        "rows": rows,
        "frames": frames(&rows),
        "spes": args.spes,
        "note": NOTE.replace("PACKET", &CastConfig::DEFAULT.packet.to_string()),
    });
    let (shared, ps3_summary) = (model.clone(), args.ps3_summary);
    let print = |rows: &[Value]| print_tables(rows, ps3_summary);
    (args.run.output).report("tradeoff", (&keys, &rows), &doc, Some(&shared), print)?;
    plots(&args.run.output.out, &rows).map_err(|e| e.to_string())?;
    cellbih_cli::report::result_set::say_written(format!(
        "written: {}/tradeoff.{{csv,json}}, tradeoff_*.svg",
        args.run.output.out.display()
    ));
    Ok(())
}

/// What `tradeoff.json`'s fields are (PACKET: the default cast's packet).
const NOTE: &str = "simulated_ms: PS3 model (timed mode), multi-SPE builders on `spes` SPEs; host_ms: this machine, one thread (median of 3 for the host builder, the emulation's time for the others); *_cost: nodes visited + triangles tested per ray, closest hit; cell_render_ms: simulated PS3 ms to cast the camera's 320 x 240 primary rays on `spes` SPEs with the default cast (packets of PACKET rays; emulated builders' rows); fronts: Pareto fronts of build ms against primary cost; frames: for R rays a frame, the host setting with the least build + trace ms (one thread) and the emulated setting with the least simulated build + cast ms (ps3)";

/// The camera image whose primary rays each emulated setting's tree is
/// cast with on the SPEs: the render in PS3 time, per ray.
const CAST_SIZE: (u32, u32) = (320, 240);

/// Builds `s` with one setting, checks the tree, measures its rays on the
/// host and, for an emulated builder, casts the camera's rays `cam` on the
/// SPEs: build and render in one currency.
fn measure(
    s: &Scene,
    st: &Setting,
    model: &Build,
    (rays, cam): (&RaySets, &[cellbih::bih::Ray]),
) -> Result<Value, String> {
    let cell = &model.cell;
    // The host's figures are one thread's: a builder that builds on the
    // host's threads builds in the job's pool of one ([`one_thread_each`]).
    let build = || {
        (model.for_builder(st.builder).with_tree(st.cfg))
            .with_knobs(&st.knobs)
            .run(s)
            .map_err(|e| e.to_string())
    };
    let mut r = build()?;
    let mut host_ms = r.host_time.as_secs_f64() * 1e3;
    if !st.builder.emulated() {
        let mut times = vec![host_ms];
        for _ in 0..2 {
            r = build()?;
            times.push(r.host_time.as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        host_ms = times[1];
    }
    r.bih.validate(s).map_err(|v| v.to_string())?;
    let q = r.bih.quality();
    // Rays per second: the median of three runs (the node and triangle
    // counts are the same every run).
    let tracer = Tracer::new(&r.bih, s);
    let mut runs: Vec<_> = (0..3).map(|_| rays.measure(&tracer)).collect();
    runs.sort_by(|a, b| a.0.mrays_per_s.total_cmp(&b.0.mrays_per_s));
    let p = runs[1].0;
    runs.sort_by(|a, b| a.1.mrays_per_s.total_cmp(&b.1.mrays_per_s));
    let i = runs[1].1;
    let cell_render_ms = if st.builder.emulated() {
        let c = cast_on_cell(
            &r.bih,
            s,
            cam,
            &CastConfig::DEFAULT.with_rates(&model.rates),
            cell,
            r.record_order(),
        )
        .map_err(|e| e.to_string())?;
        Some(c.run.ms)
    } else {
        None
    };
    Ok(json!({
        "scene": s.name, "triangles": s.len(), "builder": st.builder.name(), "setting": st.flags,
        "emulated": st.builder.emulated(),
        "simulated_ms": r.simulated.as_ref().map(|m| m.run.ms), "host_ms": host_ms,
        "sah": q.sah_cost, "nodes": q.nodes, "tree_bytes": q.memory_bytes,
        "primary_nodes": p.nodes, "primary_triangles": p.triangles, "primary_cost": p.per_ray(),
        "primary_mrays_per_s": p.mrays_per_s,
        "incoherent_nodes": i.nodes, "incoherent_triangles": i.triangles,
        "incoherent_cost": i.per_ray(), "incoherent_mrays_per_s": i.mrays_per_s,
        "cell_render_ms": cell_render_ms,
        "cell_ms_per_ray": cell_render_ms.map(|ms| ms / cam.len() as f64),
    }))
}

/// Marks the rows of one scene on its two fronts: PS3 builds (simulated ms)
/// and host builds (host ms), each against the primary rays' cost.
fn mark_fronts(rows: &mut [Value]) {
    for (key, emulated, time) in [
        ("front_ps3", true, "simulated_ms"),
        ("front_host", false, "host_ms"),
    ] {
        let idx: Vec<usize> = (0..rows.len())
            .filter(|&i| rows[i]["emulated"] == emulated)
            .collect();
        let pts: Vec<(f64, f64)> = (idx.iter())
            .map(|&i| (num(&rows[i][time]), num(&rows[i]["primary_cost"])))
            .collect();
        let front = pareto_front(&pts);
        for (k, &i) in idx.iter().enumerate() {
            rows[i][key] = json!(front.contains(&k));
        }
    }
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

fn label(r: &Value) -> String {
    format!(
        "{} {}",
        r["builder"].as_str().unwrap_or(""),
        r["setting"].as_str().unwrap_or("")
    )
    .trim()
    .to_string()
}

/// Rays per frame of the frame reading.
const FRAME_RAYS: [f64; 5] = [1e4, 1e5, 1e6, 1e7, 1e8];

/// For each scene and each frame of R rays, the host setting with the least
/// build + trace time (one thread), for primary and for incoherent rays;
/// and the emulated setting with the least simulated build + cast of R
/// primary rays on the SPEs (`ps3`: the cast's time per ray of the
/// camera's rays, times R).
fn frames(rows: &[Value]) -> Vec<Value> {
    let mut out = Vec::new();
    for scene in scene_names(rows) {
        let host: Vec<&Value> = (rows.iter())
            .filter(|r| r["scene"] == scene && r["emulated"] == false)
            .collect();
        let ps3: Vec<&Value> = (rows.iter())
            .filter(|r| r["scene"] == scene && r["cell_ms_per_ray"].is_f64())
            .collect();
        for r_rays in FRAME_RAYS {
            let mut row = json!({ "scene": scene, "rays": r_rays });
            let total = |r: &Value| num(&r["simulated_ms"]) + r_rays * num(&r["cell_ms_per_ray"]);
            if let Some(best) = ps3.iter().min_by(|a, b| total(a).total_cmp(&total(b))) {
                row["ps3"] = json!({
                    "setting": label(best), "total_ms": total(best),
                    "build_ms": num(&best["simulated_ms"]),
                    "render_ms": r_rays * num(&best["cell_ms_per_ray"]),
                });
            }
            for set in ["primary", "incoherent"] {
                let total = |r: &Value| {
                    num(&r["host_ms"]) + r_rays / (num(&r[format!("{set}_mrays_per_s")]) * 1e3)
                };
                if let Some(best) = host.iter().min_by(|a, b| total(a).total_cmp(&total(b))) {
                    row[set] = json!({ "setting": label(best), "total_ms": total(best), "build_ms": num(&best["host_ms"]) });
                }
            }
            out.push(row);
        }
    }
    out
}

fn scene_names(rows: &[Value]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        let n = r["scene"].as_str().unwrap_or("").to_string();
        if !names.contains(&n) {
            names.push(n);
        }
    }
    names
}

/// Every setting of every scene, its figures and front, then the frames;
/// with `ps3_summary` only the settings on the front of PS3 builds and the
/// PS3 frames (the part of the result that is simulated time alone).
fn print_tables(rows: &[Value], ps3_summary: bool) {
    for scene in scene_names(rows) {
        let of: Vec<&Value> = (rows.iter())
            .filter(|r| r["scene"] == scene.as_str())
            .filter(|r| !ps3_summary || r["front_ps3"] == true)
            .collect();
        let Some(first) = of.first() else {
            continue;
        };
        let which = if ps3_summary {
            ": the front of PS3 builds"
        } else {
            ""
        };
        println!("\n{scene} ({} triangles){which}", first["triangles"]);
        // 80 columns: each setting on a line of its own, its figures
        // indented on the next (in the summary, the simulated ones alone).
        println!("builder setting");
        match ps3_summary {
            true => println!(
                "  {:>8} {:>7} {:>7} {:>11} {:>11}",
                "Cell ms", "SAH", "nodes", "primary", "incoherent"
            ),
            false => println!(
                "  {:>8} {:>8} {:>7} {:>7} {:>11} {:>6} {:>11} {:>6} {:>5}",
                "Cell ms",
                "host ms",
                "SAH",
                "nodes",
                "primary",
                "Mray/s",
                "incoherent",
                "Mray/s",
                "front"
            ),
        }
        for r in &of {
            let front = match (r["front_ps3"] == true, r["front_host"] == true) {
                (true, _) => "PS3",
                (_, true) => "host",
                _ => "",
            };
            let sim = r["simulated_ms"]
                .as_f64()
                .map_or("-".into(), |v| format!("{v:.2}"));
            let cost = |set: &str| {
                let (n, t) = (
                    num(&r[format!("{set}_nodes")]),
                    num(&r[format!("{set}_triangles")]),
                );
                format!("{n:.1}+{t:.1}")
            };
            println!("{}", cellbih_cli::report::wrap(&label(r), 80));
            if ps3_summary {
                println!(
                    "  {:>8} {:>7.1} {:>7} {:>11} {:>11}",
                    sim,
                    num(&r["sah"]),
                    r["nodes"].as_u64().unwrap_or(0),
                    cost("primary"),
                    cost("incoherent"),
                );
                continue;
            }
            println!(
                "  {:>8} {:>8.2} {:>7.1} {:>7} {:>11} {:>6.2} {:>11} {:>6.2} {:>5}",
                sim,
                num(&r["host_ms"]),
                num(&r["sah"]),
                r["nodes"].as_u64().unwrap_or(0),
                cost("primary"),
                num(&r["primary_mrays_per_s"]),
                cost("incoherent"),
                num(&r["incoherent_mrays_per_s"]),
                front
            );
        }
        let wrapped = |text: &str| {
            let body = cellbih_cli::report::wrap(text, 76);
            println!("  {}", body.replace('\n', "\n    "));
        };
        let host_frames = (frames(rows).into_iter())
            .filter(|f| !ps3_summary && f["scene"] == scene.as_str())
            .collect::<Vec<_>>();
        if !host_frames.is_empty() {
            println!(
                "frame of R rays, host (one thread): the setting with the least build + trace ms"
            );
        }
        for f in &host_frames {
            let cell = |set: &str| {
                let b = &f[set];
                format!(
                    "{} ({:.1} ms)",
                    b["setting"].as_str().unwrap_or("-"),
                    num(&b["total_ms"])
                )
            };
            wrapped(&format!(
                "R = {:.0e}: primary {}; incoherent {}",
                num(&f["rays"]),
                cell("primary"),
                cell("incoherent")
            ));
        }
        println!(
            "frame of R primary rays on the PS3 (simulated): the setting with the least\n\
             build + cast on the SPEs"
        );
        for f in frames(rows).iter().filter(|f| f["scene"] == scene.as_str()) {
            let b = &f["ps3"];
            wrapped(&format!(
                "R = {:.0e}: {} ({:.1} ms: build {:.1} + render {:.1})",
                num(&f["rays"]),
                b["setting"].as_str().unwrap_or("-"),
                num(&b["total_ms"]),
                num(&b["build_ms"]),
                num(&b["render_ms"])
            ));
        }
    }
    let note = match ps3_summary {
        true => {
            "Cell ms: simulated PS3 time (multi-SPE builders on --spes SPEs); primary, incoherent: \
             nodes visited + triangles tested per ray; the front: no other PS3 build is both faster \
             and cheaper a primary ray"
        }
        false => {
            "Cell ms: simulated PS3 time (multi-SPE builders on --spes SPEs); host ms: this \
             machine, one thread (host builder: median of 3; emulated builders: the emulation); \
             primary, incoherent: nodes visited + triangles tested per ray; front: on the Pareto \
             front of PS3 builds (Cell ms) or host builds (host ms) against the primary cost"
        }
    };
    println!("\n{}", cellbih_cli::report::wrap(note, 80));
}

/// One SVG per scene: build ms (log) against primary cost; PS3 builds and
/// host builds as two series of dots, each front as a dashed step line.
fn plots(dir: &std::path::Path, rows: &[Value]) -> Result<(), Box<dyn std::error::Error>> {
    for scene in scene_names(rows) {
        let of: Vec<&Value> = rows
            .iter()
            .filter(|r| r["scene"] == scene.as_str())
            .collect();
        let series = |emulated: bool, time: &str, only_front: Option<&str>| -> Vec<(f64, f64)> {
            let mut pts: Vec<(f64, f64)> = (of.iter())
                .filter(|r| r["emulated"] == emulated && only_front.is_none_or(|k| r[k] == true))
                .map(|r| (num(&r[time]), num(&r["primary_cost"])))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            pts
        };
        let points = [
            Series {
                name: "PS3 builds (simulated ms)".into(),
                points: series(true, "simulated_ms", None),
                color: 0,
                dashed: false,
            },
            Series {
                name: "host builds (host ms, one thread)".into(),
                points: series(false, "host_ms", None),
                color: 1,
                dashed: false,
            },
        ];
        let fronts = [
            Series {
                name: "PS3 front".into(),
                points: series(true, "simulated_ms", Some("front_ps3")),
                color: 0,
                dashed: true,
            },
            Series {
                name: "host front".into(),
                points: series(false, "host_ms", Some("front_host")),
                color: 1,
                dashed: true,
            },
        ];
        let file = format!("tradeoff_{}.svg", cellbih_cli::report::file_part(&scene));
        scatter_plot(
            &output(dir, &file)?,
            &format!("{scene}: build time against measured ray cost"),
            "build ms (log)",
            "nodes + triangles per primary ray",
            &points,
            &fronts,
        )?;
    }
    Ok(())
}
