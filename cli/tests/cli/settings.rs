//! Every report names the settings that made it, and the commands that
//! build more than once (`update`, `frame`) build with every knob `build`
//! takes.

use crate::common::{ONE_RAY, assert_ok, cellbih, fill, one_ray, stderr, stdout, text_file, tmp};

/// `cellbih` with `args` and `--format json`: its JSON.
fn as_json(args: &[&str]) -> serde_json::Value {
    let mut args = args.to_vec();
    args.extend(["--format", "json"]);
    crate::common::json_of(&args)
}

/// Two builds that differ only in the machine model or the mailbox path
/// print two different settings lines and two different `settings`
/// objects; the JSON holds every knob with its value, defaults included,
/// and the version.
#[test]
fn two_settings_two_headers() {
    let a = ["build", "--builder", "spe_dfs"];
    let b = [&a[..], &["--model", "legacy", "--mailboxes", "ps3-kernel"]].concat();
    let settings_line = |args: &[&str]| -> String {
        let text = stdout(&cellbih(args));
        let from = text.find("settings    ").expect(&text);
        let rest = &text[from..];
        let end = rest.find("\nsimulated").unwrap_or(rest.len());
        rest[..end].split_whitespace().collect::<Vec<_>>().join(" ")
    };
    let (la, lb) = (settings_line(&a), settings_line(&b));
    assert_ne!(la, lb);
    assert!(la.contains("--model measured --mailboxes raw"), "{la}");
    assert!(lb.contains("--model legacy --mailboxes ps3-kernel"), "{lb}");
    let (ja, jb) = (as_json(&a), as_json(&b));
    assert_ne!(ja["settings"], jb["settings"]);
    assert_eq!(jb["settings"]["cell"]["model"], "legacy");
    assert!(
        ja["settings"]["version"]
            .as_str()
            .unwrap()
            .starts_with(env!("CARGO_PKG_VERSION"))
    );

    let private = as_json(&["build", "--builder", "spe_bfs_private", "--steal"]);
    let knobs = private["settings"]["knobs"].as_object().unwrap();
    let builder = cellbih::registry::BuilderKind::from_name("spe_bfs_private").unwrap();
    assert_eq!(knobs.len(), builder.knobs().len());
    assert_eq!(knobs["steal"], "on");
    assert_eq!(knobs["deal-per-spe"], "auto");
    // A host build names no Cell.
    let host = as_json(&["build"]);
    assert!(host["settings"]["cell"].is_null(), "{}", host["settings"]);
}

/// `raycast` and `render` say their settings on stderr, the cast's too.
#[test]
fn casts_name_their_settings() {
    let rays = one_ray("settings.rays.csv");
    let hits = tmp("settings.hits.csv");
    let out = cellbih(&fill(
        "raycast --rays {} --out {} --on-cell --cache-kib 16",
        &[&rays, hits.to_str().unwrap()],
    ));
    assert_ok(&out);
    let err = stderr(&out);
    assert!(
        err.contains("settings: builder host;") && err.contains("--cache-kib 16"),
        "{err}"
    );
}

/// `compare` names what its builders share: two runs on different Cells
/// print two settings lines and two `settings` objects.
#[test]
fn compare_names_its_settings() {
    let a = ["compare", "--scene", "rtperf:3000", "--max-depth", "4"];
    let b = [&a[..], &["--spes", "3"]].concat();
    let line = |args: &[&str]| -> String {
        let text = stdout(&cellbih(args));
        let from = text.find("settings: ").expect(&text);
        text[from..]
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ")
    };
    let (la, lb) = (line(&a), line(&b));
    assert!(
        la.contains("--spes 6") && lb.contains("--spes 3"),
        "{la}\n{lb}"
    );
    assert!(la.contains("tree --max-depth 4"), "{la}");
    let (ja, jb) = (as_json(&a), as_json(&b));
    assert_eq!(ja["settings"]["cell"]["spes"], 6);
    assert_eq!(jb["settings"]["cell"]["spes"], 3);
    assert_eq!(ja["settings"]["tree"]["max_depth"], 4);
}

/// Every family of settings `build` takes — a strategy knob, the tree, the
/// emulated Cell — changes the simulated time of `update`'s and `frame`'s
/// builds as it changes `build`'s, and their settings name it.
#[test]
fn update_and_frame_honour_every_family_of_settings() {
    let run = |cmd: &str, extra: &[&str]| -> (f64, serde_json::Value) {
        let mut args = vec![cmd, "--builder", "spe_morton", "--scene", "rtperf:4000"];
        match cmd {
            "update" => args.extend(["--strategy", "rebuild"]),
            "frame" => args.extend(["--policy", "rebuild", "--width", "8", "--height", "8"]),
            _ => {}
        }
        if cmd != "build" {
            args.extend(["--animation", "rtperf", "--frames", "1"]);
        }
        args.extend(extra);
        let v = as_json(&args);
        let ms = match cmd {
            "update" => v["frames"][0]["simulated_ms"].as_f64(),
            "frame" => v["frames"][0]["update_ms"].as_f64(),
            _ => v["simulated_ms"].as_f64(),
        };
        (ms.unwrap(), v["settings"].clone())
    };
    let families: [(&[&str], &str, serde_json::Value); 3] = [
        (&["--key-bits", "64"], "/knobs/key-bits", "64".into()),
        (&["--leaf-size", "2"], "/tree/leaf_size", 2.into()),
        (&["--model", "legacy"], "/cell/model", "legacy".into()),
    ];
    let (plain_build, _) = run("build", &[]);
    for cmd in ["update", "frame"] {
        let (plain, _) = run(cmd, &[]);
        for (extra, pointer, value) in &families {
            let (ms, settings) = run(cmd, extra);
            let (build, _) = run("build", extra);
            assert_ne!(build, plain_build, "{extra:?} changes nothing in build");
            assert_ne!(ms, plain, "{cmd} ignored {extra:?}");
            assert_eq!(settings.pointer(pointer), Some(value), "{cmd}: {settings}");
            if cmd == "frame" {
                assert_eq!(settings["cast"]["cache_kib"], 32, "{settings}");
            }
        }
    }
}

/// A library caller's request is carried whole: for every emulated builder
/// and every knob setting its table sweeps, an update's complete rebuild
/// costs what the same request's build of the moved scene costs.
#[test]
fn an_update_rebuilds_with_the_whole_request() {
    use cellbih::registry::{Build, BuilderKind};
    use cellbih::update::{Animation, Method, Updater};
    let s = cellbih::scene::load("rtperf:3000:4", None).unwrap();
    let anim = Animation::named("rtperf", &s, 1, 2).unwrap();
    let mut checked = 0;
    for &b in BuilderKind::ALL.iter().filter(|b| b.emulated()) {
        for knobs in b.sweeps() {
            let cell = cellbih::cell::CellConfig::ps3().with_spes(3);
            let request = Build::new(b).on(&cell).with_knobs(&knobs);
            let mut u = Updater::new(s.clone(), request.clone(), Method::Rebuild).unwrap();
            let r = u.step(&anim.frames[0]).unwrap();
            let fresh = request.run(&u.scene).unwrap().simulated.unwrap();
            assert_eq!(
                r.simulated_ms,
                Some(fresh.run.ms),
                "{b} {}",
                knobs.spelled()
            );
            checked += 1;
        }
    }
    assert!(checked > BuilderKind::ALL.len(), "{checked} requests");
}

/// The options of `cellbih CMD`, as its help lists them.
fn options_of(cmd: &str) -> Vec<String> {
    let help = stdout(&cellbih(&[cmd, "--help"]));
    let mut seen = Vec::new();
    for line in help.lines() {
        let t = line.trim_start();
        let Some(rest) = t.strip_prefix("--").or_else(|| t.strip_prefix("-h, --")) else {
            continue;
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
            .collect();
        let opt = format!("--{name}");
        if !seen.contains(&opt) {
            seen.push(opt);
        }
    }
    seen
}

/// A builder the registry says takes `pred`.
fn builder_where(pred: impl Fn(cellbih::registry::BuilderKind) -> bool) -> &'static str {
    (cellbih::registry::BuilderKind::ALL.iter())
        .find(|b| pred(**b))
        .expect("a builder of the registry")
        .name()
}

/// For `option` of a simulating command: what the base run needs beside
/// it (a builder that takes it, a mode it needs) and the option with a
/// value other than the default. `None`: not an input of a figure (named
/// below with why).
fn variant(cmd: &str, option: &str) -> Option<(Vec<String>, Vec<String>)> {
    use cellbih::registry::BuilderKind;
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    let baseline = BuilderKind::SPE_BFS.name();
    let emulated = s(&["--builder", baseline]);
    let knob = (BuilderKind::ALL.iter())
        .flat_map(|b| b.knobs().iter().map(move |k| (*b, *k)))
        .find(|(_, k)| format!("--{}", k.name) == option);
    if let Some((b, k)) = knob {
        let value: Vec<String> = match k.is_flag() {
            true => vec![],
            false => vec![
                (k.sweep.iter())
                    .find(|v| **v != k.default_text() && **v != "auto")
                    .expect("a sweep value besides the default")
                    .to_string(),
            ],
        };
        return Some((
            s(&["--builder", b.name()]),
            [vec![option.to_string()], value].concat(),
        ));
    }
    // Emulated where one takes it: `frame` builds on the Cell only.
    let sah = builder_where(|b| b.emulated() && b.quality().binned_sah);
    let cut = builder_where(|b| b.emulated() && b.quality().empty_cut);
    let threads = builder_where(|b| b.host_threads());
    let other = builder_where(|b| b.emulated() && b.name() != baseline);
    // raycast and render cast on the Cell when asked; frame always does.
    let on_cell = match cmd {
        "frame" => vec![],
        _ => s(&["--on-cell"]),
    };
    Some(match option {
        // The report names the scene itself; outputs and formats change
        // no figure.
        "--scene" | "--data" | "--out" | "--trace" | "--format" | "--help" => return None,
        "--builder" => (emulated, s(&["--builder", other])),
        "--leaf-size" => (emulated, s(&["--leaf-size", "4"])),
        "--max-depth" => (emulated, s(&["--max-depth", "20"])),
        "--split" => (s(&["--builder", sah]), s(&["--split", "sah"])),
        "--sah-bins" => (
            s(&["--builder", sah, "--split", "sah"]),
            s(&["--sah-bins", "8"]),
        ),
        "--sah-above" => (
            s(&["--builder", sah, "--split", "sah"]),
            s(&["--sah-above", "64"]),
        ),
        "--empty-cut" => (s(&["--builder", cut]), s(&["--empty-cut", "30"])),
        "--spes" => (emulated, s(&["--spes", "2"])),
        "--memory-mib" => (emulated, s(&["--memory-mib", "200"])),
        "--mode" => (emulated, s(&["--mode", "timed"])),
        "--model" => (emulated, s(&["--model", "legacy"])),
        "--mailboxes" => (emulated, s(&["--mailboxes", "ps3-kernel"])),
        "--code" => (emulated, s(&["--code", "tuned"])),
        "--rate" => (emulated, s(&["--rate", "spe_job=150"])),
        "--rates" => (
            emulated,
            s(&[
                "--rates",
                &text_file("two.rates", "dma_latency_cycles = 300 # a comment\n"),
            ]),
        ),
        // A frame builds on the Cell, where --threads is refused.
        "--threads" if cmd == "frame" => return None,
        "--threads" => (s(&["--builder", threads]), s(&["--threads", "3"])),
        "--camera" => (emulated, s(&["--camera", "framing"])),
        "--rays" => (vec![], s(&["--rays", &rays_file("other.rays.csv")])),
        "--on-cell" => (vec![], s(&["--on-cell"])),
        "--cache-kib" => (on_cell.clone(), s(&["--cache-kib", "16"])),
        "--cache-ways" => (on_cell.clone(), s(&["--cache-ways", "2"])),
        "--fetch-lines" => (on_cell.clone(), s(&["--fetch-lines", "2"])),
        "--tile-rays" => (on_cell.clone(), s(&["--tile-rays", "32"])),
        "--precision" => (on_cell.clone(), s(&["--precision", "double"])),
        "--rays-in-flight" => (on_cell.clone(), s(&["--rays-in-flight", "2"])),
        "--packet" => (on_cell.clone(), s(&["--packet", "2x2"])),
        "--heatmap" => (vec![], s(&["--heatmap"])),
        "--width" => (vec![], s(&["--width", "24"])),
        "--height" => (vec![], s(&["--height", "20"])),
        "--animation" => (vec![], s(&["--animation", "part"])),
        "--seed" => (vec![], s(&["--seed", "7"])),
        "--frames" => (vec![], s(&["--frames", "3"])),
        "--strategy" => (vec![], s(&["--strategy", "deep"])),
        "--deep-stop-below" => (s(&["--strategy", "deep"]), s(&["--deep-stop-below", "96"])),
        "--policy" => (vec![], s(&["--policy", "deep"])),
        "--oracle" => (vec![], s(&["--oracle"])),
        "--build-spes" => (vec![], s(&["--build-spes", "1"])),
        "--find-moved" => (emulated, s(&["--find-moved", "spe"])),
        _ => panic!(
            "{cmd} {option}: no variant in this test; add one (or say why it changes no figure)"
        ),
    })
}

fn rays_file(name: &str) -> String {
    match name {
        "other.rays.csv" => text_file(name, &format!("{ONE_RAY}0,1,8,0,0,-1,0,4\n")),
        _ => one_ray(name),
    }
}

/// The settings a run reports: the JSON `settings` where the command has
/// `--format json`, else its `settings:` line.
fn reported(cmd: &str, args: &[String]) -> String {
    let out = cellbih(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_ok(&out);
    if matches!(cmd, "raycast" | "render") {
        // The settings paragraph (wrapped at 80 columns), up to the cast's.
        let err = stderr(&out);
        let from = err.find("settings: ").expect(&err);
        let rest = &err[from..];
        let end = rest.find("on the Cell: ").unwrap_or(rest.len());
        return rest[..end].split_whitespace().collect::<Vec<_>>().join(" ");
    }
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["settings"].to_string()
}

/// Every option of every simulating command that changes a figure changes
/// the settings its report prints: two runs that differ in any one of them
/// are never reported under identical settings (the options are read from
/// each command's help, the builders' knobs from the registry, so a new
/// option without a place in the settings fails here).
#[test]
fn every_option_that_changes_a_figure_changes_the_settings() {
    let rays = rays_file("base.rays.csv");
    let png = tmp("settings.png").to_str().unwrap().to_string();
    let hits = tmp("settings.hits.csv").to_str().unwrap().to_string();
    let commands: Vec<(&str, Vec<&str>)> = vec![
        ("build", vec!["--format", "json"]),
        ("compare", vec!["--format", "json"]),
        ("raycast", vec!["--rays", &rays, "--out", &hits]),
        (
            "render",
            vec!["--out", &png, "--width", "16", "--height", "12"],
        ),
        (
            "update",
            vec!["--animation", "rtperf", "--frames", "2", "--format", "json"],
        ),
        (
            "frame",
            vec![
                "--animation",
                "rtperf",
                "--frames",
                "2",
                "--width",
                "16",
                "--height",
                "12",
                "--format",
                "json",
            ],
        ),
    ];
    let mut tried = 0;
    for (cmd, base) in &commands {
        let scene: &[&str] = match *cmd {
            "update" | "frame" => &["--scene", "rtperf:2000"],
            _ => &[],
        };
        for option in options_of(cmd) {
            let Some((needs, varied)) = variant(cmd, &option) else {
                continue;
            };
            // compare runs every builder: only its shared options apply.
            let needs: Vec<String> = match *cmd {
                "compare" => needs
                    .into_iter()
                    .skip_while(|a| a == "--builder")
                    .skip(1)
                    .collect(),
                _ => needs,
            };
            let mut args: Vec<String> = std::iter::once(cmd.to_string())
                .chain(base.iter().map(|a| a.to_string()))
                .chain(scene.iter().map(|a| a.to_string()))
                .collect();
            args.extend(needs);
            // The varied run: the option replaces one of the same name.
            let mut other = args.clone();
            if let Some(i) = other.iter().position(|a| *a == varied[0]) {
                other.drain(i..i + varied.len());
            }
            other.extend(varied.iter().cloned());
            let a = reported(cmd, &args);
            let b = reported(cmd, &other);
            assert_ne!(
                a, b,
                "{cmd} {option}: {varied:?} changed nothing in the settings"
            );
            tried += 1;
        }
    }
    assert!(tried > 100, "only {tried} options tried");
}
