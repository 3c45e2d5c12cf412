//! Procedural scenes, deterministic for a seed, modelled on the paper's test
//! scenes (section 4.2):
//!
//! - `rtperf:<triangles>[:<seed>]` — rtPerf: spheres of 200 triangles spread
//!   pseudo-randomly through a 100-unit cube, one geometry id per sphere;
//! - `car` — a car of 22,152 triangles: a body and 18 separately movable parts
//!   (body, cabin, wheels, hubs, doors, hood, trunk, …), like carVis;
//! - `cup` — one glass of 7,040 triangles alone in space, like cupVis.

use glam::Vec3;

use super::{Scene, SceneError, SplitMix64, Triangle};

/// Triangles of one rtPerf sphere (10 slices, 11 stacks).
pub const RTPERF_SPHERE_TRIANGLES: usize = 200;

/// The most triangles `rtperf:N` makes: 50 million take 1.8 GB as a scene
/// and about 4 GB once a tree is built (about 80 bytes a triangle with the
/// host builder, measured on `rtperf:4000000`), and triangle ids must stay
/// far below the node format's 2^30. The count is checked before anything
/// is allocated.
pub const MAX_RTPERF_TRIANGLES: usize = 50_000_000;

/// The triangle count `rtperf:N[:SEED]` names, read without making the
/// scene (`None` for any other spec, or one `by_name` would refuse): what
/// a command can check against the emulated memory before any work.
pub fn rtperf_triangles(spec: &str) -> Option<usize> {
    let mut parts = spec.split(':');
    (parts.next() == Some("rtperf"))
        .then(|| parts.next()?.parse().ok())
        .flatten()
        .filter(|&n| (1..=MAX_RTPERF_TRIANGLES).contains(&n))
}

/// The procedural scene named by `spec`, `None` if `spec` names none.
pub fn by_name(spec: &str) -> Result<Option<Scene>, SceneError> {
    let mut parts = spec.split(':');
    let bad = |why: &str| SceneError::Unknown {
        spec: spec.into(),
        why: why.into(),
    };
    let scene = match parts.next() {
        Some("rtperf") => {
            let tris: usize = parts
                .next()
                .ok_or_else(|| bad("rtperf needs a triangle count: rtperf:<triangles>[:<seed>]"))?
                .parse()
                .map_err(|_| bad("the triangle count of rtperf is not a whole number"))?;
            let seed: u64 = match parts.next() {
                Some(s) => s
                    .parse()
                    .map_err(|_| bad("the seed of rtperf is not a whole number"))?,
                None => 1,
            };
            if tris == 0 {
                return Err(bad("rtperf needs at least one triangle"));
            }
            if tris > MAX_RTPERF_TRIANGLES {
                return Err(bad(&format!(
                    "rtperf takes at most {MAX_RTPERF_TRIANGLES} triangles (about 80 bytes each once built)"
                )));
            }
            rtperf(tris, seed)
        }
        Some("car") => car(),
        Some("cup") => cup(),
        _ => return Ok(None),
    };
    if parts.next().is_some() {
        return Err(bad("too many ':' fields"));
    }
    Ok(Some(scene))
}

/// Collects triangles part by part; each part is one geometry id.
#[derive(Default)]
pub struct PartsBuilder {
    triangles: Vec<Triangle>,
    geometry_ids: Vec<u32>,
    names: Vec<String>,
}

impl PartsBuilder {
    /// Starts a new part: every triangle added until the next call carries
    /// its geometry id.
    pub fn part(&mut self, name: impl Into<String>) -> &mut Self {
        self.names.push(name.into());
        self
    }

    pub fn add(&mut self, t: Triangle) {
        assert!(!self.names.is_empty(), "add a part before its triangles");
        self.triangles.push(t);
        self.geometry_ids.push(self.names.len() as u32 - 1);
    }

    /// Adds the quad a-b-c-d as two triangles.
    pub fn quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
        self.add(Triangle::new(a, b, c));
        self.add(Triangle::new(a, c, d));
    }

    /// A UV sphere of `slices` x `stacks` (2·slices·(stacks−1) triangles),
    /// scaled per axis by `radii`.
    pub fn ellipsoid(&mut self, center: Vec3, radii: Vec3, slices: usize, stacks: usize) {
        let p = |i: usize, j: usize| {
            let theta = std::f32::consts::PI * j as f32 / stacks as f32;
            let phi = std::f32::consts::TAU * (i % slices) as f32 / slices as f32;
            center
                + radii
                    * Vec3::new(
                        theta.sin() * phi.cos(),
                        theta.cos(),
                        theta.sin() * phi.sin(),
                    )
        };
        for i in 0..slices {
            self.add(Triangle::new(p(i, 0), p(i + 1, 1), p(i, 1)));
            for j in 1..stacks - 1 {
                self.quad(p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            }
            self.add(Triangle::new(
                p(i, stacks - 1),
                p(i + 1, stacks - 1),
                p(i, stacks),
            ));
        }
    }

    /// A torus around the axis `axis` (0, 1, 2): 2·major·minor triangles.
    pub fn torus(
        &mut self,
        center: Vec3,
        axis: usize,
        r_major: f32,
        r_minor: f32,
        major: usize,
        minor: usize,
    ) {
        let p = |i: usize, j: usize| {
            let u = std::f32::consts::TAU * (i % major) as f32 / major as f32;
            let v = std::f32::consts::TAU * (j % minor) as f32 / minor as f32;
            let ring = r_major + r_minor * v.cos();
            let local = Vec3::new(ring * u.cos(), r_minor * v.sin(), ring * u.sin());
            center + permute(local, axis)
        };
        for i in 0..major {
            for j in 0..minor {
                self.quad(p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            }
        }
    }

    /// A box with each face cut into `n` x `n` quads (12·n² triangles).
    pub fn grid_box(&mut self, min: Vec3, max: Vec3, n: usize) {
        let e = max - min;
        for axis in 0..3 {
            for side in [0.0f32, 1.0] {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let at = |a: usize, b: usize| {
                    let mut q = min;
                    q[axis] += e[axis] * side;
                    q[u] += e[u] * a as f32 / n as f32;
                    q[v] += e[v] * b as f32 / n as f32;
                    q
                };
                for a in 0..n {
                    for b in 0..n {
                        self.quad(at(a, b), at(a + 1, b), at(a + 1, b + 1), at(a, b + 1));
                    }
                }
            }
        }
    }

    /// A surface of revolution about the y axis through `center`: the
    /// profile is a list of (radius, height); closed at the first and last
    /// points by fans to the axis. 2·segments·(points−1) + 2·segments triangles.
    pub fn lathe(&mut self, center: Vec3, profile: &[(f32, f32)], segments: usize) {
        let p = |k: usize, i: usize| {
            let a = std::f32::consts::TAU * (i % segments) as f32 / segments as f32;
            let (r, y) = profile[k];
            center + Vec3::new(r * a.cos(), y, r * a.sin())
        };
        let last = profile.len() - 1;
        for i in 0..segments {
            for k in 0..last {
                self.quad(p(k, i), p(k, i + 1), p(k + 1, i + 1), p(k + 1, i));
            }
            let axis0 = center + Vec3::new(0.0, profile[0].1, 0.0);
            let axis1 = center + Vec3::new(0.0, profile[last].1, 0.0);
            self.add(Triangle::new(axis0, p(0, i + 1), p(0, i)));
            self.add(Triangle::new(axis1, p(last, i), p(last, i + 1)));
        }
    }

    pub fn finish(self, name: &str) -> Scene {
        Scene::new(name, self.triangles, self.geometry_ids, self.names)
            .expect("procedural scenes are finite and non-empty")
    }
}

/// Rotates a y-up local frame so that its y axis becomes `axis`.
fn permute(v: Vec3, axis: usize) -> Vec3 {
    match axis {
        0 => Vec3::new(v.y, v.x, v.z),
        1 => v,
        _ => Vec3::new(v.x, v.z, v.y),
    }
}

/// rtPerf: exactly `triangles` triangles in spheres of 200 (radius
/// 0.5–2.5, at uniform random places in [0, 100]³); when `triangles` is not
/// a multiple of 200, the last sphere is cut to the remainder (an open cap).
pub fn rtperf(triangles: usize, seed: u64) -> Scene {
    let spheres = triangles.div_ceil(RTPERF_SPHERE_TRIANGLES).max(1);
    let mut rng = SplitMix64::new(seed);
    let mut b = PartsBuilder::default();
    for s in 0..spheres {
        let c = Vec3::new(
            rng.range(0.0, 100.0),
            rng.range(0.0, 100.0),
            rng.range(0.0, 100.0),
        );
        let r = rng.range(0.5, 2.5);
        b.part(format!("sphere{s}"));
        b.ellipsoid(c, Vec3::splat(r), 10, 11);
    }
    b.triangles.truncate(triangles.max(1));
    b.geometry_ids.truncate(triangles.max(1));
    b.finish(&format!("rtperf:{triangles}:{seed}"))
}

/// carVis stand-in: 22,152 triangles in 19 parts (a body and 18 movable
/// parts), about 4.6 x 1.6 x 2.2 units.
pub fn car() -> Scene {
    let mut b = PartsBuilder::default();
    b.part("body")
        .ellipsoid(Vec3::new(0.0, 0.7, 0.0), Vec3::new(2.2, 0.45, 0.9), 60, 40);
    b.part("cabin").ellipsoid(
        Vec3::new(-0.2, 1.15, 0.0),
        Vec3::new(1.1, 0.4, 0.78),
        40,
        30,
    );
    for (i, (x, z)) in [(1.4f32, 0.95f32), (1.4, -0.95), (-1.4, 0.95), (-1.4, -0.95)]
        .into_iter()
        .enumerate()
    {
        b.part(format!("wheel{i}"))
            .torus(Vec3::new(x, 0.38, z), 2, 0.28, 0.1, 44, 24);
        b.part(format!("hub{i}"))
            .lathe(Vec3::new(x, 0.38, z), &[(0.05, 0.0), (0.2, 0.0)], 32);
    }
    for (i, (x, z)) in [(0.5f32, 0.9f32), (0.5, -0.98), (-0.7, 0.9), (-0.7, -0.98)]
        .into_iter()
        .enumerate()
    {
        b.part(format!("door{i}")).grid_box(
            Vec3::new(x - 0.55, 0.45, z),
            Vec3::new(x + 0.55, 1.05, z + 0.08),
            8,
        );
    }
    b.part("hood")
        .grid_box(Vec3::new(1.2, 0.95, -0.7), Vec3::new(2.1, 1.0, 0.7), 8);
    b.part("trunk")
        .grid_box(Vec3::new(-2.1, 0.95, -0.7), Vec3::new(-1.4, 1.0, 0.7), 8);
    b.part("steering_wheel")
        .torus(Vec3::new(0.55, 1.1, 0.35), 0, 0.18, 0.025, 32, 12);
    b.part("seats")
        .grid_box(Vec3::new(-0.5, 0.6, -0.6), Vec3::new(0.1, 1.1, 0.6), 4);
    b.grid_box(Vec3::new(-1.1, 0.6, -0.6), Vec3::new(-0.6, 1.1, 0.6), 4);
    b.part("headlights")
        .ellipsoid(Vec3::new(2.15, 0.75, 0.55), Vec3::splat(0.1), 12, 10);
    b.ellipsoid(Vec3::new(2.15, 0.75, -0.55), Vec3::splat(0.1), 12, 10);
    b.finish("car")
}

/// cupVis stand-in: a drinking glass of 7,040 triangles, alone in space:
/// outer wall up, rim, inner wall down (55 profile points, 64 segments).
pub fn cup() -> Scene {
    let mut profile = Vec::new();
    for k in 0..28 {
        let y = 10.0 * k as f32 / 27.0;
        profile.push((3.0 + 0.1 * y, y));
    }
    for k in (0..27).rev() {
        let y = 0.5 + 9.5 * k as f32 / 26.0;
        profile.push((2.7 + 0.1 * y, y));
    }
    let mut b = PartsBuilder::default();
    b.part("glass").lathe(Vec3::ZERO, &profile, 64);
    b.finish("cup")
}
