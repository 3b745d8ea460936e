//! The remap kernel: one output pixel from the source at a fixed-point map position, as
//! OpenCV's `remap` computes it for a `CV_16SC2` + `CV_16UC1` map (`remapBilinear`,
//! `remapBicubic`; single channel).
//!
//! * **Linear, 8-bit**: Q15 integer weights ([`super::tables::LINEAR_Q15`]),
//!   `(Σ wᵢ·sᵢ + 2¹⁴) >> 15`, saturated.
//! * **Linear, 16-bit** and **cubic, both depths**: `f32` weights, the products summed in `f32`
//!   in OpenCV's order (for cubic: each row's four products left to right, the rows added top
//!   to bottom), rounded half to even and saturated.
//! * **Border pixels** (a neighbour outside the source): `Constant(v)` gives `v` when the
//!   whole neighbourhood lies outside, otherwise the missing neighbours count as `v` (linear:
//!   in place; cubic: the sum starts at `v` and adds `(sᵢ − v)·wᵢ` for the neighbours inside,
//!   in OpenCV's order); `Replicate` clamps the neighbours' coordinates into the source.

use super::tables::{CUBIC_F32, LINEAR_F32, LINEAR_Q15, round_even};
use crate::frame::FrameRef;

/// A sample type the kernel takes: 8- or 16-bit.
pub trait RemapSample: Copy + sealed::Sealed {
    /// The largest value.
    const MAX: u32;
    /// The value as `u32`.
    fn get(self) -> u32;
    /// `v` (at most [`RemapSample::MAX`]).
    fn put(v: u32) -> Self;
    /// Linear interpolation at the sub-pixel index `frac` of the four neighbours (top-left,
    /// top-right, bottom-left, bottom-right).
    fn linear(v: [u32; 4], frac: usize) -> Self;
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for u8 {}
    impl Sealed for u16 {}
}

/// `cvRound` then `saturate_cast` of an `f32` sum to `0..=max`.
#[inline]
fn cast_f32(sum: f32, max: u32) -> u32 {
    // Clamping first changes no saturated result and keeps the rounding trick in range.
    let clamped = if sum < -1.0 {
        -1.0
    } else if sum > max as f32 + 1.0 {
        max as f32 + 1.0
    } else {
        sum
    };
    let r = round_even(clamped);
    if r <= 0.0 {
        0
    } else if r >= max as f32 {
        max
    } else {
        r as u32
    }
}

impl RemapSample for u8 {
    const MAX: u32 = 255;
    #[inline]
    fn get(self) -> u32 {
        u32::from(self)
    }
    #[inline]
    fn put(v: u32) -> Self {
        v.min(255) as u8
    }
    #[inline]
    fn linear(v: [u32; 4], frac: usize) -> Self {
        let w = LINEAR_Q15.get(frac & 1023).copied().unwrap_or([0; 4]);
        let sum = v[0] as i32 * i32::from(w[0])
            + v[1] as i32 * i32::from(w[1])
            + v[2] as i32 * i32::from(w[2])
            + v[3] as i32 * i32::from(w[3]);
        // Weights are non-negative: the sum is too.
        ((sum + (1 << 14)) >> 15).clamp(0, 255) as u8
    }
}

impl RemapSample for u16 {
    const MAX: u32 = 65_535;
    #[inline]
    fn get(self) -> u32 {
        u32::from(self)
    }
    #[inline]
    fn put(v: u32) -> Self {
        v.min(65_535) as u16
    }
    #[inline]
    fn linear(v: [u32; 4], frac: usize) -> Self {
        let w = LINEAR_F32.get(frac & 1023).copied().unwrap_or([0.0; 4]);
        let sum = v[0] as f32 * w[0] + v[1] as f32 * w[1] + v[2] as f32 * w[2] + v[3] as f32 * w[3];
        cast_f32(sum, 65_535) as u16
    }
}

/// How a neighbour outside the source is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Border {
    /// Outside pixels have this value (saturated to the sample type, as OpenCV's
    /// `BORDER_CONSTANT` with `borderValue`).
    Constant(u16),
    /// Outside coordinates are clamped into the source (`BORDER_REPLICATE`).
    Replicate,
}

/// The constant a border reads outside the source, saturated to `T` (0 for `Replicate`, whose
/// neighbours are never outside).
#[inline]
fn constant_of<T: RemapSample>(border: Border) -> u32 {
    match border {
        Border::Constant(v) => T::put(u32::from(v)).get(),
        Border::Replicate => 0,
    }
}

/// `p` mapped into `0..n` by the border rule: `None` for a constant border's outside pixel.
#[inline]
fn border_index(p: isize, n: usize, border: Border) -> Option<usize> {
    if p >= 0 && (p as usize) < n {
        Some(p as usize)
    } else {
        match border {
            Border::Constant(_) => None,
            Border::Replicate => Some(if p < 0 { 0 } else { n - 1 }),
        }
    }
}

/// One output pixel by linear interpolation at the integer position `(sx, sy)` (the map's
/// `xy`) and sub-pixel index `frac` (`fy·32 + fx`).
#[inline]
pub(crate) fn linear_at<T: RemapSample>(
    src: &FrameRef<'_, T>,
    sx: isize,
    sy: isize,
    frac: usize,
    border: Border,
) -> T {
    let (w, h) = src.size();
    let at = |x: usize, y: usize| src.row(y).get(x).map_or(0, |v| v.get());
    if sx >= 0 && sy >= 0 && (sx as usize) + 1 < w && (sy as usize) + 1 < h {
        let (x, y) = (sx as usize, sy as usize);
        if let (Some(&[a, b]), Some(&[c, d])) = (src.row(y).get(x..x + 2), src.row(y + 1).get(x..x + 2)) {
            return T::linear([a.get(), b.get(), c.get(), d.get()], frac);
        }
    }
    let cval = constant_of::<T>(border);
    if matches!(border, Border::Constant(_))
        && (sx >= w as isize || sx + 1 < 0 || sy >= h as isize || sy + 1 < 0)
    {
        return T::put(cval);
    }
    let get = |x: isize, y: isize| match (border_index(x, w, border), border_index(y, h, border)) {
        (Some(x), Some(y)) => at(x, y),
        _ => cval,
    };
    T::linear([get(sx, sy), get(sx + 1, sy), get(sx, sy + 1), get(sx + 1, sy + 1)], frac)
}

/// One output pixel by cubic interpolation: the 4 × 4 neighbourhood from `(sx − 1, sy − 1)`.
#[inline]
pub(crate) fn cubic_at<T: RemapSample>(
    src: &FrameRef<'_, T>,
    sx: isize,
    sy: isize,
    frac: usize,
    border: Border,
) -> T {
    let (w, h) = src.size();
    let wt = CUBIC_F32.get(frac & 1023).copied().unwrap_or([0.0; 16]);
    let (x0, y0) = (sx - 1, sy - 1);
    if x0 >= 0 && y0 >= 0 && (x0 as usize) + 3 < w && (y0 as usize) + 3 < h {
        let (x0, y0) = (x0 as usize, y0 as usize);
        let mut sum = 0.0f32;
        for (r, weights) in wt.chunks_exact(4).enumerate() {
            let row = src.row(y0 + r).get(x0..x0 + 4).unwrap_or(&[]);
            let mut part = 0.0f32;
            for (c, (s, &k)) in row.iter().zip(weights).enumerate() {
                let p = s.get() as f32 * k;
                part = if c == 0 { p } else { part + p };
            }
            sum = if r == 0 { part } else { sum + part };
        }
        return T::put(cast_f32(sum, T::MAX));
    }
    let cval = constant_of::<T>(border);
    if matches!(border, Border::Constant(_))
        && (x0 >= w as isize || x0 + 4 <= 0 || y0 >= h as isize || y0 + 4 <= 0)
    {
        return T::put(cval);
    }
    let cv = cval as f32;
    let mut sum = cv;
    for (r, weights) in wt.chunks_exact(4).enumerate() {
        let Some(y) = border_index(y0 + r as isize, h, border) else { continue };
        let row = src.row(y);
        for (c, &k) in weights.iter().enumerate() {
            if let Some(x) = border_index(x0 + c as isize, w, border) {
                let s = row.get(x).map_or(0.0, |v| v.get() as f32);
                sum += (s - cv) * k;
            }
        }
    }
    T::put(cast_f32(sum, T::MAX))
}
