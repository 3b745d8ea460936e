//! Frame-to-frame feature tracking: BRIEF descriptors (`imageproc::binary_descriptors::brief`,
//! 256 tests in the 31 × 31 patch, sub-patch means from an integral image) at the detected
//! corners, matched by Hamming distance inside a search window, mutual best only.

use image::GrayImage;
use imageproc::binary_descriptors::BinaryDescriptor;
use imageproc::binary_descriptors::brief::{BriefDescriptor, TestPair, brief};
use imageproc::corners::Corner;
use imageproc::point::Point;

/// Descriptor length, bits.
pub const DESCRIPTOR_BITS: usize = 256;
/// A keypoint needs this many pixels to every border for its descriptor patch.
pub const BORDER: u32 = 17;
/// Largest accepted Hamming distance of a match (of [`DESCRIPTOR_BITS`]).
pub const MAX_HAMMING: u32 = 60;
/// Search window: a match moves at most this many pixels between frames.
pub const SEARCH_RADIUS_PX: f32 = 48.0;

/// A corner with its descriptor.
#[derive(Clone)]
pub struct Feature {
    /// Pixel position (the corner's pixel).
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// BRIEF bits.
    pub descriptor: BriefDescriptor,
}

/// The fixed BRIEF test pattern: 256 point pairs in the 31 × 31 patch drawn from a seeded
/// uniform generator (Calonder et al.'s G I sampling), the same for every frame and stream (a
/// descriptor is only comparable under one pattern; imageproc would draw a new one per call).
pub fn test_pairs() -> Vec<TestPair> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state = render_host::noise::mix64(state);
        (state >> 40) as u32 % 31
    };
    (0..DESCRIPTOR_BITS)
        .map(|_| TestPair { p0: Point::new(next(), next()), p1: Point::new(next(), next()) })
        .collect()
}

/// Descriptors of `corners` in `img` (corners too close to the border are dropped).
pub fn describe(img: &GrayImage, corners: &[Corner], pairs: &[TestPair]) -> Vec<Feature> {
    let (w, h) = img.dimensions();
    let kept: Vec<Point<u32>> = corners
        .iter()
        .filter(|c| c.x >= BORDER && c.y >= BORDER && c.x + BORDER < w && c.y + BORDER < h)
        .map(|c| Point::new(c.x, c.y))
        .collect();
    if kept.is_empty() {
        return Vec::new();
    }
    let pairs = pairs.to_vec();
    match brief(img, &kept, DESCRIPTOR_BITS, Some(&pairs)) {
        Ok((descriptors, _)) => {
            descriptors.into_iter().map(|d| Feature { x: d.corner.x, y: d.corner.y, descriptor: d }).collect()
        }
        Err(_) => Vec::new(),
    }
}

/// Mutual-best matches `(i, j)` from `a` to `b`: `b[j]` is `a[i]`'s nearest descriptor within
/// [`SEARCH_RADIUS_PX`] and [`MAX_HAMMING`], and `a[i]` is `b[j]`'s.
pub fn match_features(a: &[Feature], b: &[Feature]) -> Vec<(usize, usize)> {
    let near = |p: &Feature, q: &Feature| {
        let (dx, dy) = (p.x as f32 - q.x as f32, p.y as f32 - q.y as f32);
        dx * dx + dy * dy <= SEARCH_RADIUS_PX * SEARCH_RADIUS_PX
    };
    let best = |from: &[Feature], to: &[Feature]| -> Vec<Option<usize>> {
        from.iter()
            .map(|p| {
                to.iter()
                    .enumerate()
                    .filter(|(_, q)| near(p, q))
                    .map(|(j, q)| (p.descriptor.hamming_distance(&q.descriptor), j))
                    .min()
                    .filter(|(d, _)| *d <= MAX_HAMMING)
                    .map(|(_, j)| j)
            })
            .collect()
    };
    let (ab, ba) = (best(a, b), best(b, a));
    ab.iter().enumerate().filter_map(|(i, j)| j.filter(|&j| ba[j] == Some(i)).map(|j| (i, j))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::detect;

    /// A textured image and the same image shifted by (5, −3) px: every match moves by exactly
    /// that shift.
    #[test]
    fn matches_follow_a_known_shift() {
        let pattern = |x: i64, y: i64| -> u8 {
            let h = render_host::noise::mix64(((x.div_euclid(6)) as u64) << 32 | (y.div_euclid(6)) as u64);
            (h >> 56) as u8
        };
        let a = GrayImage::from_fn(160, 160, |x, y| image::Luma([pattern(i64::from(x), i64::from(y))]));
        let b =
            GrayImage::from_fn(160, 160, |x, y| image::Luma([pattern(i64::from(x) - 5, i64::from(y) + 3)]));
        let pairs = test_pairs();
        let (fa, fb) = (describe(&a, &detect(&a, None), &pairs), describe(&b, &detect(&b, None), &pairs));
        let m = match_features(&fa, &fb);
        assert!(m.len() >= 20, "{} matches of {} / {}", m.len(), fa.len(), fb.len());
        let right = m.iter().filter(|&&(i, j)| fb[j].x == fa[i].x + 5 && fb[j].y + 3 == fa[i].y).count();
        assert!(right * 100 >= m.len() * 95, "{right} of {} matches follow the shift", m.len());
    }
}
