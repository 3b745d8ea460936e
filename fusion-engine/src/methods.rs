//! The core's methods as the host names them (the CLI's values, also the budget table's and the
//! Python package's), and the two host entry points every tool fuses through: the core
//! pipeline ([`fuse_core`]) and the f64 references ([`fuse_reference`]). A library module: the
//! `fusion` verbs (`cli::*`), the budgets (`budget::*`) and the study's host-only methods
//! import it; it imports none of them.

use crate::CoreScratch;
use anyhow::Result;
use fusion_io::Gray;
use fusion_nostd::methods::{Guards, Variant};
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy};
use fusion_nostd::{AdaptiveParams, AdfParams, IfevipParams, TsifsdParams};
use fusion_reference::to_f64;

/// The core's fusion methods (also the method names of `fusion budget`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum MethodArg {
    /// Anisotropic diffusion + KL transform.
    Adf,
    /// Two-scale fusion with saliency detection.
    Tsifsd,
    /// Infrared feature extraction + visual information preservation.
    Ifevip,
    /// Illumination-adaptive fusion for navigation: ADF (flight) on a large target, else the
    /// blend or the TIR frame (no variants: `--variant` is ignored).
    Adaptive,
}

/// Variant names on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum VariantArg {
    /// The published implementation, step for step.
    Classic,
    /// The study's changes with every unguarded case guarded.
    Flight,
}

/// Which implementation computes the result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum EngineArg {
    /// The no_std fixed-point core.
    Core,
    /// The f64 reference implementation.
    Reference,
}

/// Rescale policies on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
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
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
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

impl From<VariantArg> for Variant {
    fn from(v: VariantArg) -> Self {
        match v {
            VariantArg::Classic => Self::Classic,
            VariantArg::Flight => Self::Flight,
        }
    }
}

/// The core method configuration for a method name and variant.
pub fn method_for(method: MethodArg, variant: VariantArg) -> Method {
    let variant = Variant::from(variant);
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

/// Fuses `vis` and `tir` with the f64 references (rescale and method;
/// [`fusion_reference::fuse`]).
pub fn fuse_reference(vis: &Gray<u8>, tir: &Gray<u8>, pipeline: &FuseConfig) -> Result<Fused> {
    let (image, raw) = fusion_reference::fuse(vis, tir, pipeline)?;
    Ok(Fused { image, raw: Some(raw), guards: Guards::NONE })
}

/// The interpolation filter, as named on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum FilterArg {
    /// Keys bicubic, a = −0.75 (`cv2.INTER_CUBIC`).
    Cubic,
    /// Pixel area (`cv2.INTER_AREA`).
    Area,
}

impl From<FilterArg> for fusion_nostd::Filter {
    fn from(f: FilterArg) -> Self {
        match f {
            FilterArg::Cubic => fusion_nostd::Filter::Cubic,
            FilterArg::Area => fusion_nostd::Filter::Area,
        }
    }
}

/// `--agc` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum AgcArg {
    /// Plateau histogram equalisation (the usual thermal-camera AGC; plateau --plateau).
    Plateau,
    /// Linear stretch between the 1 % and 99.9 % percentiles (the default: the best target
    /// contrast against cold space, BENCHMARKS.md "Thermal AGC").
    Linear,
}
