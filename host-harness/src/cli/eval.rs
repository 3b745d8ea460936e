//! `fusion eval`: fusion metrics of a fused image against its two sources — the study's suite,
//! VIFB's 13 metrics exactly as VIFB's code computes them, or both — and noise metrics against a
//! reference. Definitions of every variant: `docs/metrics.md`.

use anyhow::{Result, bail};
use clap::Args;
use fusion_io::{Channels, ColorPolicy, load_channels_u8, load_gray_u8};
use fusion_metrics::noise_metrics;
use fusion_metrics::table::{Format, MetricTable, Suite, score_images};
use std::path::{Path, PathBuf};

/// Arguments of `fusion eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Metric suite (docs/metrics.md lists every variant and the code it follows).
    #[arg(long, value_enum, default_value_t = Suite::Study)]
    pub suite: Suite,
    /// Noise metrics (MSE_S, PSNR_S, SSIM_S) against this reference image too (same size as FUSED).
    #[arg(long, value_name = "REF.png")]
    pub r#ref: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    /// Visible source (rescaled with area to the fused grid if its size differs), or a folder
    /// of them (then TIR and FUSED are folders too, paired by name without extension: a row
    /// per image and the means).
    pub vis: PathBuf,
    /// Thermal source (rescaled with bicubic to the fused grid if its size differs), or a folder.
    pub tir: PathBuf,
    /// Fused image (PNG, JPEG, TIFF or PGM), or a folder.
    pub fused: PathBuf,
}

/// Scores one triple of files (no noise metrics).
fn score(suite: Suite, vis: &Path, tir: &Path, fused: &Path) -> Result<MetricTable> {
    Ok(score_loaded(suite, vis, tir, fused)?.0)
}

/// [`score`], also returning the fused image it decoded (for the noise metrics).
fn score_loaded(suite: Suite, vis: &Path, tir: &Path, fused: &Path) -> Result<(MetricTable, Channels)> {
    let (w, h, channels) = fusion_io::image_header(fused)?;
    let per_px = match suite {
        Suite::Study => fusion_io::memory::per_pixel::EVAL_STUDY,
        Suite::Vifb => fusion_io::memory::per_pixel::EVAL_VIFB,
        Suite::All => fusion_io::memory::per_pixel::EVAL_STUDY + fusion_io::memory::per_pixel::EVAL_VIFB,
    };
    // Per channel (a colour image is scored three times), estimated from the header.
    let bytes = fusion_io::memory::estimate(
        (w as u64).saturating_mul(h as u64).saturating_mul(channels as u64),
        per_px,
    );
    fusion_io::memory::check(&fused.display().to_string(), "scoring this image", bytes)?;
    let fused = load_channels_u8(fused)?;
    Ok((score_images(suite, &load_channels_u8(vis)?, &load_channels_u8(tir)?, &fused)?, fused))
}

/// Runs `fusion eval`: one triple, or three folders of them.
pub fn run(args: &EvalArgs) -> Result<()> {
    let dirs = [&args.vis, &args.tir, &args.fused].map(|p| p.is_dir());
    if dirs.iter().any(|&d| d) {
        if !dirs.iter().all(|&d| d) {
            bail!("give three files or three folders (VIS, TIR, FUSED)");
        }
        return run_folders(args);
    }
    let (mut table, fused) = score_loaded(args.suite, &args.vis, &args.tir, &args.fused)?;
    if let Some(p) = &args.r#ref {
        let fused = fused.to_gray();
        let r = load_gray_u8(p, ColorPolicy::Bt601)?;
        if (r.width, r.height) != (fused.width, fused.height) {
            bail!("reference is {}x{}, the fused image {}x{}", r.width, r.height, fused.width, fused.height);
        }
        table.add_noise(&noise_metrics(&fused, &r), args.suite == Suite::All);
    }
    for (name, v) in &table.rows {
        if v.is_nan() {
            note!(
                "note: {name} is undefined on these images (NaN in the reference code; see docs/metrics.md)"
            );
        }
    }
    out!("{}", table.format(args.format))?;
    Ok(())
}

/// Three folders: a row per triple (paired by name without extension) and the means.
fn run_folders(args: &EvalArgs) -> Result<()> {
    if args.r#ref.is_some() {
        bail!("--ref names one reference image: it works with one triple, not with folders");
    }
    let (triples, unpaired) = fusion_io::folders::pair_by_stem(&[
        (args.vis.as_path(), "visible"),
        (args.tir.as_path(), "thermal"),
        (args.fused.as_path(), "fused"),
    ])?;
    let results = fusion_io::folders::run_all(&triples, 0, "eval", |_, f| {
        score(args.suite, &f[0], &f[1], &f[2]).map(Scored)
    })?;
    let (scored, failed) = fusion_io::folders::split_results(&triples, results, unpaired);
    let scored: Vec<(String, MetricTable)> = scored.into_iter().map(|(s, Scored(t))| (s, t)).collect();
    let tables: Vec<&MetricTable> = scored.iter().map(|(_, t)| t).collect();
    if let Some(mean) = MetricTable::mean(&tables) {
        out!("{}", folder_table(&scored, &mean, args.format))?;
    }
    for (stem, why) in &failed {
        fusion_io::console::stderr_line(format_args!("eval: failed {stem}: {why}"));
    }
    if !failed.is_empty() {
        bail!("{} of {} triples failed (listed above)", failed.len(), failed.len() + scored.len());
    }
    Ok(())
}

/// A triple's table, shown as nothing in the progress lines.
struct Scored(MetricTable);

impl std::fmt::Display for Scored {
    fn fmt(&self, _: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        Ok(())
    }
}

/// The tables of a folder run: a row per triple and a `mean` row (text, CSV), or
/// `{"images": {NAME: …}, "mean": …}` (JSON).
fn folder_table(scored: &[(String, MetricTable)], mean: &MetricTable, format: Format) -> String {
    match format {
        Format::Json => {
            let images: Vec<String> = scored
                .iter()
                .map(|(stem, t)| {
                    format!("{}:{}", serde_json::Value::from(stem.as_str()), t.format(format).trim_end())
                })
                .collect();
            format!("{{\"images\":{{{}}},\"mean\":{}}}\n", images.join(","), mean.format(format).trim_end())
        }
        Format::Csv | Format::Text => {
            let names: Vec<&str> = mean.rows.iter().map(|(n, _)| n.as_str()).collect();
            let mut all: Vec<(&str, &MetricTable)> = scored.iter().map(|(s, t)| (s.as_str(), t)).collect();
            all.push(("mean", mean));
            if format == Format::Csv {
                let mut text = format!("image,{}\n", names.join(","));
                for (stem, t) in all {
                    let csv = t.format(Format::Csv);
                    let values = csv.lines().nth(1).unwrap_or_default();
                    text += &format!("{stem},{values}\n");
                }
                text
            } else {
                let width = all.iter().map(|(s, _)| s.len()).max().unwrap_or(5).max(5);
                let mut text = format!("{:<width$}", "image");
                for n in &names {
                    text += &format!(" {n:>12}");
                }
                text.push('\n');
                for (stem, t) in all {
                    text += &format!("{stem:<width$}");
                    for (_, v) in &t.rows {
                        text += &format!(" {v:>12.4}");
                    }
                    text.push('\n');
                }
                text
            }
        }
    }
}
