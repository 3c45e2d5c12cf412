//! An experiment's files as one set: every file the run writes into its
//! `--out` directory goes first into a staging directory beside them
//! (`OUT/.cellbih-run-PID`), and only a run that finishes moves the whole
//! set into place (each file renamed over its old one; if a rename fails,
//! the ones already moved are put back). So a run that fails, runs out of
//! disk or is interrupted never leaves its new CSV beside an old JSON and
//! old plots whose recorded command describes another run: the old set
//! stays whole, and what this run measured before it failed is kept in
//! `OUT/incomplete-NAME/` and named.
//!
//! The move is one step an interrupt waits for ([`crate::output::whole_step`]):
//! a signal during it ends the process once the set is in place; before
//! it, the set is not begun. A staging directory left by a process that
//! died (killed with SIGKILL, a power cut) is removed by the next run into
//! that `--out`, and said. The set names its files (`OUT/.NAME.set`): the
//! next run of the same experiment there removes those of its files that
//! the new set does not write (an earlier run's plot of a scene no longer
//! asked for), and says what "written" only once the set is in place.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The run's staging: the `--out` directory, where its files go first,
/// the experiment's name, and what to say once the set is in place.
struct Stage {
    out: PathBuf,
    dir: PathBuf,
    name: String,
    said: Vec<String>,
}

/// The staging directory's name for process `pid`.
fn staging_name(pid: u32) -> String {
    format!(".cellbih-run-{pid}")
}

static STAGE: Mutex<Option<Stage>> = Mutex::new(None);

fn stage() -> std::sync::MutexGuard<'static, Option<Stage>> {
    STAGE.lock().unwrap_or_else(|e| e.into_inner())
}

/// From now on, files written into `out` through [`super::output`] by the
/// experiment `name` are staged until [`commit`]. Staging directories of
/// processes no longer running are removed first, and said.
pub fn begin(out: &Path, name: &str) {
    remove_stale(out);
    let dir = out.join(staging_name(std::process::id()));
    crate::output::remove_dir_on_interrupt(&dir);
    crate::output::stage_for(Some((dir.clone(), out.to_path_buf())));
    *stage() = Some(Stage {
        out: out.to_path_buf(),
        dir,
        name: name.to_string(),
        said: Vec::new(),
    });
}

/// Removes the staging directories in `out` of processes that are no
/// longer running (a process id in use again keeps its directory).
fn remove_stale(out: &Path) {
    let Ok(entries) = std::fs::read_dir(out) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = name.strip_prefix(".cellbih-run-") else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else {
            continue;
        };
        if pid == std::process::id() || alive(pid) {
            continue;
        }
        if std::fs::remove_dir_all(e.path()).is_ok() {
            eprintln!(
                "note: removed {}, left by an earlier run (process {pid}) that did not finish",
                e.path().display()
            );
        }
    }
}

/// Whether process `pid` is running (signal 0 reaches it, or it exists
/// but belongs to another user).
fn alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    // SAFETY: signal 0 only asks whether the process exists.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

/// `line` said once the set is in place ("written: …"); at once where no
/// set is open.
pub fn say_written(line: String) {
    match &mut *stage() {
        Some(s) => s.said.push(line),
        None => eprintln!("{line}"),
    }
}

/// Where a file named `file` for directory `dir` is written: the staging
/// directory while a set for `dir` is open, else `dir` itself.
pub fn place(dir: &Path, file: &str) -> std::io::Result<PathBuf> {
    match &*stage() {
        Some(s) if s.out == dir => {
            crate::output::create_dir_all_guarded(&s.dir)?;
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
    let _whole = crate::output::whole_step();
    let mut guard = stage();
    let Some(s) = &*guard else {
        return Ok(Vec::new());
    };
    let s = Stage {
        out: s.out.clone(),
        dir: s.dir.clone(),
        name: s.name.clone(),
        said: Vec::new(),
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
    let gone = replace_set(&s.out, &s.name, &files);
    let said = std::mem::take(&mut guard.as_mut().expect("a stage").said);
    *guard = None;
    drop(guard);
    for line in said {
        eprintln!("{line}");
    }
    if !gone.is_empty() {
        eprintln!("removed, of the set this one replaces: {}", gone.join(", "));
    }
    Ok(files)
}

/// Records `files` as the set of experiment `name` in `out`
/// (`OUT/.NAME.set`, a name a line) and removes the files of the set it
/// replaces that this one does not write; returns their names.
fn replace_set(out: &Path, name: &str, files: &[String]) -> Vec<String> {
    let record = out.join(format!(".{name}.set"));
    let old = std::fs::read_to_string(&record).unwrap_or_default();
    let gone: Vec<String> = (old.lines())
        .filter(|f| !f.is_empty() && !f.contains('/') && !files.iter().any(|n| n == f))
        .filter(|f| std::fs::symlink_metadata(out.join(f)).is_ok_and(|m| m.is_file()))
        .filter(|f| std::fs::remove_file(out.join(f)).is_ok())
        .map(str::to_string)
        .collect();
    let _ = crate::output::write_bytes(&record, (files.join("\n") + "\n").as_bytes());
    gone
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
            "nothing in {} was replaced: {} kept as {}",
            s.out.display(),
            kept.join(", "),
            match kept.len() {
                1 => "it was",
                _ => "they were",
            }
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
