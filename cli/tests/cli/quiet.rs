//! Nothing silent, nothing wide: what a command prints where nothing was
//! timed, while a step takes long, and in an 80-column terminal; options
//! that would mix two outputs in one stream; plain words for one of a
//! thing. The write and signal cases are in `cli/tests/cli/errors.rs`, the
//! refusals before any work in `cli/tests/cli/refusals.rs`.

use crate::common::{
    assert_fails_with, assert_ok, assert_says, cellbih, fill, json, line, one_ray, stderr, stdout,
    tmp,
};

/// Every line of `text` fits 80 columns.
fn fits_80(what: &str, text: &str) {
    for line in text.lines() {
        let n = line.chars().count();
        assert!(n <= 80, "{what}: {n} columns: {line}");
    }
}

/// The hits or the image and the cast's trace cannot both go to the
/// standard output; either alone can.
#[test]
fn two_outputs_are_not_sent_to_one_stream() {
    let rays = one_ray("two.rays.csv");
    let rays = rays.as_str();
    for args in [
        &line("render --on-cell --width 8 --height 8 --out - --trace -")[..],
        &[
            "raycast",
            "--on-cell",
            "--rays",
            rays,
            "--out",
            "-",
            "--trace",
            "-",
        ][..],
    ] {
        let out = cellbih(args);
        assert_fails_with(
            &out,
            "--out - (the standard output) and --trace - (the standard output) name the same file",
        );
        assert!(out.stdout.is_empty(), "{args:?}");
    }
    let trace = tmp("two.trace.json");
    let out = cellbih(&fill(
        "raycast --on-cell --rays {} --out - --trace {}",
        &[rays, trace.to_str().unwrap()],
    ));
    assert_ok(&out);
    assert!(stdout(&out).starts_with("ray,prim,t\n"));
}

/// The functional mode times nothing, and no report pretends it did: no
/// cycle columns, no zero cycles in the JSON, no "SPEs busy" shares; the
/// SPEs a build used are still counted (by the data they moved).
#[test]
fn the_functional_mode_prints_no_timing_fields() {
    let out = cellbih(&line("build --builder spe_bfs --mode functional"));
    assert_ok(&out);
    let text = stdout(&out);
    assert!(text.contains("the functional mode times nothing"), "{text}");
    for timed in ["busy", "DMA wait", "idle", "SPEs used"] {
        assert!(!text.contains(timed), "'{timed}' in {text}");
    }
    let out = cellbih(&line(
        "build --builder spe_bfs --mode functional --format json",
    ));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["simulated_ms"].is_null() && v["simulated_cycles"].is_null());
    assert_eq!(v["spes_used"], 1, "{v}");
    for core in v["cores"].as_array().unwrap() {
        let c = core[1].as_object().unwrap();
        for key in [
            "busy",
            "dma_wait",
            "idle",
            "atomic",
            "mailbox_wait",
            "memory_wait",
        ] {
            assert!(!c.contains_key(key), "{key} in {core}");
        }
        assert!(c.contains_key("bytes_get"), "{core}");
    }
    // Timed, the same build has its cycles.
    let out = cellbih(&line("build --builder spe_bfs --format json"));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["cores"][1][1]["busy"].as_u64().unwrap() > 0);

    let rays = one_ray("functional.rays.csv");
    let hits = tmp("functional.hits.csv");
    let out = cellbih(&fill(
        "raycast --on-cell --mode functional --rays {} --out {}",
        &[&rays, hits.to_str().unwrap()],
    ));
    assert_ok(&out);
    let err = stderr(&out);
    assert!(
        err.contains("nothing timed") && !err.contains("busy"),
        "{err}"
    );
}

/// `SPEs used` is said only of a builder that decides how many SPEs to
/// use, naming its own knob; a builder of the paper uses one by design.
#[test]
fn spes_used_is_said_only_where_a_builder_decides_it() {
    let one = stdout(&cellbih(&line("build --builder spe_bfs")));
    assert!(!one.contains("SPEs used"), "{one}");
    let many = stdout(&cellbih(&line("build --builder spe_bfs_private")));
    assert!(
        many.contains("SPEs used   4 of 6") && many.contains("--tris-per-spe 1"),
        "{many}"
    );
}

/// A shallow tree's rays are measured on an even sample, and the report
/// says so; a step that takes more than a moment says what it is doing on
/// stderr even when stderr is not a terminal.
#[test]
fn a_shallow_tree_is_measured_on_a_sample_and_long_steps_are_shown() {
    let v = json("build --scene rtperf:100000 --leaf-size 100000 --format json");
    let sampled = v["rays"]["primary"]["sampled"].as_u64().unwrap();
    assert!((1000..10_000).contains(&sampled), "{v}");
    assert!(v["rays"]["incoherent"]["sampled"].as_u64().unwrap() < 16_384);
    let text = stdout(&cellbih(&line(
        "build --scene rtperf:100000 --leaf-size 100000",
    )));
    assert!(text.contains("of the 307200 rays, evenly spread"), "{text}");
    // A usual tree: every ray.
    let v: serde_json::Value =
        serde_json::from_slice(&cellbih(&line("build --format json")).stdout).unwrap();
    assert!(v["rays"]["primary"].get("sampled").is_none(), "{v}");

    let png = tmp("slow.png");
    let out = cellbih(&[
        "render",
        "--on-cell",
        // Ray by ray: packets make this cast too quick to be a long step.
        "--packet",
        "1x1",
        "--max-depth",
        "3",
        "--width",
        "320",
        "--height",
        "240",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert_ok(&out);
    assert_says(&out, "casting the rays on the Cell …");
}

/// `compare` names, of the tree's options, only the one a left-out builder
/// does not build.
#[test]
fn compare_names_only_what_leaves_a_builder_out() {
    let out = cellbih(&line(
        "compare --scene cup --spes 2 --leaf-size 4 --split sah",
    ));
    assert_ok(&out);
    let text = stdout(&out);
    let line = text
        .lines()
        .find(|l| l.starts_with("not built:"))
        .expect(&text);
    assert!(line.ends_with("do not build --split sah)"), "{line}");
    assert!(!text.contains("do not build --leaf-size"), "{text}");
}

/// One of a thing is said in the singular; the update and the frame say
/// which builder on what, threads included; an unknown builder is named
/// as unknown by the frame-loop experiment.
#[test]
fn one_is_singular_and_every_report_says_what_built() {
    // One frame of 16 × 16 on `spes`, `build` of them building; its
    // report on one line.
    let frame = |spes: &str, build: &[&str]| {
        let mut args = vec!["frame", "--builder", "spe_bfs", "--animation", "rtperf"];
        args.extend([
            "--frames", "1", "--width", "16", "--height", "16", "--spes", spes,
        ]);
        args.extend(build);
        stdout(&cellbih(&args)).replace('\n', " ")
    };
    let text = frame("2", &["--build-spes", "1"]);
    assert!(
        text.contains("1 SPE builds the next frame while 1 SPE renders"),
        "{text}"
    );
    assert!(text.contains("for 1 frame:"), "{text}");
    let text = frame("1", &[]);
    assert!(text.contains("the one SPE builds, then renders"), "{text}");
    let one = tmp("one.obj");
    std::fs::write(&one, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let text = stdout(&cellbih(&["build", "--scene", one.to_str().unwrap()]));
    assert!(
        text.contains("(1 triangle)") && text.contains("1 leaf)"),
        "{text}"
    );
    let text = stdout(&cellbih(&line(
        "update --builder host_shared --threads 2 --animation rtperf --frames 1",
    )));
    assert!(
        text.contains("builder host_shared on 2 host threads"),
        "{text}"
    );
    let out = crate::common::command(env!("CARGO_BIN_EXE_frame_loop"))
        .args(["--builder", "nope", "--out", tmp("fl").to_str().unwrap()])
        .output()
        .unwrap();
    assert_fails_with(&out, "--builder nope: no such builder");
}

/// The commands' reports fit an 80-column terminal (tables split, notes
/// wrapped); `--format json` carries everything.
#[test]
fn reports_fit_80_columns() {
    let runs: [&[&str]; 5] = [
        &["builders"],
        &["build", "--builder", "spe_bfs_private"],
        &["build", "--builder", "spe_bfs_shared", "--job-cache", "4"],
        &["update", "--animation", "rtperf", "--frames", "2"],
        &[
            "frame",
            "--builder",
            "spe_bfs",
            "--animation",
            "rtperf",
            "--frames",
            "2",
            "--oracle",
            "--policy",
            "auto",
            "--width",
            "32",
            "--height",
            "32",
        ],
    ];
    for args in runs {
        let out = cellbih(args);
        assert_ok(&out);
        fits_80(&args.join(" "), &stdout(&out));
    }
    let exps: [(&str, &[&str]); 3] = [
        (
            env!("CARGO_BIN_EXE_spe_scaling"),
            &["--scenes", "cup", "--max-spes", "2", "--defaults-only"],
        ),
        (env!("CARGO_BIN_EXE_table2"), &["--no-sim"]),
        (
            env!("CARGO_BIN_EXE_partial_rebuild"),
            &["--to", "20000", "--frames", "3", "--no-sim"],
        ),
    ];
    for (exe, args) in exps {
        let out = crate::common::command(exe)
            .args(args)
            .args(["--out", tmp("80").to_str().unwrap()])
            .output()
            .unwrap();
        assert_ok(&out);
        fits_80(exe, &stdout(&out));
    }
}
