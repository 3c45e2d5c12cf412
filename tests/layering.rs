//! The house's floors (DESIGN.md), held: three crates — the emulator
//! (`cell/`), the library (`src/`), the front end (`cli/`) — each
//! depending only on the floors below it; the library never prints,
//! parses arguments or exits; inside each crate the parts import downwards
//! only; and no two files of a crate import each other unless one is the
//! other's parent module (a module and its own children may share types
//! both ways; two siblings may not).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// Every `.rs` file under `dir`.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out
}

/// `text` without its comments (`//` to the end of a line) and without its
/// unit tests (from `#[cfg(test)]` on): the code the crate is made of.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or_default();
    let lines = text.lines().map(|l| match l.find("//") {
        // A `//` inside a string literal ("http://…") is rare in code and
        // harmless here: the rest of the line is only dropped.
        Some(i) => &l[..i],
        None => l,
    });
    lines.collect::<Vec<_>>().join("\n")
}

/// The names of a manifest's `[dependencies]` (and target-specific
/// dependencies), not its dev-dependencies.
fn dependencies(manifest: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut inside = false;
    for line in manifest.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            inside = line == "[dependencies]"
                || (line.starts_with("[target.") && line.ends_with(".dependencies]"));
        } else if inside && let Some((name, _)) = line.split_once('=') {
            out.push(name.trim().to_string());
        }
    }
    out
}

/// The front end's crates, which neither the emulator nor the library
/// may depend on.
const FRONT_END: [&str; 6] = [
    "clap",
    "indicatif",
    "plotters",
    "signal-hook",
    "tempfile",
    "libc",
];

#[test]
fn each_crate_depends_only_on_the_floors_below() {
    let read = |p: &str| std::fs::read_to_string(format!("{ROOT}/{p}")).unwrap();
    let cell = dependencies(&read("cell/Cargo.toml"));
    let library = dependencies(&read("Cargo.toml"));
    let cli = dependencies(&read("cli/Cargo.toml"));
    assert!(!cell.is_empty() && !library.is_empty() && !cli.is_empty());
    for dep in &cell {
        assert!(
            !dep.starts_with("cellbih") && !FRONT_END.contains(&dep.as_str()),
            "the emulator depends on {dep}"
        );
    }
    assert!(library.iter().any(|d| d == "cellbih-cell"));
    for dep in &library {
        assert!(
            dep != "cellbih-cli" && !FRONT_END.contains(&dep.as_str()),
            "the library depends on {dep}, a front-end crate"
        );
    }
    assert!(cli.iter().any(|d| d == "cellbih") && cli.iter().any(|d| d == "clap"));
    // No path into another crate's sources (`#[path]` modules).
    for dir in [
        "src",
        "cell/src",
        "cli/src",
        "cli/experiments",
        "benches",
        "tests",
    ] {
        for path in sources(&Path::new(ROOT).join(dir)) {
            let text = code(&std::fs::read_to_string(&path).unwrap());
            assert!(
                !text.contains("#[path"),
                "{} has a #[path] module",
                path.display()
            );
        }
    }
}

#[test]
fn the_library_does_not_print_parse_arguments_or_exit() {
    let mut files = 0;
    for dir in ["src", "cell/src"] {
        for path in sources(&Path::new(ROOT).join(dir)) {
            let text = code(&std::fs::read_to_string(&path).unwrap());
            for said in [
                "println!",
                "eprintln!",
                "print!(",
                "eprint!(",
                "process::exit",
                "std::env::args",
                "clap::",
            ] {
                assert!(
                    !text.contains(said),
                    "{} uses {said}: the front end prints, parses and exits",
                    path.display()
                );
            }
            files += 1;
        }
    }
    assert!(files > 100, "{files} files read");
}

/// Each part of a crate and the parts it must not import (`crate::NAME`).
fn rules(krate: &str) -> Vec<(&'static str, Vec<&'static str>)> {
    match krate {
        "src" => vec![
            (
                "spe",
                vec!["strategy", "host", "cast", "registry", "update", "frame"],
            ),
            (
                "cast",
                vec!["strategy", "host", "registry", "update", "frame"],
            ),
            (
                "strategy",
                vec!["host", "cast", "registry", "update", "frame"],
            ),
            (
                "host",
                vec!["strategy", "spe", "cast", "registry", "update", "frame"],
            ),
            (
                "kernels",
                vec!["strategy", "host", "cast", "registry", "update", "frame"],
            ),
            (
                "bih",
                vec![
                    "strategy", "host", "cast", "registry", "update", "frame", "spe",
                ],
            ),
            (
                "scene",
                vec!["bih", "strategy", "host", "cast", "registry", "spe"],
            ),
        ],
        "cli/src" => vec![
            ("output", vec!["args", "command", "report"]),
            ("report", vec!["command"]),
            ("args", vec!["command", "report"]),
        ],
        _ => vec![],
    }
}

#[test]
fn each_part_imports_only_the_parts_below_it() {
    let mut files = 0;
    for krate in ["src", "cli/src"] {
        let root = Path::new(ROOT).join(krate);
        for (part, below_not) in rules(krate) {
            let dir = root.join(part);
            let paths = match dir.is_dir() {
                true => sources(&dir),
                false => vec![root.join(format!("{part}.rs"))],
            };
            for path in paths {
                let text = code(&std::fs::read_to_string(&path).unwrap());
                for m in &below_not {
                    assert!(
                        !text.contains(&format!("crate::{m}::"))
                            && !text.contains(&format!("crate::{m};"))
                            && !text.contains(&format!("crate::{m}}}")),
                        "{} ({krate}/{part}) imports crate::{m}",
                        path.display()
                    );
                }
                files += 1;
            }
        }
    }
    assert!(files > 60, "{files} files read");
}

/// A crate's modules by path (`["strategy", "machinery", "arena"]`), each
/// with the modules its code names.
fn imports(root: &Path) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let mut modules: BTreeMap<Vec<String>, String> = BTreeMap::new();
    for path in sources(root) {
        let rel = path.strip_prefix(root).unwrap().with_extension("");
        let mut segs: Vec<String> = (rel.iter())
            .map(|s| s.to_string_lossy().into_owned())
            .collect();
        if matches!(
            segs.last().map(String::as_str),
            Some("mod" | "lib" | "main")
        ) {
            segs.pop();
        }
        modules.insert(segs, code(&std::fs::read_to_string(&path).unwrap()));
    }
    // The module a path names: its longest prefix that is a module.
    let resolve = |path: &[String]| -> Option<Vec<String>> {
        (0..=path.len())
            .rev()
            .map(|n| path[..n].to_vec())
            .find(|p| modules.contains_key(p))
    };
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = BTreeMap::new();
    for (module, text) in &modules {
        let mut named = BTreeSet::new();
        let mut add = |path: Vec<String>| {
            if let Some(m) = resolve(&path)
                && &m != module
            {
                named.insert(m);
            }
        };
        // Each path of `::`-joined names, and the names a `{…}` after it
        // lists (one level).
        let chars: Vec<char> = text.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            if !ident(chars[i]) || (i > 0 && (ident(chars[i - 1]) || chars[i - 1] == ':')) {
                i += 1;
                continue;
            }
            let mut segs = Vec::new();
            let mut j = i;
            loop {
                let start = j;
                while j < chars.len() && ident(chars[j]) {
                    j += 1;
                }
                segs.push(chars[start..j].iter().collect::<String>());
                if chars.get(j) == Some(&':') && chars.get(j + 1) == Some(&':') {
                    j += 2;
                    if j < chars.len() && ident(chars[j]) {
                        continue;
                    }
                }
                break;
            }
            let mut lists: Vec<Vec<String>> = vec![vec![]];
            if chars.get(j) == Some(&'{') {
                let end = (j..chars.len()).find(|&k| chars[k] == '}').unwrap_or(j);
                let inner: String = chars[j + 1..end].iter().collect();
                lists = (inner.split(','))
                    .map(|item| {
                        let item = item.split(" as ").next().unwrap_or("").trim();
                        item.split("::").map(str::to_string).collect()
                    })
                    .collect();
            }
            i = j.max(i + 1);
            let base: Option<Vec<String>> = match segs[0].as_str() {
                "crate" => Some(segs[1..].to_vec()),
                "super" => {
                    let ups = segs.iter().take_while(|s| *s == "super").count();
                    let mut b = module[..module.len().saturating_sub(ups)].to_vec();
                    b.extend(segs[ups..].iter().cloned());
                    Some(b)
                }
                "self" => {
                    let mut b = module.clone();
                    b.extend(segs[1..].iter().cloned());
                    Some(b)
                }
                // A child module named by its own name (`use child::X`,
                // `child::f()`).
                first if segs.len() > 1 || !lists[0].is_empty() => {
                    let mut b = module.clone();
                    b.push(first.to_string());
                    modules.contains_key(&b).then(|| {
                        b.extend(segs[1..].iter().cloned());
                        b
                    })
                }
                _ => None,
            };
            if let Some(base) = base {
                for list in &lists {
                    let mut p = base.clone();
                    p.extend(
                        list.iter()
                            .filter(|s| !s.is_empty() && *s != "self")
                            .cloned(),
                    );
                    add(p);
                }
            }
        }
        out.insert(module.clone(), named);
    }
    out
}

#[test]
fn no_two_sibling_files_import_each_other() {
    for krate in ["src", "cell/src", "cli/src"] {
        let graph = imports(&Path::new(ROOT).join(krate));
        assert!(graph.len() > 5, "{krate}: {} modules", graph.len());
        let mut loops = Vec::new();
        for (a, names) in &graph {
            for b in names {
                let related = a.starts_with(b) || b.starts_with(a);
                if a < b && !related && graph.get(b).is_some_and(|n| n.contains(a)) {
                    loops.push(format!("{} <-> {}", a.join("/"), b.join("/")));
                }
            }
        }
        assert!(loops.is_empty(), "{krate}: import loops: {loops:?}");
    }
}

/// The loop finder finds a loop where there is one (two siblings naming
/// each other) and none between a module and its child.
#[test]
fn the_loop_finder_sees_a_loop() {
    let dir = std::env::temp_dir().join(format!("cellbih-layering-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("a")).unwrap();
    let write = |p: &str, t: &str| std::fs::write(dir.join(p), t).unwrap();
    write("lib.rs", "mod a;\nmod b;\n");
    write("a/mod.rs", "mod c;\npub use c::C;\npub struct A;\n");
    write("a/c.rs", "use super::A;\npub struct C;\n");
    write("b.rs", "use crate::a::{A, c::C};\n");
    let g = imports(&dir);
    let m = |s: &str| s.split('/').map(str::to_string).collect::<Vec<_>>();
    assert!(g[&m("b")].contains(&m("a")) && g[&m("b")].contains(&m("a/c")));
    assert!(g[&m("a")].contains(&m("a/c")) && g[&m("a/c")].contains(&m("a")));
    assert!(!g[&m("a")].contains(&m("b")));
    write(
        "a/mod.rs",
        "mod c;\npub use c::C;\npub struct A;\nfn f() { crate::b::g(); }\n",
    );
    let g = imports(&dir);
    assert!(g[&m("a")].contains(&m("b")) && g[&m("b")].contains(&m("a")));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The build script, whose `watched` list is tested below.
#[allow(dead_code)]
#[path = "../build.rs"]
mod build_script;

/// The build script watches what names the commit (HEAD and the branch it
/// points at) and the sources, never the index: `git status` (which the
/// suite runs) rewrites the index, and would make the next cargo command
/// build `cellbih` again.
#[test]
fn the_build_script_watches_the_commit_not_the_index() {
    let dir = std::env::temp_dir().join(format!("cellbih-git-{}", std::process::id()));
    let git = dir.join(".git");
    std::fs::create_dir_all(git.join("refs/heads")).unwrap();
    std::fs::write(git.join("HEAD"), "ref: refs/heads/topic\n").unwrap();
    std::fs::write(git.join("refs/heads/topic"), "0123\n").unwrap();
    std::fs::write(git.join("index"), "x").unwrap();
    let has = |w: &[String], p: &str| w.iter().any(|x| x == &git.join(p).display().to_string());
    let w = build_script::watched(&git);
    assert!(has(&w, "HEAD") && has(&w, "refs/heads/topic"), "{w:?}");
    assert!(!w.iter().any(|x| x.ends_with("index")), "{w:?}");
    // A detached HEAD names no branch; nothing absent is named.
    std::fs::write(git.join("HEAD"), "0123\n").unwrap();
    let w = build_script::watched(&git);
    assert!(
        has(&w, "HEAD") && !w.iter().any(|x| x.contains("refs/")),
        "{w:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// No strategy imports another: what two strategies share lives in the
/// machinery (`src/strategy/machinery/`), so a strategy is its own file
/// (or folder) and a composition of the machinery's parts. A strategy is
/// a module of `src/strategy/` that defines the registry's `STRATEGY`.
#[test]
fn no_strategy_imports_another() {
    let graph = imports(&Path::new(ROOT).join("src"));
    let strategies: BTreeSet<String> = (graph.keys())
        .filter(|m| m.len() == 2 && m[0] == "strategy")
        .filter(|m| {
            let dir = Path::new(ROOT).join("src/strategy");
            let text = std::fs::read_to_string(dir.join(format!("{}.rs", m[1])))
                .or_else(|_| std::fs::read_to_string(dir.join(&m[1]).join("mod.rs")));
            text.is_ok_and(|t| t.contains("pub const STRATEGY"))
        })
        .map(|m| m[1].clone())
        .collect();
    assert!(strategies.len() >= 5, "strategies found: {strategies:?}");
    let of = |m: &[String]| {
        (m.len() >= 2 && m[0] == "strategy" && strategies.contains(&m[1])).then(|| m[1].clone())
    };
    let mut crossings = Vec::new();
    for (module, names) in &graph {
        let Some(own) = of(module) else { continue };
        for name in names {
            if of(name).is_some_and(|o| o != own) {
                crossings.push(format!("{} names {}", module.join("/"), name.join("/")));
            }
        }
    }
    assert!(
        crossings.is_empty(),
        "strategies importing others: {crossings:?}"
    );
}
