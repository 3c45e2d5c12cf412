//! The real meshes of the data directory (CELLBIH_DATA; CI points it at
//! ../shared/data): each loads with the triangle count its README gives,
//! builds a valid tree with every builder, and answers rays as brute force
//! does.
//!
//! One test per mesh, under a harness of its own (libtest-mimic) so that a
//! skip is seen: with CELLBIH_DATA unset every mesh's test is reported
//! *ignored*, its name saying why, and the run says so in a line of its own;
//! with CELLBIH_DATA set, a missing mesh or directory is a failure.

mod common;

use cellbih::bih::Tracer;
use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{self, DATA_ENV};
use cellbih::strategy::Knobs;
use common::{check_ray, rays_for};
use libtest_mimic::{Arguments, Failed, Trial};

/// (name, triangles, zero-area triangles where the data README states them
/// unambiguously).
const MESHES: &[(&str, usize, Option<usize>)] = &[
    ("bunny", 69_451, Some(0)),
    ("dragon", 871_414, Some(108)),
    ("iss-nasa", 6_642, None),
    ("sponza-dabrovic", 66_450, Some(1)),
    ("sibenik", 76_529, Some(2)),
    ("rocker-arm", 20_088, Some(0)),
    ("homer", 12_000, Some(0)),
    ("cheburashka", 13_334, Some(0)),
    ("fandisk", 12_946, Some(0)),
    ("teapot", 6_320, Some(0)),
    ("beast", 64_618, Some(0)),
    ("ogre", 124_008, Some(4)),
    ("nefertiti", 99_938, Some(0)),
];

/// One mesh: it loads from `dir` with its counts, and every builder's tree
/// is valid and agrees with brute force.
fn check_mesh(
    dir: &std::path::Path,
    name: &str,
    triangles: usize,
    zero_area: Option<usize>,
) -> Result<(), Failed> {
    let s = scene::load(name, Some(dir)).map_err(|e| format!("{name}: {e}"))?;
    if s.len() != triangles {
        return Err(format!("{name}: {} triangles, expected {triangles}", s.len()).into());
    }
    if let Some(z) = zero_area
        && s.degenerate_count() != z
    {
        return Err(format!(
            "{name}: {} zero-area triangles, expected {z}",
            s.degenerate_count()
        )
        .into());
    }
    for &b in BuilderKind::ALL {
        let r = Build::new(b)
            .run(&s)
            .map_err(|e| format!("{name} / {b}: {e}"))?;
        r.bih
            .validate(&s)
            .map_err(|v| format!("{name} / {b}: {v}"))?;
        // Each flag a multi-SPE builder's table offers (stealing, the
        // paper's queue, …) on three SPEs in functional mode: every
        // buffer it sizes from the scene holds what the scene puts there
        // (Sibenik's deal once outgrew the stealing areas).
        if b.multi_spe() && name != "dragon" {
            let cell = CellConfig {
                cost: cellbih::cell::CostModel::functional(),
                checked: false,
                ..CellConfig::ps3().with_spes(3)
            };
            for k in b.knobs().iter().filter(|k| k.is_flag()) {
                let knobs = Knobs::default().with(k, "").unwrap();
                let f = Build::new(b)
                    .on(&cell)
                    .with_knobs(&knobs)
                    .run(&s)
                    .map_err(|e| format!("{name} / {b} --{}: {e}", k.name))?;
                f.bih
                    .validate(&s)
                    .map_err(|v| format!("{name} / {b} --{}: {v}", k.name))?;
            }
        }
        let tracer = Tracer::new(&r.bih, &s);
        // Brute force costs a pass over every triangle per ray.
        let rays = (3_000_000 / triangles).clamp(40, 400);
        for ray in rays_for(&s, rays, 99) {
            check_ray(&s, &tracer, &ray).map_err(|e| format!("{name} / {b}: {e}"))?;
        }
    }
    Ok(())
}

fn main() {
    let args = Arguments::from_args();
    let dir = scene::data_dir(None);
    if dir.is_none() {
        println!(
            "\nreal_meshes: {DATA_ENV} is not set: the {} real-mesh tests did NOT run \
             (set {DATA_ENV}=../shared/data to run them)",
            MESHES.len()
        );
    }
    let trials = MESHES
        .iter()
        .map(|&(name, triangles, zero_area)| match &dir {
            Some(dir) => {
                let dir = dir.clone();
                Trial::test(format!("real_mesh::{name}"), move || {
                    check_mesh(&dir, name, triangles, zero_area)
                })
            }
            None => Trial::test(
                format!("real_mesh::{name} (NOT RUN: {DATA_ENV} is not set)"),
                move || {
                    Err(
                        format!("{DATA_ENV} is not set: no data directory to load {name} from")
                            .into(),
                    )
                },
            )
            .with_ignored_flag(true),
        })
        .collect();
    libtest_mimic::run(&args, trials).exit();
}
