//! Rays aimed exactly at the vertices and edges of closed meshes, and the
//! count of those that leak: a ray aimed at a point of the surface must
//! hit the surface at that point or before it, wherever it starts (from
//! outside, the first surface; from inside, the enclosing one). A ray
//! leaks when it misses or its first hit lies beyond its target. The rays
//! pass exactly through their targets and cross the surface there (no
//! ray grazes it), so a watertight test owes every one of them a hit.

use cellbih::bih::{Hit, Ray, RayStats, Tracer, brute_force_closest};
use cellbih::cast::{CastConfig, Packet, cast_on_cell};
use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{Scene, Triangle};
use glam::{DMat3, DVec3, Vec3};

use super::same_hit;

/// How far past its target (relative, in the ray's `t`, the target at
/// `t = 1`) a hit may lie: the test's rounding, far below any gap.
const PAST: f64 = 1e-9;

/// Where the rays come from.
#[derive(Clone, Copy, Debug)]
pub enum Approach {
    /// The mesh is star-shaped about this point: rays from it (inside),
    /// and from 3 and 4 times as far out as their target (outside) aimed
    /// back at the target.
    Star(DVec3),
    /// Along each target's outward normal (the mean of its triangles',
    /// oriented by the enclosed volume's sign): from a tenth of the mesh's
    /// size outside and, for one in `inside_every`, a thousandth inside.
    Normals { inside_every: usize },
}

/// Points of every triangle to aim at, each with the triangles it lies
/// on: each vertex, and each edge's midpoint and quarter points (taken
/// from the edge's ends in one order, so that both triangles of the edge
/// name the same points). All are exact in `f64`.
fn targets(scene: &Scene) -> Vec<(DVec3, Vec<usize>)> {
    let mut out: Vec<(DVec3, Vec<usize>)> = Vec::new();
    let mut at = std::collections::HashMap::new();
    for (i, t) in scene.triangles.iter().enumerate() {
        for k in 0..3 {
            let (mut a, mut b) = (t.v[k].as_dvec3(), t.v[(k + 1) % 3].as_dvec3());
            if b.to_array().map(f64::to_bits) < a.to_array().map(f64::to_bits) {
                std::mem::swap(&mut a, &mut b);
            }
            for p in [a, (a + b) * 0.5, a + (b - a) * 0.25, a + (b - a) * 0.75] {
                let key = p.to_array().map(f64::to_bits);
                let n = *at.entry(key).or_insert_with(|| {
                    out.push((p, Vec::new()));
                    out.len() - 1
                });
                if !out[n].1.contains(&i) {
                    out[n].1.push(i);
                }
            }
        }
    }
    out
}

/// The ray along `d` (rounded to `f32` components) that passes exactly
/// through `p` at `t = 1`, if its origin `p - d` is exact in `f64`, and
/// if it crosses the surface there: every triangle `p` lies on faces it
/// the same way, none within a millionth of edge-on (a ray that grazes
/// the surface may rightly pass it).
fn through(scene: &Scene, p: DVec3, tris: &[usize], d: DVec3) -> Option<Ray> {
    let d = d.as_vec3().as_dvec3();
    let o = p - d;
    // TwoSum: the rounding error of `p - d`, exactly.
    let exact = (0..3).all(|a| {
        let (x, y, s) = (p[a], -d[a], o[a]);
        let yy = s - x;
        (x - (s - yy)) + (y - yy) == 0.0
    });
    let facing: Vec<f64> = (tris.iter())
        .map(|&i| {
            normal_of(&scene.triangles[i])
                .normalize()
                .dot(d.normalize())
        })
        .collect();
    let crosses = facing.iter().all(|&c| c > 1e-6) || facing.iter().all(|&c| c < -1e-6);
    (exact && crosses).then(|| Ray::new(o, d))
}

/// Every `every`-th of `targets`' points (about `most` of them), with the
/// rays aimed at each (`(ray, from outside)`) that pass exactly through
/// it and cross the surface there ([`through`]). The rays come sorted by
/// the signs of their directions, so that consecutive ones make packets.
pub fn aimed_rays(scene: &Scene, approach: Approach, most: usize) -> Vec<(Ray, bool)> {
    let all = targets(scene);
    let every = all.len().div_ceil(most).max(1);
    let b = scene.bounds();
    let size = (b.max - b.min).as_dvec3().length();
    let orient = enclosed_volume(scene).signum();
    let mut rays = Vec::new();
    for (n, (p, tris)) in all.iter().enumerate().step_by(every) {
        let mut aim = |d: DVec3, outside: bool| {
            if let Some(r) = through(scene, *p, tris, d) {
                rays.push((r, outside));
            }
        };
        match approach {
            Approach::Star(c) => {
                aim(*p - c, false);
                for k in [2.0, 3.0] {
                    aim((c - *p) * k, true);
                }
            }
            Approach::Normals { inside_every } => {
                let normal = tris
                    .iter()
                    .map(|&i| normal_of(&scene.triangles[i]).normalize())
                    .sum::<DVec3>()
                    * orient;
                if normal.length() == 0.0 {
                    continue;
                }
                let h = normal.normalize() * (0.1 * size);
                aim(-h, true);
                if n % inside_every == 0 {
                    aim(h * 0.01, false);
                }
            }
        }
    }
    rays.sort_by_key(|(r, _)| r.dir.to_array().map(f64::is_sign_negative));
    rays
}

/// The area-weighted normal of a triangle, as wound.
fn normal_of(t: &Triangle) -> DVec3 {
    let [a, b, c] = t.v.map(|v| v.as_dvec3());
    (b - a).cross(c - a)
}

/// Six times the volume the mesh encloses, signed by its winding.
fn enclosed_volume(scene: &Scene) -> f64 {
    (scene.triangles.iter())
        .map(|t| {
            let [a, b, c] = t.v.map(|v| v.as_dvec3());
            a.dot(b.cross(c))
        })
        .sum()
}

/// Whether `hit` leaks: a miss, or a first hit beyond the target.
fn leaks(hit: &Option<Hit>) -> bool {
    hit.is_none_or(|h| h.t > 1.0 + PAST)
}

/// The rays of `rays` that leak through brute force, and for every
/// builder's tree the rays whose answer differs from brute force's on
/// some path (the exact walk, its packets, the fast walk, and — for one
/// in `cell_every` builders — the SPEs, ray by ray and in 4 × 4 packets):
/// each described, for the assertion's message.
pub fn leaking(scene: &Scene, rays: &[(Ray, bool)], cell_every: usize) -> Vec<String> {
    let only: Vec<Ray> = rays.iter().map(|(r, _)| *r).collect();
    let want: Vec<_> = only.iter().map(|r| brute_force_closest(scene, r)).collect();
    let mut wrong = Vec::new();
    for (i, w) in want.iter().enumerate() {
        if leaks(w) {
            let side = if rays[i].1 { "outside" } else { "inside" };
            wrong.push(format!(
                "brute force: {side} ray {:?} leaks: {w:?}",
                only[i]
            ));
        }
    }
    for (n, &b) in BuilderKind::ALL.iter().enumerate() {
        let r = Build::new(b).run(scene).expect("builds");
        let tracer = Tracer::new(&r.bih, scene);
        let mut paths: Vec<(String, Vec<Option<Hit>>)> = vec![
            (
                "exact walk".into(),
                (only.iter())
                    .map(|ray| tracer.closest(ray, &mut RayStats::default()))
                    .collect(),
            ),
            (
                "packets".into(),
                tracer.closest_all(&only, &mut RayStats::default()),
            ),
            ("hits".into(), tracer.hits(&only)),
            (
                "fast walk".into(),
                only.iter().map(|ray| tracer.closest_fast(ray)).collect(),
            ),
        ];
        if n % cell_every == 0 {
            for packet in [Packet::SINGLE, Packet { w: 4, h: 4 }] {
                let config = CastConfig {
                    packet,
                    ..CastConfig::DEFAULT
                };
                let cast = cast_on_cell(
                    &r.bih,
                    scene,
                    &only,
                    &config,
                    &CellConfig::ps3(),
                    r.record_order(),
                )
                .expect("casts");
                paths.push((format!("SPEs {}x{}", packet.w, packet.h), cast.hits));
            }
        }
        for (path, hits) in paths {
            for (i, h) in hits.iter().enumerate() {
                if !same_hit(h, &want[i]) {
                    wrong.push(format!(
                        "{b} {path}: ray {:?}: {h:?}, brute force {:?}",
                        only[i], want[i]
                    ));
                }
            }
        }
    }
    wrong
}

/// `scene` turned by `angle` radians about `axis`, so that no edge lies
/// along a coordinate axis.
pub fn rotated(scene: &Scene, axis: DVec3, angle: f64) -> Scene {
    let m = DMat3::from_axis_angle(axis.normalize(), angle);
    let turn = |v: Vec3| (m * v.as_dvec3()).as_vec3();
    let tris = (scene.triangles.iter())
        .map(|t| Triangle { v: t.v.map(turn) })
        .collect();
    Scene::from_triangles(format!("{} rotated", scene.name), tris).expect("a scene")
}
