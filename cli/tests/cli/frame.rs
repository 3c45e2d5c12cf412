//! `cellbih frame`: every frame and the totals printed, the JSON's
//! fields, and the refusals before any work.

use crate::common::{assert_fails_with, assert_ok, cellbih, line};

/// `cellbih frame` prints each frame and the totals; its JSON has a
/// `frames` array (choice, update, render and frame ms) and the total; a
/// functional mode, an unknown policy, a host builder and the cast's
/// options are checked before any work; `--policy auto --oracle` prints
/// the predictions and the oracle's verdict.
#[test]
fn the_frame_command_reports_every_frame() {
    let args = [
        "frame",
        "--scene",
        "car",
        "--animation",
        "car",
        "--frames",
        "3",
        "--builder",
        "spe_bfs_shared",
        "--width",
        "32",
        "--height",
        "24",
        "--build-spes",
        "2",
    ];
    let out = cellbih(&args);
    assert_ok(&out);
    let text = String::from_utf8_lossy(&out.stdout).replace('\n', " ");
    assert!(
        text.contains("2 SPEs build the next frame while 4 SPEs render"),
        "{text}"
    );
    assert!(text.contains("frames per second"), "{text}");
    // What the paper's arrangement adds is said: the second copy, what the
    // update beside the render on one Cell added, and the bound on it.
    assert!(
        text.contains("of it: the PPE's share of the updates")
            && text.contains("second copy")
            && text.contains("side by side on one Cell")
            && text.contains("the bound on sharing the memory interface: at most")
            && text.contains("overlapped (each frame's PPE search during the frame before)"),
        "{text}"
    );
    let mut json_args = args.to_vec();
    json_args.extend(["--format", "json"]);
    let out = cellbih(&json_args);
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let frames = v["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    let mut total = 0.0;
    for f in frames {
        for key in [
            "choice",
            "update_ms",
            "render_ms",
            "frame_ms",
            "ppe_ms",
            "copy_ms",
            "overlap_frame_ms",
        ] {
            assert!(!f[key].is_null(), "{key}: {f}");
        }
        total += f["frame_ms"].as_f64().unwrap();
    }
    assert!((v["total_ms"].as_f64().unwrap() - total).abs() < 1e-9);
    assert!(v["second_copy_bytes"].as_u64().is_some_and(|b| b > 0));
    assert!(v["sharing_bound_ms"].as_f64().is_some_and(|b| b >= 0.0));
    // Contention simulated: the update beside the render on one Cell,
    // never faster than each alone.
    assert_eq!(v["contention"], "simulated");
    assert!(
        v["alone_total_ms"]
            .as_f64()
            .is_some_and(|a| a <= total + 1e-9)
    );
    // The frames with the PPE's search overlapped, beside the serial ones
    // the policy chose by.
    let overlap = &v["overlap"];
    assert!(
        overlap["total_ms"]
            .as_f64()
            .is_some_and(|t| t <= total + 1e-9)
    );
    assert_eq!(overlap["policy_assumed"], "serial");
    let out = cellbih(&line(
        "frame --scene car --animation car --frames 2 --builder spe_bfs --width 16 --height 12 --policy auto --oracle",
    ));
    assert_ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("pred upd ms") && text.contains("of the frames within 10 %"),
        "{text}"
    );
    // Each refused before any work, the error naming what to change.
    for (extra, says) in [
        (&["--builder", "host"][..], "needs an emulated builder"),
        (&["--mode", "functional"][..], "--mode functional has none"),
        (
            &["--policy", "fastest"][..],
            "invalid value 'fastest' for '--policy <POLICY>' [possible values: rebuild, local, deep, auto]",
        ),
        (&line("--cache-kib 1 --cache-ways 16")[..], "whole sets"),
    ] {
        let mut args = vec!["frame", "--animation", "car", "--scene", "car"];
        args.extend(extra);
        assert_fails_with(&cellbih(&args), says);
    }
}

/// Options that cannot apply are refused by name: `--build-spes` and
/// `--find-moved spe` for a builder that builds on the PPE alone, and
/// `--build-spes` equal to `--spes` (no SPE left to render beside the
/// build); the JSON's `choice` is what the table shows.
#[test]
fn frame_options_that_cannot_apply_are_refused() {
    let base = "frame --scene car --animation car --frames 1";
    for (extra, says) in [
        (
            "--builder ppe_naive --build-spes 1",
            "--build-spes: builder ppe_naive builds on the PPE",
        ),
        (
            "--builder ppe_naive --find-moved spe",
            "--find-moved spe: builder ppe_naive builds on the PPE",
        ),
        ("--spes 1 --build-spes 1", "--build-spes 1 with --spes 1"),
        ("--spes 4 --build-spes 4", "--build-spes 4 with --spes 4"),
    ] {
        let args = format!("{base} --width 8 --height 8 {extra}");
        assert_fails_with(&cellbih(&line(&args)), says);
    }
    let args = "frame --scene car --animation car --frames 2 --width 32 --height 32 --format json";
    let out = cellbih(&line(args));
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for f in v["frames"].as_array().unwrap() {
        let full = f["full_rebuild"].as_bool().unwrap();
        assert_eq!(f["choice"] == "rebuild", full, "{f}");
        assert_eq!(f["policy_choice"], "local", "{f}");
    }
}

/// `frame --trace` writes the paper's arrangement's one-Cell runs as a
/// Chrome trace whose tracks nest, each frame at its start; without a
/// paper's arrangement it is refused by name.
#[test]
fn frame_writes_the_one_cell_runs_as_a_trace() {
    let path = crate::common::tmp("frame.trace.json");
    let p = path.to_str().unwrap();
    let base = "frame --scene car --animation car --width 32 --height 24";
    let out = cellbih(&crate::common::fill(
        &format!("{base} --frames 2 --build-spes 2 --trace {{}}"),
        &[p],
    ));
    assert_ok(&out);
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    crate::common::check_nesting(&doc).unwrap();
    let ends: Vec<f64> = (doc["traceEvents"].as_array().unwrap().iter())
        .filter_map(|e| Some(e["ts"].as_f64()? + e["dur"].as_f64()?))
        .collect();
    let first_frame_us = 1e3 * {
        let v: serde_json::Value = serde_json::from_slice(
            &cellbih(&line(&format!(
                "{base} --build-spes 2 --frames 1 --format json"
            )))
            .stdout,
        )
        .unwrap();
        v["total_ms"].as_f64().unwrap()
    };
    assert!(
        ends.iter().any(|&e| e > first_frame_us),
        "no span of the second frame"
    );
    assert_fails_with(
        &cellbih(&crate::common::fill(
            &format!("{base} --frames 2 --trace {{}}"),
            &[p],
        )),
        "--trace: the trace is of the paper's arrangement's one-Cell runs",
    );
}

/// A frame the emulated memory cannot hold is refused before any work,
/// naming `--memory-mib`: a build's records, buffers and fewest nodes;
/// in the paper's arrangement also the cast and the tree's copies.
#[test]
fn a_frame_too_big_for_the_memory_is_refused_before_any_work() {
    let exe = env!("CARGO_BIN_EXE_cellbih");
    let limit = std::time::Duration::from_secs(30);
    let base = [
        "frame",
        "--animation",
        "rtperf",
        "--frames",
        "1",
        "--width",
        "8",
        "--height",
        "8",
    ];
    let out = crate::common::run_limited(
        exe,
        &[
            &base[..],
            &["--scene", "rtperf:5000000", "--memory-mib", "330"],
        ]
        .concat(),
        limit,
    );
    assert_fails_with(
        &out,
        "building its 5000000 triangles takes at least 333 MiB",
    );
    let out = crate::common::run_limited(
        exe,
        &[
            &base[..],
            &["--scene", "rtperf:3000000", "--build-spes", "1"],
        ]
        .concat(),
        limit,
    );
    assert_fails_with(
        &out,
        "the frame in the paper's arrangement holds on one Cell",
    );
    assert_fails_with(&out, "(--memory-mib): nothing built or cast");
}
