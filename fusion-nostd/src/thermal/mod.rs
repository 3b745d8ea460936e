//! The thermal camera's front end: raw focal-plane counts to a corrected frame, before the AGC.
//!
//! A microbolometer's counts are not an image yet: every pixel has its own gain and offset
//! (fixed-pattern noise, with column structure from the readout), some pixels are dead or hot,
//! and the offsets drift with the focal plane's temperature between shutter closures. The
//! chain, in the order a flight thermal camera runs it, all integer and the same bits on every
//! target:
//!
//! 1. [`nuc`] — two-point non-uniformity correction from the factory's gain and offset tables
//!    (Q2.14 gain, whole-count offset), and the offsets re-levelled from a shutter frame;
//! 2. [`bad_pixels`] — dead and hot pixels from a one-bit map take the median of their valid
//!    8-neighbours (the nearest valid pixel of the row inside a cluster);
//! 3. [`column`](mod@column) — a scene-based filter removes what column offsets the tables left (the
//!    readout's drift), from clipped horizontal differences averaged down the columns;
//!
//! then [`crate::agc`] maps the corrected 16-bit counts to the 8-bit frame the fusion takes.
//!
//! **Frames, strips, rows.** Steps 1 and 2 work on one output row at a time from the raw rows
//! `y − 1`, `y`, `y + 1` ([`correct_row`]): a bad pixel's neighbours are corrected on the fly
//! from their raw counts, so no corrected row needs keeping. [`correct_frame`] runs every row,
//! a strip is any run of them, and a camera read out line by line calls [`correct_row`] one
//! row behind the readout. Step 3, like the AGC, needs the frame's statistics: the frame's own
//! (a first pass: [`column_filter_frame`]) or the previous frame's (one pass; see [`column`](mod@column)).
//! Every form gives the same bits (tested).
//!
//! Memory, besides the frames: the tables, 4 bytes a pixel ([`nuc_table_bytes`]: 1 MiB at
//! 512², 1.25 MiB at 640 × 512, read row by row, so they can sit in slow memory), the map,
//! one bit a pixel ([`bad_map_bytes`]: 32 KiB and 40 KiB), and a [`ColumnFilter`] (28 KiB).

pub mod bad_pixels;
pub mod column;
pub mod nuc;

pub use bad_pixels::{BadPixelMap, bad_map_bytes, bit_of};
pub use column::{COLUMN_MAX_WIDTH, ColumnFilter, ColumnParams, ColumnReport, column_filter_frame};
pub use nuc::{
    GAIN_FRAC_BITS, GAIN_ONE, NucTables, ShutterReport, nuc_frame, nuc_row, nuc_table_bytes, shutter_update,
};

use crate::error::Error;
use crate::frame::{FrameMut, FrameRef};

/// `width·height`, checked (`Err` for a zero or too large dimension).
pub(crate) fn pixels(width: usize, height: usize) -> Result<usize, Error> {
    if width == 0 || height == 0 {
        return Err(Error::ZeroDimension);
    }
    for v in [width, height] {
        if v > crate::MAX_DIMENSION {
            return Err(Error::DimensionTooLarge { value: v });
        }
    }
    Ok(width * height)
}

/// The per-pixel stages of the chain: steps 1 and 2 (either may be absent).
#[derive(Debug, Clone, Copy, Default)]
pub struct Correction<'a> {
    /// The two-point tables (absent: the counts pass as they are).
    pub nuc: Option<NucTables<'a>>,
    /// The bad-pixel map (absent: no replacement).
    pub bad: Option<BadPixelMap<'a>>,
}

impl Correction<'_> {
    /// Checks that the tables and the map are of a `width × height` array.
    pub fn check_size(&self, width: usize, height: usize) -> Result<(), Error> {
        let size = (width, height);
        for got in [self.nuc.map(|t| t.size()), self.bad.map(|b| b.size())].into_iter().flatten() {
            if got != size {
                return Err(Error::SizeMismatch { expected: size, got });
            }
        }
        Ok(())
    }
}

/// Steps 1 and 2 for row `y` of a `width × height` array (`width = row.len()`): the raw row,
/// the raw rows above and below it (`None` only for the first and the last row), into `out`.
pub fn correct_row(
    stages: &Correction<'_>,
    height: usize,
    y: usize,
    above: Option<&[u16]>,
    row: &[u16],
    below: Option<&[u16]>,
    out: &mut [u16],
) -> Result<(), Error> {
    let width = row.len();
    stages.check_size(width, height)?;
    pixels(width, height)?;
    if y >= height {
        return Err(Error::InvalidParameter { name: "thermal row index" });
    }
    if out.len() != width {
        return Err(Error::BufferTooSmall { needed: width, got: out.len() });
    }
    if above.is_some() != (y > 0) || below.is_some() != (y + 1 < height) {
        return Err(Error::InvalidParameter { name: "thermal rows above and below" });
    }
    for r in [above, below].into_iter().flatten() {
        if r.len() != width {
            return Err(Error::SizeMismatch { expected: (width, 1), got: (r.len(), 1) });
        }
    }
    match &stages.nuc {
        Some(t) => nuc_row(t, y, row, out)?,
        None => out.copy_from_slice(row),
    }
    let Some(map) = &stages.bad else { return Ok(()) };
    // A neighbour's corrected value, from its raw count.
    let value = |u: usize, v: usize| -> Option<u16> {
        let src = match v.cmp(&y) {
            core::cmp::Ordering::Less => above?,
            core::cmp::Ordering::Equal => row,
            core::cmp::Ordering::Greater => below?,
        };
        let x = *src.get(u)?;
        Some(match &stages.nuc {
            Some(t) => {
                let (g, o) = t.row(v);
                nuc::correct(x, *g.get(u)?, *o.get(u)?)
            }
            None => x,
        })
    };
    for x in map.bad_in_row(y) {
        if let (Some(r), Some(o)) = (bad_pixels::replacement(map, x, y, value), out.get_mut(x)) {
            *o = r;
        }
    }
    Ok(())
}

/// Steps 1 and 2 over rows `y0 .. y0 + out.height()` of the raw frame `raw` (a strip: `out`
/// holds just those rows). The whole frame is `y0 = 0` with `out` of the frame's size.
pub fn correct_strip(
    stages: &Correction<'_>,
    raw: FrameRef<'_, u16>,
    y0: usize,
    mut out: FrameMut<'_, u16>,
) -> Result<(), Error> {
    let (w, h) = raw.size();
    stages.check_size(w, h)?;
    if out.width() != w || y0 + out.height() > h {
        return Err(Error::SizeMismatch { expected: (w, h.saturating_sub(y0)), got: out.size() });
    }
    for k in 0..out.height() {
        let y = y0 + k;
        let above = y.checked_sub(1).map(|a| raw.row(a));
        let below = (y + 1 < h).then(|| raw.row(y + 1));
        correct_row(stages, h, y, above, raw.row(y), below, out.row_mut(k))?;
    }
    Ok(())
}

/// The whole chain on one frame: steps 1 and 2 into `out`, then (with `column`) step 3 in place
/// with the frame's own estimate (smoothed with `filter`'s previous one when asked).
pub fn correct_frame(
    stages: &Correction<'_>,
    column: Option<(&mut ColumnFilter, &ColumnParams)>,
    raw: FrameRef<'_, u16>,
    mut out: FrameMut<'_, u16>,
) -> Result<Option<ColumnReport>, Error> {
    if out.size() != raw.size() {
        return Err(Error::SizeMismatch { expected: raw.size(), got: out.size() });
    }
    if let Some((f, p)) = &column {
        p.validate()?;
        if !f.fits(raw.width()) {
            return Err(Error::InvalidParameter { name: "column filter width" });
        }
    }
    correct_strip(stages, raw, 0, out.reborrow())?;
    match column {
        Some((filter, p)) => column_filter_frame(filter, out, p).map(Some),
        None => Ok(None),
    }
}
