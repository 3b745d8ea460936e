//! Running the fusion methods over a rendered dataset: the pieces `fusion demo` and
//! `fusion report` share (the method list, loading a frame pair from a manifest, a timed core
//! fusion, contact sheets).

use crate::CoreScratch;
use crate::io::{ColorPolicy, Gray, load_gray_u8};
use anyhow::{Context, Result, anyhow};
use fusion_nostd::pipeline::{FuseConfig, FuseReport, Method, RescalePolicy, fusion_grid};
use fusion_nostd::{AdfParams, Filter, Guards, IfevipParams, TsifsdParams, Variant, rescale};
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

/// `img` on the grid the fused image of `policy` has (`vis` is area-downscaled, `tir`
/// bicubic-upscaled, as the pipeline does), for metrics against the sources.
pub fn source_on_grid(img: &Gray<u8>, grid: (usize, usize), filter: Filter) -> Result<Gray<u8>> {
    if (img.width, img.height) == grid {
        return Ok(img.clone());
    }
    let mut out = Gray::new(grid.0, grid.1);
    rescale(img.view()?, out.view_mut()?, filter)?;
    Ok(out)
}

/// The grid a policy fuses on for a VIS/TIR size pair (re-exported for the CLI verbs).
pub fn grid(vis: &Gray<u8>, tir: &Gray<u8>, policy: RescalePolicy) -> Result<(usize, usize)> {
    Ok(fusion_grid((vis.width, vis.height), (tir.width, tir.height), policy)?)
}

/// The smallest square around the pixels brighter than `threshold` in any of `images` (all the
/// same size), grown by `margin` of its side and clamped to the frame: `(x0, y0, side)`. The
/// whole frame when nothing is bright.
pub fn target_square(images: &[&Gray<u8>], threshold: u8, margin: f64) -> (usize, usize, usize) {
    let Some(first) = images.first() else { return (0, 0, 0) };
    let (w, h) = (first.width, first.height);
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for img in images {
        for (i, &v) in img.data.iter().enumerate() {
            if v > threshold {
                let (x, y) = (i % w, i / w);
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
            }
        }
    }
    if x1 <= x0 || y1 <= y0 {
        return (0, 0, w.min(h));
    }
    let side = ((x1 - x0).max(y1 - y0) as f64 * (1.0 + 2.0 * margin)).ceil() as usize;
    let side = side.clamp(1, w.min(h));
    let cx = (x0 + x1) / 2;
    let cy = (y0 + y1) / 2;
    let x = cx.saturating_sub(side / 2).min(w - side);
    let y = cy.saturating_sub(side / 2).min(h - side);
    (x, y, side)
}

/// The `side × side` square of `img` at `(x, y)`, rescaled (area down, cubic up) to `tile²`.
pub fn tile(img: &Gray<u8>, (x, y, side): (usize, usize, usize), tile: usize) -> Result<Gray<u8>> {
    let view = img.view()?;
    let crop = Gray {
        width: side,
        height: side,
        data: (y..y + side).flat_map(|r| view.row(r).iter().skip(x).take(side).copied()).collect(),
    };
    if crop.data.len() != side * side {
        return Err(anyhow!("crop {side}² at ({x}, {y}) leaves the {}x{} frame", img.width, img.height));
    }
    let filter = if side >= tile { Filter::Area } else { Filter::Cubic };
    source_on_grid(&crop, (tile, tile), filter)
}

/// A contact sheet: `rows` of equally sized tiles, separated by `gap` px of mid grey.
pub fn contact_sheet(rows: &[Vec<Gray<u8>>], gap: usize) -> Gray<u8> {
    let tile = rows.iter().flatten().map(|t| t.width.max(t.height)).max().unwrap_or(0);
    let cols = rows.iter().map(Vec::len).max().unwrap_or(0);
    let w = cols * tile + (cols + 1) * gap;
    let h = rows.len() * tile + (rows.len() + 1) * gap;
    let mut sheet = Gray { width: w, height: h, data: vec![128; w * h] };
    for (r, row) in rows.iter().enumerate() {
        for (c, t) in row.iter().enumerate() {
            let (ox, oy) = (gap + c * (tile + gap), gap + r * (tile + gap));
            for y in 0..t.height {
                let src = &t.data[y * t.width..(y + 1) * t.width];
                let start = (oy + y) * w + ox;
                sheet.data[start..start + t.width].copy_from_slice(src);
            }
        }
    }
    sheet
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

    #[test]
    fn target_square_covers_the_bright_pixels() {
        let mut img = Gray { width: 20, height: 10, data: vec![0u8; 200] };
        img.data[3 * 20 + 12] = 200;
        img.data[5 * 20 + 15] = 200;
        let (x, y, side) = target_square(&[&img], 10, 0.0);
        assert_eq!(side, 4, "columns 12..=15 (4) by rows 3..=5 (3)");
        assert!(x <= 12 && x + side >= 16 && y <= 3 && y + side >= 6, "({x}, {y}, {side})");
        // nothing bright: the largest square at the origin
        assert_eq!(
            target_square(&[&Gray { width: 20, height: 10, data: vec![0; 200] }], 10, 0.1),
            (0, 0, 10)
        );
    }

    #[test]
    fn contact_sheet_places_tiles_with_gaps() {
        let t = |v| Gray { width: 2, height: 2, data: vec![v; 4] };
        let sheet = contact_sheet(&[vec![t(10), t(20)], vec![t(30)]], 1);
        assert_eq!((sheet.width, sheet.height), (7, 7));
        assert_eq!(sheet.at(1, 1), 10);
        assert_eq!(sheet.at(4, 2), 20);
        assert_eq!(sheet.at(2, 4), 30);
        assert_eq!(sheet.at(0, 0), 128);
        assert_eq!(sheet.at(4, 4), 128, "missing tile stays grey");
    }
}
