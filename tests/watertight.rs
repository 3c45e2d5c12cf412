//! No ray leaks through a closed mesh: rays aimed exactly at every vertex
//! and at points of every edge (from outside and from inside) hit the
//! surface at their target or before it, through brute force, and every
//! builder's tree answers as brute force does on every path, host and
//! SPEs (`common::leaks`). The meshes: an icosphere, a tiled room, a fan
//! of slivers, and random star-shaped meshes at every scale; a rotated
//! fandisk is in tests/real_meshes.rs. A mesh with cracks shows that the
//! check sees a leak.

mod common;

use cellbih::scene::{Scene, Triangle};
use common::leaks::{Approach, aimed_rays, leaking, rotated};
use glam::{DVec3, Vec3};
use proptest::prelude::*;

/// The icosahedron subdivided `level` times, its vertices on the unit
/// sphere pushed out to `radius(vertex)`; every vertex shared exactly.
fn icosphere(level: u32, radius: impl Fn(usize) -> f64) -> Scene {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut split = |a: usize, b: usize, v: &mut Vec<DVec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        f = f
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (
                    split(a, b, &mut v),
                    split(b, c, &mut v),
                    split(c, a, &mut v),
                );
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let p: Vec<Vec3> = (v.iter().enumerate())
        .map(|(i, p)| (*p * radius(i)).as_vec3())
        .collect();
    let tris = f.iter().map(|t| Triangle { v: t.map(|i| p[i]) }).collect();
    Scene::from_triangles(format!("icosphere {level}"), tris).unwrap()
}

/// The inside of a box `n` tiles a side, two triangles a tile, every
/// corner shared by its tiles: the lattice is `0.37` apart (no coordinate
/// exact in binary) and turned off the axes.
fn tiled_room(n: usize) -> Scene {
    let at = |i: usize| i as f32 * 0.37;
    let mut tris = Vec::new();
    for axis in 0..3 {
        for side in [0, n] {
            for i in 0..n {
                for j in 0..n {
                    let p = |a: usize, b: usize| {
                        let mut q = [0.0f32; 3];
                        q[axis] = at(side);
                        q[(axis + 1) % 3] = at(a);
                        q[(axis + 2) % 3] = at(b);
                        Vec3::from_array(q)
                    };
                    let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
                    tris.push(Triangle::new(a, b, c));
                    tris.push(Triangle::new(a, c, d));
                }
            }
        }
    }
    let room = Scene::from_triangles(format!("room {n}"), tris).unwrap();
    rotated(&room, DVec3::new(1.0, 2.0, 3.0), 0.7)
}

/// A double cone of `n` slivers each way, 60 long and 1 wide: as a
/// finely cut sphere's poles.
fn sliver_fan(n: usize) -> Scene {
    let ring = |i: usize| {
        let a = std::f64::consts::TAU * (i % n) as f64 / n as f64;
        Vec3::new(a.cos() as f32, 0.0, a.sin() as f32)
    };
    let (top, bottom) = (Vec3::new(0.0, 30.0, 0.0), Vec3::new(0.0, -30.0, 0.0));
    let tris = (0..n)
        .flat_map(|i| {
            [
                Triangle::new(top, ring(i + 1), ring(i)),
                Triangle::new(bottom, ring(i), ring(i + 1)),
            ]
        })
        .collect();
    Scene::from_triangles(format!("sliver fan {n}"), tris).unwrap()
}

fn centre(scene: &Scene) -> DVec3 {
    let b = scene.bounds();
    ((b.min + b.max) * 0.5).as_dvec3()
}

fn assert_no_leak(scene: &Scene, approach: Approach, most: usize) {
    let rays = aimed_rays(scene, approach, most);
    assert!(rays.len() > most / 2, "{}: {} rays", scene.name, rays.len());
    let wrong = leaking(scene, &rays, 3);
    assert!(
        wrong.is_empty(),
        "{}: {} of {} rays wrong, first: {:#?}",
        scene.name,
        wrong.len(),
        rays.len(),
        &wrong[..wrong.len().min(4)]
    );
}

#[test]
fn no_ray_leaks_through_an_icosphere() {
    let s = rotated(&icosphere(3, |_| 1.0), DVec3::new(0.3, 1.0, -0.2), 0.4);
    assert_no_leak(&s, Approach::Star(centre(&s)), 1500);
}

#[test]
fn no_ray_leaks_out_of_or_into_a_tiled_room() {
    let s = tiled_room(12);
    assert_no_leak(&s, Approach::Star(centre(&s)), 1500);
}

#[test]
fn no_ray_leaks_between_slivers() {
    let s = sliver_fan(600);
    assert_no_leak(&s, Approach::Star(DVec3::ZERO), 1500);
}

/// The check sees a leak: each triangle of the icosphere shrunk about its
/// centre by a millionth leaves cracks along every edge, and the rays
/// aimed at the whole sphere's edges pass through them.
#[test]
fn a_mesh_with_cracks_leaks() {
    let whole = icosphere(2, |_| 1.0);
    let shrink = |t: &Triangle| {
        let c = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
        Triangle {
            v: t.v.map(|p| c + (p - c) * (1.0 - 1e-6)),
        }
    };
    let cracked = Scene::from_triangles(
        "cracked icosphere",
        whole.triangles.iter().map(shrink).collect(),
    )
    .unwrap();
    let rays = aimed_rays(&whole, Approach::Star(DVec3::ZERO), 400);
    let wrong = leaking(&cracked, &rays, usize::MAX);
    let leaks = wrong.iter().filter(|w| w.contains("leaks")).count();
    assert!(
        leaks > rays.len() / 4,
        "{leaks} of {} rays leak",
        rays.len()
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// Random star-shaped closed meshes (an icosphere's vertices pushed in
    /// and out) at every scale, off the origin and turned.
    #[test]
    fn no_ray_leaks_through_random_closed_meshes(
        level in 1u32..3,
        exp in -15i32..=15,
        offset in -3i32..=3,
        seed in any::<u64>(),
        angle in 0.0f64..3.0,
    ) {
        let scale = 10f64.powi(exp);
        let mut rng = cellbih::scene::SplitMix64::new(seed);
        let radii: Vec<f64> = (0..700).map(|_| 0.5 + rng.next_f32() as f64).collect();
        let unit = icosphere(level, |i| radii[i]);
        let c = DVec3::splat(offset as f64 * 2.0);
        let moved = unit.triangles.iter().map(|t| Triangle {
            v: t.v.map(|p| ((p.as_dvec3() + c) * scale).as_vec3()),
        }).collect();
        let moved = Scene::from_triangles("random star", moved).unwrap();
        let s = rotated(&moved, DVec3::new(1.0, -0.5, 0.25), angle);
        let rays = aimed_rays(&s, Approach::Star(centre_of_star(&s, c * scale, angle)), 400);
        let wrong = leaking(&s, &rays, 5);
        prop_assert!(wrong.is_empty(), "{} of {} rays wrong, first: {:#?}",
            wrong.len(), rays.len(), &wrong[..wrong.len().min(3)]);
    }
}

/// Where the star's centre `c` went when the mesh was turned.
fn centre_of_star(_s: &Scene, c: DVec3, angle: f64) -> DVec3 {
    glam::DMat3::from_axis_angle(DVec3::new(1.0, -0.5, 0.25).normalize(), angle) * c
}
