//! `fusion fuse`'s options and their checks.

use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use fusion_engine::methods::{EngineArg, MethodArg, RescaleArg, SkipArg, VariantArg};
use fusion_io::OutFormat;
use fusion_reference::study_methods::HostMethod;
use std::path::PathBuf;

/// Every method `fusion fuse` knows: the core's three and the study's four host-only ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FuseMethod {
    /// Anisotropic diffusion + KL transform (core or f64 reference).
    Adf,
    /// Two-scale fusion with saliency detection (core or f64 reference).
    Tsifsd,
    /// Infrared feature extraction + visual information preservation (core or f64 reference).
    Ifevip,
    /// Illumination-adaptive fusion for navigation: ADF on a large target, else the blend or
    /// the TIR frame (core or f64 reference).
    Adaptive,
    /// Guided-filter fusion, Li et al. 2013 (host f64 only).
    Gff,
    /// Multi-scale guided-filter fusion, Bavirisetti et al. 2019 (host f64 only).
    Mgff,
    /// Fast-global-smoother decomposition + Gaussian fuzzy logic, Duan et al. 2022 (host f64 only).
    Tepgfl,
    /// Different-resolution TV fusion with FISTA, Du et al. 2018 (host f64 only): VIS and TIR at
    /// their own sizes (VIS an integer multiple of TIR), output on the VIS grid, no rescale.
    Drif,
}

impl FuseMethod {
    /// The core method, or the host-only method.
    pub fn split(self) -> Result<MethodArg, HostMethod> {
        match self {
            FuseMethod::Adf => Ok(MethodArg::Adf),
            FuseMethod::Tsifsd => Ok(MethodArg::Tsifsd),
            FuseMethod::Ifevip => Ok(MethodArg::Ifevip),
            FuseMethod::Adaptive => Ok(MethodArg::Adaptive),
            FuseMethod::Gff => Err(HostMethod::Gff),
            FuseMethod::Mgff => Err(HostMethod::Mgff),
            FuseMethod::Tepgfl => Err(HostMethod::Tepgfl),
            FuseMethod::Drif => Err(HostMethod::Drif),
        }
    }
}

/// Arguments of `fusion fuse`.
#[derive(Debug, Args)]
pub struct FuseArgs {
    /// Fusion method. gff, mgff, tepgfl and drif are the study's host-only methods (f64 engine
    /// only); drif fuses the two frames at their own resolutions (VIS an integer multiple of
    /// TIR, output on the VIS grid) and takes no --rescale.
    #[arg(long, value_enum, default_value_t = FuseMethod::Tsifsd)]
    pub method: FuseMethod,
    /// Method variant (adf, tsifsd, ifevip only) [default: flight].
    #[arg(long, value_enum)]
    pub variant: Option<VariantArg>,
    /// Implementation to run [default: core; reference for gff, mgff, tepgfl, drif].
    #[arg(long, value_enum)]
    pub engine: Option<EngineArg>,
    /// How the two bands are brought onto one grid [default: tir-up; not for drif].
    #[arg(long, value_enum)]
    pub rescale: Option<RescaleArg>,
    /// Also write the real-valued result before the 8-bit cast as a float32 `.npy` (0..255 units).
    #[arg(long, value_name = "OUT.npy")]
    pub raw: Option<PathBuf>,
    /// Scene skipping (core engine): none fuses every pixel; roi fuses a window around the
    /// target and writes the background elsewhere (the reported ROI is bit-identical to none
    /// for TSIFSD, the adaptive method and ADF on noiseless frames; ADF on noisy frames and
    /// IFEVIP fuse the crop as a frame of its own); all adds the eclipse plan. The report is
    /// printed.
    #[arg(long, value_enum, default_value_t = SkipArg::None)]
    pub skip: SkipArg,
    /// Skip with the caller's window instead of the analysis's (core engine): fuse only this
    /// box of the fusion grid, `X0,Y0,X1,Y1` (columns X0..X1, rows Y0..Y1, end excluded), e.g.
    /// a navigation filter's predicted target box. TSIFSD and the adaptive method are
    /// bit-identical to `--skip none` inside it; ADF and IFEVIP fuse the crop as a frame of its
    /// own (so does an adaptive frame with a large target, which is ADF's); the background
    /// value elsewhere. The report is printed.
    #[arg(long, value_name = "X0,Y0,X1,Y1", conflicts_with = "skip")]
    pub window: Option<WindowArg>,
    /// Fuse strip by strip in the flight core's 512 KiB strip scratch (core engine, every
    /// method and variant; no --skip, no --raw): bit-identical to the whole-frame run. The value
    /// caps the strip height in grid rows (`max`: as tall as the scratch allows). The strip
    /// report is printed.
    #[arg(long, value_name = "ROWS|max")]
    pub strips: Option<StripRows>,
    /// Folders as a sequence (core engine, ADF): fuse the pairs one after another in name order,
    /// each frame with the KL weights the one before measured (`fusion_nostd::sequence`: one
    /// pass over the strips with --strips); the first frame, and one whose VIS illumination
    /// class, covariance size (more than 1.5×) or parameters changed, take their own. The other
    /// methods are fused per frame. Runs on one thread (--jobs is refused).
    #[arg(long)]
    pub sequence_mode: bool,
    /// `--agc`, `--plateau`.
    #[command(flatten)]
    pub thermal_agc: crate::cli::agc::AgcChoice,
    /// Folders as sequences: smooth the AGC mapping over the thermal frames in name order, each
    /// frame's mapping moving 1/2^K of the way to its own (0..=8; 0: none) so the level does not
    /// flicker. Needs two folders and 14/16-bit thermal frames; the mapped thermal frames are
    /// held in memory (one byte per pixel) before the pairs are fused.
    #[arg(long, value_name = "K")]
    pub agc_smoothing: Option<u8>,
    /// The thermal camera's NUC tables (`fusion_io::thermal`: `VISTNUC1` header, Q2.14 gains,
    /// offsets in counts): raw 14/16-bit counts are corrected in the core
    /// (`fusion_nostd::thermal`) before the AGC.
    #[arg(long, value_name = "TABLES")]
    pub nuc: Option<PathBuf>,
    /// The thermal camera's bad-pixel map (8-bit image of the array's size, non-zero = bad):
    /// each bad pixel takes the median of its valid 8-neighbours, before the AGC.
    #[arg(long, value_name = "MAP")]
    pub bad_pixels: Option<PathBuf>,
    /// A shutter frame (raw counts of a flat field): re-levels the --nuc offsets before the
    /// thermal frames are corrected.
    #[arg(long, value_name = "FRAME", requires = "nuc")]
    pub shutter: Option<PathBuf>,
    /// Folders as a sequence: the shutter frames of the thermal camera (raw counts of its flat
    /// field), named like the thermal frames they were captured at (`fusion render --raw-tir`
    /// writes `tir_shutter/`); each re-levels the --nuc offsets before its frame is corrected.
    #[arg(long, value_name = "DIR", requires = "nuc")]
    pub shutter_dir: Option<PathBuf>,
    /// Remove column stripes from the raw thermal counts (after --nuc and --bad-pixels, before
    /// the AGC): the threshold of the differences that count, in counts, or `auto` (three
    /// robust standard deviations of neighbouring pixels' differences in the frame).
    #[arg(long, value_name = "COUNTS|auto")]
    pub column_filter: Option<ColumnArg>,
    /// An offset camera pair: its calibration (OpenCV `FileStorage` YAML or JSON, as `fusion
    /// register --rig`); the thermal frame (after the AGC) is warped onto the visible grid for
    /// a target at --range before the fusion (bilinear, cold space where the thermal camera did
    /// not see). The visible frame must be the rig's visible size.
    #[arg(long, value_name = "FILE", requires = "range")]
    pub rig: Option<PathBuf>,
    /// With --rig: range of the target plane along the visible optical axis, metres.
    #[arg(long, value_name = "METRES", requires = "rig")]
    pub range: Option<f64>,
    /// A colour visible image: keep its colour (fuse the luminance, restore the chroma; RGB
    /// out) or fuse its grey [default: keep].
    #[arg(long, value_enum)]
    pub color: Option<ColorArg>,
    /// Folders: pairs fused at once [default: every core].
    #[arg(long, value_name = "N")]
    pub jobs: Option<usize>,
    /// Folders: the outputs' format [default: png] (one output's format follows its extension).
    #[arg(long, value_enum)]
    pub format: Option<OutFormat>,
    /// Visible image (PNG, JPEG, TIFF or PGM/PPM; 8-bit grey or colour), or a folder of them.
    pub vis: PathBuf,
    /// Thermal-infrared image (PNG, JPEG, TIFF or PGM; 8-bit, or 14/16-bit counts through --agc;
    /// colour is converted with BT.601 weights), or a folder of them (paired with the visible
    /// folder's files by name without extension).
    pub tir: PathBuf,
    /// Fused output (.png, .tif/.tiff, or .pgm for grey; RGB when the visible image is colour and --color
    /// keep), or a folder for the pairs of two folders.
    pub output: PathBuf,
}

/// `--column-filter` value: a threshold in counts, or `auto`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnArg {
    /// From each frame: [`fusion_engine::thermal::column_threshold`].
    Auto,
    /// This many counts (1..=32 767).
    Counts(u16),
}

impl std::str::FromStr for ColumnArg {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s == "auto" {
            return Ok(ColumnArg::Auto);
        }
        match s.parse::<u16>() {
            Ok(t) if (1..=fusion_nostd::thermal::column::COLUMN_MAX_THRESHOLD).contains(&t) => {
                Ok(ColumnArg::Counts(t))
            }
            _ => Err(format!(
                "'{s}' is neither 'auto' nor a threshold of 1 to {} counts",
                fusion_nostd::thermal::column::COLUMN_MAX_THRESHOLD
            )),
        }
    }
}

/// `--strips` value: a strip height cap in grid rows, or `max`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StripRows(pub usize);

impl std::str::FromStr for StripRows {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s == "max" {
            return Ok(StripRows(usize::MAX));
        }
        match s.parse::<usize>() {
            Ok(n) if n > 0 => Ok(StripRows(n)),
            _ => Err(format!("`{s}` is not a positive number of rows or `max`")),
        }
    }
}

/// `--window` value: a box of the fusion grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WindowArg(pub fusion_nostd::scene::Rect);

impl std::str::FromStr for WindowArg {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let v: Vec<usize> = s
            .split(',')
            .map(|p| p.trim().parse::<usize>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("`{s}` is not four pixel coordinates X0,Y0,X1,Y1"))?;
        let &[x0, y0, x1, y1] = v.as_slice() else {
            return Err(format!("`{s}` is not four pixel coordinates X0,Y0,X1,Y1"));
        };
        if x1 <= x0 || y1 <= y0 {
            return Err(format!("`{s}`: the box is empty (X1 must exceed X0 and Y1 exceed Y0)"));
        }
        Ok(WindowArg(fusion_nostd::scene::Rect { x0, y0, x1, y1 }))
    }
}

/// `--color` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ColorArg {
    /// Fuse the luminance (YCbCr, BT.601 full range) and restore the visible frame's chroma:
    /// RGB out.
    Keep,
    /// Convert the visible frame to grey (MATLAB `rgb2gray` weights): grey out.
    Gray,
}

/// Refuses option combinations that cannot run, before anything is read.
pub(super) fn check_options(args: &FuseArgs) -> Result<()> {
    if let Some(range) = args.range
        && !(range.is_finite() && range > 0.0)
    {
        bail!("--range must be a positive number of metres, not {range}");
    }
    match args.method.split() {
        Ok(_) => {
            let engine = args.engine.unwrap_or(EngineArg::Core);
            let skipping = args.skip != SkipArg::None || args.window.is_some();
            if args.strips.is_some() && (engine != EngineArg::Core || args.raw.is_some() || skipping) {
                bail!(
                    "--strips works with the core engine's 8-bit output only (no --engine reference, no --raw, no --skip or --window)"
                );
            }
            if args.sequence_mode && (engine != EngineArg::Core || args.raw.is_some() || args.jobs.is_some())
            {
                bail!(
                    "--sequence-mode works with the core engine's 8-bit output on one thread (no --engine reference, no --raw, no --jobs)"
                );
            }
            if skipping && (engine != EngineArg::Core || args.raw.is_some()) {
                bail!(
                    "--skip and --window work with the core engine's 8-bit output only (no --engine reference, no --raw)"
                );
            }
        }
        Err(host) => {
            if args.strips.is_some()
                || args.skip != SkipArg::None
                || args.window.is_some()
                || args.sequence_mode
            {
                bail!(
                    "{} is a host-only method (f64): --strips, --skip, --window and --sequence-mode are core options",
                    host.name()
                );
            }
            if args.variant.is_some() {
                bail!("{} has one variant (the study's, f64): drop --variant", host.name());
            }
            if args.engine == Some(EngineArg::Core) {
                bail!(
                    "{} is a host-only method (f64): it has no core engine; use --engine reference",
                    host.name()
                );
            }
            if host.different_resolution() && args.rescale.is_some() {
                bail!("drif fuses the two frames at their own resolutions: drop --rescale");
            }
        }
    }
    args.thermal_agc.check()?;
    if args.agc_smoothing.is_some_and(|k| k > fusion_nostd::agc::AGC_MAX_SMOOTHING) {
        bail!("--agc-smoothing is at most {}", fusion_nostd::agc::AGC_MAX_SMOOTHING);
    }
    Ok(())
}
