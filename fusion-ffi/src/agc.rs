//! Thermal AGC: 14/16-bit counts to the 8 bits the fusion takes.

use crate::image::{FusionImage16, FusionImageMut, Span, deref, disjoint};
use crate::status::{FusionError, FusionStatus, run};
use fusion_nostd::{Agc, AgcMode, AgcParams};

/// AGC parameters (`fusion_nostd::AgcParams`). Start from [`fusion_agc_linear`] or
/// [`fusion_agc_plateau`].
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FusionAgcParams {
    /// 0: plateau histogram equalisation; 1: linear stretch between two percentiles.
    pub mode: u32,
    /// Plateau: the most pixels a bin counts with (≥ 1).
    pub plateau_limit: u32,
    /// Linear: lower percentile, in 1/10 000 of the pixels.
    pub linear_low: u16,
    /// Linear: upper percentile, in 1/10 000 (`linear_low < linear_high ≤ 10000`).
    pub linear_high: u16,
    /// Output level of the coldest counts.
    pub out_low: u8,
    /// Output level of the hottest counts (`> out_low`).
    pub out_high: u8,
    /// Temporal smoothing shift k (0 none, ≤ 8): the mapping moves 1/2^k of the way to each new
    /// frame's.
    pub smoothing: u8,
}

/// What one AGC frame found (telemetry).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FusionAgcReport {
    /// Pixels in the histogram.
    pub pixels: u32,
    /// Plateau: first occupied bin; linear: the lower percentile's bin (bins of 4 counts).
    pub bin_low: u16,
    /// Plateau: last occupied bin; linear: the upper percentile's bin.
    pub bin_high: u16,
    /// Bins the plateau clipped (0 for linear).
    pub clipped_bins: u32,
}

impl From<AgcParams> for FusionAgcParams {
    fn from(p: AgcParams) -> Self {
        let (mode, plateau_limit, linear_low, linear_high) = match p.mode {
            AgcMode::Plateau { limit } => (0, limit, 0, 0),
            AgcMode::Linear { low, high } => (1, 0, low, high),
        };
        FusionAgcParams {
            mode,
            plateau_limit,
            linear_low,
            linear_high,
            out_low: p.out_low,
            out_high: p.out_high,
            smoothing: p.smoothing,
        }
    }
}

impl FusionAgcParams {
    pub(crate) fn core(&self) -> Result<AgcParams, FusionError> {
        let mode = match self.mode {
            0 => AgcMode::Plateau { limit: self.plateau_limit },
            1 => AgcMode::Linear { low: self.linear_low, high: self.linear_high },
            _ => return Err(FusionError::invalid("agc mode")),
        };
        let p = AgcParams { mode, out_low: self.out_low, out_high: self.out_high, smoothing: self.smoothing };
        p.validate().map_err(FusionError::from_core)?;
        Ok(p)
    }
}

/// The default linear stretch: 1 % to 99.9 % onto 0..255, no smoothing (the fusion CLI's
/// default).
#[unsafe(no_mangle)]
pub extern "C" fn fusion_agc_linear() -> FusionAgcParams {
    AgcParams::linear().into()
}

/// Plateau equalisation for a frame of `pixels` (plateau `max(1, pixels / 2^18)`), onto
/// 0..255, no smoothing.
#[unsafe(no_mangle)]
pub extern "C" fn fusion_agc_plateau(pixels: usize) -> FusionAgcParams {
    AgcParams::plateau(pixels).into()
}

/// Bytes of one AGC state (its histogram, mapping and table; about 112 KiB). One state per
/// thermal camera: it carries the previous frame's mapping for the temporal smoothing.
#[unsafe(no_mangle)]
pub extern "C" fn fusion_agc_state_bytes() -> usize {
    core::mem::size_of::<Agc>()
}

/// The state in a caller's buffer, checked (non-NULL, aligned, long enough).
fn state<'a>(state: *mut core::ffi::c_void, bytes: usize) -> Result<(&'a mut Agc, Span), FusionError> {
    if state.is_null() {
        return Err(FusionError::of(FusionStatus::NullPointer));
    }
    if !(state as usize).is_multiple_of(core::mem::align_of::<Agc>()) {
        return Err(FusionError::of(FusionStatus::Misaligned));
    }
    let needed = core::mem::size_of::<Agc>();
    if bytes < needed {
        return Err(FusionError {
            values: [needed, bytes, 0, 0],
            ..FusionError::of(FusionStatus::ScratchTooSmall)
        });
    }
    // SAFETY: aligned, long enough, owned by the caller for the call; every field of `Agc` is an
    // integer or a bool, for which the bytes `fusion_agc_init` wrote (all zero) and every later
    // state the core wrote are valid values.
    Ok((unsafe { &mut *state.cast::<Agc>() }, Span::of(state.cast::<u8>(), needed)))
}

/// Makes `state` a fresh AGC state (no previous frame): zero-fills its
/// [`fusion_agc_state_bytes`] bytes. `state` must be aligned to 4 bytes.
///
/// # Safety
/// `state` is NULL or points to `bytes` writable bytes; `error` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_agc_init(
    state_ptr: *mut core::ffi::c_void,
    bytes: usize,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        // Checked before the write; `state` is not used as an `Agc` until it is all zero.
        if state_ptr.is_null() {
            return Err(FusionError::of(FusionStatus::NullPointer));
        }
        let needed = core::mem::size_of::<Agc>();
        if bytes < needed {
            return Err(FusionError {
                values: [needed, bytes, 0, 0],
                ..FusionError::of(FusionStatus::ScratchTooSmall)
            });
        }
        if !(state_ptr as usize).is_multiple_of(core::mem::align_of::<Agc>()) {
            return Err(FusionError::of(FusionStatus::Misaligned));
        }
        // SAFETY: `needed` writable bytes (checked above, caller's contract).
        unsafe { core::ptr::write_bytes(state_ptr.cast::<u8>(), 0, needed) };
        Ok(())
    })
}

/// Maps one thermal frame of counts to 8 bits with `params` and the camera's `state` (made by
/// [`fusion_agc_init`]; it keeps the smoothed mapping for the next frame). `output` has the
/// input's size. `report` may be NULL.
///
/// # Safety
/// `state` was initialised by [`fusion_agc_init`] and is used by one call at a time; the other
/// pointers are valid for their documented use (`report`, `error`: NULL or writable).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_agc_frame(
    state_ptr: *mut core::ffi::c_void,
    state_bytes: usize,
    params: *const FusionAgcParams,
    input: *const FusionImage16,
    output: *const FusionImageMut,
    report: *mut FusionAgcReport,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let params = deref(params)?.core()?;
        let (input, in_span) = deref(input)?.view()?;
        let output = deref(output)?;
        let (agc, state_span) = state(state_ptr, state_bytes)?;
        disjoint(output.span()?, &[in_span, state_span])?;
        disjoint(state_span, &[in_span])?;
        let r = fusion_nostd::agc_frame(agc, input, output.view_mut()?, &params)
            .map_err(FusionError::from_core)?;
        // SAFETY: the caller passes NULL or a writable report.
        if let Some(slot) = unsafe { report.as_mut() } {
            *slot = FusionAgcReport {
                pixels: r.pixels,
                bin_low: r.bins.0,
                bin_high: r.bins.1,
                clipped_bins: r.clipped_bins,
            };
        }
        Ok(())
    })
}
