//! The real meshes of the data directory (CELLBIH_DATA; CI points it at
//! ../shared/data): each loads with the triangle count its README gives,
//! builds a valid tree with every builder, and answers rays as brute force
//! does; every multi-SPE builder builds the baseline's tree (the same tree
//! hash) on 1, 6 and 8 SPEs. The same for the zoo scenes of the
//! experiments (`scene::zoo::SET`), which stand on these meshes. And no
//! ray leaks through the fandisk, a closed mesh, turned off the axes
//! (`common::leaks`).
//!
//! One test per mesh, under a harness of its own (libtest-mimic) so that a
//! skip is seen: with CELLBIH_DATA unset every mesh's test is reported
//! *ignored*, its name saying why, and the run says so in a line of its own;
//! with CELLBIH_DATA set, a missing mesh or directory is a failure.

mod common;

use cellbih::bih::Tracer;
use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{self, DATA_ENV, Scene, zoo};
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
    let base = baseline_hash(&s)?;
    for &b in BuilderKind::ALL {
        let r = Build::new(b)
            .run(&s)
            .map_err(|e| format!("{name} / {b}: {e}"))?;
        r.bih
            .validate(&s)
            .map_err(|v| format!("{name} / {b}: {v}"))?;
        if b.multi_spe() {
            same_tree_on(&s, b, base, &[1, 8])?;
            check_hash(&s, b, 6, r.bih.tree_hash(), base)?;
        }
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

/// The baseline's tree hash on `s`.
fn baseline_hash(s: &Scene) -> Result<u64, Failed> {
    let r = Build::new(BuilderKind::SPE_BFS)
        .run(s)
        .map_err(|e| format!("{} / spe_bfs: {e}", s.name))?;
    Ok(r.bih.tree_hash())
}

fn check_hash(s: &Scene, b: BuilderKind, spes: usize, hash: u64, base: u64) -> Result<(), Failed> {
    match hash == base {
        true => Ok(()),
        false => Err(format!(
            "{} / {b} on {spes} SPEs: tree {hash:016x}, the baseline's {base:016x}",
            s.name
        )
        .into()),
    }
}

/// Builder `b` builds the baseline's tree (hash `base`) on `s` with each
/// SPE count of `spes`.
fn same_tree_on(s: &Scene, b: BuilderKind, base: u64, spes: &[usize]) -> Result<(), Failed> {
    for &n in spes {
        let cell = CellConfig::ps3().with_spes(n);
        let r = Build::new(b)
            .on(&cell)
            .run(s)
            .map_err(|e| format!("{} / {b} on {n} SPEs: {e}", s.name))?;
        check_hash(s, b, n, r.bih.tree_hash(), base)?;
    }
    Ok(())
}

/// A zoo scene of the experiments' set: it loads, the baseline's tree is
/// valid and answers rays as brute force does, and every multi-SPE
/// builder builds that tree on 1, 6 and 8 SPEs.
fn check_zoo(dir: &std::path::Path, spec: &str) -> Result<(), Failed> {
    let s = scene::load(spec, Some(dir)).map_err(|e| format!("{spec}: {e}"))?;
    let base = Build::new(BuilderKind::SPE_BFS)
        .run(&s)
        .map_err(|e| format!("{spec} / spe_bfs: {e}"))?;
    base.bih.validate(&s).map_err(|v| format!("{spec}: {v}"))?;
    let tracer = Tracer::new(&base.bih, &s);
    for ray in rays_for(&s, (3_000_000 / s.len()).clamp(40, 200), 7) {
        check_ray(&s, &tracer, &ray).map_err(|e| format!("{spec}: {e}"))?;
    }
    for &b in BuilderKind::ALL.iter().filter(|b| b.multi_spe()) {
        same_tree_on(&s, b, base.bih.tree_hash(), &[1, 6, 8])?;
    }
    Ok(())
}

/// Rays aimed at the vertices and edges of the fandisk (closed), turned
/// off the axes, along each target's normal from outside and inside: none
/// leaks, and every tree answers as brute force does.
fn check_fandisk_leaks(dir: &std::path::Path) -> Result<(), Failed> {
    use common::leaks::{Approach, aimed_rays, leaking, rotated};
    let s = scene::load("fandisk", Some(dir)).map_err(|e| format!("fandisk: {e}"))?;
    let s = rotated(&s, glam::DVec3::new(0.2, 1.0, 0.5), 0.9);
    let rays = aimed_rays(&s, Approach::Normals { inside_every: 2 }, 4000);
    let wrong = leaking(&s, &rays, 4);
    if wrong.is_empty() {
        Ok(())
    } else {
        let first = &wrong[..wrong.len().min(4)];
        Err(format!(
            "{} of {} rays wrong, first: {first:#?}",
            wrong.len(),
            rays.len()
        )
        .into())
    }
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
    let zoo = zoo::SET.iter().map(|&spec| match &dir {
        Some(dir) => {
            let dir = dir.clone();
            Trial::test(format!("zoo::{spec}"), move || check_zoo(&dir, spec))
        }
        None => Trial::test(
            format!("zoo::{spec} (NOT RUN: {DATA_ENV} is not set)"),
            || Err(format!("{DATA_ENV} is not set: no data directory for the zoo's meshes").into()),
        )
        .with_ignored_flag(true),
    });
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
        .chain(zoo)
        .chain(std::iter::once(match &dir {
            Some(dir) => {
                let dir = dir.clone();
                Trial::test("leaks::fandisk_rotated", move || check_fandisk_leaks(&dir))
            }
            None => Trial::test(
                format!("leaks::fandisk_rotated (NOT RUN: {DATA_ENV} is not set)"),
                || Err(format!("{DATA_ENV} is not set: no data directory for the fandisk").into()),
            )
            .with_ignored_flag(true),
        }))
        .collect();
    libtest_mimic::run(&args, trials).exit();
}
