//! Scenes at the numerical extremes: what
//! `cli/experiments/extremes.rs` builds with every builder and what
//! `tests/extremes.rs` checks, one test per case. Each is deterministic
//! (seeded) and small enough (2,000 triangles or so) for a brute-force
//! check of every ray.
//!
//! The cases: the same random triangles at scales 1e-15 to 1e15; tiny
//! triangles in a cluster 1e7 from the origin (where an `f32` step is 1);
//! a dense cluster beside a few triangles 1e6 away; sizes mixed from 1e-6
//! to 1e3; a flat scene; collinear triangles; point triangles; stacks of
//! identical triangles; slivers (long and 1e-6 thin); triangles in planes
//! one `f32` step apart.

use glam::Vec3;

use super::{Scene, SplitMix64, Triangle};

/// Triangles per case (the far cluster's outliers aside).
const N: usize = 2000;

/// The name of every case, in the order of the table.
pub const CASES: &[&str] = &[
    "scale 1e-15",
    "scale 1e-10",
    "scale 1e-5",
    "scale 1",
    "scale 1e5",
    "scale 1e10",
    "scale 1e15",
    "tiny cluster at 1e7",
    "cluster beside 1e6",
    "sizes 1e-6 to 1e3",
    "flat",
    "collinear",
    "points",
    "stacks",
    "slivers",
    "planes one f32 step apart",
];

/// The scene of case `name` (one of [`CASES`]), `None` for another name.
pub fn case(name: &str) -> Option<Scene> {
    let mut rng = SplitMix64::new(0xe7);
    let mut p = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let tris: Vec<Triangle> = match name {
        _ if name.starts_with("scale ") => {
            let exp: i32 = match name.trim_start_matches("scale ") {
                "1" => 0,
                e => e.trim_start_matches("1e").parse().ok()?,
            };
            let s = 10f32.powi(exp);
            random(N, &mut p, 0.05)
                .map(|t| scaled(t, s, Vec3::ZERO))
                .collect()
        }
        "tiny cluster at 1e7" => {
            // 2,000 triangles 0.01 to 8 wide within 4 units of (1e7, 1e7,
            // 1e7), where an f32 step is 1: vertices round together (the
            // smaller triangles become degenerate), centers coincide, and
            // the global heuristic's halvings stop shrinking in f32.
            let at = Vec3::splat(1e7);
            (0..N)
                .map(|i| {
                    let c = p() * 4.0;
                    let size = 0.01 + (i % 100) as f32 * 0.08;
                    Triangle::new(
                        at + c,
                        at + c + (p() - 0.5) * size,
                        at + c + (p() - 0.5) * size,
                    )
                })
                .collect()
        }
        "cluster beside 1e6" => {
            let mut v: Vec<Triangle> = random(N, &mut p, 0.05).collect();
            v.extend(random(20, &mut p, 0.5).map(|t| scaled(t, 10.0, Vec3::splat(1e6))));
            v
        }
        "sizes 1e-6 to 1e3" => (0..N)
            .map(|i| {
                let size = 10f32.powf(-6.0 + 9.0 * (i as f32 / N as f32));
                let c = p() * 1000.0;
                Triangle::new(c, c + (p() - 0.5) * size, c + (p() - 0.5) * size)
            })
            .collect(),
        "flat" => random(N, &mut p, 0.05)
            .map(|t| {
                Triangle::new(
                    t.v[0] * Vec3::new(1.0, 1.0, 0.0),
                    t.v[1] * Vec3::new(1.0, 1.0, 0.0),
                    t.v[2] * Vec3::new(1.0, 1.0, 0.0),
                )
            })
            .collect(),
        "collinear" => (0..N)
            .map(|_| {
                let (a, b) = (p().x * 100.0, p().x * 100.0);
                Triangle::new(Vec3::X * a, Vec3::X * b, Vec3::X * (a * 0.5 + b * 0.5))
            })
            .collect(),
        "points" => (0..N)
            .map(|_| {
                let q = p();
                Triangle::new(q, q, q)
            })
            .collect(),
        "stacks" => (0..N)
            .map(|i| {
                let base = Vec3::new((i % 10) as f32, ((i / 10) % 2) as f32, 0.0);
                Triangle::new(base, base + Vec3::X * 0.5, base + Vec3::Y * 0.5)
            })
            .collect(),
        "slivers" => (0..N)
            .map(|_| {
                let (c, d) = (p() * 10.0, (p() - 0.5).normalize_or(Vec3::X));
                let side = d.any_orthonormal_vector() * 1e-6;
                Triangle::new(c, c + d, c + side)
            })
            .collect(),
        "planes one f32 step apart" => (0..N)
            .map(|i| {
                // 50 copies of a right triangle in each plane x = 1 + k
                // ulp, k < 40: only x separates them, and its halvings
                // reach boxes one f32 step wide whose middle rounds onto a
                // face.
                let x = f32::from_bits(1f32.to_bits() + (i % 40) as u32);
                Triangle::new(
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x, 1.0, 0.0),
                    Vec3::new(x, 0.0, 1.0),
                )
            })
            .collect(),
        _ => return None,
    };
    Scene::from_triangles(name, tris).ok()
}

/// `n` random triangles up to `size` wide in the unit cube.
fn random<'a>(
    n: usize,
    p: &'a mut impl FnMut() -> Vec3,
    size: f32,
) -> impl Iterator<Item = Triangle> + 'a {
    (0..n).map(move |_| {
        let c = p();
        Triangle::new(c, c + (p() - 0.5) * size, c + (p() - 0.5) * size)
    })
}

fn scaled(t: Triangle, s: f32, off: Vec3) -> Triangle {
    Triangle::new(t.v[0] * s + off, t.v[1] * s + off, t.v[2] * s + off)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_case_is_a_scene_of_its_kind() {
        for &name in CASES {
            let s = case(name).unwrap_or_else(|| panic!("{name}"));
            assert!(s.len() >= N, "{name}");
        }
        assert!(case("no such case").is_none());
        let b = case("scale 1e15").unwrap().bounds();
        assert!(b.max.max_element() > 1e14 && b.max.max_element() < 2e15);
        assert_eq!(case("flat").unwrap().bounds().extent().z, 0.0);
        assert_eq!(case("points").unwrap().degenerate_count(), N);
        assert_eq!(case("collinear").unwrap().degenerate_count(), N);
        let far = case("cluster beside 1e6").unwrap().bounds();
        assert!(far.max.min_element() >= 1e6);
    }
}
