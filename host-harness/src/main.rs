//! `fusion`: the host command-line tool of the VIS/TIR fusion project.

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
        render_host::output::stderr_note(format_args!(
            "fusion: internal error: {}{at}",
            msg.replace('\n', " ")
        ));
        if std::env::var_os("FUSION_BACKTRACE").is_some_and(|v| v == "1") {
            render_host::output::stderr_line(format_args!("{}", std::backtrace::Backtrace::force_capture()));
        }
    }));
    // SIGINT/SIGTERM remove the outputs being written (render_host::output).
    render_host::output::remove_in_flight_on_signal();
    let cli = host_harness::cli::Cli::parse();
    render_host::output::set_quiet(cli.quiet);
    match host_harness::cli::run(cli) {
        // A note that could not reach standard error fails the run too.
        Ok(()) if render_host::output::stderr_failed() => ExitCode::FAILURE,
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line, whatever the underlying messages hold.
            render_host::output::stderr_note(format_args!(
                "fusion: error: {}",
                format!("{e:#}").replace('\n', " ")
            ));
            ExitCode::FAILURE
        }
    }
}
