//! The one write path of the host tools (`fusion`, the renderer, the Python package): every output file goes
//! through [`write_atomic`] or, when a run writes several files that belong together, a
//! [`Batch`].
//!
//! Guarantees (README, "Robustness"):
//! * **Nothing partial, nothing redirected.** The data goes to a temporary file created
//!   exclusively (`O_CREAT | O_EXCL`, so a prepared symbolic link at that name makes the
//!   creation fail instead of being followed) under an unpredictable name in the destination's
//!   folder, with owner-only permissions (0600, the final file keeps them); it is flushed and
//!   synced, then renamed over the destination. A failure at any step removes the temporary.
//! * **Names as long as the file system allows**: the temporary's name does not grow with the
//!   destination's.
//! * **Only regular files are replaced**: a destination that exists and is a folder, device,
//!   FIFO or socket is refused with one line before anything is written.
//! * **All or nothing** for a [`Batch`]: every file is staged first; the renames then replace
//!   the destinations, and if one fails the ones already replaced are put back.
//! * **New folders whole**: a verb that fills a folder that does not exist yet builds it under a
//!   temporary name beside it and renames it into place at the end ([`in_new_folder`]), so an
//!   interrupted or failed run leaves no half-filled folder. An existing folder is filled file
//!   by file (each file atomic).
//! * **Interrupts**: with [`remove_in_flight_on_signal`] installed, SIGINT and SIGTERM remove
//!   every temporary in flight before the process exits (status 130).

use anyhow::{Context, Result, bail};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporaries currently being written (removed by the signal handler).
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn in_flight() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic while holding the lock leaves the list usable: it is only paths.
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Installs the SIGINT/SIGTERM handler (the `ctrlc` crate) that removes every temporary in
/// flight and exits with status 130. Call once, early in `main`; a second call is refused by
/// `ctrlc` and ignored here.
pub fn remove_in_flight_on_signal() {
    let _ = ctrlc::set_handler(|| {
        for path in in_flight().drain(..) {
            if path.is_dir() {
                let _ = std::fs::remove_dir_all(path);
            } else {
                let _ = std::fs::remove_file(path);
            }
        }
        crate::console::stderr_note(format_args!("interrupted: outputs in progress removed"));
        std::process::exit(130);
    });
}

/// The folder a path's file lives in (`.` for a bare name).
fn folder_of(path: &Path) -> &Path {
    path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Refuses a destination that exists and is not a regular file (following a symbolic link:
/// a link to a device is refused; a dangling link is replaced by the rename like any name).
pub fn check_destination(path: &Path) -> Result<()> {
    if path.file_name().is_none() {
        bail!("cannot write {}: not a file name", path.display());
    }
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => {
            let what = if m.is_dir() { "a folder" } else { "not a regular file (a device, FIFO or socket)" };
            bail!("cannot write {}: it exists and is {what}; give a file name", path.display())
        }
        _ => Ok(()),
    }
}

/// The OS's reason for an I/O error, without the temporary's name `tempfile` appends.
fn without_path(e: std::io::Error) -> std::io::Error {
    e.raw_os_error().map_or(e, std::io::Error::from_raw_os_error)
}

/// A file written under a temporary name, not yet in place.
struct Staged {
    temp: tempfile::TempPath,
    dest: PathBuf,
}

impl Drop for Staged {
    fn drop(&mut self) {
        let p: &Path = &self.temp;
        in_flight().retain(|q| q != p);
    }
}

/// Writes a temporary next to `dest` through `write`, flushed and synced.
fn stage(dest: &Path, write: impl FnOnce(&mut BufWriter<File>) -> Result<()>) -> Result<Staged> {
    check_destination(dest)?;
    let dir = folder_of(dest);
    let temp = tempfile::Builder::new()
        .prefix(".fusion-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {}", dest.display(), without_path(e)))?;
    let (file, temp) = temp.into_parts();
    in_flight().push(temp.to_path_buf());
    let staged = Staged { temp, dest: dest.to_path_buf() };
    let mut w = BufWriter::new(file);
    write(&mut w).with_context(|| format!("cannot write {}", dest.display()))?;
    let file = w
        .into_inner()
        .map_err(|e| e.into_error())
        .with_context(|| format!("cannot write {}", dest.display()))?;
    file.sync_all().with_context(|| format!("cannot write {}", dest.display()))?;
    Ok(staged)
}

/// Writes `path` through `write` (see the module's guarantees).
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> Result<()>) -> Result<()> {
    let mut batch = Batch::default();
    batch.add(path, write)?;
    batch.commit()
}

/// Writes `bytes` to `path` (see the module's guarantees).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| Ok(w.write_all(bytes)?))
}

/// Several files committed together: all of them or none.
#[derive(Default)]
pub struct Batch {
    staged: Vec<Staged>,
}

impl Batch {
    /// Stages `path` written by `write`; nothing is visible under `path` until [`Self::commit`].
    /// The same destination twice is refused (one would silently lose the other).
    pub fn add(&mut self, path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> Result<()>) -> Result<()> {
        if self.staged.iter().any(|s| same_file_name(&s.dest, path)) {
            bail!("{} is given for two outputs of this run", path.display());
        }
        self.staged.push(stage(path, write)?);
        Ok(())
    }

    /// Stages `bytes` for `path`.
    pub fn add_bytes(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        self.add(path, |w| Ok(w.write_all(bytes)?))
    }

    /// Puts every staged file in place. If a rename fails, the destinations already replaced
    /// get their previous content back (or are removed if they did not exist) and the error is
    /// returned; the staged temporaries are removed either way.
    pub fn commit(self) -> Result<()> {
        // The previous content of each destination, moved aside under a temporary name first,
        // so that a failure half way can restore it.
        let mut done: Vec<(PathBuf, Option<tempfile::TempPath>)> = Vec::new();
        let mut result = Ok(());
        for s in &self.staged {
            let step = (|| -> Result<Option<tempfile::TempPath>> {
                check_destination(&s.dest)?;
                let backup = if std::fs::symlink_metadata(&s.dest).is_ok() {
                    let dir = folder_of(&s.dest);
                    let b = tempfile::Builder::new()
                        .prefix(".fusion-")
                        .suffix(".old")
                        .tempfile_in(dir)?
                        .into_temp_path();
                    std::fs::rename(&s.dest, &b)?;
                    Some(b)
                } else {
                    None
                };
                if let Err(e) = std::fs::rename(&s.temp, &s.dest) {
                    if let Some(b) = &backup {
                        let _ = std::fs::rename(b, &s.dest);
                    }
                    return Err(e.into());
                }
                Ok(backup)
            })();
            match step {
                Ok(backup) => done.push((s.dest.clone(), backup)),
                Err(e) => {
                    result = Err(e).with_context(|| format!("cannot write {}", s.dest.display()));
                    break;
                }
            }
        }
        if result.is_err() {
            for (dest, backup) in done.iter().rev() {
                match backup {
                    Some(b) => {
                        let _ = std::fs::rename(b, dest);
                    }
                    None => {
                        let _ = std::fs::remove_file(dest);
                    }
                }
            }
        }
        // Dropping the backups' TempPaths removes the previous contents (or nothing, when they
        // were renamed back); dropping `self` removes any temporary not renamed.
        result
    }
}

/// Runs `fill` on the folder `out`. When `out` does not exist, `fill` gets a temporary folder
/// beside it (an unpredictable name, removed on failure or interrupt) that is renamed to `out`
/// once `fill` succeeded — the folder appears whole or not at all. When `out` exists, `fill`
/// writes into it directly.
pub fn in_new_folder<T>(out: &Path, fill: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
    if std::fs::symlink_metadata(out).is_ok() {
        return fill(out);
    }
    let parent = folder_of(out);
    std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
    let temp = tempfile::Builder::new()
        .prefix(".fusion-")
        .suffix(".tmp")
        .tempdir_in(parent)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {}", out.display(), without_path(e)))?;
    in_flight().push(temp.path().to_path_buf());
    let result = fill(temp.path()).and_then(|value| {
        std::fs::rename(temp.path(), out).with_context(|| format!("cannot create {}", out.display()))?;
        Ok(value)
    });
    let p = temp.path().to_path_buf();
    in_flight().retain(|q| q != &p);
    // On success the temporary name is gone (renamed); on failure dropping `temp` removes it.
    drop(temp);
    result
}

/// Whether two destinations name the same file (compared after resolving their folders).
fn same_file_name(a: &Path, b: &Path) -> bool {
    let resolve = |p: &Path| {
        let dir = folder_of(p);
        (
            std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf()),
            p.file_name().map(|n| n.to_os_string()),
        )
    };
    resolve(a) == resolve(b)
}

/// Writes a value as pretty JSON atomically.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    write_atomic(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value)?;
        w.write_all(b"\n")?;
        Ok(())
    })
}
