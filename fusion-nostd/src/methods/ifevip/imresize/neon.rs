//! The 8-tap passes IFEVIP runs at every frame size in NEON (AArch64): the exact `i64` products
//! by `smull`/`smlal` (two per instruction), the same sums and the same rounding as
//! [`rows_n`](super::rows_n) and [`cols_n`](super::cols_n), so the same bits (the SIMD-forms
//! test under `qemu-aarch64`, the bit-exactness jobs of `fusion budget --target a53`).
//!
//! * Rows ([`dot8`]): one output's eight samples and weights in two registers each, four
//!   multiply-accumulates and a pairwise add.
//! * Columns ([`cols8`]): eight columns of an output row at a time, each tap's weight
//!   multiplying eight samples of its source row into four `i64x2` accumulators that start at
//!   the rounding half; the shift by 30 narrows to the low 32 bits (`shrn`), what
//!   [`finish`] keeps. The two forms IFEVIP runs: `u8` frame → [`Output::U8`] (sums below 2³⁹,
//!   so the narrowed value is the whole one and the clamp follows) and `i32` plane →
//!   [`Output::Same`].

use super::{Output, Taps, finish, row_n};
use crate::{FrameMut, FrameRef};
use core::arch::aarch64::*;

/// `Σ s·w` of eight samples and Q30 weights, exact.
#[inline(always)]
pub(super) fn dot8(seg: &[i32; 8], ws: &[i32; 8]) -> i64 {
    // SAFETY: NEON is part of every AArch64 target this module is compiled for; reads the 32
    // bytes of `seg` and of `ws`.
    unsafe {
        let (s0, s1) = (vld1q_s32(seg.as_ptr()), vld1q_s32(seg.as_ptr().add(4)));
        let (w0, w1) = (vld1q_s32(ws.as_ptr()), vld1q_s32(ws.as_ptr().add(4)));
        let a = vmlal_high_s32(vmull_s32(vget_low_s32(s0), vget_low_s32(w0)), s0, w0);
        let b = vmlal_high_s32(vmull_s32(vget_low_s32(s1), vget_low_s32(w1)), s1, w1);
        vaddvq_s64(vaddq_s64(a, b))
    }
}

/// A column pass source: eight samples of a row as two registers of `i32`.
pub(super) trait Lanes8: Copy + Into<i64> + Default {
    /// The eight samples `s[..8]` (the caller passes eight).
    fn load8(s: &[Self; 8]) -> [int32x4_t; 2];
    /// The output form this source's pass has in IFEVIP (`u8` → `U8`, `i32` → `Same`).
    const OUT: Output;
}

impl Lanes8 for u8 {
    #[inline(always)]
    fn load8(s: &[u8; 8]) -> [int32x4_t; 2] {
        // SAFETY: NEON (see above); reads the 8 bytes of `s`.
        unsafe {
            let w = vmovl_u8(vld1_u8(s.as_ptr()));
            [vreinterpretq_s32_u32(vmovl_u16(vget_low_u16(w))), vreinterpretq_s32_u32(vmovl_high_u16(w))]
        }
    }
    const OUT: Output = Output::U8;
}

impl Lanes8 for i32 {
    #[inline(always)]
    fn load8(s: &[i32; 8]) -> [int32x4_t; 2] {
        // SAFETY: NEON (see above); reads the 32 bytes of `s`.
        unsafe { [vld1q_s32(s.as_ptr()), vld1q_s32(s.as_ptr().add(4))] }
    }
    const OUT: Output = Output::Same;
}

/// The column pass with eight taps into `T::OUT`; `false` (nothing written) when a table row
/// reaches below the source (the portable pass pads with zeros there).
pub(super) fn cols8<T: Lanes8>(src: FrameRef<'_, T>, taps: &Taps<'_>, mut dst: FrameMut<'_, i32>) -> bool {
    let h = src.height();
    let rows = taps.table.chunks_exact(taps.stride.max(1));
    if rows.clone().take(dst.height()).any(|r| row_n::<8>(r).is_none_or(|(start, _)| start + 8 > h)) {
        return false;
    }
    let u8_out = matches!(T::OUT, Output::U8);
    for (d, row) in dst.rows_mut().zip(rows) {
        let Some((start, ws)) = row_n::<8>(row) else { continue };
        let src_rows: [&[T]; 8] = core::array::from_fn(|t| src.row(start + t));
        let mut x = 0;
        while x + 8 <= d.len() {
            let Some(o) = d.get_mut(x..x + 8).and_then(|o| <&mut [i32; 8]>::try_from(o).ok()) else { break };
            // SAFETY: NEON register operations; the store writes the 32 bytes of `o`.
            unsafe {
                let half = vdupq_n_s64(1 << (super::WEIGHT_BITS - 1));
                let mut acc = [half; 4];
                for (r, &w) in src_rows.iter().zip(ws) {
                    let Some(seg) = r.get(x..x + 8).and_then(|s| <&[T; 8]>::try_from(s).ok()) else {
                        continue;
                    };
                    let [a, b] = T::load8(seg);
                    acc[0] = vmlal_n_s32(acc[0], vget_low_s32(a), w);
                    acc[1] = vmlal_high_n_s32(acc[1], a, w);
                    acc[2] = vmlal_n_s32(acc[2], vget_low_s32(b), w);
                    acc[3] = vmlal_high_n_s32(acc[3], b, w);
                }
                let narrow = |lo: int64x2_t, hi: int64x2_t| {
                    let v = vcombine_s32(
                        vshrn_n_s64::<{ super::WEIGHT_BITS as i32 }>(lo),
                        vshrn_n_s64::<{ super::WEIGHT_BITS as i32 }>(hi),
                    );
                    if u8_out { vminq_s32(vmaxq_s32(v, vdupq_n_s32(0)), vdupq_n_s32(255)) } else { v }
                };
                vst1q_s32(o.as_mut_ptr(), narrow(acc[0], acc[1]));
                vst1q_s32(o.as_mut_ptr().add(4), narrow(acc[2], acc[3]));
            }
            x += 8;
        }
        for (k, o) in d.iter_mut().enumerate().skip(x) {
            let acc = src_rows
                .iter()
                .zip(ws)
                .fold(0i64, |acc, (r, &w)| acc + r.get(k).copied().unwrap_or_default().into() * i64::from(w));
            *o = if u8_out { finish::<true>(acc) } else { finish::<false>(acc) };
        }
    }
    true
}
