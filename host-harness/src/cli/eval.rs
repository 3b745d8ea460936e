//! `fusion eval`: fusion metrics of a fused image against its two sources — the study's suite,
//! VIFB's 13 metrics exactly as VIFB's code computes them, or both — and noise metrics against a
//! reference. Definitions of every variant: `docs/metrics.md`.

use crate::io::{Channels, ColorPolicy, Gray, load_channels_u8, load_gray_u8};
use crate::metrics::vifb::{self, VifbMetrics};
use crate::metrics::{
    FusionMetrics, HaghighatFeature, NoiseMetrics, fmi_haghighat, format_psnr, fusion_metrics, noise_metrics,
};
use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use fusion_nostd::Filter;
use std::path::{Path, PathBuf};

/// Output formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Aligned text for people (values rounded).
    Text,
    /// One header line and one value line (full precision: every value round-trips).
    Csv,
    /// One JSON object (full precision; an undefined value is `null`).
    Json,
}

/// Which metrics to compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Suite {
    /// The study's: AG, MI (bits), FMI (Fast-FMI, Sobel), SSIM, RMSE — plus Haghighat's
    /// FMI_pixel and FMI_gradient. On grey images (a colour input is converted with BT.601).
    Study,
    /// VIFB's 13 as its MATLAB code computes them: AG, CE, EI, EN, MI, PSNR, Qabf, Qcb, Qcv,
    /// RMSE, SF, SSIM, SD. Colour images per channel, as VIFB does.
    Vifb,
    /// Both (keys prefixed `study.` / `vifb.` in text and CSV, nested objects in JSON).
    All,
}

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

/// Every channel of `img` on a `w × h` grid.
fn channels_on_grid(img: &Channels, w: usize, h: usize, filter: Filter) -> Result<Channels> {
    let planes = (0..img.planes.len())
        .map(|k| Ok(crate::study::source_on_grid(&img.plane(k), (w, h), filter)?.data))
        .collect::<Result<Vec<_>>>()?;
    Ok(Channels { width: w, height: h, planes })
}

/// The study suite: [`FusionMetrics`] and Haghighat's two FMIs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StudyMetrics {
    /// AG, MI, FMI (Fast-FMI), SSIM, RMSE as the study's tables report them.
    pub fusion: FusionMetrics,
    /// Haghighat's `fmi.m`, raw pixels, window 3.
    pub fmi_pixel: f64,
    /// Haghighat's `fmi.m`, MATLAB `gradient` features, window 3.
    pub fmi_gradient: f64,
}

/// Computes the study suite (sources already on the fused grid).
pub fn study_metrics(vis: &Gray<u8>, tir: &Gray<u8>, fused: &Gray<u8>) -> StudyMetrics {
    StudyMetrics {
        fusion: fusion_metrics(vis, tir, fused),
        fmi_pixel: fmi_haghighat(vis, tir, fused, HaghighatFeature::Pixels),
        fmi_gradient: fmi_haghighat(vis, tir, fused, HaghighatFeature::Gradient),
    }
}

/// Scores one triple of files (no noise metrics).
fn score(suite: Suite, vis: &Path, tir: &Path, fused: &Path) -> Result<MetricTable> {
    Ok(score_loaded(suite, vis, tir, fused)?.0)
}

/// [`score`], also returning the fused image it decoded (for the noise metrics).
fn score_loaded(suite: Suite, vis: &Path, tir: &Path, fused: &Path) -> Result<(MetricTable, Channels)> {
    let (w, h, channels) = crate::io::image_header(fused)?;
    let per_px = match suite {
        Suite::Study => crate::memory::per_pixel::EVAL_STUDY,
        Suite::Vifb => crate::memory::per_pixel::EVAL_VIFB,
        Suite::All => crate::memory::per_pixel::EVAL_STUDY + crate::memory::per_pixel::EVAL_VIFB,
    };
    // Per channel (a colour image is scored three times), estimated from the header.
    let bytes =
        crate::memory::estimate((w as u64).saturating_mul(h as u64).saturating_mul(channels as u64), per_px);
    crate::memory::check(&fused.display().to_string(), "scoring this image", bytes)?;
    let fused = load_channels_u8(fused)?;
    Ok((score_images(suite, &load_channels_u8(vis)?, &load_channels_u8(tir)?, &fused)?, fused))
}

/// Scores one triple of images (grey: one plane; colour: three): the sources are brought onto
/// the fused grid (VIS area, TIR bicubic) when their sizes differ. `fusion eval` and the Python
/// package (`vistir.eval`) both score here.
pub fn score_images(suite: Suite, vis: &Channels, tir: &Channels, fused: &Channels) -> Result<MetricTable> {
    let (w, h) = (fused.width, fused.height);
    let vis = channels_on_grid(vis, w, h, Filter::Area)?;
    let tir = channels_on_grid(tir, w, h, Filter::Cubic)?;
    let study = matches!(suite, Suite::Study | Suite::All)
        .then(|| study_metrics(&vis.to_gray(), &tir.to_gray(), &fused.to_gray()));
    let vifb = match suite {
        Suite::Vifb | Suite::All => Some(vifb::vifb_metrics(&vis, &tir, fused)?),
        Suite::Study => None,
    };
    Ok(MetricTable::new(study.as_ref(), vifb.as_ref(), suite == Suite::All))
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
    let (triples, unpaired) = crate::folders::pair_by_stem(&[
        (args.vis.as_path(), "visible"),
        (args.tir.as_path(), "thermal"),
        (args.fused.as_path(), "fused"),
    ])?;
    let results = crate::folders::run_all(&triples, 0, "eval", |_, f| {
        score(args.suite, &f[0], &f[1], &f[2]).map(Scored)
    })?;
    let (scored, failed) = crate::folders::split_results(&triples, results, unpaired);
    let scored: Vec<(String, MetricTable)> = scored.into_iter().map(|(s, Scored(t))| (s, t)).collect();
    if let Some((_, first)) = scored.first() {
        let n = scored.len() as f64;
        let means: Vec<(String, f64)> = first
            .rows
            .iter()
            .enumerate()
            .map(|(k, (name, _))| (name.clone(), scored.iter().map(|(_, t)| t.rows[k].1).sum::<f64>() / n))
            .collect();
        let mean = MetricTable { rows: means, groups: first.groups.clone() };
        out!("{}", folder_table(&scored, &mean, args.format))?;
    }
    for (stem, why) in &failed {
        render_host::output::stderr_line(format_args!("eval: failed {stem}: {why}"));
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

/// Named metric values in print order, with the suite each belongs to.
pub struct MetricTable {
    /// `(name, value)`; names carry a `suite.` prefix when several suites share a key.
    pub rows: Vec<(String, f64)>,
    groups: Vec<(&'static str, std::ops::Range<usize>)>,
}

impl MetricTable {
    /// Appends the noise metrics as their own group.
    pub fn add_noise(&mut self, n: &NoiseMetrics, prefixed: bool) {
        let start = self.rows.len();
        for (k, v) in [("MSE_S", n.mse_s), ("PSNR_S", n.psnr_s), ("SSIM_S", n.ssim_s)] {
            self.rows.push((if prefixed { format!("noise.{k}") } else { k.to_string() }, v));
        }
        self.groups.push(("noise", start..self.rows.len()));
    }
}

impl MetricTable {
    /// The rows of the suites given; `prefixed` names them `study.AG`, `vifb.AG`, …. The noise
    /// metrics are added with [`MetricTable::add_noise`].
    pub fn new(study: Option<&StudyMetrics>, vifb: Option<&VifbMetrics>, prefixed: bool) -> Self {
        let mut rows = Vec::new();
        let mut groups = Vec::new();
        let mut group = |suite: &'static str, values: Vec<(&str, f64)>, rows: &mut Vec<(String, f64)>| {
            let start = rows.len();
            for (k, v) in values {
                rows.push((if prefixed { format!("{suite}.{k}") } else { k.to_string() }, v));
            }
            groups.push((suite, start..rows.len()));
        };
        if let Some(s) = study {
            let f = &s.fusion;
            let values = vec![
                ("AG", f.ag),
                ("MI", f.mi),
                ("FMI", f.fmi),
                ("FMI_pixel", s.fmi_pixel),
                ("FMI_gradient", s.fmi_gradient),
                ("SSIM", f.ssim),
                ("RMSE", f.rmse),
            ];
            group("study", values, &mut rows);
        }
        if let Some(v) = vifb {
            group("vifb", vifb::KEYS.iter().copied().zip(v.values()).collect(), &mut rows);
        }
        Self { rows, groups }
    }

    /// The table in `format`: text rounds for reading, CSV and JSON keep every bit.
    pub fn format(&self, format: Format) -> String {
        let full = |v: f64| {
            if v.is_nan() {
                "nan".to_string()
            } else if v.is_infinite() {
                if v > 0.0 { "inf" } else { "-inf" }.to_string()
            } else {
                format!("{v:?}")
            }
        };
        match format {
            Format::Text => self
                .rows
                .iter()
                .map(|(n, v)| {
                    let shown = if n.ends_with("PSNR_S") {
                        format_psnr(*v)
                    } else if n.ends_with("MSE_S") {
                        format!("{v:.6}")
                    } else if v.is_finite() {
                        format!("{v:.4}")
                    } else {
                        full(*v)
                    };
                    format!("{n:<18} {shown}\n")
                })
                .collect(),
            Format::Csv => {
                let names: Vec<&str> = self.rows.iter().map(|(n, _)| n.as_str()).collect();
                let values: Vec<String> = self.rows.iter().map(|(_, v)| full(*v)).collect();
                format!("{}\n{}\n", names.join(","), values.join(","))
            }
            Format::Json => {
                // Keys in print order; infinite PSNR is the string "inf" (JSON has no
                // infinity), NaN is null; finite values in serde_json's round-trip form.
                let json = |v: f64| -> String {
                    if v.is_infinite() {
                        format!("\"{}\"", full(v))
                    } else {
                        serde_json::Number::from_f64(v).map_or("null".to_string(), |n| n.to_string())
                    }
                };
                let object = |range: std::ops::Range<usize>, strip: bool| -> String {
                    let fields: Vec<String> = self.rows[range]
                        .iter()
                        .map(|(n, v)| {
                            let key =
                                if strip { n.split_once('.').map_or(n.as_str(), |(_, k)| k) } else { n };
                            format!("\"{key}\":{}", json(*v))
                        })
                        .collect();
                    format!("{{{}}}", fields.join(","))
                };
                let prefixed = self.rows.first().is_some_and(|(n, _)| n.contains('.'));
                let value = if prefixed {
                    let fields: Vec<String> = self
                        .groups
                        .iter()
                        .map(|(suite, range)| format!("\"{suite}\":{}", object(range.clone(), true)))
                        .collect();
                    format!("{{{}}}", fields.join(","))
                } else {
                    object(0..self.rows.len(), false)
                };
                format!("{value}\n")
            }
        }
    }
}
