//! `fusion eval`: fusion metrics of a fused image against its two sources — the study's suite,
//! VIFB's 13 metrics exactly as VIFB's code computes them, or both — and noise metrics against a
//! reference. Definitions of every variant: `docs/metrics.md`.

use crate::cli::agc::AgcChoice;
use anyhow::{Context, Result, bail};
use clap::Args;
use fusion_io::{Channels, ColorPolicy, Picture, load_channels_u8, load_gray_u8};
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
    /// A 14/16-bit thermal source is scored through the core AGC as `fusion fuse` maps it
    /// before fusing (give the same `--agc`/`--plateau` as the fuse run did).
    #[command(flatten)]
    pub thermal_agc: crate::cli::agc::AgcChoice,
    /// Visible source (rescaled with area to the fused grid if its size differs), or a folder
    /// of them (then TIR and FUSED are folders too, paired by name without extension: a row
    /// per image and the means).
    pub vis: PathBuf,
    /// Thermal source (rescaled with bicubic to the fused grid if its size differs; 14/16-bit
    /// counts through the AGC, --agc), or a folder.
    pub tir: PathBuf,
    /// Fused image (PNG, JPEG, TIFF or PGM), or a folder.
    pub fused: PathBuf,
}

/// Scores one triple of files (no noise metrics).
fn score(args: &EvalArgs, vis: &Path, tir: &Path, fused: &Path) -> Result<MetricTable> {
    Ok(score_loaded(args, vis, tir, fused)?.0)
}

/// The thermal source in 8 bits: 14/16-bit counts through the core AGC, as `fusion fuse` maps
/// them before fusing (one frame, no temporal smoothing).
fn load_thermal(path: &Path, agc: &AgcChoice) -> Result<Channels> {
    match fusion_io::load_picture(path)? {
        Picture::Gray16(counts) => {
            fusion_io::console::stderr_note_once(
                "eval: 16-bit thermal",
                format_args!(
                    "fusion: note: {} holds 14/16-bit counts: scored through the core AGC ({}) as fusion fuse maps them; a fuse run with --agc-smoothing or a thermal front end mapped them otherwise",
                    path.display(),
                    if agc.given() { "as --agc/--plateau ask" } else { "linear, fuse's default" }
                ),
            );
            let params = agc.params(0, counts.width * counts.height);
            let mapped = fusion_engine::agc::map_counts(&mut fusion_engine::agc::fresh(), &counts, &params)
                .with_context(|| format!("thermal image {}: AGC", path.display()))?;
            Ok(Channels::from_gray(mapped))
        }
        Picture::Gray8(g) => {
            if agc.given() {
                fusion_io::console::stderr_note_once(
                    "eval: 8-bit thermal with --agc",
                    format_args!(
                        "fusion: note: {} is 8-bit: --agc and --plateau apply to 14/16-bit counts and are not used",
                        path.display()
                    ),
                );
            }
            Ok(Channels::from_gray(g))
        }
        Picture::Rgb8(c) => Ok(c),
    }
}

/// [`score`], also returning the fused image it decoded (for the noise metrics).
fn score_loaded(args: &EvalArgs, vis: &Path, tir: &Path, fused: &Path) -> Result<(MetricTable, Channels)> {
    let suite = args.suite;
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
    Ok((score_images(suite, &load_channels_u8(vis)?, &load_thermal(tir, &args.thermal_agc)?, &fused)?, fused))
}

/// Runs `fusion eval`: one triple, or three folders of them.
pub fn run(args: &EvalArgs) -> Result<()> {
    args.thermal_agc.check()?;
    let dirs = [&args.vis, &args.tir, &args.fused].map(|p| p.is_dir());
    if dirs.iter().any(|&d| d) {
        if !dirs.iter().all(|&d| d) {
            bail!("give three files or three folders (VIS, TIR, FUSED)");
        }
        return run_folders(args);
    }
    let (mut table, fused) = score_loaded(args, &args.vis, &args.tir, &args.fused)?;
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
        score(args, &f[0], &f[1], &f[2]).map(Scored)
    })?;
    let (scored, failed) = fusion_io::folders::split_results(&triples, results, unpaired);
    let scored: Vec<(String, MetricTable)> = scored.into_iter().map(|(s, Scored(t))| (s, t)).collect();
    let tables: Vec<&MetricTable> = scored.iter().map(|(_, t)| t).collect();
    if let Some(mean) = MetricTable::mean(&tables) {
        out!("{}", folder_table(&scored, &mean, args.format))?;
        // A metric undefined on some image makes its mean undefined too (as MATLAB's `mean`
        // in the reference code): said, with the images.
        for (k, (metric, m)) in mean.rows.iter().enumerate() {
            if m.is_nan() {
                let undefined: Vec<&str> =
                    scored.iter().filter(|(_, t)| t.rows[k].1.is_nan()).map(|(s, _)| s.as_str()).collect();
                let shown = undefined.iter().take(5).copied().collect::<Vec<_>>().join(", ");
                let more = if undefined.len() > 5 {
                    format!(" and {} more", undefined.len() - 5)
                } else {
                    String::new()
                };
                note!(
                    "note: the mean of {metric} is NaN: it is undefined on {} of {} images ({shown}{more}; see docs/metrics.md)",
                    undefined.len(),
                    scored.len()
                );
            }
        }
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

/// The tables of a folder run: CSV `row,image,METRICS…` with a line `image,NAME,…` per triple
/// (names quoted as RFC 4180 asks) and `mean,,…`; text, a line per triple, a rule and `mean of N`;
/// JSON `{"images": {NAME: …}, "mean": …}`.
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
        Format::Csv => {
            // `row` says what the line is, so an image named `mean` is still an image row.
            let names: Vec<&str> = mean.rows.iter().map(|(n, _)| n.as_str()).collect();
            let mut text = format!("row,image,{}\n", names.join(","));
            let values =
                |t: &MetricTable| t.format(Format::Csv).lines().nth(1).unwrap_or_default().to_string();
            for (stem, t) in scored {
                text += &format!("image,{},{}\n", csv_field(stem), values(t));
            }
            text += &format!("mean,,{}\n", values(mean));
            text
        }
        Format::Text => {
            let names: Vec<&str> = mean.rows.iter().map(|(n, _)| n.as_str()).collect();
            let label = format!("mean of {}", scored.len());
            let width =
                scored.iter().map(|(s, _)| s.chars().count()).chain([label.len(), 5]).max().unwrap_or(5);
            let mut text = format!("{:<width$}", "image");
            for n in &names {
                text += &format!(" {n:>12}");
            }
            text.push('\n');
            let row = |text: &mut String, name: &str, t: &MetricTable| {
                *text += &format!("{name:<width$}");
                for (_, v) in &t.rows {
                    *text += &format!(" {v:>12.4}");
                }
                text.push('\n');
            };
            for (stem, t) in scored {
                // One line per image whatever its name holds.
                row(&mut text, &stem.replace(['\n', '\r'], " "), t);
            }
            text += &"-".repeat(width + 13 * names.len());
            text.push('\n');
            row(&mut text, &label, mean);
            text
        }
    }
}

/// A CSV field (RFC 4180): quoted, with inner quotes doubled, when it holds a comma, a quote,
/// a line break or leading/trailing spaces.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.trim() != s {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::csv_field;

    #[test]
    fn csv_fields_are_quoted_when_they_must_be() {
        assert_eq!(csv_field("frame_1"), "frame_1");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
        assert_eq!(csv_field("two\nlines"), "\"two\nlines\"");
        assert_eq!(csv_field(" padded"), "\" padded\"");
    }
}
