//! The one write path of the host tools (`fusion`, the renderer, the Python package): every output file goes
//! through [`write_atomic`] or, when a run writes several files that belong together, a
//! [`Batch`].
//!
//! Guarantees (README, "What the CLI guarantees"):
//! * **Nothing partial, nothing redirected.** The data goes to a temporary file created
//!   exclusively (`O_CREAT | O_EXCL`, so a prepared symbolic link at that name makes the
//!   creation fail instead of being followed) under an unpredictable name in the destination's
//!   folder, with owner-only permissions (0600, the final file keeps them); it is flushed and
//!   synced, then renamed over the destination. A failure at any step removes the temporary.
//! * **Atomic for readers.** The rename replaces the destination in one step: a reader opening
//!   it at any moment gets the old bytes or the new ones, never "no such file". The old file is
//!   never moved aside.
//! * **Names as long as the file system allows**: the temporary's name does not grow with the
//!   destination's.
//! * **Only regular files are replaced**: a destination that exists and is a folder, device,
//!   FIFO or socket is refused with one line before anything is written.
//! * **All or nothing** for a [`Batch`]: every file is staged first; the renames then replace
//!   the destinations, and if one fails the ones already replaced get their previous bytes back
//!   (kept under a second name, a hard link to the old file made before the rename, so the
//!   destination itself is never missing).
//! * **New folders whole**: a verb that fills a folder that does not exist yet builds it under a
//!   temporary name beside it and renames it into place at the end ([`in_new_folder`]), so an
//!   interrupted or failed run leaves no half-filled folder; its subfolders are made with
//!   [`make_folders`] so an interrupt cannot have a removed temporary folder made again. An
//!   existing folder is filled file
//!   by file (each file atomic); a folder made by [`create_folder`] is removed again if the run
//!   leaves it empty.
//! * **Interrupts**: with [`remove_in_flight_on_signal`] installed, SIGINT, SIGTERM and SIGHUP
//!   remove every temporary of this process (files, folders, kept old bytes) and every empty
//!   folder it made, then exit with status 128 + the signal's number (130, 143, 129). Creating
//!   a temporary, renaming it into place and removing it all happen under one lock that the
//!   handler takes and keeps until the process ends, so no temporary can be made or renamed
//!   behind its back: every output that existed before the run is either as it was or replaced
//!   whole.

use anyhow::{Context, Result, bail};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// What the signal handler removes.
enum Pending {
    /// A temporary file: a staged output or the old bytes kept for a batch's rollback.
    File(PathBuf),
    /// A temporary folder being filled ([`in_new_folder`]).
    Folder(PathBuf),
    /// A folder this run made ([`create_folder`]): removed only if still empty.
    Made(PathBuf),
}

impl Pending {
    fn path(&self) -> &Path {
        match self {
            Pending::File(p) | Pending::Folder(p) | Pending::Made(p) => p,
        }
    }

    fn remove(&self) {
        match self {
            Pending::File(p) => {
                let _ = std::fs::remove_file(p);
            }
            Pending::Folder(p) => {
                // A worker may still be creating an entry inside it: try again while it stands.
                for _ in 0..10 {
                    if std::fs::remove_dir_all(p).is_ok() || std::fs::symlink_metadata(p).is_err() {
                        break;
                    }
                }
            }
            Pending::Made(p) => {
                let _ = std::fs::remove_dir(p);
            }
        }
    }
}

/// The temporaries and made folders of this process. Every step that creates, renames or
/// removes one holds this lock, and so does the signal handler until the process exits.
static PENDING: Mutex<Vec<Pending>> = Mutex::new(Vec::new());

fn pending() -> MutexGuard<'static, Vec<Pending>> {
    // A panic while holding the lock leaves the list usable: it is only paths.
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

fn forget(list: &mut Vec<Pending>, path: &Path) {
    if let Some(i) = list.iter().rposition(|q| q.path() == path) {
        list.remove(i);
    }
}

/// Installs the SIGINT/SIGTERM/SIGHUP handler (a thread of the `signal-hook` crate) that
/// removes every temporary of this process and every empty folder it made, says so on
/// standard error and exits with status 128 + the signal's number. Call once, early in
/// `main`; if the handler cannot be installed the signals keep their default action.
pub fn remove_in_flight_on_signal() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else { return };
    let spawned = std::thread::Builder::new().name("signals".into()).spawn(move || {
        if let Some(signal) = signals.forever().next() {
            // Held until the process ends: no temporary is made or renamed after this point.
            let list = pending();
            for p in list.iter().rev() {
                p.remove();
            }
            crate::console::stderr_note(format_args!("interrupted: outputs in progress removed"));
            std::process::exit(128 + signal);
        }
    });
    drop(spawned);
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

/// The OS's reason for an I/O error, without the temporary's name `tempfile` appends (its
/// error wraps the OS error and shows it as `REASON at path "NAME"`).
fn without_path(e: std::io::Error) -> std::io::Error {
    if let Some(raw) = e.raw_os_error() {
        return std::io::Error::from_raw_os_error(raw);
    }
    let text = e.to_string();
    match text.rfind(" at path \"") {
        Some(at) => std::io::Error::new(e.kind(), text[..at].to_string()),
        None => e,
    }
}

/// A file written under a temporary name, not yet in place. Dropping it removes the temporary.
struct Staged {
    temp: Option<PathBuf>,
    dest: PathBuf,
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(temp) = self.temp.take() {
            remove_pending(&temp);
        }
    }
}

/// Creates an exclusive temporary file named `.fusion-*SUFFIX` in `dir` through `make`
/// (which gets the free name) and registers it, both under the lock.
fn new_temporary<R>(
    dir: &Path,
    suffix: &str,
    make: impl FnMut(&Path) -> std::io::Result<R>,
) -> std::io::Result<(R, PathBuf)> {
    let mut list = pending();
    let made = tempfile::Builder::new().prefix(".fusion-").suffix(suffix).make_in(dir, make)?;
    // Kept: from here on the list, not `tempfile`, removes it.
    let path = made.path().to_path_buf();
    let (inner, temp_path) = made.into_parts();
    let _ = temp_path.keep();
    list.push(Pending::File(path.clone()));
    Ok((inner, path))
}

/// Writes a temporary next to `dest` through `write`, flushed and synced.
fn stage(dest: &Path, write: impl FnOnce(&mut BufWriter<File>) -> Result<()>) -> Result<Staged> {
    check_destination(dest)?;
    let dir = folder_of(dest);
    let (file, temp) = new_temporary(dir, ".tmp", |p| {
        let mut options = std::fs::OpenOptions::new();
        options.write(true).create_new(true);
        #[cfg(unix)]
        std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
        options.open(p)
    })
    .map_err(|e| anyhow::anyhow!("cannot write {}: {}", dest.display(), without_path(e)))?;
    let staged = Staged { temp: Some(temp), dest: dest.to_path_buf() };
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

/// A destination replaced by a batch, and its old bytes (a second name of the old file) when
/// it existed.
struct Replaced {
    dest: PathBuf,
    old: Option<PathBuf>,
}

/// Keeps `dest`'s current bytes under a temporary name beside it (a hard link to the same
/// file, or a copy where the file system has no hard links); `None` when `dest` does not exist.
fn keep_old(dest: &Path) -> std::io::Result<Option<PathBuf>> {
    if std::fs::symlink_metadata(dest).is_err() {
        return Ok(None);
    }
    let dir = folder_of(dest);
    let linked = new_temporary(dir, ".old", |p| std::fs::hard_link(dest, p));
    let (_, path) = match linked {
        Ok(made) => made,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(_) => new_temporary(dir, ".old", |p| {
            std::fs::OpenOptions::new().write(true).create_new(true).open(p)?;
            std::fs::copy(dest, p).map(|_| ())
        })?,
    };
    Ok(Some(path))
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

    /// Puts every staged file in place, each by one rename over its destination. If a rename
    /// fails, the destinations already replaced get their previous bytes back (or are removed
    /// if they did not exist) and the error is returned; the staged temporaries are removed
    /// either way.
    pub fn commit(mut self) -> Result<()> {
        let n = self.staged.len();
        let mut done: Vec<Replaced> = Vec::new();
        let mut result = Ok(());
        for (k, s) in self.staged.iter_mut().enumerate() {
            let step = (|| -> Result<Replaced> {
                check_destination(&s.dest)?;
                // The last file needs no way back: nothing after it can fail.
                let old = if k + 1 < n { keep_old(&s.dest)? } else { None };
                let mut list = pending();
                let temp = s.temp.as_deref().context("staged twice")?;
                if let Err(e) = std::fs::rename(temp, &s.dest) {
                    drop(list);
                    if let Some(o) = &old {
                        remove_pending(o);
                    }
                    return Err(e.into());
                }
                forget(&mut list, temp);
                s.temp = None;
                Ok(Replaced { dest: s.dest.clone(), old })
            })();
            match step {
                Ok(r) => done.push(r),
                Err(e) => {
                    result = Err(e).with_context(|| format!("cannot write {}", s.dest.display()));
                    break;
                }
            }
        }
        for r in done.iter().rev() {
            let mut list = pending();
            match (&r.old, result.is_err()) {
                (Some(old), true) => {
                    let _ = std::fs::rename(old, &r.dest);
                    forget(&mut list, old);
                }
                (Some(old), false) => {
                    let _ = std::fs::remove_file(old);
                    forget(&mut list, old);
                }
                (None, true) => {
                    let _ = std::fs::remove_file(&r.dest);
                }
                (None, false) => {}
            }
        }
        // Dropping `self` removes any temporary not renamed.
        result
    }
}

/// Removes a registered temporary file now.
fn remove_pending(path: &Path) {
    let mut list = pending();
    let _ = std::fs::remove_file(path);
    forget(&mut list, path);
}

/// A folder [`create_folder`] made for this run's outputs.
#[must_use = "an output folder left empty is removed only through `finish`"]
pub struct OutputFolder {
    made: Option<PathBuf>,
}

impl OutputFolder {
    /// Ends the run's use of the folder: a folder this run made and left empty is removed
    /// (a run whose every output failed leaves nothing behind); one that existed stays.
    pub fn finish(mut self) {
        self.release();
    }

    fn release(&mut self) {
        if let Some(p) = self.made.take() {
            let mut list = pending();
            let _ = std::fs::remove_dir(&p);
            list.retain(|q| !matches!(q, Pending::Made(m) if *m == p));
        }
    }
}

impl Drop for OutputFolder {
    fn drop(&mut self) {
        self.release();
    }
}

/// Makes the folder `out` (and its parents) when it is missing, for outputs written file by
/// file. Dropped or [`finished`](OutputFolder::finish), and on an interrupt, the folder is
/// removed again if this run made it and it is still empty.
pub fn create_folder(out: &Path) -> Result<OutputFolder> {
    let mut list = pending();
    if std::fs::symlink_metadata(out).is_ok() {
        return Ok(OutputFolder { made: None });
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    list.push(Pending::Made(out.to_path_buf()));
    Ok(OutputFolder { made: Some(out.to_path_buf()) })
}

/// Makes the folder `path` and its missing parents, under the lock the signal handler takes.
/// Use it for the subfolders of a folder being filled ([`in_new_folder`]): with
/// `std::fs::create_dir_all`, a worker about to make `TEMP/vis` when an interrupt removes
/// `TEMP` would make `TEMP` again after the handler's removal, and the process would exit
/// leaving it behind.
pub fn make_folders(path: &Path) -> Result<()> {
    let _list = pending();
    std::fs::create_dir_all(path).with_context(|| format!("cannot create {}", path.display()))
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
    let made = make_missing_folders(parent)?;
    let temp = {
        let mut list = pending();
        let temp = tempfile::Builder::new()
            .prefix(".fusion-")
            .suffix(".tmp")
            .tempdir_in(parent)
            .map_err(|e| anyhow::anyhow!("cannot create {}: {}", out.display(), without_path(e)))?
            .keep();
        list.push(Pending::Folder(temp.clone()));
        temp
    };
    let result = fill(&temp).and_then(|value| {
        let mut list = pending();
        std::fs::rename(&temp, out).with_context(|| format!("cannot create {}", out.display()))?;
        forget(&mut list, &temp);
        Ok(value)
    });
    let mut list = pending();
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&temp);
        forget(&mut list, &temp);
    }
    // The folders made for it: removed again if the run failed and left them empty.
    for p in made.iter().rev() {
        if result.is_err() {
            let _ = std::fs::remove_dir(p);
        }
        forget(&mut list, p);
    }
    result
}

/// Makes `path` and its missing parents, each registered as made by this run (so an interrupt
/// removes the ones still empty, deepest first). Returns the folders made, outermost first.
fn make_missing_folders(path: &Path) -> Result<Vec<PathBuf>> {
    let mut missing = Vec::new();
    let mut p = Some(path);
    while let Some(d) = p.filter(|d| !d.as_os_str().is_empty() && std::fs::symlink_metadata(d).is_err()) {
        missing.push(d.to_path_buf());
        p = d.parent();
    }
    let mut list = pending();
    let mut made = Vec::new();
    for d in missing.into_iter().rev() {
        match std::fs::create_dir(&d) {
            Ok(()) => {
                list.push(Pending::Made(d.clone()));
                made.push(d);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(e).with_context(|| format!("cannot create {}", d.display())),
        }
    }
    Ok(made)
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
