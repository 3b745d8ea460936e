//! `fusion rescale`: the core's rescalers on an image file (PNG, JPEG, TIFF or PGM in; PNG, TIFF or PGM out).

use anyhow::{Result, bail};
use clap::Args;
use fusion_engine::methods::FilterArg;
use fusion_io::{ColorPolicy, Gray, GrayInput, load_image, save_gray_u8, save_gray_u16};
use fusion_nostd::{Filter, rescale};
use std::path::PathBuf;

/// Arguments of `fusion rescale`.
#[derive(Debug, Args)]
pub struct RescaleArgs {
    /// Interpolation filter.
    #[arg(long, value_enum, default_value_t = FilterArg::Cubic)]
    pub filter: FilterArg,
    /// Output width in pixels.
    #[arg(long)]
    pub width: usize,
    /// Output height in pixels.
    #[arg(long)]
    pub height: usize,
    /// Input image (PNG, JPEG, TIFF or PGM; 8-bit or 16-bit grey).
    pub input: PathBuf,
    /// Output (.png, .tif/.tiff or .pgm, by the extension; same bit depth as the input).
    pub output: PathBuf,
}

fn rescaled<T: fusion_nostd::Sample + Default>(
    src: &Gray<T>,
    w: usize,
    h: usize,
    filter: Filter,
) -> Result<Gray<T>> {
    let mut out = Gray::new(w, h);
    rescale(src.view()?, out.view_mut()?, filter)?;
    Ok(out)
}

/// Runs `fusion rescale`.
pub fn run(args: &RescaleArgs) -> Result<()> {
    fusion_io::OutFormat::of(&args.output)?;
    if args.width == 0 || args.height == 0 {
        bail!("the requested size {}x{} has a zero side", args.width, args.height);
    }
    if args.width.max(args.height) > fusion_nostd::MAX_DIMENSION {
        bail!(
            "the requested size {}x{} exceeds the largest side the core accepts ({})",
            args.width,
            args.height,
            fusion_nostd::MAX_DIMENSION
        );
    }
    let filter = Filter::from(args.filter);
    // The output (and its encoded copy) at up to 2 bytes a sample; the input is judged by its
    // header when it is decoded.
    let out_px = (args.width as u64).saturating_mul(args.height as u64);
    let bytes = fusion_io::memory::estimate(out_px, 2 * fusion_io::memory::per_pixel::DECODE);
    fusion_io::memory::check(&args.input.display().to_string(), "rescaling to this size", bytes)?;
    match load_image(&args.input, ColorPolicy::Refuse)? {
        GrayInput::U8(src) => save_gray_u8(&args.output, &rescaled(&src, args.width, args.height, filter)?),
        GrayInput::U16(src) => save_gray_u16(&args.output, &rescaled(&src, args.width, args.height, filter)?),
    }
}
