//! Feature mutual information (FMI): the study's Fast-FMI model and Haghighat's published code.
//!
//! Two families, written down side by side in `docs/metrics.md`:
//! * [`fmi`] — the study's tables: the Fast-FMI model (Haghighat & Razian 2014) with the
//!   window's Pearson correlation `c` as the weight of the Fréchet bound, on Sobel
//!   gradient-magnitude features, 3 × 3 windows.
//! * [`fmi_haghighat`] — Haghighat's own `fmi.m` (the Fast-FMI code the field cites), features
//!   `none` (pixels) or `gradient` (MATLAB `gradient`, the x component), window 3: the weight
//!   is `c` divided by the correlation of the Fréchet bound itself, the windows are flattened
//!   column by column (MATLAB order), and the result is the mean of the per-window
//!   `(FMI_AF + FMI_BF)/2`.

use super::same_size;
use fusion_io::Gray;
use rayon::prelude::*;

/// Sobel gradient magnitude of an image (replicate border), the feature map of [`fmi`].
pub fn sobel_magnitude(a: &Gray<u8>) -> Vec<f64> {
    let (w, h) = (a.width as isize, a.height as isize);
    let px = |x: isize, y: isize| f64::from(a.at(x.clamp(0, w - 1) as usize, y.clamp(0, h - 1) as usize));
    let mut out = Vec::with_capacity(a.data.len());
    for y in 0..h {
        for x in 0..w {
            let gx = (px(x + 1, y - 1) + 2.0 * px(x + 1, y) + px(x + 1, y + 1))
                - (px(x - 1, y - 1) + 2.0 * px(x - 1, y) + px(x - 1, y + 1));
            let gy = (px(x - 1, y + 1) + 2.0 * px(x, y + 1) + px(x + 1, y + 1))
                - (px(x - 1, y - 1) + 2.0 * px(x, y - 1) + px(x + 1, y - 1));
            out.push((gx * gx + gy * gy).sqrt());
        }
    }
    out
}

/// A window's feature values as a probability vector: shifted to a zero minimum and
/// normalised; a flat window becomes the uniform distribution.
fn window_pdf(v: &[f64; 9]) -> [f64; 9] {
    let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
    let shifted = v.map(|x| x - min);
    let sum: f64 = shifted.iter().sum();
    if sum <= 0.0 { [1.0 / 9.0; 9] } else { shifted.map(|x| x / sum) }
}

/// Normalised mutual information `2·I / (H_a + H_f)` of two windows (Fast-FMI model): the joint
/// CDF is the correlation-weighted mix of the Fréchet bound and independence,
/// `H = c·min(F, G) + (1 − c)·F·G` for `c ≥ 0` and `H = |c|·max(F + G − 1, 0) + (1 − |c|)·F·G`
/// for `c < 0`, with `c` the Pearson correlation of the two pdf vectors; the joint pdf is its
/// mixed second difference. Identical windows give 1; two flat windows give 1.
fn window_nmi(a: &[f64; 9], f: &[f64; 9]) -> f64 {
    if a == f {
        return 1.0;
    }
    let (pa, pf) = (window_pdf(a), window_pdf(f));
    let n = pa.len();
    let lg = |p: &[f64; 9]| p.map(|v| if v > 0.0 { v.log2() } else { 0.0 });
    let (la, lf) = (lg(&pa), lg(&pf));
    let ent = |p: &[f64; 9], l: &[f64; 9]| -p.iter().zip(l).map(|(p, l)| p * l).sum::<f64>();
    let (ha, hf) = (ent(&pa, &la), ent(&pf, &lf));
    let mean = 1.0 / n as f64;
    let (mut sab, mut saa, mut sff) = (0.0, 0.0, 0.0);
    for (x, y) in pa.iter().zip(&pf) {
        sab += (x - mean) * (y - mean);
        saa += (x - mean) * (x - mean);
        sff += (y - mean) * (y - mean);
    }
    if saa == 0.0 && sff == 0.0 {
        return 1.0; // both flat: the same (uniform) feature distribution
    }
    let c = if saa == 0.0 || sff == 0.0 { 0.0 } else { sab / (saa * sff).sqrt() };
    let cdf = |p: &[f64; 9]| {
        let mut acc = 0.0;
        p.map(|v| {
            acc += v;
            acc
        })
    };
    let (fa, ff) = (cdf(&pa), cdf(&pf));
    // p = |c|·M + k·pa⊗pf with k = 1 − |c| and M the mixed second difference of the Fréchet
    // bound: M_ij is the length of the overlap of pa's i-th CDF step [Fa_{i−1}, Fa_i] with pf's
    // j-th step (c ≥ 0), or with its mirror [1 − Ff_j, 1 − Ff_{j−1}] (c < 0). M is non-zero on
    // at most 2n − 1 cells. Since p's marginals are pa and pf, MI = Σ p·log2 p + H_a + H_f, and
    // Σ p·log2 p is first summed in closed form as if M were 0 — k·(log2 k − H_a − H_f) — and
    // then corrected on the cells where M > 0: about 2n logarithms per window instead of n².
    let ca = c.abs();
    let k = 1.0 - ca;
    let log_k = if k > 0.0 { k.log2() } else { 0.0 };
    let mut plogp = if k > 0.0 { k * (log_k - ha - hf) } else { 0.0 };
    for i in 0..n {
        let (a0, a1) = (if i == 0 { 0.0 } else { fa[i - 1] }, fa[i]);
        for j in 0..n {
            let (f0, f1) = (if j == 0 { 0.0 } else { ff[j - 1] }, ff[j]);
            let (f0, f1) = if c >= 0.0 { (f0, f1) } else { (1.0 - f1, 1.0 - f0) };
            let m = a1.min(f1) - a0.max(f0);
            if m <= 0.0 || ca == 0.0 {
                continue;
            }
            let ind = k * pa[i] * pf[j];
            if ind > 0.0 {
                plogp -= ind * (log_k + la[i] + lf[j]);
            }
            let p = ca * m + ind;
            if p > 1e-15 {
                plogp += p * p.log2();
            }
        }
    }
    let mi = plogp + ha + hf;
    if ha + hf <= 0.0 { 1.0 } else { (2.0 * mi / (ha + hf)).clamp(0.0, 1.0) }
}

/// Feature mutual information of `f` with one source `a`: the mean over all 3 × 3 windows of
/// the windows' normalised MI on Sobel gradient-magnitude features. In [0, 1]; FMI(X, X) = 1.
pub fn fmi_pair(a: &Gray<u8>, f: &Gray<u8>) -> f64 {
    fmi_pair_with(a, f, FmiFeature::Gradient)
}

/// The feature map FMI compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmiFeature {
    /// Sobel gradient magnitude (the default, "edge features" of metrics.md).
    Gradient,
    /// Raw pixel values (FMI_pixel in the literature).
    Pixels,
}

/// [`fmi_pair`] on a chosen feature map.
pub fn fmi_pair_with(a: &Gray<u8>, f: &Gray<u8>, feature: FmiFeature) -> f64 {
    same_size(a, f);
    let (w, h) = (a.width, a.height);
    if w < 3 || h < 3 {
        return if a.data == f.data { 1.0 } else { 0.0 };
    }
    let (ga, gf) = match feature {
        FmiFeature::Gradient => (sobel_magnitude(a), sobel_magnitude(f)),
        FmiFeature::Pixels => {
            let raw = |g: &Gray<u8>| g.data.iter().map(|&v| f64::from(v)).collect::<Vec<_>>();
            (raw(a), raw(f))
        }
    };
    let row_sum = |y: usize| {
        let mut wa = [0f64; 9];
        let mut wf = [0f64; 9];
        let mut total = 0.0;
        for x in 0..w - 2 {
            for k in 0..9 {
                let idx = (y + k / 3) * w + x + k % 3;
                wa[k] = ga[idx];
                wf[k] = gf[idx];
            }
            total += window_nmi(&wa, &wf);
        }
        total
    };
    // Rows in parallel, summed in row order so the result does not depend on the thread count.
    let rows: Vec<f64> = (0..h - 2).into_par_iter().map(row_sum).collect();
    let total: f64 = rows.iter().sum();
    total / ((w - 2) * (h - 2)) as f64
}

/// FMI of a fused image: the mean of [`fmi_pair`] against VIS and against TIR (so in [0, 1]).
/// Variant: Fast-FMI (Haghighat & Razian 2014) on Sobel gradient magnitudes, 3 × 3 windows.
pub fn fmi(vis: &Gray<u8>, tir: &Gray<u8>, fused: &Gray<u8>) -> f64 {
    (fmi_pair(vis, fused) + fmi_pair(tir, fused)) / 2.0
}

/// The feature map of Haghighat's `fmi.m`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HaghighatFeature {
    /// `'none'`: the raw pixel values (FMI_pixel).
    Pixels,
    /// `'gradient'`: MATLAB `gradient(I)` with one output — the x derivative, central
    /// differences inside and one-sided differences on the first and last column (FMI_gradient).
    Gradient,
}

/// Haghighat's FMI of a fused image `f` against sources `a` and `b`, as his `fmi.m` computes it
/// (Haghighat, Aghagolzadeh & Seyedarabi 2011; the code is his Fast-FMI of Haghighat & Razian
/// 2014), window 3. In [0, 1] up to rounding; an image smaller than 3 × 3 has no window and
/// gives NaN (MATLAB's `mean2` of an empty map).
pub fn fmi_haghighat(a: &Gray<u8>, b: &Gray<u8>, f: &Gray<u8>, feature: HaghighatFeature) -> f64 {
    same_size(a, f);
    same_size(b, f);
    let (w, h) = (f.width, f.height);
    if w < 3 || h < 3 {
        return f64::NAN;
    }
    let (fa, fb, ff) =
        (haghighat_feature(a, feature), haghighat_feature(b, feature), haghighat_feature(f, feature));
    let row_sum = |y: usize| {
        let mut total = 0.0;
        for x in 0..w - 2 {
            // The 3 × 3 window flattened column by column, as MATLAB's `aSub(:)`.
            let window = |m: &[f64]| -> [f64; 9] { std::array::from_fn(|k| m[(y + k % 3) * w + x + k / 3]) };
            let (wa, wb, wf) = (window(&fa), window(&fb), window(&ff));
            let fused = (wa != wf || wb != wf).then(|| Marginal::of(&wf));
            let nmi = |w: &[f64; 9]| match &fused {
                Some(m) if *w != wf => pair_nmi(&Marginal::of(w), m),
                _ => 1.0,
            };
            total += (nmi(&wa) + nmi(&wb)) / 2.0;
        }
        total
    };
    // Rows in parallel, summed in row order so the result does not depend on the thread count.
    let rows: Vec<f64> = (0..h - 2).into_par_iter().map(row_sum).collect();
    rows.iter().sum::<f64>() / ((w - 2) * (h - 2)) as f64
}

fn haghighat_feature(g: &Gray<u8>, feature: HaghighatFeature) -> Vec<f64> {
    let (w, h) = (g.width, g.height);
    let px = |x: usize, y: usize| f64::from(g.data[y * w + x]);
    match feature {
        HaghighatFeature::Pixels => g.data.iter().map(|&v| f64::from(v)).collect(),
        HaghighatFeature::Gradient => {
            let mut out = Vec::with_capacity(w * h);
            for y in 0..h {
                for x in 0..w {
                    out.push(if w == 1 {
                        0.0
                    } else if x == 0 {
                        px(1, y) - px(0, y)
                    } else if x + 1 == w {
                        px(x, y) - px(x - 1, y)
                    } else {
                        (px(x + 1, y) - px(x - 1, y)) / 2.0
                    });
                }
            }
            out
        }
    }
}

/// One window's marginal pdf as `fmi.m` forms it: min–max rescaled (a flat window becomes all
/// ones), divided by its sum (`sum(sum(·))`: the three column sums, then their sum).
fn haghighat_pdf(v: &[f64; 9]) -> [f64; 9] {
    let max = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
    let s = if max == min { [1.0; 9] } else { v.map(|x| (x - min) / (max - min)) };
    let sum = (s[0] + s[1] + s[2]) + (s[3] + s[4] + s[5]) + (s[6] + s[7] + s[8]);
    s.map(|x| x / sum)
}

/// One window's marginal as `fmi.m` uses it: pdf, CDF, log2 of the pdf (0 where it is 0), the
/// pdf vector's mean, the entropy (bits) and the population SD of the index distribution
/// (1-based indices). The fused window's marginal is shared by its two pairs.
struct Marginal {
    p: [f64; 9],
    cdf: [f64; 9],
    log_p: [f64; 9],
    mean: f64,
    entropy: f64,
    sd: f64,
}

impl Marginal {
    fn of(window: &[f64; 9]) -> Self {
        let p = haghighat_pdf(window);
        let mut acc = 0.0;
        let cdf = p.map(|v| {
            acc += v;
            acc
        });
        let log_p = p.map(|v| if v != 0.0 { v.log2() } else { 0.0 });
        let entropy = -p.iter().zip(&log_p).map(|(p, l)| p * l).sum::<f64>();
        let (mut e, mut e2) = (0.0, 0.0);
        for (i, &v) in p.iter().enumerate() {
            let i = (i + 1) as f64;
            e += i * v;
            e2 += i * i * v;
        }
        Self { p, cdf, log_p, mean: p.iter().sum::<f64>() / 9.0, entropy, sd: (e2 - e * e).sqrt() }
    }
}

/// The Pearson correlation `c` of two pdf vectors as `fmi.m` computes it (0 when the cross sum
/// is exactly 0).
fn pearson(a: &Marginal, f: &Marginal) -> f64 {
    let (mut sab, mut saa, mut sff) = (0.0, 0.0, 0.0);
    for (x, y) in a.p.iter().zip(&f.p) {
        sab += (x - a.mean) * (y - f.mean);
        saa += (x - a.mean) * (x - a.mean);
        sff += (y - f.mean) * (y - f.mean);
    }
    if sab == 0.0 { 0.0 } else { sab / (saa * sff).sqrt() }
}

/// `Σ_i Σ_j bound(F_i, A_j) − (Σ F)(Σ A)`, the covariance numerator of the Fréchet bound, in
/// O(n): both CDFs are non-decreasing, so the cells where `min(F_i, A_j) = A_j` (upper bound)
/// or where `F_i + A_j > 1` (lower bound) form a prefix or a suffix of `j` that moves
/// monotonically with `i`.
fn bound_covariance(f: &[f64; 9], a: &[f64; 9], upper: bool) -> f64 {
    let (sf, sa): (f64, f64) = (f.iter().sum(), a.iter().sum());
    let mut total = 0.0;
    if upper {
        // Σ_j min(F_i, A_j) = (Σ of A_j < F_i) + F_i·(count of A_j ≥ F_i).
        let (mut j, mut below) = (0, 0.0);
        for &fi in f {
            while j < 9 && a[j] < fi {
                below += a[j];
                j += 1;
            }
            total += below + fi * (9 - j) as f64;
        }
    } else {
        // Σ_j max(F_i + A_j − 1, 0) over the suffix of A_j > 1 − F_i.
        let mut suffix = [0f64; 10];
        for j in (0..9).rev() {
            suffix[j] = suffix[j + 1] + a[j];
        }
        let mut j = 9;
        for &fi in f {
            while j > 0 && fi + a[j - 1] - 1.0 > 0.0 {
                j -= 1;
            }
            total += suffix[j] + (9 - j) as f64 * (fi - 1.0);
        }
    }
    total - sf * sa
}

/// `fmi.m`'s normalised MI of one window pair (`a` a source window's marginal, `f` the fused
/// one's). The joint pdf is `φ·M + (1 − φ)·p_f ⊗ p_a` with `M` the cell masses of the Fréchet
/// upper bound `min(F_f, F_a)` (c ≥ 0) or lower bound `max(F_f + F_a − 1, 0)` (c < 0) and
/// `φ = c / corr(bound)`; a cell's entropy term is `real(−p·log2 p)`, i.e. `−p·log2|p|` (φ can
/// exceed 1 and make cells negative).
///
/// `M` is the overlap of the CDF steps (or, for the lower bound, of f's steps with a's mirrored
/// ones), non-zero on at most 17 of the 81 cells: the joint entropy is summed in closed form as
/// if `M` were 0 — `−k(log2|k| − H_a − H_f)`, `k = 1 − φ` — and corrected on those cells, found
/// by merging the two step sequences. The test module keeps the file's 81-cell loop and compares.
fn pair_nmi(a: &Marginal, f: &Marginal) -> f64 {
    let c = pearson(a, f);
    let upper = c >= 0.0;
    let phi = if (upper && c == 0.0) || a.sd == 0.0 || f.sd == 0.0 {
        0.0
    } else {
        c / (bound_covariance(&f.cdf, &a.cdf, upper) / (f.sd * a.sd))
    };
    let k = 1.0 - phi;
    let log_k = if k != 0.0 { k.abs().log2() } else { 0.0 };
    let mut joint = if k == 0.0 { 0.0 } else { -k * (log_k - f.entropy - a.entropy) };
    if phi != 0.0 {
        // a's steps in increasing order: [A_{j−1}, A_j] (upper) or [1 − A_j, 1 − A_{j−1}] (lower).
        let a_step = |n: usize| -> (usize, f64, f64) {
            let j = if upper { n } else { 8 - n };
            let (lo, hi) = (if j == 0 { 0.0 } else { a.cdf[j - 1] }, a.cdf[j]);
            if upper { (j, lo, hi) } else { (j, 1.0 - hi, 1.0 - lo) }
        };
        let (mut i, mut n) = (0, 0);
        while i < 9 && n < 9 {
            let (f0, f1) = (if i == 0 { 0.0 } else { f.cdf[i - 1] }, f.cdf[i]);
            let (j, a0, a1) = a_step(n);
            let m = f1.min(a1) - f0.max(a0);
            if m > 0.0 {
                let q = k * f.p[i] * a.p[j];
                let plogp_q = if q == 0.0 { 0.0 } else { -q * (log_k + f.log_p[i] + a.log_p[j]) };
                let p = phi * m + q;
                let plogp_p = if p == 0.0 { 0.0 } else { -p * p.abs().log2() };
                joint += plogp_p - plogp_q;
            }
            if f1 <= a1 {
                i += 1;
            }
            if a1 <= f1 {
                n += 1;
            }
        }
    }
    let mi = a.entropy + f.entropy - joint;
    if mi == 0.0 { 0.0 } else { 2.0 * mi / (a.entropy + f.entropy) }
}

/// [`pair_nmi`] of two raw windows (`fmi.m`'s branch for identical windows first).
#[cfg(test)]
fn haghighat_window(a: &[f64; 9], f: &[f64; 9]) -> f64 {
    if a == f { 1.0 } else { pair_nmi(&Marginal::of(a), &Marginal::of(f)) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::entropy;

    fn pattern(w: usize, h: usize, seed: u64) -> Gray<u8> {
        let mut s = seed;
        Gray {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    (s >> 56) as u8
                })
                .collect(),
        }
    }

    /// The Fast-FMI window MI by the direct n² sum over the joint pdf (the definition).
    fn window_nmi_direct(a: &[f64; 9], f: &[f64; 9]) -> f64 {
        let (pa, pf) = (window_pdf(a), window_pdf(f));
        let (ha, hf) = (entropy(&pa), entropy(&pf));
        let mean = 1.0 / 9.0;
        let (mut sab, mut saa, mut sff) = (0.0, 0.0, 0.0);
        for (x, y) in pa.iter().zip(&pf) {
            sab += (x - mean) * (y - mean);
            saa += (x - mean) * (x - mean);
            sff += (y - mean) * (y - mean);
        }
        let c = if saa == 0.0 || sff == 0.0 { 0.0 } else { sab / (saa * sff).sqrt() };
        let cdf = |p: &[f64; 9]| {
            let mut acc = 0.0;
            p.map(|v| {
                acc += v;
                acc
            })
        };
        let (fa, ff) = (cdf(&pa), cdf(&pf));
        let joint = |i: usize, j: usize| -> f64 {
            if i == 0 || j == 0 {
                return 0.0;
            }
            let (u, v) = (fa[i - 1], ff[j - 1]);
            if c >= 0.0 {
                c * u.min(v) + (1.0 - c) * u * v
            } else {
                -c * (u + v - 1.0).max(0.0) + (1.0 + c) * u * v
            }
        };
        let mut mi = 0.0;
        for (i, &pai) in pa.iter().enumerate() {
            for (j, &pfj) in pf.iter().enumerate() {
                let p = joint(i + 1, j + 1) - joint(i, j + 1) - joint(i + 1, j) + joint(i, j);
                let q = pai * pfj;
                if p > 1e-15 && q > 0.0 {
                    mi += p * (p / q).log2();
                }
            }
        }
        if ha + hf <= 0.0 { 1.0 } else { (2.0 * mi / (ha + hf)).clamp(0.0, 1.0) }
    }

    #[test]
    fn window_nmi_equals_the_direct_sum() {
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) % 50) as f64
        };
        for _ in 0..5000 {
            let a: [f64; 9] = std::array::from_fn(|_| next());
            let mut f: [f64; 9] = std::array::from_fn(|_| next());
            if next() < 10.0 {
                f = a.map(|v| 60.0 - v); // negatively correlated
            }
            if saa_is_flat(&a) && saa_is_flat(&f) {
                continue;
            }
            let (fast, direct) = (window_nmi(&a, &f), window_nmi_direct(&a, &f));
            assert!((fast - direct).abs() < 1e-9, "{a:?} {f:?}: {fast} vs {direct}");
        }
    }

    fn saa_is_flat(v: &[f64; 9]) -> bool {
        v.iter().all(|&x| x == v[0])
    }

    #[test]
    #[ignore = "prints FMI variants on a VIFB pair; run with --ignored --nocapture"]
    fn fmi_variants_on_vifb() {
        let d = fusion_io::testdata::vifb_dir();
        let load = |n: &str| fusion_io::load_gray_u8(&d.join(n), fusion_io::ColorPolicy::Refuse).unwrap();
        let (v, t, f) = (load("fight_VIS.png"), load("fight_IR.png"), load("fight_ADF_ref.png"));
        for feature in [FmiFeature::Gradient, FmiFeature::Pixels] {
            let x = (fmi_pair_with(&v, &f, feature) + fmi_pair_with(&t, &f, feature)) / 2.0;
            println!("{feature:?}: {x:.4}");
        }
    }

    #[test]
    fn fmi_properties() {
        let a = pattern(20, 16, 4);
        assert!((fmi_pair(&a, &a) - 1.0).abs() < 1e-12);
        let b = pattern(20, 16, 5);
        let v = fmi_pair(&a, &b);
        assert!((0.0..1.0).contains(&v), "{v}");
        // A fused image equal to one source scores higher against it than an unrelated one.
        assert!(fmi(&a, &b, &a) > fmi_pair(&b, &a));
        // Hand case: perfectly correlated non-identical windows (scaled copies) have c = 1, the
        // joint pdf is the diagonal of the common pdf, so the normalised MI is 1.
        let w1 = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
        let w2 = w1.map(|v| 2.0 * v);
        assert!((window_nmi(&w1, &w2) - 1.0).abs() < 1e-9);
        // A flat window against a structured one carries no information.
        assert!(window_nmi(&[3.0; 9], &w1).abs() < 1e-12);
    }

    struct DirectStats {
        c: f64,
        ca: [f64; 9],
        cf: [f64; 9],
        pa: [f64; 9],
        pf: [f64; 9],
        sd_a: f64,
        sd_f: f64,
        h_a: f64,
        h_f: f64,
    }

    /// `fmi.m`'s window loop as written: all 81 cells of the joint pdf from the four-term
    /// differences of the bound, `real(−p·log2 p)` on each non-zero cell.
    fn haghighat_window_direct(a: &[f64; 9], f: &[f64; 9]) -> f64 {
        if a == f {
            return 1.0;
        }
        let (ma, mf) = (Marginal::of(a), Marginal::of(f));
        let s = DirectStats {
            c: pearson(&ma, &mf),
            ca: ma.cdf,
            cf: mf.cdf,
            pa: ma.p,
            pf: mf.p,
            sd_a: ma.sd,
            sd_f: mf.sd,
            h_a: ma.entropy,
            h_f: mf.entropy,
        };
        let upper = s.c >= 0.0;
        let bound = |fi: f64, aj: f64| {
            if upper {
                0.5 * (fi + aj - (fi - aj).abs())
            } else {
                0.5 * (fi + aj - 1.0 + (fi + aj - 1.0).abs())
            }
        };
        let phi = if (upper && s.c == 0.0) || s.sd_a == 0.0 || s.sd_f == 0.0 {
            0.0
        } else {
            let mut cov = 0.0;
            for i in 0..9 {
                for j in 0..9 {
                    cov += bound(s.cf[i], s.ca[j]) - s.cf[i] * s.ca[j];
                }
            }
            s.c / (cov / (s.sd_f * s.sd_a))
        };
        let big = |i: usize, j: usize| if i == 0 || j == 0 { 0.0 } else { bound(s.cf[i - 1], s.ca[j - 1]) };
        let mut joint = 0.0;
        for i in 1..=9 {
            for j in 1..=9 {
                let m = big(i, j) - big(i - 1, j) - big(i, j - 1) + big(i - 1, j - 1);
                let p = phi * m + (1.0 - phi) * s.pf[i - 1] * s.pa[j - 1];
                if p != 0.0 {
                    joint += -p * p.abs().log2();
                }
            }
        }
        let mi = s.h_a + s.h_f - joint;
        if mi == 0.0 { 0.0 } else { 2.0 * mi / (s.h_a + s.h_f) }
    }

    #[test]
    fn haghighat_window_equals_the_files_81_cell_loop() {
        let mut state = 777u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) % 40) as f64
        };
        let mut negative = 0;
        for n in 0..20000 {
            let a: [f64; 9] = std::array::from_fn(|_| next());
            let mut f: [f64; 9] = std::array::from_fn(|_| next());
            match n % 4 {
                0 => f = a.map(|v| 50.0 - v),          // anti-correlated: the lower bound
                1 => f = a.map(|v| (v / 8.0).floor()), // ties and a flat-ish window
                _ => {}
            }
            if pearson(&Marginal::of(&a), &Marginal::of(&f)) < 0.0 {
                negative += 1;
            }
            let (fast, direct) = (haghighat_window(&a, &f), haghighat_window_direct(&a, &f));
            assert!(
                (fast - direct).abs() <= 1e-12 * direct.abs().max(1.0),
                "{a:?} {f:?}: {fast} vs {direct}"
            );
        }
        assert!(negative > 1000, "the lower-bound branch ran {negative} times");
    }

    #[test]
    fn haghighat_hand_cases() {
        // Identical windows score 1 by the file's first branch.
        let w1 = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
        assert_eq!(haghighat_window(&w1, &w1), 1.0);
        // A scaled copy has the same pdf: c = 1, and φ = 1/corr(upper bound of a distribution
        // with itself) = 1, so the joint pdf is the diagonal and the normalised MI is 1.
        let v = haghighat_window(&w1, &w1.map(|x| 3.0 * x + 7.0));
        assert!((v - 1.0).abs() < 1e-12, "{v}");
        // Whole images: FMI(X, X, X) = 1; against unrelated noise it is well below 1.
        let a = pattern(24, 18, 9);
        for feature in [HaghighatFeature::Pixels, HaghighatFeature::Gradient] {
            assert_eq!(fmi_haghighat(&a, &a, &a, feature), 1.0);
            let v = fmi_haghighat(&a, &pattern(24, 18, 10), &pattern(24, 18, 11), feature);
            assert!(v > 0.0 && v < 0.9, "{feature:?}: {v}");
        }
        // The gradient feature is MATLAB's x derivative: one-sided at the borders.
        let g = Gray { width: 4, height: 1, data: vec![0, 10, 30, 60] };
        assert_eq!(haghighat_feature(&g, HaghighatFeature::Gradient), vec![10.0, 15.0, 25.0, 30.0]);
    }
}
