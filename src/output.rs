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
//! - every error names the path.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use thiserror::Error;

/// A file that could not be written.
#[derive(Debug, Error)]
#[error("{}: cannot write: {source}", path.display())]
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
}

fn target(path: &Path) -> Result<Target, OutputError> {
    let err = |what: String| OutputError::new(path, std::io::Error::other(what));
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => return Err(err("it is a directory".into())),
        Ok(m) if !m.is_file() => return Ok(Target::Direct),
        _ => {}
    }
    // A link to a regular file is replaced at its target, keeping the link.
    let file = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    if file.file_name().is_none() {
        return Err(err("not a file name".into()));
    }
    let dir = match file.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(err(format!(
            "the directory {} does not exist",
            dir.display()
        )));
    }
    Ok(Target::Replace { dir, file })
}

/// Checks, before any work, that `path` can be written: its directory exists
/// and takes a new file, or it is a device or pipe that opens for writing.
/// Nothing is left behind.
pub fn check_writable(path: &Path) -> Result<(), OutputError> {
    match target(path)? {
        Target::Direct => OpenOptions::new()
            .write(true)
            .open(path)
            .map(drop)
            .map_err(|e| OutputError::new(path, e)),
        Target::Replace { dir, .. } => tempfile::NamedTempFile::new_in(&dir)
            .map(drop)
            .map_err(|e| OutputError::new(path, e)),
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
            let tmp = tempfile::NamedTempFile::new_in(&dir).map_err(fail)?;
            let mut w = BufWriter::new(tmp);
            write(&mut w).map_err(fail)?;
            let tmp = w.into_inner().map_err(|e| fail(e.into_error()))?;
            tmp.as_file().sync_all().map_err(fail)?;
            // The temporary file is private (0600); give it the mode a new
            // file would have had.
            set_default_mode(tmp.as_file());
            tmp.persist(&file).map_err(|e| fail(e.error))?;
            Ok(())
        }
    }
}

/// [`write_file`] of a byte buffer.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_file(path, |w| w.write_all(bytes))
}

#[cfg(unix)]
fn set_default_mode(f: &File) {
    use std::os::unix::fs::PermissionsExt;
    // rw-r--r--, what `File::create` gives under the usual umask.
    let _ = f.set_permissions(std::fs::Permissions::from_mode(0o644));
}

#[cfg(not(unix))]
fn set_default_mode(_: &File) {}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn dev_full_and_missing_directories_are_errors() {
        let e = write_bytes(Path::new("/dev/full"), &[0; 100]).unwrap_err();
        assert!(e.to_string().starts_with("/dev/full: cannot write"), "{e}");
        assert!(check_writable(Path::new("/dev/full")).is_ok());
        let e = check_writable(Path::new("/no/such/dir/x.csv")).unwrap_err();
        assert!(e.to_string().contains("/no/such/dir does not exist"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let e = check_writable(dir.path()).unwrap_err();
        assert!(e.to_string().contains("it is a directory"), "{e}");
    }
}
