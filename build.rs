//! Names the commit cellbih is built from, when it is built from a git
//! checkout, so that every report can say what made it
//! (`registry::settings::version`); `-dirty` after it when the files the
//! build reads differ from that commit.

/// What the build reads: a change here changes the program.
const SOURCES: [&str; 10] = [
    "src",
    "cell",
    "cli/src",
    "cli/experiments",
    "cli/Cargo.toml",
    "scenes",
    "scripts/meshes.tsv",
    "Cargo.toml",
    "Cargo.lock",
    "build.rs",
];

fn main() {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            // `git status` would otherwise refresh the index, which this
            // script watches: every build would then run it again.
            .env("GIT_OPTIONAL_LOCKS", "0")
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let mut commit = git(&["rev-parse", "--short=10", "HEAD"]).unwrap_or_default();
    let status = [
        &["status", "--porcelain", "--untracked-files=no", "--"][..],
        &SOURCES,
    ]
    .concat();
    if !commit.is_empty() && git(&status).is_some_and(|s| !s.is_empty()) {
        commit.push_str("-dirty");
    }
    println!("cargo:rustc-env=CELLBIH_COMMIT={commit}");
    // A new commit moves HEAD or the branch it names; an edit to a source
    // makes the build dirty (or clean again).
    for path in [
        ".git/HEAD",
        ".git/refs/heads",
        ".git/packed-refs",
        ".git/index",
    ]
    .into_iter()
    .chain(SOURCES)
    // A path that does not exist counts as changed on every build, and
    // would rebuild everything each time: only those there are named.
    .filter(|p| std::path::Path::new(p).exists())
    {
        println!("cargo:rerun-if-changed={path}");
    }
}
