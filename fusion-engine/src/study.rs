//! Running the fusion methods over a rendered dataset: the pieces `fusion demo` and
//! `fusion report` share (the method list, loading a frame pair from a manifest, a timed core
//! fusion, contact sheets).

use crate::CoreScratch;
use anyhow::{Context, Result, anyhow};
use fusion_io::{ColorPolicy, Gray, load_gray_u8};
use fusion_nostd::pipeline::{FuseConfig, FuseReport, Method, RescalePolicy, fusion_grid};
use fusion_nostd::{AdfParams, Guards, IfevipParams, TsifsdParams, Variant};
use render_host::Manifest;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A named method configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NamedMethod {
    /// Short name for tables and file names (`adf`, `tsifsd-classic`, …).
    pub name: &'static str,
    /// The core configuration.
    pub method: Method,
}

/// The methods the core carries, as the study's tables list them: ADF (flight), TSIFSD in both
/// variants (the flight saliency changes the result), IFEVIP (flight).
pub fn core_methods() -> Vec<NamedMethod> {
    vec![
        NamedMethod { name: "adf", method: Method::Adf(AdfParams::default()) },
        NamedMethod {
            name: "tsifsd-classic",
            method: Method::Tsifsd(TsifsdParams { variant: Variant::Classic, ..TsifsdParams::default() }),
        },
        NamedMethod { name: "tsifsd", method: Method::Tsifsd(TsifsdParams::default()) },
        NamedMethod { name: "ifevip", method: Method::Ifevip(IfevipParams::default()) },
    ]
}

/// A rendered dataset on disk: its folder and manifest.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// The dataset folder (holds `manifest.json`).
    pub dir: PathBuf,
    /// The parsed manifest.
    pub manifest: Manifest,
}

impl Dataset {
    /// Opens `dir/manifest.json`.
    pub fn open(dir: &Path) -> Result<Self> {
        let path = dir.join("manifest.json");
        let text =
            std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
        let manifest =
            serde_json::from_str(&text).with_context(|| format!("bad manifest {}", path.display()))?;
        Ok(Self { dir: dir.to_path_buf(), manifest })
    }

    /// Frame `frame` of set `set` (e.g. `vis_light`, `tir512`), the noisy or the clean version.
    pub fn image(&self, set: &str, frame: usize, noisy: bool) -> Result<Gray<u8>> {
        let info =
            self.manifest.frames.get(frame).ok_or_else(|| anyhow!("no frame {frame} in the dataset"))?;
        let files = info.files.get(set).ok_or_else(|| anyhow!("no set {set} in the dataset"))?;
        let rel = if noisy { &files.noisy } else { &files.clean };
        let rel = rel.as_ref().ok_or_else(|| anyhow!("set {set} has no {} images", version(noisy)))?;
        load_gray_u8(&self.dir.join(rel), ColorPolicy::Refuse)
    }

    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.manifest.frames.len()
    }
}

/// `"noisy"` or `"clean"`.
pub fn version(noisy: bool) -> &'static str {
    if noisy { "noisy" } else { "clean" }
}

/// One core fusion with its timing.
#[derive(Debug, Clone)]
pub struct TimedFusion {
    /// The fused frame.
    pub fused: Gray<u8>,
    /// Median wall time of the repeats, seconds (rescale + fusion, scratch allocated outside).
    pub seconds: f64,
    /// Guards the core fired.
    pub guards: Guards,
    /// The core's whole report (grid, rescale, guards, skips) of the last repeat.
    pub report: FuseReport,
}

/// Fuses `vis` and `tir` with the core pipeline `repeats` times (at least once) and keeps the
/// median time.
pub fn fuse_timed(
    vis: &Gray<u8>,
    tir: &Gray<u8>,
    pipeline: &FuseConfig,
    repeats: usize,
) -> Result<TimedFusion> {
    let (vs, ts) = ((vis.width, vis.height), (tir.width, tir.height));
    let (w, h) = fusion_grid(vs, ts, pipeline.rescale)?;
    let mut scratch = CoreScratch::new(pipeline.scratch_pixels(vs, ts)?);
    let mut fused = Gray::new(w, h);
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        let report = fusion_nostd::pipeline::fuse(
            vis.view()?,
            tir.view()?,
            fused.view_mut()?,
            &mut scratch.view_mut(),
            pipeline,
        )?;
        times.push(t.elapsed().as_secs_f64());
        last = Some(report);
    }
    let report = last.context("no fusion ran")?;
    Ok(TimedFusion { fused, seconds: median(&mut times), guards: report.guards, report })
}

/// The median of `v` (0 for an empty slice); sorts `v`.
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => 0.0,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// The grid a policy fuses on for a VIS/TIR size pair (re-exported for the CLI verbs).
pub fn grid(vis: &Gray<u8>, tir: &Gray<u8>, policy: RescalePolicy) -> Result<(usize, usize)> {
    Ok(fusion_grid((vis.width, vis.height), (tir.width, tir.height), policy)?)
}

/// The synthetic `n × n` scene of the criterion benches and the callgrind example: a smooth
/// bright blob over texture, different per `seed` (so the two bands differ and the quadtree,
/// the saliencies and the KL weights have work to do; a constant frame would flatter a method).
pub fn bench_frame(n: usize, seed: usize) -> Vec<u8> {
    (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            let (dx, dy) = (x as f64 - n as f64 * 0.4, y as f64 - n as f64 * 0.55);
            let blob = 180.0 * (-(dx * dx + dy * dy) / (0.02 * (n * n) as f64)).exp();
            let texture = ((x * 7 + y * 13 + seed) ^ (i.wrapping_mul(2654435761) >> 7)) % 23;
            (blob + 20.0 + texture as f64 + (x * seed % 31) as f64).min(255.0) as u8
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut []), 0.0);
    }
}
