//! VIFB's 13 fusion metrics, computed the way VIFB's MATLAB code computes them.
//!
//! VIFB (Zhang et al., "VIFB: a visible and infrared image fusion benchmark", CVPRW 2020) ships
//! one MATLAB file per metric (`metrics/metrics*.m`). Papers that report "VIFB metrics" report
//! what those files compute, which is not always the textbook formula: RMSE there is
//! `sqrt(Σ(A−F)²)/(M·N)`, not a root *mean* square; MI is in nats after a min–max rescale;
//! Qabf's "equal strength" case yields the strength itself instead of 1. This module follows the
//! files, built-ins included (`gradient`'s one-sided borders, `imfilter(…,'replicate')`,
//! `conv2`/`filter2` zero padding, `freqspace`, `blkproc`'s zero-padded blocks, `int16` and
//! `round` ties away from zero). Every rule, with the line of MATLAB it comes from, is in
//! `docs/metrics.md`; the tests compare all 13 against VIFB's code run under GNU Octave on the
//! twelve shared triples (`tests/data/vifb/vifb_metrics.csv`) to 1e-6 relative.
//!
//! Colour follows VIFB's wrappers: a colour fused image is scored per channel against the
//! matching channel of a colour source (or the single channel of a grey one) and the channel
//! scores are averaged — except SF, which VIFB computes on the channels laid side by side
//! (`[m, n] = size(fused)` of an M×N×3 array gives n = 3N). A grey fused image against a colour
//! source converts the source with `rgb2gray` first, as the metric files do.
//!
//! Two numerical liberties, both far below the 1e-6 tolerance: the Gaussian windows are applied
//! as separable passes, and the FFT filtering of Qcb/Qcv keeps the real part of the inverse
//! transform (the filters are real and even, so VIFB's complex result differs from it only by
//! rounding noise in the imaginary part).

use super::fft::{self, Spectra2d};
use anyhow::{Result, bail};
use fusion_io::Channels;
use rustfft::num_complex::Complex;

/// The JSON/CSV keys of the suite, in VIFB's order.
pub const KEYS: [&str; 13] =
    ["AG", "CE", "EI", "EN", "MI", "PSNR", "Qabf", "Qcb", "Qcv", "RMSE", "SF", "SSIM", "SD"];

/// The smallest side the suite accepts: SSIM's 11 × 11 window must fit once
/// (`filter2(…, 'valid')` of a smaller image is empty and VIFB's mean is NaN).
pub const MIN_SIDE: usize = 11;

/// VIFB's 13 metrics of one (VIS, IR, fused) triple, in the units VIFB's code returns.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct VifbMetrics {
    /// Average gradient (`metricsAvg_gradient.m`).
    #[serde(rename = "AG")]
    pub ag: f64,
    /// Cross entropy, the mean of KL(VIS‖F) and KL(IR‖F) in bits (`metricsCross_entropy.m`).
    #[serde(rename = "CE")]
    pub ce: f64,
    /// Edge intensity, mean Sobel magnitude (`metricsEdge_intensity.m`).
    #[serde(rename = "EI")]
    pub ei: f64,
    /// Entropy of the fused image, bits (`metricsEntropy.m`).
    #[serde(rename = "EN")]
    pub en: f64,
    /// MI(VIS, F) + MI(IR, F) in nats after a min–max rescale (`metricsMutinf.m`).
    #[serde(rename = "MI")]
    pub mi: f64,
    /// `20·log10(255/√((e_VIS + e_IR)/2))` with VIFB's `e = √Σ(A−F)²/(MN)` (`metricsPsnr.m`).
    #[serde(rename = "PSNR")]
    pub psnr: f64,
    /// Xydeas–Petrović edge preservation (`metricsQabf.m`).
    #[serde(rename = "Qabf")]
    pub qabf: f64,
    /// Chen–Blum (`metricsQcb.m`).
    #[serde(rename = "Qcb")]
    pub qcb: f64,
    /// Chen–Varshney (`metricsQcv.m`); lower is better.
    #[serde(rename = "Qcv")]
    pub qcv: f64,
    /// `(e_VIS + e_IR)/2` with `e = √Σ(A−F)²/(MN)` (`metricsRmse.m`).
    #[serde(rename = "RMSE")]
    pub rmse: f64,
    /// Spatial frequency (`metricsSpatial_frequency.m`).
    #[serde(rename = "SF")]
    pub sf: f64,
    /// SSIM(VIS, F) + SSIM(IR, F) (`metricsSsim.m`).
    #[serde(rename = "SSIM")]
    pub ssim: f64,
    /// Standard deviation of the fused image (`metricsVariance.m`, which returns the root).
    #[serde(rename = "SD")]
    pub sd: f64,
}

impl VifbMetrics {
    /// The values in the order of [`KEYS`].
    pub fn values(&self) -> [f64; 13] {
        [
            self.ag, self.ce, self.ei, self.en, self.mi, self.psnr, self.qabf, self.qcb, self.qcv, self.rmse,
            self.sf, self.ssim, self.sd,
        ]
    }

    fn from_values(v: [f64; 13]) -> Self {
        let [ag, ce, ei, en, mi, psnr, qabf, qcb, qcv, rmse, sf, ssim, sd] = v;
        Self { ag, ce, ei, en, mi, psnr, qabf, qcb, qcv, rmse, sf, ssim, sd }
    }
}

/// One 8-bit channel, row-major.
#[derive(Debug, Clone, Copy)]
pub struct Plane<'a> {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width * height` samples.
    pub data: &'a [u8],
}

/// The suite on a triple. Sizes must agree (rescale the sources first) and be at least
/// [`MIN_SIDE`]; the fused image and the sources have 1 or 3 channels.
pub fn vifb_metrics(vis: &Channels, ir: &Channels, fused: &Channels) -> Result<VifbMetrics> {
    let (w, h) = (fused.width, fused.height);
    for (name, c) in [("visible", vis), ("infrared", ir)] {
        if (c.width, c.height) != (w, h) {
            bail!("the {name} image is {}x{}, the fused image {w}x{h}", c.width, c.height);
        }
    }
    if w < MIN_SIDE || h < MIN_SIDE {
        bail!(
            "the VIFB metrics need at least {MIN_SIDE}x{MIN_SIDE} pixels (SSIM's window); the image is {w}x{h}"
        );
    }
    for (name, c) in [("visible", vis), ("infrared", ir), ("fused", fused)] {
        if !matches!(c.planes.len(), 1 | 3) {
            bail!("the {name} image has {} channels; 1 or 3 are scored", c.planes.len());
        }
    }
    if fused.planes.len() == 1 {
        // Grey result: the metric files' own `rgb2gray` branches convert a colour source.
        let (v, i) = (vis.to_gray().data, ir.to_gray().data);
        let mut chen = Chen::new(w, h);
        let m = channel_metrics(&mut chen, plane(&v, w, h), plane(&i, w, h), plane(&fused.planes[0], w, h));
        let mut all = m.values;
        all[10] = spatial_frequency(&[plane(&fused.planes[0], w, h)]);
        return Ok(VifbMetrics::from_values(all));
    }
    // Colour result: VIFB's wrappers loop over the channels (`img1(:,:,k)`, and `img2(:,:,k)`
    // or the grey `img2`) and average; a grey visible image stands for every channel.
    let pick = |c: &'_ Channels, k: usize| -> usize { if c.planes.len() == 1 { 0 } else { k } };
    let mut sum = [0f64; 13];
    let mut chen = Chen::new(w, h);
    for k in 0..3 {
        let m = channel_metrics(
            &mut chen,
            plane(&vis.planes[pick(vis, k)], w, h),
            plane(&ir.planes[pick(ir, k)], w, h),
            plane(&fused.planes[k], w, h),
        );
        for (s, v) in sum.iter_mut().zip(m.values) {
            *s += v;
        }
    }
    let mut all = sum.map(|s| s / 3.0);
    let planes: Vec<Plane> = fused.planes.iter().map(|p| plane(p, w, h)).collect();
    all[10] = spatial_frequency(&planes);
    Ok(VifbMetrics::from_values(all))
}

/// The per-channel values (SF's slot is filled by the caller: its colour rule is not a mean).
struct ChannelMetrics {
    values: [f64; 13],
}

/// Every metric but SF on one channel triple; passes that several metrics share run once.
fn plane(data: &[u8], w: usize, h: usize) -> Plane<'_> {
    Plane { width: w, height: h, data }
}

fn channel_metrics(chen: &mut Chen, v: Plane, i: Plane, f: Plane) -> ChannelMetrics {
    let (w, h) = (f.width, f.height);
    let hist_f = histogram(f.data);
    let n = (w * h) as f64;
    let ce = (kl_bits(&histogram(v.data), &hist_f, n) + kl_bits(&histogram(i.data), &hist_f, n)) / 2.0;
    let e_v = vifb_error(v.data, f.data, n);
    let e_i = vifb_error(i.data, f.data, n);
    let rmse = (e_v + e_i) / 2.0;
    let psnr = 20.0 * (255.0 / rmse.sqrt()).log10();
    let (qcb, qcv) = chen.metrics(v, i, f);
    let (ssim_v, ssim_i) = super::ssim_valid_pair(v, i, f);
    let values = [
        average_gradient(f),
        ce,
        edge_intensity(f),
        entropy_bits(&hist_f, n),
        mutinf(v.data, f.data) + mutinf(i.data, f.data),
        psnr,
        qabf(v, i, f),
        qcb,
        qcv,
        rmse,
        f64::NAN,
        ssim_v + ssim_i,
        standard_deviation(f.data),
    ];
    ChannelMetrics { values }
}

#[inline(never)]
fn histogram(data: &[u8]) -> [u64; 256] {
    let mut h = [0u64; 256];
    for &v in data {
        h[v as usize] += 1;
    }
    h
}

/// `metricsEntropy.m`: −Σ p·log2 p over the 256 bins of the fused image.
#[inline(never)]
fn entropy_bits(h: &[u64; 256], n: f64) -> f64 {
    -h.iter().filter(|&&c| c > 0).map(|&c| c as f64 / n).map(|p| p * p.log2()).sum::<f64>()
}

/// `metricsCross_entropy.m`'s `cross_entropy(img, fused)`: Σ P1·log2(P1/P2) over the bins where
/// both are non-zero (so a KL divergence that skips the bins it could not define).
#[inline(never)]
fn kl_bits(a: &[u64; 256], f: &[u64; 256], n: f64) -> f64 {
    a.iter()
        .zip(f)
        .filter(|&(&x, &y)| x > 0 && y > 0)
        .map(|(&x, &y)| {
            let (p1, p2) = (x as f64 / n, y as f64 / n);
            p1 * (p1 / p2).log2()
        })
        .sum()
}

/// VIFB's `mse(a, b)` of `metricsRmse.m`/`metricsPsnr.m`: `sqrt(sum((a−b).^2))/(m·n)` — the root
/// of the *sum*, divided by the pixel count (not a root mean square).
#[inline(never)]
fn vifb_error(a: &[u8], b: &[u8], n: f64) -> f64 {
    let s: u64 = a.iter().zip(b).map(|(&x, &y)| (i64::from(x) - i64::from(y)).unsigned_abs().pow(2)).sum();
    (s as f64).sqrt() / n
}

/// `metricsAvg_gradient.m`: `[dzdx, dzdy] = gradient(F)` (central differences inside, one-sided
/// at the borders), `Σ sqrt((dzdx² + dzdy²)/2) / ((r−1)(c−1))` over all r·c pixels.
#[inline(never)]
fn average_gradient(f: Plane) -> f64 {
    let (w, h) = (f.width, f.height);
    let px = |x: usize, y: usize| f64::from(f.data[y * w + x]);
    let grad = |lo: f64, mid_lo: f64, mid_hi: f64, hi: f64, at_lo: bool, at_hi: bool| {
        if at_lo {
            mid_hi - lo
        } else if at_hi {
            hi - mid_lo
        } else {
            (mid_hi - mid_lo) / 2.0
        }
    };
    let mut s = 0.0;
    for y in 0..h {
        for x in 0..w {
            let p = px(x, y);
            let dx = if w == 1 {
                0.0
            } else {
                let l = if x > 0 { px(x - 1, y) } else { p };
                let r = if x + 1 < w { px(x + 1, y) } else { p };
                grad(p, l, r, p, x == 0, x + 1 == w)
            };
            let dy = if h == 1 {
                0.0
            } else {
                let u = if y > 0 { px(x, y - 1) } else { p };
                let d = if y + 1 < h { px(x, y + 1) } else { p };
                grad(p, u, d, p, y == 0, y + 1 == h)
            };
            s += ((dx * dx + dy * dy) / 2.0).sqrt();
        }
    }
    s / ((h - 1) * (w - 1)) as f64
}

/// `metricsEdge_intensity.m`: mean of `sqrt(gx² + gy²)`, `gx = imfilter(F, fspecial('sobel'),
/// 'replicate')`, `gy` with the transposed kernel.
#[inline(never)]
fn edge_intensity(f: Plane) -> f64 {
    let (w, h) = (f.width as isize, f.height as isize);
    let px = |x: isize, y: isize| i32::from(f.data[(y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize]);
    let mut s = 0.0;
    for y in 0..h {
        for x in 0..w {
            // Correlation with [1 2 1; 0 0 0; −1 −2 −1] and its transpose (signs vanish in the square).
            let gx = px(x - 1, y - 1) + 2 * px(x, y - 1) + px(x + 1, y - 1)
                - px(x - 1, y + 1)
                - 2 * px(x, y + 1)
                - px(x + 1, y + 1);
            let gy = px(x - 1, y - 1) + 2 * px(x - 1, y) + px(x - 1, y + 1)
                - px(x + 1, y - 1)
                - 2 * px(x + 1, y)
                - px(x + 1, y + 1);
            s += f64::from(gx * gx + gy * gy).sqrt();
        }
    }
    s / (w * h) as f64
}

/// `metricsMutinf.m`'s `mutinf(a, b)`: both rescaled to [0, 1] by their own min and max (a
/// constant image to 0), binned by `int16(x·255)` (round half away from zero), then
/// `H(a) + H(b) − H(a, b)` with natural logarithms — nats, not bits.
#[inline(never)]
fn mutinf(a: &[u8], b: &[u8]) -> f64 {
    let bins = |d: &[u8]| -> Vec<usize> {
        let (lo, hi) = d.iter().fold((u8::MAX, u8::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        if lo == hi {
            return vec![0; d.len()];
        }
        let range = f64::from(hi) - f64::from(lo);
        // The same IEEE steps as MATLAB: (a − min)/(max − min), then ·255, then int16().
        let map: Vec<usize> = (0..=255u8)
            .map(|v| (((f64::from(v) - f64::from(lo)) / range) * 255.0).round() as usize)
            .collect();
        d.iter().map(|&v| map[v as usize]).collect()
    };
    let (ba, bb) = (bins(a), bins(b));
    let mut joint = vec![0u64; 256 * 256];
    let mut ha = [0u64; 256];
    let mut hb = [0u64; 256];
    for (&x, &y) in ba.iter().zip(&bb) {
        joint[x * 256 + y] += 1;
        ha[x] += 1;
        hb[y] += 1;
    }
    let nats = |h: &[u64]| -> f64 {
        let n: u64 = h.iter().sum();
        -h.iter().filter(|&&c| c > 0).map(|&c| c as f64 / n as f64).map(|p| p * p.ln()).sum::<f64>()
    };
    nats(&ha) + nats(&hb) - nats(&joint)
}

/// `metricsVariance.m` (despite the name, the root): `sqrt(Σ(F − mean)²/(r·c))`.
#[inline(never)]
fn standard_deviation(f: &[u8]) -> f64 {
    let n = f.len() as f64;
    let mean = f.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    (f.iter().map(|&v| (f64::from(v) - mean).powi(2)).sum::<f64>() / n).sqrt()
}

/// `metricsSpatial_frequency.m` on the fused channels laid side by side (one channel: the image):
/// `RF = Σ (F(i,j) − F(i,j−1))² / (m·n)` along the rows of the concatenation (so the step from
/// one channel's last column to the next channel's first counts), `CF` along the columns,
/// `sqrt(RF + CF)`.
#[inline(never)]
fn spatial_frequency(planes: &[Plane]) -> f64 {
    let (w, h) = (planes[0].width, planes[0].height);
    let n = (w * h * planes.len()) as f64;
    let (mut rf, mut cf) = (0u64, 0u64);
    let sq = |a: u8, b: u8| u64::from(a.abs_diff(b)).pow(2);
    for y in 0..h {
        let mut prev: Option<u8> = None;
        for p in planes {
            let row = &p.data[y * w..(y + 1) * w];
            for &v in row {
                if let Some(q) = prev {
                    rf += sq(v, q);
                }
                prev = Some(v);
            }
            if y > 0 {
                let above = &p.data[(y - 1) * w..y * w];
                cf += row.iter().zip(above).map(|(&a, &b)| sq(a, b)).sum::<u64>();
            }
        }
    }
    (rf as f64 / n + cf as f64 / n).sqrt()
}

/// Half the side of [`atan_table`]: Sobel responses `|x|, |y| ≤ ATAN_SPAN` are looked up.
const ATAN_SPAN: i32 = 96;

/// Qabf's orientation `atan((255y)/(255x))` (π/2 where `x` is 0) of every integer Sobel pair
/// with `|x|, |y| ≤ ATAN_SPAN`, by the same expression as for any other pair: a lookup gives
/// the bits the call gives. Most pixels of real images have responses this small.
fn atan_table() -> &'static [f64] {
    static TABLE: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let r = ATAN_SPAN;
        (-r..=r).flat_map(|y| (-r..=r).map(move |x| sobel_angle(x, y))).collect()
    })
}

/// Qabf's orientation of one Sobel pair (`α`, π/2 where the x response is 0).
fn sobel_angle(x: i32, y: i32) -> f64 {
    let (x, y) = (255.0 * f64::from(x), 255.0 * f64::from(y));
    if x == 0.0 { std::f64::consts::FRAC_PI_2 } else { (y / x).atan() }
}

/// The image with a zero border of one pixel (`conv2`'s zero padding), `w + 2` wide.
fn zero_bordered(d: &[u8], w: usize, h: usize) -> Vec<u8> {
    let pw = w + 2;
    let mut pad = vec![0u8; pw * (h + 2)];
    for y in 0..h {
        pad[(y + 1) * pw + 1..(y + 1) * pw + 1 + w].copy_from_slice(&d[y * w..(y + 1) * w]);
    }
    pad
}

/// Row `y` of Qabf's strength `g` and orientation `α` of a zero-bordered image: the 3 × 3
/// Sobel responses of `conv2(·, h, 'same')` as exact integers — `x` for `[−1 0 1; −2 0 2;
/// −1 0 1]`, `y` for `[1 2 1; 0 0 0; −1 −2 −1]` (convolution flips both, which negates both
/// and leaves ratios and magnitudes unchanged) — scaled by 255 (`255*im2double` of a `double`
/// image), `g = √(x² + y²)`.
fn strength_angle_row(pad: &[u8], w: usize, y: usize, g: &mut [f64], a: &mut [f64]) {
    let pw = w + 2;
    let row = |k: usize| &pad[(y + k) * pw..(y + k + 1) * pw];
    let (up, mid, down) = (row(0), row(1), row(2));
    let px = |r: &[u8], x: usize| i32::from(r[x]);
    let table = atan_table();
    let side = 2 * ATAN_SPAN + 1;
    for x in 0..w {
        let sx =
            px(up, x + 2) + 2 * px(mid, x + 2) + px(down, x + 2) - px(up, x) - 2 * px(mid, x) - px(down, x);
        let sy = px(up, x) + 2 * px(up, x + 1) + px(up, x + 2)
            - px(down, x)
            - 2 * px(down, x + 1)
            - px(down, x + 2);
        let (fx, fy) = (255.0 * f64::from(sx), 255.0 * f64::from(sy));
        g[x] = (fx * fx + fy * fy).sqrt();
        a[x] = if sx.abs() <= ATAN_SPAN && sy.abs() <= ATAN_SPAN {
            table[((sy + ATAN_SPAN) * side + sx + ATAN_SPAN) as usize]
        } else {
            sobel_angle(sx, sy)
        };
    }
}

/// `metricsQabf.m` (Xydeas–Petrović): Sobel strength g and orientation α (π/2 where the x
/// response is 0) of each image scaled by 255 (`255*im2double` of a `double` image), then per
/// source `Q = Tg/(1+e^{kg(G−Dg)}) · Ta/(1+e^{ka(A−Da)})` with `G = min/max` of the strengths —
/// or the fused strength itself where they are equal (the file's branch) — and
/// `A = 1 − |α_S − α_F|/(π/2)`; result `Σ(Q_A g_A + Q_B g_B)/Σ(g_A + g_B)`.
///
/// Streamed a row at a time, the sums in the direct loop's order (every pixel of A, then of B).
/// A pixel whose source strength is 0 adds exactly 0 and is skipped.
#[inline(never)]
fn qabf(a: Plane, b: Plane, f: Plane) -> f64 {
    const TG: f64 = 0.9994;
    const KG: f64 = -15.0;
    const DG: f64 = 0.5;
    const TA: f64 = 0.9879;
    const KA: f64 = -22.0;
    const DA: f64 = 0.8;
    let (w, h) = (f.width, f.height);
    let pf = zero_bordered(f.data, w, h);
    let (mut gf, mut af, mut gs, mut as_) = (vec![0f64; w], vec![0f64; w], vec![0f64; w], vec![0f64; w]);
    let mut nume = 0.0;
    let mut deno = 0.0;
    for src in [a, b] {
        let ps = zero_bordered(src.data, w, h);
        for y in 0..h {
            strength_angle_row(&pf, w, y, &mut gf, &mut af);
            strength_angle_row(&ps, w, y, &mut gs, &mut as_);
            for k in 0..w {
                let (g_s, g_f) = (gs[k], gf[k]);
                if g_s == 0.0 {
                    continue;
                }
                let ratio = if g_s > g_f {
                    g_f / g_s
                } else if g_s == g_f {
                    g_f
                } else {
                    g_s / g_f
                };
                let angle = 1.0 - (as_[k] - af[k]).abs() / std::f64::consts::FRAC_PI_2;
                let qg = TG / (1.0 + (KG * (ratio - DG)).exp());
                let qa = TA / (1.0 + (KA * (angle - DA)).exp());
                nume += qg * qa * g_s;
                deno += g_s;
            }
        }
    }
    nume / deno
}

/// `normalize1` of `metricsQcb.m`/`metricsQcv.m`: `round((x − min)/(max − min)·255)`; an
/// all-zero image stays 0 and any other constant image becomes NaN (0/0), as in the file.
#[inline(never)]
fn normalize1(d: &[u8], out: &mut [f64]) {
    let (lo, hi) = d.iter().fold((u8::MAX, u8::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    if lo == 0 && hi == 0 {
        out.fill(0.0);
        return;
    }
    let (lo, range) = (f64::from(lo), f64::from(hi) - f64::from(lo));
    let map: Vec<f64> = (0..=255u8).map(|v| ((f64::from(v) - lo) / range * 255.0).round()).collect();
    for (o, &v) in out.iter_mut().zip(d) {
        *o = map[v as usize];
    }
}

/// `freqspace(n)`'s frequencies at FFT index `k` (un-shifted): `2k/n` for `k < ⌈n/2⌉`, else
/// `2(k − n)/n` — the value `ifftshift` puts at `k`.
fn freq(k: usize, n: usize) -> f64 {
    let signed = if k < n.div_ceil(2) { k as f64 } else { k as f64 - n as f64 };
    2.0 * signed / n as f64
}

/// The plans, filter tables and buffers of Qcb and Qcv for one image size, made once per
/// triple and reused by every channel (the filters and the Gaussians' spectra depend on the
/// size only).
struct Chen {
    /// The image grid.
    small: Spectra2d,
    /// The grid padded by the Gaussians' radius 15 (linear, not circular, filtering).
    padded: Spectra2d,
    /// Chen–Blum's contrast-sensitivity filter on the image grid (column layout).
    csf: Vec<f64>,
    /// Chen–Varshney's Mannos–Sakrison filter on the image grid.
    mannos: Vec<f64>,
    /// The real spectra of the two Gaussians (σ 2 and 4) on the padded grid.
    k2: Vec<f64>,
    k4: Vec<f64>,
    /// The three `normalize1`d channels and their spectra.
    norm: [Vec<f64>; 3],
    spec: [Vec<Complex<f64>>; 3],
    /// A CSF-filtered image on the zero-padded grid, its spectrum, and its two Gaussian sums.
    big: Vec<f64>,
    big_spec: Vec<Complex<f64>>,
    g2: Vec<f64>,
    g4: Vec<f64>,
    /// The three images' `C'` (Qcb); the first is then Qcv's filtered difference image.
    contrast: [Vec<f64>; 3],
}

impl Chen {
    fn new(w: usize, h: usize) -> Self {
        let small = Spectra2d::new(w, h);
        let (pw, ph) = (fft::fast_size(w + 15), fft::fast_size(h + 15));
        let mut padded = Spectra2d::new(pw, ph);
        let (hh, ll) = (h as f64 / 30.0, w as f64 / 30.0);
        let csf = small.table(|ky, kx| {
            let (u, v) = (ll * freq(kx, w), hh * freq(ky, h));
            let r = (u * u + v * v).sqrt();
            (-(r / 15.3870).powi(2)).exp() - 0.7622 * (-(r / 1.3456).powi(2)).exp()
        });
        let (sw, sh) = (w as f64 / 8.0, h as f64 / 8.0);
        let mannos = small.table(|ky, kx| {
            let (u, v) = (sw * freq(kx, w), sh * freq(ky, h));
            let r = (u * u + v * v).sqrt();
            2.6 * (0.0192 + 0.144 * r) * (-(0.144 * r).powf(1.1)).exp()
        });
        let mut big_spec = vec![Complex::default(); padded.len()];
        let mut kernel = |sigma: f64| -> Vec<f64> {
            // `exp(−(x² + y²)/2σ²)/(2πσ²)` for x, y in −15..15, centred on (0, 0) of the padded grid.
            let mut k = vec![0f64; pw * ph];
            for dy in -15i32..=15 {
                for dx in -15i32..=15 {
                    let (x, y) = (f64::from(dx), f64::from(dy));
                    let v = (-(x * x + y * y) / (2.0 * sigma * sigma)).exp()
                        / (2.0 * std::f64::consts::PI * sigma * sigma);
                    k[dy.rem_euclid(ph as i32) as usize * pw + dx.rem_euclid(pw as i32) as usize] = v;
                }
            }
            // An even kernel has a real spectrum (the imaginary parts are rounding noise).
            padded.forward(&k, &mut big_spec);
            big_spec.iter().map(|c| c.re).collect()
        };
        let (k2, k4) = (kernel(2.0), kernel(4.0));
        let spec = [(); 3].map(|_| vec![Complex::default(); small.len()]);
        Self {
            csf,
            mannos,
            k2,
            k4,
            norm: [(); 3].map(|_| vec![0.0; w * h]),
            spec,
            big: vec![0.0; pw * ph],
            big_spec,
            g2: vec![0.0; pw * ph],
            g4: vec![0.0; pw * ph],
            contrast: [(); 3].map(|_| vec![0.0; w * h]),
            small,
            padded,
        }
    }

    /// Qcb and Qcv of one channel triple; they share the rescale (`normalize1`) and the
    /// forward FFTs.
    #[inline(never)]
    fn metrics(&mut self, a: Plane, b: Plane, f: Plane) -> (f64, f64) {
        for (k, p) in [a, b, f].iter().enumerate() {
            normalize1(p.data, &mut self.norm[k]);
            self.small.forward(&self.norm[k], &mut self.spec[k]);
        }
        (self.chen_blum(), self.chen_varshney())
    }

    /// `metricsQcb.m` (Chen–Blum), on the `normalize1`d channels' spectra `[A, B, F]`.
    ///
    /// Contrast-sensitivity filter `S(r) = e^{−(r/15.3870)²} − 0.7622·e^{−(r/1.3456)²}` on
    /// `freqspace` scaled by (W/30, H/30); local contrast `C = |G₂ ∗ I / G₄ ∗ I − 1|` with the
    /// unnormalised 31 × 31 Gaussians σ 2 and 4 (`filter2 … 'same'`, zero padding); `C' = C³/(C² +
    /// 10⁻⁴)`; preservation `Q_SF = min/max(C'_S, C'_F)`; saliency `λ_A = C'_A²/(C'_A² + C'_B²)`;
    /// result the mean of `λ_A Q_AF + λ_B Q_BF`.
    #[inline(never)]
    fn chen_blum(&mut self) -> f64 {
        let (w, h) = (self.small.width, self.small.height);
        let pw = self.padded.width;
        // The local contrast's two Gaussians, `filter2(G, I, 'same')` with zero padding, as
        // products in the frequency domain of a grid padded by the kernels' radius 15 (so
        // nothing wraps around): one forward and two inverse transforms per image. Outside
        // the image `big` stays 0.
        for k in 0..3 {
            let (spec, csf) = (&self.spec[k], &self.csf);
            self.small.inverse(|i| spec[i] * csf[i], &mut self.big, pw);
            self.padded.forward(&self.big, &mut self.big_spec);
            let (sb, k2, k4) = (&self.big_spec, &self.k2, &self.k4);
            self.padded.inverse(|i| sb[i] * k2[i], &mut self.g2, pw);
            self.padded.inverse(|i| sb[i] * k4[i], &mut self.g4, pw);
            for y in 0..h {
                let (g2, g4) = (&self.g2[y * pw..y * pw + w], &self.g4[y * pw..y * pw + w]);
                for ((o, &g2), &g4) in self.contrast[k][y * w..(y + 1) * w].iter_mut().zip(g2).zip(g4) {
                    // `C' = C³/(C² + 10⁻⁴)` with `C = |G₂∗I/G₄∗I − 1|`.
                    let c = (g2 / g4 - 1.0).abs();
                    *o = c.powi(3) / (c * c + 0.0001);
                }
            }
        }
        let [ca, cb, cf] = &self.contrast;
        // MATLAB's `(X./Y).*mask + (Y./X).*(1−mask)`: an Inf or NaN in the unused branch still
        // poisons the sum (Inf·0 = NaN), so both branches are evaluated.
        let pres = |x: f64, y: f64| {
            let m = if x < y { 1.0 } else { 0.0 };
            (x / y) * m + (y / x) * (1.0 - m)
        };
        let mut total = 0.0;
        for k in 0..w * h {
            let (a2, b2) = (ca[k] * ca[k], cb[k] * cb[k]);
            total += a2 / (a2 + b2) * pres(ca[k], cf[k]) + b2 / (a2 + b2) * pres(cb[k], cf[k]);
        }
        total / (w * h) as f64
    }

    /// `metricsQcv.m` (Chen–Varshney), on the spectra `[A, B, F]` and the `normalize1`d sources.
    ///
    /// Saliency per 16 × 16 block (`blkproc`, zero-padded at the bottom and right):
    /// `λ = Σ g⁵` of the source's Sobel magnitude (`filter2 … 'same'`, zero padding). Dissimilarity
    /// per block: `D = mean((S − F) filtered by Mannos–Sakrison)²` over the padded block (÷ 256),
    /// the filter `2.6(0.0192 + 0.144r)e^{−(0.144r)^{1.1}}` on `freqspace` scaled by (W/8, H/8).
    /// Result `Σ(λ_A D_A + λ_B D_B)/Σ(λ_A + λ_B)`; lower is better.
    #[inline(never)]
    fn chen_varshney(&mut self) -> f64 {
        let (w, h) = (self.small.width, self.small.height);
        let (bw, bh) = (w.div_ceil(CV_WIN), h.div_ceil(CV_WIN));
        let la = cv_saliency(&self.norm[0], w, h);
        let lb = cv_saliency(&self.norm[1], w, h);
        let mut dissimilarity = |src: usize| -> Vec<f64> {
            let (s, fs, m) = (&self.spec[src], &self.spec[2], &self.mannos);
            let img = &mut self.contrast[0];
            self.small.inverse(|i| (s[i] - fs[i]) * m[i], img, w);
            let mut blocks = vec![0f64; bw * bh];
            for (y, row) in img.chunks_exact(w).enumerate() {
                let line = &mut blocks[(y / CV_WIN) * bw..(y / CV_WIN + 1) * bw];
                for (bx, part) in row.chunks(CV_WIN).enumerate() {
                    let mut acc = line[bx];
                    for &v in part {
                        acc += v * v;
                    }
                    line[bx] = acc;
                }
            }
            blocks.iter_mut().for_each(|b| *b /= (CV_WIN * CV_WIN) as f64);
            blocks
        };
        let (da, db) = (dissimilarity(0), dissimilarity(1));
        let mut nume = 0.0;
        let mut deno = 0.0;
        for k in 0..bw * bh {
            nume += la[k] * da[k] + lb[k] * db[k];
            deno += la[k] + lb[k];
        }
        nume / deno
    }
}

/// Qcv's block size.
const CV_WIN: usize = 16;

/// Qcv's saliency `Σ g⁵` per 16 × 16 block of the Sobel magnitude of `img` (zero padding),
/// each block summed in row order as the direct loop does.
fn cv_saliency(img: &[f64], w: usize, h: usize) -> Vec<f64> {
    let (bw, bh) = (w.div_ceil(CV_WIN), h.div_ceil(CV_WIN));
    // The image with a zero border of one pixel.
    let pw = w + 2;
    let mut pad = vec![0f64; pw * (h + 2)];
    for y in 0..h {
        pad[(y + 1) * pw + 1..(y + 1) * pw + 1 + w].copy_from_slice(&img[y * w..(y + 1) * w]);
    }
    let mut blocks = vec![0f64; bw * bh];
    let mut g5 = vec![0f64; w];
    for y in 0..h {
        let (up, mid, down) =
            (&pad[y * pw..(y + 1) * pw], &pad[(y + 1) * pw..(y + 2) * pw], &pad[(y + 2) * pw..(y + 3) * pw]);
        cv_row(up, mid, down, &mut g5);
        let line = &mut blocks[(y / CV_WIN) * bw..(y / CV_WIN + 1) * bw];
        for (bx, part) in g5.chunks(CV_WIN).enumerate() {
            let mut acc = line[bx];
            for &v in part {
                acc += v;
            }
            line[bx] = acc;
        }
    }
    blocks
}

/// `g⁵` of one row's Sobel magnitude from the padded rows above, at and below it (`w + 2`
/// wide); the same operations in the same order as the direct formula.
#[multiversion::multiversion(targets(
    "x86_64+avx2+fma",
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl",
    "aarch64+neon"
))]
fn cv_row(up: &[f64], mid: &[f64], down: &[f64], out: &mut [f64]) {
    let w = out.len();
    let (up, mid, down) = (&up[..w + 2], &mid[..w + 2], &down[..w + 2]);
    for x in 0..w {
        // Padded column x + 1 is image column x.
        let gx = up[x + 2] + 2.0 * mid[x + 2] + down[x + 2] - up[x] - 2.0 * mid[x] - down[x];
        let gy = down[x] + 2.0 * down[x + 1] + down[x + 2] - up[x] - 2.0 * up[x + 1] - up[x + 2];
        let g = (gx * gx + gy * gy).sqrt();
        out[x] = g.powi(5);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fusion_io::load_channels_u8;

    fn plane_of(data: &[u8], w: usize) -> Plane<'_> {
        Plane { width: w, height: data.len() / w, data }
    }

    #[test]
    fn hand_cases_of_the_files_own_formulas() {
        // `mse` of metricsRmse.m: sqrt(Σ d²)/(m·n) = sqrt(9 + 16)/4.
        assert_eq!(vifb_error(&[0, 0, 0, 0], &[3, 4, 0, 0], 4.0), 5.0 / 4.0);
        // `gradient`: one-sided on the border columns (1 and 3), central inside (4/2 = 2); no
        // vertical change. Σ |dx|/√2 over 3 rows, divided by (3 − 1)(3 − 1).
        let ramp = [0, 1, 4, 0, 1, 4, 0, 1, 4];
        let want = 3.0 * (1.0 + 2.0 + 3.0) / 2f64.sqrt() / 4.0;
        assert!((average_gradient(plane_of(&ramp, 3)) - want).abs() < 1e-12);
        // Spatial frequency of two 1 × 2 channels side by side: the row [1, 3, 0, 2] has steps
        // 2, −3, 2 (the middle one across the channels), no column steps: sqrt(17/4).
        let (a, b) = ([1u8, 3], [0u8, 2]);
        assert_eq!(spatial_frequency(&[plane_of(&a, 2), plane_of(&b, 2)]), (17f64 / 4.0).sqrt());
        // KL of identical histograms is 0; entropy of a two-level half/half image is 1 bit.
        let h = histogram(&[0, 0, 9, 9]);
        assert_eq!(kl_bits(&h, &h, 4.0), 0.0);
        assert_eq!(entropy_bits(&h, 4.0), 1.0);
    }

    #[test]
    fn mutinf_is_in_nats_after_the_min_max_rescale() {
        // Full range: the rescale is the identity, so MI(X, X) = H(X) in nats.
        let x: Vec<u8> = (0..4096u32).map(|i| ((i * 2654435761) >> 24) as u8).collect();
        assert!(x.contains(&0) && x.contains(&255));
        let h = histogram(&x);
        let nats = -h.iter().filter(|&&c| c > 0).map(|&c| c as f64 / 4096.0).map(|p| p * p.ln()).sum::<f64>();
        assert!((mutinf(&x, &x) - nats).abs() < 1e-12);
        // The rescale makes MI blind to an offset and a scale: MI(X, 2X + 10) on a half-range X.
        let half: Vec<u8> = x.iter().map(|v| v / 2).collect();
        let moved: Vec<u8> = half.iter().map(|v| v * 2 + 10).collect();
        assert!((mutinf(&half, &moved) - mutinf(&half, &half)).abs() < 1e-12);
        // A constant image goes to bin 0: no information.
        assert_eq!(mutinf(&[7; 16], &x[..16]), 0.0);
    }

    #[test]
    fn qabf_of_an_image_with_itself_takes_the_files_equal_strength_branch() {
        // gA = gF everywhere, so the file sets G to the strength itself (≥ 255 where it is not 0)
        // instead of 1: Q_g = Tg exactly, and A = 1: Q = Tg·Ta/(1 + e^{−22·0.2}).
        let x: Vec<u8> = (0..30 * 20u32).map(|i| ((i * 2654435761) >> 24) as u8).collect();
        let p = plane_of(&x, 30);
        let want = 0.9994 * 0.9879 / (1.0 + (-22.0f64 * (1.0 - 0.8)).exp());
        assert!((qabf(p, p, p) - want).abs() < 1e-12, "{} vs {want}", qabf(p, p, p));
    }

    #[test]
    fn a_constant_non_zero_image_is_undefined_for_the_chen_metrics() {
        // normalize1 divides 0 by 0: NaN, as VIFB's code gives.
        let mut out = [1.0; 4];
        normalize1(&[5; 4], &mut out);
        assert!(out.iter().all(|v| v.is_nan()));
        normalize1(&[0; 4], &mut out);
        assert_eq!(out, [0.0; 4]);
        let n: Vec<u8> = (0..16 * 16u32).map(|i| (i * 37 % 256) as u8).collect();
        let (c, t) = (vec![9u8; 256], plane_of(&n, 16));
        let (qcb, qcv) = Chen::new(16, 16).metrics(plane_of(&c, 16), t, t);
        assert!(qcb.is_nan() && qcv.is_nan());
    }

    #[test]
    fn colour_is_the_channel_mean_and_sf_lays_the_channels_side_by_side() {
        let d = fusion_io::testdata::vifb_dir();
        let load = |n: &str| load_channels_u8(&d.join(n)).unwrap();
        let (v, i) = (load("fight_VIS.png"), load("fight_IR.png"));
        let outs = ["ADF", "TSIFSD", "IFEVIP"].map(|m| load(&format!("fight_{m}_ref.png")));
        let (w, h) = (v.width, v.height);
        let vis = Channels {
            width: w,
            height: h,
            planes: vec![v.planes[0].clone(), i.planes[0].clone(), v.planes[0].clone()],
        };
        let fused =
            Channels { width: w, height: h, planes: outs.iter().map(|o| o.planes[0].clone()).collect() };
        let colour = vifb_metrics(&vis, &i, &fused).unwrap().values();
        let grey: Vec<[f64; 13]> = (0..3)
            .map(|k| {
                let g = |c: &Channels, k: usize| Channels::from_gray(c.plane(k));
                vifb_metrics(&g(&vis, k), &i, &g(&fused, k)).unwrap().values()
            })
            .collect();
        for (m, key) in KEYS.iter().enumerate().filter(|&(_, &k)| k != "SF") {
            let mean = (grey[0][m] + grey[1][m] + grey[2][m]) / 3.0;
            assert!((colour[m] - mean).abs() <= 1e-12 * mean.abs(), "{key}: {} vs {mean}", colour[m]);
        }
        // SF: the grey SF of the 3W × H image made of the three channels side by side.
        let mut wide = Vec::with_capacity(3 * w * h);
        for y in 0..h {
            for p in &fused.planes {
                wide.extend_from_slice(&p[y * w..(y + 1) * w]);
            }
        }
        let sf = spatial_frequency(&[plane_of(&wide, 3 * w)]);
        assert_eq!(colour[10], sf);
    }
}
