//! The AVX-512 copy of the row loop (x86-64 hosts with AVX-512 F and BW): sixteen pixels × two
//! bands (32 lanes of `i16`) at a time. The flux's two 64-entry tables sit in four registers and
//! are read by `vpermi2w`, so a flux is nine operations (one multiply). The same values as the
//! portable loop, so the same bits (checked by `avx512_rows_equal_the_portable_rows` and
//! `table_and_avx512_equal_the_function_exhaustively`).

use super::{FluxFn, RowCarry, SEGMENTS, hi, lo, pack};
use core::arch::x86_64::*;

/// Sixteen words at `s[at..at + 16]`.
#[target_feature(enable = "avx512f,avx512bw")]
#[inline]
fn load(s: &[i32], at: usize) -> Option<__m512i> {
    let v: &[i32; 16] = s.get(at..at + 16)?.try_into().ok()?;
    // SAFETY: reads the 64 bytes of `v` (unaligned load).
    Some(unsafe { _mm512_loadu_si512(v.as_ptr().cast()) })
}

/// Stores sixteen words to `s[at..at + 16]`.
#[target_feature(enable = "avx512f,avx512bw")]
#[inline]
fn store(s: &mut [i32], at: usize, x: __m512i) -> Option<()> {
    let v: &mut [i32; 16] = s.get_mut(at..at + 16)?.try_into().ok()?;
    // SAFETY: writes the 64 bytes of `v` (unaligned store).
    unsafe { _mm512_storeu_si512(v.as_mut_ptr().cast(), x) };
    Some(())
}

/// Thirty-two `i16` as a register.
#[target_feature(enable = "avx512f,avx512bw")]
#[inline]
fn lanes(x: &[i16; 32]) -> __m512i {
    // SAFETY: reads the 64 bytes of `x`.
    unsafe { _mm512_loadu_si512(x.as_ptr().cast()) }
}

/// The constants of [`FluxFn`] in registers.
pub(super) struct Flux {
    limit: __m512i,
    shift: __m128i,
    base: [__m512i; 2],
    slope: [__m512i; 2],
}

/// Half `i` of a 64-entry table.
#[target_feature(enable = "avx512f,avx512bw")]
#[inline]
fn half(t: &[i16; SEGMENTS], i: usize) -> __m512i {
    let h: Option<&[i16; 32]> = t.get(32 * i..32 * i + 32).and_then(|h| h.try_into().ok());
    match h {
        Some(h) => lanes(h),
        None => _mm512_setzero_si512(),
    }
}

impl Flux {
    #[target_feature(enable = "avx512f,avx512bw")]
    #[inline]
    pub(super) fn new(fx: &FluxFn) -> Self {
        Flux {
            limit: _mm512_set1_epi16(fx.limit as i16),
            shift: _mm_cvtsi32_si128(fx.shift as i32),
            base: [half(&fx.base, 0), half(&fx.base, 1)],
            slope: [half(&fx.slope, 0), half(&fx.slope, 1)],
        }
    }

    /// [`FluxFn::eval`] on thirty-two differences in `−32767..=32767`, step by step as
    /// [`FluxFn::magnitude`] (`vpermi2w` reads the index's low six bits; `j ≤ 63`).
    #[target_feature(enable = "avx512f,avx512bw")]
    #[inline]
    pub(super) fn apply(&self, d: __m512i) -> __m512i {
        let m = _mm512_min_epu16(_mm512_abs_epi16(d), self.limit);
        let j = _mm512_srl_epi16(m, self.shift);
        let b = _mm512_permutex2var_epi16(self.base[0], j, self.base[1]);
        let s = _mm512_permutex2var_epi16(self.slope[0], j, self.slope[1]);
        let g = _mm512_add_epi16(b, _mm512_mulhrs_epi16(m, s));
        _mm512_mask_sub_epi16(g, _mm512_movepi16_mask(d), _mm512_setzero_si512(), g)
    }
}

/// [`Flux::apply`] on thirty-two values (for the tests).
///
/// # Safety
/// The CPU must support AVX-512 F and BW.
#[cfg(test)]
#[target_feature(enable = "avx512f,avx512bw")]
pub(super) unsafe fn flux32(fx: &FluxFn, x: [i16; 32]) -> [i16; 32] {
    let flux = Flux::new(fx);
    let mut out = [0i16; 32];
    // SAFETY: writes the 64 bytes of `out`.
    unsafe { _mm512_storeu_si512(out.as_mut_ptr().cast(), flux.apply(lanes(&x))) };
    out
}

/// Runs the row loop of `Diffusion::row` on whole blocks of sixteen pixels from the start of
/// the row, updating `carry`; returns the pixels done.
///
/// # Safety
/// The CPU must support AVX-512 F and BW.
#[target_feature(enable = "avx512f,avx512bw")]
pub(super) unsafe fn row_blocks(
    fx: &FluxFn,
    p: &[i32],
    q: &[i32],
    north: &mut [i32],
    out: &mut [i32],
    carry: &mut RowCarry,
) -> usize {
    const TOP: __mmask16 = 1 << 15;
    let flux = Flux::new(fx);
    let zero = _mm512_setzero_si512();
    // Word 15 holds the carried value; the other words (and `v_prev`) are 0, so that the
    // first block writes the unused `north[0]` exactly as the portable loop does.
    let mut h_prev = _mm512_maskz_set1_epi32(TOP, carry.h_prev);
    let mut v_prev = zero;
    let mut dr_prev = _mm512_maskz_set1_epi32(TOP, carry.dr_prev);
    let mut x = 0;
    while x + 16 <= out.len() {
        let (Some(pc), Some(pr), Some(ql), Some(qc), Some(qr), Some(n_here)) =
            (load(p, x + 1), load(p, x + 2), load(q, x), load(q, x + 1), load(q, x + 2), load(north, x + 1))
        else {
            break;
        };
        let h = flux.apply(_mm512_sub_epi16(pr, pc));
        let v = flux.apply(_mm512_sub_epi16(qc, pc));
        let dr = flux.apply(_mm512_sub_epi16(qr, pc));
        let dl = flux.apply(_mm512_sub_epi16(ql, pc));
        // `[prev[16 − k..], cur[..16 − k]]`: `cur` moved up by k words.
        let west = _mm512_alignr_epi32::<15>(h, h_prev);
        let t = _mm512_subs_epi16(_mm512_adds_epi16(h, v), west);
        let s = _mm512_subs_epi16(_mm512_adds_epi16(dr, dl), n_here);
        let step = _mm512_adds_epi16(_mm512_adds_epi16(t, t), s);
        let next = _mm512_max_epi16(_mm512_adds_epi16(pc, step), zero);
        // The north sums of the row below at x − 1 .. x + 14 (pixel indices 0-based):
        // 2·v(k) + dr(k − 1) + dl(k + 1).
        let v_up = _mm512_alignr_epi32::<15>(v, v_prev);
        let dr_up = _mm512_alignr_epi32::<14>(dr, dr_prev);
        let below = _mm512_adds_epi16(_mm512_adds_epi16(_mm512_adds_epi16(v_up, v_up), dr_up), dl);
        if store(out, x, next).is_none() || store(north, x, below).is_none() {
            break;
        }
        (h_prev, v_prev, dr_prev) = (h, v, dr);
        x += 16;
    }
    if x > 0 {
        let word = |a: __m512i, i: usize| {
            let mut l = [0i32; 16];
            // SAFETY: writes the 64 bytes of `l`.
            unsafe { _mm512_storeu_si512(l.as_mut_ptr().cast(), a) };
            l.get(i).copied().unwrap_or(0)
        };
        // The last whole block's fluxes (what the next block would take as `*_prev`).
        let (v15, dr14) = (word(v_prev, 15), word(dr_prev, 14));
        let partial = |f: fn(i32) -> i32| 2 * f(v15) + f(dr14);
        *carry = RowCarry {
            h_prev: word(h_prev, 15),
            dr_prev: word(dr_prev, 15),
            partial: pack(partial(lo), partial(hi)),
        };
    }
    x
}
