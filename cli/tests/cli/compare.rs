//! `cellbih compare`: every builder side by side, with the paper's tree
//! and with quality knobs.

use crate::common::stderr;
use crate::common::{assert_ok, assert_says, cellbih, json, line};
use cellbih::registry::BuilderKind;

/// `cellbih compare`: a row per builder, the baseline's speedup 1, the
/// baseline's tree where the builder makes it, ray costs measured.
#[test]
fn compare_puts_every_builder_side_by_side() {
    let doc = json("compare --scene car --spes 2 --format json");
    assert_eq!(doc["spes"], 2);
    let rows = doc["rows"].as_array().unwrap();
    assert_eq!(rows.len(), BuilderKind::ALL.len());
    let row = |name: &str| rows.iter().find(|r| r["builder"] == name).unwrap();
    assert_eq!(row("spe_bfs")["speedup_over_spe_bfs"], 1.0);
    assert!(row("host")["simulated_ms"].is_null());
    for name in ["spe_bfs_shared", "spe_bfs_private", "spe_morton"] {
        assert_eq!(row(name)["sah_cost"], row("spe_bfs")["sah_cost"], "{name}");
        assert!(
            row(name)["speedup_over_spe_bfs"].as_f64().unwrap() > 1.0,
            "{name}"
        );
    }
    // The render in the build's currency: every emulated builder's tree
    // cast on the SPEs; the same tree numbered alike casts in the same
    // simulated time (ppe_naive and spe_dfs number nodes depth first, the
    // breadth-first builders level by level) within 1e-5: their
    // leaves hold their triangles in different orders, and a packet pays
    // for `t` only at a triangle a ray's line meets, so the moments of the
    // later reads, and the SPEs' contention, move by a few cycles.
    assert!(row("host")["cell_render_ms"].is_null());
    let ms = |name: &str| row(name)["cell_render_ms"].as_f64().unwrap();
    for (a, b) in [("ppe_naive", "spe_dfs"), ("spe_bfs", "spe_bfs_private")] {
        assert!(
            (ms(a) / ms(b) - 1.0).abs() < 1e-5,
            "{a} {} {b} {}",
            ms(a),
            ms(b)
        );
    }
    for r in rows {
        assert_eq!(
            r["cell_render_ms"].is_f64(),
            !r["simulated_ms"].is_null(),
            "{r}"
        );
        assert!(r["ray_nodes"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["incoherent"]["nodes"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["tree_bytes"].as_u64().unwrap() > 0, "{r}");
    }
    let text = cellbih(&line("compare --scene car"));
    assert_ok(&text);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains("speedup") && text.contains("spe_morton") && text.contains("Cell render"),
        "{text}"
    );
}

/// With quality knobs, every builder that builds them does (the speedup
/// over `spe_bfs` with the same knobs), and the others are named.
#[test]
fn compare_with_knobs_builds_them_where_they_are_built() {
    let doc = json("compare --scene car --empty-cut 30 --split sah --format json");
    let settings = &doc["settings"];
    assert_eq!(settings["tree"]["split"], "sah", "{settings}");
    assert_eq!(settings["tree"]["empty_cut"], 30, "{settings}");
    assert_eq!(settings["cell"]["spes"], 6, "{settings}");
    assert_eq!(settings["cell"]["model"], "measured", "{settings}");
    // The Cell render column's cast is named: the default, in packets.
    assert_eq!(settings["cast"]["packet"], "4x4", "{settings}");
    let cfg = cellbih::bih::BihConfig {
        split: cellbih::bih::SplitChoice::BinnedSah { bins: 16, above: 0 },
        empty_cut: Some(30),
        ..Default::default()
    };
    let (built, not): (Vec<BuilderKind>, Vec<BuilderKind>) = BuilderKind::ALL
        .iter()
        .copied()
        .partition(|b| b.builds(&cfg));
    let rows = doc["rows"].as_array().unwrap();
    let names: Vec<&str> = rows
        .iter()
        .map(|r| r["builder"].as_str().unwrap())
        .collect();
    assert_eq!(names, built.iter().map(|b| b.name()).collect::<Vec<_>>());
    assert_eq!(
        doc["not_built_by"],
        serde_json::json!(not.iter().map(|b| b.name()).collect::<Vec<_>>())
    );
    assert!(!not.is_empty() && !built.is_empty(), "{names:?}");
    assert_eq!(built.len() + not.len(), BuilderKind::ALL.len());
    // The same tree from every builder of the knobs: the host's.
    for r in rows {
        assert_eq!(r["sah_cost"], rows[0]["sah_cost"], "{r}");
    }
    let base = rows.iter().find(|r| r["builder"] == "spe_bfs").unwrap();
    assert_eq!(base["speedup_over_spe_bfs"], 1.0);
}

/// A builder that fails (here: a build that does not fit 2 MiB of emulated
/// memory) is named, with its error, beside the table of the others, and
/// compare then exits non-zero; the JSON lists it under "failed".
#[test]
fn a_failing_builder_is_named_and_the_others_are_compared() {
    let args = ["compare", "--scene", "rtperf:30000", "--memory-mib", "2"];
    let out = crate::common::cellbih(&args);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), stderr(&out));
    assert!(!out.status.success());
    assert!(
        stdout.contains("FAILED: builder ") && stdout.contains("main memory full"),
        "{stdout}"
    );
    assert!(stderr.contains("5 builders failed"), "{stderr}");
    // The cast on the SPEs does not fit 2 MiB either: said, not fatal.
    assert!(stdout.contains("not cast on the SPEs, builder"), "{stdout}");
    let mut json = args.to_vec();
    json.extend(["--format", "json"]);
    let out = crate::common::cellbih(&json);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (rows, failed) = (
        doc["rows"].as_array().unwrap(),
        doc["failed"].as_array().unwrap(),
    );
    assert!(!rows.is_empty() && !failed.is_empty(), "{doc}");
    for f in failed {
        let name = f["builder"].as_str().unwrap();
        assert!(cellbih::registry::BuilderKind::from_name(name).is_some());
        assert!(rows.iter().all(|r| r["builder"] != name));
    }
    let built = rows.len() + failed.len();
    let builds = cellbih::registry::BuilderKind::ALL.len();
    assert_eq!(built, builds, "every builder either compared or named");
}

/// The demo (`cellbih` with no command) and `compare` print for an
/// 80-column terminal: every line of their tables and notes fits, the
/// demo writes its image, and its table has every builder of the
/// registry, in both halves (the build, then the tree's worth).
#[test]
fn the_demo_and_compare_fit_80_columns() {
    let dir = crate::common::tmp("demo");
    std::fs::create_dir_all(&dir).unwrap();
    let demo = crate::common::command(env!("CARGO_BIN_EXE_cellbih"))
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_ok(&demo);
    assert!(dir.join("cellbih-demo.png").exists());
    let compare = cellbih(&line("compare --scene car --spes 2"));
    assert_ok(&compare);
    for out in [&demo, &compare] {
        let text = String::from_utf8_lossy(&out.stdout);
        for line in text.lines() {
            assert!(
                line.chars().count() <= 80,
                "{} columns: {line}",
                line.chars().count()
            );
        }
        for b in BuilderKind::ALL {
            let rows = text
                .lines()
                .filter(|l| l.split_whitespace().next() == Some(b.name()));
            assert_eq!(rows.count(), 2, "{b}: {text}");
        }
    }
}

/// `compare` takes the emulated Cell's options every other command takes:
/// another machine model moves the simulated times, `--mode timed` gives
/// the checked mode's figures, and the functional mode (nothing timed) is
/// refused before any build.
#[test]
fn compare_takes_the_cells_options() {
    let run = |extra: &[&str]| {
        let mut args = vec!["compare", "--scene", "rtperf:400:2", "--format", "json"];
        args.extend(extra);
        cellbih(&args)
    };
    let ms = |out: &std::process::Output| -> Vec<f64> {
        assert_ok(out);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        (v["rows"].as_array().unwrap().iter())
            .filter_map(|r| r["simulated_ms"].as_f64())
            .collect()
    };
    let measured = ms(&run(&[]));
    assert!(!measured.is_empty());
    assert_eq!(ms(&run(&["--mode", "timed"])), measured);
    assert_ne!(ms(&run(&["--model", "legacy"])), measured);
    let out = run(&["--mode", "functional"]);
    assert!(!out.status.success());
    assert_says(&out, "--mode functional");
}
