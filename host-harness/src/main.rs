//! `fusion`: the host command-line tool of the VIS/TIR fusion project. Flags and verbs only:
//! each verb (`cli/`) parses its options and calls the library crates (`fusion-io`,
//! `fusion-engine`, `fusion-metrics`, `fusion-reference`, `fusion-report`, `render-host`,
//! `fusion-navbench`, `fusion-budget`), which hold the work.

// `out!`, `outln!`, `note!`: printing that returns errors instead of panicking.
#[macro_use]
extern crate fusion_io;

mod cli;

/// Whether standard output was closed when the process started (`fusion … >&-`).
static STDOUT_WAS_CLOSED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Runs before Rust's runtime (from `.init_array`, as the C library starts the program), which
/// reopens a closed standard output on `/dev/null`: a summary printed there would vanish while
/// the run exits 0, so whether it was closed is recorded first and the run refused in `main`.
#[cfg(target_os = "linux")]
extern "C" fn record_closed_stdout() {
    // SAFETY: fcntl(F_GETFD) on a descriptor number only reads its flags; -1 means not open.
    if unsafe { libc::fcntl(libc::STDOUT_FILENO, libc::F_GETFD) } == -1 {
        STDOUT_WAS_CLOSED.store(true, std::sync::atomic::Ordering::Relaxed);
    }
}

#[cfg(target_os = "linux")]
#[used]
#[unsafe(link_section = ".init_array")]
static RECORD_CLOSED_STDOUT: extern "C" fn() = record_closed_stdout;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    // A panic is a bug, but the user still gets one line, not a backtrace (set
    // FUSION_BACKTRACE=1 for one); the exit status is then 101.
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let at = info.location().map(|l| format!(" at {}:{}", l.file(), l.line())).unwrap_or_default();
        // Printed whatever `--quiet` says: it silences notes, not errors.
        fusion_io::console::stderr_line(format_args!(
            "fusion: internal error: {}{at}",
            msg.replace('\n', " ")
        ));
        if std::env::var_os("FUSION_BACKTRACE").is_some_and(|v| v == "1") {
            fusion_io::console::stderr_line(format_args!("{}", std::backtrace::Backtrace::force_capture()));
        }
    }));
    // SIGINT/SIGTERM/SIGHUP remove the outputs being written (fusion_io::output).
    fusion_io::output::remove_in_flight_on_signal();
    if STDOUT_WAS_CLOSED.load(std::sync::atomic::Ordering::Relaxed) {
        fusion_io::console::stderr_line(format_args!(
            "fusion: error: standard output is closed; give it somewhere to go (>/dev/null to discard it)"
        ));
        return ExitCode::FAILURE;
    }
    let cli = cli::Cli::parse();
    fusion_io::console::set_quiet(cli.quiet);
    match cli::run(cli) {
        // A note that could not reach standard error fails the run too.
        Ok(()) if fusion_io::console::stderr_failed() => ExitCode::FAILURE,
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line, whatever the underlying messages hold, and whatever `--quiet` says.
            fusion_io::console::stderr_line(format_args!(
                "fusion: error: {}",
                fusion_io::console::one_line(&e)
            ));
            ExitCode::FAILURE
        }
    }
}
