//! Two-point non-uniformity correction (NUC) and the shutter's offset update.
//!
//! Each pixel `p` of a microbolometer answers the same flux with its own gain and offset. The
//! factory's two-point calibration (two uniform black bodies) gives per pixel a gain `G(p)`
//! and an offset `O(p)` that put every pixel on one response:
//!
//! `y(p) = clamp(⌊(g(p)·x(p) + 2¹³) / 2¹⁴⌋ + O(p), 0, 65 535)`
//!
//! with `x` the raw count, `g = round(G·2¹⁴)` the gain in unsigned Q2.14 and `O` whole counts.
//!
//! **Why Q2.14 and whole-count offsets.** A calibrated gain sits within a few per cent of its
//! array's mean (the gain spread of the arrays in the literature is 1–5 %), so the gain needs
//! little range and much resolution: Q2.14 holds `0 ≤ G < 4` (an output scale up to 4× the raw
//! one) in steps of 2⁻¹⁴ = 6.1·10⁻⁵, so the gain's rounding moves a 14-bit full-scale count
//! (16 383) by at most half a count — less than a microbolometer's temporal noise (its NETD is
//! one to a few counts). The offset's rounding (half a count) is of the same size. The product
//! `g·x + 2¹³` fits `u32` for every 16-bit `x`. Two bytes of gain and two of offset per pixel:
//! 1 MiB of tables for a 512² array, 1.25 MiB for 640 × 512 ([`nuc_table_bytes`]).
//!
//! **The shutter.** Between calibrations the offsets drift with the focal plane's temperature.
//! When the camera closes its shutter (a uniform scene at the shutter's temperature), the
//! offsets are re-levelled so the corrected shutter frame is flat at its mean:
//! with `c(p)` the shutter frame corrected with the current tables (unclamped) and `m` the
//! mean of `c` over the valid pixels (rounded half up), `O'(p) = O(p) + m − c(p)` — the gains
//! stay, the level of the array stays, each pixel's deviation goes ([`shutter_update`]).

use crate::error::Error;
use crate::frame::{FrameMut, FrameRef};

use super::bad_pixels::BadPixelMap;

/// Fraction bits of the gain table: `g = round(G · 2^GAIN_FRAC_BITS)`.
pub const GAIN_FRAC_BITS: u32 = 14;
/// The gain table's value for a gain of exactly 1.
pub const GAIN_ONE: u16 = 1 << GAIN_FRAC_BITS;

/// Bytes of NUC tables (gain and offset) for a `width × height` array.
pub const fn nuc_table_bytes(width: usize, height: usize) -> usize {
    width * height * 4
}

/// A two-point calibration: per pixel a gain (Q2.14, [`GAIN_FRAC_BITS`]) and an offset
/// (counts), row-major without padding.
#[derive(Debug, Clone, Copy)]
pub struct NucTables<'a> {
    width: usize,
    height: usize,
    gain: &'a [u16],
    offset: &'a [i16],
}

impl<'a> NucTables<'a> {
    /// Tables for a `width × height` array; `Err` when a dimension is zero or too large or a
    /// table's length is not `width·height`.
    pub fn new(width: usize, height: usize, gain: &'a [u16], offset: &'a [i16]) -> Result<Self, Error> {
        let n = super::pixels(width, height)?;
        if gain.len() != n {
            return Err(Error::InvalidParameter { name: "nuc gain table length" });
        }
        if offset.len() != n {
            return Err(Error::InvalidParameter { name: "nuc offset table length" });
        }
        Ok(NucTables { width, height, gain, offset })
    }

    /// The array's size (width, height).
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Row `y`'s gains and offsets (empty beyond the last row).
    pub(crate) fn row(&self, y: usize) -> (&'a [u16], &'a [i16]) {
        let r = y * self.width..(y + 1) * self.width;
        (self.gain.get(r.clone()).unwrap_or(&[]), self.offset.get(r).unwrap_or(&[]))
    }
}

/// One pixel's correction, unclamped.
#[inline(always)]
pub(crate) fn correct_unclamped(x: u16, g: u16, o: i16) -> i32 {
    // ≤ 65 535² + 2¹³ < 2³²: no overflow.
    let scaled = (u32::from(g) * u32::from(x) + (1 << (GAIN_FRAC_BITS - 1))) >> GAIN_FRAC_BITS;
    scaled as i32 + i32::from(o)
}

/// One pixel's correction.
#[inline(always)]
pub(crate) fn correct(x: u16, g: u16, o: i16) -> u16 {
    correct_unclamped(x, g, o).clamp(0, i32::from(u16::MAX)) as u16
}

/// Corrects one row (`raw` and `out` of the tables' width; row `y` of the array).
pub fn nuc_row(tables: &NucTables<'_>, y: usize, raw: &[u16], out: &mut [u16]) -> Result<(), Error> {
    if y >= tables.height {
        return Err(Error::InvalidParameter { name: "nuc row index" });
    }
    if raw.len() != tables.width || out.len() != tables.width {
        return Err(Error::SizeMismatch { expected: (tables.width, 1), got: (raw.len().min(out.len()), 1) });
    }
    let (g, o) = tables.row(y);
    for (((d, &x), &g), &o) in out.iter_mut().zip(raw).zip(g).zip(o) {
        *d = correct(x, g, o);
    }
    Ok(())
}

/// Corrects a whole frame of raw counts into `out` (both of the tables' size).
pub fn nuc_frame(
    tables: &NucTables<'_>,
    raw: FrameRef<'_, u16>,
    mut out: FrameMut<'_, u16>,
) -> Result<(), Error> {
    let size = tables.size();
    for got in [raw.size(), out.size()] {
        if got != size {
            return Err(Error::SizeMismatch { expected: size, got });
        }
    }
    for (y, row) in raw.rows().enumerate() {
        nuc_row(tables, y, row, out.row_mut(y))?;
    }
    Ok(())
}

/// What a [`shutter_update`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShutterReport {
    /// The mean corrected shutter level `m` the offsets now flatten to, counts.
    pub level: i32,
    /// Pixels the mean was taken over (the valid ones).
    pub pixels: u32,
    /// Offsets that did not fit `i16` and were clamped (a pixel so far off is a bad pixel).
    pub clamped: u32,
}

/// Re-levels `offset` from a shutter frame (see the module's documentation): `gain` and
/// `offset` are the current tables of `shutter`'s size, `bad` (optional) the pixels left out
/// of the mean. `Err` (the offsets untouched) for sizes that differ or a frame with no valid
/// pixel.
pub fn shutter_update(
    gain: &[u16],
    offset: &mut [i16],
    bad: Option<&BadPixelMap<'_>>,
    shutter: FrameRef<'_, u16>,
) -> Result<ShutterReport, Error> {
    let (w, h) = shutter.size();
    let n = super::pixels(w, h)?;
    if gain.len() != n {
        return Err(Error::InvalidParameter { name: "nuc gain table length" });
    }
    if offset.len() != n {
        return Err(Error::InvalidParameter { name: "nuc offset table length" });
    }
    if let Some(b) = bad
        && b.size() != (w, h)
    {
        return Err(Error::SizeMismatch { expected: (w, h), got: b.size() });
    }
    // Pass 1: the mean of the corrected shutter frame over the valid pixels — each row summed
    // whole, then its few bad pixels taken out again (exact integer sums, so the same mean as
    // skipping them, without a map bit read per pixel).
    let (mut sum, mut count) = (0i64, 0u32);
    for (y, row) in shutter.rows().enumerate() {
        let (g, o) =
            (gain.get(y * w..(y + 1) * w).unwrap_or(&[]), offset.get(y * w..(y + 1) * w).unwrap_or(&[]));
        let mut row_sum = 0i64;
        for ((&s, &g), &o) in row.iter().zip(g).zip(o) {
            row_sum += i64::from(correct_unclamped(s, g, o));
        }
        count += w as u32;
        if let Some(b) = bad {
            for x in b.bad_in_row(y) {
                if let (Some(&s), Some(&g), Some(&o)) = (row.get(x), g.get(x), o.get(x)) {
                    row_sum -= i64::from(correct_unclamped(s, g, o));
                    count -= 1;
                }
            }
        }
        sum += row_sum;
    }
    if count == 0 {
        return Err(Error::InvalidParameter { name: "shutter frame (no valid pixel)" });
    }
    // Round half up: ⌊(2·sum + n) / (2n)⌋.
    let c = i64::from(count);
    let level = (2 * sum + c).div_euclid(2 * c) as i32;
    // Pass 2: each pixel's offset moves by its deviation from the level.
    let mut clamped = 0u32;
    for (y, row) in shutter.rows().enumerate() {
        let g = gain.get(y * w..(y + 1) * w).unwrap_or(&[]);
        let o = offset.get_mut(y * w..(y + 1) * w).unwrap_or(&mut []);
        for ((&s, &g), o) in row.iter().zip(g).zip(o.iter_mut()) {
            let new = i32::from(*o) + level - correct_unclamped(s, g, *o);
            let fit = new.clamp(i32::from(i16::MIN), i32::from(i16::MAX));
            clamped += u32::from(fit != new);
            *o = fit as i16;
        }
    }
    Ok(ShutterReport { level, pixels: count, clamped })
}
