//! The core's methods as the host names them (the CLI's values, also the budget table's and the
//! Python package's), and the two host entry points every tool fuses through: the core
//! pipeline ([`fuse_core`]) and the f64 references ([`fuse_reference`]). A library module: the
//! `fusion` verbs (`cli::*`), the budgets (`budget::*`) and the study's host-only methods
//! import it; it imports none of them.

use crate::CoreScratch;
use crate::io::Gray;
use crate::reference;
use anyhow::Result;
use clap::ValueEnum;
use fusion_nostd::methods::{Guards, Variant};
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, fusion_grid};
use fusion_nostd::{AdaptiveParams, AdfParams, IfevipParams, TsifsdParams};

/// The core's fusion methods (also the method names of `fusion budget`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Anisotropic diffusion + KL transform.
    Adf,
    /// Two-scale fusion with saliency detection.
    Tsifsd,
    /// Infrared feature extraction + visual information preservation.
    Ifevip,
    /// Illumination-adaptive fusion for navigation (no variants: `--variant` is ignored).
    Adaptive,
}

/// Variant names on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum VariantArg {
    /// The published implementation, step for step.
    Classic,
    /// The study's changes with every unguarded case guarded.
    Flight,
}

/// Which implementation computes the result.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EngineArg {
    /// The no_std fixed-point core.
    Core,
    /// The f64 reference implementation.
    Reference,
}

/// Rescale policies on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RescaleArg {
    /// Bicubic upscale of TIR to the VIS grid.
    TirUp,
    /// Area downscale of VIS to the TIR grid.
    VisDown,
    /// No rescale; the two frames must have the same size.
    None,
}

impl From<RescaleArg> for RescalePolicy {
    fn from(r: RescaleArg) -> Self {
        match r {
            RescaleArg::TirUp => RescalePolicy::TirUp,
            RescaleArg::VisDown => RescalePolicy::VisDown,
            RescaleArg::None => RescalePolicy::None,
        }
    }
}

/// `--skip` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SkipArg {
    /// Fuse every pixel.
    None,
    /// Fuse only the target window.
    Roi,
    /// The window plus the eclipse plan.
    All,
}

impl From<SkipArg> for fusion_nostd::pipeline::SkipPolicy {
    fn from(s: SkipArg) -> Self {
        match s {
            SkipArg::None => Self::None,
            SkipArg::Roi => Self::Roi,
            SkipArg::All => Self::All,
        }
    }
}

/// The core method configuration for a method name and variant.
pub fn method_for(method: MethodArg, variant: VariantArg) -> Method {
    let variant = match variant {
        VariantArg::Classic => Variant::Classic,
        VariantArg::Flight => Variant::Flight,
    };
    match method {
        MethodArg::Adf => Method::Adf(AdfParams { variant, ..AdfParams::default() }),
        MethodArg::Tsifsd => Method::Tsifsd(TsifsdParams { variant, ..TsifsdParams::default() }),
        MethodArg::Ifevip => Method::Ifevip(IfevipParams { variant, ..IfevipParams::default() }),
        MethodArg::Adaptive => Method::Adaptive(AdaptiveParams::default()),
    }
}

/// The result of one fusion on the host.
#[derive(Debug, Clone)]
pub struct Fused {
    /// The 8-bit fused frame.
    pub image: Gray<u8>,
    /// The real-valued result before the cast, 0..255 units, when the engine has one.
    pub raw: Option<Gray<f64>>,
    /// Guards the core fired (empty for the reference engine).
    pub guards: Guards,
}

/// Fuses `vis` and `tir` with the core pipeline; with `with_raw`, through the core's pre-cast
/// entry ([`fusion_nostd::pipeline::fuse_raw`]) so the Q16 value comes back too (IFEVIP saturates
/// to 8 bits at every step, so its raw value is its output).
pub fn fuse_core(vis: &Gray<u8>, tir: &Gray<u8>, pipeline: &FuseConfig, with_raw: bool) -> Result<Fused> {
    let run = crate::study::fuse_timed(vis, tir, pipeline, 1)?;
    let (out, (w, h)) = (run.fused, run.report.grid);
    let raw = match (with_raw, &pipeline.method) {
        (false, _) => None,
        (true, Method::Ifevip(_) | Method::Adaptive(_)) => Some(to_f64(&out)),
        (true, _) => {
            let mut raw = Gray::<i32>::new(w, h);
            let mut scratch =
                CoreScratch::new(pipeline.scratch_pixels((vis.width, vis.height), (tir.width, tir.height))?);
            fusion_nostd::pipeline::fuse_raw(
                vis.view()?,
                tir.view()?,
                raw.view_mut()?,
                &mut scratch.view_mut(),
                pipeline,
            )?;
            let scale = f64::from(1u32 << fusion_nostd::methods::adf::RAW_FRAC_BITS);
            Some(Gray { width: w, height: h, data: raw.data.iter().map(|&v| f64::from(v) / scale).collect() })
        }
    };
    Ok(Fused { image: out, raw, guards: run.guards })
}

/// Fuses `vis` and `tir` with the f64 references (rescale and method).
pub fn fuse_reference(vis: &Gray<u8>, tir: &Gray<u8>, pipeline: &FuseConfig) -> Result<Fused> {
    // The adaptive method decides on the input VIS frame, before the rescale (as the core).
    let decision = fusion_nostd::pipeline::adaptive_decision(vis.view()?, pipeline)?;
    let (w, h) = fusion_grid((vis.width, vis.height), (tir.width, tir.height), pipeline.rescale)?;
    let to_grid = |img: &Gray<u8>, filter| {
        if (img.width, img.height) == (w, h) {
            img.clone()
        } else {
            reference::rescale::rescale_u8(img, w, h, filter)
        }
    };
    let vis = to_f64(&to_grid(vis, fusion_nostd::Filter::Area));
    let tir = to_f64(&to_grid(tir, fusion_nostd::Filter::Cubic));
    let raw = match &pipeline.method {
        Method::Adf(p) => reference::adf::fuse_adf(&vis, &tir, p),
        Method::Tsifsd(p) => reference::tsifsd::fuse_tsifsd(&vis, &tir, p),
        Method::Ifevip(p) => reference::ifevip::fuse_ifevip(&vis, &tir, p),
        Method::Adaptive(p) => reference::adaptive::fuse_adaptive(&vis, &tir, p, decision),
    };
    let image = Gray { width: w, height: h, data: raw.data.iter().map(|&v| matlab_uint8(v)).collect() };
    Ok(Fused { image, raw: Some(raw), guards: Guards::NONE })
}

/// MATLAB's `uint8()` cast: round half away from zero, saturate, NaN → 0.
pub fn matlab_uint8(v: f64) -> u8 {
    if v.is_nan() { 0 } else { v.round().clamp(0.0, 255.0) as u8 }
}

/// An 8-bit image as `f64` samples in 0..255 units.
pub fn to_f64(img: &Gray<u8>) -> Gray<f64> {
    Gray { width: img.width, height: img.height, data: img.data.iter().map(|&v| f64::from(v)).collect() }
}

/// `--agc` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AgcArg {
    /// Plateau histogram equalisation (the usual thermal-camera AGC; plateau --plateau).
    Plateau,
    /// Linear stretch between the 1 % and 99.9 % percentiles (the default: the best target
    /// contrast against cold space, BENCHMARKS.md "Thermal AGC").
    Linear,
}
