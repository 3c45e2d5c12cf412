//! The scene zoo: every kind is made the same from its name (and seed),
//! bad names are refused with the forms, every builder builds a valid tree
//! on it that answers rays as brute force does, every multi-SPE builder
//! builds the baseline's tree on 1–8 SPEs, and more SPEs never run a
//! count predicted slower (small scenes here;
//! the zoo's large scenes are in
//! `tests/real_meshes.rs`, which has the data directory, and the goals in
//! `spe_scaling --zoo`).

mod common;

use cellbih::bih::Tracer;
use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::{self, Scene, zoo};
use cellbih::strategy::program::Prediction;
use common::{check_ray, rays_for};

/// Zoo scenes that need no data directory: every kind, small.
const SMALL: &[&str] = &[
    "ground:cup:1000",
    "stadium:cup",
    "clusters:4:3000:7",
    "row:car:3",
    "soup:2000:3",
    "city:8:2",
];

fn load(spec: &str) -> Scene {
    scene::load(spec, None).unwrap_or_else(|e| panic!("{spec}: {e}"))
}

#[test]
fn every_kind_is_made_the_same_from_its_name() {
    let cup = load("cup");
    let car = load("car");
    let expect = [
        cup.len() + 2,
        cup.len() + 2 + 64 * 31 * 2,
        3000,
        3 * car.len(),
        2000,
        8 * 8 * 12 + 2,
    ];
    for (&spec, n) in SMALL.iter().zip(expect) {
        let (a, b) = (load(spec), load(spec));
        assert_eq!(a.len(), n, "{spec}");
        assert_eq!(a.name, spec);
        assert_eq!(a.triangles, b.triangles, "{spec}: not deterministic");
        assert_eq!(a.geometry_ids, b.geometry_ids, "{spec}");
    }
    // Another seed, another scene; the same seed by default.
    assert_ne!(load("soup:2000:3").triangles, load("soup:2000:4").triangles);
    assert_eq!(load("soup:50").triangles, load("soup:50:1").triangles);
}

#[test]
fn every_kind_has_the_shape_its_name_says() {
    // The ground quad spans `scale` times the mesh's larger horizontal
    // extent, at its lowest point.
    let (cup, g) = (load("cup"), load("ground:cup:1000"));
    let (c, e) = (cup.bounds(), g.bounds());
    let wide = (c.max.x - c.min.x).max(c.max.z - c.min.z);
    assert!(((e.max.x - e.min.x) / wide - 1000.0).abs() < 1.0, "{e:?}");
    assert_eq!(e.min.y, c.min.y);
    assert_eq!(g.geometry_names.last().map(String::as_str), Some("ground"));
    // Clusters are balls of radius 1 far apart: every cluster's triangles
    // within 1.1 of their mean.
    let s = load("clusters:4:3000:7");
    for part in 0..4u32 {
        let tris: Vec<_> = (s.triangles.iter().zip(&s.geometry_ids))
            .filter(|&(_, &g)| g == part)
            .map(|(t, _)| t.v[0])
            .collect();
        let mean = tris.iter().copied().sum::<glam::Vec3>() / tris.len() as f32;
        assert!(
            tris.iter().all(|p| p.distance(mean) < 1.1),
            "cluster {part}"
        );
    }
    // A row: copy i is copy 0 moved along x.
    let (car, row) = (load("car"), load("row:car:3"));
    let step = row.triangles[car.len()].v[0].x - car.triangles[0].v[0].x;
    assert!(step > car.bounds().max.x - car.bounds().min.x);
    // Soup triangles are long and thin: at least 5 long, at most 0.01 wide.
    for t in &load("soup:2000:3").triangles {
        let long = (t.v[1] - t.v[0]).length();
        assert!((4.99..50.01).contains(&long), "{long}");
        assert!((t.v[2] - t.v[0]).length() <= 0.0101);
    }
}

#[test]
fn bad_names_are_refused_with_the_forms() {
    for (spec, says) in [
        ("ground:cup", "ground needs a scale"),
        ("ground:cup:0", "not a positive number"),
        ("ground:cup:nan", "not a positive number"),
        ("ground:cup:10:3", "too many ':' fields"),
        ("clusters:0:100", "at least 1"),
        ("clusters:8:4", "at least 8"),
        ("clusters:2:x", "not a whole number"),
        ("soup:0", "at least 1"),
        ("city:100000", "at most"),
        ("row:cup", "row needs a copy count"),
        ("stadium:nosuchmesh", "nosuchmesh"),
    ] {
        let e = scene::load(spec, None).err().map(|e| e.to_string());
        let e = e.unwrap_or_else(|| panic!("{spec} was accepted"));
        assert!(e.contains(says), "{spec}: {e}");
        // A missing or extra field names every form.
        if says.contains("needs") || says.contains("too many") {
            assert!(e.contains(zoo::FORMS), "{spec}: {e}");
        }
    }
}

#[test]
fn every_builder_builds_a_tree_that_answers_as_brute_force() {
    for &spec in SMALL {
        let s = load(spec);
        for &b in BuilderKind::ALL {
            let r = Build::new(b)
                .run(&s)
                .unwrap_or_else(|e| panic!("{spec} / {b}: {e}"));
            r.bih
                .validate(&s)
                .unwrap_or_else(|v| panic!("{spec} / {b}: {v}"));
            let tracer = Tracer::new(&r.bih, &s);
            for ray in rays_for(&s, 60, 5) {
                check_ray(&s, &tracer, &ray).unwrap_or_else(|e| panic!("{spec} / {b}: {e}"));
            }
        }
    }
}

/// The simulated ms of builder `b` on `s` with `spes` SPEs, its tree's
/// hash, and its prediction of its time if it made one.
fn run(b: BuilderKind, s: &Scene, spes: usize) -> (f64, u64, Option<Prediction>) {
    let cell = CellConfig::ps3().with_spes(spes);
    let r = Build::new(b).on(&cell).run(s).unwrap();
    let sim = r.simulated.expect("emulated");
    (sim.run.ms, r.bih.tree_hash(), sim.predicted)
}

/// Every multi-SPE builder builds the baseline's tree on 1–8 SPEs, and
/// runs on the count it predicts fastest of those given, from one
/// prediction whatever the SPEs given, so that more SPEs given never run a
/// count predicted slower. (How often a prediction is slower with one
/// SPE more on the real builds: `spe_scaling --zoo`, docs/many-spes.md.)
#[test]
fn every_multi_spe_builder_builds_the_baselines_tree_and_more_spes_never_run_slower() {
    let mut scenes: Vec<String> = SMALL.iter().map(|s| s.to_string()).collect();
    // Small rtPerf scenes, where the SPEs a scene gets matter most.
    scenes.extend(
        [
            "rtperf:1000:1",
            "rtperf:4000:2",
            "rtperf:7000:1",
            "cup",
            "default",
        ]
        .map(String::from),
    );
    for spec in &scenes {
        let s = load(spec);
        let (_, base, _) = run(BuilderKind::SPE_BFS, &s, 1);
        for &b in BuilderKind::ALL.iter().filter(|b| b.multi_spe()) {
            let mut given_all = None;
            for spes in (1..=8).rev() {
                let (_, hash, predicted) = run(b, &s, spes);
                assert_eq!(
                    hash, base,
                    "{spec} / {b} on {spes} SPEs: not the baseline's tree"
                );
                let p = predicted.unwrap_or_else(|| panic!("{spec} / {b}: no prediction"));
                let all: &Prediction = given_all.get_or_insert(p.clone());
                assert_eq!(p.cycles[..], all.cycles[..spes], "{spec} / {b}");
                let fastest = (1..=spes).min_by_key(|&k| (p.cycles[k - 1], k));
                assert_eq!(Some(p.chosen), fastest, "{spec} / {b}, {spes} given");
            }
        }
    }
}

/// `spe_morton`'s ranges keyed again within their cells, both ways — a
/// ball too large for one local store's key pairs (every SPE keys it) and
/// balls that fit (one SPE each) — at the scale extremes (the clusters
/// scaled to 1e-15 and 1e15), on 1 and 8 SPEs: the path runs (its phase
/// is there), the tree is the baseline's, it answers rays as brute force
/// does, and a second run gives the same cycles, counters and nodes.
#[test]
fn keys_within_cells_at_the_extremes_on_1_and_8_spes_twice() {
    let morton = BuilderKind::ALL
        .iter()
        .copied()
        .find(|b| b.name() == "spe_morton")
        .expect("the Morton builder");
    for spec in ["clusters:2:20000:3", "clusters:4:20000:5"] {
        for scale in [1e-15f32, 1.0, 1e15] {
            let c = load(spec);
            let tris = c
                .triangles
                .iter()
                .map(|t| cellbih::scene::Triangle {
                    v: t.v.map(|p| p * scale),
                })
                .collect();
            let s = Scene::new(
                format!("{spec} x {scale:e}"),
                tris,
                c.geometry_ids.clone(),
                c.geometry_names.clone(),
            )
            .unwrap();
            let (_, base, _) = run(BuilderKind::SPE_BFS, &s, 1);
            for spes in [1, 8] {
                let cell = CellConfig::ps3().with_spes(spes);
                let build = || Build::new(morton).on(&cell).run(&s).unwrap();
                let (r, again) = (build(), build());
                let what = format!("{} on {spes} SPEs", s.name);
                let sim = r.simulated.as_ref().unwrap();
                assert!(
                    sim.phases
                        .iter()
                        .any(|(p, _)| p.contains("keys within cells")),
                    "{what}: no range keyed again"
                );
                assert_eq!(r.bih.tree_hash(), base, "{what}: not the baseline's tree");
                common::check_multi_spe_runs(&r, &again, &what);
                r.bih.validate(&s).unwrap_or_else(|v| panic!("{what}: {v}"));
                let tracer = Tracer::new(&r.bih, &s);
                for ray in rays_for(&s, 40, 3) {
                    check_ray(&s, &tracer, &ray).unwrap_or_else(|e| panic!("{what}: {e}"));
                }
            }
        }
    }
}
