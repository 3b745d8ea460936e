//! The fast global smoother (D. Min, S. Choi, J. Lu, B. Ham, K. Sohn, M. N. Do, "Fast global
//! image smoothing based on weighted least squares", IEEE Trans. Image Processing 23(12),
//! 5638–5653, 2014), f64, written from the paper.
//!
//! The weighted-least-squares smoother minimises, for an input `f` and a guide `g`,
//! `Σ_p (u_p − f_p)² + λ Σ_p Σ_{q ∈ N(p)} w_{p,q}(g) (u_p − u_q)²` with
//! `w_{p,q} = exp(−|g_p − g_q| / σ_c)`. FGS replaces the 2-D system by 1-D ones: along each
//! row, then along each column, it solves `(I + λ_t A_g) u = f` where `A_g` is the weighted
//! 1-D Laplacian of the line (a tridiagonal system, solved exactly by the Thomas algorithm,
//! O(n)). The pair of passes is repeated `T` times with
//! `λ_t = (3/2) · 4^{T−t} / (4^T − 1) · λ`, t = 1 … T, which removes the streaks a single
//! separable pass leaves. When the input is its own guide, the guide is replaced by the
//! current estimate after each iteration, as the paper proposes.
//!
//! `σ_c` is given in the units of the image (grey levels here); the paper's values are on
//! [0, 1] images (multiply by 255). `T = 3` as in the paper.

use fusion_io::Gray;

/// Fast-global-smoother parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FgsParams {
    /// Regularisation weight `λ` (dimensionless; the smoothing scale grows like `√λ` pixels).
    pub lambda: f64,
    /// Range scale `σ_c` of the edge weights, in the image's units.
    pub sigma_c: f64,
    /// Iterations `T` (each one a row pass and a column pass).
    pub iterations: usize,
}

/// Solves the 1-D system `(1 + λ(w_{i−1} + w_i)) u_i − λ w_{i−1} u_{i−1} − λ w_i u_{i+1} = f_i`
/// in place (`line` holds `f` on entry and `u` on return); `weights[i]` links samples `i` and
/// `i + 1` (length `n − 1`). `scratch` needs `n` samples.
pub fn solve_line(line: &mut [f64], weights: &[f64], lambda: f64, scratch: &mut [f64]) {
    let n = line.len();
    if n < 2 {
        return;
    }
    // Forward sweep: scratch holds c'_i, line holds d'_i.
    let mut prev_c = 0.0;
    for i in 0..n {
        let wl = if i > 0 { weights[i - 1] } else { 0.0 };
        let wr = if i + 1 < n { weights[i] } else { 0.0 };
        let (a, c) = (-lambda * wl, -lambda * wr);
        let b = 1.0 + lambda * (wl + wr);
        let m = b - a * prev_c;
        let d_prev = if i > 0 { line[i - 1] } else { 0.0 };
        line[i] = (line[i] - a * d_prev) / m;
        prev_c = c / m;
        scratch[i] = prev_c;
    }
    for i in (0..n - 1).rev() {
        line[i] -= scratch[i] * line[i + 1];
    }
}

fn edge_weight(a: f64, b: f64, sigma_c: f64) -> f64 {
    if sigma_c > 0.0 { (-(a - b).abs() / sigma_c).exp() } else { f64::from(u8::from(a == b)) }
}

/// One row pass: every row solved with weights from the same row of `guide`.
fn rows(u: &mut Gray<f64>, guide: &Gray<f64>, lambda: f64, sigma_c: f64) {
    let w = u.width;
    let (mut weights, mut scratch) = (vec![0.0; w.saturating_sub(1)], vec![0.0; w]);
    for (line, g) in u.data.chunks_exact_mut(w).zip(guide.data.chunks_exact(w)) {
        for (k, wt) in weights.iter_mut().enumerate() {
            *wt = edge_weight(g[k], g[k + 1], sigma_c);
        }
        solve_line(line, &weights, lambda, &mut scratch);
    }
}

/// One column pass, all columns at once (row-major sweeps, the same arithmetic as
/// [`solve_line`] per column).
fn columns(u: &mut Gray<f64>, guide: &Gray<f64>, lambda: f64, sigma_c: f64) {
    let (w, h) = (u.width, u.height);
    if h < 2 {
        return;
    }
    let mut cprime = vec![0.0; w * h];
    // weights between row y − 1 and row y (0 above the first row), then between y and y + 1
    let (mut w_up, mut w_down) = (vec![0.0; w], vec![0.0; w]);
    for y in 0..h {
        if y + 1 < h {
            let (g0, g1) = (&guide.data[y * w..(y + 1) * w], &guide.data[(y + 1) * w..(y + 2) * w]);
            for x in 0..w {
                w_down[x] = edge_weight(g0[x], g1[x], sigma_c);
            }
        } else {
            w_down.iter_mut().for_each(|v| *v = 0.0);
        }
        for x in 0..w {
            let (wl, wr) = (w_up[x], w_down[x]);
            let (a, c) = (-lambda * wl, -lambda * wr);
            let b = 1.0 + lambda * (wl + wr);
            let (prev_c, d_prev) =
                if y > 0 { (cprime[(y - 1) * w + x], u.data[(y - 1) * w + x]) } else { (0.0, 0.0) };
            let m = b - a * prev_c;
            u.data[y * w + x] = (u.data[y * w + x] - a * d_prev) / m;
            cprime[y * w + x] = c / m;
        }
        std::mem::swap(&mut w_up, &mut w_down);
    }
    for y in (0..h - 1).rev() {
        for x in 0..w {
            let next = u.data[(y + 1) * w + x];
            u.data[y * w + x] -= cprime[y * w + x] * next;
        }
    }
}

/// The fast global smoother of `img`, guided by `guide` or, with `None`, by itself (the guide
/// then follows the estimate after every iteration).
pub fn fgs(img: &Gray<f64>, guide: Option<&Gray<f64>>, p: &FgsParams) -> Gray<f64> {
    let mut u = img.clone();
    let t_max = p.iterations as i32;
    let denom = 4f64.powi(t_max) - 1.0;
    let mut own_guide = img.clone();
    for t in 1..=t_max {
        let lambda_t = 1.5 * 4f64.powi(t_max - t) / denom * p.lambda;
        let g = guide.unwrap_or(&own_guide);
        rows(&mut u, g, lambda_t, p.sigma_c);
        columns(&mut u, g, lambda_t, p.sigma_c);
        if guide.is_none() {
            own_guide.data.copy_from_slice(&u.data);
        }
    }
    u
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study_methods::test_images::{constant, textured};

    #[test]
    fn solve_line_hand_case() {
        // n = 3, unit weights, λ = 1: [[2,-1,0],[-1,3,-1],[0,-1,2]] u = f.
        // f = (1, 0, 1) → u = (3/4, 1/2, 3/4): check 2·3/4 − 1/2 = 1, −3/4 + 3/2 − 3/4 = 0.
        let mut line = [1.0, 0.0, 1.0];
        solve_line(&mut line, &[1.0, 1.0], 1.0, &mut [0.0; 3]);
        for (u, e) in line.iter().zip([0.75, 0.5, 0.75]) {
            assert!((u - e).abs() < 1e-15, "{line:?}");
        }
        // a zero weight splits the line into independent parts: the identity here
        let mut line = [5.0, 9.0];
        solve_line(&mut line, &[0.0], 100.0, &mut [0.0; 2]);
        assert_eq!(line, [5.0, 9.0]);
    }

    #[test]
    fn column_pass_equals_solve_line_per_column() {
        let (img, guide) = (textured(5, 9, 1), textured(5, 9, 2));
        let mut fast = img.clone();
        columns(&mut fast, &guide, 7.0, 20.0);
        for x in 0..5 {
            let mut line: Vec<f64> = (0..9).map(|y| img.at(x, y)).collect();
            let weights: Vec<f64> =
                (0..8).map(|y| edge_weight(guide.at(x, y), guide.at(x, y + 1), 20.0)).collect();
            solve_line(&mut line, &weights, 7.0, &mut [0.0; 9]);
            for (y, v) in line.iter().enumerate() {
                assert!((fast.at(x, y) - v).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn smoother_of_a_constant_is_the_constant_and_lambda_zero_is_the_identity() {
        let p = FgsParams { lambda: 400.0, sigma_c: 12.0, iterations: 3 };
        let c = fgs(&constant(13, 8, 71.0), None, &p);
        assert!(c.data.iter().all(|v| (v - 71.0).abs() < 1e-9));
        let t = textured(13, 8, 3);
        let same = fgs(&t, None, &FgsParams { lambda: 0.0, ..p });
        assert_eq!(same, t);
    }

    #[test]
    fn smooths_flat_noise_but_keeps_a_strong_edge() {
        // Left half ≈ 20, right half ≈ 220, ±3 ripple: σ_c = 10 keeps the 200-level edge.
        let (w, h) = (40, 10);
        let img = Gray {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|i| if i % w < w / 2 { 20.0 } else { 220.0 } + if (i % w + i / w) % 2 == 0 { 3.0 } else { -3.0 })
                .collect(),
        };
        let u = fgs(&img, None, &FgsParams { lambda: 100.0, sigma_c: 10.0, iterations: 3 });
        for y in 0..h {
            assert!((u.at(w / 2 - 1, y) - 20.0).abs() < 5.0 && (u.at(w / 2, y) - 220.0).abs() < 5.0);
            assert!((u.at(5, y) - 20.0).abs() < 1.0, "ripple smoothed: {}", u.at(5, y));
        }
    }
}
