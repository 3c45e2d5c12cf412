//! The `cellbih` command as a user runs it: the raycast CSV contract end to
//! end against brute force, JSON output, `-` as standard input and output,
//! and clear errors. The emulated Cell's options (`--spes`, `--mode`,
//! `--model`, `--mailboxes`, `--trace`) are in `cli/tests/cli/emulator.rs`;
//! refusals of arguments in `cli/tests/cli/refusals.rs`; failed writes in
//! `cli/tests/cli/errors.rs`.

use crate::common::stderr;
use crate::common::{assert_ok, cellbih, fill, json, line, tmp};
use cellbih::bih::brute_force_closest;
use cellbih::rays_csv::write_rays;
use cellbih::scene;

#[test]
fn raycast_writes_one_line_per_ray_equal_to_brute_force() {
    for spec in ["default", "car", "rtperf:5000:2"] {
        let s = scene::load(spec, None).unwrap();
        let rays = crate::common::rays_for(&s, 300, 5);
        let rays_path = tmp(&format!("{}.rays.csv", spec.replace(':', "_")));
        let hits_path = tmp(&format!("{}.hits.csv", spec.replace(':', "_")));
        write_rays(std::fs::File::create(&rays_path).unwrap(), &rays).unwrap();
        let out = cellbih(&fill(
            "raycast --scene {} --rays {} --out {}",
            &[
                spec,
                rays_path.to_str().unwrap(),
                hits_path.to_str().unwrap(),
            ],
        ));
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
    let rays = crate::common::rays_for(&s, 100, 8);
    let rays_path = tmp("builders.rays.csv");
    write_rays(std::fs::File::create(&rays_path).unwrap(), &rays).unwrap();
    let mut outputs = Vec::new();
    for b in cellbih::registry::BuilderKind::ALL {
        let out = cellbih(&fill(
            "build --scene car --builder {} --format json",
            &[b.name()],
        ));
        assert!(out.status.success(), "{b}: {}", stderr(&out));
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
        assert!(out.status.success(), "{b}: {}", stderr(&out));
        outputs.push(std::fs::read_to_string(hits).unwrap());
    }
    assert!(
        outputs.windows(2).all(|w| w[0] == w[1]),
        "every builder answers the same hits"
    );
}

#[test]
fn bad_rays_file_is_a_clear_error() {
    let p = tmp("bad.rays.csv");
    std::fs::write(
        &p,
        "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,0,1,0,0,0,inf\n0,0,0,1,0,zero,0,inf\n",
    )
    .unwrap();
    let out = cellbih(&fill(
        "raycast --rays {} --out {}",
        &[p.to_str().unwrap(), tmp("x.csv").to_str().unwrap()],
    ));
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("bad.rays.csv:3: field 6 ('zero') is not a number"),
        "{err}"
    );

    std::fs::write(&p, "x,y\n").unwrap();
    let out = cellbih(&fill(
        "raycast --rays {} --out {}",
        &[p.to_str().unwrap(), tmp("x.csv").to_str().unwrap()],
    ));
    assert!(stderr(&out).contains("the header must be"));
}

#[test]
fn build_json_reports_the_tree() {
    let out = cellbih(&line("build --scene cup --format json"));
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["triangles"], 7040);
    assert_eq!(v["builder"], "host");
    assert!(v["quality"]["sah_cost"].as_f64().unwrap() > 1.0);
    assert!(v["quality"]["leaves"].as_u64().unwrap() >= 7040 / 12);
}

#[test]
fn info_and_errors() {
    let out = cellbih(&line("info --scene car --format json"));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        v["geometry_ids"].as_u64(),
        Some(scene::load("car", None).unwrap().geometry_names.len() as u64)
    );
    let out = cellbih(&line("build --builder nope"));
    assert!(!out.status.success());
    assert!(stderr(&out).contains("the builders are: host"));
    let out = cellbih(&line("info --scene /no/such/file.obj"));
    assert!(stderr(&out).contains("/no/such/file.obj: cannot read"));
}

#[test]
fn render_writes_png_images() {
    for (flag, name) in [(None, "s.png"), (Some("--heatmap"), "h.png")] {
        let p = tmp(name);
        let mut args = fill(
            "render --width 64 --height 48 --out {}",
            &[p.to_str().unwrap()],
        );
        args.extend(flag);
        let out = cellbih(&args);
        assert_ok(&out);
        let img = image::open(&p).unwrap();
        assert_eq!((img.width(), img.height()), (64, 48));
    }
}

/// The README's first command, `cargo run --release` at the root, runs
/// the demo: the workspace's default members include this crate, whose
/// default binary is `cellbih` among the experiments' binaries; and the
/// README's test command, at the root too, tests every crate.
#[test]
fn cargo_run_has_a_default_binary() {
    let manifest =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml")).unwrap();
    assert!(
        manifest
            .lines()
            .any(|l| l.trim() == r#"default-run = "cellbih""#),
        "cli/Cargo.toml must say default-run = \"cellbih\""
    );
    let root = std::fs::read_to_string(format!("{}/Cargo.toml", crate::common::ROOT)).unwrap();
    assert!(
        root.lines()
            .any(|l| l.trim() == r#"default-members = [".", "cell", "cli", "xtask"]"#),
        "the root Cargo.toml must make the three crates and the xtask default members"
    );
}

#[test]
fn update_prints_frames_and_a_summary() {
    let v = json("update --scene car --animation car --frames 8 --strategy deep --format json");
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
    let out = cellbih(&line(
        "update --scene cup --animation cup --frames 3 --builder spe_bfs",
    ));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.contains("simulated ms per frame"),
        "{text}"
    );
    assert!(text.contains("complete rebuilds 3"), "{text}");

    for (args, msg) in [
        (&["--animation", "walk"][..], "unknown animation 'walk'"),
        (
            &line("--animation car --strategy fast")[..],
            "unknown --strategy 'fast'",
        ),
    ] {
        let mut a = vec!["update", "--scene", "car"];
        a.extend_from_slice(args);
        let out = cellbih(&a);
        let err = stderr(&out);
        assert!(!out.status.success() && err.contains(msg), "{err}");
    }
}

#[test]
fn ci_runs_the_readme_test_command_verbatim() {
    let root = crate::common::ROOT;
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
        let mut child = crate::common::command(env!("CARGO_BIN_EXE_cellbih"))
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
    assert!(stderr(&out).contains("written to the standard output"));
    let out = run(
        &["render", "--out", "-", "--width", "32", "--height", "24"],
        b"",
    );
    assert_ok(&out);
    assert!(out.stdout.starts_with(b"\x89PNG"));
    let out = run(&["build", "--builder", "spe_bfs", "--trace", "-"], b"");
    assert!(!out.status.success() && stderr(&out).contains("--trace -"));
    let exp = crate::common::command(env!("CARGO_BIN_EXE_validate"))
        .args(["--out", "-"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(!exp.status.success() && stderr(&exp).contains("'-'"));
    assert!(!dir.join("-").exists(), "a file or directory named '-'");
}
