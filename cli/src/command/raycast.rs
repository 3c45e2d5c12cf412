//! `cellbih raycast`: builds the tree, casts the rays of a CSV file on the
//! host or on the emulated Cell's SPEs, and writes the closest hits.

use std::fs::File;
use std::io::BufReader;

use rayon::prelude::*;

use cellbih::bih::Tracer;
use cellbih::cast::cast_on_cell;
use cellbih::rays_csv;
use cellbih::registry::Settings;

use super::shown;
use crate::Res;
use crate::args::{RaycastCommand, parse_build};
use crate::output::{check_writable, write_file};
use crate::report::step;

/// Runs `cellbih raycast`.
pub fn run(args: RaycastCommand) -> Res<()> {
    let RaycastCommand {
        scene,
        build,
        rays,
        out,
        cast,
    } = args;
    let c = parse_build(&build, cast.on_cell)?;
    let inputs: Vec<_> = (scene.input().into_iter())
        .chain(build.inputs())
        .chain([("--rays", rays.as_path())])
        .collect();
    let on_cell = cast.config(c.cell.cost.charge_compute, &out, &inputs)?;
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
    // Every path traces each ray at unit scale (its hits are the same);
    // a hit's t is then given back in the ray's own units.
    let (rays, scales): (Vec<_>, Vec<_>) = rays.iter().map(|r| r.at_unit_scale()).unzip();
    let cast_rays = on_cell.is_some().then_some(rays.len());
    scene.check_fits(&c, cast_rays)?;
    let s = scene.load()?;
    let report = super::build_checked(&s, &c, cast_rays)?;
    let (hits, cell_report) = match &on_cell {
        Some(cfg) => {
            let cell = super::cast_cell(&s, &report, cast_rays, &c, &cast)?;
            let r = step("casting the rays on the Cell", || {
                cast_on_cell(
                    &report.bih,
                    &s,
                    &rays,
                    &cfg.with_rates(&c.rates),
                    &cell,
                    report.record_order(),
                )
            })?;
            (r.hits.clone(), Some(r))
        }
        None => {
            let tracer = Tracer::new(&report.bih, &s);
            // The tracer's fastest (`Tracer::hits`), in chunks over the
            // threads: the same hits as ray by ray.
            let hits: Vec<_> = (rays.par_chunks(4096))
                .map(|chunk| tracer.hits(chunk))
                .collect::<Vec<_>>()
                .concat();
            (hits, None)
        }
    };
    let hits: Vec<_> = (hits.into_iter().zip(scales))
        .map(|(h, k)| {
            let t = h.map(|h| cellbih::bih::times_pow2(h.t, -k));
            h.zip(t.filter(|t| t.is_finite()))
                .map(|(h, t)| cellbih::bih::Hit { t, ..h })
        })
        .collect();
    write_file(&out, |w| rays_csv::write_hits(w, &hits))?;
    let n_hit = hits.iter().flatten().count();
    let said = format!(
        "{}, {} ({}), written to {}",
        crate::report::count(hits.len() as u64, "ray"),
        crate::report::count(n_hit as u64, "hit"),
        c.describe(),
        shown(&out)
    );
    let settings = Settings::new(&c, on_cell).with("rays", rays_path.as_str());
    super::say_cast(&said, &settings, &c, cell_report.as_ref(), &cast)
}
