//! `fusion fuse`: fuse one VIS/TIR pair with a chosen method, engine and rescale policy.
//!
//! The core's three methods run on either engine; the study's four host-only methods (GFF,
//! MGFF, TEPGFL, DRIF; [`fusion_reference::study_methods`]) run on the host f64 engine only.

mod args;
mod folders;
mod pair;

pub use args::FuseArgs;

use anyhow::{Result, bail};
use fusion_nostd::methods::Guards;
use pair::fuse_files;

/// Runs `fusion fuse`: one pair, or two folders of pairs.
pub fn run(args: &FuseArgs) -> Result<()> {
    args::check_options(args)?;
    // The inputs first: a missing one is the error to report, not the output's name.
    for (what, path) in [("visible image", &args.vis), ("thermal image", &args.tir)] {
        if !path.exists() {
            bail!("{what}: cannot open {}: no such file or folder", path.display());
        }
    }
    match (args.vis.is_dir(), args.tir.is_dir()) {
        (false, false) => {
            if args.agc_smoothing.is_some() {
                bail!("--agc-smoothing smooths over a sequence: give two folders of frames");
            }
            if args.shutter_dir.is_some() {
                bail!(
                    "--shutter-dir follows a sequence's shutter frames: give two folders (one frame: --shutter)"
                );
            }
            if args.sequence_mode {
                bail!("--sequence-mode carries weights from frame to frame: give two folders of frames");
            }
            if args.jobs.is_some() || args.format.is_some() {
                bail!("--jobs and --format are for folders; one output's format follows its extension");
            }
            fusion_io::folders::check_output_file(&args.output, &[&args.vis, &args.tir])?;
            let (report, guards) = fuse_files(args, &args.vis, &args.tir, None, &args.output, None)?;
            out!("{report}")?;
            if guards != Guards::NONE {
                note!("fusion: guards: {guards} (fusion_nostd::Guards)");
            }
            Ok(())
        }
        (true, true) => folders::run(args),
        (true, false) => bail!(
            "visible image: {} is a folder and the thermal image {} is not: give two files or two folders",
            args.vis.display(),
            args.tir.display()
        ),
        (false, true) => bail!(
            "thermal image: {} is a folder and the visible image {} is not: give two files or two folders",
            args.tir.display(),
            args.vis.display()
        ),
    }
}
