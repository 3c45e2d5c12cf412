//! The `cellbih` command as a user runs it: the raycast CSV contract end to
//! end against brute force, JSON output, and clear errors.

mod common;

use cellbih::bih::brute_force_closest;
use cellbih::rays_csv::write_rays;
use cellbih::scene;
use common::{assert_ok, cellbih, tmp};

#[test]
fn raycast_writes_one_line_per_ray_equal_to_brute_force() {
    for spec in ["default", "car", "rtperf:5000:2"] {
        let s = scene::load(spec, None).unwrap();
        let rays = common::rays_for(&s, 300, 5);
        let rays_path = tmp(&format!("{}.rays.csv", spec.replace(':', "_")));
        let hits_path = tmp(&format!("{}.hits.csv", spec.replace(':', "_")));
        write_rays(std::fs::File::create(&rays_path).unwrap(), &rays).unwrap();
        let out = cellbih(&[
            "raycast",
            "--scene",
            spec,
            "--rays",
            rays_path.to_str().unwrap(),
            "--out",
            hits_path.to_str().unwrap(),
        ]);
        assert_ok(&out);
        let text = std::fs::read_to_string(&hits_path).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("ray,prim,t"));
        let lines: Vec<&str> = lines.collect();
        assert_eq!(lines.len(), rays.len());
        let mut hits = 0;
        for (i, (line, ray)) in lines.iter().zip(&rays).enumerate() {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f[0], i.to_string());
            match brute_force_closest(&s, ray) {
                None => assert_eq!((f[1], f[2]), ("-1", ""), "{spec} ray {i}"),
                Some(h) => {
                    hits += 1;
                    let t: f64 = f[2].parse().unwrap();
                    assert_eq!(t, h.t, "{spec} ray {i}: t must read back exactly");
                    let prim: u32 = f[1].parse().unwrap();
                    let alone = cellbih::bih::intersect_triangle(
                        &s.triangles[prim as usize],
                        ray,
                        ray.tmin,
                        ray.tmax,
                    );
                    assert!(
                        prim == h.prim || alone.is_some_and(|a| a.0 == t),
                        "{spec} ray {i}"
                    );
                }
            }
        }
        assert!(hits > 50, "{spec}: the rays should mostly hit ({hits})");
    }
}

#[test]
fn every_builder_name_works_with_build_and_raycast() {
    let s = scene::load("car", None).unwrap();
    let rays = common::rays_for(&s, 100, 8);
    let rays_path = tmp("builders.rays.csv");
    write_rays(std::fs::File::create(&rays_path).unwrap(), &rays).unwrap();
    let mut outputs = Vec::new();
    for b in cellbih::registry::BuilderKind::ALL {
        let out = cellbih(&[
            "build",
            "--scene",
            "car",
            "--builder",
            b.name(),
            "--format",
            "json",
        ]);
        assert!(
            out.status.success(),
            "{b}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let hits = tmp(&format!("builders.{b}.hits.csv"));
        let args = [
            "raycast",
            "--scene",
            "car",
            "--builder",
            b.name(),
            "--rays",
            rays_path.to_str().unwrap(),
            "--out",
            hits.to_str().unwrap(),
        ];
        let out = cellbih(&args);
        assert!(
            out.status.success(),
            "{b}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        outputs.push(std::fs::read_to_string(hits).unwrap());
    }
    assert!(
        outputs.windows(2).all(|w| w[0] == w[1]),
        "every builder answers the same hits"
    );
}

#[test]
fn build_trace_writes_chrome_json() {
    let p = tmp("trace.json");
    let out = cellbih(&[
        "build",
        "--scene",
        "cup",
        "--builder",
        "ppe_naive",
        "--trace",
        p.to_str().unwrap(),
    ]);
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    assert!(
        v["traceEvents"]
            .as_array()
            .unwrap()
            .iter()
            .any(|e| e["ph"] == "X" && e["tid"] == 0)
    );
    let out = cellbih(&[
        "build",
        "--scene",
        "cup",
        "--builder",
        "host",
        "--trace",
        p.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("does not run on the emulated Cell"));
}

#[test]
fn bad_rays_file_is_a_clear_error() {
    let p = tmp("bad.rays.csv");
    std::fs::write(
        &p,
        "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,0,1,0,0,0,inf\n0,0,0,1,0,zero,0,inf\n",
    )
    .unwrap();
    let out = cellbih(&[
        "raycast",
        "--rays",
        p.to_str().unwrap(),
        "--out",
        tmp("x.csv").to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.rays.csv:3: field 6 ('zero') is not a number"),
        "{err}"
    );

    std::fs::write(&p, "x,y\n").unwrap();
    let out = cellbih(&[
        "raycast",
        "--rays",
        p.to_str().unwrap(),
        "--out",
        tmp("x.csv").to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("the header must be"));
}

#[test]
fn build_json_reports_the_tree() {
    let out = cellbih(&["build", "--scene", "cup", "--format", "json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["triangles"], 7040);
    assert_eq!(v["builder"], "host");
    assert!(v["quality"]["sah_cost"].as_f64().unwrap() > 1.0);
    assert!(v["quality"]["leaves"].as_u64().unwrap() >= 7040 / 12);
}

#[test]
fn info_and_errors() {
    let out = cellbih(&["info", "--scene", "car", "--format", "json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        v["geometry_ids"].as_u64(),
        Some(scene::load("car", None).unwrap().geometry_names.len() as u64)
    );
    let out = cellbih(&["build", "--builder", "nope"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("the builders are: host"));
    let out = cellbih(&["info", "--scene", "/no/such/file.obj"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("/no/such/file.obj: cannot read"));
}

#[test]
fn render_writes_png_images() {
    for (flag, name) in [(None, "s.png"), (Some("--heatmap"), "h.png")] {
        let p = tmp(name);
        let mut args = vec![
            "render",
            "--width",
            "64",
            "--height",
            "48",
            "--out",
            p.to_str().unwrap(),
        ];
        args.extend(flag);
        let out = cellbih(&args);
        assert_ok(&out);
        let img = image::open(&p).unwrap();
        assert_eq!((img.width(), img.height()), (64, 48));
    }
}

/// The README's first command, `cargo run --release`, needs a default
/// binary once experiments add binaries of their own.
#[test]
fn cargo_run_has_a_default_binary() {
    let manifest =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml")).unwrap();
    assert!(
        manifest
            .lines()
            .any(|l| l.trim() == r#"default-run = "cellbih""#),
        "Cargo.toml must say default-run = \"cellbih\""
    );
}

#[test]
fn update_prints_frames_and_a_summary() {
    let out = cellbih(&[
        "update",
        "--scene",
        "car",
        "--animation",
        "car",
        "--frames",
        "8",
        "--strategy",
        "deep",
        "--format",
        "json",
    ]);
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let frames = v["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 8);
    assert_eq!(v["method"], "deep");
    let s = &v["summary"];
    assert_eq!(
        s["updates"].as_u64().unwrap() + s["rebuilds"].as_u64().unwrap(),
        8
    );
    // Every frame moves one car part; a deep update rebuilds less than all.
    for f in frames {
        assert!(f["transformed"].as_u64().unwrap() > 0);
        assert!(f["rebuilt"].as_u64().unwrap() <= 22_152);
    }
    assert!(v["sah_after"].as_f64().unwrap() > 0.0);

    // Text, on an emulated builder: simulated time is shown.
    let out = cellbih(&[
        "update",
        "--scene",
        "cup",
        "--animation",
        "cup",
        "--frames",
        "3",
        "--builder",
        "spe_bfs",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.contains("simulated ms per frame"),
        "{text}"
    );
    assert!(text.contains("complete rebuilds 3"), "{text}");

    for (args, msg) in [
        (&["--animation", "walk"][..], "unknown animation 'walk'"),
        (
            &["--animation", "car", "--strategy", "fast"][..],
            "unknown --strategy 'fast'",
        ),
    ] {
        let mut a = vec!["update", "--scene", "car"];
        a.extend_from_slice(args);
        let out = cellbih(&a);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(msg), "{err}");
    }
}

#[test]
fn ci_runs_the_readme_test_command_verbatim() {
    let root = env!("CARGO_MANIFEST_DIR");
    let readme = std::fs::read_to_string(format!("{root}/README.md")).unwrap();
    let ci = std::fs::read_to_string(format!("{root}/.ci/run")).unwrap();
    // The README's first code block holds the two commands of a new user.
    let block = readme
        .split("```sh")
        .nth(1)
        .unwrap()
        .split("```")
        .next()
        .unwrap();
    let test_cmd = block
        .lines()
        .find(|l| l.contains("cargo test"))
        .expect("the README's first block has a test command");
    assert!(block.lines().any(|l| l.trim() == "cargo run --release"));
    assert!(
        ci.lines().any(|l| l.trim() == test_cmd.trim()),
        ".ci/run does not run the README's test command `{test_cmd}`"
    );
}

/// `cellbih builders` lists the registry; `--spes N` reaches every emulated
/// builder through build, raycast, render and update and is said in each
/// report; `build --format json` has the same keys for every builder. A
/// builder of the paper uses one SPE and takes the same cycles whatever the
/// SPE count (idle SPEs cost nothing); a multi-SPE builder is faster on 8.
#[test]
fn the_registry_and_spes_reach_every_command() {
    let listed = String::from_utf8_lossy(&cellbih(&["builders"]).stdout).into_owned();
    for b in cellbih::registry::BuilderKind::ALL {
        let line = listed.lines().find(|l| l.starts_with(b.name()));
        assert!(line.is_some(), "{b} in {listed}");
        // Each line says whether the builder builds the quality knobs.
        let says = line
            .unwrap()
            .ends_with("builds --split sah and --empty-cut");
        assert_eq!(says, b.quality().binned_sah && b.quality().empty_cut, "{b}");
        let json = |spes: &str| -> serde_json::Value {
            let out = cellbih(&[
                "build",
                "--scene",
                "cup",
                "--builder",
                b.name(),
                "--spes",
                spes,
                "--format",
                "json",
            ]);
            assert_ok(&out);
            serde_json::from_slice(&out.stdout).unwrap()
        };
        let (one, eight) = (json("1"), json("8"));
        for key in [
            "scene",
            "triangles",
            "builder",
            "host_ms",
            "quality",
            "simulated_ms",
            "simulated_cycles",
            "spes",
            "cores",
            "work",
        ] {
            assert!(eight.get(key).is_some(), "{b}: no '{key}'");
        }
        if b.emulated() {
            assert_eq!(
                (one["spes"].as_u64(), eight["spes"].as_u64()),
                (Some(1), Some(8))
            );
            assert_eq!(eight["cores"].as_array().unwrap().len(), 9, "{b}");
            let (c1, c8) = (
                one["simulated_cycles"].as_u64().unwrap(),
                eight["simulated_cycles"].as_u64().unwrap(),
            );
            if !b.multi_spe() {
                // The paper's builders use one SPE: idle ones cost nothing.
                assert_eq!(c1, c8, "{b}");
            } else {
                assert!(c8 < c1, "{b}: 8 SPEs {c8} cycles, 1 SPE {c1}");
            }
        } else {
            assert!(eight["spes"].is_null() && eight["simulated_ms"].is_null());
        }
    }
    let rays = tmp("spes.rays.csv");
    std::fs::write(&rays, "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,5,0,0,-1,0,inf\n").unwrap();
    let hits = tmp("spes.hits.csv");
    let png = tmp("spes.png");
    for (args, want) in [
        (
            vec![
                "raycast",
                "--rays",
                rays.to_str().unwrap(),
                "--out",
                hits.to_str().unwrap(),
            ],
            "builder spe_bfs on 3 SPEs",
        ),
        (
            vec![
                "render",
                "--width",
                "16",
                "--height",
                "12",
                "--out",
                png.to_str().unwrap(),
            ],
            "builder spe_bfs on 3 SPEs",
        ),
    ] {
        let mut a = args.clone();
        a.extend(["--builder", "spe_bfs", "--spes", "3"]);
        let out = cellbih(&a);
        assert_ok(&out);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(want), "{err}");
    }
    let out = cellbih(&[
        "update",
        "--scene",
        "cup",
        "--animation",
        "cup",
        "--frames",
        "1",
        "--builder",
        "spe_dfs",
        "--spes",
        "2",
    ]);
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("builder spe_dfs on 2 SPEs"));
    let out = cellbih(&["build", "--spes", "0"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("0 is not in 1..=8"));
}

/// The scaling experiment: every multi-SPE builder and knob setting on
/// every SPE count up to --max-spes, each row with its speedup over the
/// baseline and where the time went; refuses bad arguments up front.
#[test]
fn spe_scaling_writes_a_row_per_builder_and_spe_count() {
    let exe = env!("CARGO_BIN_EXE_spe_scaling");
    let dir = tmp("scaling");
    let out = std::process::Command::new(exe)
        .args(["--scenes", "default", "--max-spes", "2", "--format", "json"])
        .args(["--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert_ok(&out);
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = rows.as_array().unwrap();
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
    for (args, msg) in [
        (&["--max-spes", "0"][..], "0 is not in 1..=8"),
        (&["--out", "/proc/x"][..], "/proc/x: cannot write"),
    ] {
        let out = std::process::Command::new(exe).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(msg), "{err}");
    }
}

/// `--mode`: checked and timed give the same cycles and tree; functional
/// the same tree and no simulated time, said in words.
#[test]
fn the_emulator_modes_agree_on_the_tree() {
    let run = |mode: &str| -> serde_json::Value {
        let out = cellbih(&[
            "build",
            "--scene",
            "car",
            "--builder",
            "spe_morton",
            "--mode",
            mode,
            "--format",
            "json",
        ]);
        assert_ok(&out);
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let (checked, timed, functional) = (run("checked"), run("timed"), run("functional"));
    assert!(checked["simulated_cycles"].as_u64().unwrap() > 0);
    assert_eq!(checked["simulated_cycles"], timed["simulated_cycles"]);
    assert!(
        functional["simulated_cycles"].is_null(),
        "no timing: {functional}"
    );
    for m in [&timed, &functional] {
        assert_eq!(m["quality"], checked["quality"]);
    }
    let out = cellbih(&[
        "build",
        "--scene",
        "car",
        "--builder",
        "spe_bfs",
        "--mode",
        "functional",
    ]);
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("functional mode (no timing)"));
    let out = cellbih(&["build", "--mode", "fast"]);
    assert!(!out.status.success());
}

/// `--model measured` runs the builds on the model held against real PS3s
/// (docs/validation.md): the same trees, other cycles where the model
/// changed (several SPEs sharing the memory interface); `--mailboxes
/// ps3-kernel` never makes an emulated build faster and slows the builders
/// that talk to the PPE by mailbox by at least one kernel hand-off.
#[test]
fn the_measured_model_and_the_kernels_mailboxes_are_options_of_a_build() {
    use cellbih::registry::BuilderKind;
    let run = |builder: &str, extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["build", "--builder", builder, "--format", "json"];
        args.extend(extra);
        let out = cellbih(&args);
        assert_ok(&out);
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let cycles = |v: &serde_json::Value| v["simulated_cycles"].as_u64().unwrap();
    let (mut moved, mut slowed) = (0, 0);
    for b in BuilderKind::ALL.iter().filter(|b| b.emulated()) {
        let legacy = run(b.name(), &[]);
        let measured = run(b.name(), &["--model", "measured"]);
        assert_eq!(legacy["quality"], measured["quality"], "{b}: the same tree");
        if b.multi_spe() {
            moved += (cycles(&legacy) != cycles(&measured)) as usize;
        }
        let kernel = run(b.name(), &["--mailboxes", "ps3-kernel"]);
        assert!(cycles(&kernel) >= cycles(&legacy), "{b}");
        slowed += (cycles(&kernel) > cycles(&legacy) + 18_000) as usize;
    }
    assert!(moved > 0 && slowed > 0, "moved {moved}, slowed {slowed}");
}

/// `-` is the standard input for `--rays` and the standard output for
/// `--out` (hits CSV, PNG); no file named `-` appears; a `--trace -` that
/// would mix with the report, and an experiment's `--out -` (a directory
/// of several files), are refused by name.
#[test]
fn a_dash_is_the_standard_input_or_output() {
    use std::io::Write;
    let dir = tmp("dash");
    std::fs::create_dir_all(&dir).unwrap();
    let run = |args: &[&str], input: &[u8]| {
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_cellbih"))
            .args(args)
            .current_dir(&dir)
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        child.stdin.take().unwrap().write_all(input).unwrap();
        child.wait_with_output().unwrap()
    };
    let rays = b"ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,5,0,0,-1,0,inf\n";
    let out = run(&["raycast", "--rays", "-", "--out", "-"], rays);
    assert_ok(&out);
    let hits = String::from_utf8_lossy(&out.stdout);
    assert!(hits.starts_with("ray,prim,t\n0,"), "{hits}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("written to the standard output"));
    let out = run(
        &["render", "--out", "-", "--width", "32", "--height", "24"],
        b"",
    );
    assert_ok(&out);
    assert!(out.stdout.starts_with(b"\x89PNG"));
    let out = run(&["build", "--builder", "spe_bfs", "--trace", "-"], b"");
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("--trace -"));
    let exp = std::process::Command::new(env!("CARGO_BIN_EXE_validate"))
        .args(["--out", "-"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(!exp.status.success() && String::from_utf8_lossy(&exp.stderr).contains("'-'"));
    assert!(!dir.join("-").exists(), "a file or directory named '-'");
}

/// The functional mode has no timing, and says so: no simulated ms or
/// cycles in a build's or an update's JSON (they were 0), the text says
/// "none", and a trace (a timeline) is refused.
#[test]
fn the_functional_mode_reports_no_timing() {
    let out = cellbih(&[
        "build",
        "--builder",
        "spe_bfs",
        "--mode",
        "functional",
        "--format",
        "json",
    ]);
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        v["simulated_ms"].is_null() && v["simulated_cycles"].is_null(),
        "{v}"
    );
    assert_eq!(v["timing"], "none: functional mode");
    let timed = cellbih(&["build", "--builder", "spe_bfs", "--format", "json"]);
    let t: serde_json::Value = serde_json::from_slice(&timed.stdout).unwrap();
    assert!(t["simulated_ms"].as_f64().unwrap() > 0.0 && t["timing"] == "simulated");
    let out = cellbih(&[
        "update",
        "--scene",
        "car",
        "--animation",
        "car",
        "--frames",
        "2",
        "--builder",
        "spe_bfs",
        "--mode",
        "functional",
        "--format",
        "json",
    ]);
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for f in v["frames"].as_array().unwrap() {
        assert!(f["simulated_ms"].is_null(), "{f}");
    }
    let trace = tmp("functional.trace.json");
    let t = trace.to_str().unwrap();
    let out = cellbih(&[
        "build",
        "--builder",
        "spe_bfs",
        "--mode",
        "functional",
        "--trace",
        t,
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no timing"));
    assert!(!trace.exists());
}

/// One SPE is "1 SPE", not "1 SPEs", wherever a command says how many.
#[test]
fn one_spe_is_singular() {
    for args in [
        &["build", "--builder", "spe_bfs", "--spes", "1"][..],
        &[
            "update",
            "--scene",
            "car",
            "--animation",
            "car",
            "--frames",
            "1",
            "--builder",
            "spe_bfs",
            "--spes",
            "1",
        ][..],
        &["compare", "--spes", "1"][..],
    ] {
        let out = cellbih(args);
        assert_ok(&out);
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            text.contains("1 SPE") && !text.contains("1 SPEs"),
            "{args:?}: {text}"
        );
    }
}
