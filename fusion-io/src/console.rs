//! Standard output and standard error for the host tools, without panics: [`stdout_write`]
//! returns an error when standard output is closed or full; notes to standard error
//! ([`stderr_note`]) respect `--quiet` ([`set_quiet`]) and a failure to print one is remembered
//! ([`stderr_failed`]) so the run can end with status 1. The crate's macros `out!`, `outln!`
//! and `note!` wrap these.

use anyhow::{Context, Result};

use std::io::Write;

/// Set by `--quiet`: notes are not printed (errors still are).
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Silences [`stderr_note`] for the rest of the run (`--quiet`).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

/// Whether `--quiet` was given (the renderer then shows no progress bar and no summary).
pub fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

/// Writes an error line to standard error, whatever `--quiet` says; a failure is remembered.
pub fn stderr_line(args: std::fmt::Arguments<'_>) {
    let mut err = std::io::stderr().lock();
    if err.write_fmt(args).and_then(|()| err.write_all(b"\n")).and_then(|()| err.flush()).is_err() {
        STDERR_FAILED.store(true, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Set when a note could not be written to standard error (the run then ends with status 1).
static STDERR_FAILED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Writes to standard output and flushes; a failure (closed pipe, full disk) is returned as
/// an error naming standard output, never a panic.
pub fn stdout_write(args: std::fmt::Arguments<'_>) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_fmt(args).and_then(|()| out.flush()).context("cannot write to standard output")
}

/// Writes a note (progress, a warning, guards) to standard error unless `--quiet`; a failure
/// is remembered ([`stderr_failed`]) instead of panicking, so the run can end with status 1.
pub fn stderr_note(args: std::fmt::Arguments<'_>) {
    if !QUIET.load(std::sync::atomic::Ordering::Relaxed) {
        stderr_line(args);
    }
}

/// Notes already given by [`stderr_note_once`].
static SAID: std::sync::Mutex<Vec<&'static str>> = std::sync::Mutex::new(Vec::new());

/// [`stderr_note`] the first time `key` is given in this run, nothing after: a note that would
/// repeat for every file of a folder (an option that does not apply to them, a conversion) is
/// said once.
pub fn stderr_note_once(key: &'static str, args: std::fmt::Arguments<'_>) {
    let mut said = SAID.lock().unwrap_or_else(|e| e.into_inner());
    if !said.contains(&key) {
        said.push(key);
        drop(said);
        stderr_note(args);
    }
}

/// An error and its causes on one line (`context: cause: cause`), line breaks replaced by
/// spaces, a cause left out when the text before it already says it (decoders' errors often
/// repeat their source in their own message).
pub fn one_line(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let part = cause.to_string().replace(['\n', '\r'], " ");
        let part = part.trim().trim_end_matches(['.', ':']).trim();
        if part.is_empty() || text.contains(part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(part);
    }
    text
}

/// Whether a note to standard error failed during this run.
pub fn stderr_failed() -> bool {
    STDERR_FAILED.load(std::sync::atomic::Ordering::Relaxed)
}

#[cfg(test)]
mod tests {
    #[test]
    fn one_line_drops_causes_already_said() {
        let inner = anyhow::anyhow!("Invalid PNG signature.");
        let e = inner
            .context("Format error decoding Png: Invalid PNG signature.")
            .context("a.png is not a valid PNG");
        assert_eq!(
            super::one_line(&e),
            "a.png is not a valid PNG: Format error decoding Png: Invalid PNG signature"
        );
        let e = anyhow::anyhow!("no such file").context("cannot open\nb.png");
        assert_eq!(super::one_line(&e), "cannot open b.png: no such file");
    }
}
