//! Output files: checked before any work, written so that nothing already
//! there is lost or half-written.
//!
//! A regular file (or a path not yet taken) is written to a temporary file
//! beside it and renamed over it, so a failed or interrupted run leaves the
//! old file whole. A symbolic link is followed and its final target replaced
//! the same way, so the link survives. A device or a FIFO is never replaced
//! by a file: it is opened and written through, and a write error (`ENOSPC`
//! from `/dev/full`) is reported.
//!
//! Between [`begin`] and [`commit`] (the binary brackets each run with them),
//! writes are staged so that a run writes all its outputs or none: regular
//! files go to their temporaries and are renamed only at [`commit`], device
//! and FIFO bytes are kept until then; a failed run calls [`abort`], which
//! removes the temporaries.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

use crate::CliError;

/// Links followed before giving up (the limit of Linux's `ELOOP`).
const MAX_LINKS: usize = 40;

fn err(path: &Path, what: impl std::fmt::Display) -> CliError {
    CliError::usage(format!("{path:?}: {what}"))
}

/// A failed write: a runtime failure (exit 1), not a usage error.
fn write_err(path: &Path, what: impl std::fmt::Display) -> CliError {
    CliError::runtime(format!("{path:?}: {what}"))
}

/// A write held back until [`commit`].
#[derive(Debug)]
struct Staged {
    /// The path as the user gave it (for messages).
    path: PathBuf,
    /// Where it lands (links followed).
    target: PathBuf,
    pending: Pending,
}

#[derive(Debug)]
enum Pending {
    /// A written temporary beside `target`, renamed at [`commit`].
    Rename(PathBuf),
    /// Bytes for a device or FIFO, written at [`commit`].
    Through(Vec<u8>),
}

/// What a run has staged.
#[derive(Debug, Default)]
struct Stage {
    files: Vec<Staged>,
    /// `--out` directories this run created: removed again (when empty) if
    /// the run fails.
    dirs: Vec<PathBuf>,
}

impl Stage {
    /// Removes the temporaries of `files` and the directories made for them.
    fn undo(files: &[Staged], dirs: &[PathBuf]) {
        for s in files {
            if let Pending::Rename(tmp) = &s.pending {
                let _ = fs::remove_file(tmp);
            }
        }
        for d in dirs.iter().rev() {
            let _ = fs::remove_dir(d);
        }
    }
}

/// The staged writes of the run, `None` outside [`begin`]…[`commit`].
static STAGE: Mutex<Option<Stage>> = Mutex::new(None);

fn stage() -> MutexGuard<'static, Option<Stage>> {
    STAGE.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Starts staging: until [`commit`] or [`abort`], [`write()`] renames nothing
/// into place and writes no device.
pub fn begin() {
    *stage() = Some(Stage::default());
}

/// Ends staging without writing: removes every temporary written so far.
pub fn abort() {
    let s = stage().take().unwrap_or_default();
    Stage::undo(&s.files, &s.dirs);
}

/// Writes the staged device and FIFO outputs, then (`before_rename`, e.g.
/// printing the report, returning `Ok`) renames the staged files into
/// place. A failure before the renames removes every temporary, so no file
/// output is left; one during them removes those not yet renamed.
///
/// # Errors
/// The first failed write, `before_rename`'s error, or a failed rename, as a
/// runtime error naming the path.
pub fn commit(before_rename: impl FnOnce() -> Result<(), CliError>) -> Result<(), CliError> {
    let Stage { files, dirs } = stage().take().unwrap_or_default();
    for s in &files {
        if let Pending::Through(bytes) = &s.pending
            && let Err(e) = write_through(&s.path, &s.target, bytes)
        {
            Stage::undo(&files, &dirs);
            return Err(e);
        }
    }
    if let Err(e) = before_rename() {
        Stage::undo(&files, &dirs);
        return Err(e);
    }
    for (i, s) in files.iter().enumerate() {
        if let Pending::Rename(tmp) = &s.pending
            && let Err(e) = fs::rename(tmp, &s.target)
        {
            Stage::undo(&files[i..], &[]);
            return Err(write_err(&s.path, e));
        }
    }
    Ok(())
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
    if let Ok(link) = fs::read_link(dir) {
        // A dangling link: creating the directory would fail with "File
        // exists", and creating its target would write where `--out` does not say.
        return Err(CliError::usage(format!(
            "--out {dir:?}: a symbolic link to {link:?}, which does not exist: give a directory, or make the link's target first"
        )));
    }
    fs::create_dir_all(dir).map_err(|e| CliError::usage(format!("--out {dir:?}: {e}")))?;
    if let Some(s) = stage().as_mut() {
        s.dirs.push(dir.to_path_buf());
    }
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
/// straight through for devices and FIFOs; between [`begin`] and [`commit`],
/// staged instead (see the module docs).
///
/// # Errors
/// A one-line runtime error naming the quoted path.
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let target = resolve(path)?;
    let how = kind(&target)?;
    let mut guard = stage();
    let Some(Stage { files: staged, .. }) = guard.as_mut() else {
        drop(guard);
        return match how {
            Kind::Through => write_through(path, &target, bytes),
            Kind::Replace => {
                let tmp = temporary(&target);
                write_temporary(path, &target, &tmp, bytes)?;
                fs::rename(&tmp, &target).map_err(|e| {
                    let _ = fs::remove_file(&tmp);
                    write_err(path, e)
                })
            }
        };
    };
    // The same output written twice in a run: the last bytes win for a
    // file (one temporary), both go through to a device, as unstaged.
    let earlier = staged.iter_mut().find(|s| s.target == target);
    match how {
        Kind::Through => match earlier {
            Some(Staged { pending: Pending::Through(b), .. }) => b.extend_from_slice(bytes),
            _ => staged.push(Staged { path: path.into(), target, pending: Pending::Through(bytes.to_vec()) }),
        },
        Kind::Replace => {
            let tmp = temporary(&target);
            write_temporary(path, &target, &tmp, bytes)?;
            if earlier.is_none() {
                staged.push(Staged { path: path.into(), target, pending: Pending::Rename(tmp) });
            }
        }
    }
    Ok(())
}

fn write_through(path: &Path, target: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let mut f = OpenOptions::new().write(true).open(target).map_err(|e| write_err(path, e))?;
    f.write_all(bytes).and_then(|()| f.flush()).map_err(|e| write_err(path, e))
}

/// Writes `tmp` whole (synced, with `target`'s permissions if it exists);
/// removes it again on failure.
fn write_temporary(path: &Path, target: &Path, tmp: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let keep = fs::metadata(target).ok().map(|m| m.permissions());
    let res = (|| {
        let mut f = File::create(tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        if let Some(p) = keep {
            fs::set_permissions(tmp, p)?;
        }
        Ok::<(), io::Error>(())
    })();
    if res.is_err() {
        let _ = fs::remove_file(tmp);
    }
    res.map_err(|e| write_err(path, e))
}
