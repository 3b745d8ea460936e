//! `fusion`: the host command-line tool of the VIS/TIR fusion project.

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = host_harness::cli::Cli::parse();
    match host_harness::cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fusion: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
