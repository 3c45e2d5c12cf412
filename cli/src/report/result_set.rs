//! An experiment's files as one set: every file the run writes into its
//! `--out` directory goes first into a staging directory beside them
//! (`OUT/.cellbih-run-PID`), and only a run that finishes moves the whole
//! set into place (each file renamed over its old one; if a rename fails,
//! the ones already moved are put back). So a run that fails, runs out of
//! disk or is interrupted never leaves its new CSV beside an old JSON and
//! old plots whose recorded command describes another run: the old set
//! stays whole, and what this run measured before it failed is kept in
//! `OUT/incomplete-NAME/` and named.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The run's staging: the `--out` directory and where its files go first.
struct Stage {
    out: PathBuf,
    dir: PathBuf,
}

static STAGE: Mutex<Option<Stage>> = Mutex::new(None);

fn stage() -> std::sync::MutexGuard<'static, Option<Stage>> {
    STAGE.lock().unwrap_or_else(|e| e.into_inner())
}

/// From now on, files written into `out` through [`super::output`] are
/// staged until [`commit`].
pub fn begin(out: &Path) {
    let dir = out.join(format!(".cellbih-run-{}", std::process::id()));
    crate::output::remove_dir_on_interrupt(&dir);
    *stage() = Some(Stage {
        out: out.to_path_buf(),
        dir,
    });
}

/// Where a file named `file` for directory `dir` is written: the staging
/// directory while a set for `dir` is open, else `dir` itself.
pub fn place(dir: &Path, file: &str) -> std::io::Result<PathBuf> {
    match &*stage() {
        Some(s) if s.out == dir => {
            std::fs::create_dir_all(&s.dir)?;
            Ok(s.dir.join(file))
        }
        _ => Ok(dir.join(file)),
    }
}

/// The names of the files in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.filter_map(|e| e.ok())
                .filter(|e| e.path().is_file())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Moves the staged set into place, all or nothing. A file of the set
/// that is a device or a pipe in `--out` (or a link to one) is written
/// into first, before anything is renamed; a link to a regular file is
/// replaced at its target and stays a link. On failure the set stays
/// staged, for [`abandon`].
pub fn commit() -> Result<Vec<String>, String> {
    let guard = stage();
    let Some(s) = &*guard else {
        return Ok(Vec::new());
    };
    let files = names(&s.dir);
    let (direct, replaced): (Vec<&String>, Vec<&String>) =
        (files.iter()).partition(|f| std::fs::metadata(s.out.join(f)).is_ok_and(|m| !m.is_file()));
    for f in direct {
        let bytes = std::fs::read(s.dir.join(f)).map_err(|e| e.to_string())?;
        crate::output::write_bytes(&s.out.join(f), &bytes).map_err(|e| e.to_string())?;
    }
    let backup = s.dir.join(".old");
    let mut moved: Vec<(PathBuf, &String, bool)> = Vec::new();
    let mut failure = None;
    for f in replaced {
        let link = s.out.join(f);
        // A link to a regular file: its target is replaced.
        let target = std::fs::canonicalize(&link).unwrap_or(link);
        let had_old = target.exists();
        let step = (|| {
            if had_old {
                std::fs::create_dir_all(&backup)?;
                std::fs::rename(&target, backup.join(f))?;
            }
            std::fs::rename(s.dir.join(f), &target)
        })();
        match step {
            Ok(()) => moved.push((target, f, had_old)),
            Err(e) => {
                if had_old && !target.exists() {
                    let _ = std::fs::rename(backup.join(f), &target);
                }
                failure = Some(format!("{}: cannot move into place: {e}", target.display()));
                break;
            }
        }
    }
    if let Some(why) = failure {
        // Put back what was moved: the old set stays whole.
        for (target, f, had_old) in moved {
            let _ = std::fs::rename(&target, s.dir.join(f));
            if had_old {
                let _ = std::fs::rename(backup.join(f), &target);
            }
        }
        return Err(why);
    }
    let _ = std::fs::remove_dir_all(&s.dir);
    drop(guard);
    *stage() = None;
    Ok(files)
}

/// After a failed run: the old files stay as they were, and what this run
/// wrote before it failed is moved to `OUT/incomplete-NAME/` (replacing
/// an older one). Returns the lines that say so.
pub fn abandon(name: &str) -> Vec<String> {
    let Some(s) = stage().take() else {
        return Vec::new();
    };
    let written: Vec<String> = names(&s.dir);
    let mut say = Vec::new();
    if written.is_empty() {
        let _ = std::fs::remove_dir_all(&s.dir);
        return say;
    }
    let kept = names(&s.out);
    say.push(match kept.is_empty() {
        true => format!("nothing in {} was replaced", s.out.display()),
        false => format!(
            "nothing in {} was replaced: {} kept as they were",
            s.out.display(),
            kept.join(", ")
        ),
    });
    let incomplete = s.out.join(format!("incomplete-{name}"));
    let _ = std::fs::remove_dir_all(&incomplete);
    match std::fs::rename(&s.dir, &incomplete) {
        Ok(()) => say.push(format!(
            "what this run wrote before the error is in {}: {}",
            incomplete.display(),
            written.join(", ")
        )),
        Err(_) => say.push(format!(
            "what this run wrote before the error is in {}: {}",
            s.dir.display(),
            written.join(", ")
        )),
    }
    say
}
