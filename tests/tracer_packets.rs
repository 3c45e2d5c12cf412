//! The host tracer's packets (`Tracer::closest_packet`): every ray of a
//! packet answers as the single-ray walk does, bit for bit, with the same
//! nodes visited and triangles tested, for every builder's tree at the
//! numerical extremes of the property scenes — camera rays from outside
//! and inside, packets of rays from scattered origins with finite ends,
//! and packets that must fall back to single rays (mixed signs, zero
//! direction components). Both builds of the loop (AVX2 and portable)
//! agree.

mod common;

use cellbih::bih::{PACKET_RAYS, Ray, RayStats, Tracer};
use cellbih::registry::{Build, BuilderKind};
use cellbih::render::Camera;
use common::{packet_ray_sets as ray_sets, same_hit as same, scene_strategy};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    #[test]
    fn packets_answer_as_single_rays(scene in scene_strategy(), seed in any::<u64>()) {
        for &b in BuilderKind::ALL {
            let r = Build::new(b).run(&scene)
                .map_err(|e| TestCaseError::fail(format!("{b}: {e}")))?;
            let tracer = Tracer::new(&r.bih, &scene);
            let portable = Tracer::new(&r.bih, &scene).portable();
            for (set, rays) in ray_sets(&scene, seed) {
                for (p, packet) in rays.chunks(PACKET_RAYS).enumerate() {
                    for t in [&tracer, &portable] {
                        let n = packet.len();
                        let mut hits = vec![None; n];
                        let mut each = vec![RayStats::default(); n];
                        t.closest_packet(packet, &mut hits, &mut each);
                        for (i, ray) in packet.iter().enumerate() {
                            let mut alone = RayStats::default();
                            let want = tracer.closest(ray, &mut alone);
                            prop_assert!(same(&hits[i], &want),
                                "{b}, {set}: packet {p} ray {i}: {:?} alone {want:?}", hits[i]);
                            prop_assert_eq!(each[i], alone, "{}, {}: packet {} ray {}", b, set, p, i);
                        }
                    }
                }
                // All at once: the same hits, and the counts summed.
                let mut total = RayStats::default();
                let all = tracer.closest_all(&rays, &mut total);
                let mut alone = RayStats::default();
                for (ray, hit) in rays.iter().zip(&all) {
                    prop_assert!(same(hit, &tracer.closest(ray, &mut alone)), "{b}, {set}");
                }
                prop_assert_eq!(total, alone);
            }
        }
    }
}

/// The host render (4 × 4 packets in bands of four rows, edge blocks
/// cut) gives every pixel the single ray's answer and cost.
#[test]
fn the_render_in_packets_gives_single_rays_answers() {
    let s = cellbih::scene::load("default", None).unwrap();
    let bih = Build::new(BuilderKind::HOST).run(&s).unwrap().bih;
    let tracer = Tracer::new(&bih, &s);
    let cam = Camera::framing(&s.bounds(), 37, 21);
    let frame = cellbih::render::trace(&tracer, &s.triangles, &cam);
    let mut stats = RayStats::default();
    for y in 0..cam.height {
        for x in 0..cam.width {
            let mut one = RayStats::default();
            let ray = cam.ray(x, y);
            let hit = tracer.closest(&ray, &mut one);
            let i = (y * cam.width + x) as usize;
            assert_eq!(frame.shade[i].is_some(), hit.is_some(), "pixel ({x}, {y})");
            assert_eq!(
                frame.cost[i] as u64,
                one.nodes_visited + one.triangles_tested,
                "pixel ({x}, {y})"
            );
            stats += one;
        }
    }
    assert_eq!(frame.stats, stats);
    assert!(frame.stats.rays == 37 * 21 && frame.shade.iter().any(Option::is_some));
}

/// A packet with a ray that is not a number somewhere (an origin of NaN
/// or infinity, a NaN end) goes ray by ray, and every ray — that one
/// too — answers and counts as it does alone.
#[test]
fn a_packet_with_a_ray_that_is_not_a_number_goes_ray_by_ray() {
    let s = cellbih::scene::load("default", None).unwrap();
    let bih = Build::new(BuilderKind::HOST).run(&s).unwrap().bih;
    let tracer = Tracer::new(&bih, &s);
    let cam = Camera::framing(&s.bounds(), 16, 16);
    let blocks = cam.rays_in_blocks(4, 4);
    for odd in [
        |r: &mut Ray| r.origin.x = f64::NAN,
        |r: &mut Ray| r.origin.y = f64::INFINITY,
        |r: &mut Ray| r.tmax = f64::NAN,
        |r: &mut Ray| r.tmin = f64::NAN,
    ] {
        for packet in blocks.chunks(PACKET_RAYS) {
            let mut rays = packet.to_vec();
            odd(&mut rays[5]);
            let mut hits = vec![None; rays.len()];
            let mut each = vec![RayStats::default(); rays.len()];
            tracer.closest_packet(&rays, &mut hits, &mut each);
            for (i, ray) in rays.iter().enumerate() {
                let mut alone = RayStats::default();
                assert!(same(&hits[i], &tracer.closest(ray, &mut alone)), "ray {i}");
                assert_eq!(each[i], alone, "ray {i}");
            }
        }
    }
}
