//! The NEON form of the row loop (AArch64: Cortex-A53/A72 class, Arm hosts): [`Lanes`] on four
//! pixels × two bands (8 lanes of `i16`) for the loop of `simd.rs`. The flux function's two
//! 64-entry tables (base and slope, 128 bytes each) sit in eight registers and are read with
//! `tbl`/`tbx` on the bytes of each entry, so a flux is [`FluxFn::magnitude`] step by step in
//! registers, as the AVX-512 form does with `vpermi2w`: `|∇|` clamped to the limit, the segment
//! `j = m >> k`, base and slope of segment `j`, one rounding doubling multiply-high (`sqrdmulh`:
//! `⌊(m·s + 2¹⁴) / 2¹⁵⌋`, the portable `mulhrs`; `m ≤ 32767`, `|s| ≤ 2¹³`, so it never
//! saturates), the sign of `∇` back. The same values as the portable loop, so the same bits
//! (checked on the emulated Cortex-A53 by `fusion budget --target a53` against the host).

use super::simd::{Lanes, row_blocks as blocks};
use super::{FluxFn, RowCarry, SEGMENTS};
use core::arch::aarch64::*;

/// A 64-entry `i16` table as two 64-byte halves for `tbl`/`tbx` (entries 0–31 and 32–63,
/// little-endian bytes).
#[derive(Clone, Copy)]
struct Table([uint8x16x4_t; 2]);

impl Table {
    fn new(t: &[i16; SEGMENTS]) -> Self {
        let mut bytes = [0u8; 2 * SEGMENTS];
        for (b, v) in bytes.chunks_exact_mut(2).zip(t) {
            b.copy_from_slice(&v.to_le_bytes());
        }
        let half = |h: usize| {
            let quarter = |q: usize| {
                let at = 64 * h + 16 * q;
                let chunk: [u8; 16] =
                    bytes.get(at..at + 16).and_then(|c| c.try_into().ok()).unwrap_or([0; 16]);
                // SAFETY: reads the 16 bytes of `chunk`.
                unsafe { vld1q_u8(chunk.as_ptr()) }
            };
            uint8x16x4_t(quarter(0), quarter(1), quarter(2), quarter(3))
        };
        Table([half(0), half(1)])
    }

    /// Entry `j` of every 16-bit lane (`j` in 0..64): the byte indices `2j` and `2j + 1`, the
    /// first half by `tbl` (indices ≥ 64 give 0), the second by `tbx` on the index less 64
    /// (indices below 64 wrap past 191 and keep the first half's byte).
    #[inline(always)]
    fn lookup(&self, j: uint16x8_t) -> int16x8_t {
        // SAFETY: NEON is part of every AArch64 target this module is compiled for.
        unsafe {
            let idx = vreinterpretq_u8_u16(vmlaq_n_u16(vdupq_n_u16(0x0100), j, 0x0202));
            let lo = vqtbl4q_u8(self.0[0], idx);
            let both = vqtbx4q_u8(lo, self.0[1], vsubq_u8(idx, vdupq_n_u8(64)));
            vreinterpretq_s16_u8(both)
        }
    }
}

/// The constants of [`FluxFn`] in registers.
pub(super) struct Flux {
    limit: uint16x8_t,
    /// `−k`: `ushl` by a negative count shifts right.
    shift: int16x8_t,
    base: Table,
    slope: Table,
}

impl Flux {
    pub(super) fn new(fx: &FluxFn) -> Self {
        // SAFETY: NEON is part of every AArch64 target this module is compiled for.
        unsafe {
            Flux {
                limit: vdupq_n_u16(fx.limit as u16),
                shift: vdupq_n_s16(-(fx.shift as i16)),
                base: Table::new(&fx.base),
                slope: Table::new(&fx.slope),
            }
        }
    }

    /// [`FluxFn::eval`] on eight differences.
    #[inline(always)]
    fn apply(&self, d: int16x8_t) -> int16x8_t {
        // SAFETY: NEON is part of every AArch64 target this module is compiled for.
        unsafe {
            // |−32768| is 0x8000 as u16, clamped to the limit like −32767's.
            let m = vminq_u16(vreinterpretq_u16_s16(vabsq_s16(d)), self.limit);
            let j = vshlq_u16(m, self.shift);
            let m = vreinterpretq_s16_u16(m);
            let g = vaddq_s16(self.base.lookup(j), vqrdmulhq_s16(m, self.slope.lookup(j)));
            vbslq_s16(vcltzq_s16(d), vnegq_s16(g), g)
        }
    }
}

impl Lanes for Flux {
    type V = int16x8_t;
    const WORDS: usize = 4;

    // SAFETY (every method): NEON is part of every AArch64 target this module is compiled for
    // (`cfg(target_feature = "neon")`).
    #[inline(always)]
    fn zero(&self) -> int16x8_t {
        // SAFETY: see above.
        unsafe { vdupq_n_s16(0) }
    }

    #[inline(always)]
    fn top(&self, w: i32) -> int16x8_t {
        // SAFETY: see above.
        unsafe { vreinterpretq_s16_s32(vsetq_lane_s32::<3>(w, vdupq_n_s32(0))) }
    }

    #[inline(always)]
    fn load(&self, s: &[i32]) -> int16x8_t {
        match s.get(..4).and_then(|v| <&[i32; 4]>::try_from(v).ok()) {
            // SAFETY: see above; reads the 16 bytes of `v`.
            Some(v) => unsafe { vreinterpretq_s16_s32(vld1q_s32(v.as_ptr())) },
            None => self.zero(),
        }
    }

    #[inline(always)]
    fn store(&self, s: &mut [i32], at: usize, x: int16x8_t) -> Option<()> {
        let v: &mut [i32; 4] = s.get_mut(at..at + 4)?.try_into().ok()?;
        // SAFETY: see above; writes the 16 bytes of `v`.
        unsafe { vst1q_s32(v.as_mut_ptr(), vreinterpretq_s32_s16(x)) };
        Some(())
    }

    #[inline(always)]
    fn word(&self, x: int16x8_t, i: usize) -> i32 {
        let mut l = [0i32; 4];
        // SAFETY: see above; writes the 16 bytes of `l`.
        unsafe { vst1q_s32(l.as_mut_ptr(), vreinterpretq_s32_s16(x)) };
        l.get(i).copied().unwrap_or(0)
    }

    #[inline(always)]
    fn flux(&self, d: int16x8_t) -> int16x8_t {
        self.apply(d)
    }

    #[inline(always)]
    fn sub(&self, a: int16x8_t, b: int16x8_t) -> int16x8_t {
        // SAFETY: see above.
        unsafe { vsubq_s16(a, b) }
    }

    #[inline(always)]
    fn adds(&self, a: int16x8_t, b: int16x8_t) -> int16x8_t {
        // SAFETY: see above.
        unsafe { vqaddq_s16(a, b) }
    }

    #[inline(always)]
    fn subs(&self, a: int16x8_t, b: int16x8_t) -> int16x8_t {
        // SAFETY: see above.
        unsafe { vqsubq_s16(a, b) }
    }

    #[inline(always)]
    fn max0(&self, a: int16x8_t) -> int16x8_t {
        // SAFETY: see above.
        unsafe { vmaxq_s16(a, vdupq_n_s16(0)) }
    }

    #[inline(always)]
    fn up<const K: usize>(&self, prev: int16x8_t, cur: int16x8_t) -> int16x8_t {
        // SAFETY: see above.
        unsafe {
            let (p, c) = (vreinterpretq_s32_s16(prev), vreinterpretq_s32_s16(cur));
            vreinterpretq_s16_s32(match K {
                1 => vextq_s32::<3>(p, c),
                _ => vextq_s32::<2>(p, c),
            })
        }
    }
}

/// Runs the row loop of `Diffusion::row` (`simd.rs`) on whole blocks of four pixels from the
/// start of the row, updating `carry`; returns the pixels done.
pub(super) fn row_blocks(
    fx: &FluxFn,
    p: &[i32],
    q: &[i32],
    north: &mut [i32],
    out: &mut [i32],
    carry: &mut RowCarry,
) -> usize {
    blocks(&Flux::new(fx), p, q, north, out, carry)
}
