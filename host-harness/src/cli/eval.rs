//! `fusion eval`: the study's fusion metrics of a fused image (and noise metrics against a reference).

use crate::io::{ColorPolicy, Gray, load_gray_u8};
use crate::metrics::{FusionMetrics, NoiseMetrics, format_psnr, fusion_metrics, noise_metrics};
use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use fusion_nostd::{Filter, rescale};
use std::path::PathBuf;

/// Output formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Aligned text for people.
    Text,
    /// One header line and one value line.
    Csv,
    /// One JSON object.
    Json,
}

/// Arguments of `fusion eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Noise metrics (MSE_S, PSNR_S, SSIM_S) against this reference image too (same size as FUSED).
    #[arg(long, value_name = "REF.png")]
    pub r#ref: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    /// Visible source (rescaled with area to the fused grid if its size differs).
    pub vis: PathBuf,
    /// Thermal source (rescaled with bicubic to the fused grid if its size differs).
    pub tir: PathBuf,
    /// Fused image.
    pub fused: PathBuf,
}

/// `img` on a `w × h` grid with the core's rescaler (a copy if it already is).
pub fn on_grid(img: &Gray<u8>, w: usize, h: usize, filter: Filter) -> Result<Gray<u8>> {
    if (img.width, img.height) == (w, h) {
        return Ok(img.clone());
    }
    let mut out = Gray::new(w, h);
    rescale(img.view()?, out.view_mut()?, filter)?;
    Ok(out)
}

/// Runs `fusion eval`.
pub fn run(args: &EvalArgs) -> Result<()> {
    let fused = load_gray_u8(&args.fused, ColorPolicy::Bt601)?;
    let (w, h) = (fused.width, fused.height);
    let vis = on_grid(&load_gray_u8(&args.vis, ColorPolicy::Bt601)?, w, h, Filter::Area)?;
    let tir = on_grid(&load_gray_u8(&args.tir, ColorPolicy::Bt601)?, w, h, Filter::Cubic)?;
    let fm = fusion_metrics(&vis, &tir, &fused);
    let nm = match &args.r#ref {
        Some(p) => {
            let r = load_gray_u8(p, ColorPolicy::Bt601)?;
            if (r.width, r.height) != (w, h) {
                bail!("reference is {}x{}, the fused image {w}x{h}", r.width, r.height);
            }
            Some(noise_metrics(&fused, &r))
        }
        None => None,
    };
    print!("{}", format_metrics(&fm, nm.as_ref(), args.format));
    Ok(())
}

/// Formats metrics for printing.
pub fn format_metrics(fm: &FusionMetrics, nm: Option<&NoiseMetrics>, format: Format) -> String {
    let mut names = vec!["AG", "MI", "FMI", "SSIM", "RMSE"];
    let mut values = vec![
        format!("{:.4}", fm.ag),
        format!("{:.4}", fm.mi),
        format!("{:.4}", fm.fmi),
        format!("{:.4}", fm.ssim),
        format!("{:.4}", fm.rmse),
    ];
    if let Some(n) = nm {
        names.extend(["MSE_S", "PSNR_S", "SSIM_S"]);
        values.extend([format!("{:.6}", n.mse_s), format_psnr(n.psnr_s), format!("{:.4}", n.ssim_s)]);
    }
    match format {
        Format::Text => names.iter().zip(&values).map(|(n, v)| format!("{n:<7} {v}\n")).collect(),
        Format::Csv => format!("{}\n{}\n", names.join(","), values.join(",")),
        Format::Json => {
            let fields: Vec<String> = names
                .iter()
                .zip(&values)
                .map(|(n, v)| if v == "inf" { format!("\"{n}\":\"inf\"") } else { format!("\"{n}\":{v}") })
                .collect();
            format!("{{{}}}\n", fields.join(","))
        }
    }
}
