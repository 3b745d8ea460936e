//! The renderer without the `fusion` CLI: a dataset in the study's layout, or a rendezvous
//! sequence, into a new folder.
//!
//! ```sh
//! cargo run --release -p render-host --example render -- OUT_DIR [approach|flyaround]
//! ```

use render_host::RenderOptions;
use render_host::sequence::SequenceName;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let Some(out) = args.next() else { anyhow::bail!("usage: render OUT_DIR [approach|flyaround]") };
    let sequence = match args.next().as_deref() {
        None => None,
        Some("approach") => Some(SequenceName::Approach),
        Some("flyaround") => Some(SequenceName::Flyaround),
        Some(other) => anyhow::bail!("unknown sequence {other}: approach or flyaround"),
    };
    let options = RenderOptions { out: out.into(), sequence, frames: Some(4), ..RenderOptions::default() };
    println!("{}", render_host::render(&options)?);
    Ok(())
}
