//! Registration of offset cameras: the thermal image resampled onto the visible grid.
//!
//! Two cameras side by side see the target from two points: at the target's range the
//! baseline alone moves it by tens of thermal pixels, and their lenses differ. Before a
//! pixel-level fusion the thermal frame is warped onto the visible camera's grid through a
//! **fixed-point map**: for every output (visible-grid) pixel the source (thermal) position,
//! as OpenCV keeps it after `convertMaps(…, CV_16SC2)` — the integer part `(x, y)` as two
//! `i16` and the sub-pixel position as one `u16` index `fy·32 + fx` (1/32 pixel,
//! [`TAB_SIZE`]). [`remap`] resamples through such a map, the same bits as OpenCV's `remap`
//! given that map (see [`kernel`] for the arithmetic and `BENCHMARKS.md`,
//! "Registration", for what was compared).
//!
//! The map is an input: a frame's map depends on the range (the plane the target lies in), so a
//! caller recomputes it when the range changes, for the whole frame or strip by strip (a
//! strip's map is a map of the strip's height: [`remap`] takes any output size).

pub mod kernel;
pub mod rig;
pub mod tables;

pub use kernel::{Border, RemapSample};
pub use rig::{Camera, NODE_STEP, Rig, RigMap, node_count};
pub use tables::{TAB_BITS, TAB_SIZE};

use crate::error::Error;
use crate::frame::{FrameMut, FrameRef};

/// The interpolation of [`remap`] (OpenCV's `INTER_LINEAR`, `INTER_CUBIC`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    /// 2 × 2 neighbourhood, bilinear weights.
    Linear,
    /// 4 × 4 neighbourhood, Keys' cubic with a = −0.75.
    Cubic,
}

/// A fixed-point map of `width × height` output pixels: `xy` holds `(x, y)` per pixel
/// (`2·width·height` values, row-major, x first: OpenCV's `CV_16SC2`), `frac` the sub-pixel
/// index `fy·32 + fx` per pixel (OpenCV's `CV_16UC1`; bits above the low 10 are ignored, as
/// OpenCV does).
#[derive(Debug, Clone, Copy)]
pub struct FixedMap<'a> {
    width: usize,
    height: usize,
    xy: &'a [i16],
    frac: &'a [u16],
}

impl<'a> FixedMap<'a> {
    /// A map of `width × height`; `Err` for a zero size or arrays of another length.
    pub fn new(width: usize, height: usize, xy: &'a [i16], frac: &'a [u16]) -> Result<Self, Error> {
        let n = crate::thermal::pixels(width, height)?;
        if xy.len() != 2 * n {
            return Err(Error::BufferTooSmall { needed: 2 * n, got: xy.len() });
        }
        if frac.len() != n {
            return Err(Error::BufferTooSmall { needed: n, got: frac.len() });
        }
        Ok(FixedMap { width, height, xy, frac })
    }

    /// `(width, height)` of the output it maps.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Row `y`: its `(x, y)` pairs and its sub-pixel indices.
    fn row(&self, y: usize) -> (&'a [i16], &'a [u16]) {
        let w = self.width;
        (
            self.xy.get(2 * y * w..2 * (y + 1) * w).unwrap_or(&[]),
            self.frac.get(y * w..(y + 1) * w).unwrap_or(&[]),
        )
    }
}

/// Resamples `src` through `map` into `out` (of the map's size): output pixel `(u, v)` is
/// `src` interpolated at the map's position for it, neighbours outside `src` read by `border`.
/// `Err` (nothing written) when `out` is not the map's size.
pub fn remap<T: RemapSample>(
    src: FrameRef<'_, T>,
    map: &FixedMap<'_>,
    mut out: FrameMut<'_, T>,
    interpolation: Interpolation,
    border: Border,
) -> Result<(), Error> {
    if out.size() != map.size() {
        return Err(Error::SizeMismatch { expected: map.size(), got: out.size() });
    }
    for y in 0..map.height {
        let (xy, frac) = map.row(y);
        let row = out.row_mut(y);
        for ((o, p), &f) in row.iter_mut().zip(xy.chunks_exact(2)).zip(frac) {
            let (sx, sy) =
                (p.first().map_or(0, |&v| isize::from(v)), p.get(1).map_or(0, |&v| isize::from(v)));
            let f = usize::from(f) & (TAB_SIZE * TAB_SIZE - 1);
            *o = match interpolation {
                Interpolation::Linear => kernel::linear_at(&src, sx, sy, f, border),
                Interpolation::Cubic => kernel::cubic_at(&src, sx, sy, f, border),
            };
        }
    }
    Ok(())
}

/// Registers the thermal frame `src` onto the visible grid: `out` (the visible size of
/// `map`) strip by strip, each strip's fixed-point map filled from `map` ([`RigMap::rows`])
/// into the scratch `xy`/`frac` (as many whole visible rows as `frac` holds: 6 bytes a pixel,
/// 96 KiB for 16 rows of 1024), then [`remap`]ped. The same bits for any strip height.
/// `Err` (nothing written) when `src` is not the thermal camera's size, `out` not the visible
/// camera's, or the scratch holds no whole row or `xy` is not twice `frac`.
pub fn register<T: RemapSample>(
    src: FrameRef<'_, T>,
    map: &RigMap<'_>,
    mut out: FrameMut<'_, T>,
    interpolation: Interpolation,
    border: Border,
    xy: &mut [i16],
    frac: &mut [u16],
) -> Result<(), Error> {
    if out.size() != map.size() {
        return Err(Error::SizeMismatch { expected: map.size(), got: out.size() });
    }
    if src.size() != map.tir_size() {
        return Err(Error::SizeMismatch { expected: map.tir_size(), got: src.size() });
    }
    let (w, h) = map.size();
    let strip = frac.len().checked_div(w).unwrap_or(0);
    if strip == 0 {
        return Err(Error::BufferTooSmall { needed: w, got: frac.len() });
    }
    if xy.len() < 2 * strip * w {
        return Err(Error::BufferTooSmall { needed: 2 * strip * w, got: xy.len() });
    }
    let mut y0 = 0;
    while y0 < h {
        let rows = strip.min(h - y0);
        let (xy, frac) =
            (xy.get_mut(..2 * rows * w).unwrap_or(&mut []), frac.get_mut(..rows * w).unwrap_or(&mut []));
        map.rows(y0, xy, frac)?;
        let strip_map = FixedMap::new(w, rows, xy, frac)?;
        remap(src, &strip_map, out.sub_rows_mut(y0, y0 + rows)?, interpolation, border)?;
        y0 += rows;
    }
    Ok(())
}
