//! Sequence mode from C: a caller-owned state that carries ADF's KL weights from one frame to
//! the next (`fusion_nostd::sequence`), and the two fusion entry points that use it.

use crate::fuse::{FusionConfig, FusionReport, put, strips, whole};
use crate::image::{FusionImage, FusionImageMut, Span};
use crate::status::{FusionError, FusionStatus, run};
use fusion_nostd::scene::Illumination;
use fusion_nostd::sequence::{Pass, Restart, Sequence, SequenceParams};

/// How a frame of a sequence was fused (values of [`FusionSequenceStep::pass`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FusionPass {
    /// With the weights carried from the previous frame (one pass in strips).
    Carried = 0,
    /// With the frame's own weights (two passes in strips); [`FusionSequenceStep::restart`]
    /// says why.
    Own = 1,
    /// Per frame: the method carries nothing (TSIFSD, IFEVIP, adaptive), or ADF's skip plan
    /// found nothing to fuse.
    PerFrame = 2,
}

/// Why a frame took its own weights (values of [`FusionSequenceStep::restart`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FusionRestart {
    /// Not restarted (carried, or per frame).
    NoRestart = 0,
    /// Nothing carried: the first frame (after [`fusion_sequence_init`], or after a frame of a
    /// method that carries nothing).
    First = 1,
    /// The VIS illumination class changed.
    Illumination = 2,
    /// The covariance's pixel count changed by more than the state's
    /// `size_change_percent`.
    Size = 3,
    /// The method's parameters changed.
    Method = 4,
}

/// What the last frame of a sequence did.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FusionSequenceStep {
    /// A `FusionPass` value.
    pub pass: u32,
    /// A `FusionRestart` value.
    pub restart: u32,
    /// The VIS illumination the rule compared: 0 none (per frame), 1 light, 2 eclipse, 3
    /// saturated.
    pub illumination: u32,
    /// Pixels of the covariance (the grid or the skip plan's crop; 0 per frame).
    pub pixels: usize,
    /// ADF's IR weight the frame was fused with, Q30 (`/ 2^30`; 0 per frame).
    pub p_ir_used_q30: i64,
    /// ADF's IR weight of the frame's own covariance, Q30: carried to the next frame.
    pub p_ir_own_q30: i64,
}

/// The state in the caller's buffer: a tag written by [`fusion_sequence_init`], then the core's.
#[repr(C)]
struct State {
    tag: u64,
    seq: Sequence,
}

/// The tag of an initialised state ("FUSIONSQ").
const TAG: u64 = u64::from_le_bytes(*b"FUSIONSQ");

/// Bytes of one sequence state (a few dozen; align it to 8 bytes). One state per sequence of
/// frames (per camera pair).
#[unsafe(no_mangle)]
pub extern "C" fn fusion_sequence_state_bytes() -> usize {
    core::mem::size_of::<State>()
}

/// The state buffer checked (non-NULL, aligned, long enough).
fn checked(ptr: *mut core::ffi::c_void, bytes: usize) -> Result<Span, FusionError> {
    if ptr.is_null() {
        return Err(FusionError::of(FusionStatus::NullPointer));
    }
    if !(ptr as usize).is_multiple_of(core::mem::align_of::<State>()) {
        return Err(FusionError::of(FusionStatus::Misaligned));
    }
    let needed = core::mem::size_of::<State>();
    if bytes < needed {
        return Err(FusionError {
            values: [needed, bytes, 0, 0],
            ..FusionError::of(FusionStatus::ScratchTooSmall)
        });
    }
    Ok(Span::of(ptr.cast::<u8>(), needed))
}

/// The initialised state in the caller's buffer.
fn state<'a>(ptr: *mut core::ffi::c_void, bytes: usize) -> Result<(&'a mut Sequence, Span), FusionError> {
    let span = checked(ptr, bytes)?;
    // SAFETY: aligned and long enough (checked); the tag is a plain integer, read before the
    // core's state is used as such.
    let tag = unsafe { core::ptr::read(ptr.cast::<u64>()) };
    if tag != TAG {
        return Err(FusionError::invalid("sequence state"));
    }
    // SAFETY: tagged by `fusion_sequence_init`, which wrote a valid `State`; since then only the
    // core wrote it (the caller's contract: the state is not changed by anything else).
    Ok((unsafe { &mut (*ptr.cast::<State>()).seq }, span))
}

/// Starts a sequence in `state` (8-byte aligned, at least [`fusion_sequence_state_bytes`]):
/// nothing carried, so the next frame takes its own weights. `size_change_percent` is the largest
/// change of the covariance's pixel count (the grid, or the skip plan's crop) between two frames
/// that still carries the weights, per cent of the smaller (`≥ 100`; 150 is the core's
/// default); `window_frames` (0–8; 5 is the core's default): with scene skipping, the target
/// boxes of that many previous frames are joined to each frame's own.
///
/// # Safety
/// `state` is NULL or points to `bytes` writable bytes; `error` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_sequence_init(
    state_ptr: *mut core::ffi::c_void,
    bytes: usize,
    size_change_percent: u32,
    window_frames: u32,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        checked(state_ptr, bytes)?;
        let params = SequenceParams {
            size_change_percent: u16::try_from(size_change_percent).unwrap_or(u16::MAX),
            window_frames: u8::try_from(window_frames).unwrap_or(u8::MAX),
        };
        params.validate().map_err(FusionError::from_core)?;
        // SAFETY: aligned and at least `size_of::<State>()` writable bytes (checked above).
        unsafe {
            core::ptr::write(state_ptr.cast::<State>(), State { tag: TAG, seq: Sequence::new(params) })
        };
        Ok(())
    })
}

fn step_of(seq: &Sequence) -> FusionSequenceStep {
    let Some(s) = seq.last_step() else {
        return FusionSequenceStep {
            pass: FusionPass::PerFrame as u32,
            restart: 0,
            illumination: 0,
            pixels: 0,
            p_ir_used_q30: 0,
            p_ir_own_q30: 0,
        };
    };
    let (pass, restart) = match s.pass {
        Pass::Carried => (FusionPass::Carried, FusionRestart::NoRestart),
        Pass::Own(Restart::First) => (FusionPass::Own, FusionRestart::First),
        Pass::Own(Restart::Illumination) => (FusionPass::Own, FusionRestart::Illumination),
        Pass::Own(Restart::Size) => (FusionPass::Own, FusionRestart::Size),
        Pass::Own(Restart::Method) => (FusionPass::Own, FusionRestart::Method),
        Pass::PerFrame => (FusionPass::PerFrame, FusionRestart::NoRestart),
    };
    FusionSequenceStep {
        pass: pass as u32,
        restart: restart as u32,
        illumination: match s.illumination {
            None => 0,
            Some(Illumination::Light) => 1,
            Some(Illumination::Eclipse) => 2,
            Some(Illumination::Saturated) => 3,
        },
        pixels: s.pixels,
        p_ir_used_q30: s.p_ir_used_q30,
        p_ir_own_q30: s.p_ir_own_q30,
    }
}

/// [`crate::fusion_fuse`] for the next frame of the sequence in `state` (started by
/// [`fusion_sequence_init`]): ADF takes the weights the previous frame measured unless the
/// illumination class, the covariance's size or the parameters changed; the other methods are
/// fused per frame. The first frame gives `fusion_fuse`'s bytes. `step` (may be NULL) says how
/// the frame was fused. On an error the state is as it was before the call.
///
/// # Safety
/// As [`crate::fusion_fuse`]; `state` was initialised by [`fusion_sequence_init`], is used by
/// one call at a time and is not written by anything else; `step` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_fuse_in_sequence(
    state_ptr: *mut core::ffi::c_void,
    state_bytes: usize,
    config: *const FusionConfig,
    vis: *const FusionImage,
    tir: *const FusionImage,
    out: *const FusionImageMut,
    scratch: *mut core::ffi::c_void,
    scratch_bytes: usize,
    report: *mut FusionReport,
    step: *mut FusionSequenceStep,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let (seq, span) = state(state_ptr, state_bytes)?;
        whole(config, vis, tir, out, scratch, scratch_bytes, report, Some((&mut *seq, span)))?;
        if !step.is_null() {
            put(step, step_of(seq))?;
        }
        Ok(())
    })
}

/// [`crate::fusion_fuse_strips`] for the next frame of the sequence in `state`: the bytes of
/// [`fusion_fuse_in_sequence`]; an ADF frame with carried weights takes one pass over the strips
/// (each strip diffused once) instead of two.
///
/// # Safety
/// As [`fusion_fuse_in_sequence`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_fuse_strips_in_sequence(
    state_ptr: *mut core::ffi::c_void,
    state_bytes: usize,
    config: *const FusionConfig,
    vis: *const FusionImage,
    tir: *const FusionImage,
    out: *const FusionImageMut,
    scratch: *mut core::ffi::c_void,
    scratch_bytes: usize,
    max_rows: usize,
    report: *mut FusionReport,
    step: *mut FusionSequenceStep,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let (seq, span) = state(state_ptr, state_bytes)?;
        strips(config, vis, tir, out, scratch, scratch_bytes, max_rows, report, Some((&mut *seq, span)))?;
        if !step.is_null() {
            put(step, step_of(seq))?;
        }
        Ok(())
    })
}
