//! The `cellbih` command: inspect a scene, build its BIH with any builder,
//! cast rays from a file, render. With no arguments it runs a short
//! demonstration on the embedded default scene.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use rayon::prelude::*;

use cellbih::bih::{RayStats, Tracer};
use cellbih::cast::{cast_camera, cast_on_cell};
use cellbih::cell::CellConfig;
use cellbih::output::{check_writable, write_file};
use cellbih::registry::{Build, BuilderKind};
use cellbih::render::{Frame, trace};
use cellbih::report::{Settings, step, wrap};
use cellbih::update::{MAX_FRAMES, Method, Updater};
use cellbih::{rays_csv, render};

#[path = "cli/build_args.rs"]
mod build_args;
#[path = "cli/cast_args.rs"]
mod cast_args;
#[path = "cli/compare.rs"]
mod compare;
#[path = "cli/frame.rs"]
mod frame;
#[path = "cli/print.rs"]
mod print;
#[path = "cli/scene_arg.rs"]
mod scene_arg;
#[path = "cli/update.rs"]
mod update;

use build_args::{BuildArgs, TreeArgs, parse_build};

use print::{info, print_build};
use scene_arg::{CameraArg, SceneArg, check_built, check_memory};
use update::{AnimationArg, update};

/// Where the demo writes its image: the current directory.

#[derive(Parser)]
#[command(
    term_width = 80,
    name = "cellbih",
    version = cellbih::report::settings::version_static(),
    about = "Bounding Interval Hierarchies on an emulated Cell Broadband Engine",
    after_help = "With no command, runs the demo: every builder on the embedded default \
                  scene, a table of their times and trees, and the image cellbih-demo.png \
                  written in the current directory."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Clone, Copy, ValueEnum)]
enum Format {
    Text,
    Json,
}

#[derive(Subcommand)]
enum Command {
    /// Triangles, geometry ids, bounds and degenerate triangles of a scene.
    Info {
        #[command(flatten)]
        scene: SceneArg,
        #[arg(long, value_enum, default_value = "text")]
        format: Format,
    },
    /// Every builder side by side on one scene: simulated ms and speedup
    /// over spe_bfs, host ms, SAH, measured ray cost, the tree's memory.
    Compare {
        #[command(flatten)]
        scene: SceneArg,
        /// The tree every builder makes (builders that do not build these
        /// knobs are left out, and named).
        #[command(flatten)]
        tree: TreeArgs,
        /// SPEs of the emulated Cell for the multi-SPE builders, 1 to 16
        /// (9 to 16: a what-if).
        #[arg(long, default_value_t = 6, value_parser = cellbih::report::between::<u64, _>(1..=16))]
        spes: u64,
        /// Main memory of the emulated Cell, MiB (a PS3 has 256). A build
        /// that does not fit fails alone, named; the others are compared.
        #[arg(long, default_value_t = 256, value_parser = cellbih::report::between::<u64, _>(1..=4096))]
        memory_mib: u64,
        /// Host threads of the builders that build on the host's cores
        /// (host_shared, …) [default: the machine's available parallelism]
        #[arg(long, value_parser = cellbih::report::between::<u64, _>(1..=1024))]
        threads: Option<u64>,
        #[command(flatten)]
        camera: CameraArg,
        #[arg(long, value_enum, default_value = "text")]
        format: Format,
    },
    /// Builds the tree and reports its time and quality.
    Build {
        #[command(flatten)]
        scene: SceneArg,
        #[command(flatten)]
        build: BuildArgs,
        #[command(flatten)]
        camera: CameraArg,
        #[arg(long, value_enum, default_value = "text")]
        format: Format,
        /// Write the emulated Cell's timeline here as Chrome trace JSON
        /// (open it in ui.perfetto.dev or chrome://tracing). A trace costs
        /// about 100 bytes of file and 75 of memory per span, streamed to
        /// the file: spe_bfs on the default scene writes 0.4 MB, on the
        /// dragon 97 MB (946k spans, 70 MB more memory, 2 s more).
        #[arg(long)]
        trace: Option<PathBuf>,
    },
    /// Casts the rays of a CSV file (ox,oy,oz,dx,dy,dz,tmin,tmax) and writes
    /// the closest hits (ray,prim,t; a miss is prim -1).
    Raycast {
        #[command(flatten)]
        scene: SceneArg,
        #[command(flatten)]
        build: BuildArgs,
        /// The rays: a CSV file with the header ox,oy,oz,dx,dy,dz,tmin,tmax.
        #[arg(long)]
        rays: PathBuf,
        /// Where to write the hits (ray,prim,t), one line per ray.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        cast: cast_args::CastArgs,
    },
    /// Renders a shaded PNG, or with --heatmap the traversal cost per pixel.
    Render {
        #[command(flatten)]
        scene: SceneArg,
        #[command(flatten)]
        build: BuildArgs,
        /// The image to write (PNG: the name must end in .png).
        #[arg(long)]
        out: PathBuf,
        /// Color each pixel by its ray's traversal cost (nodes visited plus
        /// triangles tested) instead of shading it.
        #[arg(long)]
        heatmap: bool,
        /// Image width in pixels (1 to 16,384; at most 64 Mi pixels in all).
        #[arg(long, default_value_t = 800)]
        width: u32,
        /// Image height in pixels (1 to 16,384).
        #[arg(long, default_value_t = 600)]
        height: u32,
        #[command(flatten)]
        camera: CameraArg,
        #[command(flatten)]
        cast: cast_args::CastArgs,
    },
    /// Moves objects frame by frame and keeps the tree up to date (the
    /// paper's local update, the deeper update, or complete rebuilds).
    Update {
        #[command(flatten)]
        scene: SceneArg,
        #[command(flatten)]
        build: BuildArgs,
        #[command(flatten)]
        anim: AnimationArg,
        /// Frames to play, 0 to 100,000.
        #[arg(long, default_value_t = 20,
              value_parser = cellbih::report::between::<u64, _>(0..=MAX_FRAMES as u64))]
        frames: u64,
        /// local (Algorithm 1) | deep (section 5) | rebuild (every frame).
        #[arg(long, default_value = "local")]
        strategy: String,
        /// With --strategy deep: rebuild a touched subtree whole when it
        /// holds at most this many triangles [default: 48]
        #[arg(long)]
        deep_stop_below: Option<usize>,
        #[arg(long, value_enum, default_value = "text")]
        format: Format,
    },
    /// The whole frame on the Cell: per frame, objects move, the tree
    /// follows (rebuilt, or updated locally or deeply), and the primary
    /// rays are cast on the SPEs; every time is simulated PS3 time.
    Frame {
        #[command(flatten)]
        scene: SceneArg,
        #[command(flatten)]
        build: BuildArgs,
        #[command(flatten)]
        anim: AnimationArg,
        /// Frames to play, 1 to 100,000.
        #[arg(long, default_value_t = 10,
              value_parser = cellbih::report::between::<u64, _>(1..=MAX_FRAMES as u64))]
        frames: u64,
        /// How the tree follows the moves: rebuild (every frame, with
        /// --builder), local (Algorithm 1), deep (section 5), or auto
        /// (section 5's metric: each frame's options priced before any is
        /// done — what each would build, counted on a copy of the tree, at
        /// the cost of builds timed before the first frame, and the render
        /// of the tree each leaves — the cheapest taken).
        #[arg(long, default_value = "local")]
        policy: String,
        /// Also run every option from the same state each frame (three
        /// times the work) and report how the policy's choices compare.
        #[arg(long)]
        oracle: bool,
        /// SPEs that update the tree; the others render meanwhile (the
        /// paper's arrangement: 1). Default: all of --spes, which build and
        /// then all render (section 5's).
        #[arg(long, value_parser = cellbih::report::between::<u64, _>(1..=16))]
        build_spes: Option<u64>,
        /// Image width in pixels: one primary ray each.
        #[arg(long, default_value_t = 640)]
        width: u32,
        /// Image height in pixels.
        #[arg(long, default_value_t = 480)]
        height: u32,
        #[command(flatten)]
        camera: CameraArg,
        #[command(flatten)]
        cache: cast_args::CacheArgs,
        #[arg(long, value_enum, default_value = "text")]
        format: Format,
    },
    /// The names --builder accepts.
    Builders,
}

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn main() -> ExitCode {
    cellbih::report::quiet_on_closed_pipe();
    cellbih::report::one_line_on_failed_stdout("cellbih");
    cellbih::output::clean_up_on_interrupt();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Res<()> {
    match cli.command {
        None => compare::demo(),
        Some(Command::Builders) => {
            // 80 columns: each builder's name, what it is (indented 4),
            // then its knobs (`  --name`, their help indented 6).
            let wrapped = |indent: usize, text: &str| {
                let pad = " ".repeat(indent);
                let body = cellbih::report::wrap(text, 80 - indent);
                format!("{pad}{}", body.replace('\n', &format!("\n{pad}")))
            };
            for b in BuilderKind::ALL {
                let q = b.quality();
                let knobs = match (q.binned_sah, q.empty_cut) {
                    (true, true) => "; builds --split sah and --empty-cut",
                    (false, true) => "; builds --empty-cut",
                    (true, false) => "; builds --split sah",
                    (false, false) => "",
                };
                println!("{}", b.name());
                println!("{}", wrapped(4, &format!("{}{knobs}", b.describe())));
                for k in b.knobs() {
                    let range = match k.is_flag() {
                        true => String::new(),
                        false => format!(" ({}; default {})", k.range(), k.default_text()),
                    };
                    println!("  --{}", k.name);
                    println!("{}", wrapped(6, &format!("{}{range}", k.help)));
                }
            }
            Ok(())
        }
        Some(Command::Info { scene, format }) => info(&scene.load()?, format),
        Some(Command::Compare {
            scene,
            tree,
            spes,
            memory_mib,
            threads,
            camera,
            format,
        }) => {
            let mut cell = CellConfig::ps3().with_spes(spes as usize);
            cell.main_memory_bytes = memory_mib * 1024 * 1024;
            // A scene whose triangle records alone overflow the emulated
            // Cell fails every emulated builder: refused before any build.
            let emulated = Build::new(BuilderKind::SPE_BFS).on(&cell);
            scene.check_fits(&emulated, None)?;
            let s = scene.load()?;
            check_memory(&s.name, (s.len(), 0), None, &emulated, Default::default())?;
            // A viewpoint of another scene is refused before any build.
            camera.view.camera(&s.name, &s.bounds(), 1, 1)?;
            let threads = threads.map_or_else(
                || std::thread::available_parallelism().map_or(1, |n| n.get()),
                |n| n as usize,
            );
            // What every builder shares; each runs with its default knobs.
            let shared = Build::new(BuilderKind::HOST)
                .with_tree(tree.config()?)
                .on(&cell)
                .on_threads(threads);
            let c = shared.install(|| {
                compare::rows(&s, &shared, &camera.view).map_err(|e| e.to_string())
            })??;
            compare::print(&s, &shared, &c, format, &camera.view);
            match c.failed.len() {
                0 => Ok(()),
                n => Err(format!(
                    "{} failed: {}",
                    cellbih::report::count(n as u64, "builder"),
                    names(&c.failed)
                )
                .into()),
            }
        }
        Some(Command::Frame {
            scene,
            build,
            anim,
            frames,
            policy,
            oracle,
            build_spes,
            width,
            height,
            camera,
            cache,
            format,
        }) => {
            let c = build_args::parse_build_or(&build, BuilderKind::SPE_BFS, true)?;
            let asked = frame::Asked {
                policy: &policy,
                oracle,
                build_spes,
                width,
                height,
                view: camera.view,
                cache: &cache,
            };
            let cfg = frame::config(&c, &asked)?;
            let rays = Some(width as usize * height as usize);
            scene.check_fits(&c, rays)?;
            let settings = anim
                .named(Settings::new(&cfg.build, Some(cfg.cast)).with_view(&cfg.view))
                .with("frames", frames)
                .with("policy", policy.as_str())
                .with("oracle", oracle)
                .with("build-spes", cfg.build_spes)
                .with("width", width)
                .with("height", height);
            let (s, anim) = anim.load(&scene, frames)?;
            check_memory(&s.name, (s.len(), 0), rays, &c, Default::default())?;
            frame::run(&s, &anim, &cfg, format, &settings)
        }
        Some(Command::Update {
            scene,
            build,
            anim,
            frames,
            strategy,
            deep_stop_below,
            format,
        }) => {
            let c = parse_build(&build, false)?;
            let method = Method::from_name(&strategy).ok_or_else(|| {
                format!("unknown --strategy '{strategy}': local, deep or rebuild")
            })?;
            if deep_stop_below.is_some() && method != Method::Deep {
                return Err(format!(
                    "--deep-stop-below applies to --strategy deep only (here: {strategy})"
                )
                .into());
            }
            let deep_stop_below = deep_stop_below.unwrap_or(cellbih::update::DEEP_STOP_BELOW);
            let mut settings = anim
                .named(Settings::new(&c, None))
                .with("frames", frames)
                .with("strategy", strategy.as_str());
            if method == Method::Deep {
                settings = settings.with("deep-stop-below", deep_stop_below);
            }
            scene.check_fits(&c, None)?;
            let (s, anim) = anim.load(&scene, frames)?;
            check_memory(&s.name, (s.len(), 0), None, &c, Default::default())?;
            // The first build and every rebuild on the builder's threads.
            c.install(|| {
                let mut u = Updater::new(s, c.clone(), method).map_err(|e| e.to_string())?;
                u.deep_stop_below = deep_stop_below;
                update(&mut u, &anim, format, &c.describe(), &settings).map_err(|e| e.to_string())
            })??;
            Ok(())
        }
        Some(Command::Build {
            scene,
            build,
            camera,
            format,
            trace,
        }) => {
            let mut c = parse_build(&build, false)?;
            if let Some(path) = &trace {
                if !c.builder.emulated() {
                    return Err(format!(
                        "--trace: builder '{}' does not run on the emulated Cell",
                        c.builder
                    )
                    .into());
                }
                cellbih::output::check_distinct(&[
                    ("the report", Path::new("-")),
                    ("--trace", path),
                ])?;
                if matches!(build.mode, Some(build_args::Mode::Functional)) {
                    return Err("--trace: --mode functional has no timing, so no timeline; use --mode timed or checked".into());
                }
                check_writable(path)?;
            }
            scene.check_fits(&c, None)?;
            let s = scene.load()?;
            // A viewpoint of another scene is refused before the build.
            camera.view.camera(&s.name, &s.bounds(), 1, 1)?;
            check_memory(&s.name, (s.len(), 0), None, &c, Default::default())?;
            c.cell.trace = trace.is_some();
            let mut report = step(&format!("building {} with {}", s.name, c.builder), || {
                c.run(&s)
            })?;
            print_build(
                &s,
                &report,
                format,
                &Settings::new(&c, None).with_view(&camera.view),
                &camera.view,
            );
            if let Some(path) = &trace {
                let timeline = report
                    .simulated
                    .as_mut()
                    .and_then(|m| m.trace.take())
                    .ok_or("--trace: the build kept no timeline")?;
                write_file(path, |w| timeline.write_chrome(w))?;
                eprintln!(
                    "trace written to {} ({} spans)",
                    path.display(),
                    timeline.spans.len()
                );
            }
            Ok(())
        }
        Some(Command::Raycast {
            scene,
            build,
            rays,
            out,
            cast,
        }) => {
            let c = parse_build(&build, cast.on_cell)?;
            let on_cell = cast.config(c.cell.cost.charge_compute, &out)?;
            check_writable(&out)?;
            let rays_path = rays.display().to_string();
            // `-`: the rays come on the standard input.
            let rays = if rays.as_os_str() == "-" {
                rays_csv::read_rays("standard input", std::io::stdin().lock())?
            } else {
                let path = rays.display().to_string();
                let file = File::open(&rays).map_err(|e| format!("{path}: cannot open: {e}"))?;
                rays_csv::read_rays(&path, BufReader::new(file))?
            };
            let cast_rays = on_cell.is_some().then_some(rays.len());
            scene.check_fits(&c, cast_rays)?;
            let s = scene.load()?;
            check_memory(&s.name, (s.len(), 0), cast_rays, &c, Default::default())?;
            let report = step(&format!("building {} with {}", s.name, c.builder), || {
                c.run(&s)
            })?;
            let (hits, cell_report) = match &on_cell {
                Some(cfg) => {
                    check_built(&s, &report, cast_rays, &c)?;
                    let mut cell = c.cell.clone();
                    cell.trace = cast.trace.is_some();
                    let r = step("casting the rays on the Cell", || {
                        cast_on_cell(&report.bih, &s, &rays, cfg, &cell, report.record_order())
                    })?;
                    (r.hits.clone(), Some(r))
                }
                None => {
                    let tracer = Tracer::new(&report.bih, &s);
                    let hits: Vec<_> = rays
                        .par_iter()
                        .map(|r| tracer.closest(r, &mut RayStats::default()))
                        .collect();
                    (hits, None)
                }
            };
            write_file(&out, |w| rays_csv::write_hits(w, &hits))?;
            let n_hit = hits.iter().flatten().count();
            let said = format!(
                "{}, {} ({}), written to {}",
                cellbih::report::count(hits.len() as u64, "ray"),
                cellbih::report::count(n_hit as u64, "hit"),
                c.describe(),
                shown(&out)
            );
            eprintln!("{}", wrap(&said, 80));
            let settings = Settings::new(&c, on_cell).with("rays", rays_path.as_str());
            eprintln!("{}", wrap(&format!("settings: {}", settings.line()), 80));
            if let Some(r) = &cell_report {
                eprintln!("{}", wrap(&cast_args::describe(r, c.cell.spes), 80));
                cast_args::write_trace(&cast, r)?;
            }
            Ok(())
        }
        Some(Command::Render {
            scene,
            build,
            out,
            heatmap,
            width,
            height,
            camera,
            cast,
        }) => {
            let c = parse_build(&build, cast.on_cell)?;
            let on_cell = cast.config(c.cell.cost.charge_compute, &out)?;
            render::check_size(width, height)?;
            check_png(&out)?;
            let cast_rays = on_cell
                .is_some()
                .then_some(width as usize * height as usize);
            scene.check_fits(&c, cast_rays)?;
            let s = scene.load()?;
            // A viewpoint of another scene is refused before the build.
            camera.view.camera(&s.name, &s.bounds(), 1, 1)?;
            check_memory(&s.name, (s.len(), 0), cast_rays, &c, Default::default())?;
            let report = step(&format!("building {} with {}", s.name, c.builder), || {
                c.run(&s)
            })?;
            let cam = camera.view.camera(&s.name, &s.bounds(), width, height)?;
            let (frame, cell_report) = match &on_cell {
                Some(cfg) => {
                    check_built(&s, &report, cast_rays, &c)?;
                    let mut cell = c.cell.clone();
                    cell.trace = cast.trace.is_some();
                    let r = step("casting the rays on the Cell", || {
                        cast_camera(&report.bih, &s, &cam, cfg, &cell, report.record_order())
                    })?;
                    let f = Frame::of_hits(&cam, &s.triangles, &r.hits, &r.costs, r.stats());
                    (f, Some(r))
                }
                None => (
                    trace(&Tracer::new(&report.bih, &s), &s.triangles, &cam),
                    None,
                ),
            };
            let img = if heatmap {
                frame.heatmap()
            } else {
                frame.shaded()
            };
            write_png(&out, &img)?;
            let st = frame.stats;
            let said = format!(
                "{} written ({}); per ray: {:.1} nodes, {:.1} triangles{}",
                shown(&out),
                c.describe(),
                st.nodes_visited as f64 / st.rays as f64,
                st.triangles_tested as f64 / st.rays as f64,
                if heatmap {
                    format!("; white = {} (nodes + triangles)", frame.max_cost())
                } else {
                    String::new()
                }
            );
            eprintln!("{}", wrap(&said, 80));
            let settings = Settings::new(&c, on_cell)
                .with_view(&camera.view)
                .with("width", width)
                .with("height", height)
                .with("heatmap", heatmap);
            eprintln!("{}", wrap(&format!("settings: {}", settings.line()), 80));
            if let Some(r) = &cell_report {
                eprintln!("{}", wrap(&cast_args::describe(r, c.cell.spes), 80));
                cast_args::write_trace(&cast, r)?;
            }
            Ok(())
        }
    }
}

/// "1 SPE", "6 SPEs".
fn spes(n: usize) -> String {
    cellbih::report::count(n as u64, "SPE")
}

/// The builders of `failed`, by name.
fn names(failed: &[(BuilderKind, String)]) -> String {
    let v: Vec<&str> = failed.iter().map(|(b, _)| b.name()).collect();
    v.join(", ")
}

/// A path as messages name it: `-` is the standard output.
fn shown(path: &Path) -> String {
    match path.as_os_str() == "-" {
        true => "the standard output".into(),
        false => path.display().to_string(),
    }
}

/// Checks before any work that `path` names a PNG file that can be written.
fn check_png(path: &Path) -> Res<()> {
    // `-`: the PNG goes to the standard output.
    let png = path.as_os_str() == "-"
        || path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !png {
        return Err(format!(
            "{}: images are written as PNG: give a name ending in .png",
            path.display()
        )
        .into());
    }
    Ok(check_writable(path)?)
}

/// Encodes `img` as PNG into `path`, whole or not at all.
fn write_png(path: &Path, img: &image::RgbImage) -> Res<()> {
    let mut png = Vec::new();
    img.write_with_encoder(image::codecs::png::PngEncoder::new(&mut png))?;
    Ok(cellbih::output::write_bytes(path, &png)?)
}
