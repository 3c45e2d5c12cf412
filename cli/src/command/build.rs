//! `cellbih build`: builds a scene's tree with one builder and reports its
//! time and quality (and, with `--trace`, the emulated Cell's timeline).

use std::path::Path;

use crate::Res;
use crate::args::{BuildCommand, parse_build};
use crate::command::print::print_build;
use crate::output::check_writable;
use cellbih::registry::Settings;

/// Runs `cellbih build`.
pub fn run(args: BuildCommand) -> Res<()> {
    let BuildCommand {
        scene,
        build,
        camera,
        format,
        trace,
    } = args;
    let mut c = parse_build(&build, false)?;
    if let Some(path) = &trace {
        if !c.builder.emulated() {
            return Err(format!(
                "--trace: builder '{}' does not run on the emulated Cell",
                c.builder
            )
            .into());
        }
        let inputs: Vec<_> = scene.input().into_iter().chain(build.inputs()).collect();
        let outputs = [("the report", Path::new("-")), ("--trace", path.as_path())];
        crate::output::check_files(&outputs, &inputs)?;
        if matches!(build.request.cell.mode, Some(crate::args::Mode::Functional)) {
            return Err("--trace: --mode functional has no timing, so no timeline; use --mode timed or checked".into());
        }
        check_writable(path)?;
    }
    scene.check_fits(&c, None)?;
    let s = scene.load()?;
    // A viewpoint of another scene is refused before the build.
    camera.view.camera(&s.name, &s.bounds(), 1, 1)?;
    c.cell.trace = trace.is_some();
    let mut report = super::build_checked(&s, &c, None)?;
    print_build(
        &s,
        &report,
        format,
        &Settings::new(&c, None).with_view(&camera.view),
        &camera.view,
    );
    if let Some(path) = &trace {
        let timeline = report.simulated.as_mut().and_then(|m| m.trace.take());
        super::write_timeline(path, timeline.as_ref(), "the build")?;
    }
    Ok(())
}
