//! Memory modelled to the scene: every emulated build reports its main
//! memory by purpose (every buffer named, none unknown), its local stores'
//! high-water marks, and a level-by-level build never needs more
//! WorkAPPE than the bound it is sized by; a build that does not fit fails
//! naming the buffer and the sizes.

mod common;

use cellbih::bih::BihConfig;
use cellbih::cell::CellConfig;
use cellbih::registry::{Build, BuilderKind};
use cellbih::scene;
use cellbih::spe::footprint::{Purpose, widest_level, work_ppe_jobs};
use cellbih::strategy::Knobs;
use common::{assert_ok, cellbih, run_experiment};

#[test]
fn every_buffer_has_a_purpose_and_the_sums_add_up() {
    for name in ["default", "car", "rtperf:20000"] {
        let s = scene::load(name, None).unwrap();
        for leaf in [1, 12] {
            let cfg = BihConfig {
                leaf_size: leaf,
                ..BihConfig::default()
            };
            for &b in BuilderKind::ALL.iter().filter(|b| b.emulated()) {
                let r = Build::new(b).with_tree(cfg).run(&s).unwrap();
                let f = r.simulated.unwrap().footprint;
                assert!(
                    f.unknown.is_empty(),
                    "{b}: buffers without a purpose: {:?}",
                    f.unknown
                );
                let sum: u64 = f.by_purpose.iter().map(|(_, b)| b).sum();
                assert!(
                    sum <= f.total && f.total - sum < 128 * 64,
                    "{b}: {sum} of {}",
                    f.total
                );
                // At least the records, 48 bytes each, and the tree's nodes.
                assert!(
                    f.bytes(Purpose::TriangleRecords) >= 48 * s.len() as u64,
                    "{b}"
                );
                let tree = 12 * r.bih.nodes.len() as u64;
                assert!(f.bytes(Purpose::Nodes) >= tree, "{b}");
                assert_eq!(f.unused_node_bytes, f.bytes(Purpose::Nodes) - tree, "{b}");
                assert_eq!(f.ls_high_water.len(), 6);
                assert!(f.ls_high_water.iter().all(|&h| h <= 256 * 1024), "{b}");
                if b.name().starts_with("spe_") {
                    assert!(f.ls_high_water[0] > 16 * 1024, "{b}: {:?}", f.ls_high_water);
                }
                // The widest level within the bound WorkAPPE is sized by.
                assert!(
                    f.work_ppe_needed <= work_ppe_jobs(s.len(), leaf) as u64,
                    "{b}"
                );
                assert_eq!(f.work_ppe_needed, widest_level(&r.bih));
            }
        }
    }
}

#[test]
fn a_build_that_does_not_fit_names_the_buffer_and_the_sizes() {
    let out = cellbih(&[
        "build",
        "--scene",
        "rtperf:200000",
        "--builder",
        "spe_morton",
        "--memory-mib",
        "12",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("main memory full: ")
            && err.contains(" asked ")
            && err.contains("of 12582912 in use"),
        "{err}"
    );
    assert!(
        err.contains("largest so far: triangle records 9600000 bytes"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    // The same scene in 64 MiB fits and reports what it used.
    let out = cellbih(&[
        "build",
        "--scene",
        "rtperf:200000",
        "--builder",
        "spe_morton",
        "--memory-mib",
        "64",
        "--mode",
        "functional",
    ]);
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("main memory "));
}

/// `footprint`: each emulated builder's bytes per triangle, and a bracket
/// around the largest rtperf:N it builds: the lower end built, the upper
/// ran out of memory naming a buffer (here in 24 MiB, to stay quick).
#[test]
fn footprint_brackets_the_largest_scene_each_builder_fits() {
    let (rows, dir) = run_experiment(
        env!("CARGO_BIN_EXE_footprint"),
        "footprint",
        &["--memory-mib", "24"],
    );
    assert_eq!(
        rows.len(),
        BuilderKind::ALL.iter().filter(|b| b.emulated()).count()
    );
    for r in rows {
        let (fits, fails) = (
            r["fits_n"].as_u64().unwrap(),
            r["fails_n"].as_u64().unwrap(),
        );
        assert!(fits < fails && fails as f64 <= fits as f64 * 1.25, "{r}");
        // Never a build above 1.1 times the prediction (in whole spheres).
        let predicted = r["predicted_n"].as_u64().unwrap() as f64;
        assert!(
            fails <= ((predicted * 1.1 / 200.0).round() as u64) * 200,
            "{r}"
        );
        let bpt = r["bytes_per_triangle"].as_f64().unwrap();
        // The records alone are 48 bytes a triangle.
        assert!(
            bpt >= 48.0 && (fits as f64) * bpt < 24.0 * 1048576.0 * 1.05,
            "{r}"
        );
        assert!(!r["oom_buffer"].as_str().unwrap().is_empty());
    }
    assert!(dir.join("footprint.csv").exists());
}

/// The smallest memory works: the footprints are fitted in a larger one
/// (they do not depend on its size), and every builder builds at least one
/// rtPerf sphere in 1 MiB, verified.
#[test]
fn footprint_in_one_mib_predicts_and_verifies() {
    let (rows, _) = run_experiment(
        env!("CARGO_BIN_EXE_footprint"),
        "footprint-1",
        &["--memory-mib", "1"],
    );
    assert_eq!(
        rows.len(),
        BuilderKind::ALL.iter().filter(|b| b.emulated()).count()
    );
    for r in rows {
        let fits = r["fits_n"].as_u64().unwrap();
        assert!(fits >= 200, "{r}");
        if let Some(fails) = r["fails_n"].as_u64() {
            assert!(fails > fits && r["oom_buffer"].is_string(), "{r}");
        }
    }
}

/// A prediction whose verification builds would need more host memory
/// than `--host-memory-mib` allows is reported, not verified, saying how
/// much it would need: nothing is built past the budget (the run is quick
/// and every row is there).
#[test]
fn footprint_does_not_run_the_host_out_of_memory() {
    let (rows, _) = run_experiment(
        env!("CARGO_BIN_EXE_footprint"),
        "footprint-host",
        &["--memory-mib", "4096", "--host-memory-mib", "1"],
    );
    assert_eq!(
        rows.len(),
        BuilderKind::ALL.iter().filter(|b| b.emulated()).count()
    );
    for r in rows {
        assert!(r["fits_n"].is_null() && r["fails_n"].is_null(), "{r}");
        let need = r["verify_host_mib"].as_u64().unwrap();
        // Over 4 GiB of emulated memory filled: more than 4096 MiB.
        assert!(need > 4096, "{r}");
        let why = r["not_verified"].as_str().unwrap();
        assert!(
            why.contains(&format!("{need} MiB")) && why.contains("--host-memory-mib"),
            "{why}"
        );
        assert!(r["predicted_n"].as_u64().unwrap() > 10_000_000, "{r}");
    }
}

/// the cooperative top partitions in place, so a builder that
/// offers `--coop-partition` keeps one array of triangle records by
/// default (as the baseline does) and two only with `scratch`; and the
/// ObjectArena pool is sized to the tree (under a node a triangle here,
/// six SPEs' part-filled blocks included, against the 2n + 1 slots it
/// used to hold).
#[test]
fn the_in_place_top_keeps_one_record_array_and_the_pool_fits_the_tree() {
    let s = scene::load("rtperf:200000", None).unwrap();
    let cell = CellConfig {
        cost: cellbih::cell::CostModel::functional(),
        checked: false,
        ..CellConfig::ps3()
    };
    let record = 48 * s.len() as u64;
    let mut checked = 0;
    for &b in BuilderKind::ALL.iter().filter(|b| b.multi_spe()) {
        let f = |knobs: &Knobs| {
            let r = Build::new(b).on(&cell).with_knobs(knobs).run(&s);
            r.unwrap().simulated.unwrap().footprint
        };
        let nodes = f(&Knobs::default()).bytes(Purpose::Nodes);
        assert!(nodes < 12 * s.len() as u64, "{b}: {nodes} bytes of nodes");
        if b.knob("coop-partition").is_err() {
            continue;
        }
        let records = |k: &Knobs| f(k).bytes(Purpose::TriangleRecords);
        assert_eq!(records(&Knobs::default()), record, "{b}: in place");
        let mut scratch = Knobs::default();
        b.set_knob(&mut scratch, "coop-partition", "scratch")
            .unwrap();
        assert_eq!(records(&scratch), 2 * record, "{b}: scratch");
        checked += 1;
    }
    assert!(checked > 0, "no builder offers --coop-partition");
}
