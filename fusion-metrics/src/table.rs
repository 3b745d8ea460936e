//! One call scores a fused image against its sources: [`score_images`] with a [`Suite`] (the
//! study's, VIFB's 13, or both) gives a [`MetricTable`], printed as text, CSV or JSON
//! ([`Format`]). `fusion eval` and the Python package (`vistir.eval`) both score here.

use crate::vifb::{self, VifbMetrics};
use crate::{FusionMetrics, HaghighatFeature, NoiseMetrics, fmi_haghighat, format_psnr, fusion_metrics};
use anyhow::Result;
use fusion_io::{Channels, Gray};
use fusion_nostd::Filter;

/// Output formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Format {
    /// Aligned text for people (values rounded).
    Text,
    /// One header line and one value line (full precision: every value round-trips).
    Csv,
    /// One JSON object (full precision; an undefined value is `null`).
    Json,
}

/// Which metrics to compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
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

/// Every channel of `img` on a `w × h` grid.
fn channels_on_grid(img: &Channels, w: usize, h: usize, filter: Filter) -> Result<Channels> {
    let planes = (0..img.planes.len())
        .map(|k| Ok(fusion_io::source_on_grid(&img.plane(k), (w, h), filter)?.data))
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

/// Named metric values in print order, with the suite each belongs to.
pub struct MetricTable {
    /// `(name, value)`; names carry a `suite.` prefix when several suites share a key.
    pub rows: Vec<(String, f64)>,
    groups: Vec<(&'static str, std::ops::Range<usize>)>,
}

impl MetricTable {
    /// The mean of each row over `tables` (all of one suite, as a folder run scores them); `None`
    /// for no tables.
    pub fn mean(tables: &[&MetricTable]) -> Option<MetricTable> {
        let first = tables.first()?;
        let n = tables.len() as f64;
        let rows = first
            .rows
            .iter()
            .enumerate()
            .map(|(k, (name, _))| (name.clone(), tables.iter().map(|t| t.rows[k].1).sum::<f64>() / n))
            .collect();
        Some(MetricTable { rows, groups: first.groups.clone() })
    }

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
