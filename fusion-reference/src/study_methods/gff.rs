//! GFF — image fusion with guided filtering (S. Li, X. Kang, J. Hu, "Image fusion with guided
//! filtering", IEEE Trans. Image Processing 22(7), 2864–2875, 2013), f64, written from the paper.
//!
//! For the sources `I_n` (n = VIS, TIR; images in 0..255 units, same size):
//! 1. **Two-scale decomposition**: base `B_n = I_n ∗ Z` with `Z` the 31×31 average filter,
//!    detail `D_n = I_n − B_n`.
//! 2. **Saliency**: `H_n = |I_n ∗ L|` with the 3×3 Laplacian `[0 1 0; 1 −4 1; 0 1 0]`, then
//!    `S_n = H_n ∗ g` with the 11×11 Gaussian of σ = 5 (`r_g = 5`, `σ_g = 5`).
//! 3. **Initial weights**: `P_n = 1` where `S_n` is the largest of the saliencies, else 0.
//! 4. **Refined weights** with the guided filter, each source its own guidance:
//!    `W_n^B = G_{r1,ε1}(P_n, I_n)`, `W_n^D = G_{r2,ε2}(P_n, I_n)`, then normalised to sum 1
//!    per pixel.
//! 5. **Fusion**: `F = Σ_n W_n^B B_n + Σ_n W_n^D D_n`.
//!
//! Parameters (the paper's defaults, also those of the authors' public `GFF.m`):
//! average filter 31×31, Gaussian 11×11 σ = 5, `r1 = 45`, `ε1 = 0.3`, `r2 = 7`, `ε2 = 10⁻⁶`.
//! The ε values refer to images on [0, 1], so the guidance and the Laplacian use `I / 255`.
//!
//! Details that follow the authors' code where the paper is silent: every filter uses the
//! replicate border (`imfilter(…, 'replicate')`); the guided filter's windows are clipped at
//! the border (`boxfilter ./ N`); on a saliency tie the first source wins (MATLAB `max`), and
//! the first source is VIS (the order of the VIFB wrapper); each refined weight is cast to
//! 8 bits (`uint8(W·255)/255`: clipped to [0, 1] and rounded to steps of 1/255, "to remove
//! values which are not in the [0, 1] range") and the weights are normalised as
//! `(W_n + 10⁻¹²) / Σ(W + 10⁻¹²)`, so they always sum to 1 and a pixel where both are 0 gets ½, ½.
//! The result is real-valued (the CLI casts it to 8 bits as MATLAB's `uint8`).

use super::guided_filter::guided_filter;
use super::kernels::{box_mean_replicate, correlate3_replicate, gaussian_taps, separable_replicate};
use super::same_size;
use anyhow::Result;
use fusion_io::Gray;

/// GFF's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GffParams {
    /// Side of the average filter of the two-scale decomposition.
    pub average_size: usize,
    /// Side of the Gaussian that smooths the Laplacian saliency (`2 r_g + 1`).
    pub gauss_size: usize,
    /// σ of that Gaussian (`σ_g`).
    pub gauss_sigma: f64,
    /// Guided-filter radius for the base-layer weights.
    pub r1: usize,
    /// Guided-filter ε for the base-layer weights (images on [0, 1]).
    pub eps1: f64,
    /// Guided-filter radius for the detail-layer weights.
    pub r2: usize,
    /// Guided-filter ε for the detail-layer weights (images on [0, 1]).
    pub eps2: f64,
    /// Cast the refined weights to 8 bits before normalising, as the authors' code does.
    pub quantise_weights: bool,
}

impl Default for GffParams {
    fn default() -> Self {
        Self {
            average_size: 31,
            gauss_size: 11,
            gauss_sigma: 5.0,
            r1: 45,
            eps1: 0.3,
            r2: 7,
            eps2: 1e-6,
            quantise_weights: true,
        }
    }
}

/// GFF's refined weights, normalised: `[VIS, TIR]` for the base and the detail layers.
#[derive(Debug, Clone, PartialEq)]
pub struct GffWeights {
    /// `W^B_VIS`, `W^B_TIR`.
    pub base: [Gray<f64>; 2],
    /// `W^D_VIS`, `W^D_TIR`.
    pub detail: [Gray<f64>; 2],
}

const LAPLACIAN: [[f64; 3]; 3] = [[0.0, 1.0, 0.0], [1.0, -4.0, 1.0], [0.0, 1.0, 0.0]];

fn scaled(img: &Gray<f64>, k: f64) -> Gray<f64> {
    Gray { width: img.width, height: img.height, data: img.data.iter().map(|v| v * k).collect() }
}

/// Steps 2–4: the normalised base and detail weights of a VIS/TIR pair.
pub fn gff_weights(vis: &Gray<f64>, tir: &Gray<f64>, p: &GffParams) -> Result<GffWeights> {
    same_size("GFF", vis, tir)?;
    let unit = [scaled(vis, 1.0 / 255.0), scaled(tir, 1.0 / 255.0)];
    let taps = gaussian_taps(p.gauss_size, p.gauss_sigma);
    let sal: Vec<Gray<f64>> = unit
        .iter()
        .map(|g| {
            let mut h = correlate3_replicate(g, &LAPLACIAN);
            h.data.iter_mut().for_each(|v| *v = v.abs());
            separable_replicate(&h, &taps)
        })
        .collect();
    let p_vis = Gray {
        width: vis.width,
        height: vis.height,
        data: sal[0].data.iter().zip(&sal[1].data).map(|(&a, &b)| if a >= b { 1.0 } else { 0.0 }).collect(),
    };
    let p_tir = Gray { data: p_vis.data.iter().map(|v| 1.0 - v).collect(), ..p_vis.clone() };
    let refine = |r: usize, eps: f64| -> [Gray<f64>; 2] {
        let mut w = [guided_filter(&unit[0], &p_vis, r, eps), guided_filter(&unit[1], &p_tir, r, eps)];
        if p.quantise_weights {
            for g in &mut w {
                g.data.iter_mut().for_each(|v| *v = (*v * 255.0).clamp(0.0, 255.0).round() / 255.0);
            }
        }
        let [a, b] = &mut w;
        for (x, y) in a.data.iter_mut().zip(b.data.iter_mut()) {
            let (xa, yb) = (*x + 1e-12, *y + 1e-12);
            let sum = xa + yb;
            (*x, *y) = (xa / sum, yb / sum);
        }
        w
    };
    Ok(GffWeights { base: refine(p.r1, p.eps1), detail: refine(p.r2, p.eps2) })
}

/// GFF fusion of a VIS/TIR pair of the same size, real-valued, 0..255 units.
pub fn fuse_gff(vis: &Gray<f64>, tir: &Gray<f64>, p: &GffParams) -> Result<Gray<f64>> {
    let w = gff_weights(vis, tir, p)?;
    let (b_v, b_t) = (box_mean_replicate(vis, p.average_size), box_mean_replicate(tir, p.average_size));
    let data = (0..vis.data.len())
        .map(|k| {
            let (d_v, d_t) = (vis.data[k] - b_v.data[k], tir.data[k] - b_t.data[k]);
            w.base[0].data[k] * b_v.data[k]
                + w.base[1].data[k] * b_t.data[k]
                + w.detail[0].data[k] * d_v
                + w.detail[1].data[k] * d_t
        })
        .collect();
    Ok(Gray { width: vis.width, height: vis.height, data })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study_methods::test_images::{constant, textured};

    #[test]
    fn identical_inputs_fuse_to_themselves() {
        let a = textured(40, 33, 3);
        let f = fuse_gff(&a, &a, &GffParams::default()).unwrap();
        for (x, y) in f.data.iter().zip(&a.data) {
            assert!((x - y).abs() < 1e-9, "{x} vs {y}");
        }
    }

    #[test]
    fn weights_sum_to_one_and_stay_in_range() {
        let (v, t) = (textured(37, 29, 1), textured(37, 29, 8));
        for quantise in [true, false] {
            let w = gff_weights(&v, &t, &GffParams { quantise_weights: quantise, ..GffParams::default() })
                .unwrap();
            for pair in [&w.base, &w.detail] {
                for k in 0..v.data.len() {
                    assert!((pair[0].data[k] + pair[1].data[k] - 1.0).abs() < 1e-12);
                    if quantise {
                        assert!((0.0..=1.0).contains(&pair[0].data[k]));
                    }
                }
            }
        }
    }

    #[test]
    fn two_constants_give_the_first_source_on_a_saliency_tie() {
        // Both saliencies are 0: VIS wins every pixel (MATLAB max), W_VIS = 1 after the
        // guided filter of a constant map, so F = VIS exactly (up to the 1e-12 normalisation).
        let f = fuse_gff(&constant(9, 7, 40.0), &constant(9, 7, 200.0), &GffParams::default()).unwrap();
        assert!(f.data.iter().all(|v| (v - 40.0).abs() < 1e-6), "{:?}", &f.data[..3]);
    }

    #[test]
    fn the_salient_source_dominates_the_detail() {
        // VIS flat at 50, TIR with a checkerboard: TIR is the salient one everywhere, so the
        // fused detail is TIR's and the base is mostly TIR's.
        let v = constant(32, 32, 50.0);
        let t = Gray {
            width: 32,
            height: 32,
            data: (0..1024).map(|i| if (i % 32 + i / 32) % 2 == 0 { 100.0 } else { 140.0 }).collect(),
        };
        let f = fuse_gff(&v, &t, &GffParams::default()).unwrap();
        let err = f.data.iter().zip(&t.data).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < 1.0, "max |F − TIR| = {err}");
    }

    #[test]
    fn size_mismatch_is_an_error() {
        assert!(fuse_gff(&constant(4, 4, 0.0), &constant(4, 5, 0.0), &GffParams::default()).is_err());
    }
}
