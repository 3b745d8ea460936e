//! # fusion-reference
//!
//! The `f64` side of the VIS/TIR fusion project: reference implementations written straight
//! from the specifications (`docs/reference/`), independent of the `no_std` core's integer
//! code, on images in 0..255 grey-level units — the oracle every core kernel is tested
//! against — and the study's four host-only methods (GFF, MGFF, TEPGFL, DRIF).
//!
//! * [`adf`], [`tsifsd`], [`ifevip`], [`adaptive`]: the core's methods, classic and flight
//!   variants; [`rescale`]: OpenCV's bicubic and area resize; [`agc`]: the thermal gain control;
//!   [`thermal`]: the thermal front end (two-point correction, shutter, bad pixels, column filter).
//! * [`study_methods`]: the study's other methods, host only.
//! * [`fuse`]: a whole pipeline (rescale onto the fusion grid, then the method), as the core's
//!   `pipeline::fuse` runs it.
//!
//! ```
//! use fusion_io::Gray;
//! use fusion_nostd::pipeline::{FuseConfig, Method};
//! use fusion_nostd::TsifsdParams;
//!
//! let vis = Gray { width: 8, height: 8, data: (0..64).map(|i| (i * 4) as u8).collect() };
//! let tir = Gray { width: 8, height: 8, data: vec![200u8; 64] };
//! let config = FuseConfig { method: Method::Tsifsd(TsifsdParams::default()), ..FuseConfig::default() };
//! let (fused, raw) = fusion_reference::fuse(&vis, &tir, &config)?;
//! assert_eq!((fused.width, fused.height), (8, 8));
//! assert!(raw.data.iter().all(|v| v.is_finite()));
//! # Ok::<(), anyhow::Error>(())
//! ```

use anyhow::Result;
use fusion_io::Gray;
use fusion_nostd::pipeline::{FuseConfig, Method, fusion_grid};

pub mod adaptive;
pub mod adf;
pub mod agc;
pub mod ifevip;
pub mod rescale;
pub mod study_methods;
pub mod thermal;
pub mod tsifsd;

/// Fuses `vis` and `tir` with the f64 references: both brought onto the fusion grid by the
/// reference rescalers (VIS area, TIR bicubic), then the method; the 8-bit image (MATLAB's
/// `uint8` cast) and the real-valued result before the cast, in 0..255 units.
pub fn fuse(vis: &Gray<u8>, tir: &Gray<u8>, pipeline: &FuseConfig) -> Result<(Gray<u8>, Gray<f64>)> {
    // The adaptive method decides on the input frames, before the rescale (as the core: the
    // scene analysis's integer counts, shared).
    let decision = fusion_nostd::pipeline::adaptive_decision(vis.view()?, tir.view()?, pipeline)?;
    let (w, h) = fusion_grid((vis.width, vis.height), (tir.width, tir.height), pipeline.rescale)?;
    let to_grid = |img: &Gray<u8>, filter| {
        if (img.width, img.height) == (w, h) {
            img.clone()
        } else {
            crate::rescale::rescale_u8(img, w, h, filter)
        }
    };
    let vis = to_f64(&to_grid(vis, fusion_nostd::Filter::Area));
    let tir = to_f64(&to_grid(tir, fusion_nostd::Filter::Cubic));
    let raw = match &pipeline.method {
        Method::Adf(p) => crate::adf::fuse_adf(&vis, &tir, p),
        Method::Tsifsd(p) => crate::tsifsd::fuse_tsifsd(&vis, &tir, p),
        Method::Ifevip(p) => crate::ifevip::fuse_ifevip(&vis, &tir, p),
        Method::Adaptive(p) => crate::adaptive::fuse_adaptive(&vis, &tir, p, decision),
    };
    let image = Gray { width: w, height: h, data: raw.data.iter().map(|&v| matlab_uint8(v)).collect() };
    Ok((image, raw))
}

/// MATLAB's `uint8()` cast: round half away from zero, saturate, NaN → 0.
pub fn matlab_uint8(v: f64) -> u8 {
    if v.is_nan() { 0 } else { v.round().clamp(0.0, 255.0) as u8 }
}

/// An 8-bit image as `f64` samples in 0..255 units.
pub fn to_f64(img: &Gray<u8>) -> Gray<f64> {
    Gray { width: img.width, height: img.height, data: img.data.iter().map(|&v| f64::from(v)).collect() }
}
