//! The whole frame on the Cell: for each animated scene, image
//! size and arrangement of the SPEs, every policy of the frame loop —
//! rebuild, local, deep, and section 5's `auto` judged by the oracle —
//! played frame by frame, every time simulated PS3 time: frames per
//! second, where each frame's time goes, predicted against measured.
//!
//! `cargo run --release --bin frame_loop -- [--scenes car,cup,rtperf:100000]
//! [--sizes 320x240,640x480] [--frames 10] [--builder spe_bfs_private]
//! [--empty-cut 30 …] [--spes 6] [--threads N] [--out results]`
//!
//! Writes frame_loop.{csv,json} (a row per scene, size, arrangement and
//! policy; the JSON also holds every frame, and each case's goals) and one
//! SVG per scene and size: frame time per frame, a line per policy and
//! arrangement. Then a table of the metric's goals per case (scene, size,
//! arrangement): `auto` against the best fixed policy, the share of its
//! frames within 10 % of the oracle's best, its mean prediction error.
//! With `--ends`, which arrangement wins each case at the ends of the
//! PPE's bands and in each code class ([`ends`]).

// The options' doc comments are their --help text: `rtperf:N[:SEED]` is
// the scene syntax there, not a link.
#![allow(rustdoc::broken_intra_doc_links)]

mod ends;

use clap::Parser;
use serde_json::{Value, json};

use cellbih::cast::CastConfig;
use cellbih::frame::{FrameConfig, Policy, play};
use cellbih::registry::{Build, BuilderKind};
use cellbih::update::{Animation, Method};
use cellbih_cli::args::SceneArgs;
use cellbih_cli::args::{RateArgs, RunArgs};
use cellbih_cli::report::{Series, TreeArgs, line_plot, output, side_by_side};

#[derive(Parser)]
#[command(
    about = "The whole frame on the Cell: each policy and arrangement on animated scenes, section 5's metric against the oracle (default run: about 3½ min)"
)]
struct Args {
    /// Scenes, comma-separated: car, cup and rtperf:N[:SEED] play their
    /// own animations; any other scene (a mesh of the data directory) plays
    /// `part`: 2 % of its triangles split off as a part that moves.
    #[arg(long, value_delimiter = ',', default_value = "car,cup,rtperf:100000")]
    scenes: Vec<String>,
    /// Image sizes, comma-separated, WIDTHxHEIGHT.
    #[arg(long, value_delimiter = ',', default_value = "320x240,640x480")]
    sizes: Vec<String>,
    /// Frames per run (1 to 1,000).
    #[arg(long, default_value_t = 10, value_parser = cellbih_cli::args::between::<u64, _>(1..=1000))]
    frames: u64,
    /// The builder of every rebuild (an emulated one).
    #[arg(long, default_value = "spe_bfs_private")]
    builder: String,
    #[command(flatten)]
    tree: TreeArgs,
    /// SPEs of the Cell (2 to 8: the paper's arrangement needs one to build
    /// and one to render).
    #[arg(long, default_value_t = 6, value_parser = cellbih_cli::args::between::<u64, _>(2..=8))]
    spes: u64,
    /// Seed of the animations' pseudo-random moves.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Also play each arrangement again, at the fixed policy that was its
    /// best, with every PPE rate at the cheap and at the dear end of its
    /// band and in each other code class, and say which arrangement wins
    /// at each (about 8 more runs a case).
    #[arg(long)]
    ends: bool,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    rates: RateArgs,
}

fn main() {
    cellbih_cli::report::main("frame_loop", |a: &Args| &a.run.output, run);
}

/// The animation a scene plays.
fn animation_of(spec: &str) -> &'static str {
    match spec.split(':').next() {
        Some("car") => "car",
        Some("cup") => "cup",
        Some("rtperf") => "rtperf",
        _ => "part",
    }
}

fn size_of(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("size '{s}': WIDTHxHEIGHT, e.g. 640x480");
    let (w, h) = s.split_once('x').ok_or_else(bad)?;
    let (w, h) = (w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?);
    cellbih::render::check_size(w, h)?;
    Ok((w, h))
}

fn run(args: &Args) -> Result<(), String> {
    use cellbih_cli::args::{Charges, set_charges};
    set_charges("frame_loop", Charges::builds_and(true, true));
    args.run.threads.install()?;
    let emulated = || -> Vec<&str> {
        (BuilderKind::ALL.iter())
            .filter(|b| b.emulated())
            .map(|b| b.name())
            .collect()
    };
    let builder = match BuilderKind::from_name(&args.builder) {
        Some(b) if b.emulated() => b,
        Some(b) => {
            return Err(format!(
                "--builder {b}: builds on the host, and the frame is timed on the Cell; \
                 the emulated builders: {}",
                emulated().join(", ")
            ));
        }
        None => {
            return Err(format!(
                "--builder {}: no such builder; the emulated builders: {}",
                args.builder,
                emulated().join(", ")
            ));
        }
    };
    let (cell, rates) = args.rates.ps3(args.spes as usize)?;
    let build = Build::new(builder)
        .with_tree(args.tree.config()?)
        .on(&cell)
        .with_rates(&rates);
    build.check().map_err(|e| e.to_string())?;
    let sizes: Vec<(u32, u32)> = args
        .sizes
        .iter()
        .map(|s| size_of(s))
        .collect::<Result<_, _>>()?;
    let scenes: Vec<(String, &str)> = (args.scenes.iter())
        .map(|s| (s.clone(), animation_of(s)))
        .collect();
    let spes = args.spes as usize;
    let policies = [
        Policy::Fixed(Method::Rebuild),
        Policy::Fixed(Method::Local),
        Policy::Fixed(Method::Deep),
        Policy::Auto,
    ];
    let arrangements = [("section 5", spes), ("paper", 1)];
    // Every scene loaded before any work; every one that does not, named.
    let loaded = cellbih_cli::report::load_scenes(&args.scenes, args.scene.data.dir().as_deref())?;
    let mut played = Vec::new();
    for ((spec, anim_name), s) in scenes.iter().zip(loaded) {
        let s = Animation::prepare(anim_name, s).map_err(|e| e.to_string())?;
        let anim = Animation::named(anim_name, &s, args.frames as usize, args.seed)?;
        played.push((spec, *anim_name, s, anim));
    }
    // Every (scene, size, arrangement, policy) side by side.
    let mut jobs = Vec::new();
    for si in 0..played.len() {
        for &(w, h) in &sizes {
            for (ai, &arrangement) in arrangements.iter().enumerate() {
                for (pi, &policy) in policies.iter().enumerate() {
                    jobs.push((si, (w, h), (ai, arrangement), (pi, policy)));
                }
            }
        }
    }
    let done = side_by_side(
        "runs",
        &jobs,
        |&(si, (w, h), (ai, (arrangement, build_spes)), (pi, policy))| {
            let (spec, anim_name, s, anim) = &played[si];
            let cfg = frame_config(&build, policy, build_spes, (w, h), args);
            let r = play(s, anim, &cfg, |_| {}).map_err(|e| format!("{spec}: {e}"))?;
            let n = r.frames.len() as f64;
            let mean = |f: &dyn Fn(&cellbih::frame::FrameReport) -> f64| {
                r.frames.iter().map(f).sum::<f64>() / n
            };
            let predicted: Vec<f64> = (r.frames.iter())
                .filter_map(|f| f.predicted.map(|p| cfg.frame_ms(p.update_ms, p.render_ms)))
                .collect();
            let prediction_error = (!predicted.is_empty()).then(|| {
                (r.frames.iter().zip(&predicted))
                    .map(|(f, p)| (p - f.frame_ms).abs() / f.frame_ms)
                    .sum::<f64>()
                    / predicted.len() as f64
            });
            let series = Series {
                name: format!("{} ({arrangement})", policy.name()),
                points: (r.frames.iter())
                    .map(|f| (f.frame as f64, f.frame_ms))
                    .collect(),
                color: pi,
                dashed: ai == 1,
            };
            let row = json!({
                "scene": spec,
                "triangles": s.len(),
                "animation": anim_name,
                "width": w,
                "height": h,
                "arrangement": arrangement,
                "build_spes": build_spes,
                "render_spes": cfg.render_spes(),
                "policy": policy.name(),
                "total_ms": r.total_ms,
                "fps": r.fps,
                "mean_update_ms": mean(&|f| f.update_ms),
                "mean_render_ms": mean(&|f| f.render_ms),
                "complete_rebuilds": r.frames.iter().filter(|f| f.full_rebuild).count(),
                "near_best": r.near_best,
                "oracle_total_ms": r.oracle_total_ms,
                "prediction_error": prediction_error,
                "contention": r.contention,
                "alone_total_ms": r.alone_total_ms,
                "sharing_bound_ms": r.sharing_bound_ms,
                "frames": r.frames,
            });
            Ok::<_, String>((row, series))
        },
    );
    // The rows in order; a plot per scene and size, drawn after the
    // measurements are written.
    let mut rows = Vec::new();
    let per_plot = arrangements.len() * policies.len();
    let mut series = Vec::new();
    let mut plots = Vec::new();
    for (k, d) in done.into_iter().enumerate() {
        let (row, line) = d?;
        rows.push(row);
        series.push(line);
        if series.len() < per_plot {
            continue;
        }
        let (si, (w, h), ..) = jobs[k];
        plots.push((played[si].0, (w, h), std::mem::take(&mut series)));
    }
    const KEYS: [&str; 21] = [
        "scene",
        "triangles",
        "animation",
        "width",
        "height",
        "arrangement",
        "build_spes",
        "render_spes",
        "policy",
        "total_ms",
        "fps",
        "mean_update_ms",
        "mean_render_ms",
        "complete_rebuilds",
        "near_best",
        "oracle_total_ms",
        "prediction_error",
        "contention",
        "alone_total_ms",
        "sharing_bound_ms",
        "frames",
    ];
    let flat: Vec<Value> = rows
        .iter()
        .map(|r| {
            let mut r = r.clone();
            r["frames"] = json!(r["frames"].as_array().map_or(0, |f| f.len()));
            r
        })
        .collect();
    let (in_force, end_rows) = match args.ends {
        true => play_ends(args, &build, (&played, &rows), &arrangements)?,
        false => (Vec::new(), Vec::new()),
    };
    let note = "simulated PS3 ms on the default model; section 5: every SPE builds, then every SPE renders (frame = update + render); paper: one SPE builds the next frame while the others render (frame = the longer); near_best: auto's frames within 10 % of the oracle's best option; prediction_error: auto's mean |predicted − measured| / measured frame time";
    args.run.output.report(
        "frame_loop",
        (&KEYS, &flat),
        &json!({
            "note": note, "builder": builder.name(), "spes": spes, "rows": rows,
            "ends": end_rows,
        }),
        Some(&build),
        |rows| {
            table(rows, note);
            goals(rows);
            arrangement_table(rows);
            if args.ends {
                ends::table(&in_force, &end_rows);
            }
        },
    )?;
    for (spec, (w, h), series) in plots {
        let file = format!(
            "frame_loop_{}_{w}x{h}.svg",
            cellbih_cli::report::file_part(spec)
        );
        let path = output(&args.run.output.out, &file).map_err(|e| e.to_string())?;
        line_plot(
            &path,
            &format!("{spec}, {w} × {h}: frame time on the PS3 model"),
            "frame",
            "simulated ms",
            &series,
            false,
        )
        .map_err(|e| e.to_string())?;
    }

    cellbih_cli::report::result_set::say_written(format!(
        "written: {}/frame_loop.{{csv,json}}, frame_loop_*.svg",
        args.run.output.out.display()
    ));
    Ok(())
}

/// The frame loop's configuration of one run.
fn frame_config(
    build: &Build,
    policy: Policy,
    build_spes: usize,
    (width, height): (u32, u32),
    args: &Args,
) -> FrameConfig {
    FrameConfig {
        build: build.clone(),
        policy,
        oracle: policy == Policy::Auto,
        build_spes,
        width,
        height,
        view: args.scene.camera.view(),
        cast: CastConfig::DEFAULT,
        find_moved: Default::default(),
    }
}

/// A scene as played: its spec, animation name, scene and animation.
type Played<'a> = (&'a String, &'a str, cellbih::scene::Scene, Animation);

/// `--ends`: each case's arrangements played again at their best fixed
/// policies on every end of the model ([`ends::ends`]). Returns each
/// case's ratio at the rates in force and a row per case and end.
fn play_ends(
    args: &Args,
    build: &Build,
    (played, rows): (&[Played], &[Value]),
    arrangements: &[(&str, usize)],
) -> Result<(Vec<Value>, Vec<Value>), String> {
    let total = |r: &Value| r["total_ms"].as_f64().unwrap_or(f64::INFINITY);
    let ends = ends::ends(&build.cell, &build.rates);
    // Each case's best fixed policy per arrangement: (scene index, size,
    // [(policy, build SPEs, total ms)]).
    let mut cases = Vec::new();
    for (si, p) in played.iter().enumerate() {
        let mut seen = Vec::new();
        for r in rows.iter().filter(|r| r["scene"] == *p.0) {
            let size = (
                r["width"].as_u64().unwrap_or(0),
                r["height"].as_u64().unwrap_or(0),
            );
            if seen.contains(&size) {
                continue;
            }
            seen.push(size);
            let best = |arrangement: &str| {
                (rows.iter())
                    .filter(|x| x["scene"] == *p.0 && x["width"] == size.0 && x["height"] == size.1)
                    .filter(|x| x["arrangement"] == arrangement && x["policy"] != "auto")
                    .min_by(|a, b| total(a).total_cmp(&total(b)))
                    .map(|x| (x["policy"].as_str().unwrap_or("").to_string(), total(x)))
            };
            let picks: Option<Vec<_>> = (arrangements.iter())
                .map(|&(a, spes)| best(a).map(|(pol, ms)| (pol, spes, ms)))
                .collect();
            if let Some(picks) = picks {
                cases.push((si, (size.0 as u32, size.1 as u32), picks));
            }
        }
    }
    let mut jobs = Vec::new();
    for (ci, case) in cases.iter().enumerate() {
        for (ei, _) in ends.iter().enumerate() {
            for ai in 0..case.2.len() {
                jobs.push((ci, ei, ai));
            }
        }
    }
    let done = side_by_side("ends", &jobs, |&(ci, ei, ai)| {
        let (si, size, picks) = &cases[ci];
        let (spec, _, s, anim) = &played[*si];
        let (policy, build_spes, _) = &picks[ai];
        let method = Method::from_name(policy).ok_or_else(|| format!("policy {policy}"))?;
        let end = &ends[ei];
        let b = build.clone().on(&end.cell).with_rates(&end.rates);
        let cfg = frame_config(&b, Policy::Fixed(method), *build_spes, *size, args);
        let r = play(s, anim, &cfg, |_| {}).map_err(|e| format!("{spec} ({}): {e}", end.name))?;
        Ok::<_, String>(r.total_ms)
    });
    let done: Vec<f64> = done.into_iter().collect::<Result<_, _>>()?;
    let (mut in_force, mut out) = (Vec::new(), Vec::new());
    let mut k = 0;
    for (si, (w, h), picks) in &cases {
        let case = json!({ "scene": played[*si].0, "width": w, "height": h });
        let mut at = json!({ "ratio": ends::ratio(picks[0].2, picks[1].2) });
        for key in ["scene", "width", "height"] {
            at[key] = case[key].clone();
        }
        in_force.push(at);
        for end in &ends {
            out.push(ends::row(&case, &end.name, done[k], done[k + 1]));
            k += 2;
        }
    }
    Ok((in_force, out))
}

/// The rows in two tables of 80 columns (times, then the policy's
/// choices), and the note wrapped.
fn table(rows: &[Value], note: &str) {
    let lead = |r: &Value| {
        format!(
            "{:<13} {:>9} {:<9} {:<7}",
            cut(r["scene"].as_str().unwrap_or(""), 13),
            format!("{}x{}", r["width"], r["height"]),
            r["arrangement"].as_str().unwrap_or(""),
            r["policy"].as_str().unwrap_or(""),
        )
    };
    let head = format!(
        "{:<13} {:>9} {:<9} {:<7}",
        "scene", "size", "arrange", "policy"
    );
    println!(
        "{head} {:>9} {:>7} {:>9} {:>9}",
        "total ms", "fps", "update ms", "render ms"
    );
    for r in rows {
        println!(
            "{} {:>9.2} {:>7.1} {:>9.2} {:>9.2}",
            lead(r),
            r["total_ms"].as_f64().unwrap_or(0.0),
            r["fps"].as_f64().unwrap_or(0.0),
            r["mean_update_ms"].as_f64().unwrap_or(0.0),
            r["mean_render_ms"].as_f64().unwrap_or(0.0),
        );
    }
    println!(
        "\n{head} {:>8} {:>9} {:>9}",
        "rebuilds", "near best", "pred err"
    );
    for r in rows {
        let pct = |k: &str| {
            r[k].as_f64()
                .map_or("-".into(), |v| format!("{:.0} %", v * 100.0))
        };
        println!(
            "{} {:>8} {:>9} {:>9}",
            lead(r),
            r["complete_rebuilds"].as_u64().unwrap_or(0),
            pct("near_best"),
            pct("prediction_error"),
        );
    }
    println!("{}", cellbih_cli::report::wrap(note, 80));
}

/// `text` cut to `n` characters, an ellipsis in the last place when cut
/// (a scene given as a long path still fits its column).
fn cut(text: &str, n: usize) -> String {
    match text.chars().count() > n {
        true => text.chars().take(n - 1).chain(['…']).collect(),
        false => text.to_string(),
    }
}

/// Which arrangement wins each scene and size, each at its best policy
/// (fixed or `auto`), and by how much; for the paper's, what running the
/// update beside the render on one Cell added to each alone, and the bound
/// on it (both as a share of the frames alone).
fn arrangement_table(rows: &[Value]) {
    println!("\nwhich arrangement wins, each at its best policy:");
    println!(
        "{:<12} {:>9} {:<7} {:>8} {:<7} {:>8} {:>8} {:>7} {:>6}",
        "scene", "size", "sec 5", "ms", "paper", "ms", "paper/5", "shared", "bound"
    );
    let total = |r: &Value| r["total_ms"].as_f64().unwrap_or(f64::INFINITY);
    let mut seen = Vec::new();
    for r in rows {
        let case = (r["scene"].clone(), r["width"].clone(), r["height"].clone());
        if seen.contains(&case) {
            continue;
        }
        let best = |arrangement: &str| {
            (rows.iter())
                .filter(|x| (x["scene"].clone(), x["width"].clone(), x["height"].clone()) == case)
                .filter(|x| x["arrangement"] == arrangement)
                .min_by(|a, b| total(a).total_cmp(&total(b)))
        };
        let (Some(five), Some(paper)) = (best("section 5"), best("paper")) else {
            continue;
        };
        let alone = paper["alone_total_ms"].as_f64().unwrap_or(f64::NAN);
        let bound = paper["sharing_bound_ms"].as_f64().unwrap_or(f64::NAN);
        println!(
            "{:<12} {:>9} {:<7} {:>8.2} {:<7} {:>8.2} {:>8.3} {:>5.1} % {:>4.1} %",
            cut(r["scene"].as_str().unwrap_or(""), 12),
            format!("{}x{}", r["width"], r["height"]),
            five["policy"].as_str().unwrap_or(""),
            total(five),
            paper["policy"].as_str().unwrap_or(""),
            total(paper),
            total(paper) / total(five),
            (total(paper) / alone - 1.0) * 100.0,
            bound / alone * 100.0,
        );
        seen.push(case);
    }
    let line = "each arrangement at its best policy; paper/5: the paper's total over section \
                5's (above 1: section 5's wins); shared: what the update beside the render on \
                one Cell added to each alone; bound: the most sharing the memory interface \
                could add";
    println!("{}", cellbih_cli::report::wrap(line, 80));
}

/// The metric's goals per case (scene, size, arrangement): `auto`'s total
/// within 5 % of the best fixed policy's, at least 90 % of its frames
/// within 10 % of the oracle's best, its mean prediction error at most 5 %.
fn goals(rows: &[Value]) {
    println!("\nauto against the best fixed policy, per case:");
    println!(
        "{:<13} {:>9} {:<9} {:<7} {:>8} {:>8} {:>6} {:>5} {:>6}",
        "scene", "size", "arrange", "best", "best ms", "auto ms", "x best", "near", "pred"
    );
    let case = |r: &Value| {
        (
            r["scene"].clone(),
            r["width"].clone(),
            r["height"].clone(),
            r["arrangement"].clone(),
        )
    };
    let (mut cases, mut met) = (0, 0);
    for auto in rows.iter().filter(|r| r["policy"] == "auto") {
        let fixed = rows
            .iter()
            .filter(|r| case(r) == case(auto) && r["policy"] != "auto");
        let Some(best) = fixed.min_by(|a, b| {
            let t = |r: &Value| r["total_ms"].as_f64().unwrap_or(f64::INFINITY);
            t(a).total_cmp(&t(b))
        }) else {
            continue;
        };
        let (best_ms, auto_ms) = (
            best["total_ms"].as_f64().unwrap_or(0.0),
            auto["total_ms"].as_f64().unwrap_or(0.0),
        );
        let ratio = auto_ms / best_ms;
        let near = auto["near_best"].as_f64().unwrap_or(0.0);
        let err = auto["prediction_error"].as_f64().unwrap_or(f64::INFINITY);
        cases += 1;
        met += (ratio <= 1.05 && near >= 0.9 && err <= 0.05) as usize;
        println!(
            "{:<13} {:>9} {:<9} {:<7} {:>8.2} {:>8.2} {:>6.3} {:>3.0} % {:>4.1} %",
            cut(auto["scene"].as_str().unwrap_or(""), 13),
            format!("{}x{}", auto["width"], auto["height"]),
            auto["arrangement"].as_str().unwrap_or(""),
            best["policy"].as_str().unwrap_or(""),
            best_ms,
            auto_ms,
            ratio,
            near * 100.0,
            err * 100.0,
        );
    }
    let line = format!(
        "goals (auto within 5 % of the best fixed policy, 90 % of its frames within 10 % \
         of the oracle's best, mean prediction error 5 % at most): met in {met} of {cases} cases"
    );
    println!("{}", cellbih_cli::report::wrap(&line, 80));
}
