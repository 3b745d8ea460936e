//! The general separable rescalers: any size to any size, both filters.
//!
//! * [`rescale_integer`] (u8, u16): exact integer arithmetic. Each output is
//!   `N = Σ_y wy · Σ_x wx · src` over the two axes' integer weights, then divided by the
//!   product of the axes' denominators with the filter's rounding rule (cubic: ties to even,
//!   area: half up) and saturated. Area is exact (the weights are exact rationals); cubic
//!   uses Q14 weights from a Q16 phase, exact at factor 2 (so this path is bit-identical to
//!   the dedicated 2× kernels and to OpenCV there) and within ±1 level elsewhere.
//! * [`rescale_float`] (f32): the same taps with `f64`-computed weights rounded to `f32`,
//!   horizontal pass then vertical pass in `f32`, no saturation.
//!
//! These loops are written for clarity, not speed: they serve non-2× sizes and act as the
//! in-core oracle for the fast kernels.

use super::Filter;
use super::taps::AxisRule;
use crate::{FrameMut, FrameRef};

/// How an exact integer quotient is rounded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rounding {
    /// Round half to even (cubic, as `cvRound`).
    HalfEven,
    /// Round half up (area, as OpenCV's `(sum + 2) >> 2`).
    HalfUp,
}

impl Rounding {
    /// The rounding rule a filter uses on integer samples.
    pub(crate) fn of(filter: Filter) -> Self {
        match filter {
            Filter::Cubic => Rounding::HalfEven,
            Filter::Area => Rounding::HalfUp,
        }
    }

    /// `num / den` rounded by this rule (`den > 0`; a zero `den` gives 0, never a panic).
    #[inline]
    pub(crate) fn divide(self, num: i64, den: i64) -> i64 {
        if den <= 0 {
            return 0;
        }
        // Euclidean quotient and remainder by a divisor ≥ 1, which neither is zero nor
        // overflows (LLVM's AArch64 code kept a panic path behind `checked_div_euclid`).
        let (q, r) = (num / den, num % den);
        let (q, r) = if r < 0 { (q - 1, r + den) } else { (q, r) };
        let twice_r = 2 * r;
        let up = match self {
            Rounding::HalfUp => twice_r >= den,
            Rounding::HalfEven => twice_r > den || (twice_r == den && q & 1 == 1),
        };
        q + i64::from(up)
    }
}

/// An integer sample type of the exact path.
pub(crate) trait IntSample: Copy {
    const MAX: i64;
    fn to_i64(self) -> i64;
    fn from_saturated(v: i64) -> Self;
}

impl IntSample for u8 {
    const MAX: i64 = u8::MAX as i64;
    #[inline]
    fn to_i64(self) -> i64 {
        i64::from(self)
    }
    #[inline]
    fn from_saturated(v: i64) -> Self {
        v.clamp(0, <Self as IntSample>::MAX) as u8
    }
}

impl IntSample for u16 {
    const MAX: i64 = u16::MAX as i64;
    #[inline]
    fn to_i64(self) -> i64 {
        i64::from(self)
    }
    #[inline]
    fn from_saturated(v: i64) -> Self {
        v.clamp(0, <Self as IntSample>::MAX) as u16
    }
}

/// Exact integer rescale of `src` into `dst` (sizes already validated, any ratio).
pub(crate) fn rescale_integer<T: IntSample>(src: FrameRef<'_, T>, mut dst: FrameMut<'_, T>, filter: Filter) {
    let (sw, sh) = src.size();
    let (dw, dh) = dst.size();
    let rx = AxisRule::new(filter, sw, dw);
    let ry = AxisRule::new(filter, sh, dh);
    let den = rx.denominator() * ry.denominator();
    let rounding = Rounding::of(filter);
    for (y, out) in dst.rows_mut().enumerate() {
        for (x, px) in out.iter_mut().enumerate() {
            let mut n = 0i64;
            ry.for_each_tap_fixed(y, |sy, wy| {
                let row = src.row(sy);
                let mut h = 0i64;
                rx.for_each_tap_fixed(x, |sx, wx| {
                    h += wx * row.get(sx).map_or(0, |v| v.to_i64());
                });
                n += wy * h;
            });
            *px = T::from_saturated(rounding.divide(n, den));
        }
    }
}

/// `f32` rescale of `src` into `dst` (sizes validated, input finite, any ratio).
pub(crate) fn rescale_float(src: FrameRef<'_, f32>, mut dst: FrameMut<'_, f32>, filter: Filter) {
    let (sw, sh) = src.size();
    let (dw, dh) = dst.size();
    let rx = AxisRule::new(filter, sw, dw);
    let ry = AxisRule::new(filter, sh, dh);
    for (y, out) in dst.rows_mut().enumerate() {
        for (x, px) in out.iter_mut().enumerate() {
            let mut v = 0f32;
            ry.for_each_tap_float(y, |sy, wy| {
                let row = src.row(sy);
                let mut h = 0f32;
                rx.for_each_tap_float(x, |sx, wx| {
                    h += wx as f32 * row.get(sx).copied().unwrap_or(0.0);
                });
                v += wy as f32 * h;
            });
            *px = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_rules() {
        assert_eq!(Rounding::HalfEven.divide(5, 2), 2);
        assert_eq!(Rounding::HalfEven.divide(7, 2), 4);
        assert_eq!(Rounding::HalfEven.divide(-5, 2), -2);
        assert_eq!(Rounding::HalfEven.divide(-7, 2), -4);
        assert_eq!(Rounding::HalfUp.divide(5, 2), 3);
        assert_eq!(Rounding::HalfUp.divide(-5, 2), -2);
        assert_eq!(Rounding::HalfUp.divide(430, 4), 108);
        assert_eq!(Rounding::HalfEven.divide(9, 4), 2);
        assert_eq!(Rounding::HalfEven.divide(11, 4), 3);
    }
}
