//! `fusion fuse`: fuse one VIS/TIR pair with a chosen method, engine and rescale policy.

use crate::CoreScratch;
use crate::io::{ColorPolicy, Gray, load_gray_u8, save_gray_u8, write_npy_f32};
use crate::reference;
use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use fusion_nostd::fuse::{Guards, Variant};
use fusion_nostd::pipeline::{Method, Pipeline, RescalePolicy, fusion_grid};
use fusion_nostd::{AdfParams, IfevipParams, TsifsdParams};
use std::path::PathBuf;

/// Fusion method names on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Anisotropic diffusion + KL transform.
    Adf,
    /// Two-scale fusion with saliency detection.
    Tsifsd,
    /// Infrared feature extraction + visual information preservation.
    Ifevip,
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

/// Arguments of `fusion fuse`.
#[derive(Debug, Args)]
pub struct FuseArgs {
    /// Fusion method.
    #[arg(long, value_enum, default_value_t = MethodArg::Tsifsd)]
    pub method: MethodArg,
    /// Method variant.
    #[arg(long, value_enum, default_value_t = VariantArg::Flight)]
    pub variant: VariantArg,
    /// Implementation to run.
    #[arg(long, value_enum, default_value_t = EngineArg::Core)]
    pub engine: EngineArg,
    /// How the two bands are brought onto one grid.
    #[arg(long, value_enum, default_value_t = RescaleArg::TirUp)]
    pub rescale: RescaleArg,
    /// Also write the real-valued result before the 8-bit cast as a float32 `.npy` (0..255 units).
    #[arg(long, value_name = "OUT.npy")]
    pub raw: Option<PathBuf>,
    /// Visible image (grey PNG; colour is converted with BT.601 weights).
    pub vis: PathBuf,
    /// Thermal-infrared image (grey PNG; colour is converted with BT.601 weights).
    pub tir: PathBuf,
    /// Fused output (8-bit grey PNG).
    pub output: PathBuf,
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
pub fn fuse_core(vis: &Gray<u8>, tir: &Gray<u8>, pipeline: &Pipeline, with_raw: bool) -> Result<Fused> {
    let (w, h) = fusion_grid((vis.width, vis.height), (tir.width, tir.height), pipeline.rescale)?;
    let mut scratch =
        CoreScratch::new(pipeline.scratch_pixels((vis.width, vis.height), (tir.width, tir.height))?);
    let mut out = Gray::new(w, h);
    let report = fusion_nostd::pipeline::fuse(
        vis.view()?,
        tir.view()?,
        out.view_mut()?,
        &mut scratch.view_mut(),
        pipeline,
    )?;
    let raw = match (with_raw, &pipeline.method) {
        (false, _) => None,
        (true, Method::Ifevip(_)) => Some(to_f64(&out)),
        (true, _) => {
            let mut raw = Gray::<i32>::new(w, h);
            fusion_nostd::pipeline::fuse_raw(
                vis.view()?,
                tir.view()?,
                raw.view_mut()?,
                &mut scratch.view_mut(),
                pipeline,
            )?;
            let scale = f64::from(1u32 << fusion_nostd::fuse::adf::RAW_FRAC_BITS);
            Some(Gray { width: w, height: h, data: raw.data.iter().map(|&v| f64::from(v) / scale).collect() })
        }
    };
    Ok(Fused { image: out, raw, guards: report.guards })
}

/// Fuses `vis` and `tir` with the f64 references (rescale and method).
pub fn fuse_reference(vis: &Gray<u8>, tir: &Gray<u8>, pipeline: &Pipeline) -> Result<Fused> {
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

/// Runs `fusion fuse`.
pub fn run(args: &FuseArgs) -> Result<()> {
    let vis = load_gray_u8(&args.vis, ColorPolicy::Bt601).context("visible image")?;
    let tir = load_gray_u8(&args.tir, ColorPolicy::Bt601).context("thermal image")?;
    let pipeline = Pipeline { rescale: args.rescale.into(), method: method_for(args.method, args.variant) };
    let fused = match args.engine {
        EngineArg::Core => fuse_core(&vis, &tir, &pipeline, args.raw.is_some())?,
        EngineArg::Reference => fuse_reference(&vis, &tir, &pipeline)?,
    };
    if let Some(raw_path) = &args.raw {
        let Some(raw) = &fused.raw else { bail!("no pre-cast value for this engine and method") };
        let data: Vec<f32> = raw.data.iter().map(|&v| v as f32).collect();
        write_npy_f32(raw_path, raw.width, raw.height, &data)?;
    }
    save_gray_u8(&args.output, &fused.image)?;
    if fused.guards != Guards::NONE {
        eprintln!("fusion: guards fired: {:#x}", fused.guards.0);
    }
    Ok(())
}
