//! Output files: checked before any work, written so that nothing already
//! there is lost or half-written.
//!
//! A regular file (or a path not yet taken) is written to a temporary file
//! beside it and renamed over it, so a failed or interrupted run leaves the
//! old file whole. A symbolic link is followed and its final target replaced
//! the same way, so the link survives. A device or a FIFO is never replaced
//! by a file: it is opened and written through, and a write error (`ENOSPC`
//! from `/dev/full`) is reported.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::CliError;

/// Links followed before giving up (the limit of Linux's `ELOOP`).
const MAX_LINKS: usize = 40;

fn err(path: &Path, what: impl std::fmt::Display) -> CliError {
    CliError::usage(format!("{path:?}: {what}"))
}

/// The final target of `path` after following symbolic links (the target
/// need not exist yet).
///
/// # Errors
/// A one-line error for a link loop or an unreadable link.
pub fn resolve(path: &Path) -> Result<PathBuf, CliError> {
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let t = fs::read_link(&p).map_err(|e| err(&p, e))?;
                p = if t.is_absolute() { t } else { p.parent().map_or_else(|| t.clone(), |d| d.join(&t)) };
            }
            _ => return Ok(p),
        }
    }
    Err(err(path, "too many levels of symbolic links"))
}

/// What kind of thing an output path names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// A regular file, or nothing yet: write beside it and rename.
    Replace,
    /// A device or FIFO: write through.
    Through,
}

fn kind(target: &Path) -> Result<Kind, CliError> {
    match fs::metadata(target) {
        Ok(m) if m.is_dir() => Err(err(target, "is a directory")),
        Ok(m) if m.is_file() => Ok(Kind::Replace),
        Ok(_) => Ok(Kind::Through),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(Kind::Replace),
        Err(e) => Err(err(target, e)),
    }
}

fn dir_of(target: &Path) -> &Path {
    target.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Prepares `--out DIR`: refuses a path that exists and is not a directory,
/// creates a missing one (and its parents). Returns the directory when this
/// call created it, so that a run that then fails can remove it again (only
/// if still empty: nothing is left behind, nothing a user had is touched).
///
/// # Errors
/// `--out` names a file, or the directory cannot be created.
pub fn out_dir(dir: &Path) -> Result<Option<PathBuf>, CliError> {
    if fs::metadata(dir).is_ok_and(|m| !m.is_dir()) {
        return Err(CliError::usage(format!("--out {dir:?}: not a directory")));
    }
    if dir.exists() {
        return Ok(None);
    }
    fs::create_dir_all(dir).map_err(|e| CliError::usage(format!("--out {dir:?}: {e}")))?;
    Ok(Some(dir.to_path_buf()))
}

/// [`out_dir`], then `checks` (typically [`check`] on each file the run will
/// write); when they fail, the directory this call made goes again (only if
/// still empty). Returns whether the directory was made here.
///
/// # Errors
/// The first error of [`out_dir`] or `checks`.
pub fn out_dir_checked(dir: &Path, checks: impl FnOnce() -> Result<(), CliError>) -> Result<bool, CliError> {
    let created = out_dir(dir)?;
    if let Err(e) = checks() {
        if let Some(d) = &created {
            let _ = fs::remove_dir(d);
        }
        return Err(e);
    }
    Ok(created.is_some())
}

/// [`out_dir_checked`] for files named `names` in `dir`: their paths.
///
/// # Errors
/// One line naming `--out` or the file.
pub fn out_files(dir: &Path, names: &[&str]) -> Result<Vec<PathBuf>, CliError> {
    let paths: Vec<PathBuf> = names.iter().map(|n| dir.join(n)).collect();
    out_dir_checked(dir, || paths.iter().try_for_each(|p| check("--out", p)))?;
    Ok(paths)
}

/// Checks, before any work, that `path` can be written: not empty, not a
/// directory, its directory exists and accepts a new file (probed with a
/// temporary file, removed at once); devices must open for writing (FIFOs
/// are not opened: that would wait for a reader).
///
/// # Errors
/// A one-line error naming the option and the quoted path.
pub fn check(flag: &str, path: &Path) -> Result<(), CliError> {
    let named = |e: CliError| CliError::usage(format!("{flag} {e}"));
    if path.as_os_str().is_empty() {
        return Err(CliError::usage(format!("{flag}: an empty path")));
    }
    let target = resolve(path).map_err(named)?;
    match kind(&target).map_err(named)? {
        Kind::Through => {
            let is_fifo = {
                use std::os::unix::fs::FileTypeExt;
                fs::metadata(&target).is_ok_and(|m| m.file_type().is_fifo())
            };
            if !is_fifo {
                OpenOptions::new().write(true).open(&target).map_err(|e| named(err(path, e)))?;
            }
        }
        Kind::Replace => {
            let dir = dir_of(&target);
            match fs::metadata(dir) {
                Ok(m) if m.is_dir() => {}
                Ok(_) => return Err(named(err(path, format!("{dir:?} is not a directory")))),
                Err(e) => return Err(named(err(path, format!("directory {dir:?}: {e}")))),
            }
            let probe = temporary(&target);
            File::create(&probe).map_err(|e| named(err(path, format!("cannot write in {dir:?}: {e}"))))?;
            let _ = fs::remove_file(&probe);
        }
    }
    Ok(())
}

fn temporary(target: &Path) -> PathBuf {
    let name = target.file_name().map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    dir_of(target).join(format!(".{name}.tmp{}", std::process::id()))
}

/// Writes `bytes` to `path`: atomically for regular files (through links),
/// straight through for devices and FIFOs.
///
/// # Errors
/// A one-line error naming the quoted path.
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let target = resolve(path)?;
    match kind(&target)? {
        Kind::Through => {
            let mut f = OpenOptions::new().write(true).open(&target).map_err(|e| err(path, e))?;
            f.write_all(bytes).and_then(|()| f.flush()).map_err(|e| err(path, e))
        }
        Kind::Replace => {
            let tmp = temporary(&target);
            let keep = fs::metadata(&target).ok().map(|m| m.permissions());
            let res = (|| {
                let mut f = File::create(&tmp)?;
                f.write_all(bytes)?;
                f.sync_all()?;
                if let Some(p) = keep {
                    fs::set_permissions(&tmp, p)?;
                }
                fs::rename(&tmp, &target)
            })();
            if res.is_err() {
                let _ = fs::remove_file(&tmp);
            }
            res.map_err(|e| err(path, e))
        }
    }
}
