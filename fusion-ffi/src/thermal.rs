//! The thermal front end: raw focal-plane counts corrected before the AGC
//! (`fusion_nostd::thermal`): two-point NUC, the shutter's offset update, bad-pixel replacement,
//! the column-noise filter.

use crate::image::{FusionImage16, FusionImageMut16, Span, deref, disjoint};
use crate::status::{FusionError, FusionStatus, run};
use fusion_nostd::thermal::{
    BadPixelMap, ColumnFilter, ColumnParams, Correction, NucTables, bad_map_bytes, column_filter_frame,
    correct_frame, shutter_update,
};

/// One camera's calibration (`fusion_nostd::thermal`): per pixel a Q2.14 gain and an offset in
/// counts (row-major, `width·height` each; both NULL: no correction), and the one-bit bad-pixel
/// map (`⌈width/8⌉` bytes a row, pixel x in bit x mod 8 of byte x/8, 1 = bad; NULL: none).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FusionThermalTables {
    /// Array width, px.
    pub width: usize,
    /// Array height, px.
    pub height: usize,
    /// Gains, Q2.14 (16384 = 1), or NULL.
    pub gain: *const u16,
    /// Offsets, counts, or NULL (with `gain`).
    pub offset: *const i16,
    /// The bad-pixel map, or NULL.
    pub bad_pixels: *const u8,
}

/// Column filter parameters (`fusion_nostd::thermal::ColumnParams`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FusionColumnParams {
    /// Threshold of the horizontal differences that count, counts (1..=32767): a few times the
    /// temporal noise of a difference.
    pub threshold: u16,
    /// Radius of the profile's low-pass, columns (≥ 1; 16 suits a 512-row array).
    pub radius: u16,
    /// Temporal smoothing shift k (0: each frame's own estimate, ≤ 8).
    pub smoothing: u8,
}

/// The tables' and map's core views and the memory they span.
fn stages<'a>(t: &FusionThermalTables) -> Result<(Correction<'a>, [Span; 3]), FusionError> {
    let n = crate::image::extent(t.width, t.height, t.width)?;
    let mut spans = [
        Span::of(core::ptr::null::<u8>(), 0),
        Span::of(core::ptr::null::<u8>(), 0),
        Span::of(core::ptr::null::<u8>(), 0),
    ];
    let nuc = match (t.gain.is_null(), t.offset.is_null()) {
        (true, true) => None,
        (false, false) => {
            if !(t.gain as usize).is_multiple_of(2) || !(t.offset as usize).is_multiple_of(2) {
                return Err(FusionError::of(FusionStatus::Misaligned));
            }
            // SAFETY: the caller's contract: `width·height` readable, aligned elements each.
            let (g, o) =
                unsafe { (core::slice::from_raw_parts(t.gain, n), core::slice::from_raw_parts(t.offset, n)) };
            spans[0] = Span::of(t.gain, n);
            spans[1] = Span::of(t.offset, n);
            Some(NucTables::new(t.width, t.height, g, o).map_err(FusionError::from_core)?)
        }
        _ => return Err(FusionError::invalid("gain and offset: both or none")),
    };
    let bad = if t.bad_pixels.is_null() {
        None
    } else {
        let len = bad_map_bytes(t.width, t.height);
        // SAFETY: the caller's contract: `bad_map_bytes` readable bytes.
        let bits = unsafe { core::slice::from_raw_parts(t.bad_pixels, len) };
        spans[2] = Span::of(t.bad_pixels, len);
        Some(BadPixelMap::new(t.width, t.height, bits).map_err(FusionError::from_core)?)
    };
    Ok((Correction { nuc, bad }, spans))
}

/// Corrects one frame of raw counts: the NUC tables (if given), then the bad pixels (if given)
/// into `output` (the input's size, the tables' size). Nothing is written on an error.
///
/// # Safety
/// `tables`' pointers are NULL or point to `width·height` readable elements (the map:
/// `⌈width/8⌉·height` bytes); the images' pointers are valid for their documented use; `error`
/// is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_thermal_correct(
    tables: *const FusionThermalTables,
    input: *const FusionImage16,
    output: *const FusionImageMut16,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let (stages, spans) = stages(deref(tables)?)?;
        let (input, in_span) = deref(input)?.view()?;
        let output = deref(output)?;
        let [g, o, b] = spans;
        disjoint(output.span()?, &[in_span, g, o, b])?;
        stages.check_size(input.width(), input.height()).map_err(FusionError::from_core)?;
        correct_frame(&stages, None, input, output.view_mut()?).map_err(FusionError::from_core)?;
        Ok(())
    })
}

/// Re-levels the offsets from a shutter frame (the raw counts of a flat field): the corrected
/// shutter frame becomes flat at its mean over the valid pixels. `tables` gives the gains, the
/// map (optional) and the size; `offset` (its `width·height` offsets, updated in place) must be
/// the table's own offsets or a copy. Nothing is written on an error.
///
/// # Safety
/// As [`fusion_thermal_correct`]; `offset` points to `width·height` writable `int16_t`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_thermal_shutter(
    tables: *const FusionThermalTables,
    offset: *mut i16,
    shutter: *const FusionImage16,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let t = deref(tables)?;
        if t.gain.is_null() || offset.is_null() {
            return Err(FusionError::of(FusionStatus::NullPointer));
        }
        if !(offset as usize).is_multiple_of(2) || !(t.gain as usize).is_multiple_of(2) {
            return Err(FusionError::of(FusionStatus::Misaligned));
        }
        let n = crate::image::extent(t.width, t.height, t.width)?;
        let (shutter, sh_span) = deref(shutter)?.view()?;
        if shutter.size() != (t.width, t.height) {
            return Err(FusionError::from_core(fusion_nostd::Error::SizeMismatch {
                expected: (t.width, t.height),
                got: shutter.size(),
            }));
        }
        let bad_len = bad_map_bytes(t.width, t.height);
        let bad_span =
            if t.bad_pixels.is_null() { Span::of(t.bad_pixels, 0) } else { Span::of(t.bad_pixels, bad_len) };
        disjoint(Span::of(offset.cast_const(), n), &[sh_span, Span::of(t.gain, n), bad_span])?;
        // SAFETY: the caller's contract (`width·height` elements each); the offsets are disjoint
        // from everything else read here (checked).
        let (gain, offset) =
            unsafe { (core::slice::from_raw_parts(t.gain, n), core::slice::from_raw_parts_mut(offset, n)) };
        let bad = if t.bad_pixels.is_null() {
            None
        } else {
            // SAFETY: the caller's contract: `bad_map_bytes` readable bytes.
            let bits = unsafe { core::slice::from_raw_parts(t.bad_pixels, bad_len) };
            Some(BadPixelMap::new(t.width, t.height, bits).map_err(FusionError::from_core)?)
        };
        shutter_update(gain, offset, bad.as_ref(), shutter).map_err(FusionError::from_core)?;
        Ok(())
    })
}

/// Bytes of one column filter state (about 28 KiB); one per camera (it carries the smoothed
/// estimate from frame to frame).
#[unsafe(no_mangle)]
pub extern "C" fn fusion_column_state_bytes() -> usize {
    core::mem::size_of::<ColumnFilter>()
}

/// Makes `state` a fresh column filter state (zero-fills it). `state` must be aligned to 8 bytes.
///
/// # Safety
/// `state` is NULL or points to `bytes` writable bytes; `error` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_column_init(
    state: *mut core::ffi::c_void,
    bytes: usize,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        check_state(state, bytes)?;
        // SAFETY: `size_of::<ColumnFilter>()` writable bytes (checked above).
        unsafe { core::ptr::write_bytes(state.cast::<u8>(), 0, core::mem::size_of::<ColumnFilter>()) };
        Ok(())
    })
}

fn check_state(state: *mut core::ffi::c_void, bytes: usize) -> Result<(), FusionError> {
    if state.is_null() {
        return Err(FusionError::of(FusionStatus::NullPointer));
    }
    if !(state as usize).is_multiple_of(core::mem::align_of::<ColumnFilter>()) {
        return Err(FusionError::of(FusionStatus::Misaligned));
    }
    let needed = core::mem::size_of::<ColumnFilter>();
    if bytes < needed {
        return Err(FusionError {
            values: [needed, bytes, 0, 0],
            ..FusionError::of(FusionStatus::ScratchTooSmall)
        });
    }
    Ok(())
}

/// The column filter on one corrected frame, in place, with the frame's own estimate (smoothed
/// with the state's previous one when `params.smoothing > 0`).
///
/// # Safety
/// `state` was initialised by [`fusion_column_init`] and is used by one call at a time; `frame`
/// is valid for reading and writing; `error` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_column_frame(
    state: *mut core::ffi::c_void,
    state_bytes: usize,
    params: *const FusionColumnParams,
    frame: *const FusionImageMut16,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let p = deref(params)?;
        let params = ColumnParams { threshold: p.threshold, radius: p.radius, smoothing: p.smoothing };
        params.validate().map_err(FusionError::from_core)?;
        check_state(state, state_bytes)?;
        let frame = deref(frame)?;
        disjoint(
            frame.span()?,
            &[Span::of(state.cast_const().cast::<u8>(), core::mem::size_of::<ColumnFilter>())],
        )?;
        // SAFETY: aligned, long enough (checked), initialised by `fusion_column_init` (all zero)
        // or by the core: every field is an integer array, an integer or a bool.
        let filter = unsafe { &mut *state.cast::<ColumnFilter>() };
        column_filter_frame(filter, frame.view_mut()?, &params).map_err(FusionError::from_core)?;
        Ok(())
    })
}
