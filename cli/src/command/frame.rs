//! `cellbih frame`: the frame loop on the Cell: per frame the
//! objects move, the tree follows by the policy, the primary rays are cast
//! on the SPEs; every time is simulated PS3 time.

use serde_json::json;

use cellbih::frame::{FrameConfig, FrameRun, Policy, play};
use cellbih::scene::Scene;
use cellbih::update::Animation;

use cellbih::registry::{Build, BuilderKind, Settings};

use crate::Res;
use crate::args::{CacheArgs, Format, FrameCommand, PlayArgs, check_memory, parse_build_or};

/// Runs `cellbih frame`.
pub fn run(args: FrameCommand) -> Res<()> {
    let FrameCommand {
        play,
        frames,
        policy,
        oracle,
        build_spes,
        width,
        height,
        camera,
        cache,
        format,
        trace,
    } = args;
    let mut c = parse_build_or(&play.build, BuilderKind::SPE_BFS, true)?;
    if let Some(path) = &trace {
        check_trace(path, &play, build_spes, c.cell.spes)?;
        c.cell.trace = true;
    }
    let local = matches!(policy.as_str(), "local" | "auto");
    let find_moved = play.find_moved(local, &format!("--policy {policy}"), &c)?;
    let PlayArgs { scene, anim, .. } = play;
    let asked = Asked {
        find_moved,
        policy: &policy,
        oracle,
        build_spes,
        width,
        height,
        view: camera.view,
        cache: &cache,
    };
    let cfg = config(&c, &asked)?;
    let rays = Some(width as usize * height as usize);
    scene.check_fits(&c, rays)?;
    let mut settings = anim
        .named(Settings::new(&cfg.build, Some(cfg.cast)).with_view(&cfg.view))
        .with("frames", frames)
        .with("policy", policy.as_str());
    if local {
        settings = settings.with("find-moved", find_moved.name());
    }
    let settings = settings
        .with("oracle", oracle)
        .with("build-spes", cfg.build_spes)
        .with("width", width)
        .with("height", height);
    let (s, anim) = anim.load(&scene, frames)?;
    check_memory(&s.name, (s.len(), 0), rays, &c, Default::default())?;
    check_frame_memory(&s, &cfg)?;
    let run = play_and_print(&s, &anim, &cfg, format, &settings)?;
    match &trace {
        Some(path) => super::write_timeline(path, run.trace.as_ref(), "the frames"),
        None => Ok(()),
    }
}

/// `--trace PATH`, checked before any work: the paper's arrangement (the
/// one-Cell runs are what it traces), a path that can be written and
/// replaces no input.
fn check_trace(
    path: &std::path::Path,
    play: &PlayArgs,
    build_spes: Option<u64>,
    spes: usize,
) -> Res<()> {
    if build_spes.is_none_or(|k| (k as usize) >= spes) {
        return Err(crate::usage(
            "--trace: the trace is of the paper's arrangement's one-Cell runs; give \
             --build-spes fewer than --spes",
        ));
    }
    let inputs: Vec<_> = (play.scene.input().into_iter())
        .chain(play.build.inputs())
        .collect();
    let outputs = [("the report", std::path::Path::new("-")), ("--trace", path)];
    crate::output::check_files(&outputs, &inputs)?;
    Ok(crate::output::check_writable(path)?)
}

/// Refuses, before any work, a frame the emulated Cell's main memory
/// cannot hold even at its least. In the paper's arrangement the one Cell
/// holds at once the casters' tree, triangles, rays and hits, and either
/// the tree's two copies an in-place update copies between or a whole
/// build (the lesser counted: a first frame does one of them); in
/// section 5's the build and the cast come one after the other
/// ([`check_memory`] checked each).
fn check_frame_memory(s: &Scene, cfg: &FrameConfig) -> Res<()> {
    if cfg.all_spes_build() {
        return Ok(());
    }
    let c = &cfg.build;
    let n = s.len();
    let rays = cfg.width as usize * cfg.height as usize;
    let nodes = (2 * n.div_ceil(c.tree.leaf_size.max(1) as usize)).saturating_sub(1);
    let order = Default::default();
    let build = c.builder.least_memory(n, &c.tree, cfg.build_spes);
    let copies = 2 * cellbih::frame::charge::tree_bytes(nodes, n, order).next_multiple_of(128);
    let need = cellbih::cast::memory_needed(nodes, n, rays, order) + build.min(copies);
    let have = c.cell.main_memory_bytes;
    if need > have {
        return Err(format!(
            "{}: the frame in the paper's arrangement holds on one Cell the cast ({rays} \
             rays) and the tree's two copies or a whole build: at least {} MiB of main \
             memory; the emulated Cell has {} MiB (--memory-mib): nothing built or cast",
            s.name,
            need.div_ceil(1 << 20),
            have >> 20
        )
        .into());
    }
    Ok(())
}

/// What `frame` was asked, checked.
pub struct Asked<'a> {
    pub find_moved: cellbih::update::FindMoved,
    pub policy: &'a str,
    pub oracle: bool,
    pub build_spes: Option<u64>,
    pub width: u32,
    pub height: u32,
    pub view: cellbih::render::View,
    pub cache: &'a CacheArgs,
}

/// Checks the options before any work; the frame loop's configuration.
pub fn config(c: &Build, a: &Asked) -> Res<FrameConfig> {
    let policy = Policy::from_name(a.policy).ok_or_else(|| {
        format!(
            "unknown --policy '{}': rebuild, local, deep or auto",
            a.policy
        )
    })?;
    if !c.cell.cost.charge_compute {
        return Err("frame measures simulated time: --mode functional has none".into());
    }
    cellbih::render::check_size(a.width, a.height)?;
    let spes = c.cell.spes;
    if let Some(k) = a.build_spes {
        if !c.builder.on_spes() {
            return Err(crate::usage(format!(
                "--build-spes: builder {} builds on the PPE, and no SPE builds",
                c.builder
            )));
        }
        if k as usize > spes {
            return Err(crate::usage(format!(
                "--build-spes {k}: more than the {spes} SPEs (--spes); give fewer than \
                 --spes for the paper's arrangement"
            )));
        }
        if k as usize == spes {
            return Err(crate::usage(format!(
                "--build-spes {k} with --spes {spes}: every SPE would build, then all \
                 render (section 5's arrangement, the default); give fewer than --spes \
                 for the paper's (some SPEs build while the others render)"
            )));
        }
    }
    Ok(FrameConfig {
        build: c.clone(),
        policy,
        oracle: a.oracle,
        build_spes: a.build_spes.map_or(spes, |k| k as usize),
        width: a.width,
        height: a.height,
        view: a.view.clone(),
        cast: a.cache.config()?,
        find_moved: a.find_moved,
    })
}

/// Plays the animation and prints every frame and the totals; the run.
pub fn play_and_print(
    s: &Scene,
    anim: &Animation,
    cfg: &FrameConfig,
    format: Format,
    settings: &crate::report::Settings,
) -> Res<FrameRun> {
    let progress = crate::report::Progress::new("frames", anim.frames.len() as u64);
    let run = play(s, anim, cfg, |_| progress.inc())?;
    progress.finish();
    print(s, anim, cfg, &run, format, settings);
    Ok(run)
}

fn print(
    s: &Scene,
    anim: &Animation,
    cfg: &FrameConfig,
    run: &FrameRun,
    format: Format,
    settings: &crate::report::Settings,
) {
    // "1 SPE builds", "2 SPEs build".
    let verb = |n: usize, what: &str| match n {
        1 => format!("1 SPE {what}s"),
        n => format!("{n} SPEs {what}"),
    };
    let arrangement = match (cfg.all_spes_build(), cfg.spes()) {
        (true, 1) => "the one SPE builds, then renders".to_string(),
        (true, n) => format!("all {n} SPEs build, then all render"),
        (false, _) => format!(
            "{} the next frame while {} (the paper's arrangement)",
            verb(cfg.build_spes, "build"),
            verb(cfg.render_spes(), "render")
        ),
    };
    if let Format::Json = format {
        let v = json!({
            "settings": settings.to_json(),
            "scene": s.name,
            "triangles": s.len(),
            "animation": anim.name,
            "builder": cfg.build.builder.name(),
            "policy": cfg.policy.name(),
            "spes": cfg.spes(),
            "build_spes": cfg.build_spes,
            "width": cfg.width,
            "height": cfg.height,
            // `choice` is what the frame did, as the table says it
            // (`rebuild` where a local or deep update rebuilt completely);
            // `policy_choice` what the policy chose.
            "frames": (run.frames.iter()).map(|f| {
                let mut v = json!(f);
                v["policy_choice"] = json!(f.choice);
                v["choice"] = json!(f.what_ran());
                v
            }).collect::<Vec<_>>(),
            "total_ms": run.total_ms,
            "fps": run.fps,
            "oracle": cfg.oracle,
            "near_best": run.near_best,
            "oracle_total_ms": run.oracle_total_ms,
            "second_copy_bytes": run.second_copy_bytes,
            "contention": run.contention,
            "alone_total_ms": run.alone_total_ms,
            "sharing_bound_ms": run.sharing_bound_ms,
            "overlap": {
                "total_ms": run.overlap_total_ms,
                "fps": run.overlap_fps,
                "what": "the PPE's search of each frame made during the frame before, after its graft",
                "policy_assumed": "serial",
            },
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&v).expect("plain values")
        );
        return;
    }
    let title = format!(
        "{} on {} ({}), {} × {}, policy {}, builder {}; {arrangement}",
        anim.name,
        s.name,
        crate::report::count(s.len() as u64, "triangle"),
        cfg.width,
        cfg.height,
        cfg.policy.name(),
        cfg.build.builder
    );
    println!("{}", crate::report::wrap(&title, 80));
    let line = format!("settings: {}", settings.line());
    println!("{}", crate::report::wrap(&line, 80));
    let oracle = run.frames.iter().any(|f| f.oracle_ms.is_some());
    let predicted = run.frames.iter().any(|f| f.predicted.is_some());
    println!(
        "{:>5} {:>8} {:>8} {:>10} {:>10} {:>10} {:>9} {:>6}",
        "frame", "choice", "rebuilt", "update ms", "render ms", "frame ms", "ray cost", "cache"
    );
    for f in &run.frames {
        let choice = f.what_ran();
        println!(
            "{:>5} {choice:>8} {:>8} {:>10.2} {:>10.2} {:>10.2} {:>9.1} {:>5.1}%",
            f.frame,
            f.rebuilt,
            f.update_ms,
            f.render_ms,
            f.frame_ms,
            f.ray_cost,
            f.cache_hit_rate * 100.0
        );
    }
    // What the metric predicted and what every option measured: a second
    // table, so that each fits 80 columns.
    if predicted || oracle {
        print!("\n{:>5} {:>8}", "frame", "choice");
        if predicted {
            print!(" {:>11} {:>11}", "pred upd ms", "pred ren ms");
        }
        if oracle {
            print!(" {:>10} {:>10} {:>10}", "rebuild ms", "local ms", "deep ms");
        }
        println!();
        for f in &run.frames {
            let choice = f.what_ran();
            print!("{:>5} {choice:>8}", f.frame);
            if let Some(p) = f.predicted {
                print!(" {:>11.2} {:>11.2}", p.update_ms, p.render_ms);
            }
            if let Some([r, l, d]) = f.oracle_ms {
                print!(" {r:>10.2} {l:>10.2} {d:>10.2}");
            }
            println!();
        }
    }
    let total = format!(
        "total {:.2} ms for {}: {:.2} frames per second (simulated PS3 time; ray cost: nodes + \
         triangles per ray; cache: the software cache's hit rate)",
        run.total_ms,
        crate::report::count(run.frames.len() as u64, "frame"),
        run.fps
    );
    println!("\n{}", crate::report::wrap(&total, 80));
    let sum = |f: fn(&cellbih::frame::FrameReport) -> f64| run.frames.iter().map(f).sum::<f64>();
    let mut of_it = format!(
        "of it: the PPE's share of the updates {:.2} ms, program switches {:.2} ms",
        sum(|f| f.ppe_ms),
        sum(|f| f.switch_ms)
    );
    if let (Some(bytes), Some(bound), Some(alone)) = (
        run.second_copy_bytes,
        run.sharing_bound_ms,
        run.alone_total_ms,
    ) {
        of_it += &format!(
            ", copies into the tree's second copy ({:.1} MiB) {:.2} ms; the update and the \
             render side by side on one Cell: {:+.2} ms against each alone (the bound on \
             sharing the memory interface: at most {bound:+.2} ms)",
            bytes as f64 / (1u64 << 20) as f64,
            sum(|f| f.copy_ms),
            run.total_ms - alone
        );
    }
    println!("{}", crate::report::wrap(&of_it, 80));
    let overlap = format!(
        "overlapped (each frame's PPE search during the frame before): {:.2} ms, {:.2} fps; \
         chosen by the serial frames",
        run.overlap_total_ms, run.overlap_fps
    );
    println!("{}", crate::report::wrap(&overlap, 80));
    if let (Some(near), Some(best)) = (run.near_best, run.oracle_total_ms) {
        let line = format!(
            "oracle: {:.0} % of the frames within 10 % of the best option; every frame at its \
             best: {best:.2} ms ({:+.1} %)",
            near * 100.0,
            (run.total_ms / best - 1.0) * 100.0
        );
        println!("{}", crate::report::wrap(&line, 80));
    }
}
