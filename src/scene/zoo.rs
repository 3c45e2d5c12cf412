//! The scene zoo: scenes nobody tuned a default on, named on the command
//! line, deterministic for a seed. Each is a shape of scene that real work
//! meets and the meshes of the data directory do not: a model standing on
//! a floor far larger than itself, a small detailed model inside a huge
//! sparse enclosure (the "teapot in a stadium"), dense clusters far apart,
//! copies side by side, long thin triangles, a city of boxes.
//!
//! - `ground:<mesh>:<scale>` — the mesh on a ground quad (two triangles)
//!   `<scale>` times its larger horizontal extent, centred under it;
//! - `stadium:<mesh>[:<scale>]` — the mesh on the centre spot of a stadium
//!   (a floor and an open bowl of stands, 3,970 triangles) `<scale>` times the
//!   mesh's size across (default 200);
//! - `clusters:<k>:<triangles>[:<seed>]` — `<k>` balls of radius 1 packed
//!   with small random triangles, at random places in a cube 10,000 across;
//! - `row:<mesh>:<k>` — `<k>` copies of the mesh side by side along x, a
//!   tenth of its width apart;
//! - `soup:<triangles>[:<seed>]` — long thin random triangles (5 to 50
//!   long, 0.001 to 0.01 wide) crossing a cube 100 across;
//! - `city:<k>[:<seed>]` — a `<k>` x `<k>` grid of boxes (12 triangles
//!   each, 2 to 60 high) on a ground quad.
//!
//! `<mesh>` is any scene name without a `:` (`default`, `cup`, `car`, a
//! mesh of the data directory, a path). Every zoo scene keeps its mesh's
//! geometry ids and adds its own parts (`ground`, `stands`, a cluster, a
//! box), so the local update can move any of them.

use std::path::Path;

use glam::Vec3;

use super::procedural::PartsBuilder;
use super::{Scene, SceneError, SplitMix64, Triangle};

/// The most triangles a counted zoo scene (`clusters`, `soup`, `city`,
/// `row`) makes, as `rtperf` (see `procedural::MAX_RTPERF_TRIANGLES`).
pub const MAX_ZOO_TRIANGLES: usize = super::procedural::MAX_RTPERF_TRIANGLES;

/// The zoo's kinds and the form of their names, for help and errors.
pub const FORMS: &str = "ground:<mesh>:<scale>, stadium:<mesh>[:<scale>], \
    clusters:<k>:<triangles>[:<seed>], row:<mesh>:<k>, soup:<triangles>[:<seed>], city:<k>[:<seed>]";

/// The zoo scenes the experiments and tests run: one of each kind, at
/// least 100,000 triangles where the kind has a count, and three small
/// ones where the SPEs a scene gets matter (mesh scenes need the data
/// directory).
pub const SET: &[&str] = &[
    "ground:dragon:10",
    "ground:dragon:1000",
    "ground:bunny:1000",
    "stadium:teapot",
    "clusters:8:200000:1",
    "row:bunny:4",
    "soup:200000:1",
    "city:96:1",
    "clusters:6:16000:16",
    "city:16:18",
    "soup:3000:20",
];

/// The zoo scene named by `spec`, `None` if `spec` names none. Meshes
/// inside it load through `load` (with the data directory `data`).
pub fn by_name(spec: &str, data: Option<&Path>) -> Result<Option<Scene>, SceneError> {
    let parts: Vec<&str> = spec.split(':').collect();
    let bad = |why: String| SceneError::Unknown {
        spec: spec.into(),
        why,
    };
    let kind = parts[0];
    if !["ground", "stadium", "clusters", "row", "soup", "city"].contains(&kind) {
        return Ok(None);
    }
    let field = |i: usize, what: &str| -> Result<&str, SceneError> {
        parts
            .get(i)
            .copied()
            .filter(|s| !s.is_empty())
            .ok_or_else(|| bad(format!("{kind} needs {what}: the forms are {FORMS}")))
    };
    let count = |i: usize, what: &str, least: usize| -> Result<usize, SceneError> {
        let n: usize = field(i, &format!("a {what}"))?
            .parse()
            .map_err(|_| bad(format!("the {what} of {kind} is not a whole number")))?;
        if n < least {
            return Err(bad(format!("{kind} needs a {what} of at least {least}")));
        }
        Ok(n)
    };
    let seed = |i: usize| -> Result<u64, SceneError> {
        match parts.get(i) {
            None => Ok(1),
            Some(s) => s
                .parse()
                .map_err(|_| bad(format!("the seed of {kind} is not a whole number"))),
        }
    };
    let scale = |i: usize, default: Option<f32>| -> Result<f32, SceneError> {
        let s = match (parts.get(i), default) {
            (None, Some(d)) => return Ok(d),
            _ => field(i, "a scale")?,
        };
        positive_f32(s).map_err(|why| bad(format!("the scale of {kind} {why}")))
    };
    let mesh = |i: usize| -> Result<Scene, SceneError> {
        let name = field(i, "a mesh")?;
        super::load(name, data).map_err(|e| match e {
            SceneError::Unknown { why, .. } => bad(format!(
                "its mesh '{name}' {}: {why}",
                "(a mesh name or file: a scene with ':' cannot stand inside a zoo scene)"
            )),
            e => e,
        })
    };
    // `None`: more than `usize` holds.
    let capped = |n: Option<usize>| -> Result<usize, SceneError> {
        n.filter(|&n| n <= MAX_ZOO_TRIANGLES).ok_or_else(|| {
            let n = n.map_or(format!("more than {MAX_ZOO_TRIANGLES}"), |n| n.to_string());
            bad(format!(
                "{kind} makes {n} triangles; the zoo makes at most {MAX_ZOO_TRIANGLES}"
            ))
        })
    };
    let (scene, fields) = match kind {
        // The scale is checked before the mesh is loaded.
        "ground" => {
            let scale = scale(2, None)?;
            (ground(&mesh(1)?, scale), 3)
        }
        "stadium" => {
            let scale = scale(2, Some(200.0))?;
            (stadium(&mesh(1)?, scale), 3)
        }
        "clusters" => {
            let k = count(1, "cluster count", 1)?;
            let n = capped(Some(count(2, "triangle count", k)?))?;
            (clusters(k, n, seed(3)?), 4)
        }
        "row" => {
            let m = mesh(1)?;
            let k = count(2, "copy count", 1)?;
            capped(m.len().checked_mul(k))?;
            (row(&m, k), 3)
        }
        "soup" => {
            let n = capped(Some(count(1, "triangle count", 1)?))?;
            (soup(n, seed(2)?), 3)
        }
        _ => {
            let k = count(1, "grid size", 1)?;
            capped(
                k.checked_mul(k)
                    .and_then(|kk| kk.checked_mul(12)?.checked_add(2)),
            )?;
            (city(k, seed(2)?), 3)
        }
    };
    if parts.len() > fields {
        return Err(bad(format!("too many ':' fields: the forms are {FORMS}")));
    }
    let mut scene = scene;
    scene.name = spec.into();
    Ok(Some(scene))
}

/// `s` as a positive `f32`, or why not ("is beyond f32: …", "is not a
/// positive number: …").
fn positive_f32(s: &str) -> Result<f32, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 && x <= f32::MAX as f64 => Ok(x as f32),
        Ok(x) if x.is_finite() && x > 0.0 => Err(format!("is beyond f32: '{s}' (at most 3.4e38)")),
        _ => Err(format!("is not a positive number: '{s}'")),
    }
}

/// Starts a builder with every part and triangle of `mesh`, moved by
/// `offset`, its parts' names prefixed by `prefix`.
fn add_mesh(b: &mut PartsBuilder, mesh: &Scene, offset: Vec3, prefix: &str) {
    let mut by_part: Vec<Vec<Triangle>> = vec![Vec::new(); mesh.geometry_names.len()];
    for (t, &g) in mesh.triangles.iter().zip(&mesh.geometry_ids) {
        by_part[g as usize].push(Triangle {
            v: t.v.map(|p| p + offset),
        });
    }
    for (name, tris) in mesh.geometry_names.iter().zip(by_part) {
        if tris.is_empty() {
            continue;
        }
        b.part(format!("{prefix}{name}"));
        for t in tris {
            b.add(t);
        }
    }
}

/// The mesh's box as f32 vectors: its centre and its extent.
fn frame(mesh: &Scene) -> (Vec3, Vec3) {
    let b = mesh.bounds();
    (0.5 * (b.min + b.max), b.max - b.min)
}

/// The mesh on a horizontal quad `scale` times its larger horizontal
/// extent, at the mesh's lowest point.
pub fn ground(mesh: &Scene, scale: f32) -> Scene {
    let (c, e) = frame(mesh);
    let half = 0.5 * scale * e.x.max(e.z).max(f32::MIN_POSITIVE);
    let y = mesh.bounds().min.y;
    let mut b = PartsBuilder::default();
    add_mesh(&mut b, mesh, Vec3::ZERO, "");
    b.part("ground");
    let at = |dx: f32, dz: f32| Vec3::new(c.x + dx * half, y, c.z + dz * half);
    b.quad(at(-1.0, -1.0), at(-1.0, 1.0), at(1.0, 1.0), at(1.0, -1.0));
    b.finish("ground")
}

/// The mesh on the centre spot of a stadium `scale` times its size across:
/// a floor of 2 triangles and a bowl of stands rising from the pitch's edge
/// (64 segments of 31 steps: 3,968 triangles), open to the sky.
pub fn stadium(mesh: &Scene, scale: f32) -> Scene {
    let (c, e) = frame(mesh);
    let size = e.max_element().max(f32::MIN_POSITIVE);
    let (r, y) = (0.5 * scale * size, mesh.bounds().min.y);
    let mut b = PartsBuilder::default();
    add_mesh(&mut b, mesh, Vec3::ZERO, "");
    b.part("floor");
    let at = |dx: f32, dz: f32| Vec3::new(c.x + dx * r, y, c.z + dz * r);
    b.quad(at(-1.0, -1.0), at(-1.0, 1.0), at(1.0, 1.0), at(1.0, -1.0));
    // Stands: 31 steps outward and upward, from the pitch's edge to 1.5 r
    // across and 0.4 r high.
    let profile: Vec<(f32, f32)> = (0..32)
        .map(|k| {
            let t = k as f32 / 31.0;
            (r * (1.0 + 0.5 * t), y + 0.4 * r * t * t)
        })
        .collect();
    b.part("stands");
    let ring = |k: usize, i: usize| {
        let (rad, h) = profile[k];
        let a = std::f32::consts::TAU * (i % 64) as f32 / 64.0;
        Vec3::new(c.x + rad * a.cos(), h, c.z + rad * a.sin())
    };
    for i in 0..64 {
        for k in 0..31 {
            b.quad(
                ring(k, i),
                ring(k, i + 1),
                ring(k + 1, i + 1),
                ring(k + 1, i),
            );
        }
    }
    b.finish("stadium")
}

/// `k` balls of radius 1, `n` small triangles in all (0.01 to 0.05
/// across), at random places in a cube 10,000 across.
pub fn clusters(k: usize, n: usize, seed: u64) -> Scene {
    let mut rng = SplitMix64::new(seed);
    let centres: Vec<Vec3> = (0..k)
        .map(|_| {
            Vec3::new(
                rng.range(0.0, 1e4),
                rng.range(0.0, 1e4),
                rng.range(0.0, 1e4),
            )
        })
        .collect();
    let mut b = PartsBuilder::default();
    for (i, &c) in centres.iter().enumerate() {
        b.part(format!("cluster{i}"));
        let here = n * (i + 1) / k - n * i / k;
        for _ in 0..here {
            let p = c + unit_ball(&mut rng);
            let s = rng.range(0.01, 0.05);
            b.add(Triangle::new(
                p,
                p + s * unit_ball(&mut rng),
                p + s * unit_ball(&mut rng),
            ));
        }
    }
    b.finish("clusters")
}

/// A point uniformly in the unit ball (rejection from the cube).
fn unit_ball(rng: &mut SplitMix64) -> Vec3 {
    loop {
        let p = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        if p.length_squared() <= 1.0 {
            return p;
        }
    }
}

/// `k` copies of the mesh along x, a tenth of its width apart; copy `i`'s
/// parts are named `<i>/<part>`.
pub fn row(mesh: &Scene, k: usize) -> Scene {
    let (_, e) = frame(mesh);
    let step = 1.1 * e.x.max(f32::MIN_POSITIVE);
    let mut b = PartsBuilder::default();
    for i in 0..k {
        add_mesh(
            &mut b,
            mesh,
            Vec3::new(step * i as f32, 0.0, 0.0),
            &format!("{i}/"),
        );
    }
    b.finish("row")
}

/// `n` long thin triangles: each from a random point in a cube 100 across,
/// 5 to 50 long in a random direction, 0.001 to 0.01 wide.
pub fn soup(n: usize, seed: u64) -> Scene {
    let mut rng = SplitMix64::new(seed);
    let mut b = PartsBuilder::default();
    b.part("soup");
    for _ in 0..n {
        let a = Vec3::new(
            rng.range(0.0, 100.0),
            rng.range(0.0, 100.0),
            rng.range(0.0, 100.0),
        );
        let d = unit_ball(&mut rng).normalize_or(Vec3::X);
        let side = d.any_orthonormal_vector();
        let (len, width) = (rng.range(5.0, 50.0), rng.range(0.001, 0.01));
        b.add(Triangle::new(a, a + len * d, a + width * side));
    }
    b.finish("soup")
}

/// A `k` x `k` grid of boxes, each 8 x 8 on a 10-unit pitch and 2 to 60
/// high (most low, a few towers), on a ground quad; each box is a part.
pub fn city(k: usize, seed: u64) -> Scene {
    let mut rng = SplitMix64::new(seed);
    let mut b = PartsBuilder::default();
    let side = 10.0 * k as f32;
    b.part("ground");
    b.quad(
        Vec3::new(-5.0, 0.0, -5.0),
        Vec3::new(-5.0, 0.0, side - 5.0),
        Vec3::new(side - 5.0, 0.0, side - 5.0),
        Vec3::new(side - 5.0, 0.0, -5.0),
    );
    for i in 0..k {
        for j in 0..k {
            let u = rng.next_f32();
            let h = 2.0 + 58.0 * u * u * u;
            let (x, z) = (10.0 * i as f32, 10.0 * j as f32);
            b.part(format!("box{i}_{j}"));
            b.grid_box(
                Vec3::new(x - 4.0, 0.0, z - 4.0),
                Vec3::new(x + 4.0, h, z + 4.0),
                1,
            );
        }
    }
    b.finish("city")
}
