//! The parts import downwards only (DESIGN.md): the emulator knows nothing
//! of trees; the SPE toolkit knows no strategy and no caster; the caster
//! and the strategies do not import each other; the host builders and the
//! strategies do not import each other; only the registry sits above both
//! families.

use std::path::{Path, PathBuf};

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

#[test]
fn each_part_imports_only_the_parts_below_it() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let rules: [(&str, &[&str]); 5] = [
        (
            "cell",
            &[
                "aabb", "bih", "scene", "spe", "strategy", "host", "cast", "registry", "quality",
                "render", "update", "frame", "report",
            ],
        ),
        (
            "spe",
            &[
                "strategy", "host", "cast", "registry", "update", "frame", "report",
            ],
        ),
        ("cast", &["strategy", "host", "registry", "update", "frame"]),
        (
            "strategy",
            &["host", "cast", "registry", "update", "frame", "report"],
        ),
        (
            "host",
            &[
                "strategy", "spe", "cast", "registry", "update", "frame", "report",
            ],
        ),
    ];
    let mut files = 0;
    for (part, below_not) in rules {
        for path in sources(&root.join(part)) {
            let text = std::fs::read_to_string(&path).unwrap();
            for m in below_not {
                assert!(
                    !text.contains(&format!("crate::{m}::"))
                        && !text.contains(&format!("crate::{m};")),
                    "{} (src/{part}) imports crate::{m}",
                    path.display()
                );
            }
            files += 1;
        }
    }
    assert!(files > 40, "{files} files read");
}
