use super::blocks::for_each_block;
use super::*;

#[test]
fn rect_helpers() {
    let r = Rect { x0: 5, y0: 6, x1: 10, y1: 12 };
    assert_eq!(r.area(), 30);
    assert_eq!(r.grow(6, (14, 14)), Rect { x0: 0, y0: 0, x1: 14, y1: 14 });
    assert_eq!(Rect::full((20, 20)).shrink_inner(3, (20, 20)), Rect::full((20, 20)));
    assert_eq!(r.grow(2, (20, 20)).shrink_inner(2, (20, 20)), r);
    assert!(Rect { x0: 2, y0: 2, x1: 4, y1: 4 }.shrink_inner(2, (9, 9)).is_empty());
    assert_eq!(Rect::default().union(r), r);
    assert!(r.covers(&Rect { x0: 6, y0: 6, x1: 7, y1: 7 }) && !r.covers(&Rect::full((7, 7))));
}

#[test]
fn background_noise_and_threshold() -> Result<(), Error> {
    // Background 3 with ±1 noise on half the pixels: ¾ of the samples ≤ 3, ¼ at 4, grouped upper
    // quartile 3.5 → spread ½ → 6·1.4826·½ = 4.4 → delta 5.
    let mut px = [0u8; 40 * 40];
    for (i, p) in px.iter_mut().enumerate() {
        *p = match i % 4 {
            0 => 2,
            1 => 4,
            _ => 3,
        };
    }
    let s = band_stats(FrameRef::new(&px, 40, 40)?, &SceneParams::default());
    assert_eq!((s.background, s.spread_q8, s.threshold), (3, 128, 8));
    assert_eq!(s.signal, None);
    assert_eq!(s.varying, Some(Rect { x0: 0, y0: 0, x1: 38, y1: 40 })); // x = 38, 39 are 3 in every row
    // A single spike does not make a target; a 2-pixel run does.
    px[100] = 200;
    assert_eq!(band_stats(FrameRef::new(&px, 40, 40)?, &SceneParams::default()).signal, None);
    px[101] = 200;
    let s = band_stats(FrameRef::new(&px, 40, 40)?, &SceneParams::default());
    assert_eq!(s.signal, Some(Rect { x0: 20, y0: 2, x1: 22, y1: 3 }));
    Ok(())
}

#[test]
fn bright_backgrounds_decline_and_black_vis_is_eclipse() -> Result<(), Error> {
    let grey = [120u8; 16 * 16];
    let black = [0u8; 16 * 16];
    let s = analyze(
        FrameRef::new(&grey, 16, 16)?,
        FrameRef::new(&black, 16, 16)?,
        (16, 16),
        &SceneParams::default(),
    )?;
    assert_eq!(s.decline, Some(Decline::BackgroundNotDark));
    let s = analyze(
        FrameRef::new(&black, 16, 16)?,
        FrameRef::new(&black, 16, 16)?,
        (16, 16),
        &SceneParams::default(),
    )?;
    assert_eq!((s.illumination, s.decline, s.target, s.varying), (Illumination::Eclipse, None, None, None));
    let mut sat = [0u8; 16 * 16];
    sat[..64].fill(255);
    let s = analyze(
        FrameRef::new(&sat, 16, 16)?,
        FrameRef::new(&black, 16, 16)?,
        (16, 16),
        &SceneParams::default(),
    )?;
    assert_eq!(s.illumination, Illumination::Saturated);
    let bad = SceneParams { min_delta: 0, ..SceneParams::default() };
    assert!(analyze(FrameRef::new(&black, 16, 16)?, FrameRef::new(&black, 16, 16)?, (16, 16), &bad).is_err());
    Ok(())
}

/// The definitions of [`band_stats`] pixel by pixel (the analysis before the word-wise
/// scans): the subsample histogram with saturating counts, then every row folded to its
/// minimum and maximum and searched for the first and last run / differing pixel.
fn reference_band_stats(f: FrameRef<'_, u8>, p: &SceneParams) -> BandStats {
    let mut hist = [0u32; 256];
    let small = f.width().saturating_mul(f.height()) <= 1 << 16;
    let (sy, sx) = if small { (1, 1) } else { (4, 2) };
    let mut n = 0u32;
    for row in f.rows().step_by(sy) {
        for &v in row.iter().step_by(sx) {
            hist[usize::from(v)] = hist[usize::from(v)].saturating_add(1);
            n = n.saturating_add(1);
        }
    }
    let background = median_of(&hist, n);
    let spread_q8 = upper_quartile_q8(&hist, n)
        .saturating_sub(u32::from(background) << 8)
        .min(u32::from(u16::MAX)) as u16;
    let spread = (u64::from(spread_q8) * u64::from(p.k_sigma_tenths) * 14826).div_ceil(100_000 << 8);
    let delta = spread.max(u64::from(p.min_delta)).min(256) as u16;
    let threshold = u16::from(background) + delta;
    let signal_samples =
        (0..256).filter(|&v| v as u16 > threshold).map(|v| hist[v]).fold(0u32, u32::saturating_add);
    let saturated_samples = if threshold < 255 { hist[255] } else { 0 };
    let add = |b: &mut Option<Rect>, y: usize, x0: usize, x1: usize| {
        let r = Rect { x0, y0: y, x1, y1: y + 1 };
        *b = Some(b.map_or(r, |b| b.union(r)));
    };
    let (mut signal, mut varying) = (None, None);
    for (y, row) in f.rows().enumerate() {
        let above = |x: usize| row.get(x).is_some_and(|&v| u16::from(v) > threshold);
        let runs: Vec<usize> = (0..row.len()).filter(|&x| above(x) && above(x + 1)).collect();
        if let (Some(&a), Some(&b)) = (runs.first(), runs.last()) {
            add(&mut signal, y, a, b + 2);
        }
        let diff: Vec<usize> = (0..row.len()).filter(|&x| row[x] != background).collect();
        if let (Some(&a), Some(&b)) = (diff.first(), diff.last()) {
            add(&mut varying, y, a, b + 1);
        }
    }
    BandStats {
        background,
        spread_q8,
        threshold,
        samples: n,
        signal_samples,
        saturated_samples,
        signal,
        varying,
    }
}

/// The word-lane block sums equal the sums pixel by pixel, for every block side, odd sizes,
/// frames wider than one chunk, and every other block row.
#[test]
fn block_sums_match_pixel_sums() {
    let mut rng = Rng(7);
    for (w, h) in [(1, 1), (3, 5), (17, 9), (64, 33), (1030, 11), (2051, 3)] {
        let data: Vec<u8> = (0..w * h).map(|_| rng.next() as u8).collect();
        let d = &data[..];
        let f = FrameRef::new(d, w, h).unwrap();
        for b in [2, 4, 8, 16] {
            for step in [1, 2] {
                let mut seen = 0;
                for_each_block(f, b, step, |bx, by, sum, count| {
                    assert_eq!(by % step, 0);
                    let (x0, y0) = (bx * b, by * b);
                    let (x1, y1) = ((x0 + b).min(w), (y0 + b).min(h));
                    let want: u32 =
                        (y0..y1).flat_map(|y| (x0..x1).map(move |x| u32::from(d[y * w + x]))).sum();
                    assert_eq!(
                        (sum, count),
                        (want, ((x1 - x0) * (y1 - y0)) as u32),
                        "{w}x{h} b {b} block ({bx}, {by})"
                    );
                    seen += 1;
                });
                assert_eq!(seen, w.div_ceil(b) * h.div_ceil(b).div_ceil(step), "{w}x{h} b {b}");
            }
        }
    }
}

/// xorshift64*: deterministic test frames without a dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 16
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

extern crate std;
use std::vec::Vec;
use std::{format, vec};

/// Compares [`band_stats`] with the reference on a `w × h` frame with row `stride` (the
/// padding filled with `pad`, which must never be read).
fn same_as_reference(px: &[u8], w: usize, h: usize, stride: usize, params: &SceneParams, what: &str) {
    let f = FrameRef::with_stride(px, w, h, stride).expect("valid frame");
    let fast = band_stats(f, params);
    let slow = reference_band_stats(f, params);
    assert_eq!(fast, slow, "{what}: {w}×{h} stride {stride}");
}

/// A `w × h` frame (stride `stride`) of background `bg` with noise `±noise` on a share of
/// the pixels, then `marks` single pixels, 2-pixel runs and longer runs at random places
/// (often at row ends and at the threshold), padding `pad`.
#[allow(clippy::too_many_arguments)]
fn random_frame(
    rng: &mut Rng,
    w: usize,
    h: usize,
    stride: usize,
    bg: u8,
    noise: u8,
    marks: usize,
    pad: u8,
) -> Vec<u8> {
    let mut px = vec![pad; (h - 1) * stride + w];
    for y in 0..h {
        for x in 0..w {
            let n = if noise > 0 && rng.below(3) == 0 {
                rng.below(2 * usize::from(noise) + 1) as i32 - i32::from(noise)
            } else {
                0
            };
            px[y * stride + x] = (i32::from(bg) + n).clamp(0, 255) as u8;
        }
    }
    let t0 = reference_band_stats(
        FrameRef::with_stride(&px, w, h, stride).expect("frame"),
        &SceneParams::default(),
    )
    .threshold;
    for _ in 0..marks {
        let y = rng.below(h);
        let x = match rng.below(4) {
            0 => 0,
            1 => w.saturating_sub(1 + rng.below(2)),
            _ => rng.below(w),
        };
        let v = match rng.below(5) {
            0 => 255,
            1 => t0.min(255) as u8,
            2 => (t0 + 1).min(255) as u8,
            3 => bg.wrapping_add(1),
            _ => rng.below(256) as u8,
        };
        let len = match rng.below(3) {
            0 => 1,
            1 => 2,
            _ => 1 + rng.below(40),
        };
        for i in x..(x + len).min(w) {
            px[y * stride + i] = v;
        }
    }
    px
}

#[test]
fn word_scans_match_the_per_pixel_definitions_on_random_frames() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let params = [
        SceneParams::default(),
        SceneParams { min_delta: 1, k_sigma_tenths: 0, ..SceneParams::default() },
        SceneParams { min_delta: 200, ..SceneParams::default() },
    ];
    for case in 0..600 {
        let (w, h) = match case % 6 {
            0 => (1 + rng.below(40), 1 + rng.below(40)),
            1 => (1, 1 + rng.below(300)),
            2 => (1 + rng.below(300), 1),
            3 => (15 + rng.below(3) + 16 * rng.below(4), 1 + rng.below(20)),
            4 => (257 + rng.below(80), 257 + rng.below(20)), // subsampled histogram
            _ => (1 + rng.below(100), 1 + rng.below(100)),
        };
        let stride = w + if rng.below(2) == 0 { 0 } else { 1 + rng.below(7) };
        let bg = match rng.below(5) {
            0 => 0,
            1 => 130 + rng.below(20) as u8, // threshold ≥ 128
            2 => 250,                       // threshold ≥ 255: no signal possible
            _ => rng.below(50) as u8,
        };
        let noise = [0u8, 0, 1, 3, 12][rng.below(5)];
        let marks = rng.below(12);
        let pad = [0u8, 255, bg.wrapping_add(1)][rng.below(3)];
        let px = random_frame(&mut rng, w, h, stride, bg, noise, marks, pad);
        let p = &params[rng.below(params.len())];
        same_as_reference(&px, w, h, stride, p, &format!("case {case} bg {bg} noise {noise}"));
    }
}

#[test]
fn word_scans_match_the_per_pixel_definitions_on_adversarial_frames() {
    let p = SceneParams::default();
    for w in [1usize, 2, 3, 15, 16, 17, 31, 32, 33, 47, 64, 65] {
        for h in [1usize, 2, 3, 5] {
            for stride in [w, w + 1, w + 3] {
                let len = (h - 1) * stride + w;
                for fill in [0u8, 1, 123, 124, 127, 128, 250, 254, 255] {
                    for (pad, corners) in [(0u8, false), (255, false), (0, true), (255, true)] {
                        let mut px = vec![pad; len];
                        let at = |x: usize, y: usize| y * stride + x;
                        for y in 0..h {
                            for x in 0..w {
                                px[at(x, y)] = fill;
                            }
                        }
                        same_as_reference(&px, w, h, stride, &p, "flat");
                        if corners {
                            // The varying box spans the frame: the signal search then
                            // scans whole rows, group by group.
                            px[at(0, 0)] = fill ^ 1;
                            px[at(w - 1, h - 1)] = fill ^ 1;
                        }
                        // A single spike and a 2-pixel run at each place of the middle row:
                        // row start, row end, group edges.
                        let y = h / 2;
                        for x in 0..w {
                            for v in
                                [fill.wrapping_add(4), fill.wrapping_add(5), fill.wrapping_add(128), 255, 0]
                            {
                                let mut q = px.clone();
                                q[at(x, y)] = v;
                                same_as_reference(&q, w, h, stride, &p, &format!("spike {v} at {x}"));
                                if x + 1 < w {
                                    q[at(x + 1, y)] = v;
                                    same_as_reference(&q, w, h, stride, &p, &format!("run {v} at {x}"));
                                }
                            }
                        }
                        // Runs at both ends of the top and bottom rows, spikes between.
                        let mut q = px.clone();
                        for y in [0, h - 1] {
                            q[at(0, y)] = 255;
                            q[at(w - 1, y)] = 255;
                            if w >= 2 {
                                q[at(w - 2, y)] = 255;
                            }
                        }
                        same_as_reference(&q, w, h, stride, &p, "end runs");
                    }
                }
            }
        }
    }
}

#[test]
fn mapped_boxes_cover_the_rescaler_taps() {
    let r = Rect { x0: 10, y0: 10, x1: 12, y1: 12 };
    let m = map_rect(r, (32, 32), (64, 64));
    assert!(m.x0 <= 20 - 4 && m.x1 >= 24 + 4, "{m:?}");
    assert_eq!(map_rect(r, (32, 32), (32, 32)), r);
}
