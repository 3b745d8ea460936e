//! MGFF — multi-scale guided image fusion (D. P. Bavirisetti, G. Xiao, J. Zhao, R. Dhuli,
//! G. Liu, "Multi-scale guided image and video fusion: a fast and efficient approach",
//! Circuits, Systems, and Signal Processing 38, 5576–5605, 2019), f64, written from the paper.
//!
//! For two sources `I_1, I_2` (0..255 units, same size), with `A_n^0 = I_n`:
//! 1. **Multi-scale guided decomposition**, levels `k = 1 … K`: each source's base at level
//!    `k` is the guided filter of the *other* source's previous base, guided by its own previous
//!    base (the "structure-transferring" cross guidance):
//!    `A_1^k = G_{r,ε}(guide A_1^{k−1}, input A_2^{k−1})`,
//!    `A_2^k = G_{r,ε}(guide A_2^{k−1}, input A_1^{k−1})`; details `D_n^k = A_n^{k−1} − A_n^k`.
//! 2. **Saliency** of a detail layer: its magnitude, `S_n^k = |D_n^k|`.
//! 3. **Weights**: `w_n^k = S_n^k / (S_1^k + S_2^k)` per pixel and level (they sum to 1).
//! 4. **Fusion**: base `B = ½ (A_1^K + A_2^K)`, detail `D = Σ_k Σ_n w_n^k D_n^k`, `F = B + D`.
//!
//! Parameters (those of the authors' public code, `run_MGFF.m`/`fuse_MGF.m`): `K = 4` levels,
//! the same guided filter at every level, radius `r = 9`, `ε = 10³` in 0..255 units
//! (≈ 0.0154 on [0, 1]). Source order: `I_1` = TIR, `I_2` = VIS (the VIFB wrapper's order;
//! the method is symmetric except for the guard below).
//!
//! Guard (ours): where both saliencies of a level are 0 the published weights are 0/0 = NaN;
//! we use ½, ½ there (the fused detail is then the mean of two zero details, i.e. 0).
//! Guided-filter windows are clipped at the border, as the authors' `boxfilter ./ N`.
//! With identical inputs every level's weights are ½ and the details telescope, so `F = I`.

use super::guided_filter::guided_filter;
use super::same_size;
use anyhow::Result;
use fusion_io::Gray;

/// MGFF's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MgffParams {
    /// Decomposition levels `K`.
    pub levels: usize,
    /// Guided-filter window radius.
    pub radius: usize,
    /// Guided-filter regulariser, 0..255 units squared.
    pub eps: f64,
}

impl Default for MgffParams {
    fn default() -> Self {
        Self { levels: 4, radius: 9, eps: 1e3 }
    }
}

/// The detail weights of one level: `w_1 = S_1 / (S_1 + S_2)`, ½ where both are 0.
pub fn level_weights(d1: &Gray<f64>, d2: &Gray<f64>) -> Vec<f64> {
    d1.data
        .iter()
        .zip(&d2.data)
        .map(|(a, b)| {
            let (s1, s2) = (a.abs(), b.abs());
            if s1 + s2 > 0.0 { s1 / (s1 + s2) } else { 0.5 }
        })
        .collect()
}

fn sub(a: &Gray<f64>, b: &Gray<f64>) -> Gray<f64> {
    Gray { width: a.width, height: a.height, data: a.data.iter().zip(&b.data).map(|(x, y)| x - y).collect() }
}

/// MGFF fusion of a VIS/TIR pair of the same size, real-valued, 0..255 units.
pub fn fuse_mgff(vis: &Gray<f64>, tir: &Gray<f64>, p: &MgffParams) -> Result<Gray<f64>> {
    same_size("MGFF", vis, tir)?;
    let (mut a1, mut a2) = (tir.clone(), vis.clone());
    let mut detail = vec![0.0; vis.data.len()];
    for _ in 0..p.levels {
        let n1 = guided_filter(&a1, &a2, p.radius, p.eps);
        let n2 = guided_filter(&a2, &a1, p.radius, p.eps);
        let (d1, d2) = (sub(&a1, &n1), sub(&a2, &n2));
        let w1 = level_weights(&d1, &d2);
        for (k, d) in detail.iter_mut().enumerate() {
            *d += w1[k] * d1.data[k] + (1.0 - w1[k]) * d2.data[k];
        }
        (a1, a2) = (n1, n2);
    }
    let data = (0..detail.len()).map(|k| 0.5 * (a1.data[k] + a2.data[k]) + detail[k]).collect();
    Ok(Gray { width: vis.width, height: vis.height, data })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study_methods::test_images::{constant, textured};

    #[test]
    fn identical_inputs_fuse_to_themselves() {
        let a = textured(45, 31, 2);
        let f = fuse_mgff(&a, &a, &MgffParams::default()).unwrap();
        for (x, y) in f.data.iter().zip(&a.data) {
            assert!((x - y).abs() < 1e-9, "{x} vs {y}");
        }
    }

    #[test]
    fn weights_sum_to_one_with_the_zero_guard() {
        let d1 = Gray { width: 4, height: 1, data: vec![0.0, 3.0, -1.0, 0.0] };
        let d2 = Gray { width: 4, height: 1, data: vec![0.0, 1.0, 3.0, -2.0] };
        assert_eq!(level_weights(&d1, &d2), vec![0.5, 0.75, 0.25, 0.0]);
        let w2 = level_weights(&d2, &d1);
        for (a, b) in level_weights(&d1, &d2).iter().zip(&w2) {
            assert_eq!(a + b, 1.0);
        }
    }

    #[test]
    fn two_constants_average() {
        // Every guided filter of a constant is that constant, so the first level already swaps
        // them: A_1 = c_2, A_2 = c_1, D_1 = c_1 − c_2 = −D_2 with equal saliency (w = ½): the
        // details cancel and F = ½(c_1 + c_2).
        let f = fuse_mgff(&constant(8, 6, 30.0), &constant(8, 6, 130.0), &MgffParams::default()).unwrap();
        assert!(f.data.iter().all(|v| (v - 80.0).abs() < 1e-9), "{:?}", &f.data[..2]);
    }

    #[test]
    fn output_size_and_mismatch() {
        let f = fuse_mgff(&textured(20, 11, 1), &textured(20, 11, 4), &MgffParams::default()).unwrap();
        assert_eq!((f.width, f.height), (20, 11));
        assert!(f.data.iter().all(|v| v.is_finite()));
        assert!(fuse_mgff(&textured(20, 11, 1), &textured(11, 20, 1), &MgffParams::default()).is_err());
    }
}
