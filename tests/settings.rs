//! Every report names the settings that made it, and the commands that
//! build more than once (`update`, `frame`) build with every knob `build`
//! takes.

mod common;

use common::{assert_ok, cellbih, stderr, stdout, tmp};

fn json(args: &[&str]) -> serde_json::Value {
    let mut args = args.to_vec();
    args.extend(["--format", "json"]);
    let out = cellbih(&args);
    assert_ok(&out);
    serde_json::from_slice(&out.stdout).unwrap()
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
    let (ja, jb) = (json(&a), json(&b));
    assert_ne!(ja["settings"], jb["settings"]);
    assert_eq!(jb["settings"]["cell"]["model"], "legacy");
    assert!(
        ja["settings"]["version"]
            .as_str()
            .unwrap()
            .starts_with(env!("CARGO_PKG_VERSION"))
    );

    let private = json(&["build", "--builder", "spe_bfs_private", "--steal"]);
    let knobs = private["settings"]["knobs"].as_object().unwrap();
    let builder = cellbih::registry::BuilderKind::from_name("spe_bfs_private").unwrap();
    assert_eq!(knobs.len(), builder.knobs().len());
    assert_eq!(knobs["steal"], "on");
    assert_eq!(knobs["deal-per-spe"], "auto");
    // A host build names no Cell.
    let host = json(&["build"]);
    assert!(host["settings"]["cell"].is_null(), "{}", host["settings"]);
}

/// `raycast` and `render` say their settings on stderr, the cast's too.
#[test]
fn casts_name_their_settings() {
    let rays = tmp("settings.rays.csv");
    std::fs::write(&rays, "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,1,8,0,0,-1,0,inf\n").unwrap();
    let hits = tmp("settings.hits.csv");
    let out = cellbih(&[
        "raycast",
        "--rays",
        rays.to_str().unwrap(),
        "--out",
        hits.to_str().unwrap(),
        "--on-cell",
        "--cache-kib",
        "16",
    ]);
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
    let (ja, jb) = (json(&a), json(&b));
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
        let v = json(&args);
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
