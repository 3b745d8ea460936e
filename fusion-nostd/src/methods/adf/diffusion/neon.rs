//! The NEON form of the row loop (AArch64: Cortex-A53/A72 class, Arm hosts): [`Lanes`] on four
//! pixels × two bands (8 lanes of `i16`) for the loop of `simd.rs`. The flux function is held
//! as its 64-entry byte tables ([`ByteTables`]: the nodes, their high bytes when a node does
//! not fit an `i8`, the scaled rises), four registers each, read by `tbl` for two registers of
//! differences at once (their segment indices narrowed into the 16 bytes of one register):
//! `m = |x − c|` by one absolute difference (`sabd`; the states' differences are below 2¹⁵),
//! clamped to the limit, the segment `j = m >> k`, node and rise of segment `j`, one rounding
//! doubling multiply-high of `q = m mod 2ᵏ` (`sqrdmulh`: `⌊(q·s + 2¹⁴) / 2¹⁵⌋`, the portable
//! `mulhrs`; `q < 2⁹`, `|s| ≤ 2¹³`, so it never saturates), the sign of `x − c` back (`x < c`:
//! `(f ⊕ −1) + 1 = −f`). The same values as the portable loop, so the same bits (unit tests
//! `table_and_avx512_equal_the_function_exhaustively` and `simd_rows_equal_the_portable_rows`
//! under `qemu-aarch64` in CI; every fused frame of the emulated Cortex-A53 by
//! `fusion budget --target a53` against the host).

use super::flux::{ByteTables, SEGMENTS};
use super::row::RowCarry;
use super::simd::{Lanes, row_blocks as blocks};
use core::arch::aarch64::*;

/// The flux function in NEON registers ([`ByteTables`] read by `tbl`); `WIDE`: the nodes take
/// two bytes.
struct Flux<const WIDE: bool> {
    limit: uint16x8_t,
    /// `−k`: `ushl` by a negative count shifts right.
    shift: int16x8_t,
    /// `−max(k − 7, 0)`: the rise byte in a lane's high byte, shifted right (arithmetic) by
    /// `max(k − 7, 0)`, is the slope of the Q15 product.
    rise_shift: int16x8_t,
    /// `2ᵏ − 1`: `q = m mod 2ᵏ`.
    low_bits: int16x8_t,
    node_lo: int8x16x4_t,
    /// The nodes' high bytes (`WIDE` only).
    node_hi: int8x16x4_t,
    rise: int8x16x4_t,
}

/// A 64-entry byte table in four registers.
fn table(t: &[u8; SEGMENTS]) -> int8x16x4_t {
    let quarter = |q: usize| {
        let chunk: [u8; 16] = t.get(16 * q..16 * q + 16).and_then(|c| c.try_into().ok()).unwrap_or([0; 16]);
        // SAFETY: NEON (every AArch64 target this module is compiled for); reads the 16 bytes
        // of `chunk`.
        unsafe { vld1q_s8(chunk.as_ptr().cast()) }
    };
    int8x16x4_t(quarter(0), quarter(1), quarter(2), quarter(3))
}

impl<const WIDE: bool> Flux<WIDE> {
    fn new(t: &ByteTables, limit: i32, shift: u32) -> Self {
        // SAFETY: NEON register operations only.
        unsafe {
            Flux {
                limit: vdupq_n_u16(limit as u16),
                shift: vdupq_n_s16(-(shift as i16)),
                rise_shift: vdupq_n_s16(-(t.rise_shift as i16)),
                low_bits: vdupq_n_s16(((1u32 << shift) - 1) as i16),
                node_lo: table(&t.node_lo),
                node_hi: table(&t.node_hi.unwrap_or([0; SEGMENTS])),
                rise: table(&t.rise),
            }
        }
    }

    /// [`FluxFn::eval`](super::flux::FluxFn::eval) of `a − c` and `b − c` (differences of states,
    /// below 2¹⁵ in magnitude), eight lanes each.
    #[inline(always)]
    fn apply2(&self, [a, b]: [int16x8_t; 2], c: int16x8_t) -> [int16x8_t; 2] {
        // SAFETY: NEON register operations only.
        unsafe {
            let magnitude = |x: int16x8_t| vminq_u16(vreinterpretq_u16_s16(vabdq_s16(x, c)), self.limit);
            let (ma, mb) = (magnitude(a), magnitude(b));
            // The segments (below 64) as bytes: `a`'s in bytes 0..8, `b`'s in 8..16.
            let j = vuzp1q_u8(
                vreinterpretq_u8_u16(vshlq_u16(ma, self.shift)),
                vreinterpretq_u8_u16(vshlq_u16(mb, self.shift)),
            );
            let node = vqtbl4q_s8(self.node_lo, j);
            let (na, nb) = if WIDE {
                let hi = vqtbl4q_s8(self.node_hi, j);
                (vreinterpretq_s16_s8(vzip1q_s8(node, hi)), vreinterpretq_s16_s8(vzip2q_s8(node, hi)))
            } else {
                (vmovl_s8(vget_low_s8(node)), vmovl_high_s8(node))
            };
            let rise = vqtbl4q_s8(self.rise, j);
            let (ra, rb) = (vshll_n_s8::<8>(vget_low_s8(rise)), vshll_high_n_s8::<8>(rise));
            let flux = |x: int16x8_t, m: uint16x8_t, node: int16x8_t, rise: int16x8_t| {
                let q = vandq_s16(vreinterpretq_s16_u16(m), self.low_bits);
                let f = vaddq_s16(node, vqrdmulhq_s16(q, vshlq_s16(rise, self.rise_shift)));
                // All ones where `x < c`: `(f ⊕ −1) − (−1) = −f`.
                let negative = vreinterpretq_s16_u16(vcgtq_s16(c, x));
                vsubq_s16(veorq_s16(f, negative), negative)
            };
            [flux(a, ma, na, ra), flux(b, mb, nb, rb)]
        }
    }
}

/// [`FluxFn::eval`](super::flux::FluxFn::eval) by the NEON form on pairs of registers of eight
/// values `x − c`, into `out` (for the tests); `None` as
/// [`FluxFn::byte_tables`](super::flux::FluxFn::byte_tables).
#[cfg(test)]
pub(super) fn flux_pairs(
    fx: &super::flux::FluxFn,
    x: &[[[i16; 8]; 2]],
    c: [i16; 8],
    out: &mut [[[i16; 8]; 2]],
) -> Option<()> {
    let t = fx.byte_tables()?;
    let (narrow, wide) =
        (Flux::<false>::new(&t, fx.limit, fx.shift), Flux::<true>::new(&t, fx.limit, fx.shift));
    for (x, o) in x.iter().zip(out) {
        // SAFETY: NEON; reads the 16 bytes of each `x[i]` and of `c`, writes those of each `o[i]`.
        unsafe {
            let (c, x) = (vld1q_s16(c.as_ptr()), x.map(|x| vld1q_s16(x.as_ptr())));
            let f = if t.node_hi.is_some() { wide.apply2(x, c) } else { narrow.apply2(x, c) };
            for (o, f) in o.iter_mut().zip(f) {
                vst1q_s16(o.as_mut_ptr(), f);
            }
        }
    }
    Some(())
}

impl<const WIDE: bool> Lanes for Flux<WIDE> {
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
        self.apply2([d, d], self.zero())[0]
    }

    #[inline(always)]
    fn flux4(&self, [a, b, c, d]: [int16x8_t; 4], centre: int16x8_t) -> [int16x8_t; 4] {
        let [fa, fb] = self.apply2([a, b], centre);
        let [fc, fd] = self.apply2([c, d], centre);
        [fa, fb, fc, fd]
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
/// start of the row with the flux function's byte tables `t` (limit and shift `k` as
/// [`FluxFn`](super::flux::FluxFn)'s), updating `carry`; returns the pixels done.
pub(super) fn row_blocks(
    t: &ByteTables,
    (limit, shift): (i32, u32),
    p: &[i32],
    q: &[i32],
    north: &mut [i32],
    out: &mut [i32],
    carry: &mut RowCarry,
) -> usize {
    match t.node_hi {
        Some(_) => blocks(&Flux::<true>::new(t, limit, shift), p, q, north, out, carry),
        None => blocks(&Flux::<false>::new(t, limit, shift), p, q, north, out, carry),
    }
}
