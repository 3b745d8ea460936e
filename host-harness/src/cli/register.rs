//! `fusion register`: a thermal image of an offset camera pair warped onto the visible grid
//! (`fusion_nostd::registration`), to look at before fusing.

use anyhow::{Result, bail};
use clap::Args;
use fusion_engine::registration::{BorderArg, InterpolationArg, register};
use fusion_io::{ColorPolicy, GrayInput, load_image, save_gray_u8, save_gray_u16};
use std::path::PathBuf;

/// Arguments of `fusion register`.
#[derive(Debug, Args)]
pub struct RegisterArgs {
    /// The camera pair's calibration: OpenCV `FileStorage` YAML or JSON with
    /// `camera_matrix_vis`, `dist_coeffs_vis`, `image_size_vis`, the same with `_tir`, `R`, `T`
    /// (`stereoCalibrate`'s convention: camera 1 = VIS, `X_tir = R·X_vis + T`, metres).
    #[arg(long, value_name = "FILE")]
    pub rig: PathBuf,
    /// Range of the target plane along the visible optical axis, metres.
    #[arg(long, value_name = "METRES")]
    pub range: f64,
    /// Interpolation.
    #[arg(long, value_enum, default_value_t = InterpolationArg::Linear)]
    pub interp: InterpolationArg,
    /// Where the thermal camera did not see: a constant (`--border-value`) or the nearest edge.
    #[arg(long, value_enum, default_value_t = BorderArg::Constant)]
    pub border: BorderArg,
    /// The constant of `--border constant` (0: cold space).
    #[arg(long, default_value_t = 0, value_name = "LEVEL")]
    pub border_value: u16,
    /// Thermal image of the rig's thermal size (PNG, TIFF, PGM; 8- or 16-bit grey).
    pub tir: PathBuf,
    /// Output: the thermal image on the visible grid (.png, .tif/.tiff or .pgm; same bit depth).
    pub output: PathBuf,
}

/// Runs `fusion register`.
pub fn run(args: &RegisterArgs) -> Result<()> {
    fusion_io::OutFormat::of(&args.output)?;
    if !(args.range.is_finite() && args.range > 0.0) {
        bail!("--range must be a positive number of metres, not {}", args.range);
    }
    let rig = fusion_io::rig::read(&args.rig)?;
    let (interp, border) = (args.interp.into(), args.border.with_value(args.border_value));
    let out_px = (rig.vis.width * rig.vis.height) as u64;
    let bytes = fusion_io::memory::estimate(out_px, 2 * fusion_io::memory::per_pixel::DECODE);
    fusion_io::memory::check(&args.tir.display().to_string(), "registering onto the visible grid", bytes)?;
    match load_image(&args.tir, ColorPolicy::Refuse)? {
        GrayInput::U8(tir) => save_gray_u8(&args.output, &register(&tir, &rig, args.range, interp, border)?),
        GrayInput::U16(tir) => {
            save_gray_u16(&args.output, &register(&tir, &rig, args.range, interp, border)?)
        }
    }
}
