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

/// `update` and `frame` build with the strategy knobs given: a knob that
/// changes `build`'s simulated time changes theirs, and their settings
/// name it.
#[test]
fn update_and_frame_honour_every_knob() {
    let rebuild = |knob: &[&str]| -> (f64, serde_json::Value) {
        let mut args = vec!["update", "--strategy", "rebuild", "--builder", "spe_morton"];
        args.extend(["--animation", "rtperf", "--frames", "1"]);
        args.extend(knob);
        let v = json(&args);
        (
            v["frames"][0]["simulated_ms"].as_f64().unwrap(),
            v["settings"].clone(),
        )
    };
    let (plain, _) = rebuild(&[]);
    let (wide, settings) = rebuild(&["--key-bits", "64"]);
    assert!(
        wide > plain * 1.5,
        "--key-bits 64: {wide} ms, default {plain} ms"
    );
    assert_eq!(settings["knobs"]["key-bits"], "64");

    let frame = |knob: &[&str]| -> (f64, serde_json::Value) {
        let mut args = vec!["frame", "--builder", "spe_morton", "--policy", "rebuild"];
        args.extend([
            "--animation",
            "rtperf",
            "--frames",
            "1",
            "--width",
            "8",
            "--height",
            "8",
        ]);
        args.extend(knob);
        let v = json(&args);
        (
            v["frames"][0]["update_ms"].as_f64().unwrap(),
            v["settings"].clone(),
        )
    };
    let (plain, _) = frame(&[]);
    let (wide, settings) = frame(&["--key-bits", "64"]);
    assert!(
        wide > plain * 1.5,
        "--key-bits 64: {wide} ms, default {plain} ms"
    );
    assert_eq!(settings["knobs"]["key-bits"], "64");
    assert_eq!(settings["cast"]["cache_kib"], 32);
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
