//! The experiments through their binaries: `tradeoff` (its fronts are
//! Pareto fronts of its rows, its frame reading, its files), `extremes`
//! (every case and builder valid and agreeing), `spe_scaling` (a row per
//! setting the registry sweeps and SPE count), `frame_loop` (the whole
//! frame on the Cell). `footprint` is in `tests/footprint.rs`; `validate`
//! and `sensitivity` in `cli/tests/cli/model_checks.rs`.

use crate::common::stderr;
use serde_json::json;

use crate::common::{assert_ok, fill, run_experiment, tmp};

/// `tradeoff`: every builder setting on a scene, each row with its build
/// cost and measured ray cost; the fronts are Pareto fronts of the rows
/// (no row on a front is beaten on both build ms and ray cost by another of
/// its kind); the frame reading names a host setting; the files are written.
#[test]
fn tradeoff_writes_every_setting_with_its_fronts() {
    let (rows, dir) = run_experiment(
        env!("CARGO_BIN_EXE_tradeoff"),
        "tradeoff",
        &["--scenes", "default"],
    );
    // Every builder at its defaults and at each knob setting its registry
    // entry sweeps.
    for b in cellbih::registry::BuilderKind::ALL {
        for knobs in b.sweeps() {
            let setting = knobs.spelled();
            assert!(
                rows.iter()
                    .any(|r| r["builder"] == b.name() && r["setting"] == setting.as_str()),
                "{b} {setting}"
            );
        }
    }
    for setting in [
        "--split sah --empty-cut 10",
        "--split sah --sah-above 4096 --empty-cut 10",
    ] {
        assert!(rows.iter().any(|r| r["setting"] == setting), "{setting}");
    }
    for (front, time) in [("front_ps3", "simulated_ms"), ("front_host", "host_ms")] {
        let kind: Vec<&serde_json::Value> = rows
            .iter()
            .filter(|r| r["emulated"] == (front == "front_ps3"))
            .collect();
        let on: Vec<&&serde_json::Value> = kind.iter().filter(|r| r[front] == true).collect();
        assert!(!on.is_empty(), "{front}");
        let xy = |r: &serde_json::Value| {
            (
                r[time].as_f64().unwrap(),
                r["primary_cost"].as_f64().unwrap(),
            )
        };
        for r in &on {
            let (x, y) = xy(r);
            let beaten = kind.iter().any(|o| {
                let (ox, oy) = xy(o);
                ox <= x && oy <= y && (ox < x || oy < y)
            });
            assert!(!beaten, "{front}: {r}");
        }
    }
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("tradeoff.json")).unwrap()).unwrap();
    assert_eq!(doc["frames"].as_array().unwrap().len(), 5);
    assert!(
        doc["frames"][0]["primary"]["setting"]
            .as_str()
            .unwrap()
            .starts_with("host")
    );
    // Build and render in one currency: every emulated row's tree cast on
    // the SPEs, and for each frame size the PS3 setting with the least
    // build + render, which no other emulated row beats.
    for r in &rows {
        assert_eq!(r["cell_render_ms"].is_f64(), r["emulated"] == true, "{r}");
    }
    for f in doc["frames"].as_array().unwrap() {
        let rays = f["rays"].as_f64().unwrap();
        let best = f["ps3"]["total_ms"].as_f64().unwrap();
        for r in rows.iter().filter(|r| r["emulated"] == true) {
            let t =
                r["simulated_ms"].as_f64().unwrap() + rays * r["cell_ms_per_ray"].as_f64().unwrap();
            assert!(t >= best - 1e-9, "{r} beats {f}");
        }
    }
    let small = &doc["frames"][0]["ps3"];
    let large = &doc["frames"][4]["ps3"];
    assert!(
        small["build_ms"].as_f64() <= large["build_ms"].as_f64(),
        "{small} {large}"
    );
    let csv = std::fs::read_to_string(dir.join("tradeoff.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + rows.len());
    assert!(dir.join("tradeoff_default.svg").exists());
}

/// `extremes`: a row per case and builder run, all valid and agreeing
/// with brute force (it fails otherwise).
#[test]
fn extremes_checks_every_case_and_builder() {
    let (rows, dir) = run_experiment(
        env!("CARGO_BIN_EXE_extremes"),
        "extremes",
        &["--rays", "20"],
    );
    let runs = cellbih::registry::BuilderKind::every_run(cellbih::bih::BihConfig::SAH_CUT).len();
    assert_eq!(rows.len(), cellbih::scene::extremes::CASES.len() * runs);
    assert!(
        rows.iter()
            .all(|r| r["valid"] == true && r["disagree"] == 0 && r["rays"] == 20)
    );
    assert!(
        rows.iter().any(|r| r["f32_stalls"].as_u64().unwrap() > 0),
        "some case stalls f32"
    );
    assert!(dir.join("extremes.csv").exists());
}

/// The scaling experiment: every multi-SPE builder and knob setting on
/// every SPE count up to --max-spes, each row with its speedup over the
/// baseline and where the time went; refuses bad arguments up front.
#[test]
fn spe_scaling_writes_a_row_per_builder_and_spe_count() {
    let exe = env!("CARGO_BIN_EXE_spe_scaling");
    let dir = tmp("scaling");
    let out = crate::common::command(exe)
        .args(["--scenes", "default", "--max-spes", "2", "--format", "json"])
        .args(["--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert_ok(&out);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = doc["rows"].as_array().unwrap();
    // Each variant on 1 and 2 SPEs: every multi-SPE builder with every knob
    // setting its registry entry sweeps, named by its options.
    let mut by_variant: std::collections::BTreeMap<&str, Vec<u64>> = Default::default();
    for r in rows {
        let v = by_variant
            .entry(r["builder"].as_str().unwrap())
            .or_default();
        v.push(r["spes"].as_u64().unwrap());
    }
    assert!(by_variant.values().all(|s| s == &[1, 2]), "{by_variant:?}");
    let mut changes_tree = std::collections::BTreeMap::new();
    for b in cellbih::registry::BuilderKind::ALL
        .iter()
        .filter(|b| b.multi_spe())
    {
        for knobs in b.sweeps() {
            let name = format!("{} {}", b.name(), knobs.spelled());
            let name = name.trim_end().to_string();
            assert!(by_variant.contains_key(name.as_str()), "{name} missing");
            changes_tree.insert(name, knobs.change_the_tree());
        }
    }
    assert_eq!(changes_tree.len(), by_variant.len(), "{by_variant:?}");
    let speedup_of = |name: &str, spes: u64| {
        let r = rows
            .iter()
            .find(|r| r["builder"] == name && r["spes"] == spes);
        r.unwrap()["speedup"].as_f64().unwrap()
    };
    for r in rows {
        let waste = r["arena_waste"].as_f64().unwrap();
        assert!((0.0..1.0).contains(&waste), "{r}");
        if r["builder"].as_str().unwrap().starts_with("spe_bfs_shared") {
            assert!(r["jobs_taken"].as_u64().unwrap() > 0, "{r}");
        }
        let speedup = r["speedup"].as_f64().unwrap();
        assert!(speedup > 0.0, "{r}");
        // Two SPEs are at most twice one SPE of the same setting.
        let name = r["builder"].as_str().unwrap();
        assert!(
            speedup_of(name, 2) <= 2.0 * speedup_of(name, 1) * 1.001,
            "{name}: superlinear"
        );
        let shares: f64 = ["busy", "dma_wait", "sync_wait", "idle", "atomic"]
            .iter()
            .map(|k| r[k].as_f64().unwrap())
            .sum();
        // Atomic cycles include their waits; the rest partition the run.
        assert!((0.99..1.02).contains(&shares), "{r}");
        if !changes_tree[name] {
            assert_eq!(r["sah_over_baseline"], 1.0, "the baseline's tree: {r}");
        }
    }
    let csv = std::fs::read_to_string(dir.join("spe_scaling.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + rows.len());
    assert!(dir.join("spe_scaling_default.svg").exists());
    // The what-if beyond 8 SPEs, each builder's defaults only: one row a
    // builder and count, 16 SPEs included.
    let out = crate::common::command(exe)
        .args([
            "--scenes",
            "rtperf:3000",
            "--max-spes",
            "16",
            "--defaults-only",
        ])
        .args(["--format", "json", "--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert_ok(&out);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = doc["rows"].as_array().unwrap();
    let builders: Vec<_> = (cellbih::registry::BuilderKind::ALL.iter())
        .filter(|b| b.multi_spe())
        .collect();
    assert_eq!(rows.len(), builders.len() * 16);
    for b in builders {
        let counts: Vec<u64> = (rows.iter())
            .filter(|r| r["builder"] == b.name())
            .map(|r| r["spes"].as_u64().unwrap())
            .collect();
        assert_eq!(counts, (1..=16).collect::<Vec<u64>>(), "{b}");
    }
    for (args, msg) in [
        (&["--max-spes", "0"][..], "0 is not between 1 and 16"),
        (&["--max-spes", "17"][..], "17 is not between 1 and 16"),
        (&["--out", "/proc/x"][..], "/proc/x: cannot write"),
    ] {
        let out = crate::common::command(exe).args(args).output().unwrap();
        let err = stderr(&out);
        assert!(!out.status.success() && err.contains(msg), "{err}");
    }
}

/// `frame_loop`: a row for every scene, size, arrangement and policy, the
/// frames behind each in the JSON, a plot per scene and size; `auto`
/// judged by the oracle, the fixed policies not; a scene that cannot be
/// loaded and a tree knob the builder does not take refused by name.
#[test]
fn frame_loop_plays_every_policy_in_both_arrangements() {
    let (rows, dir) = run_experiment(
        env!("CARGO_BIN_EXE_frame_loop"),
        "frame_loop",
        &[
            "--scenes",
            "car,rtperf:3000",
            "--sizes",
            "32x24",
            "--frames",
            "3",
        ],
    );
    assert_eq!(rows.len(), 2 * 2 * 4, "scenes × arrangements × policies");
    for r in &rows {
        let auto = r["policy"] == "auto";
        assert_eq!(r["near_best"].is_null(), !auto, "{r}");
        assert_eq!(r["frames"].as_array().map(Vec::len), Some(3), "{r}");
        let (u, rd, t) = (
            r["mean_update_ms"].as_f64().unwrap(),
            r["mean_render_ms"].as_f64().unwrap(),
            r["total_ms"].as_f64().unwrap(),
        );
        // Section 5 adds update and render; the paper's overlaps them, on
        // one Cell, never faster than each side alone.
        if r["arrangement"] == "section 5" {
            assert!((t - 3.0 * (u + rd)).abs() < 1e-6 * t, "{r}");
            assert_eq!(r["contention"], "none", "{r}");
        } else {
            assert!(
                t <= 3.0 * (u + rd) + 1e-9 && t >= 3.0 * u.max(rd) - 1e-9,
                "{r}"
            );
            assert_eq!(r["contention"], "simulated", "{r}");
            let alone = r["alone_total_ms"].as_f64().unwrap();
            assert!(alone > 0.0 && alone <= t + 1e-9, "{r}");
        }
    }
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("frame_loop.json")).unwrap())
            .unwrap();
    let frames = doc["rows"][0]["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    assert!(dir.join("frame_loop_car_32x24.svg").exists());
    assert!(dir.join("frame_loop_rtperf_3000_32x24.svg").exists());
    let csv = std::fs::read_to_string(dir.join("frame_loop.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + rows.len());
    let out = crate::common::command(env!("CARGO_BIN_EXE_frame_loop"))
        .args(fill(
            "--scenes no-such-mesh --data /nonexistent --out {}",
            &[dir.to_str().unwrap()],
        ))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(stderr(&out).contains("no-such-mesh"));
    // A tree knob the builder does not take is refused by name.
    let out = crate::common::command(env!("CARGO_BIN_EXE_frame_loop"))
        .args([
            "--builder",
            "spe_morton",
            "--empty-cut",
            "30",
            "--scenes",
            "car",
        ])
        .args(["--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("empty-cut") || err.contains("cut-off"),
        "{err}"
    );
}

/// `frame_loop --ends`: each case's arrangements played again, at their
/// best fixed policies, with the PPE cheap and dear and in the other two
/// code classes; each end's ratio is the paper's total over section 5's,
/// and a dearer PPE never makes section 5's frames faster.
#[test]
fn frame_loop_plays_each_case_again_at_the_models_ends() {
    let (rows, dir) = run_experiment(
        env!("CARGO_BIN_EXE_frame_loop"),
        "frame_loop",
        &[
            "--scenes", "car", "--sizes", "32x24", "--frames", "2", "--ends",
        ],
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("frame_loop.json")).unwrap())
            .unwrap();
    let ends = doc["ends"].as_array().unwrap();
    let names: Vec<&str> = ends.iter().map(|e| e["end"].as_str().unwrap()).collect();
    assert_eq!(names, ["PPE cheap", "PPE dear", "compiled", "tuned"]);
    let ms = |e: &serde_json::Value, k: &str| e[k].as_f64().unwrap();
    for e in ends {
        let ratio = ms(e, "paper_ms") / ms(e, "section5_ms");
        assert!((ms(e, "ratio") - ratio).abs() < 1e-12, "{e}");
    }
    // Section 5's frame adds the PPE's share to the rest (the paper's
    // overlaps it with a render it contends with: no order promised).
    assert!(
        ms(&ends[0], "section5_ms") <= ms(&ends[1], "section5_ms"),
        "{ends:?}"
    );
    // The tuned class's SPU kernels are cheaper: section 5's total, every
    // SPE building and rendering, falls below its best at the rates in
    // force.
    let best_five = (rows.iter())
        .filter(|r| r["arrangement"] == "section 5" && r["policy"] != "auto")
        .map(|r| r["total_ms"].as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert!(ms(&ends[3], "section5_ms") < best_five, "{ends:?}");
    // Without --ends, none.
    let (_, dir) = run_experiment(
        env!("CARGO_BIN_EXE_frame_loop"),
        "frame_loop",
        &["--scenes", "cup", "--sizes", "32x24", "--frames", "1"],
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("frame_loop.json")).unwrap())
            .unwrap();
    assert_eq!(doc["ends"].as_array().map(Vec::len), Some(0));
}

/// The experiments run their independent emulations side by side
/// (`--threads`, rayon): the simulated figures of a run on two and on
/// three threads are byte for byte those of a run on one (the columns of
/// host time and host ray rates aside: this machine's, measured side by
/// side). Every experiment that takes `--threads` (`tradeoff` aside: its
/// run of a scene takes half a minute a thread count here; it shares the
/// same `side_by_side`), on scenes small enough for the test.
#[test]
fn simulated_figures_do_not_depend_on_the_threads() {
    let data = crate::common::data_dir();
    let mut runs: Vec<(&str, &str, Vec<&str>)> = vec![
        (
            env!("CARGO_BIN_EXE_spe_scaling"),
            "spe_scaling.csv",
            vec![
                "--scenes",
                "default,rtperf:3000",
                "--max-spes",
                "3",
                "--defaults-only",
            ],
        ),
        (
            env!("CARGO_BIN_EXE_sensitivity"),
            "sensitivity.csv",
            vec!["--scenes", "default", "--spes", "2,3"],
        ),
        (
            env!("CARGO_BIN_EXE_extremes"),
            "extremes.csv",
            vec!["--rays", "40"],
        ),
        (
            env!("CARGO_BIN_EXE_frame_loop"),
            "frame_loop.csv",
            vec![
                "--scenes",
                "car,rtperf:2000",
                "--sizes",
                "32x24",
                "--frames",
                "3",
            ],
        ),
        (env!("CARGO_BIN_EXE_validate"), "validate.csv", vec![]),
    ];
    match &data {
        Some(_) => runs.push((env!("CARGO_BIN_EXE_table1"), "table1.csv", vec![])),
        None => eprintln!("experiments: CELLBIH_DATA is not set: table1 did NOT run"),
    }
    for (exe, file, args) in runs {
        let csv = |threads: &str| {
            let dir = tmp(&format!("threads-{threads}-{file}"));
            let out = crate::common::command(exe)
                .args(&args)
                .args(["--threads", threads, "--out", dir.to_str().unwrap()])
                .output()
                .unwrap();
            assert_ok(&out);
            let text = std::fs::read_to_string(dir.join(file)).unwrap();
            simulated_columns(&text)
        };
        let one = csv("1");
        assert!(one.lines().count() > 1, "{file}: no rows");
        for threads in ["2", "3"] {
            assert_eq!(csv(threads), one, "{file} on {threads} threads");
        }
    }
}

/// A CSV without its columns of host time or host ray rates.
fn simulated_columns(csv: &str) -> String {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let keep: Vec<bool> = (header.iter())
        .map(|h| !(h.contains("host") || h.contains("mrays")))
        .collect();
    let pick = |l: &str| -> String {
        (l.split(',').zip(&keep))
            .filter(|(_, k)| **k)
            .map(|(v, _)| v)
            .collect::<Vec<_>>()
            .join(",")
    };
    std::iter::once(pick(&header.join(",")))
        .chain(lines.map(pick))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The `host_scaling` example (it measures obvhs, a dev-dependency; `cargo
/// test` builds it beside this test).
fn host_scaling() -> String {
    let exe = std::env::current_exe().unwrap();
    let exe = exe
        .parent()
        .unwrap()
        .parent()
        .unwrap()
        .join("examples")
        .join("host_scaling");
    assert!(exe.exists(), "{} was not built", exe.display());
    exe.to_str().unwrap().to_string()
}

/// `host_scaling`: a row per builder that builds on
/// the host's threads and thread count, the serial builder's, the peer's
/// and, above one thread, the machine's ceiling; every parallel tree the
/// serial builder's; the files written.
#[test]
fn host_scaling_measures_every_parallel_builder_on_every_thread_count() {
    let exe = host_scaling();
    let (rows, dir) = run_experiment(
        &exe,
        "host_scaling",
        &[
            "--scenes",
            "default,rtperf:20000",
            "--threads",
            "1,2",
            "--runs",
            "1",
            "--rounds",
            "1",
        ],
    );
    let parallel: Vec<_> = (cellbih::registry::BuilderKind::ALL.iter())
        .filter(|b| b.host_threads())
        .collect();
    assert!(!parallel.is_empty());
    for scene in ["default", "rtperf:20000:1"] {
        let of = |builder: &str, threads: u64| {
            (rows.iter())
                .filter(|r| {
                    r["scene"] == scene && r["builder"] == builder && r["threads"] == threads
                })
                .count()
        };
        assert_eq!(of("host", 1), 1, "{scene}");
        for b in &parallel {
            for threads in [1, 2] {
                assert_eq!(of(b.name(), threads), 1, "{scene} {b} {threads}");
            }
        }
        assert_eq!(of("ceiling", 2), 1, "{scene}");
        assert_eq!(of("ceiling", 1), 0, "{scene}: a ceiling of one thread");
        assert_eq!(of("obvhs fastest", 2), 1, "{scene}");
    }
    for r in &rows {
        let builder = r["builder"].as_str().unwrap();
        if builder.starts_with("host") {
            assert_eq!(r["same_tree"], true, "{r}");
        }
        assert!(r["wall_ms"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["speedup"].as_f64().unwrap() > 0.0, "{r}");
        if cfg!(target_os = "linux") {
            // /proc/stat's steal: a share, never negative (a row shorter
            // than its 10 ms ticks may count one whole).
            assert!(r["stolen"].as_f64().is_some_and(|f| f >= 0.0), "{r}");
        }
    }
    assert!(dir.join("host_scaling.csv").exists());
    assert!(dir.join("host_scaling.svg").exists());
}

/// `host_scaling --split sah --sah-above N --empty-cut P`: every parallel
/// builder measured with the knobs, each tree the serial builder's with
/// them (not the paper's: the JSON names the settings); binned SAH's
/// options without `--split sah` refused, named.
#[test]
fn host_scaling_builds_with_the_quality_knobs() {
    let exe = host_scaling();
    let knobs = ["--split", "sah", "--sah-above", "2000", "--empty-cut", "10"];
    let mut args = vec!["--scenes", "rtperf:20000", "--threads", "2", "--runs", "1"];
    args.extend(["--rounds", "2"]);
    args.extend(knobs);
    let (rows, dir) = run_experiment(&exe, "host_scaling_knobs", &args);
    let parallel = (cellbih::registry::BuilderKind::ALL.iter()).filter(|b| b.host_threads());
    for b in parallel {
        let row = (rows.iter()).find(|r| r["builder"] == b.name());
        let row = row.unwrap_or_else(|| panic!("no row for {b}"));
        assert_eq!(row["same_tree"], true, "{row}");
    }
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("host_scaling.json")).unwrap()).unwrap();
    let tree = &doc["settings"]["tree"];
    assert_eq!(
        (&tree["split"], &tree["sah_above"], &tree["empty_cut"]),
        (&json!("sah"), &json!(2000), &json!(10)),
        "{tree}"
    );
    let out = crate::common::command(&exe)
        .args(["--scenes", "default", "--sah-above", "10"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("--sah-above"), "{err}");
}

/// Every experiment's `--help` opens with one line on what it measures and
/// how long its default run takes.
#[test]
fn every_experiment_says_what_it_measures_and_how_long_it_takes() {
    let exes = [
        env!("CARGO_BIN_EXE_dma_bandwidth"),
        env!("CARGO_BIN_EXE_table1"),
        env!("CARGO_BIN_EXE_partial_rebuild"),
        env!("CARGO_BIN_EXE_table2"),
        env!("CARGO_BIN_EXE_spe_scaling"),
        env!("CARGO_BIN_EXE_tradeoff"),
        env!("CARGO_BIN_EXE_extremes"),
        env!("CARGO_BIN_EXE_footprint"),
        env!("CARGO_BIN_EXE_validate"),
        env!("CARGO_BIN_EXE_sensitivity"),
        env!("CARGO_BIN_EXE_frame_loop"),
    ];
    for exe in exes {
        let out = crate::common::command(exe).arg("--help").output().unwrap();
        let help = String::from_utf8_lossy(&out.stdout);
        // The first paragraph (wrapped at 80 columns).
        let first = help.split("\n\n").next().unwrap_or("").replace('\n', " ");
        assert!(
            first.contains("(default run: ") && !first.starts_with("Usage"),
            "{exe}: {first}"
        );
    }
}

/// An experiment run in a model that is not the default says so first in
/// its text and in every plot's title; run in the default, neither does;
/// an experiment answers `--version` with its name and the commit.
#[test]
fn an_experiment_names_a_model_that_is_not_the_default() {
    let exe = env!("CARGO_BIN_EXE_spe_scaling");
    let dir = crate::common::tmp("named-model");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "--scenes",
            "rtperf:3000",
            "--max-spes",
            "2",
            "--defaults-only",
        ];
        args.extend(extra);
        args.extend(["--out", dir.to_str().unwrap()]);
        let out = crate::common::command(exe).args(&args).output().unwrap();
        crate::common::assert_ok(&out);
        let svg = std::fs::read_to_string(dir.join("spe_scaling_time.svg")).unwrap();
        (String::from_utf8_lossy(&out.stdout).into_owned(), svg)
    };
    let (text, svg) = run(&["--code", "tuned", "--rate", "spe_job=300"]);
    assert!(
        text.starts_with("model: --code tuned --rate spe_job=300"),
        "{text}"
    );
    assert!(svg.contains("--code tuned --rate spe_job=300"));
    let (text, svg) = run(&[]);
    assert!(
        !text.contains("model:") && !svg.contains("--code"),
        "{text}"
    );
    let out = crate::common::command(exe)
        .arg("--version")
        .output()
        .unwrap();
    crate::common::assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("spe_scaling "));
}

/// How long an experiment's default run takes is written in one place,
/// its `--help` (measured): every experiment's says it, and the README's
/// table of experiments types none.
#[test]
fn an_experiments_duration_is_written_once() {
    let manifest =
        std::fs::read_to_string(format!("{}/cli/Cargo.toml", crate::common::ROOT)).unwrap();
    let bins: Vec<&str> = (manifest.split("[[bin]]").skip(1))
        .map(|b| b.split("\n[").next().unwrap())
        .filter_map(|b| {
            b.lines()
                .find_map(|l| l.strip_prefix("name = \"")?.strip_suffix('"'))
        })
        .filter(|&n| n != "cellbih")
        .collect();
    assert!(bins.len() >= 10, "{bins:?}");
    let release = std::path::Path::new(env!("CARGO_BIN_EXE_cellbih"))
        .parent()
        .unwrap()
        .to_path_buf();
    for bin in &bins {
        let out = crate::common::command(release.join(bin))
            .arg("--help")
            .output()
            .unwrap();
        let help = String::from_utf8_lossy(&out.stdout);
        assert!(help.contains("(default run: "), "{bin}: {help}");
    }
    let readme = std::fs::read_to_string(format!("{}/README.md", crate::common::ROOT)).unwrap();
    let section = readme.split("## The experiments").nth(1).unwrap();
    let section = section.split("\n## ").next().unwrap();
    for word in [" min", " s,", " s |", "seconds", "minutes"] {
        assert!(
            !section.contains(word),
            "the README types a duration ({word}): {section}"
        );
    }
}
