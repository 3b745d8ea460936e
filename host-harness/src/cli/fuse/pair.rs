//! One pair: load (thermal counts through the AGC), fuse on the chosen engine, write the
//! outputs as one batch, and the report line (also each pair of a folder run).

use super::args::{ColorArg, ColumnArg, FuseArgs, StripRows};
use anyhow::{Context, Result, bail};
use fusion_engine::methods::{
    EngineArg, Fused, RescaleArg, VariantArg, fuse_core, fuse_reference, method_for,
};
use fusion_engine::sequence::{Form, SequenceFuser};
use fusion_engine::thermal::{Column, ThermalChain};
use fusion_io::npy::encode_npy_f32;
use fusion_io::{Batch, Channels, Gray, OutFormat, Picture, encode_channels};
use fusion_nostd::methods::Guards;
use fusion_nostd::pipeline::{FuseConfig, RescalePolicy, SkipPolicy, Skips, fusion_grid};
use fusion_nostd::sequence::SequenceParams;
use fusion_nostd::thermal::ColumnParams;
use fusion_reference as reference;
use fusion_reference::study_methods::{HostMethod, cast_u8, drif, fuse_host_u8};
use fusion_reference::to_f64;
use std::path::Path;
use std::sync::Mutex;

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
    let roi_is = if s.taken.contains(Skips::CROP) {
        "the method on the computed window as a frame of its own (crop semantics)"
    } else {
        "bit-identical to --skip none"
    };
    format!(
        "skip: policy {:?}, illumination {}, taken {:#x}{}\n\
         skip: roi ({roi_is}) {}\n\
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

/// The core AGC parameters the options ask for, for a frame of `pixels`: `--agc` (linear
/// unless `--plateau` is given, which asks for plateau equalisation), `--plateau`,
/// `--agc-smoothing`.
pub fn agc_params(args: &FuseArgs, pixels: usize) -> fusion_nostd::AgcParams {
    args.thermal_agc.params(args.agc_smoothing.unwrap_or(0), pixels)
}

/// The thermal front end the options ask for (`--nuc`, `--bad-pixels`, `--shutter`,
/// `--column-filter`), the shutter applied; `None` when no stage is asked for.
pub fn thermal_chain(args: &FuseArgs) -> Result<Option<ThermalChain>> {
    if args.nuc.is_none() && args.bad_pixels.is_none() && args.column_filter.is_none() {
        return Ok(None);
    }
    let (nuc, bad) = fusion_engine::thermal::load(args.nuc.as_deref(), args.bad_pixels.as_deref())?;
    let radius = fusion_engine::thermal::COLUMN_RADIUS;
    let column = args.column_filter.map(|c| match c {
        ColumnArg::Counts(threshold) => Column::Params(ColumnParams { threshold, radius, smoothing: 0 }),
        ColumnArg::Auto => Column::Auto { radius, smoothing: 0 },
    });
    let mut chain = ThermalChain::new(nuc, bad, column)?;
    if let Some(path) = &args.shutter {
        let frame = match fusion_io::load_picture(path).context("shutter frame")? {
            Picture::Gray16(g) => g,
            _ => bail!("shutter frame: {} is not 14/16-bit raw counts", path.display()),
        };
        chain.shutter(&frame).with_context(|| format!("shutter frame {}", path.display()))?;
    }
    Ok(Some(chain))
}

/// One thermal frame's counts through the front end (`chain`) and the core AGC, with `agc`'s
/// state (smoothing).
pub fn agc_map(
    args: &FuseArgs,
    agc: &mut fusion_nostd::Agc,
    chain: Option<&mut ThermalChain>,
    counts: &Gray<u16>,
    path: &Path,
) -> Result<Gray<u8>> {
    let corrected;
    let counts = match chain {
        Some(c) => {
            corrected = c.correct(counts).with_context(|| format!("thermal image {}", path.display()))?;
            &corrected
        }
        None => counts,
    };
    fusion_engine::agc::map_counts(agc, counts, &agc_params(args, counts.width * counts.height))
        .with_context(|| format!("thermal image {}: AGC", path.display()))
}

/// Both inputs read and made ready for the grey fusion.
pub(super) struct Prepared {
    /// The visible frame's grey, or its luminance when the chroma is kept.
    vis: Gray<u8>,
    /// The visible frame's Cb and Cr when its colour is kept.
    chroma: Option<[Gray<u8>; 2]>,
    /// The thermal frame in 8 bits (through the AGC when it was 14/16-bit).
    tir: Gray<u8>,
}

/// Reads both inputs; `tir_mapped` is the thermal frame already through the AGC (a folder run
/// with `--agc-smoothing`).
pub(super) fn prepare(
    args: &FuseArgs,
    vis_path: &Path,
    tir_path: &Path,
    tir_mapped: Option<Gray<u8>>,
) -> Result<Prepared> {
    let vis_picture = fusion_io::load_picture(vis_path).context("visible image")?;
    let already_mapped = tir_mapped.is_some();
    let tir_picture = match tir_mapped {
        Some(g) => Picture::Gray8(g),
        None => fusion_io::load_picture(tir_path).context("thermal image")?,
    };
    let (vis, chroma) = match vis_picture {
        Picture::Gray8(g) => (g, None),
        Picture::Gray16(_) => bail!(
            "visible image: {} is 16-bit; give an 8-bit one (the AGC is for the thermal band)",
            vis_path.display()
        ),
        Picture::Rgb8(c) => match args.color.unwrap_or(ColorArg::Keep) {
            ColorArg::Keep => {
                let [y, cb, cr] = fusion_engine::color::rgb_to_ycbcr(&c);
                (y, Some([cb, cr]))
            }
            ColorArg::Gray => (c.to_gray(), None),
        },
    };
    if !already_mapped
        && !matches!(tir_picture, Picture::Gray16(_))
        && (args.nuc.is_some() || args.bad_pixels.is_some() || args.column_filter.is_some())
    {
        bail!(
            "thermal image: {} is 8-bit; --nuc, --bad-pixels and --column-filter correct raw 14/16-bit counts",
            tir_path.display()
        );
    }
    let tir = match tir_picture {
        Picture::Gray8(g) => {
            if args.thermal_agc.given() || args.agc_smoothing.is_some() {
                fusion_io::console::stderr_note_once(
                    "8-bit thermal with AGC options",
                    format_args!(
                        "fusion: note: {} is 8-bit: --agc, --plateau and --agc-smoothing apply to 14/16-bit counts and are not used{}",
                        tir_path.display(),
                        if args.tir.is_dir() { " (said once for the folder)" } else { "" }
                    ),
                );
            }
            g
        }
        Picture::Rgb8(c) => c.to_gray(),
        Picture::Gray16(counts) => {
            let mut chain = thermal_chain(args)?;
            agc_map(args, &mut fusion_engine::agc::fresh(), chain.as_mut(), &counts, tir_path)?
        }
    };
    let tir = match (&args.rig, args.range) {
        (Some(rig_path), Some(range)) => {
            let rig = fusion_io::rig::read(rig_path)?;
            if (vis.width, vis.height) != (rig.vis.width, rig.vis.height) {
                bail!(
                    "visible image: {} is {}x{}, the rig's visible camera {}x{}",
                    vis_path.display(),
                    vis.width,
                    vis.height,
                    rig.vis.width,
                    rig.vis.height
                );
            }
            fusion_engine::registration::register(
                &tir,
                &rig,
                range,
                fusion_nostd::registration::Interpolation::Linear,
                fusion_nostd::registration::Border::Constant(0),
            )
            .with_context(|| format!("thermal image {}", tir_path.display()))?
        }
        _ => tir,
    };
    Ok(Prepared { vis, chroma, tir })
}

/// What one grey fusion gives: the image, the pre-cast value, the guards and the text report
/// (strips, skip) to print.
pub(super) struct GrayResult {
    fused: Fused,
    report: String,
}

/// The core pipeline of the options (`None` for a host-only method).
pub(super) fn core_pipeline(args: &FuseArgs) -> Option<FuseConfig> {
    let method = args.method.split().ok()?;
    Some(FuseConfig {
        rescale: args.rescale.unwrap_or(RescaleArg::TirUp).into(),
        method: method_for(method, args.variant.unwrap_or(VariantArg::Flight)),
        skip: args.window.map_or(args.skip.into(), |w| SkipPolicy::Window(w.0)),
        ..Default::default()
    })
}

/// The sequence a `--sequence-mode` folder run fuses its pairs in (whole frame, or in strips
/// with `--strips`).
pub(super) fn sequence_fuser(args: &FuseArgs) -> Option<SequenceFuser> {
    let form = match args.strips {
        Some(StripRows(max_rows)) => Form::Strips { max_rows },
        None => Form::WholeFrame,
    };
    Some(SequenceFuser::new(core_pipeline(args)?, SequenceParams::default(), form))
}

/// Fuses one grey pair; in a `--sequence-mode` run (`seq`), as the sequence's next frame.
pub(super) fn fuse_gray(
    args: &FuseArgs,
    vis: &Gray<u8>,
    tir: &Gray<u8>,
    seq: Option<&Mutex<SequenceFuser>>,
) -> Result<GrayResult> {
    let rescale = args.rescale.unwrap_or(RescaleArg::TirUp);
    let fused = match (args.method.split(), core_pipeline(args)) {
        (Ok(_), Some(pipeline)) => {
            if let Some(seq) = seq {
                let mut seq = seq.lock().map_err(|_| anyhow::anyhow!("the sequence's state was lost"))?;
                let f = seq.fuse(vis, tir)?;
                let report = match f.strips {
                    Some(s) => strip_report_text(&s, f.report.grid),
                    None if pipeline.skip != SkipPolicy::None => skip_report_text(&f.report),
                    None => String::new(),
                } + &sequence_step_text(&f.step);
                let fused = Fused { image: f.image, raw: None, guards: f.report.guards };
                return Ok(GrayResult { fused, report });
            }
            let engine = args.engine.unwrap_or(EngineArg::Core);
            if let Some(StripRows(rows)) = args.strips {
                let mut scratch = fusion_engine::strips::HostStripScratch::default();
                let (image, report, strips, _) =
                    fusion_engine::strips::fuse_strips_once(vis, tir, &pipeline, rows, &mut scratch)?;
                let fused = Fused { image, raw: None, guards: report.guards };
                return Ok(GrayResult { fused, report: strip_report_text(&strips, report.grid) });
            }
            if pipeline.skip != SkipPolicy::None {
                let (image, report, _) = fusion_engine::skip::fuse_once(vis, tir, &pipeline)?;
                let fused = Fused { image, raw: None, guards: report.guards };
                return Ok(GrayResult { fused, report: skip_report_text(&report) });
            }
            match engine {
                EngineArg::Core => fuse_core(vis, tir, &pipeline, args.raw.is_some())?,
                EngineArg::Reference => fuse_reference(vis, tir, &pipeline)?,
            }
        }
        (Err(host), _) => fuse_host_method(vis, tir, host, rescale.into())?,
        (Ok(_), None) => bail!("no core pipeline for a core method"),
    };
    Ok(GrayResult { fused, report: String::new() })
}

/// One line on how a frame of a sequence was fused.
pub fn sequence_step_text(s: &fusion_nostd::sequence::SequenceStep) -> String {
    use fusion_nostd::sequence::Pass;
    let q30 = f64::from(1u32 << 30);
    match s.pass {
        Pass::Carried => format!(
            "sequence: carried weights (one pass): p_IR {:.6} (this frame's own {:.6})\n",
            s.p_ir_used_q30 as f64 / q30,
            s.p_ir_own_q30 as f64 / q30
        ),
        Pass::Own(r) => {
            format!("sequence: own weights ({r:?} restart): p_IR {:.6}\n", s.p_ir_own_q30 as f64 / q30)
        }
        Pass::PerFrame => "sequence: fused per frame (nothing carried)\n".to_string(),
    }
}

/// The memory estimate from the headers, before either frame is decoded. The fusion grid is
/// the larger frame's (tir-up, none) or the smaller one's (vis-down).
pub(super) fn check_memory(args: &FuseArgs, vis_path: &Path, tir_path: &Path) -> Result<()> {
    let rescale = args.rescale.unwrap_or(RescaleArg::TirUp);
    let (vw, vh, vc) = fusion_io::image_header(vis_path).context("visible image")?;
    let (tw, th, _) = fusion_io::image_header(tir_path).context("thermal image")?;
    let (vis_px, tir_px) = ((vw as u64).saturating_mul(vh as u64), (tw as u64).saturating_mul(th as u64));
    let grid = match rescale {
        RescaleArg::VisDown => vis_px.min(tir_px),
        _ => vis_px.max(tir_px),
    };
    let per_px = match (args.method.split(), args.engine.unwrap_or(EngineArg::Core)) {
        (Err(_), _) => fusion_io::memory::per_pixel::FUSE_HOST_METHOD,
        (Ok(_), EngineArg::Reference) => fusion_io::memory::per_pixel::FUSE_REFERENCE,
        (Ok(_), EngineArg::Core) => fusion_io::memory::per_pixel::FUSE_CORE,
    };
    // A colour frame kept in colour carries its two chroma planes and the RGB output too.
    let per_px = per_px + if vc == 3 { 6 } else { 0 };
    let (input, band) =
        if vis_px >= tir_px { (vis_path, "visible image") } else { (tir_path, "thermal image") };
    fusion_io::memory::check(
        &input.display().to_string(),
        "fusing this pair",
        fusion_io::memory::estimate(grid, per_px),
    )
    .context(band)
}

/// Fuses one pair of files into `output` (and `args.raw`); returns the text report to print
/// and the guards that fired.
pub(super) fn fuse_files(
    args: &FuseArgs,
    vis_path: &Path,
    tir_path: &Path,
    tir_mapped: Option<Gray<u8>>,
    output: &Path,
    seq: Option<&Mutex<SequenceFuser>>,
) -> Result<(String, Guards)> {
    let format = OutFormat::of(output)?;
    check_memory(args, vis_path, tir_path)?;
    let input = prepare(args, vis_path, tir_path, tir_mapped)?;
    let GrayResult { fused, report } = fuse_gray(args, &input.vis, &input.tir, seq)?;
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
        Some([cb, cr]) => fusion_engine::color::fused_in_colour(&fused.image, cb, cr)?,
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

/// Fuses one pair of a folder run (no report printed; `tir_mapped`: the thermal frame already
/// through the AGC); says which guards fired, if any.
pub fn fuse_pair_quietly(
    args: &FuseArgs,
    vis: &Path,
    tir: &Path,
    tir_mapped: Option<Gray<u8>>,
    output: &Path,
    seq: Option<&Mutex<SequenceFuser>>,
) -> Result<String> {
    let (report, guards) = fuse_files(args, vis, tir, tir_mapped, output, seq)?;
    // In a sequence, how the frame was fused (its report's last line).
    let step =
        report.lines().rfind(|l| l.starts_with("sequence: ")).map(|l| l.trim_start_matches("sequence: "));
    let guards = (guards != Guards::NONE).then(|| format!("guards: {guards}"));
    Ok([step.map(str::to_string), guards].into_iter().flatten().collect::<Vec<_>>().join("; "))
}
