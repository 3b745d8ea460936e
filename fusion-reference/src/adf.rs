//! ADF f64 reference, written from the spec (`docs/reference/fusion-algorithms.md`, ADF,
//! Part B) on images in 0..255 grey-level units. Independent of the core's integer code.
//!
//! * Diffusion: explicit 8-neighbour Perona–Malik, Jacobi, exponential conduction
//!   `exp(−(∇/κ)²)`, update `Δt·(Σ_axial c∇ + (1/dd²)·Σ_diag c∇)` with `dd = √2` as the
//!   published code writes it (`1/(√2)²` in floating point); the eight terms are summed in the
//!   published order (N, S, W, E, NE, SE, SW, NW). Classic: zero padding; flight: replicate.
//! * KL: sample covariance (N − 1) of `[D_IR(:), D_VIS(:)]`; the eigenvector of the larger
//!   eigenvalue as `(cos θ, sin θ)` with `θ = ½·atan2(2·c₁₂, c₁₁ − c₂₂)` (the 2×2 Jacobi
//!   rotation; an exact tie gives θ = 0, the first column, as MATLAB's `eig`).
//!   Classic: `p = v/(v₁+v₂)`, unguarded (near `v₁ + v₂ = 0` the result is huge or non-finite,
//!   as published). Flight: `p = |v|/(|v₁|+|v₂|)`, ½, ½ on a tie or zero covariance.
//! * `F = ½A_IR + ½A_VIS + p_IR·D_IR + p_VIS·D_VIS`, real-valued (not cast).

use fusion_io::Gray;
use fusion_nostd::Variant;
use fusion_nostd::methods::adf::AdfParams;

/// Perona–Malik diffusion of `img` (N = `params.iterations`, Δt, κ, border by variant).
pub fn diffuse(img: &Gray<f64>, params: &AdfParams) -> Gray<f64> {
    let (w, h) = (img.width as isize, img.height as isize);
    let kappa = f64::from(params.kappa);
    let dt = params.dt();
    let dd = 2f64.sqrt();
    let diag = 1.0 / (dd * dd);
    let replicate = params.variant == Variant::Flight;
    let mut cur = img.data.clone();
    let mut next = cur.clone();
    for _ in 0..params.iterations {
        let at = |data: &[f64], x: isize, y: isize| -> f64 {
            if replicate {
                data[(y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize]
            } else if x < 0 || y < 0 || x >= w || y >= h {
                0.0
            } else {
                data[(y * w + x) as usize]
            }
        };
        for y in 0..h {
            for x in 0..w {
                let c = at(&cur, x, y);
                let g = |dx: isize, dy: isize| {
                    let n = at(&cur, x + dx, y + dy) - c;
                    (-(n / kappa).powi(2)).exp() * n
                };
                // N, S, W, E, NE, SE, SW, NW.
                let sum = g(0, -1)
                    + g(0, 1)
                    + g(-1, 0)
                    + g(1, 0)
                    + diag * g(1, -1)
                    + diag * g(1, 1)
                    + diag * g(-1, 1)
                    + diag * g(-1, -1);
                next[(y * w + x) as usize] = c + dt * sum;
            }
        }
        std::mem::swap(&mut cur, &mut next);
    }
    Gray { width: img.width, height: img.height, data: cur }
}

/// The KL weights `(p_IR, p_VIS)` of two detail layers.
pub fn kl_weights(d_ir: &[f64], d_vis: &[f64], variant: Variant) -> (f64, f64) {
    let n = d_ir.len() as f64;
    let m1 = d_ir.iter().sum::<f64>() / n;
    let m2 = d_vis.iter().sum::<f64>() / n;
    let norm = (n - 1.0).max(1.0);
    let c11 = d_ir.iter().map(|v| (v - m1) * (v - m1)).sum::<f64>() / norm;
    let c22 = d_vis.iter().map(|v| (v - m2) * (v - m2)).sum::<f64>() / norm;
    let c12 = d_ir.iter().zip(d_vis).map(|(a, b)| (a - m1) * (b - m2)).sum::<f64>() / norm;
    let theta = 0.5 * (2.0 * c12).atan2(c11 - c22);
    let (v1, v2) = (theta.cos(), theta.sin());
    match variant {
        Variant::Classic => (v1 / (v1 + v2), v2 / (v1 + v2)),
        Variant::Flight => {
            if c12 == 0.0 && c11 == c22 {
                (0.5, 0.5)
            } else {
                (v1.abs() / (v1.abs() + v2.abs()), v2.abs() / (v1.abs() + v2.abs()))
            }
        }
    }
}

/// ADF fusion of a VIS/TIR pair (same size), real-valued result in 0..255 units before the
/// 8-bit cast. Panics on a size mismatch (host reference).
pub fn fuse_adf(vis: &Gray<f64>, tir: &Gray<f64>, params: &AdfParams) -> Gray<f64> {
    assert_eq!((vis.width, vis.height), (tir.width, tir.height), "ADF reference: sizes differ");
    let a_ir = diffuse(tir, params);
    let a_vis = diffuse(vis, params);
    let d_ir: Vec<f64> = tir.data.iter().zip(&a_ir.data).map(|(i, a)| i - a).collect();
    let d_vis: Vec<f64> = vis.data.iter().zip(&a_vis.data).map(|(i, a)| i - a).collect();
    let (p_ir, p_vis) = kl_weights(&d_ir, &d_vis, params.variant);
    let data = (0..d_ir.len())
        .map(|i| (0.5 * a_ir.data[i] + 0.5 * a_vis.data[i]) + (p_ir * d_ir[i] + p_vis * d_vis[i]))
        .collect();
    Gray { width: vis.width, height: vis.height, data }
}
