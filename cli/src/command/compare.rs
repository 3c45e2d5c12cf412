//! `cellbih compare`: every builder side by side on one scene — simulated
//! time on the PS3 model and speedup over the single-SPE baseline
//! `spe_bfs`, host time, SAH, measured ray cost (primary rays of the render
//! camera, one host thread) and the tree's memory. The demo (`cellbih` with
//! no arguments) is this on the embedded default scene.

use std::io::IsTerminal;
use std::path::Path;

use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;

use crate::report::Settings;
use cellbih::bih::Tracer;
use cellbih::cast::{CastConfig, cast_on_cell};
use cellbih::quality::rays::{RayCost, RaySets};
use cellbih::registry::{Build, BuildReport, BuilderKind};
use cellbih::render::View;
use cellbih::scene::Scene;

use crate::Res;
use crate::args::{CompareCommand, Format, RequestArgs, check_memory};

/// Runs `cellbih compare`.
pub fn run(args: CompareCommand) -> Res<()> {
    let CompareCommand {
        scene,
        request: RequestArgs { tree, cell, host },
        camera,
        format,
    } = args;
    if matches!(cell.mode, Some(crate::args::Mode::Functional)) {
        return Err("--mode functional: compare reports simulated time, and the functional mode times nothing; use --mode timed or checked".into());
    }
    let (cell, rates) = cell.config_and_rates()?;
    // A scene whose triangle records and fewest nodes alone overflow the
    // emulated Cell fails every emulated builder: refused before any
    // build (the naive PPE build needs nothing more).
    let emulated = Build::new(BuilderKind::PPE_NAIVE).on(&cell);
    scene.check_fits(&emulated, None)?;
    let s = scene.load()?;
    check_memory(&s.name, (s.len(), 0), None, &emulated, Default::default())?;
    // A viewpoint of another scene is refused before any build.
    camera.view.camera(&s.name, &s.bounds(), 1, 1)?;
    let threads = host.or_all();
    // What every builder shares; each runs with its default knobs.
    let shared = Build::new(BuilderKind::HOST)
        .with_tree(tree.config()?)
        .on(&cell)
        .with_rates(&rates)
        .on_threads(threads);
    let c = shared.install(|| rows(&s, &shared, &camera.view).map_err(|e| e.to_string()))??;
    print(&s, &shared, &c, format, &camera.view);
    match c.failed.len() {
        0 => Ok(()),
        n => Err(format!(
            "{} failed: {}",
            crate::report::count(n as u64, "builder"),
            super::names(&c.failed)
        )
        .into()),
    }
}

/// The camera image whose primary rays `compare` casts on the SPEs
/// through each emulated builder's tree: the render, in the build's
/// currency.
pub const CAST_SIZE: (u32, u32) = (320, 240);

/// Node visits and triangle tests (estimated from the primary rays' cost
/// on the host) that the cast on the SPEs may emulate for one builder:
/// about two seconds of host time. A tree whose camera rays would cost more
/// (a shallow tree's huge leaves) is cast on every k-th ray, its simulated
/// time scaled by k, and the row says so. The dragon's trees take about
/// 4 M.
pub const CAST_BUDGET: f64 = 8e6;

/// One builder's row.
pub struct Row {
    pub builder: BuilderKind,
    pub host_ms: f64,
    pub simulated_ms: Option<f64>,
    /// Emulated builders: simulated ms to cast the camera's
    /// [`CAST_SIZE`] primary rays through the tree on the SPEs.
    pub render_ms: Option<f64>,
    /// Where the cast would have cost more than [`CAST_BUDGET`]: the rays
    /// cast (every k-th), `render_ms` scaled to all of them.
    pub render_sampled: Option<usize>,
    /// Why the cast on the SPEs could not run (it needs the tree, the
    /// triangles and the rays in the emulated memory), if it could not.
    pub render_error: Option<String>,
    pub nodes: usize,
    pub depth: u32,
    pub sah: f64,
    /// Primary rays of the render camera, and incoherent rays.
    pub primary: RayCost,
    pub incoherent: RayCost,
    pub tree_bytes: usize,
    /// Emulated builders: main memory the build used (every buffer).
    pub main_memory: Option<u64>,
}

/// What `compare` measured: a row per builder that built the tree, each
/// failure by builder, and the last build that succeeded.
pub struct Compared {
    pub rows: Vec<Row>,
    pub failed: Vec<(BuilderKind, String)>,
    pub last: Option<BuildReport>,
}

/// Builds `s` as `shared` asks (its tree, Cell and host threads) by every
/// builder that builds that tree, with its default knobs, checks each tree and casts the standard ray sets ([`RaySets`])
/// through it. A builder that fails (a build that does not fit the
/// emulated memory, say) is a failure named by builder, and the others go
/// on. Progress on stderr when it is a terminal.
pub fn rows(
    s: &Scene,
    shared: &Build,
    view: &View,
) -> Result<Compared, Box<dyn std::error::Error>> {
    let (cfg, cell) = (&shared.tree, &shared.cell);
    let builders: Vec<BuilderKind> = (BuilderKind::ALL.iter().copied())
        .filter(|b| b.builds(cfg))
        .collect();
    let bar = if std::io::stderr().is_terminal() {
        let bar = ProgressBar::new(builders.len() as u64);
        bar.set_style(ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}")?);
        bar
    } else {
        ProgressBar::hidden()
    };
    let rays = RaySets::for_scene(s, view)?;
    // The camera's rays in blocks of the cast's packets, the order they
    // take; a sample of them keeps whole packets.
    let packet = CastConfig::DEFAULT.packet;
    let cam = (view.camera(&s.name, &s.bounds(), CAST_SIZE.0, CAST_SIZE.1)?)
        .rays_in_blocks(packet.w, packet.h);
    let mut out = Vec::new();
    let (mut last, mut failed) = (None, Vec::new());
    // On a terminal a bar; elsewhere a line for each builder that takes
    // more than a moment.
    let quietly = |what: &str, work: &mut dyn FnMut()| match bar.is_hidden() {
        true => crate::report::step(what, work),
        false => work(),
    };
    for b in builders {
        bar.set_message(b.name());
        let mut built = None;
        quietly(&format!("building with {b}"), &mut || {
            built = Some(shared.for_builder(b).run(s));
        });
        let r = match built.expect("built") {
            Ok(r) => r,
            Err(e) => {
                failed.push((b, e.to_string()));
                bar.inc(1);
                continue;
            }
        };
        r.bih.validate(s).map_err(|e| format!("builder {b}: {e}"))?;
        let q = r.bih.quality();
        let tracer = Tracer::new(&r.bih, s);
        let mut costs = None;
        quietly(&format!("measuring {b}'s tree"), &mut || {
            costs = Some(rays.measure(&tracer))
        });
        let (primary, incoherent) = costs.expect("measured");
        let (mut render_ms, mut render_error, mut render_sampled) = (None, None, None);
        if r.simulated.as_ref().is_some_and(|m| m.run.timed) {
            let k = (primary.per_ray() * cam.len() as f64 / CAST_BUDGET)
                .ceil()
                .max(1.0) as usize;
            let sample: Vec<_> = (cam.chunks(packet.rays() as usize).step_by(k))
                .flatten()
                .copied()
                .collect();
            if k > 1 {
                render_sampled = Some(sample.len());
            }
            let mut cast = None;
            quietly(
                &format!("casting through {b}'s tree on the Cell"),
                &mut || {
                    cast = Some(cast_on_cell(
                        &r.bih,
                        s,
                        &sample,
                        &CastConfig::DEFAULT.with_rates(&shared.rates),
                        cell,
                        r.record_order(),
                    ))
                },
            );
            match cast.expect("cast") {
                Ok(c) if k > 1 => {
                    render_ms = Some(c.run.ms * cam.len() as f64 / sample.len() as f64)
                }
                Ok(c) => render_ms = Some(c.run.ms),
                Err(e) => render_error = Some(e.to_string()),
            }
        }
        out.push(Row {
            builder: b,
            host_ms: r.host_time.as_secs_f64() * 1e3,
            simulated_ms: r.simulated.as_ref().map(|m| m.run.ms),
            render_ms,
            render_error,
            render_sampled,
            nodes: q.nodes,
            depth: q.max_depth,
            sah: q.sah_cost,
            primary,
            incoherent,
            tree_bytes: q.memory_bytes,
            main_memory: r.simulated.as_ref().map(|m| m.footprint.total),
        });
        last = Some(r);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(Compared {
        rows: out,
        failed,
        last,
    })
}

/// The baseline's simulated ms (with the same knobs), for speedups.
fn baseline_ms(rows: &[Row]) -> Option<f64> {
    let base = rows.iter().find(|r| r.builder == BuilderKind::SPE_BFS)?;
    base.simulated_ms
}

/// Prints the rows as a table or as JSON, and the builders that failed.
pub fn print(s: &Scene, shared: &Build, c: &Compared, format: Format, view: &View) {
    let (spes, cfg) = (shared.cell.spes, &shared.tree);
    let mut settings = Settings::shared(shared).with_view(view);
    // The Cell render column casts with the default cast.
    settings.cast = Some(CastConfig::DEFAULT);
    let rows = &c.rows[..];
    let failed: Vec<serde_json::Value> = (c.failed.iter())
        .map(|(b, e)| json!({"builder": b.name(), "error": e}))
        .collect();
    let left_out: Vec<&str> = (BuilderKind::ALL.iter())
        .filter(|b| !b.builds(cfg))
        .map(|b| b.name())
        .collect();
    let base = baseline_ms(rows);
    let speedup = |r: &Row| Some(base? / r.simulated_ms?);
    if let Format::Json = format {
        let rows: Vec<_> = (rows.iter())
            .map(|r| {
                json!({
                    "builder": r.builder.name(), "host_ms": r.host_ms,
                    "simulated_ms": r.simulated_ms, "speedup_over_spe_bfs": speedup(r),
                    "cell_render_ms": r.render_ms, "cell_render_error": r.render_error,
                    "cell_render_rays_cast": r.render_sampled,
                    "nodes": r.nodes, "depth": r.depth, "sah_cost": r.sah,
                    "ray_nodes": r.primary.nodes, "ray_triangles": r.primary.triangles,
                    "mrays_per_s": r.primary.mrays_per_s, "incoherent": r.incoherent,
                    "tree_bytes": r.tree_bytes, "main_memory_bytes": r.main_memory,
                })
            })
            .collect();
        let doc = json!({
            "scene": s.name, "triangles": s.len(), "spes": spes,
            "settings": settings.to_json(),
            "rows": rows, "not_built_by": left_out, "failed": failed,
        });
        println!("{doc}");
        return;
    }
    let w = BuilderKind::ALL
        .iter()
        .map(|b| b.name().len())
        .max()
        .unwrap_or(0);
    // Two tables of at most 80 columns: what the build cost, what the
    // tree is worth.
    let opt = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |v| format!("{v:.d$}"));
    println!(
        "{:<w$} {:>9} {:>8} {:>8} {:>8} {:>6} {:>9} {:>9}",
        "builder", "Cell ms", "speedup", "host ms", "nodes", "depth", "tree KiB", "Cell MiB"
    );
    for r in rows {
        println!(
            "{:<w$} {:>9} {:>8} {:>8.2} {:>8} {:>6} {:>9.1} {:>9}",
            r.builder.name(),
            opt(r.simulated_ms, 2),
            opt(speedup(r), 2),
            r.host_ms,
            r.nodes,
            r.depth,
            r.tree_bytes as f64 / 1024.0,
            opt(r.main_memory.map(|b| b as f64 / (1024.0 * 1024.0)), 2),
        );
    }
    println!(
        "\n{:<w$} {:>9} {:>11} {:>8} {:>11} {:>8} {:>11}",
        "builder", "SAH", "primary", "Mrays/s", "incoherent", "Mrays/s", "Cell render"
    );
    for r in rows {
        println!(
            "{:<w$} {:>9.2} {:>11} {:>8.2} {:>11} {:>8.2} {:>11}",
            r.builder.name(),
            r.sah,
            format!("{:.1}+{:.1}", r.primary.nodes, r.primary.triangles),
            r.primary.mrays_per_s,
            format!("{:.1}+{:.1}", r.incoherent.nodes, r.incoherent.triangles),
            r.incoherent.mrays_per_s,
            match r.render_sampled {
                Some(_) => format!("{}*", opt(r.render_ms, 2)),
                None => opt(r.render_ms, 2),
            },
        );
    }
    let sampled = |c: RayCost| c.sampled.is_some();
    if rows
        .iter()
        .any(|r| sampled(r.primary) || sampled(r.incoherent))
    {
        let line = format!(
            "(rays whose whole set would take more than {} node visits and triangle tests \
             are measured on an even sample of the set; --format json gives its size)",
            cellbih::quality::rays::WORK_BUDGET
        );
        println!("{}", crate::report::wrap(&line, 80));
    }
    if rows.iter().any(|r| r.render_sampled.is_some()) {
        let line = format!(
            "(*: the tree's rays would cost the emulation more than {CAST_BUDGET:.0} node visits \
             and triangle tests; cast on every k-th ray, its time scaled by k)"
        );
        println!("{}", crate::report::wrap(&line, 80));
    }
    // Grouped by what excludes them: only the options they do not build.
    let mut groups: Vec<(Vec<&str>, Vec<&str>)> = Vec::new();
    for b in BuilderKind::ALL.iter().filter(|b| !b.builds(cfg)) {
        let missing = b.quality().missing(cfg);
        match groups.iter_mut().find(|(m, _)| *m == missing) {
            Some((_, names)) => names.push(b.name()),
            None => groups.push((missing, vec![b.name()])),
        }
    }
    for (missing, names) in &groups {
        println!(
            "\n{}",
            crate::report::wrap(
                &format!(
                    "not built: {} ({} not build {})",
                    names.join(", "),
                    if names.len() == 1 {
                        "it does"
                    } else {
                        "they do"
                    },
                    missing.join(" or ")
                ),
                80
            )
        );
    }
    for r in rows {
        if let Some(e) = &r.render_error {
            let line = format!("not cast on the SPEs, builder {}: {e}", r.builder);
            println!("\n{}", crate::report::wrap(&line, 80));
        }
    }
    for (b, e) in &c.failed {
        println!(
            "\n{}",
            crate::report::wrap(&format!("FAILED: builder {b}: {e}"), 80)
        );
    }
    let with = if cfg.flags().is_empty() {
        String::new()
    } else {
        format!(" with {}", cfg.flags())
    };
    let note = format!(
        "trees{with} valid. Cell ms: simulated time on the PS3 model (multi-SPE builders on {}{}); \
         speedup: over\u{1}spe_bfs (one SPE, the paper's baseline); host figures: this machine, one \
         thread ({} build on --threads, by default every core); tree KiB: nodes and triangle \
         ids; Cell MiB: main memory the emulated build used \
         (every buffer). primary, incoherent: nodes visited + triangles tested per ray, closest \
         hit (the render camera's primary rays; 16,384 rays from random points in the scene box \
         in random directions); Cell render: simulated ms to cast the camera's {}×{} primary rays \
         through the tree on the SPEs.",
        // Kept on one line: "6 SPEs" is one phrase.
        match spes {
            1 => "1\u{1}SPE".to_string(),
            n => format!("up\u{1}to\u{1}{n}\u{1}SPEs"),
        },
        match spes {
            1 => "",
            _ => ": a small scene runs on fewer, --tris-per-spe",
        },
        {
            let names: Vec<&str> = (BuilderKind::ALL.iter())
                .filter(|b| b.host_threads())
                .map(|b| b.name())
                .collect();
            match names.split_last() {
                Some((last, [])) => last.to_string(),
                Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
                None => "no builder".into(),
            }
        },
        CAST_SIZE.0,
        CAST_SIZE.1
    );
    let note = crate::report::wrap(&note, 80).replace('\u{1}', " ");
    println!("\n{note}");
    let line = format!("settings: {}", settings.line());
    println!("\n{}", crate::report::wrap(&line, 80));
}

/// Where the demo writes its image (the current directory).
const DEMO_PNG: &str = "cellbih-demo.png";

/// `cargo run --release`: every builder on the default scene, then primary
/// rays and a rendered image.
pub fn demo() -> Res<()> {
    crate::output::check_writable(Path::new(DEMO_PNG))?;
    let s = cellbih::scene::load("default", None)?;
    println!(
        "cellbih demo: `cellbih compare` on scene '{}', {} triangles in {} objects\n",
        s.name,
        s.len(),
        s.geometry_names.len()
    );
    let shared = Build::new(BuilderKind::HOST);
    let c = rows(&s, &shared, &View::Default)?;
    print(&s, &shared, &c, Format::Text, &View::Default);
    if !c.failed.is_empty() {
        return Err(format!(
            "{} failed: {}",
            crate::report::count(c.failed.len() as u64, "builder"),
            super::names(&c.failed)
        )
        .into());
    }
    let r = c.last.expect("every builder built");
    let cam = View::Default.camera(&s.name, &s.bounds(), 640, 480)?;
    let tracer = Tracer::new(&r.bih, &s);
    let frame = cellbih::render::trace(&tracer, &s.triangles, &cam);
    super::write_png(Path::new(DEMO_PNG), &frame.shaded())?;
    println!("image written to {DEMO_PNG} (in the current directory)");
    println!("next:");
    for cmd in [
        "cellbih --help",
        "cellbih compare --scene rtperf:100000",
        "cellbih build --scene rtperf:100000",
        "cellbih update --scene car --animation car",
        "cellbih frame --scene car --animation car --builder spe_bfs --policy auto",
        "cargo test --release",
    ] {
        println!("  {cmd}");
    }
    Ok(())
}
