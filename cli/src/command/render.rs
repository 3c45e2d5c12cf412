//! `cellbih render`: builds the tree and renders a shaded PNG (or the
//! traversal cost per pixel), on the host or on the emulated Cell's SPEs.

use cellbih::bih::Tracer;
use cellbih::cast::cast_camera;
use cellbih::registry::Settings;
use cellbih::render::{self, Frame, trace};

use super::{check_png, shown, write_png};
use crate::Res;
use crate::args::{RenderCommand, parse_build};
use crate::report::step;

/// Runs `cellbih render`.
pub fn run(args: RenderCommand) -> Res<()> {
    let RenderCommand {
        scene,
        build,
        out,
        heatmap,
        width,
        height,
        camera,
        cast,
    } = args;
    let c = parse_build(&build, cast.on_cell)?;
    let inputs: Vec<_> = (scene.input().into_iter()).chain(build.inputs()).collect();
    let on_cell = cast.config(c.cell.cost.charge_compute, &out, &inputs)?;
    render::check_size(width, height)?;
    check_png(&out)?;
    let cast_rays = on_cell
        .is_some()
        .then_some(width as usize * height as usize);
    scene.check_fits(&c, cast_rays)?;
    let s = scene.load()?;
    // A viewpoint of another scene is refused before the build.
    camera.view.camera(&s.name, &s.bounds(), 1, 1)?;
    let report = super::build_checked(&s, &c, cast_rays)?;
    let cam = camera.view.camera(&s.name, &s.bounds(), width, height)?;
    let (frame, cell_report) = match &on_cell {
        Some(cfg) => {
            let cell = super::cast_cell(&s, &report, cast_rays, &c, &cast)?;
            let r = step("casting the rays on the Cell", || {
                cast_camera(
                    &report.bih,
                    &s,
                    &cam,
                    &cfg.with_rates(&c.rates),
                    &cell,
                    report.record_order(),
                )
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
    let settings = Settings::new(&c, on_cell)
        .with_view(&camera.view)
        .with("width", width)
        .with("height", height)
        .with("heatmap", heatmap);
    super::say_cast(&said, &settings, &c, cell_report.as_ref(), &cast)
}
