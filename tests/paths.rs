//! Words that cannot drift: every path and link the README, docs/ and the
//! sources' `//!` comments name exists — a file or folder of the
//! repository, a page, and a heading of that page where a link names one.

use std::path::{Path, PathBuf};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The folders whose paths the words name.
const TOP: [&str; 9] = [
    "src/",
    "cell/",
    "cli/",
    "tests/",
    "benches/",
    "docs/",
    "xtask/",
    "examples/",
    ".ci/",
];

/// Files below `dir` (recursively) whose names end in `ext`, outside
/// `target/` and hidden folders.
fn files(dir: &Path, ext: &str, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if p.is_dir() && name != "target" && !name.starts_with('.') {
            files(&p, ext, out);
        } else if name.ends_with(ext) {
            out.push(p);
        }
    }
}

/// The pages: the README and docs/*.md.
fn pages() -> Vec<PathBuf> {
    let root = Path::new(ROOT);
    let mut out = vec![root.join("README.md")];
    files(&root.join("docs"), ".md", &mut out);
    out
}

/// The paths `text` names: words that start with one of [`TOP`], cut at
/// the first character a path does not hold (`cellmark:docs/x.md` names
/// another repository's file).
fn named_paths(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (i, _) in text.char_indices() {
        // Inside a word, or another repository's (`owner/name:path`).
        let before = text[..i].chars().next_back();
        if before.is_some_and(|c| c.is_alphanumeric() || "_./-:".contains(c)) {
            continue;
        }
        let Some(top) = TOP.iter().find(|t| text[i..].starts_with(*t)) else {
            continue;
        };
        let rest = &text[i + top.len()..];
        let len = rest
            .find(|c: char| !(c.is_alphanumeric() || "_./-".contains(c)))
            .unwrap_or(rest.len());
        let path = format!("{top}{}", &rest[..len]);
        // A pattern or a placeholder is not a path.
        let next = rest[len..].chars().next();
        if next.is_some_and(|c| "{*<…".contains(c)) {
            continue;
        }
        out.push(path.trim_end_matches(['.', '-']).to_string());
    }
    out
}

/// The Markdown links of `text`: `(target)` after `]`, not a URL.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("](") {
        let tail = &rest[at + 2..];
        let end = tail.find(')').unwrap_or(tail.len());
        let target = &tail[..end];
        if !target.contains("://") && !target.starts_with("mailto:") && !target.is_empty() {
            out.push(target.to_string());
        }
        rest = &tail[end..];
    }
    out
}

/// GitHub's anchor of a heading: lower case, punctuation dropped, spaces
/// to hyphens.
fn anchor(heading: &str) -> String {
    (heading
        .trim_start_matches('#')
        .trim()
        .to_lowercase()
        .chars())
    .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
    .map(|c| if c == ' ' { '-' } else { c })
    .collect()
}

/// The anchors of a page's headings, and of its `<a id="…">` tags.
fn anchors(text: &str) -> Vec<String> {
    let mut in_code = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.starts_with("```") {
            in_code = !in_code;
        } else if !in_code && line.starts_with('#') {
            out.push(anchor(line));
        } else if !in_code {
            for tag in line.split("<a id=\"").skip(1) {
                out.extend(tag.split('"').next().map(String::from));
            }
        }
    }
    out
}

/// What a page or source names that is not there.
fn missing_in(file: &Path, text: &str, root: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let shown = file
        .strip_prefix(root)
        .unwrap_or(file)
        .display()
        .to_string();
    for p in named_paths(text) {
        if !root.join(&p).exists() {
            out.push(format!("{shown}: names {p}, which is not there"));
        }
    }
    if file.extension().is_some_and(|e| e == "md") {
        let dir = file.parent().expect("a page is in a folder");
        for link in links(text) {
            let (path, frag) = link.split_once('#').unwrap_or((&link, ""));
            let target = if path.is_empty() {
                file.to_path_buf()
            } else {
                dir.join(path)
            };
            if !target.exists() {
                out.push(format!("{shown}: links to {link}, which is not there"));
            } else if !frag.is_empty() && target.extension().is_some_and(|e| e == "md") {
                let page = std::fs::read_to_string(&target).expect("a page reads");
                if !anchors(&page).iter().any(|a| a == frag) {
                    out.push(format!("{shown}: links to {link}: no such heading"));
                }
            }
        }
    }
    out
}

#[test]
fn every_path_and_link_the_words_name_is_there() {
    let root = Path::new(ROOT);
    let mut missing = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("a page reads");
        missing.extend(missing_in(&page, &text, root));
    }
    let mut sources = Vec::new();
    for dir in [
        "src", "cell", "cli", "tests", "benches", "xtask", "examples",
    ] {
        files(&root.join(dir), ".rs", &mut sources);
    }
    assert!(
        sources.len() > 100,
        "the sources were found: {}",
        sources.len()
    );
    for file in sources {
        let text = std::fs::read_to_string(&file).expect("a source reads");
        let docs: String = (text.lines())
            .filter_map(|l| l.trim_start().strip_prefix("//!"))
            .collect::<Vec<_>>()
            .join("\n");
        missing.extend(missing_in(&file, &docs, root));
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

#[test]
fn every_plot_in_docs_is_shown_by_a_page() {
    let root = Path::new(ROOT);
    let text: String = (pages().iter())
        .map(|p| std::fs::read_to_string(p).expect("a page reads"))
        .collect();
    let mut plots = Vec::new();
    files(&root.join("docs"), ".svg", &mut plots);
    let unused: Vec<String> = (plots.iter())
        .map(|p| {
            p.file_name()
                .expect("a file")
                .to_string_lossy()
                .into_owned()
        })
        .filter(|name| !text.contains(&format!("{name})")))
        .collect();
    assert!(unused.is_empty(), "plots no page shows: {unused:?}");
}

#[test]
fn the_checks_find_what_is_not_there() {
    let root = Path::new(ROOT);
    let page = root.join("docs/some-page.md");
    let text = "See `src/no_such_file.rs`, [a page](nowhere.md), \
                [a heading](tree.md#no-such-heading), [ok](tree.md), \
                `results/table1.{csv,json}` and src/bih/ too.";
    let m = missing_in(&page, text, root);
    assert_eq!(m.len(), 3, "{m:?}");
    assert!(m[0].contains("src/no_such_file.rs"), "{m:?}");
    assert!(m[1].contains("nowhere.md"), "{m:?}");
    assert!(m[2].contains("no such heading"), "{m:?}");
    assert_eq!(
        anchor("## What it measures, 1–8 SPEs"),
        "what-it-measures-18-spes"
    );
    let tagged = anchors("# Top\n<a id=\"here\"></a>**Here.** text\n```\n<a id=\"code\">\n```");
    assert_eq!(tagged, ["top", "here"]);
}

/// The reference stays a reference: docs/ (generated tables included) in
/// under 30,000 words, as `wc -w` counts them.
#[test]
fn the_docs_stay_under_thirty_thousand_words() {
    let mut pages = Vec::new();
    files(&Path::new(ROOT).join("docs"), ".md", &mut pages);
    let words: usize = (pages.iter())
        .map(|p| {
            std::fs::read_to_string(p)
                .unwrap()
                .split_whitespace()
                .count()
        })
        .sum();
    assert!(
        words < 30_000,
        "docs/ holds {words} words: cut prose, or point at a generated table"
    );
}
