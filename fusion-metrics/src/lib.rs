//! # fusion-metrics
//!
//! Fusion-quality and noise metrics in `f64` (every variant and the code it follows:
//! `docs/metrics.md`): the study's suite (AG, MI, FMI, SSIM, RMSE, and Haghighat's FMIs), VIFB's
//! 13 exactly as VIFB's MATLAB code computes them ([`vifb`]), the noise metrics against a
//! reference ([`noise_metrics`]), and one call that scores a triple and prints it
//! ([`table::score_images`], what `fusion eval` and `vistir.eval` run).
//!
//! All take 8-bit images as `Gray<u8>` (0..255 units). "1:2" metrics compare a fused image with
//! both sources, "1:1" metrics compare one image with one reference. Where a metric is
//! undefined (constant images, images smaller than a window) it returns a defined value and
//! the function says which.
//!
//! ```
//! use fusion_io::Gray;
//! use fusion_metrics::{fusion_metrics, noise_metrics};
//!
//! let vis = Gray { width: 16, height: 16, data: (0..256).map(|i| (i % 16 * 16) as u8).collect() };
//! let tir = Gray { width: 16, height: 16, data: (0..256).map(|i| (i / 16 * 16) as u8).collect() };
//! let fused = Gray { width: 16, height: 16, data: vis.data.iter().zip(&tir.data).map(|(a, b)| a / 2 + b / 2).collect() };
//! let m = fusion_metrics(&vis, &tir, &fused);
//! assert!(m.mi > 0.0 && m.ag > 0.0);
//! // An image against itself: no noise, infinite PSNR, SSIM 1.
//! let n = noise_metrics(&fused, &fused);
//! assert_eq!((n.mse_s, n.psnr_s, n.ssim_s), (0.0, f64::INFINITY, 1.0));
//! ```

use fusion_io::Gray;

mod fft;
mod filter;
pub mod fmi;
pub mod table;
pub mod vifb;

pub use fmi::{FmiFeature, HaghighatFeature, fmi, fmi_haghighat, fmi_pair, fmi_pair_with, sobel_magnitude};

pub(crate) fn same_size<T, U>(a: &Gray<T>, b: &Gray<U>) {
    assert_eq!((a.width, a.height), (b.width, b.height), "metric inputs must have the same size");
}

/// Shannon entropy (bits) of a normalised histogram.
pub(crate) fn entropy(p: &[f64]) -> f64 {
    p.iter().filter(|&&v| v > 0.0).map(|&v| -v * v.log2()).sum()
}

/// Entropy (bits) of an 8-bit image's 256-bin histogram.
pub fn entropy_u8(a: &Gray<u8>) -> f64 {
    let mut h = [0f64; 256];
    for &v in &a.data {
        h[v as usize] += 1.0;
    }
    let n = a.data.len() as f64;
    h.iter_mut().for_each(|v| *v /= n);
    entropy(&h)
}

/// Mutual information (bits) of two 8-bit images over the 256 × 256 joint histogram.
/// MI(X, X) = H(X); MI of a constant image with anything is 0.
pub fn mutual_information(a: &Gray<u8>, b: &Gray<u8>) -> f64 {
    same_size(a, b);
    let mut joint = vec![0f64; 256 * 256];
    let mut pa = [0f64; 256];
    let mut pb = [0f64; 256];
    for (&x, &y) in a.data.iter().zip(&b.data) {
        joint[x as usize * 256 + y as usize] += 1.0;
        pa[x as usize] += 1.0;
        pb[y as usize] += 1.0;
    }
    let n = a.data.len() as f64;
    let mut mi = 0.0;
    for (i, row) in joint.chunks_exact(256).enumerate() {
        for (j, &c) in row.iter().enumerate() {
            if c > 0.0 {
                mi += c / n * ((c * n) / (pa[i] * pb[j])).log2();
            }
        }
    }
    mi.max(0.0)
}

/// The 11 × 11 Gaussian window (σ = 1.5) of SSIM, normalised to sum 1.
/// The 11-tap Gaussian (σ 1.5) normalised to sum 1; the 2-D window is its outer product
/// (exactly the normalised 2-D Gaussian, since exp(−(x²+y²)/2σ²) = exp(−x²/2σ²)·exp(−y²/2σ²)).
fn ssim_window() -> [f64; 11] {
    let mut w = [0f64; 11];
    for (j, v) in w.iter_mut().enumerate() {
        let x = j as f64 - 5.0;
        *v = (-(x * x) / (2.0 * 1.5 * 1.5)).exp();
    }
    let sum: f64 = w.iter().sum();
    w.map(|v| v / sum)
}

/// SSIM (Wang et al. 2004): 11 × 11 Gaussian window σ 1.5, K1 = 0.01, K2 = 0.03, L = 255,
/// mean over the valid windows (no padding). Images smaller than 11 × 11 use one window over
/// the whole image with uniform weights. SSIM(X, X) = 1.
pub fn ssim(a: &Gray<u8>, b: &Gray<u8>) -> f64 {
    same_size(a, b);
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let index = |ma: f64, mb: f64, va: f64, vb: f64, cov: f64| {
        ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2))
    };
    let (w, h) = (a.width, a.height);
    if w < 11 || h < 11 {
        let n = (w * h) as f64;
        let ma = a.data.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let mb = b.data.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let (mut va, mut vb, mut cov) = (0.0, 0.0, 0.0);
        for (&x, &y) in a.data.iter().zip(&b.data) {
            let (dx, dy) = (f64::from(x) - ma, f64::from(y) - mb);
            va += dx * dx;
            vb += dy * dy;
            cov += dx * dy;
        }
        return index(ma, mb, va / n, vb / n, cov / n);
    }
    ssim_valid_windows(&a.data, &b.data, w, h)
}

/// SSIM(a, f) and SSIM(b, f) over a VIFB channel triple (the same windows and constants as
/// [`ssim`]; the caller guarantees the sides are at least 11): the eight moment images a, b, f,
/// a², b², f², af, bf filtered once (f and f² serve both pairs), each index summed in window
/// order as [`ssim_valid_windows`] sums it — the same values as two separate calls.
#[inline(never)]
pub(crate) fn ssim_valid_pair(a: vifb::Plane, b: vifb::Plane, f: vifb::Plane) -> (f64, f64) {
    let (w, h) = (f.width, f.height);
    let (a, b, f) = (a.data, b.data, f.data);
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let index = |ma: f64, mb: f64, va: f64, vb: f64, cov: f64| {
        ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2))
    };
    let g = ssim_window();
    let (mut total_a, mut total_b) = (0.0, 0.0);
    filter::correlate_valid_in_strips(
        8,
        (w, h),
        &g,
        |p, y, row| {
            let (ra, rb, rf) = (&a[y * w..(y + 1) * w], &b[y * w..(y + 1) * w], &f[y * w..(y + 1) * w]);
            match p {
                0..=2 => {
                    for (o, &x) in row.iter_mut().zip([ra, rb, rf][p]) {
                        *o = f64::from(x);
                    }
                }
                3..=5 => {
                    for (o, &x) in row.iter_mut().zip([ra, rb, rf][p - 3]) {
                        *o = f64::from(x) * f64::from(x);
                    }
                }
                _ => {
                    for ((o, &x), &y) in row.iter_mut().zip([ra, rb][p - 6]).zip(rf) {
                        *o = f64::from(x) * f64::from(y);
                    }
                }
            }
        },
        |_, n, m| {
            let len = n * (w - 10);
            let [ma, mb, mf, saa, sbb, sff, saf, sbf] = [0, 1, 2, 3, 4, 5, 6, 7].map(|p| &m[p][..len]);
            for k in 0..len {
                total_a += index(
                    ma[k],
                    mf[k],
                    saa[k] - ma[k] * ma[k],
                    sff[k] - mf[k] * mf[k],
                    saf[k] - ma[k] * mf[k],
                );
            }
            for k in 0..len {
                total_b += index(
                    mb[k],
                    mf[k],
                    sbb[k] - mb[k] * mb[k],
                    sff[k] - mf[k] * mf[k],
                    sbf[k] - mb[k] * mf[k],
                );
            }
        },
    );
    let n = ((h - 10) * (w - 10)) as f64;
    (total_a / n, total_b / n)
}

/// Mean SSIM over the valid 11 × 11 windows of two `w × h` images (`w, h ≥ 11`): MATLAB's
/// `filter2(window, ·, 'valid')` of the five moment images, then the index, then `mean2`.
#[inline(never)]
fn ssim_valid_windows(a: &[u8], b: &[u8], w: usize, h: usize) -> f64 {
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let index = |ma: f64, mb: f64, va: f64, vb: f64, cov: f64| {
        ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2))
    };
    // The five moment images a, b, a², b², ab, each filtered with the window over its valid
    // part, streamed in strips of rows; the index per window, summed in row order.
    let g = ssim_window();
    let mut total = 0.0;
    filter::correlate_valid_in_strips(
        5,
        (w, h),
        &g,
        |p, y, row| {
            let (ra, rb) = (&a[y * w..(y + 1) * w], &b[y * w..(y + 1) * w]);
            let moment: fn(f64, f64) -> f64 = match p {
                0 => |x, _| x,
                1 => |_, y| y,
                2 => |x, _| x * x,
                3 => |_, y| y * y,
                _ => |x, y| x * y,
            };
            for ((o, &x), &y) in row.iter_mut().zip(ra).zip(rb) {
                *o = moment(f64::from(x), f64::from(y));
            }
        },
        |_, n, m| {
            let len = n * (w - 10);
            let [ma, mb, saa, sbb, sab] = [0, 1, 2, 3, 4].map(|p| &m[p][..len]);
            for k in 0..len {
                total += index(
                    ma[k],
                    mb[k],
                    saa[k] - ma[k] * ma[k],
                    sbb[k] - mb[k] * mb[k],
                    sab[k] - ma[k] * mb[k],
                );
            }
        },
    );
    total / ((h - 10) * (w - 10)) as f64
}

/// Mean squared error in 0..255 units.
pub fn mse(a: &Gray<u8>, b: &Gray<u8>) -> f64 {
    same_size(a, b);
    let s: f64 = a.data.iter().zip(&b.data).map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2)).sum();
    s / a.data.len() as f64
}

/// Root mean squared error in 0..255 units.
pub fn rmse(a: &Gray<u8>, b: &Gray<u8>) -> f64 {
    mse(a, b).sqrt()
}

/// Average gradient: mean over pixels of `sqrt((∇x² + ∇y²)/2)` with forward differences, over
/// the (W−1) × (H−1) pixels that have both; 0 for an image with a side of 1.
pub fn average_gradient(a: &Gray<u8>) -> f64 {
    let (w, h) = (a.width, a.height);
    if w < 2 || h < 2 {
        return 0.0;
    }
    let mut s = 0.0;
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            let p = f64::from(a.at(x, y));
            let gx = f64::from(a.at(x + 1, y)) - p;
            let gy = f64::from(a.at(x, y + 1)) - p;
            s += ((gx * gx + gy * gy) / 2.0).sqrt();
        }
    }
    s / ((w - 1) * (h - 1)) as f64
}

/// The study's 1:2 fusion metrics of a fused image against its two sources.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FusionMetrics {
    /// Average gradient of the fused image.
    pub ag: f64,
    /// MI(VIS, F) + MI(TIR, F), bits.
    pub mi: f64,
    /// Feature mutual information (see [`fmi()`]), in [0, 1].
    pub fmi: f64,
    /// SSIM(VIS, F) + SSIM(TIR, F), up to 2.
    pub ssim: f64,
    /// (RMSE(VIS, F) + RMSE(TIR, F)) / 2, 0..255 units.
    pub rmse: f64,
}

/// Computes the 1:2 metrics (sources already on the fused image's grid).
pub fn fusion_metrics(vis: &Gray<u8>, tir: &Gray<u8>, fused: &Gray<u8>) -> FusionMetrics {
    FusionMetrics {
        ag: average_gradient(fused),
        mi: mutual_information(vis, fused) + mutual_information(tir, fused),
        fmi: fmi(vis, tir, fused),
        ssim: ssim(vis, fused) + ssim(tir, fused),
        rmse: (rmse(vis, fused) + rmse(tir, fused)) / 2.0,
    }
}

/// The 1:1 noise metrics of an image against its reference.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct NoiseMetrics {
    /// MSE on [0, 1] images.
    pub mse_s: f64,
    /// 10·log10(1 / MSE_S) dB; `f64::INFINITY` for identical images (reported as "inf").
    pub psnr_s: f64,
    /// SSIM against the reference.
    pub ssim_s: f64,
}

/// Computes the 1:1 metrics of `img` against `reference`.
pub fn noise_metrics(img: &Gray<u8>, reference: &Gray<u8>) -> NoiseMetrics {
    let mse_s = mse(img, reference) / (255.0 * 255.0);
    let psnr_s = if mse_s == 0.0 { f64::INFINITY } else { 10.0 * (1.0 / mse_s).log10() };
    NoiseMetrics { mse_s, psnr_s, ssim_s: ssim(img, reference) }
}

/// Formats a PSNR for tables: "inf" for identical images.
pub fn format_psnr(p: f64) -> String {
    if p.is_infinite() { "inf".to_string() } else { format!("{p:.2}") }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: usize, h: usize, data: Vec<u8>) -> Gray<u8> {
        Gray { width: w, height: h, data }
    }

    fn pattern(w: usize, h: usize, seed: u64) -> Gray<u8> {
        let mut s = seed;
        img(
            w,
            h,
            (0..w * h)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    (s >> 56) as u8
                })
                .collect(),
        )
    }

    #[test]
    fn mi_of_an_image_with_itself_is_its_entropy() {
        let a = pattern(40, 30, 1);
        assert!((mutual_information(&a, &a) - entropy_u8(&a)).abs() < 1e-12);
        // Hand case: two values, equally likely, perfectly dependent → 1 bit; independent → 0.
        let x = img(4, 1, vec![0, 0, 255, 255]);
        assert!((mutual_information(&x, &x) - 1.0).abs() < 1e-12);
        let y = img(4, 1, vec![0, 255, 0, 255]);
        assert!(mutual_information(&x, &y).abs() < 1e-12);
        let c = img(4, 1, vec![7; 4]);
        assert_eq!(mutual_information(&c, &x), 0.0);
    }

    #[test]
    fn ssim_properties() {
        let a = pattern(32, 24, 2);
        assert!((ssim(&a, &a) - 1.0).abs() < 1e-12);
        let b = pattern(32, 24, 3);
        let s = ssim(&a, &b);
        assert!(s < 0.2 && s > -1.0, "independent noise: {s}");
        // Symmetric.
        assert!((ssim(&a, &b) - ssim(&b, &a)).abs() < 1e-12);
        // Constant images: defined (the constants keep it finite), 1 when equal.
        let c = img(12, 12, vec![100; 144]);
        assert!((ssim(&c, &c) - 1.0).abs() < 1e-12);
        // Small images use one global window: hand case with means 0 and 255, no variance.
        let z = img(3, 3, vec![0; 9]);
        let f = img(3, 3, vec![255; 9]);
        let c1 = (0.01f64 * 255.0).powi(2);
        assert!((ssim(&z, &f) - c1 / (255.0 * 255.0 + c1)).abs() < 1e-12);
    }

    /// SSIM by the direct 2-D window sum (the definition) against the separable implementation.
    #[test]
    fn ssim_separable_equals_the_direct_window_sum() {
        let (a, b) = (pattern(17, 14, 6), pattern(17, 14, 7));
        let g = ssim_window();
        let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
        let mut total = 0.0;
        for y0 in 0..=14 - 11 {
            for x0 in 0..=17 - 11 {
                let (mut ma, mut mb, mut saa, mut sbb, mut sab) = (0.0, 0.0, 0.0, 0.0, 0.0);
                for i in 0..11 {
                    for j in 0..11 {
                        let w = g[i] * g[j];
                        let (x, y) = (f64::from(a.at(x0 + j, y0 + i)), f64::from(b.at(x0 + j, y0 + i)));
                        (ma, mb) = (ma + w * x, mb + w * y);
                        (saa, sbb, sab) = (saa + w * x * x, sbb + w * y * y, sab + w * x * y);
                    }
                }
                let (va, vb, cov) = (saa - ma * ma, sbb - mb * mb, sab - ma * mb);
                total +=
                    ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            }
        }
        let direct = total / (4.0 * 7.0);
        assert!((ssim(&a, &b) - direct).abs() < 1e-12, "{} vs {direct}", ssim(&a, &b));
    }

    #[test]
    fn rmse_ag_psnr_hand_cases() {
        let a = img(2, 2, vec![0, 0, 0, 0]);
        let b = img(2, 2, vec![3, 4, 0, 0]);
        assert_eq!(rmse(&a, &a), 0.0);
        assert!((rmse(&a, &b) - (25.0f64 / 4.0).sqrt()).abs() < 1e-12);
        assert_eq!(average_gradient(&a), 0.0);
        // One pixel with both forward differences: ∇x = 4 − 3 = 1, ∇y = 0 − 3 = −3.
        assert!((average_gradient(&b) - ((1.0 + 9.0) / 2.0f64).sqrt()).abs() < 1e-12);
        let n = noise_metrics(&a, &a);
        assert_eq!(format_psnr(n.psnr_s), "inf");
        let n = noise_metrics(&a, &img(2, 2, vec![255, 0, 0, 0]));
        assert!((n.mse_s - 0.25).abs() < 1e-12);
        assert!((n.psnr_s - 10.0 * 4.0f64.log10()).abs() < 1e-12);
    }
}
