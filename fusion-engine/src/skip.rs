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
    let (mut se, mut max_abs, mut differing) = (0f64, 0u8, 0usize);
    for (&a, &b) in skipped.data.iter().zip(&full.data) {
        let d = a.abs_diff(b);
        se += f64::from(d) * f64::from(d);
        max_abs = max_abs.max(d);
        differing += usize::from(d != 0);
    }
    let mse = se / full.data.len().max(1) as f64;
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
