//! Feature detection on the target: FAST-9 corners (`imageproc::corners::corners_fast9`) after
//! non-maximum suppression (`imageproc::suppress::local_maxima`), kept where a target mask says
//! the target is.

use image::GrayImage;
use imageproc::corners::{Corner, corners_fast9};
use imageproc::filter::gaussian_blur_f32;
use imageproc::suppress::local_maxima;

/// FAST threshold (grey levels) used by the navigation front end: a corner's arc must differ
/// from its centre by more than this, after the [`PRESMOOTH_SIGMA`] blur.
pub const FAST_THRESHOLD: u8 = 10;

/// Gaussian pre-smoothing before the segment test, px. The study's sensor noise (white,
/// σ ≈ 12 grey levels, plus 1/f in TIR) otherwise fires the test all over the target and the
/// background; σ = 1.5 px brings it to ≈ 2 levels, as a tracker's first pyramid level would.
pub const PRESMOOTH_SIGMA: f32 = 1.5;

/// Radius of the non-maximum suppression, px (one corner per 7 × 7 block at most).
pub const NMS_RADIUS: u32 = 3;

/// The FAST-9 corners of `img` (smoothed with [`PRESMOOTH_SIGMA`] first) after non-maximum
/// suppression, those inside `mask` only (row major, `img`'s size) when a mask is given.
pub fn detect(img: &GrayImage, mask: Option<&[bool]>) -> Vec<Corner> {
    corners(&gaussian_blur_f32(img, PRESMOOTH_SIGMA), FAST_THRESHOLD, mask)
}

/// The FAST-9 corners of `img` as it is after non-maximum suppression, those inside `mask` only
/// (row major, `img`'s size) when a mask is given.
pub fn corners(img: &GrayImage, threshold: u8, mask: Option<&[bool]>) -> Vec<Corner> {
    let all = local_maxima(&corners_fast9(img, threshold), NMS_RADIUS);
    let w = img.width() as usize;
    all.into_iter()
        .filter(|c| mask.is_none_or(|m| m.get(c.y as usize * w + c.x as usize).copied().unwrap_or(false)))
        .collect()
}

/// A target mask from a rendered depth or hit image: pixels where the target was hit, grown by
/// `grow` pixels (corners on the outline sit half a window outside the last hit pixel).
pub fn grow_mask(hit: &[bool], width: usize, height: usize, grow: usize) -> Vec<bool> {
    let mut out = vec![false; hit.len()];
    for y in 0..height {
        for x in 0..width {
            if !hit[y * width + x] {
                continue;
            }
            for yy in y.saturating_sub(grow)..(y + grow + 1).min(height) {
                for xx in x.saturating_sub(grow)..(x + grow + 1).min(width) {
                    out[yy * width + xx] = true;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_sit_on_a_squares_corners_and_a_mask_keeps_one_of_them() {
        let mut img = GrayImage::new(40, 40);
        for y in 10..30 {
            for x in 10..30 {
                img.put_pixel(x, y, image::Luma([200]));
            }
        }
        let truth = [(10i64, 10i64), (29, 10), (10, 29), (29, 29)];
        let near =
            |c: &Corner, t: (i64, i64)| (i64::from(c.x) - t.0).abs().max((i64::from(c.y) - t.1).abs()) <= 3;
        let found = corners(&img, FAST_THRESHOLD, None);
        for c in &found {
            assert!(truth.iter().any(|&t| near(c, t)), "{c:?} is on no corner");
        }
        for t in truth {
            assert!(found.iter().any(|c| near(c, t)), "no corner found at {t:?}: {found:?}");
        }
        let mut mask = vec![false; 40 * 40];
        mask[10 * 40 + 10] = true;
        let grown = grow_mask(&mask, 40, 40, 3);
        let kept = corners(&img, FAST_THRESHOLD, Some(&grown));
        assert!(!kept.is_empty() && kept.iter().all(|c| near(c, (10, 10))), "{kept:?}");
        // A flat image has none.
        assert!(corners(&GrayImage::new(40, 40), FAST_THRESHOLD, None).is_empty());
    }
}
