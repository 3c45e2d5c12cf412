//! Moving objects and the paper's animations (issue 5, part 1).

use cellbih::scene;
use cellbih::update::{Animation, Move, apply};
use glam::{Affine3A, Vec3};

#[test]
fn a_move_transforms_its_geometry_and_nothing_else() {
    let s = scene::load("car", None).unwrap();
    let by = Vec3::new(0.5, 0.0, 0.0);
    let moved = apply(&s, &[Move::translate(3, by)]).unwrap();
    let mut changed = 0;
    for ((a, b), &g) in s
        .triangles
        .iter()
        .zip(&moved.triangles)
        .zip(&s.geometry_ids)
    {
        if g == 3 {
            changed += 1;
            for k in 0..3 {
                assert!((b.v[k] - a.v[k] - by).length() < 1e-5);
            }
        } else {
            assert_eq!(a, b);
        }
    }
    assert!(changed > 0);
    assert_eq!(moved.geometry_ids, s.geometry_ids);
}

#[test]
fn a_marked_move_changes_nothing() {
    let s = scene::load("cup", None).unwrap();
    let moved = apply(&s, &[Move::marked(0)]).unwrap();
    assert_eq!(moved.triangles, s.triangles);
    assert_eq!(moved.bounds(), s.bounds());
}

#[test]
fn bad_moves_are_errors() {
    let s = scene::load("cup", None).unwrap();
    let e = apply(&s, &[Move::translate(7, Vec3::ONE)])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("geometry id 7") && e.contains("1 geometries"),
        "{e}"
    );
    let blow_up = Move {
        geometry: 0,
        transform: Affine3A::from_scale(Vec3::splat(f32::MAX)),
    };
    let e = apply(&s, &[blow_up]).unwrap_err().to_string();
    assert!(e.contains("non-finite"), "{e}");
}

#[test]
fn animations_are_deterministic_and_move_like_the_papers() {
    let rt = scene::load("rtperf:10000:1", None).unwrap();
    let a = Animation::named("rtperf", &rt, 20, 7).unwrap();
    let b = Animation::named("rtperf", &rt, 20, 7).unwrap();
    assert_eq!(a.frames, b.frames);
    assert_ne!(
        a.frames,
        Animation::named("rtperf", &rt, 20, 8).unwrap().frames
    );
    assert_eq!(a.frames.len(), 20);
    // One sphere in 50 per frame; every fifth frame marked only.
    assert!(a.frames.iter().all(|f| f.len() == 1));
    assert!(a.frames[4].iter().all(Move::is_identity));
    assert!(!a.frames[0].iter().all(Move::is_identity));

    // cupVis: every real move changes the scene box.
    let cup = scene::load("cup", None).unwrap();
    let anim = Animation::named("cup", &cup, 30, 0).unwrap();
    let mut s = cup.clone();
    let (mut real, mut marked) = (0, 0);
    for f in &anim.frames {
        let next = apply(&s, f).unwrap();
        if f.iter().all(Move::is_identity) {
            marked += 1;
            assert_eq!(next.bounds(), s.bounds());
        } else {
            real += 1;
            assert_ne!(next.bounds(), s.bounds());
        }
        s = next;
    }
    assert_eq!((real, marked), (29, 1));

    // carVis: a part out and back returns the scene (within rounding).
    let car = scene::load("car", None).unwrap();
    let anim = Animation::named("car", &car, 2, 0).unwrap();
    let there = apply(&car, &anim.frames[0]).unwrap();
    assert_ne!(there.triangles, car.triangles);
    let back = apply(&there, &anim.frames[1]).unwrap();
    for (a, b) in car.triangles.iter().zip(&back.triangles) {
        for k in 0..3 {
            assert!((a.v[k] - b.v[k]).length() < 1e-5);
        }
    }
    assert!(Animation::named("walk", &car, 2, 0).is_err());
}
