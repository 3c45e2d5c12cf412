//! The emulated Cell through the `cellbih` command: the registry and
//! `--spes` in every command, `--mode` (checked, timed, functional: no
//! timing, said so), `--model` and `--mailboxes`, and `--trace`'s Chrome
//! JSON; `raycast --on-cell` and `render --on-cell` (casting on the SPEs).

use crate::common::stderr;
use crate::common::{assert_fails_with, assert_ok, cellbih, fill, json, line, tmp};

#[test]
fn build_trace_writes_chrome_json() {
    let p = tmp("trace.json");
    let out = cellbih(&fill(
        "build --scene cup --builder ppe_naive --trace {}",
        &[p.to_str().unwrap()],
    ));
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    assert!(
        v["traceEvents"]
            .as_array()
            .unwrap()
            .iter()
            .any(|e| e["ph"] == "X" && e["tid"] == 0)
    );
    let out = cellbih(&fill(
        "build --scene cup --builder host --trace {}",
        &[p.to_str().unwrap()],
    ));
    assert!(stderr(&out).contains("does not run on the emulated Cell"));
}

/// `cellbih builders` lists the registry; `--spes N` reaches every emulated
/// builder through build, raycast, render and update and is said in each
/// report; `build --format json` has the same keys for every builder. A
/// builder of the paper uses one SPE and takes the same cycles whatever the
/// SPE count (idle SPEs cost nothing); a multi-SPE builder is faster on 8.
#[test]
fn the_registry_and_spes_reach_every_command() {
    let listed = String::from_utf8_lossy(&cellbih(&line("builders")).stdout).into_owned();
    for b in cellbih::registry::BuilderKind::ALL {
        // Each builder's name on a line of its own, what it is indented
        // under it (wrapped to 80 columns), saying whether it builds the
        // quality knobs.
        let at = listed.lines().position(|l| l == b.name());
        assert!(at.is_some(), "{b} in {listed}");
        let block: Vec<&str> = (listed.lines().skip(at.unwrap() + 1))
            .take_while(|l| l.starts_with("    "))
            .map(str::trim)
            .collect();
        assert!(listed.lines().all(|l| l.chars().count() <= 80), "{listed}");
        let says = block
            .join(" ")
            .ends_with("builds --split sah and --empty-cut");
        assert_eq!(says, b.quality().binned_sah && b.quality().empty_cut, "{b}");
        // A host builder takes no --spes (nothing runs on the Cell): its
        // report is the same without it.
        let json = |spes: &str| -> serde_json::Value {
            let mut args = vec!["build", "--scene", "cup", "--builder", b.name()];
            if b.emulated() {
                args.extend(["--spes", spes]);
            }
            args.extend(["--format", "json"]);
            let out = cellbih(&args);
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
            fill(
                "raycast --rays {} --out {}",
                &[rays.to_str().unwrap(), hits.to_str().unwrap()],
            ),
            "builder spe_bfs on 3 SPEs",
        ),
        (
            fill(
                "render --width 16 --height 12 --out {}",
                &[png.to_str().unwrap()],
            ),
            "builder spe_bfs on 3 SPEs",
        ),
    ] {
        let mut a = args.clone();
        a.extend(["--builder", "spe_bfs", "--spes", "3"]);
        let out = cellbih(&a);
        assert_ok(&out);
        let err = stderr(&out);
        assert!(err.contains(want), "{err}");
    }
    let out = cellbih(&line(
        "update --scene cup --animation cup --frames 1 --builder spe_dfs --spes 2",
    ));
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("builder spe_dfs on 2 SPEs"));
    let out = cellbih(&line("build --spes 0"));
    assert!(stderr(&out).contains("0 is not between 1 and 16"));
}

/// `--mode`: checked and timed give the same cycles and tree; functional
/// the same tree and no simulated time, said in words.
#[test]
fn the_emulator_modes_agree_on_the_tree() {
    let run = |mode: &str| -> serde_json::Value {
        let out = cellbih(&fill(
            "build --scene car --builder spe_morton --mode {} --format json",
            &[mode],
        ));
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
    let out = cellbih(&line(
        "build --scene car --builder spe_bfs --mode functional",
    ));
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("functional mode (no timing)"));
    let out = cellbih(&line("build --mode fast"));
    assert!(!out.status.success());
}

/// A build runs on the model held against real PS3s (docs/validation.md)
/// unless `--model legacy` asks for the model before it: the same trees,
/// other cycles where the model changed (several SPEs sharing the memory
/// interface), and `--model measured` is the default spelled out;
/// `--mailboxes ps3-kernel` never makes an emulated build faster and slows
/// the builders that talk to the PPE by mailbox by at least one kernel
/// hand-off.
#[test]
fn the_legacy_model_and_the_kernels_mailboxes_are_options_of_a_build() {
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
        let measured = run(b.name(), &[]);
        let spelled = run(b.name(), &["--model", "measured"]);
        assert_eq!(cycles(&measured), cycles(&spelled), "{b}: the default");
        let legacy = run(b.name(), &["--model", "legacy"]);
        assert_eq!(legacy["quality"], measured["quality"], "{b}: the same tree");
        if b.multi_spe() {
            moved += (cycles(&legacy) != cycles(&measured)) as usize;
        }
        let kernel = run(b.name(), &["--mailboxes", "ps3-kernel"]);
        assert!(cycles(&kernel) >= cycles(&measured), "{b}");
        slowed += (cycles(&kernel) > cycles(&measured) + 18_000) as usize;
    }
    assert!(moved > 0 && slowed > 0, "moved {moved}, slowed {slowed}");
}

/// The functional mode has no timing, and says so: no simulated ms or
/// cycles in a build's or an update's JSON (they were 0), the text says
/// "none", and a trace (a timeline) is refused.
#[test]
fn the_functional_mode_reports_no_timing() {
    let v = json("build --builder spe_bfs --mode functional --format json");
    assert!(
        v["simulated_ms"].is_null() && v["simulated_cycles"].is_null(),
        "{v}"
    );
    assert_eq!(v["timing"], "none: functional mode");
    let timed = cellbih(&line("build --builder spe_bfs --format json"));
    let t: serde_json::Value = serde_json::from_slice(&timed.stdout).unwrap();
    assert!(t["simulated_ms"].as_f64().unwrap() > 0.0 && t["timing"] == "simulated");
    let v = json(
        "update --scene car --animation car --frames 2 --builder spe_bfs --mode functional --format json",
    );
    for f in v["frames"].as_array().unwrap() {
        assert!(f["simulated_ms"].is_null(), "{f}");
    }
    let trace = tmp("functional.trace.json");
    let t = trace.to_str().unwrap();
    let out = cellbih(&fill(
        "build --builder spe_bfs --mode functional --trace {}",
        &[t],
    ));
    assert!(!out.status.success());
    assert!(stderr(&out).contains("no timing"));
    assert!(!trace.exists());
}

/// One SPE is "1 SPE", not "1 SPEs", wherever a command says how many.
#[test]
fn one_spe_is_singular() {
    for args in [
        &line("build --builder spe_bfs --spes 1")[..],
        &line("update --scene car --animation car --frames 1 --builder spe_bfs --spes 1")[..],
        &["compare", "--spes", "1"][..],
    ] {
        let out = cellbih(args);
        assert_ok(&out);
        let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), stderr(&out));
        assert!(
            text.contains("1 SPE") && !text.contains("1 SPEs"),
            "{args:?}: {text}"
        );
    }
}

/// `raycast --on-cell` and `render --on-cell` cast on the emulated SPEs:
/// the hits file and the image are byte for byte the host tracer's for the
/// same tree, and the report says what the cast cost on the Cell; the
/// cast's options are refused, by name, without `--on-cell`.
#[test]
fn casting_on_the_cell_writes_what_the_host_writes() {
    use cellbih::rays_csv::write_rays;
    let s = cellbih::scene::load("default", None).unwrap();
    let rays = crate::common::rays_for(&s, 400, 9);
    let rays_path = tmp("on_cell.rays.csv");
    write_rays(std::fs::File::create(&rays_path).unwrap(), &rays).unwrap();
    for builder in ["host", "spe_morton"] {
        let mut files = Vec::new();
        for extra in [&[][..], &line("--on-cell --spes 3 --cache-kib 4")[..]] {
            let hits = tmp(&format!("on_cell_{builder}_{}.csv", files.len()));
            let mut args = fill(
                "raycast --builder {} --rays {} --out {}",
                &[builder, rays_path.to_str().unwrap(), hits.to_str().unwrap()],
            );
            args.extend(extra);
            let out = cellbih(&args);
            assert_ok(&out);
            let err = stderr(&out);
            assert_eq!(err.contains("on the Cell:"), !extra.is_empty(), "{err}");
            if !extra.is_empty() {
                assert!(
                    err.contains("with 3 SPEs") && err.contains("software cache hit rate"),
                    "{err}"
                );
            }
            files.push(std::fs::read(&hits).unwrap());
        }
        assert_eq!(files[0], files[1], "{builder}: the hits files differ");
    }
    for heatmap in [false, true] {
        let mut pngs = Vec::new();
        for on_cell in [false, true] {
            let p = tmp(&format!("on_cell_{heatmap}_{on_cell}.png"));
            let mut args = fill(
                "render --width 48 --height 32 --out {}",
                &[p.to_str().unwrap()],
            );
            if heatmap {
                args.push("--heatmap");
            }
            if on_cell {
                args.push("--on-cell");
            }
            assert_ok(&cellbih(&args));
            pngs.push(std::fs::read(&p).unwrap());
        }
        // The shaded image is the host's; the heat map shows the SPE
        // caster's own cost (it tests a leaf's triangles without the host
        // tracer's leaf boxes), so it only has the same size.
        if heatmap {
            let img = image::load_from_memory(&pngs[1]).unwrap();
            assert_eq!((img.width(), img.height()), (48, 32));
        } else {
            assert_eq!(pngs[0], pngs[1], "the shaded images differ");
        }
    }
    // In packets of 4 × 4: the same image (and the same heat map: each
    // ray's cost is its own walk's), the packets reported and the setting
    // named.
    for heatmap in [false, true] {
        let mut pngs = Vec::new();
        for packet in ["1x1", "4x4"] {
            let p = tmp(&format!("on_cell_packet_{heatmap}_{packet}.png"));
            let mut args = vec!["render", "--width", "48", "--height", "32"];
            args.extend([
                "--on-cell",
                "--packet",
                packet,
                "--out",
                p.to_str().unwrap(),
            ]);
            if heatmap {
                args.push("--heatmap");
            }
            let out = cellbih(&args);
            assert_ok(&out);
            let err = stderr(&out);
            assert!(err.contains(&format!("--packet {packet}")), "{err}");
            assert_eq!(err.contains(" packets, "), packet == "4x4", "{err}");
            pngs.push(std::fs::read(&p).unwrap());
        }
        assert_eq!(
            pngs[0], pngs[1],
            "heat map {heatmap}: packets changed the image"
        );
    }
    // The cast's timeline: every SPE on it; refused without --on-cell and
    // in the functional mode, before any work.
    let trace = tmp("on_cell_trace.json");
    let png = tmp("on_cell_traced.png");
    let (t, p) = (trace.to_str().unwrap(), png.to_str().unwrap());
    let args = [
        "render",
        "--width",
        "16",
        "--height",
        "12",
        "--out",
        p,
        "--on-cell",
        "--spes",
        "2",
        "--trace",
        t,
    ];
    assert_ok(&cellbih(&args));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    let names: std::collections::BTreeSet<String> = (doc["traceEvents"].as_array().unwrap().iter())
        .filter(|e| e["ph"] == "M")
        .filter_map(|e| e["args"]["name"].as_str().map(String::from))
        .collect();
    assert!(
        names.contains("SPE 0") && names.contains("SPE 1"),
        "{names:?}"
    );
    let _ = std::fs::remove_file(&png);
    assert_fails_with(
        &cellbih(&["render", "--out", p, "--trace", t]),
        "--trace applies to --on-cell only",
    );
    assert_fails_with(
        &cellbih(&fill(
            "render --out {} --on-cell --trace {} --mode functional",
            &[p, t],
        )),
        "keeps no timeline",
    );
    assert!(!png.exists(), "nothing rendered");
    for option in [
        ["--cache-kib", "8"],
        ["--tile-rays", "16"],
        ["--fetch-lines", "2"],
        ["--cache-ways", "2"],
        ["--rays-in-flight", "4"],
        ["--precision", "double"],
        ["--packet", "2x2"],
    ] {
        let hits = tmp("on_cell_refused.csv");
        let _ = std::fs::remove_file(&hits);
        let mut args = fill(
            "raycast --rays {} --out {}",
            &[rays_path.to_str().unwrap(), hits.to_str().unwrap()],
        );
        args.extend(option);
        assert_fails_with(
            &cellbih(&args),
            &format!("{} applies to --on-cell only", option[0]),
        );
        assert!(!hits.exists(), "{option:?}: nothing is written");
    }
}
