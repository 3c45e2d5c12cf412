//! Memory on the command line: a build that does not fit names the buffer
//! and the sizes; the `footprint` experiment brackets the largest scene
//! each emulated builder fits, and never runs the host out of memory.

use crate::common::stderr;
use cellbih::registry::BuilderKind;

use crate::common::{assert_ok, cellbih, line, run_experiment};

#[test]
fn a_build_that_does_not_fit_names_the_buffer_and_the_sizes() {
    let out = cellbih(&line(
        "build --scene rtperf:200000 --builder spe_morton --memory-mib 12",
    ));
    let err = stderr(&out);
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
    let out = cellbih(&line(
        "build --scene rtperf:200000 --builder spe_morton --memory-mib 64 --mode functional",
    ));
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
