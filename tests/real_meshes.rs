//! The real meshes of the data directory (CELLBIH_DATA; CI points it at
//! ../shared/data): each loads with the triangle count its README gives,
//! builds a valid tree, and answers rays as brute force does.

mod common;

use cellbih::bih::{BihConfig, Tracer};
use cellbih::build::BuilderKind;
use cellbih::scene;
use common::{check_ray, data_dir, rays_for};

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

#[test]
fn every_real_mesh_loads_builds_and_agrees_with_brute_force() {
    let Some(dir) = data_dir("real_meshes") else {
        return;
    };
    for &(name, triangles, zero_area) in MESHES {
        let s = scene::load(name, Some(&dir)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(s.len(), triangles, "{name}: triangle count");
        if let Some(z) = zero_area {
            assert_eq!(s.degenerate_count(), z, "{name}: zero-area triangles");
        }
        for &b in BuilderKind::ALL {
            let r = b
                .build(&s, &BihConfig::default())
                .unwrap_or_else(|e| panic!("{name} / {b}: {e}"));
            r.bih
                .validate(&s)
                .unwrap_or_else(|v| panic!("{name} / {b}: {v}"));
            let tracer = Tracer::new(&r.bih, &s);
            // Brute force costs a pass over every triangle per ray.
            let rays = (3_000_000 / triangles).clamp(40, 400);
            for ray in rays_for(&s, rays, 99) {
                check_ray(&s, &tracer, &ray).unwrap_or_else(|e| panic!("{name} / {b}: {e}"));
            }
        }
    }
}
