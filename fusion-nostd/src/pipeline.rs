//! The one entry point a firmware calls per frame pair: align the two bands on one grid, fuse.
//!
//! ```text
//! VIS (e.g. 1024²) ─┐                       ┌─ rescale TIR up (bicubic)  ─┐
//!                   ├─ RescalePolicy ───────┼─ rescale VIS down (area)   ─┼─ Method ─→ fused u8
//! TIR (e.g. 512²)  ─┘                       └─ none (sizes must match)   ─┘
//! ```
//!
//! The rescaled band goes into the scratch's `u8` band plane; the method borrows the `i32`
//! work planes. When both frames already share a grid the rescale is skipped whatever the
//! policy says (and [`FuseReport::rescaled`] says so).

use crate::fuse::Guards;
use crate::fuse::adf::{AdfParams, fuse_adf, fuse_adf_raw};
use crate::fuse::ifevip::{IfevipParams, fuse_ifevip};
use crate::fuse::tsifsd::{TsifsdParams, fuse_tsifsd, fuse_tsifsd_raw};
use crate::{Error, Filter, FrameMut, FrameRef, ScratchMut, rescale};

/// Which band is rescaled onto the other's grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum RescalePolicy {
    /// Upscale TIR to the VIS grid with bicubic (the study's recommendation; default).
    #[default]
    TirUp,
    /// Downscale VIS to the TIR grid with area.
    VisDown,
    /// No rescale: the frames must already have the same size.
    None,
}

/// The fusion method and its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// Anisotropic diffusion + Karhunen–Loève fusion.
    Adf(AdfParams),
    /// Two-scale image fusion with saliency detection.
    Tsifsd(TsifsdParams),
    /// Infrared feature extraction + visual information preservation.
    Ifevip(IfevipParams),
}

impl Default for Method {
    fn default() -> Self {
        Method::Tsifsd(TsifsdParams::default())
    }
}

/// A whole per-frame configuration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pipeline {
    /// How the two bands are brought onto one grid.
    pub rescale: RescalePolicy,
    /// How they are fused.
    pub method: Method,
}

impl Pipeline {
    /// Pixels each scratch plane (the three `i32` planes and the `u8` band plane) must hold to
    /// fuse a `vis`-sized frame with a `tir`-sized one, or [`Error::SizeMismatch`] when the
    /// policy cannot align them.
    ///
    /// Sizes a view could not have are refused first: a zero side ([`Error::ZeroDimension`]) or
    /// a side above [`crate::MAX_DIMENSION`] ([`Error::DimensionTooLarge`]).
    pub fn scratch_pixels(&self, vis: (usize, usize), tir: (usize, usize)) -> Result<usize, Error> {
        for value in [vis.0, vis.1, tir.0, tir.1] {
            if value == 0 {
                return Err(Error::ZeroDimension);
            }
            if value > crate::MAX_DIMENSION {
                return Err(Error::DimensionTooLarge { value });
            }
        }
        let (w, h) = fusion_grid(vis, tir, self.rescale)?;
        let pixels = w.checked_mul(h).ok_or(Error::DimensionTooLarge { value: w.max(h) })?;
        Ok(match &self.method {
            Method::Adf(_) | Method::Tsifsd(_) => pixels,
            Method::Ifevip(p) => crate::fuse::ifevip::scratch_pixels(w, h, p).max(pixels),
        })
    }
}

/// What one [`fuse`] call did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FuseReport {
    /// Width and height of the grid the frames were fused on (= the output size).
    pub grid: (usize, usize),
    /// Whether a band was rescaled (false when the sizes already matched).
    pub rescaled: bool,
    /// The guards the method fired.
    pub guards: Guards,
}

/// The grid `policy` fuses on, given the two input sizes.
pub fn fusion_grid(
    vis: (usize, usize),
    tir: (usize, usize),
    policy: RescalePolicy,
) -> Result<(usize, usize), Error> {
    match policy {
        RescalePolicy::TirUp => Ok(vis),
        RescalePolicy::VisDown => Ok(tir),
        RescalePolicy::None if vis == tir => Ok(vis),
        RescalePolicy::None => Err(Error::SizeMismatch { expected: vis, got: tir }),
    }
}

/// Runs one method on two frames of the same size.
pub fn fuse_method(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    method: &Method,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    match method {
        Method::Adf(p) => fuse_adf(vis, tir, out, p, scratch),
        Method::Tsifsd(p) => fuse_tsifsd(vis, tir, out, p, scratch),
        Method::Ifevip(p) => fuse_ifevip(vis, tir, out, p, scratch),
    }
}

/// Fuses a VIS/TIR pair into `out`: rescale by `pipeline.rescale`, then `pipeline.method`.
///
/// `out` must have the size of the fusion grid (the VIS size for [`RescalePolicy::TirUp`],
/// the TIR size for [`RescalePolicy::VisDown`]). Errors: [`Error::SizeMismatch`] for a wrong
/// output size or (policy `None`) different input sizes, [`Error::ScratchTooSmall`], and any
/// error of the method. On error `out` may hold a partial result and must not be used.
pub fn fuse(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    scratch: &mut ScratchMut<'_>,
    pipeline: &Pipeline,
) -> Result<FuseReport, Error> {
    on_grid(vis, tir, out.size(), scratch, pipeline.rescale, |v, t, s| {
        fuse_method(v, t, out, &pipeline.method, s)
    })
}

/// Like [`fuse`], but writes the method's real-valued result before the 8-bit cast, in Q16
/// (`raw / 65536.0` grey levels); [`fuse`] is this value cast with
/// [`crate::fuse::round_away_sat_u8`]`(raw, 16)`.
///
/// ADF and TSIFSD only: IFEVIP's published arithmetic saturates to `uint8` at every step, so
/// its pre-cast value is its output; for it this returns [`Error::InvalidParameter`]
/// (`name: "method"`).
pub fn fuse_raw(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    raw: FrameMut<'_, i32>,
    scratch: &mut ScratchMut<'_>,
    pipeline: &Pipeline,
) -> Result<FuseReport, Error> {
    on_grid(vis, tir, raw.size(), scratch, pipeline.rescale, |v, t, s| match &pipeline.method {
        Method::Adf(p) => fuse_adf_raw(v, t, raw, p, s),
        Method::Tsifsd(p) => fuse_tsifsd_raw(v, t, raw, p, s),
        Method::Ifevip(_) => Err(Error::InvalidParameter { name: "method" }),
    })
}

/// Brings both bands onto the fusion grid of `policy` (rescaling one into the scratch's band
/// plane when the sizes differ) and runs `fuse_on_grid` there with the remaining planes.
fn on_grid(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out_size: (usize, usize),
    scratch: &mut ScratchMut<'_>,
    policy: RescalePolicy,
    fuse_on_grid: impl FnOnce(FrameRef<'_, u8>, FrameRef<'_, u8>, &mut ScratchMut<'_>) -> Result<Guards, Error>,
) -> Result<FuseReport, Error> {
    let grid = fusion_grid(vis.size(), tir.size(), policy)?;
    if out_size != grid {
        return Err(Error::SizeMismatch { expected: grid, got: out_size });
    }
    if vis.size() == tir.size() {
        let guards = fuse_on_grid(vis, tir, scratch)?;
        return Ok(FuseReport { grid, rescaled: false, guards });
    }
    let (band, mut planes) = scratch.split_band(grid.0 * grid.1)?;
    let guards = match policy {
        RescalePolicy::TirUp => {
            rescale(tir, FrameMut::new(band, grid.0, grid.1)?, Filter::Cubic)?;
            fuse_on_grid(vis, FrameRef::new(band, grid.0, grid.1)?, &mut planes)?
        }
        RescalePolicy::VisDown | RescalePolicy::None => {
            rescale(vis, FrameMut::new(band, grid.0, grid.1)?, Filter::Area)?;
            fuse_on_grid(FrameRef::new(band, grid.0, grid.1)?, tir, &mut planes)?
        }
    };
    Ok(FuseReport { grid, rescaled: true, guards })
}
