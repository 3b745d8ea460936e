//! Scene skipping on the host: one timed fusion with its report, and the error a skip adds
//! against the unskipped result (shared by `fusion skip-study`, `fusion fuse --skip` and the
//! tests).

use anyhow::Result;
use fusion_io::Gray;
use fusion_nostd::pipeline::{FuseConfig, FuseReport};
use fusion_nostd::scene::Rect;

/// One core fusion: the fused frame, the report and the wall time (seconds, scratch allocated
/// outside the timed part).
pub fn fuse_once(
    vis: &Gray<u8>,
    tir: &Gray<u8>,
    pipeline: &FuseConfig,
) -> Result<(Gray<u8>, FuseReport, f64)> {
    let run = crate::study::fuse_timed(vis, tir, pipeline, 1)?;
    Ok((run.fused, run.report, run.seconds))
}

/// The error of a skipped result against the unskipped one, over the whole frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkipError {
    /// Largest absolute difference, grey levels.
    pub max_abs: u8,
    /// PSNR over the frame, dB (`∞` when identical).
    pub psnr: f64,
    /// Pixels that differ.
    pub differing: usize,
}

/// [`SkipError`] of `skipped` against `full` (same size).
pub fn skip_error(skipped: &Gray<u8>, full: &Gray<u8>) -> SkipError {
    skip_error_in(skipped, full, Rect::full((full.width, full.height)))
}

/// [`SkipError`] of `skipped` against `full` (same size) over the pixels of `rect` only (e.g. a
/// skip report's ROI); its PSNR is over those pixels.
pub fn skip_error_in(skipped: &Gray<u8>, full: &Gray<u8>, rect: Rect) -> SkipError {
    let (mut se, mut max_abs, mut differing) = (0f64, 0u8, 0usize);
    for y in rect.y0..rect.y1 {
        let row = y * full.width;
        for (&a, &b) in
            skipped.data[row + rect.x0..row + rect.x1].iter().zip(&full.data[row + rect.x0..row + rect.x1])
        {
            let d = a.abs_diff(b);
            se += f64::from(d) * f64::from(d);
            max_abs = max_abs.max(d);
            differing += usize::from(d != 0);
        }
    }
    let mse = se / rect.area().max(1) as f64;
    let psnr = if mse == 0.0 { f64::INFINITY } else { 10.0 * (255.0 * 255.0 / mse).log10() };
    SkipError { max_abs, psnr, differing }
}

/// The first pixel of `rect` where `a` and `b` differ: `(x, y, a, b)`.
pub fn first_difference_in(a: &Gray<u8>, b: &Gray<u8>, rect: Rect) -> Option<(usize, usize, u8, u8)> {
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            let (p, q) = (a.data[y * a.width + x], b.data[y * b.width + x]);
            if p != q {
                return Some((x, y, p, q));
            }
        }
    }
    None
}

/// The reference of the crop semantics ([`fusion_nostd::pipeline::Skips::CROP`]): both bands
/// brought onto the fusion grid as the unskipped fusion brings them (the same rescale, whole
/// frame), cut to `window`, and fused as a pair of their own by `pipeline`'s method without
/// skipping (with the crop's parameters, `Method::on_crop`). The result sits at `window` in a grid-sized frame (zeros elsewhere), so it compares
/// with a skipped output pixel for pixel.
pub fn fuse_crop(vis: &Gray<u8>, tir: &Gray<u8>, pipeline: &FuseConfig, window: Rect) -> Result<Gray<u8>> {
    use fusion_nostd::pipeline::{RescalePolicy, SkipPolicy, fusion_grid};
    use fusion_nostd::{Filter, rescale};
    let grid = fusion_grid((vis.width, vis.height), (tir.width, tir.height), pipeline.rescale)?;
    let on_grid = |band: &Gray<u8>, filter: Filter| -> Result<Gray<u8>> {
        if (band.width, band.height) == grid {
            return Ok(band.clone());
        }
        let mut g = Gray::new(grid.0, grid.1);
        rescale(band.view()?, g.view_mut()?, filter)?;
        Ok(g)
    };
    // Only the band off the grid is rescaled: VIS down by area, TIR up by bicubic.
    let (vis_g, tir_g) = (on_grid(vis, Filter::Area)?, on_grid(tir, Filter::Cubic)?);
    let cut = |g: &Gray<u8>| {
        let mut c = Gray::new(window.width(), window.height());
        for (y, row) in c.data.chunks_exact_mut(window.width().max(1)).enumerate() {
            let at = (window.y0 + y) * g.width + window.x0;
            row.copy_from_slice(&g.data[at..at + window.width()]);
        }
        c
    };
    let crop_pipeline = FuseConfig {
        rescale: RescalePolicy::None,
        skip: SkipPolicy::None,
        method: pipeline.method.on_crop((window.width(), window.height()), grid),
        ..*pipeline
    };
    let (fused, _, _) = fuse_once(&cut(&vis_g), &cut(&tir_g), &crop_pipeline)?;
    let mut out = Gray::new(grid.0, grid.1);
    for (y, row) in fused.data.chunks_exact(window.width().max(1)).enumerate() {
        let at = (window.y0 + y) * grid.0 + window.x0;
        out.data[at..at + window.width()].copy_from_slice(row);
    }
    Ok(out)
}
