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
            // `git status` would otherwise refresh the index as it reads.
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
    for path in watched(std::path::Path::new(".git")) {
        println!("cargo:rerun-if-changed={path}");
    }
}

/// What names the commit — `HEAD` and the ref it points at (loose, or in
/// `packed-refs`) — and the sources: a new commit or checkout moves the
/// first, an edit to a source makes the build dirty (or clean again). Not
/// the index: `git status` and `git add` rewrite it without changing what
/// is built, and every cargo command after them would build again. Only
/// paths that exist are named: one that does not counts as changed on
/// every build.
pub fn watched(git: &std::path::Path) -> Vec<String> {
    let head = git.join("HEAD");
    let branch = std::fs::read_to_string(&head)
        .ok()
        .and_then(|h| (h.trim().strip_prefix("ref: ")).map(|r| git.join(r).display().to_string()));
    [
        head.display().to_string(),
        git.join("packed-refs").display().to_string(),
    ]
    .into_iter()
    .chain(branch)
    .chain(SOURCES.iter().map(|s| s.to_string()))
    .filter(|p| std::path::Path::new(p).exists())
    .collect()
}
