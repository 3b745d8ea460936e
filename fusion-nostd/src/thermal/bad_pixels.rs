//! Bad-pixel replacement: dead and hot pixels take a value from their valid neighbours.
//!
//! **The map.** One bit per pixel, 1 = bad; row-major, each row `⌈width/8⌉` bytes, pixel `x` in
//! bit `x mod 8` (least significant first) of byte `x / 8` — 32 KiB for a 512² array, 40 KiB
//! for 640 × 512 ([`bad_map_bytes`]). Bits past the width in a row's last byte must be 0.
//!
//! **The rule.** A bad pixel takes the median of its valid 8-neighbours (inside the frame, not
//! bad), read after the non-uniformity correction; with an even number of them the mean of the
//! two middle values, rounded half up. A bad pixel with no valid 8-neighbour (inside a cluster
//! of 3 × 3 or more, or a dead row next to another) takes the nearest valid pixel of its own
//! row, the left one when two are as near. A map where some bad pixel has neither is refused
//! ([`BadPixelMap::new`]): such a camera has lost whole rows and needs a new map, not a guess.
//!
//! Replacement reads only valid pixels, so its result does not depend on the order pixels are
//! replaced in: the whole frame in place, strips and single rows give the same bits.

use crate::error::Error;

/// Bytes of a bad-pixel map for a `width × height` array.
pub const fn bad_map_bytes(width: usize, height: usize) -> usize {
    width.div_ceil(8) * height
}

/// Where pixel `(x, y)` of a `width`-wide map lies: its byte and the bit within it.
#[inline]
pub const fn bit_of(width: usize, x: usize, y: usize) -> (usize, u32) {
    (y * width.div_ceil(8) + x / 8, (x % 8) as u32)
}

/// A validated bad-pixel map (see the module's documentation for the format and the rule).
#[derive(Debug, Clone, Copy)]
pub struct BadPixelMap<'a> {
    width: usize,
    height: usize,
    bits: &'a [u8],
    count: u32,
}

impl<'a> BadPixelMap<'a> {
    /// Checks and wraps a map: `Err` for a length other than [`bad_map_bytes`], bits set past a
    /// row's width, or a bad pixel with neither a valid 8-neighbour nor a valid pixel in its row.
    pub fn new(width: usize, height: usize, bits: &'a [u8]) -> Result<Self, Error> {
        super::pixels(width, height)?;
        if bits.len() != bad_map_bytes(width, height) {
            return Err(Error::InvalidParameter { name: "bad-pixel map length" });
        }
        let stride = width.div_ceil(8);
        if !width.is_multiple_of(8) {
            let spare = 0xffu8 << (width % 8);
            if bits.chunks_exact(stride).any(|r| r.last().is_some_and(|&b| b & spare != 0)) {
                return Err(Error::InvalidParameter { name: "bad-pixel map (bits past the row's width)" });
            }
        }
        let mut map = BadPixelMap { width, height, bits, count: 0 };
        let mut count = 0u32;
        for y in 0..height {
            let row_has_valid = (0..width).any(|x| !map.is_bad(x, y));
            for x in map.bad_in_row(y) {
                count += 1;
                if !row_has_valid && !map.has_valid_neighbour(x, y) {
                    return Err(Error::InvalidParameter {
                        name: "bad-pixel map (a bad pixel with no valid neighbour and no valid pixel in its row)",
                    });
                }
            }
        }
        map.count = count;
        Ok(map)
    }

    /// The array's size (width, height).
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Bad pixels in the map.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Whether pixel `(x, y)` is bad (`false` outside the array).
    #[inline]
    pub fn is_bad(&self, x: usize, y: usize) -> bool {
        if x >= self.width {
            return false;
        }
        let (i, k) = bit_of(self.width, x, y);
        self.bits.get(i).is_some_and(|&b| b >> k & 1 == 1)
    }

    /// The bad pixels' columns in row `y`, left to right (whole zero bytes skipped).
    pub fn bad_in_row(&self, y: usize) -> impl Iterator<Item = usize> + '_ {
        let stride = self.width.div_ceil(8);
        let row = self.bits.get(y * stride..(y + 1) * stride).unwrap_or(&[]);
        row.iter()
            .enumerate()
            .filter(|(_, b)| **b != 0)
            .flat_map(move |(i, &b)| (0..8).filter(move |k| b >> k & 1 == 1).map(move |k| i * 8 + k))
    }

    fn has_valid_neighbour(&self, x: usize, y: usize) -> bool {
        neighbours(x, y, self.width, self.height).any(|(u, v)| !self.is_bad(u, v))
    }
}

/// The 8-neighbours of `(x, y)` inside a `w × h` frame, row by row.
fn neighbours(x: usize, y: usize, w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    (-1isize..=1).flat_map(move |dy| {
        (-1isize..=1).filter_map(move |dx| {
            let (u, v) = (x.checked_add_signed(dx)?, y.checked_add_signed(dy)?);
            ((dx, dy) != (0, 0) && u < w && v < h).then_some((u, v))
        })
    })
}

/// The replacement value of bad pixel `(x, y)`: `value(u, v)` gives the corrected value of any
/// pixel of rows `y − 1 ..= y + 1` (`None` when that row is not at hand, as for the row above
/// the first). `None` when the pixel has no valid neighbour at hand and no valid pixel in its row.
pub(crate) fn replacement(
    map: &BadPixelMap<'_>,
    x: usize,
    y: usize,
    value: impl Fn(usize, usize) -> Option<u16>,
) -> Option<u16> {
    let mut v = [0u16; 8];
    let mut k = 0usize;
    for (u, w) in neighbours(x, y, map.width, map.height) {
        if !map.is_bad(u, w)
            && let (Some(s), Some(slot)) = (value(u, w), v.get_mut(k))
        {
            *slot = s;
            k += 1;
        }
    }
    if k > 0 {
        let v = v.get_mut(..k)?;
        v.sort_unstable();
        let hi = *v.get(k / 2)?;
        return Some(if k % 2 == 1 {
            hi
        } else {
            let lo = *v.get(k / 2 - 1)?;
            ((u32::from(lo) + u32::from(hi) + 1) >> 1) as u16
        });
    }
    // The nearest valid pixel of the row, left first.
    (1..map.width).find_map(|d| {
        let left = x.checked_sub(d).filter(|&u| !map.is_bad(u, y));
        let right = Some(x + d).filter(|&u| u < map.width && !map.is_bad(u, y));
        left.or(right).and_then(|u| value(u, y))
    })
}
