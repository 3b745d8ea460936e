//! Configuration, work memory and the two fusion entry points.

use crate::image::{FusionImage, FusionImageMut, Span, deref, disjoint};
use crate::status::{FusionError, FusionStatus, run};
use fusion_nostd::pipeline::{
    FuseConfig, FuseReport, Method, RescalePolicy, SkipPolicy, fuse_in_sequence, fusion_grid,
};
use fusion_nostd::scene::{Decline, Illumination, Rect};
use fusion_nostd::sequence::Sequence;
use fusion_nostd::strips::{StripReport, StripScratchMut, fuse_strips_in_sequence};
use fusion_nostd::{ScratchMut, Variant};

/// The size of the strip working set the budgets measure (512 KiB: 256 KiB of work words, 256
/// KiB of band rows). [`fusion_fuse_strips`] takes any size it can fit one strip into.
pub const FUSION_STRIP_SCRATCH_BYTES: usize = 512 * 1024;

/// The fusion methods (values of [`FusionConfig::method`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FusionMethod {
    /// Anisotropic diffusion + Karhunen–Loève fusion.
    Adf = 0,
    /// Two-scale image fusion with saliency detection (default).
    Tsifsd = 1,
    /// Infrared feature extraction + visual information preservation.
    Ifevip = 2,
    /// Illumination-adaptive fusion for navigation: ADF on a large target, else the two-scale
    /// blend or the TIR frame (no variants).
    Adaptive = 3,
}

/// Method variants (values of [`FusionConfig::variant`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FusionVariant {
    /// The study's changes, every unguarded case guarded (default).
    Flight = 0,
    /// The published implementation step for step.
    Classic = 1,
}

/// How the bands are brought onto one grid (values of [`FusionConfig::rescale`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FusionRescale {
    /// Bicubic upscale of TIR onto the VIS grid (default).
    TirUp = 0,
    /// Area downscale of VIS onto the TIR grid.
    VisDown = 1,
    /// No rescale: the two frames have the same size.
    None = 2,
}

/// Scene skipping (values of [`FusionConfig::skip`]; whole-frame [`fusion_fuse`] only).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FusionSkip {
    /// Fuse every pixel (default).
    None = 0,
    /// Fuse a window around the target, write the background elsewhere; the window's pixels
    /// are bit-identical to `FUSION_SKIP_NONE`.
    Roi = 1,
    /// `FUSION_SKIP_ROI` plus the eclipse plan.
    All = 2,
    /// Fuse only the caller's box [`FusionConfig::window`] (e.g. a navigation filter's
    /// predicted target box), whatever the analysis found: TSIFSD and the adaptive method are
    /// bit-identical to `FUSION_SKIP_NONE` inside it, ADF and IFEVIP fuse the crop as a frame
    /// of its own (crop semantics, see the core's `pipeline` docs; so does an adaptive frame
    /// with a large target, which is ADF's); the background elsewhere.
    Window = 3,
}

/// A per-frame configuration: plain numbers (the enums above), each method with its default
/// parameters. Start from [`fusion_config_default`].
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FusionConfig {
    /// A `FusionMethod` value.
    pub method: u32,
    /// A `FusionVariant` value (ignored by `FUSION_METHOD_ADAPTIVE`).
    pub variant: u32,
    /// A `FusionRescale` value.
    pub rescale: u32,
    /// A `FusionSkip` value.
    pub skip: u32,
    /// The caller's box for `FUSION_SKIP_WINDOW`, grid pixels `[x0, x1) × [y0, y1)` as
    /// `{x0, y0, x1, y1}` (clipped to the grid; ignored by the other skip values).
    pub window: [usize; 4],
}

/// What one fusion did.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FusionReport {
    /// Width of the fusion grid (= the output).
    pub grid_width: usize,
    /// Height of the fusion grid.
    pub grid_height: usize,
    /// 1 when a band was rescaled, else 0.
    pub rescaled: u32,
    /// `FUSION_GUARD_*` bits the method fired.
    pub guards: u32,
    /// What the scene skipping took (`fusion_nostd::pipeline::Skips` bits: 1 ROI, 2 ROI
    /// rescale, 4 eclipse VIS, 8 eclipse TIR target, 16 no rescale, 32 crop semantics); 0 when
    /// nothing.
    pub skip_taken: u32,
    /// Why skipping declined: 0 it did not (or was not asked), 1 background not dark, 2 too
    /// noisy, 3 window too large, 4 frame-global statistic.
    pub skip_declined: u32,
    /// The analysed VIS illumination: 0 not analysed, 1 light, 2 eclipse, 3 saturated.
    pub illumination: u32,
    /// The background level written outside the window, or −1 when the whole frame was fused.
    pub background: i32,
    /// The window the method ran on, grid pixels `[x0, x1) × [y0, y1)` (the whole grid when
    /// nothing was skipped).
    pub window: [usize; 4],
    /// Strips per pass ([`fusion_fuse_strips`]; 0 for a whole-frame call).
    pub strips: usize,
    /// Output rows per strip (0 for a whole-frame call).
    pub strip_rows: usize,
    /// Bytes of the strip working set in use (0 for a whole-frame call).
    pub working_set_bytes: usize,
}

/// TSIFSD flight, TIR upscaled onto the VIS grid, no skipping.
#[unsafe(no_mangle)]
pub extern "C" fn fusion_config_default() -> FusionConfig {
    FusionConfig {
        method: FusionMethod::Tsifsd as u32,
        variant: FusionVariant::Flight as u32,
        rescale: FusionRescale::TirUp as u32,
        skip: FusionSkip::None as u32,
        window: [0; 4],
    }
}

impl FusionConfig {
    /// The core configuration, or `InvalidParameter` naming the field that holds no value.
    fn pipeline(&self) -> Result<FuseConfig, FusionError> {
        let variant = match self.variant {
            v if v == FusionVariant::Flight as u32 => Variant::Flight,
            v if v == FusionVariant::Classic as u32 => Variant::Classic,
            _ => return Err(FusionError::invalid("variant")),
        };
        // `FusionMethod` numbers the core's `Method::KINDS`.
        let method = Method::KINDS
            .get(self.method as usize)
            .and_then(|kind| Method::named(kind, variant))
            .ok_or(FusionError::invalid("method"))?;
        let rescale = match self.rescale {
            r if r == FusionRescale::TirUp as u32 => RescalePolicy::TirUp,
            r if r == FusionRescale::VisDown as u32 => RescalePolicy::VisDown,
            r if r == FusionRescale::None as u32 => RescalePolicy::None,
            _ => return Err(FusionError::invalid("rescale")),
        };
        let skip = match self.skip {
            s if s == FusionSkip::None as u32 => SkipPolicy::None,
            s if s == FusionSkip::Roi as u32 => SkipPolicy::Roi,
            s if s == FusionSkip::All as u32 => SkipPolicy::All,
            s if s == FusionSkip::Window as u32 => {
                let [x0, y0, x1, y1] = self.window;
                SkipPolicy::Window(Rect { x0, y0, x1, y1 })
            }
            _ => return Err(FusionError::invalid("skip")),
        };
        Ok(FuseConfig { rescale, method, skip, ..FuseConfig::default() })
    }
}

/// Writes `value` through a caller's out-pointer (NULL → `NullPointer`).
pub(crate) fn put<T>(out: *mut T, value: T) -> Result<(), FusionError> {
    // SAFETY: the caller passes NULL or a pointer to a writable `T` (header contract).
    let slot = unsafe { out.as_mut() }.ok_or(FusionError::of(FusionStatus::NullPointer))?;
    *slot = value;
    Ok(())
}

/// The width and height of the fused frame for a `vis` and a `tir` frame under `config`'s
/// rescale policy (the VIS size for tir-up, the TIR size for vis-down).
///
/// # Safety
/// `config` points to a valid configuration; `width`, `height` are writable; `error` is NULL or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_output_size(
    config: *const FusionConfig,
    vis_width: usize,
    vis_height: usize,
    tir_width: usize,
    tir_height: usize,
    width: *mut usize,
    height: *mut usize,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let pipeline = deref(config)?.pipeline()?;
        // The same size checks as the scratch query (zero, oversized sides).
        pipeline
            .scratch_pixels((vis_width, vis_height), (tir_width, tir_height))
            .map_err(FusionError::from_core)?;
        let (w, h) = fusion_grid((vis_width, vis_height), (tir_width, tir_height), pipeline.rescale)
            .map_err(FusionError::from_core)?;
        put(width, w)?;
        put(height, h)
    })
}

/// Bytes of scratch [`fusion_fuse`] needs for a pair of these sizes under `config`: three
/// `int32` work planes and one byte plane of the grid's pixels (13 bytes per grid pixel; IFEVIP
/// on small frames a little more). The scratch must be 4-byte aligned; its contents do not
/// matter and are not preserved.
///
/// # Safety
/// `config` points to a valid configuration; `bytes` is writable; `error` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_scratch_bytes(
    config: *const FusionConfig,
    vis_width: usize,
    vis_height: usize,
    tir_width: usize,
    tir_height: usize,
    bytes: *mut usize,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let pipeline = deref(config)?.pipeline()?;
        let pixels = pipeline
            .scratch_pixels((vis_width, vis_height), (tir_width, tir_height))
            .map_err(FusionError::from_core)?;
        put(bytes, scratch_bytes_for(pixels)?)
    })
}

/// Bytes per pixel of the whole-frame scratch: three `i32` planes and the `u8` band plane.
const SCRATCH_BYTES_PER_PIXEL: usize = fusion_nostd::SCRATCH_PLANES * 4 + 1;

fn scratch_bytes_for(pixels: usize) -> Result<usize, FusionError> {
    pixels
        .checked_mul(SCRATCH_BYTES_PER_PIXEL)
        .ok_or(FusionError::from_core(fusion_nostd::Error::DimensionTooLarge { value: pixels }))
}

/// A caller's 4-byte-aligned buffer of `bytes`, checked.
fn aligned(ptr: *mut core::ffi::c_void, bytes: usize) -> Result<Span, FusionError> {
    if ptr.is_null() {
        return Err(FusionError::of(FusionStatus::NullPointer));
    }
    if !(ptr as usize).is_multiple_of(4) {
        return Err(FusionError::of(FusionStatus::Misaligned));
    }
    Ok(Span::of(ptr.cast::<u8>(), bytes))
}

/// Splits a caller's aligned buffer into `words` `i32`s and `rest` bytes after them.
///
/// # Safety
/// `ptr` is 4-byte aligned and points to `words·4 + rest` writable bytes that nothing else
/// accesses during the call.
unsafe fn carve<'a>(ptr: *mut core::ffi::c_void, words: usize, rest: usize) -> (&'a mut [i32], &'a mut [u8]) {
    // SAFETY: per this function's contract; the two slices do not overlap.
    unsafe {
        let w = core::slice::from_raw_parts_mut(ptr.cast::<i32>(), words);
        let b = core::slice::from_raw_parts_mut(ptr.cast::<u8>().add(words * 4), rest);
        (w, b)
    }
}

fn report_of(r: &FuseReport, strips: Option<&StripReport>) -> FusionReport {
    let s = &r.skip;
    FusionReport {
        grid_width: r.grid.0,
        grid_height: r.grid.1,
        rescaled: u32::from(r.rescaled),
        guards: r.guards.0,
        skip_taken: s.taken.0,
        skip_declined: match s.declined {
            None => 0,
            Some(Decline::BackgroundNotDark) => 1,
            Some(Decline::TooNoisy) => 2,
            Some(Decline::RoiTooLarge) => 3,
            Some(Decline::GlobalStatistic) => 4,
        },
        illumination: match s.illumination {
            None => 0,
            Some(Illumination::Light) => 1,
            Some(Illumination::Eclipse) => 2,
            Some(Illumination::Saturated) => 3,
        },
        background: s.background.map_or(-1, i32::from),
        window: [s.computed.x0, s.computed.y0, s.computed.x1, s.computed.y1],
        strips: strips.map_or(0, |t| t.strips),
        strip_rows: strips.map_or(0, |t| t.strip_rows),
        working_set_bytes: strips.map_or(0, |t| t.working_set_bytes()),
    }
}

/// Fuses one VIS/TIR pair into `out` with `config`: rescale one band onto the other's grid,
/// skip what the scene allows (`config->skip`), fuse. `out` must have the fusion grid's size
/// ([`fusion_output_size`]); `scratch` holds at least [`fusion_scratch_bytes`] bytes, 4-byte
/// aligned. `report` (may be NULL) receives what the call did.
///
/// The same bytes as `fusion fuse` (the CLI) and every flight target.
///
/// # Safety
/// Every pointer is NULL (refused, except `report` and `error`, which are optional) or valid
/// for its documented use; `out`, `scratch`, `report` and `error` are not read or written by
/// anything else during the call.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_fuse(
    config: *const FusionConfig,
    vis: *const FusionImage,
    tir: *const FusionImage,
    out: *const FusionImageMut,
    scratch: *mut core::ffi::c_void,
    scratch_bytes: usize,
    report: *mut FusionReport,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || whole(config, vis, tir, out, scratch, scratch_bytes, report, None))
}

/// [`fusion_fuse`]'s work, in a sequence when `seq` is given (the state and its bytes, which
/// must not overlap the output or the scratch).
#[allow(clippy::too_many_arguments)]
pub(crate) fn whole(
    config: *const FusionConfig,
    vis: *const FusionImage,
    tir: *const FusionImage,
    out: *const FusionImageMut,
    scratch: *mut core::ffi::c_void,
    scratch_bytes: usize,
    report: *mut FusionReport,
    seq: Option<(&mut Sequence, Span)>,
) -> Result<(), FusionError> {
    {
        let pipeline = deref(config)?.pipeline()?;
        let (vis, vis_span) = deref(vis)?.view()?;
        let (tir, tir_span) = deref(tir)?.view()?;
        let out = deref(out)?;
        let pixels = pipeline.scratch_pixels(vis.size(), tir.size()).map_err(FusionError::from_core)?;
        let needed = scratch_bytes_for(pixels)?;
        let scratch_span = aligned(scratch, scratch_bytes)?;
        if scratch_bytes < needed {
            return Err(FusionError {
                values: [needed, scratch_bytes, 0, 0],
                ..FusionError::of(FusionStatus::ScratchTooSmall)
            });
        }
        disjoint(out.span()?, &[vis_span, tir_span, scratch_span])?;
        disjoint(scratch_span, &[vis_span, tir_span])?;
        if let Some((_, state_span)) = &seq {
            disjoint(*state_span, &[vis_span, tir_span, scratch_span, out.span()?])?;
        }
        // SAFETY: `scratch` is aligned, at least `needed` bytes, and overlaps nothing else here.
        let (words, band) = unsafe { carve(scratch, 3 * pixels, pixels) };
        let (a, rest) = words.split_at_mut(pixels);
        let (b, c) = rest.split_at_mut(pixels);
        let mut planes = ScratchMut::with_band([a, b, c], band);
        let r = match seq {
            None => fusion_nostd::fuse(vis, tir, out.view_mut()?, &mut planes, &pipeline),
            Some((seq, _)) => fuse_in_sequence(vis, tir, out.view_mut()?, &mut planes, &pipeline, seq),
        }
        .map_err(FusionError::from_core)?;
        if !report.is_null() {
            put(report, report_of(&r, None))?;
        }
        Ok(())
    }
}

/// [`fusion_fuse`] strip by strip in a fixed working set: the same bytes and guards. The
/// scratch (4-byte aligned) is split in half: work words, then band rows;
/// [`FUSION_STRIP_SCRATCH_BYTES`] (512 KiB) is the size the flight budgets measure. `max_rows`
/// caps the strip height (`SIZE_MAX`: as tall as the scratch allows).
///
/// Strips run without scene skipping (`config->skip` must be `FUSION_SKIP_NONE`) and need an
/// exact 2× rescale (or none): `FUSION_STATUS_UNSUPPORTED_RATIO` otherwise. Nothing is written to
/// `out` before every check passed.
///
/// # Safety
/// As [`fusion_fuse`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_fuse_strips(
    config: *const FusionConfig,
    vis: *const FusionImage,
    tir: *const FusionImage,
    out: *const FusionImageMut,
    scratch: *mut core::ffi::c_void,
    scratch_bytes: usize,
    max_rows: usize,
    report: *mut FusionReport,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || strips(config, vis, tir, out, scratch, scratch_bytes, max_rows, report, None))
}

/// [`fusion_fuse_strips`]'s work, in a sequence when `seq` is given (as [`whole`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn strips(
    config: *const FusionConfig,
    vis: *const FusionImage,
    tir: *const FusionImage,
    out: *const FusionImageMut,
    scratch: *mut core::ffi::c_void,
    scratch_bytes: usize,
    max_rows: usize,
    report: *mut FusionReport,
    seq: Option<(&mut Sequence, Span)>,
) -> Result<(), FusionError> {
    let pipeline = deref(config)?.pipeline()?;
    let (vis, vis_span) = deref(vis)?.view()?;
    let (tir, tir_span) = deref(tir)?.view()?;
    let out = deref(out)?;
    let scratch_span = aligned(scratch, scratch_bytes)?;
    disjoint(out.span()?, &[vis_span, tir_span, scratch_span])?;
    disjoint(scratch_span, &[vis_span, tir_span])?;
    if let Some((_, state_span)) = &seq {
        disjoint(*state_span, &[vis_span, tir_span, scratch_span, out.span()?])?;
    }
    let words = scratch_bytes / 2 / 4;
    // SAFETY: `scratch` is aligned, `scratch_bytes` long and overlaps nothing else here.
    let (work, band) = unsafe { carve(scratch, words, scratch_bytes - words * 4) };
    let mut scratch = StripScratchMut::from_slices(work, band);
    let out = out.view_mut()?;
    let (r, s) = match seq {
        None => fusion_nostd::strips::fuse_strips(vis, tir, out, &mut scratch, &pipeline, max_rows),
        Some((seq, _)) => fuse_strips_in_sequence(vis, tir, out, &mut scratch, &pipeline, max_rows, seq),
    }
    .map_err(FusionError::from_core)?;
    if !report.is_null() {
        put(report, report_of(&r, Some(&s)))?;
    }
    Ok(())
}
