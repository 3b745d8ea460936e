//! `fusion fuse`: fuse one VIS/TIR pair with a chosen method, engine and rescale policy.
//!
//! The core's three methods run on either engine; the study's four host-only methods (GFF,
//! MGFF, TEPGFL, DRIF; [`crate::study_methods`]) run on the host f64 engine only.

use crate::io::{Batch, Channels, Gray, OutFormat, Picture, encode_channels, encode_npy_f32};
use crate::methods::{
    AgcArg, EngineArg, Fused, MethodArg, RescaleArg, SkipArg, VariantArg, fuse_core, fuse_reference,
    method_for, to_f64,
};
use crate::reference;
use crate::study_methods::{HostMethod, cast_u8, drif, fuse_host_u8};
use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use fusion_nostd::methods::Guards;
use fusion_nostd::pipeline::{FuseConfig, RescalePolicy, fusion_grid};
use std::path::{Path, PathBuf};

/// Every method `fusion fuse` knows: the core's three and the study's four host-only ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FuseMethod {
    /// Anisotropic diffusion + KL transform (core or f64 reference).
    Adf,
    /// Two-scale fusion with saliency detection (core or f64 reference).
    Tsifsd,
    /// Infrared feature extraction + visual information preservation (core or f64 reference).
    Ifevip,
    /// Illumination-adaptive fusion for navigation (core or f64 reference).
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
    /// Scene skipping (core engine, ADF/TSIFSD/IFEVIP): none fuses every pixel; roi fuses a
    /// window around the target and writes the background elsewhere (pixels of the reported
    /// ROI are bit-identical to none); all adds the eclipse plan. The report is printed.
    #[arg(long, value_enum, default_value_t = SkipArg::None)]
    pub skip: SkipArg,
    /// Fuse strip by strip in the flight core's 512 KiB strip scratch (core engine, every
    /// method and variant; no --skip, no --raw): bit-identical to the whole-frame run. The value
    /// caps the strip height in grid rows (`max`: as tall as the scratch allows). The strip
    /// report is printed.
    #[arg(long, value_name = "ROWS|max")]
    pub strips: Option<StripRows>,
    /// Thermal AGC for a 14/16-bit thermal image (its counts to 8 bits, in the core:
    /// `fusion_nostd::agc`) [default: linear]. An 8-bit thermal image is used as it is.
    #[arg(long, value_enum)]
    pub agc: Option<AgcArg>,
    /// The plateau of plateau equalisation, in pixels per histogram bin (bins of 4 counts); given
    /// alone it asks for --agc plateau [default: the thermal frame's pixels / 2^18, at least 1].
    #[arg(long, value_name = "PIXELS")]
    pub plateau: Option<u32>,
    /// Folders as sequences: smooth the AGC mapping over the thermal frames in name order, each
    /// frame's mapping moving 1/2^K of the way to its own (0..=8; 0: none) so the level does not
    /// flicker. Needs two folders and 14/16-bit thermal frames; the mapped thermal frames are
    /// held in memory (one byte per pixel) before the pairs are fused.
    #[arg(long, value_name = "K")]
    pub agc_smoothing: Option<u8>,
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

/// One line per field of a strip report, as `fusion fuse --strips` prints it.
pub fn strip_report_text(r: &fusion_nostd::strips::StripReport, grid: (usize, usize)) -> String {
    format!(
        "strips: {} strips of {} rows (halo {} rows, {} pass{})\n\
         strips: method rows {} = {:.3} × the grid's {}; band rows {}\n\
         strips: working set {} B = {} work words ({} B) + {} B of band window\n",
        r.strips,
        r.strip_rows,
        r.halo_rows,
        r.passes,
        if r.passes == 1 { "" } else { "es" },
        r.method_rows,
        r.method_rows as f64 / grid.1.max(1) as f64,
        grid.1,
        r.band_rows,
        r.working_set_bytes(),
        r.work_words,
        r.work_words * 4,
        r.band_bytes,
    )
}

/// One line per field of a skip report, as `fusion fuse --skip` prints it.
pub fn skip_report_text(r: &fusion_nostd::pipeline::FuseReport) -> String {
    let s = &r.skip;
    let rect = |q: &fusion_nostd::scene::Rect| {
        format!("x {}..{}, y {}..{} ({} px)", q.x0, q.x1, q.y0, q.y1, q.area())
    };
    let grid = r.grid.0 * r.grid.1;
    format!(
        "skip: policy {:?}, illumination {}, taken {:#x}{}\n\
         skip: roi (bit-identical to --skip none) {}\n\
         skip: computed window {} = {:.2} % of the frame; background value outside {}\n\
         skip: output outside the roi proven identical too: {}\n",
        s.policy,
        s.illumination.map_or("not analysed".to_string(), |i| format!("{i:?}")),
        s.taken.0,
        s.declined.map_or(String::new(), |d| format!(", declined: {d:?} (whole frame fused)")),
        rect(&s.roi),
        rect(&s.computed),
        100.0 * s.computed.area() as f64 / grid.max(1) as f64,
        s.background.map_or("-".to_string(), |b| b.to_string()),
        s.exact_outside,
    )
}

/// Fuses with a host-only method on the f64 engine: the rescale policy first (f64 reference
/// rescalers, as [`fuse_reference`]), except for DRIF, which takes both frames as they are.
pub fn fuse_host_method(
    vis: &Gray<u8>,
    tir: &Gray<u8>,
    method: HostMethod,
    rescale: RescalePolicy,
) -> Result<Fused> {
    let (image, raw) = if method == HostMethod::Drif {
        let run = drif::fuse_drif(&to_f64(vis), &to_f64(tir), &drif::DrifParams::default())?;
        let (start, end) = (run.energy[0], run.energy.last().copied().unwrap_or(run.energy[0]));
        note!(
            "drif: {} FISTA iterations ({}), energy {start:.4e} -> {end:.4e}",
            run.iterations,
            if run.converged { "converged" } else { "iteration bound reached" }
        );
        (cast_u8(&run.fused), run.fused)
    } else {
        let (w, h) = fusion_grid((vis.width, vis.height), (tir.width, tir.height), rescale)?;
        let to_grid = |img: &Gray<u8>, filter| {
            if (img.width, img.height) == (w, h) {
                img.clone()
            } else {
                reference::rescale::rescale_u8(img, w, h, filter)
            }
        };
        fuse_host_u8(
            method,
            &to_grid(vis, fusion_nostd::Filter::Area),
            &to_grid(tir, fusion_nostd::Filter::Cubic),
        )?
    };
    Ok(Fused { image, raw: Some(raw), guards: Guards::NONE })
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

/// The core AGC parameters the options ask for, for a frame of `pixels`: `--agc` (linear
/// unless `--plateau` is given, which asks for plateau equalisation), `--plateau`,
/// `--agc-smoothing`.
pub fn agc_params(args: &FuseArgs, pixels: usize) -> fusion_nostd::AgcParams {
    let default = if args.plateau.is_some() { AgcArg::Plateau } else { AgcArg::Linear };
    crate::agc::params(args.agc.unwrap_or(default), args.plateau, args.agc_smoothing.unwrap_or(0), pixels)
}

/// One thermal frame's counts through the core AGC, with `agc`'s state (smoothing).
pub fn agc_map(
    args: &FuseArgs,
    agc: &mut fusion_nostd::Agc,
    counts: &Gray<u16>,
    path: &Path,
) -> Result<Gray<u8>> {
    crate::agc::map_counts(agc, counts, &agc_params(args, counts.width * counts.height))
        .with_context(|| format!("thermal image {}: AGC", path.display()))
}

/// Both inputs read and made ready for the grey fusion.
struct Prepared {
    /// The visible frame's grey, or its luminance when the chroma is kept.
    vis: Gray<u8>,
    /// The visible frame's Cb and Cr when its colour is kept.
    chroma: Option<[Gray<u8>; 2]>,
    /// The thermal frame in 8 bits (through the AGC when it was 14/16-bit).
    tir: Gray<u8>,
}

/// Reads both inputs; `tir_mapped` is the thermal frame already through the AGC (a folder run
/// with `--agc-smoothing`).
fn prepare(
    args: &FuseArgs,
    vis_path: &Path,
    tir_path: &Path,
    tir_mapped: Option<Gray<u8>>,
) -> Result<Prepared> {
    let vis_picture = crate::io::load_picture(vis_path).context("visible image")?;
    let tir_picture = match tir_mapped {
        Some(g) => Picture::Gray8(g),
        None => crate::io::load_picture(tir_path).context("thermal image")?,
    };
    let (vis, chroma) = match vis_picture {
        Picture::Gray8(g) => (g, None),
        Picture::Gray16(_) => bail!(
            "visible image: {} is 16-bit; give an 8-bit one (the AGC is for the thermal band)",
            vis_path.display()
        ),
        Picture::Rgb8(c) => match args.color.unwrap_or(ColorArg::Keep) {
            ColorArg::Keep => {
                let [y, cb, cr] = crate::color::rgb_to_ycbcr(&c);
                (y, Some([cb, cr]))
            }
            ColorArg::Gray => (c.to_gray(), None),
        },
    };
    let tir = match tir_picture {
        Picture::Gray8(g) => {
            if (args.agc.is_some() || args.plateau.is_some()) && args.agc_smoothing.is_none() {
                note!(
                    "fusion: note: {} is 8-bit: --agc and --plateau apply to 14/16-bit counts and are not used",
                    tir_path.display()
                );
            }
            g
        }
        Picture::Rgb8(c) => c.to_gray(),
        Picture::Gray16(counts) => agc_map(args, &mut crate::agc::fresh(), &counts, tir_path)?,
    };
    Ok(Prepared { vis, chroma, tir })
}

/// What one grey fusion gives: the image, the pre-cast value, the guards and the text report
/// (strips, skip) to print.
struct GrayResult {
    fused: Fused,
    report: String,
}

fn fuse_gray(args: &FuseArgs, vis: &Gray<u8>, tir: &Gray<u8>) -> Result<GrayResult> {
    let rescale = args.rescale.unwrap_or(RescaleArg::TirUp);
    let fused = match args.method.split() {
        Ok(method) => {
            let pipeline = FuseConfig {
                rescale: rescale.into(),
                method: method_for(method, args.variant.unwrap_or(VariantArg::Flight)),
                skip: args.skip.into(),
                ..Default::default()
            };
            let engine = args.engine.unwrap_or(EngineArg::Core);
            if let Some(StripRows(rows)) = args.strips {
                let mut scratch = crate::strips::HostStripScratch::default();
                let (image, report, strips, _) =
                    crate::strips::fuse_strips_once(vis, tir, &pipeline, rows, &mut scratch)?;
                let fused = Fused { image, raw: None, guards: report.guards };
                return Ok(GrayResult { fused, report: strip_report_text(&strips, report.grid) });
            }
            if args.skip != SkipArg::None {
                let (image, report, _) = crate::skip::fuse_once(vis, tir, &pipeline)?;
                let fused = Fused { image, raw: None, guards: report.guards };
                return Ok(GrayResult { fused, report: skip_report_text(&report) });
            }
            match engine {
                EngineArg::Core => fuse_core(vis, tir, &pipeline, args.raw.is_some())?,
                EngineArg::Reference => fuse_reference(vis, tir, &pipeline)?,
            }
        }
        Err(host) => fuse_host_method(vis, tir, host, rescale.into())?,
    };
    Ok(GrayResult { fused, report: String::new() })
}

/// Refuses option combinations that cannot run, before anything is read.
fn check_options(args: &FuseArgs) -> Result<()> {
    match args.method.split() {
        Ok(_) => {
            let engine = args.engine.unwrap_or(EngineArg::Core);
            if args.strips.is_some()
                && (engine != EngineArg::Core || args.raw.is_some() || args.skip != SkipArg::None)
            {
                bail!(
                    "--strips works with the core engine's 8-bit output only (no --engine reference, no --raw, no --skip)"
                );
            }
            if args.skip != SkipArg::None && (engine != EngineArg::Core || args.raw.is_some()) {
                bail!(
                    "--skip works with the core engine's 8-bit output only (no --engine reference, no --raw)"
                );
            }
        }
        Err(host) => {
            if args.strips.is_some() || args.skip != SkipArg::None {
                bail!("{} is a host-only method (f64): --strips and --skip are core options", host.name());
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
    if let (Some(AgcArg::Linear), Some(_)) = (args.agc, args.plateau) {
        bail!("--plateau sets the plateau of --agc plateau; drop it with --agc linear");
    }
    if args.agc_smoothing.is_some_and(|k| k > fusion_nostd::agc::AGC_MAX_SMOOTHING) {
        bail!("--agc-smoothing is at most {}", fusion_nostd::agc::AGC_MAX_SMOOTHING);
    }
    if args.plateau == Some(0) {
        bail!("--plateau must be at least 1 pixel per bin");
    }
    Ok(())
}

/// The memory estimate from the headers, before either frame is decoded. The fusion grid is
/// the larger frame's (tir-up, none) or the smaller one's (vis-down).
fn check_memory(args: &FuseArgs, vis_path: &Path, tir_path: &Path) -> Result<()> {
    let rescale = args.rescale.unwrap_or(RescaleArg::TirUp);
    let (vw, vh, vc) = crate::io::image_header(vis_path).context("visible image")?;
    let (tw, th, _) = crate::io::image_header(tir_path).context("thermal image")?;
    let (vis_px, tir_px) = ((vw as u64).saturating_mul(vh as u64), (tw as u64).saturating_mul(th as u64));
    let grid = match rescale {
        RescaleArg::VisDown => vis_px.min(tir_px),
        _ => vis_px.max(tir_px),
    };
    let per_px = match (args.method.split(), args.engine.unwrap_or(EngineArg::Core)) {
        (Err(_), _) => crate::memory::per_pixel::FUSE_HOST_METHOD,
        (Ok(_), EngineArg::Reference) => crate::memory::per_pixel::FUSE_REFERENCE,
        (Ok(_), EngineArg::Core) => crate::memory::per_pixel::FUSE_CORE,
    };
    // A colour frame kept in colour carries its two chroma planes and the RGB output too.
    let per_px = per_px + if vc == 3 { 6 } else { 0 };
    let (input, band) =
        if vis_px >= tir_px { (vis_path, "visible image") } else { (tir_path, "thermal image") };
    crate::memory::check(
        &input.display().to_string(),
        "fusing this pair",
        crate::memory::estimate(grid, per_px),
    )
    .context(band)
}

/// Fuses one pair of files into `output` (and `args.raw`); returns the text report to print
/// and the guards that fired.
fn fuse_files(
    args: &FuseArgs,
    vis_path: &Path,
    tir_path: &Path,
    tir_mapped: Option<Gray<u8>>,
    output: &Path,
) -> Result<(String, Guards)> {
    let format = OutFormat::of(output)?;
    check_memory(args, vis_path, tir_path)?;
    let input = prepare(args, vis_path, tir_path, tir_mapped)?;
    let GrayResult { fused, report } = fuse_gray(args, &input.vis, &input.tir)?;
    let (vis, tir) = (&input.vis, &input.tir);
    if vis.width * tir.height != vis.height * tir.width {
        note!(
            "fusion: note: VIS {}x{} and TIR {}x{} differ in aspect ratio; the rescale stretches one onto the other's grid",
            vis.width,
            vis.height,
            tir.width,
            tir.height
        );
    }
    let image = match &input.chroma {
        None => Channels::from_gray(fused.image.clone()),
        Some([cb, cr]) => crate::color::fused_in_colour(&fused.image, cb, cr)?,
    };
    // Both outputs or neither: the image and the raw array are staged, then renamed together.
    let mut batch = Batch::default();
    if let Some(raw_path) = &args.raw {
        let Some(raw) = &fused.raw else { bail!("no pre-cast value for this engine and method") };
        let data: Vec<f32> = raw.data.iter().map(|&v| v as f32).collect();
        let nan = data.iter().filter(|v| v.is_nan()).count();
        if nan > 0 {
            note!(
                "fusion: note: {nan} raw values are NaN (the published method's 0/0, e.g. classic TSIFSD on flat regions); the 8-bit output has 0 there"
            );
        }
        batch.add(raw_path, |w| encode_npy_f32(w, raw.width, raw.height, &data))?;
    }
    batch.add(output, |w| encode_channels(w, format, &image))?;
    batch.commit()?;
    Ok((report, fused.guards))
}

/// Runs `fusion fuse`: one pair, or two folders of pairs.
pub fn run(args: &FuseArgs) -> Result<()> {
    check_options(args)?;
    match (args.vis.is_dir(), args.tir.is_dir()) {
        (false, false) => {
            if args.agc_smoothing.is_some() {
                bail!("--agc-smoothing smooths over a sequence: give two folders of frames");
            }
            if args.jobs.is_some() || args.format.is_some() {
                bail!("--jobs and --format are for folders; one output's format follows its extension");
            }
            let (report, guards) = fuse_files(args, &args.vis, &args.tir, None, &args.output)?;
            out!("{report}")?;
            if guards != Guards::NONE {
                note!("fusion: guards: {guards} (fusion_nostd::Guards)");
            }
            Ok(())
        }
        (true, true) => crate::cli::fuse_folders::run(args),
        (true, false) => bail!(
            "visible image: {} is a folder and the thermal image {} is not: give two files or two folders",
            args.vis.display(),
            args.tir.display()
        ),
        (false, true) => bail!(
            "thermal image: {} is a folder and the visible image {} is not: give two files or two folders",
            args.tir.display(),
            args.vis.display()
        ),
    }
}

/// Fuses one pair of a folder run (no report printed; `tir_mapped`: the thermal frame already
/// through the AGC); says which guards fired, if any.
pub fn fuse_pair_quietly(
    args: &FuseArgs,
    vis: &Path,
    tir: &Path,
    tir_mapped: Option<Gray<u8>>,
    output: &Path,
) -> Result<String> {
    let (_, guards) = fuse_files(args, vis, tir, tir_mapped, output)?;
    Ok(if guards == Guards::NONE { String::new() } else { format!("guards: {guards}") })
}
