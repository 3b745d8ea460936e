//! Adaptive-fusion f64 reference, written from the rule in `fusion_nostd::methods::adaptive`'s
//! docs on images in 0..255 grey-level units, independent of the core's integer code:
//!
//! * `B_k`: the `n × n` mean, replicate border ([`super::tsifsd::box_mean`]).
//! * `G_VIS`: the 3×3 binomial `[1 2 1]ᵀ[1 2 1]/16`, replicate border.
//! * The per-frame decision is given (the scene analysis's integer counts, shared with the
//!   core): `TirOnly` gives `I_TIR`; `Adf` is the ADF reference ([`crate::adf::fuse_adf`]
//!   with the parameters' `adf`).
//! * Lit share `a = clamp((B_VIS − level − offset) / span, 0, 1)`, quantised as the core does
//!   (`⌊256·a⌋ / 256`: a stated step of the method, not an implementation error).
//! * `F = max(B_VIS, B_TIR) + (G_VIS − B_VIS) + (1 − a)(I_TIR − B_TIR)`.
//! * `g = clamp((16·G_VIS − 16·glare)/256, 0, 1)`, `out = (1 − g)·F + g·I_TIR`, not cast.

use super::tsifsd::box_mean;
use fusion_io::Gray;
use fusion_nostd::methods::adaptive::{AdaptiveParams, Decision};

/// The 3×3 binomial smoothing with replicate border.
pub fn binomial3(img: &Gray<f64>) -> Gray<f64> {
    let (w, h) = (img.width as isize, img.height as isize);
    let at = |x: isize, y: isize| img.at(x.clamp(0, w - 1) as usize, y.clamp(0, h - 1) as usize);
    let mut out = Gray::new(img.width, img.height);
    for y in 0..h {
        for x in 0..w {
            let row = |yy: isize| at(x - 1, yy) + 2.0 * at(x, yy) + at(x + 1, yy);
            out.data[(y * w + x) as usize] = (row(y - 1) + 2.0 * row(y) + row(y + 1)) / 16.0;
        }
    }
    out
}

/// The adaptive fusion of two same-size images with the frame's decision (not cast).
pub fn fuse_adaptive(
    vis: &Gray<f64>,
    tir: &Gray<f64>,
    p: &AdaptiveParams,
    decision: Option<Decision>,
) -> Gray<f64> {
    let vis_level = match decision {
        Some(Decision::Blend { vis_level }) => vis_level,
        Some(Decision::Adf) => return crate::adf::fuse_adf(vis, tir, &p.adf),
        Some(Decision::TirOnly) | None => return tir.clone(),
    };
    let (lit0, span) = (f64::from(vis_level) + f64::from(p.lit_offset), f64::from(p.lit_span));
    let n = usize::from(p.base_size);
    let (bv, bt, gv) = (box_mean(vis, n, false), box_mean(tir, n, false), binomial3(vis));
    let glare = f64::from(p.glare_level);
    let mut out = Gray::new(vis.width, vis.height);
    for i in 0..out.data.len() {
        let a = (256.0 * ((bv.data[i] - lit0) / span).clamp(0.0, 1.0) + 1e-9).floor() / 256.0;
        let f =
            bv.data[i].max(bt.data[i]) + (gv.data[i] - bv.data[i]) + (1.0 - a) * (tir.data[i] - bt.data[i]);
        let g = ((gv.data[i] - glare) / 16.0).clamp(0.0, 1.0);
        out.data[i] = (1.0 - g) * f + g * tir.data[i];
    }
    out
}
