//! `fusion render` without the rest of the harness: the same arguments, the same output.
//!
//! ```sh
//! cargo run --release -p render-host --example render -- --out DIR [--frames 20] [--seed S]
//! ```

use clap::Parser;

/// Renders a VIS/TIR dataset of a spacecraft target (see `fusion render --help`).
#[derive(Parser)]
#[command(name = "render")]
struct Cli {
    #[command(flatten)]
    args: render_host::cli::RenderArgs,
}

fn main() -> anyhow::Result<()> {
    render_host::cli::run(&Cli::parse().args)
}
