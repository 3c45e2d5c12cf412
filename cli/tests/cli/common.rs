//! What the command-line tests share: running the `cellbih` binary and the
//! experiments, reading what they print, and a temporary directory.
#![allow(dead_code)]

use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use cellbih::registry::BuilderKind;

pub use cellbih::cell::trace::check_nesting;
pub use cellbih::quality::agree::rays_for;

/// The repository's root (the README, docs/, scenes/, scripts/).
pub const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");

/// A command running `exe` from the repository's root, as a user runs the
/// README's commands there (cargo runs this test binary in `cli/`): a
/// relative `CELLBIH_DATA` (the README's `../shared/data`) means the same
/// to it as to them. A test may still give it a directory of its own.
pub fn command(exe: impl AsRef<std::ffi::OsStr>) -> Command {
    let mut c = Command::new(exe);
    c.current_dir(ROOT);
    c
}

/// The data directory of real meshes, as the commands run from the root
/// see it (`CELLBIH_DATA`, relative to the root), if one is set.
pub fn data_dir() -> Option<std::path::PathBuf> {
    cellbih::scene::data_dir(None).map(|d| std::path::Path::new(ROOT).join(d))
}

/// Runs the `cellbih` binary with `args`.
pub fn cellbih<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    command(env!("CARGO_BIN_EXE_cellbih"))
        .args(args)
        .output()
        .unwrap()
}

/// Fails with the command's stderr unless it succeeded.
pub fn assert_ok(out: &Output) {
    assert!(out.status.success(), "{}", stderr(out));
}

/// The builders that build on the host's threads (`--threads`).
pub fn host_threaded() -> Vec<BuilderKind> {
    let v: Vec<BuilderKind> = (BuilderKind::ALL.iter().copied())
        .filter(|b| b.host_threads())
        .collect();
    assert!(!v.is_empty(), "the registry has no parallel host builder");
    v
}

/// Runs experiment binary `exe` with `args`, `--format json` and `--out`
/// a fresh directory named `name`; returns its rows and the directory.
pub fn run_experiment(
    exe: &str,
    name: &str,
    args: &[&str],
) -> (Vec<serde_json::Value>, std::path::PathBuf) {
    let dir = tmp(name);
    let out = command(exe)
        .args(args)
        .args(["--format", "json", "--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert_ok(&out);
    // The standard output carries the file's document, settings included.
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        doc["settings"]["version"].is_string(),
        "{exe}: stdout has no settings"
    );
    // Every JSON file it wrote names its settings: the command line that
    // made it and the version.
    for f in std::fs::read_dir(&dir).unwrap() {
        let path = f.unwrap().path();
        if path.extension().is_some_and(|e| e == "json") {
            let doc: serde_json::Value =
                serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
            let settings = &doc["settings"];
            let command = settings["command"].as_str().unwrap_or_default();
            assert!(
                command.contains(args.first().copied().unwrap_or_default())
                    && settings["version"].is_string(),
                "{}: settings {settings}",
                path.display()
            );
        }
    }
    (doc["rows"].as_array().unwrap().clone(), dir)
}

/// A path in this test process's own temporary directory.
pub fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("cellbih-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// Runs `exe` with `args`, killing it after `limit`: a refusal must come
/// at once, so a run that takes longer is a failure (a hang or a huge
/// allocation), not a slow pass.
pub fn run_limited(exe: &str, args: &[&str], limit: Duration) -> Output {
    let mut child = command(exe)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            child.kill().unwrap();
            panic!("{exe} {args:?} still ran after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// What the command said on stderr, each error or note unwrapped (the
/// lines it was wrapped onto at 80 columns, indented by two spaces,
/// joined again).
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).replace("\n  ", " ")
}

pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Fails unless the command failed with `msg` in its stderr.
pub fn assert_fails_with(out: &Output, msg: &str) {
    let err = stderr(out);
    assert!(
        !out.status.success() && err.contains(msg),
        "expected a failure saying '{msg}', got {:?}: {err}",
        out.status
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// A command line's words: `line("build --scene car")` is
/// `["build", "--scene", "car"]` (no word holds a space).
pub fn line(text: &str) -> Vec<&str> {
    text.split_whitespace().collect()
}

/// Runs `cellbih` with the words of `text`, fails with its stderr unless
/// it succeeded, and reads its standard output as JSON.
pub fn json(text: &str) -> serde_json::Value {
    json_of(&line(text))
}

/// Runs `cellbih` with `args`, fails with its stderr unless it succeeded,
/// and reads its standard output as JSON.
pub fn json_of(args: &[&str]) -> serde_json::Value {
    let out = cellbih(args);
    assert_ok(&out);
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Fails unless the command's stderr says `text` (whether it succeeded or
/// not), showing what it said.
pub fn assert_says(out: &Output, text: &str) {
    let err = stderr(out);
    assert!(err.contains(text), "expected '{text}' on stderr: {err}");
}

/// A command line's words with each `{}` a word of its own, filled in
/// order from `fill` (a path may hold spaces: the text is split first):
/// `fill("raycast --rays {}", &[p])`.
pub fn fill<'a>(text: &'a str, fill: &[&'a str]) -> Vec<&'a str> {
    let mut rest = fill.iter();
    let words: Vec<&str> = (text.split_whitespace())
        .map(|w| match w {
            "{}" => rest.next().expect("a value for each {}"),
            w => w,
        })
        .collect();
    assert!(rest.next().is_none(), "more values than {{}} in '{text}'");
    words
}

/// A rays file of one ray that hits the default scene.
pub const ONE_RAY: &str = "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,1,8,0,0,-1,0,inf\n";

/// A file `name` in this test process's temporary directory holding
/// `text`; its path.
pub fn text_file(name: &str, text: &str) -> String {
    let path = tmp(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// A rays file of [`ONE_RAY`] named `name`; its path.
pub fn one_ray(name: &str) -> String {
    text_file(name, ONE_RAY)
}
