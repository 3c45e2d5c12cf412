//! Each case of the numerical extremes (`scene::extremes`, the table of
//! `cli/experiments/extremes.rs`) as a test: every builder with the paper's
//! settings, and the builders that build the quality knobs with binned SAH
//! and the empty-space cut-off, give a valid tree whose every ray agrees
//! with brute force; the multi-SPE builders also on 1 and on 8 SPEs with
//! every SPE at work (`--tris-per-spe 1`: the cases are small scenes,
//! which they would otherwise run on fewer).

use cellbih::bih::BihConfig;
use cellbih::cell::CellConfig;
use cellbih::quality::agree::{examine, rays_for};
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene::extremes;
use cellbih::strategy::Knobs;

fn check_case(name: &str) {
    let scene = extremes::case(name).unwrap();
    let rays = rays_for(&scene, 300, 5);
    let runs = BuilderKind::every_run(BihConfig::SAH_CUT);
    for (b, cfg) in runs {
        let e = examine(&Build::new(b).with_tree(cfg), &scene, &rays);
        assert!(e.ok(), "{name}, {b} {cfg:?}: {e:?}");
        assert!(
            e.depth <= cfg.max_depth && e.largest_leaf >= 1,
            "{name}, {b}: {e:?}"
        );
        if b.multi_spe() {
            let mut every = Knobs::default();
            b.set_knob(&mut every, "tris-per-spe", "1").unwrap();
            for spes in [1, 8] {
                let cell = CellConfig::ps3().with_spes(spes);
                let request = Build::new(b).with_tree(cfg).on(&cell).with_knobs(&every);
                let e = examine(&request, &scene, &rays);
                assert!(e.ok(), "{name}, {b} {cfg:?} on {spes} SPEs: {e:?}");
            }
        }
    }
}

macro_rules! cases {
    ($($test:ident: $name:literal,)*) => {
        $(#[test] fn $test() { check_case($name); })*

        /// The tests above are the whole list of cases.
        #[test]
        fn every_case_has_its_test() {
            let mut tested = vec![$($name),*];
            let mut all = extremes::CASES.to_vec();
            tested.sort_unstable();
            all.sort_unstable();
            assert_eq!(tested, all);
        }
    };
}

cases! {
    scale_1e_minus_15: "scale 1e-15",
    scale_1e_minus_10: "scale 1e-10",
    scale_1e_minus_5: "scale 1e-5",
    scale_1: "scale 1",
    scale_1e5: "scale 1e5",
    scale_1e10: "scale 1e10",
    scale_1e15: "scale 1e15",
    tiny_cluster_at_1e7: "tiny cluster at 1e7",
    cluster_beside_1e6: "cluster beside 1e6",
    sizes_1e_minus_6_to_1e3: "sizes 1e-6 to 1e3",
    flat: "flat",
    collinear: "collinear",
    points: "points",
    stacks: "stacks",
    slivers: "slivers",
    planes_one_f32_step_apart: "planes one f32 step apart",
}
