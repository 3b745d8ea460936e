//! Registration of an offset camera pair (`fusion_nostd::registration`): the thermal frame
//! onto the visible grid at a range.

use crate::image::{FusionImage, FusionImage16, FusionImageMut, FusionImageMut16, Span, deref, disjoint};
use crate::status::{FusionError, FusionStatus, run};
use fusion_nostd::registration::{
    Border, Camera, Interpolation, NODE_STEP, Rig, RigMap, node_count, register,
};

/// Visible rows of map per strip in the scratch.
const STRIP_ROWS: usize = 16;

/// One camera (OpenCV's camera matrix and distortion; pixel centres at integers).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FusionCamera {
    /// Focal length along x, px.
    pub fx: f32,
    /// Focal length along y, px.
    pub fy: f32,
    /// Principal point x, px.
    pub cx: f32,
    /// Principal point y, px.
    pub cy: f32,
    /// `k1, k2, p1, p2, k3` (OpenCV's order).
    pub dist: [f32; 5],
    /// Image width, px.
    pub width: usize,
    /// Image height, px.
    pub height: usize,
}

/// A VIS/TIR pair in `stereoCalibrate`'s convention: `X_tir = R·X_vis + T` (metres).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FusionRig {
    /// The visible camera (camera 1).
    pub vis: FusionCamera,
    /// The thermal camera (camera 2).
    pub tir: FusionCamera,
    /// Rotation, row-major.
    pub r: [f32; 9],
    /// Translation, metres.
    pub t: [f32; 3],
}

/// Interpolation: `FUSION_REGISTER_LINEAR` (0) or `FUSION_REGISTER_CUBIC` (1); where the thermal
/// camera did not see: `border_replicate` 0 (the constant `border_value`) or 1 (the edge).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FusionRegisterParams {
    /// 0 linear, 1 cubic.
    pub interpolation: u32,
    /// 0: the constant `border_value`; 1: the nearest edge pixel.
    pub border_replicate: u32,
    /// The constant (saturated to the image's depth).
    pub border_value: u16,
}

fn camera(c: &FusionCamera) -> Camera {
    Camera { fx: c.fx, fy: c.fy, cx: c.cx, cy: c.cy, dist: c.dist, width: c.width, height: c.height }
}

#[cfg(test)]
pub(crate) fn tests_rig(r: &FusionRig) -> Rig {
    rig(r)
}

fn rig(r: &FusionRig) -> Rig {
    let m = r.r;
    Rig {
        vis: camera(&r.vis),
        tir: camera(&r.tir),
        r: [[m[0], m[1], m[2]], [m[3], m[4], m[5]], [m[6], m[7], m[8]]],
        t: r.t,
    }
}

/// Bytes of scratch [`fusion_register_u8`] and [`fusion_register_u16`] need for `rig`: the node
/// grid (8 bytes a node every 16 visible pixels) and 16 rows of map (6 bytes a visible pixel);
/// 0 for a rig without a visible size.
///
/// # Safety
/// `rig` is NULL or points to a `FusionRig`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_register_scratch_bytes(rig: *const FusionRig) -> usize {
    // SAFETY: NULL or a valid rig (header contract).
    match unsafe { rig.as_ref() } {
        Some(r) => 8 * node_count(r.vis.width, r.vis.height, NODE_STEP) + 6 * STRIP_ROWS * r.vis.width,
        None => 0,
    }
}

/// The scratch split into the node grid, the strip's positions and its sub-pixel indices.
type Parts<'a> = (&'a mut [[f32; 2]], &'a mut [i16], &'a mut [u16]);

fn split<'a>(rig: &FusionRig, scratch: *mut u8, bytes: usize) -> Result<(Parts<'a>, Span), FusionError> {
    if scratch.is_null() {
        return Err(FusionError::of(FusionStatus::NullPointer));
    }
    if !(scratch as usize).is_multiple_of(4) {
        return Err(FusionError::of(FusionStatus::Misaligned));
    }
    let nodes = node_count(rig.vis.width, rig.vis.height, NODE_STEP);
    let w = rig.vis.width;
    let needed = 8 * nodes + 6 * STRIP_ROWS * w;
    if bytes < needed {
        return Err(FusionError::from_core(fusion_nostd::Error::BufferTooSmall { needed, got: bytes }));
    }
    // SAFETY: the caller's contract: `bytes` writable bytes, 4-aligned (checked), used by
    // nothing else during the call; the three parts are disjoint and aligned for their types
    // (8·nodes and 4·16·w are multiples of 4 and 2).
    let parts = unsafe {
        let nodes_ptr = scratch.cast::<[f32; 2]>();
        let xy_ptr = scratch.add(8 * nodes).cast::<i16>();
        let frac_ptr = scratch.add(8 * nodes + 4 * STRIP_ROWS * w).cast::<u16>();
        (
            core::slice::from_raw_parts_mut(nodes_ptr, nodes),
            core::slice::from_raw_parts_mut(xy_ptr, 2 * STRIP_ROWS * w),
            core::slice::from_raw_parts_mut(frac_ptr, STRIP_ROWS * w),
        )
    };
    Ok((parts, Span::of(scratch.cast_const(), needed)))
}

fn params(p: &FusionRegisterParams) -> Result<(Interpolation, Border), FusionError> {
    let interp = match p.interpolation {
        0 => Interpolation::Linear,
        1 => Interpolation::Cubic,
        _ => return Err(FusionError::invalid("interpolation")),
    };
    let border = match p.border_replicate {
        0 => Border::Constant(p.border_value),
        1 => Border::Replicate,
        _ => return Err(FusionError::invalid("border_replicate")),
    };
    Ok((interp, border))
}

/// The shared body of [`fusion_register_u8`] and [`fusion_register_u16`].
#[allow(clippy::too_many_arguments)]
fn register_any<'a, T: fusion_nostd::registration::RemapSample + 'a>(
    rig: *const FusionRig,
    range_m: f32,
    params: *const FusionRegisterParams,
    input: Result<(fusion_nostd::FrameRef<'a, T>, Span), FusionError>,
    output: (Result<Span, FusionError>, impl FnOnce() -> Result<fusion_nostd::FrameMut<'a, T>, FusionError>),
    scratch: *mut u8,
    scratch_bytes: usize,
) -> Result<(), FusionError> {
    let r = deref(rig)?;
    let (interp, border) = self::params(deref(params)?)?;
    let (input, in_span) = input?;
    let ((nodes, xy, frac), sc_span) = split(r, scratch, scratch_bytes)?;
    disjoint(output.0?, &[in_span, sc_span])?;
    disjoint(sc_span, &[in_span])?;
    let map = RigMap::new(&self::rig(r), range_m, NODE_STEP, nodes).map_err(FusionError::from_core)?;
    register(input, &map, (output.1)()?, interp, border, xy, frac).map_err(FusionError::from_core)
}

/// Warps an 8-bit thermal frame (the rig's thermal size) onto the visible grid (`output`, the
/// rig's visible size) for a target at `range_m` metres along the visible optical axis:
/// `fusion register`'s bytes. Nothing is written to `output` on an error.
///
/// # Safety
/// `rig`, `params`, `input`, `output` point to valid values; `scratch` to `scratch_bytes`
/// writable, 4-aligned bytes (at least [`fusion_register_scratch_bytes`]) not overlapping the
/// images; `error` is NULL or writable.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fusion_register_u8(
    rig: *const FusionRig,
    range_m: f32,
    params: *const FusionRegisterParams,
    input: *const FusionImage,
    output: *const FusionImageMut,
    scratch: *mut u8,
    scratch_bytes: usize,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let out = deref(output)?;
        let input = deref(input).and_then(|i| i.view());
        register_any(rig, range_m, params, input, (out.span(), || out.view_mut()), scratch, scratch_bytes)
    })
}

/// As [`fusion_register_u8`] for 16-bit frames.
///
/// # Safety
/// As [`fusion_register_u8`].
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fusion_register_u16(
    rig: *const FusionRig,
    range_m: f32,
    params: *const FusionRegisterParams,
    input: *const FusionImage16,
    output: *const FusionImageMut16,
    scratch: *mut u8,
    scratch_bytes: usize,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let out = deref(output)?;
        let input = deref(input).and_then(|i| i.view());
        register_any(rig, range_m, params, input, (out.span(), || out.view_mut()), scratch, scratch_bytes)
    })
}
