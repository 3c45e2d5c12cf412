//! The `cellbih` command's subcommands, one file each, and what several
//! of them share: how a cast on the Cell is described, paths as messages
//! name them, PNG output.

pub mod build;
pub mod builders;
pub mod compare;
pub mod frame;
pub mod info;
pub mod print;
pub mod rates;
pub mod raycast;
pub mod render;
pub mod update;

use std::path::Path;

use cellbih::cast::CastReport;
use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuildReport, BuilderKind, Settings};
use cellbih::scene::Scene;

use crate::Res;
use crate::args::{CastArgs, check_built, check_memory};
use crate::output::check_writable;
use crate::report::{step, wrap};

/// "1 SPE", "6 SPEs".
pub fn spes(n: usize) -> String {
    crate::report::count(n as u64, "SPE")
}

/// The builders of `failed`, by name.
pub fn names(failed: &[(BuilderKind, String)]) -> String {
    let v: Vec<&str> = failed.iter().map(|(b, _)| b.name()).collect();
    v.join(", ")
}

/// A path as messages name it: `-` is the standard output.
pub fn shown(path: &Path) -> String {
    match path.as_os_str() == "-" {
        true => "the standard output".into(),
        false => path.display().to_string(),
    }
}

/// Checks before any work that `path` names a PNG file that can be written.
pub fn check_png(path: &Path) -> Res<()> {
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
pub fn write_png(path: &Path, img: &image::RgbImage) -> Res<()> {
    let mut png = Vec::new();
    img.write_with_encoder(image::codecs::png::PngEncoder::new(&mut png))?;
    Ok(crate::output::write_bytes(path, &png)?)
}

/// One paragraph on what casting on the Cell cost: simulated time, rays
/// per second, the cache, where the SPEs' time went.
pub fn describe(r: &CastReport, on: usize) -> String {
    let st = r.stats();
    let per = |x: u64| x as f64 / st.rays.max(1) as f64;
    let cache = r.cache();
    let sh = r.shares();
    let switches: u64 = r.spes.iter().map(|s| s.switches).sum();
    let switched = if switches > 0 {
        format!(" ({switches} switches to another ray on a miss)")
    } else {
        String::new()
    };
    let packets: u64 = r.spes.iter().map(|s| s.packets).sum();
    let packed = if packets > 0 {
        let nodes: u64 = r.spes.iter().map(|s| s.packet_nodes).sum();
        format!(
            "; {}, {:.1} nodes each",
            crate::report::count(packets, "packet"),
            nodes as f64 / packets as f64
        )
    } else {
        String::new()
    };
    let (time, shares) = match r.rays_per_s() {
        Some(rps) => (
            format!(
                "{:.2} ms simulated on the PS3 model with {} ({:.2} M rays/s)",
                r.run.ms,
                spes(on),
                rps / 1e6
            ),
            format!(
                "; SPEs busy {:.0} % (least {:.0} %, most {:.0} %), waiting for DMA {:.0} %{switched}, atomic {:.1} %",
                sh.busy * 100.0,
                sh.busy_min * 100.0,
                sh.busy_max * 100.0,
                sh.dma_wait * 100.0,
                sh.atomic * 100.0,
            ),
        ),
        // Nothing was timed: no time and no shares of it.
        None => (
            format!("on {} in the functional mode (nothing timed)", spes(on)),
            String::new(),
        ),
    };
    format!(
        "on the Cell: {time}; per ray {:.1} nodes, {:.1} triangles{packed}; software cache hit rate {:.1} % ({} misses){shares}",
        per(st.nodes_visited),
        per(st.triangles_tested),
        cache.hit_rate() * 100.0,
        cache.misses,
    )
}

/// Writes the cast's timeline to `path` if one was asked for, and says so.
pub fn write_trace(args: &CastArgs, r: &CastReport) -> Res<()> {
    match &args.trace {
        Some(path) => write_timeline(path, r.trace.as_ref(), "the cast"),
        None => Ok(()),
    }
}

/// Writes `timeline` (what `what` kept, if it kept one) to `path` as
/// Chrome trace JSON, and says so.
pub fn write_timeline(path: &Path, timeline: Option<&cellbih::cell::Trace>, what: &str) -> Res<()> {
    let timeline = timeline.ok_or_else(|| format!("--trace: {what} kept no timeline"))?;
    crate::output::write_file(path, |w| timeline.write_chrome(w))?;
    eprintln!(
        "trace written to {} ({} spans)",
        path.display(),
        timeline.spans.len()
    );
    Ok(())
}

/// Builds `s` as `c` asks, once its memory is checked (for `cast_rays`
/// rays to cast on the Cell after the build, if any), saying so where the
/// build takes long.
pub fn build_checked(s: &Scene, c: &Build, cast_rays: Option<usize>) -> Res<BuildReport> {
    check_memory(&s.name, (s.len(), 0), cast_rays, c, Default::default())?;
    Ok(step(
        &format!("building {} with {}", s.name, c.builder),
        || c.run(s),
    )?)
}

/// The Cell a cast runs on, once the tree `report` built is checked to fit
/// beside `cast_rays` rays: `c`'s, keeping a timeline if `--trace` asks.
pub fn cast_cell(
    s: &Scene,
    report: &BuildReport,
    cast_rays: Option<usize>,
    c: &Build,
    cast: &CastArgs,
) -> Res<CellConfig> {
    check_built(s, report, cast_rays, c)?;
    let mut cell = c.cell.clone();
    cell.trace = cast.trace.is_some();
    Ok(cell)
}

/// Says on stderr what `said` says, the settings, and what a cast on the
/// Cell cost (writing its timeline where `--trace` asks).
pub fn say_cast(
    said: &str,
    settings: &Settings,
    c: &Build,
    cell_report: Option<&CastReport>,
    cast: &CastArgs,
) -> Res<()> {
    eprintln!("{}", wrap(said, 80));
    eprintln!("{}", wrap(&format!("settings: {}", settings.line()), 80));
    if let Some(r) = cell_report {
        eprintln!("{}", wrap(&describe(r, c.cell.spes), 80));
        write_trace(cast, r)?;
    }
    Ok(())
}
