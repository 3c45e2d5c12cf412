//! Files the project writes — hits CSV, PNG, experiment CSV/JSON/SVG,
//! traces — written so that nothing is lost and nothing is half-written:
//!
//! - [`check_writable`] is called before the work starts, so that a path
//!   that cannot be written fails at once, not after minutes of work;
//! - [`write_file`] writes a regular file beside its target and renames it
//!   into place only when every byte was written and flushed, so a failed
//!   write leaves the old file (or none), never a truncated one that looks
//!   valid. A target that is not a regular file (a device such as
//!   `/dev/full`, a pipe) is written directly and flushed explicitly;
//! - `-` is the standard output, as command-line users expect;
//! - an existing file keeps its permissions (a 0600 file stays 0600); a new
//!   one gets what `open(2)` would give it, `0666 & !umask`;
//! - every error names the path the user gave, never the temporary file;
//! - an interrupt (Ctrl-C), a `kill`/`timeout` (SIGTERM) or a closed
//!   terminal (SIGHUP) while a file is being written removes its temporary
//!   file before the process ends ([`clean_up_on_interrupt`]);
//! - a file-size limit (`ulimit -f`) is a write error ("File too large")
//!   like a full disk, not a signal that kills the process mid-write.

use std::fs::OpenOptions;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use thiserror::Error;

/// A file that could not be written, named by the path the user gave (a
/// file of an experiment's set by its place in `--out`, not its staging).
#[derive(Debug, Error)]
#[error("{}: cannot write: {source}", user_path(path).display())]
pub struct OutputError {
    pub path: PathBuf,
    pub source: std::io::Error,
}

impl OutputError {
    fn new(path: &Path, source: std::io::Error) -> Self {
        OutputError {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// How a path is written.
enum Target {
    /// A regular file (or none yet): a temporary file in `dir`, renamed to
    /// `file` at the end. `file` is the link's target when `path` is a link.
    Replace { dir: PathBuf, file: PathBuf },
    /// A device or pipe: opened and written in place.
    Direct,
    /// `-`: the standard output.
    Stdout,
}

fn target(path: &Path) -> Result<Target, OutputError> {
    let err = |what: String| OutputError::new(path, std::io::Error::other(what));
    if path.as_os_str() == "-" {
        return Ok(Target::Stdout);
    }
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => return Err(err("it is a directory".into())),
        Ok(m) if !m.is_file() => return Ok(Target::Direct),
        _ => {}
    }
    // A link is replaced at its target (there yet or not), keeping the link.
    let file = resolved(path);
    if file.file_name().is_none() {
        return Err(err("not a file name".into()));
    }
    let dir = match file.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(err(match not_a_directory(&dir) {
            Some(f) => format!("{} is not a directory", f.display()),
            None => format!("the directory {} does not exist", dir.display()),
        }));
    }
    Ok(Target::Replace { dir, file })
}

/// The first of `dir` and its ancestors that exists but is not a directory
/// (a regular file where a directory is asked for), if any.
pub fn not_a_directory(dir: &Path) -> Option<PathBuf> {
    dir.ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .find(|a| std::fs::metadata(a).is_ok_and(|m| !m.is_dir()))
        .map(Path::to_path_buf)
}

/// A temporary file in `dir` created as `open(2)` creates a new file: mode
/// `0666 & !umask` (`tempfile`'s own default is a private 0600), listed
/// in [`IN_FLIGHT`] in the same step, so that no interrupt falls between
/// the file's creation and its listing (and none after the interrupt's
/// clean-up creates one: [`CREATING`]).
fn new_temporary(dir: &Path) -> std::io::Result<Temporary> {
    let mut b = tempfile::Builder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        b.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let _creating = creating();
    let file = b.tempfile_in(dir)?;
    let listed = Listed::new(file.path());
    Ok(Temporary {
        file,
        _listed: listed,
    })
}

/// A temporary file and its listing, dropped in that order: the file is
/// gone before it is unlisted.
struct Temporary {
    file: tempfile::NamedTempFile,
    _listed: Listed,
}

/// Held while a file or directory that an interrupt must remove is
/// created and listed; the interrupt's clean-up takes it and keeps it
/// until the process ends, so nothing is created after the clean-up.
static CREATING: Mutex<()> = Mutex::new(());

fn creating() -> std::sync::MutexGuard<'static, ()> {
    CREATING.lock().unwrap_or_else(|e| e.into_inner())
}

/// Creates `dir` (and its parents) in one step with respect to an
/// interrupt: an interrupt's clean-up either sees it or comes after the
/// process has stopped creating (a staging directory the clean-up
/// removes whole).
pub fn create_dir_all_guarded(dir: &Path) -> std::io::Result<()> {
    let _creating = creating();
    std::fs::create_dir_all(dir)
}

/// Checks, before any work, that `path` can be written: its directory exists
/// and takes a new file, or it is a device or pipe that opens for writing.
/// Nothing is left behind.
pub fn check_writable(path: &Path) -> Result<(), OutputError> {
    match target(path)? {
        Target::Stdout => Ok(()),
        Target::Direct => OpenOptions::new()
            .write(true)
            .open(path)
            .map(drop)
            .map_err(|e| OutputError::new(path, e)),
        Target::Replace { dir, .. } => new_temporary(&dir)
            .map(drop)
            .map_err(|e| OutputError::new(path, std::io::Error::new(e.kind(), plain_error(&e)))),
    }
}

/// Writes `path` with `write`, buffered, flushed explicitly; a regular file
/// appears only when complete (see the module's docs). Any error — from
/// `write`, the flush, or the rename — names `path`.
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    let fail = |e| OutputError::new(path, e);
    match target(path)? {
        Target::Stdout => {
            let mut w = BufWriter::new(std::io::stdout().lock());
            write(&mut w).map_err(fail)?;
            w.flush().map_err(fail)
        }
        Target::Direct => {
            let f = OpenOptions::new()
                .write(true)
                .truncate(true)
                .open(path)
                .map_err(fail)?;
            let mut w = BufWriter::new(f);
            write(&mut w).map_err(fail)?;
            w.flush().map_err(fail)
        }
        Target::Replace { dir, file } => {
            let plain = |e: std::io::Error| fail(std::io::Error::new(e.kind(), plain_error(&e)));
            let mut staged = new_temporary(&dir).map_err(plain)?;
            let tmp = &mut staged.file;
            // Written through the plain file: the temporary file's own
            // writer puts its name into errors.
            let mut w = BufWriter::new(tmp.as_file_mut());
            write(&mut w).map_err(plain)?;
            w.into_inner().map_err(|e| plain(e.into_error()))?;
            tmp.as_file().sync_all().map_err(plain)?;
            // The temporary file has a new file's mode (the umask applied
            // by open(2)); a file it replaces keeps its own.
            if let Ok(old) = std::fs::metadata(&file) {
                let _ = tmp.as_file().set_permissions(old.permissions());
            }
            // Unlisted only after the rename (the listing drops last).
            staged.file.persist(&file).map_err(|e| plain(e.error))?;
            Ok(())
        }
    }
}

/// The temporary files being written now.
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A temporary file listed in [`IN_FLIGHT`] while it lives.
struct Listed(PathBuf);

impl Listed {
    fn new(path: &Path) -> Self {
        lock_in_flight().push(path.to_path_buf());
        Listed(path.to_path_buf())
    }
}

impl Drop for Listed {
    fn drop(&mut self) {
        lock_in_flight().retain(|p| p != &self.0);
    }
}

fn lock_in_flight() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// A staging directory and the directory its files are for (an
/// experiment's set: [`crate::report::result_set`]).
static STAGED: Mutex<Option<(PathBuf, PathBuf)>> = Mutex::new(None);

/// Files written into `staging` are the user's files of `out`: errors
/// name them there ([`user_path`]); `None` ends it.
pub fn stage_for(dirs: Option<(PathBuf, PathBuf)>) {
    *STAGED.lock().unwrap_or_else(|e| e.into_inner()) = dirs;
}

/// The path a user knows `path` by: a file in a staging directory, at its
/// place in the directory it is for; any other path as it is.
pub fn user_path(path: &Path) -> PathBuf {
    let staged = STAGED.lock().unwrap_or_else(|e| e.into_inner());
    match (&*staged, path.file_name()) {
        (Some((staging, out)), Some(f)) if path.parent() == Some(staging.as_path()) => out.join(f),
        _ => path.to_path_buf(),
    }
}

/// Held by a step that must finish whole once begun (an experiment's set
/// moved into place): an interrupt waits for it, then ends the process.
static WHOLE: Mutex<()> = Mutex::new(());

/// Holds off interrupts until the guard is dropped: what runs meanwhile
/// is either done whole or, if the signal came first, not begun.
pub fn whole_step() -> std::sync::MutexGuard<'static, ()> {
    WHOLE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Directories an interrupt removes whole (an experiment's staged set).
static DIRS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Has an interrupt remove `dir` and everything in it.
pub fn remove_dir_on_interrupt(dir: &Path) {
    DIRS.lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(dir.to_path_buf());
}

/// The temporary files of the writes under way.
pub fn in_flight() -> Vec<PathBuf> {
    lock_in_flight().clone()
}

/// Removes the temporary files of the writes under way (what an interrupt
/// does before the process ends); returns how many.
pub fn remove_in_flight() -> usize {
    let files = lock_in_flight();
    let mut n = (files.iter())
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count();
    for dir in DIRS.lock().unwrap_or_else(|e| e.into_inner()).iter() {
        n += std::fs::read_dir(dir).map_or(0, |r| r.count());
        let _ = std::fs::remove_dir_all(dir);
    }
    n
}

/// On Ctrl-C (SIGINT), `kill`/`timeout` (SIGTERM) or a closed terminal
/// (SIGHUP): remove the temporary files of the writes under way, say so, and
/// exit with status 128 + the signal's number (130, 143, 129), as a shell
/// reports it: an interrupted run leaves the old files, never a hidden
/// `.tmp` one. Once per process; the commands and experiments call it first
/// thing.
pub fn clean_up_on_interrupt() {
    #[cfg(unix)]
    // SAFETY: setting one signal's disposition at start-up. A file-size
    // limit (`ulimit -f`) then fails the write with "File too large",
    // whose error path removes the temporary file and names the output,
    // instead of killing the process with SIGXFSZ mid-write and leaving
    // a hidden `.tmp` file for good.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            // Handlers that cannot be registered leave the default (the
            // process ends), as before.
            let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])
            else {
                return;
            };
            std::thread::spawn(move || {
                if let Some(sig) = signals.forever().next() {
                    // A step under way that must finish whole does; none
                    // begins after this.
                    let _whole = whole_step();
                    // Kept until the process ends: no file or staging
                    // directory is created after the clean-up.
                    let _creating = creating();
                    let removed = remove_in_flight();
                    let name = match sig {
                        SIGINT => "interrupted",
                        SIGTERM => "terminated (SIGTERM)",
                        _ => "hung up (SIGHUP)",
                    };
                    eprintln!(
                        "{name}{}",
                        match removed {
                            0 => String::new(),
                            n => format!(
                                ": {} of this run removed; the files already there are kept as they were",
                                cellbih::words::count(n as u64, "unfinished file")
                            ),
                        }
                    );
                    std::process::exit(128 + sig);
                }
            });
        });
    }
}

/// What file a path would write: the standard output's or an existing
/// file's device and inode (through links, `/dev/stdout` included), or
/// for a file not yet there its directory's identity and its name.
#[derive(Debug, PartialEq, Eq)]
enum Identity {
    Inode(u64, u64),
    New(u64, u64, std::ffi::OsString),
    Unknown(PathBuf),
}

/// Where `path` leads: its links followed (a link to a file not yet there
/// included, relative targets read from the link's directory, at most 40
/// links deep as the kernel allows), its directory's links resolved.
pub fn resolved(path: &Path) -> PathBuf {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => match std::fs::read_link(&p) {
                Ok(to) => p = p.parent().map_or(to.clone(), |d| d.join(&to)),
                Err(_) => break,
            },
            _ => break,
        }
    }
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    match (std::fs::canonicalize(&dir), p.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => p,
    }
}

fn identity(path: &Path) -> Identity {
    use std::os::unix::fs::MetadataExt;
    let of = |m: std::fs::Metadata| Identity::Inode(m.dev(), m.ino());
    if path.as_os_str() == "-" {
        return match std::fs::metadata("/proc/self/fd/1")
            .or_else(|_| std::fs::metadata("/dev/stdout"))
        {
            Ok(m) => of(m),
            Err(_) => Identity::Unknown(path.to_path_buf()),
        };
    }
    if let Ok(m) = std::fs::metadata(path) {
        return of(m);
    }
    // Not there yet (or a link to a file not there yet): where it leads.
    let path = resolved(path);
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match (std::fs::metadata(dir), path.file_name()) {
        (Ok(m), Some(name)) => Identity::New(m.dev(), m.ino(), name.to_os_string()),
        _ => Identity::Unknown(path.to_path_buf()),
    }
}

/// A path as the checks below name it.
fn shown(p: &Path) -> String {
    match p.as_os_str() == "-" {
        true => "- (the standard output)".to_string(),
        false => p.display().to_string(),
    }
}

/// Refuses, before any work, two outputs of one run that would write one
/// file: the same name, a link to it (or to where it would be),
/// `/dev/stdout` beside `-`, … Each output is `(option, path)`; the error
/// names both options and paths.
pub fn check_distinct(outputs: &[(&str, &Path)]) -> Result<(), String> {
    check_files(outputs, &[])
}

/// [`check_distinct`] of `outputs`, and each output against each of the
/// run's `inputs` (`(option, path)`; `-`, the standard input, is no file
/// an output could replace): an output that would replace an input is
/// refused, naming both.
pub fn check_files(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), String> {
    let ids: Vec<Identity> = outputs.iter().map(|(_, p)| identity(p)).collect();
    // Anything may go to /dev/null together.
    let null = identity(Path::new("/dev/null"));
    for i in 0..outputs.len() {
        for j in i + 1..outputs.len() {
            if ids[i] == ids[j] && ids[i] != null {
                return Err(format!(
                    "{} {} and {} {} name the same file: one would overwrite the other; \
                     give them different files",
                    outputs[i].0,
                    shown(outputs[i].1),
                    outputs[j].0,
                    shown(outputs[j].1),
                ));
            }
        }
    }
    for (option, path) in inputs.iter().filter(|(_, p)| p.as_os_str() != "-") {
        let id = identity(path);
        if let Some(k) = ids.iter().position(|o| *o == id && id != null) {
            return Err(format!(
                "{} {} would replace the input {option} {}: give the output another file",
                outputs[k].0,
                shown(outputs[k].1),
                path.display()
            ));
        }
    }
    Ok(())
}

/// [`write_file`] of a byte buffer.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_file(path, |w| w.write_all(bytes))
}

/// An I/O error's words without any path the library put in them (a
/// temporary file's name means nothing to the user).
fn plain_error(e: &std::io::Error) -> String {
    let words = match e.get_ref() {
        Some(inner) => match inner.source() {
            Some(cause) => cause.to_string(),
            None => inner.to_string(),
        },
        None => e.to_string(),
    };
    // `tempfile` appends the temporary file's path to some of its errors
    // without giving their cause apart.
    match words.find(" at path \"") {
        Some(i) => words[..i].to_string(),
        None => words,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// While a file is written its temporary file is listed for an
    /// interrupt to remove, and only while: after the rename (or a failed
    /// write) nothing of it is listed.
    #[test]
    fn a_write_under_way_is_listed_for_an_interrupt() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        let mine = || -> Vec<PathBuf> {
            (in_flight().into_iter())
                .filter(|f| f.parent() == Some(dir.path()))
                .collect()
        };
        write_file(&p, |w| {
            let listed = mine();
            assert_eq!(listed.len(), 1, "{listed:?}");
            assert!(listed[0].exists() && listed[0] != p);
            w.write_all(b"x")
        })
        .unwrap();
        assert!(mine().is_empty());
        let failed = write_file(&p, |_| Err(std::io::Error::other("no")));
        assert!(failed.is_err() && mine().is_empty());
        assert_eq!(std::fs::read(&p).unwrap(), b"x");
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_names_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        std::fs::write(&p, "old\n").unwrap();
        let e = write_file(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk on fire"))
        })
        .unwrap_err();
        assert!(
            e.to_string()
                .contains("out.csv: cannot write: disk on fire"),
            "{e}"
        );
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old\n");
        // No temporary file is left beside it.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        write_bytes(&p, b"new\n").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new\n");
    }

    /// Overwriting keeps the file's permissions: a private file stays
    /// private; a new file gets 0666 less the umask (0644 under the usual
    /// 022; other umasks are tested through the command, in a process of
    /// its own).
    #[cfg(unix)]
    #[test]
    fn an_overwritten_file_keeps_its_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("secret.csv");
        std::fs::write(&p, "old").unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o600)).unwrap();
        write_bytes(&p, b"new").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&p), 0o600);
        let fresh = dir.path().join("fresh.csv");
        write_bytes(&fresh, b"x").unwrap();
        // The umask, read without changing it.
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        let umask = (status.lines())
            .find_map(|l| l.strip_prefix("Umask:"))
            .map(|m| u32::from_str_radix(m.trim(), 8).unwrap())
            .unwrap();
        assert_eq!(mode(&fresh), 0o666 & !umask);
    }

    /// An I/O error that a library wrapped with the temporary file's path
    /// (as `tempfile`'s writer does) is reported by its cause alone: the
    /// error then names the file the user gave.
    #[test]
    fn errors_lose_the_temporary_files_name() {
        #[derive(Debug)]
        struct WithPath(std::io::Error);
        impl std::fmt::Display for WithPath {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{} at path \"/out/.tmpXYZ\"", self.0)
            }
        }
        impl std::error::Error for WithPath {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                Some(&self.0)
            }
        }
        let disk = || std::io::Error::from_raw_os_error(28);
        let wrapped = std::io::Error::new(std::io::ErrorKind::StorageFull, WithPath(disk()));
        assert_eq!(plain_error(&wrapped), disk().to_string());
        assert_eq!(plain_error(&disk()), disk().to_string());
        let own = std::io::Error::other("disk on fire");
        assert_eq!(plain_error(&own), "disk on fire");
        let flat = std::io::Error::other("No such file (os error 2) at path \"/proc/.tmpAb12\"");
        assert_eq!(plain_error(&flat), "No such file (os error 2)");
    }

    #[test]
    fn a_link_to_a_regular_file_stays_a_link() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.csv");
        let link = dir.path().join("link.csv");
        std::fs::write(&real, "old").unwrap();
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_bytes(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
    }

    #[test]
    fn two_outputs_that_name_one_file_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        let link = dir.path().join("link.csv");
        std::fs::write(&a, "x").unwrap();
        std::os::unix::fs::symlink(&a, &link).unwrap();
        let new = dir.path().join("new.csv");
        let same_new = dir.path().join(".").join("new.csv");
        let other = dir.path().join("other.csv");
        assert!(check_distinct(&[("--out", &a), ("--trace", &link)]).is_err());
        let e = check_distinct(&[("--out", &new), ("--trace", &same_new)]).unwrap_err();
        assert!(
            e.contains("--out") && e.contains("--trace") && e.contains("same file"),
            "{e}"
        );
        assert!(check_distinct(&[("--out", &a), ("--trace", &other)]).is_ok());
        // A link to a file not yet there names that file.
        let dangling = dir.path().join("dangling.json");
        std::os::unix::fs::symlink("later.csv", &dangling).unwrap();
        let later = dir.path().join("later.csv");
        assert!(check_distinct(&[("--out", &later), ("--trace", &dangling)]).is_err());
        // An output that would replace an input.
        let e = check_files(&[("--out", &a)], &[("--rays", &link)]).unwrap_err();
        assert!(e.contains("would replace the input --rays"), "{e}");
        assert!(check_files(&[("--out", &other)], &[("--rays", &a)]).is_ok());
        assert!(
            check_distinct(&[
                ("--out", Path::new("-")),
                ("--trace", Path::new("/dev/stdout"))
            ])
            .is_err()
        );
    }

    #[test]
    fn dev_full_and_missing_directories_are_errors() {
        let e = write_bytes(Path::new("/dev/full"), &[0; 100]).unwrap_err();
        assert!(e.to_string().starts_with("/dev/full: cannot write"), "{e}");
        assert!(check_writable(Path::new("/dev/full")).is_ok());
        let e = check_writable(Path::new("/no/such/dir/x.csv")).unwrap_err();
        assert!(e.to_string().contains("/no/such/dir does not exist"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plain");
        std::fs::write(&file, "x").unwrap();
        let e = check_writable(&file.join("sub/x.csv")).unwrap_err();
        assert!(e.to_string().ends_with("plain is not a directory"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let e = check_writable(dir.path()).unwrap_err();
        assert!(e.to_string().contains("it is a directory"), "{e}");
    }
}
