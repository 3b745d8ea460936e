//! The AVX-512 form of the row loop (x86-64 hosts with AVX-512 F and BW): [`Lanes`] on sixteen
//! pixels × two bands (32 lanes of `i16`) for the loop of `simd.rs`. The flux's two 64-entry tables sit in four registers and
//! are read by `vpermi2w`, so a flux is nine operations (one multiply). The same values as the
//! portable loop, so the same bits (checked by `avx512_rows_equal_the_portable_rows` and
//! `table_and_avx512_equal_the_function_exhaustively`).

use super::flux::{FluxFn, SEGMENTS};
use super::row::RowCarry;
use super::simd::{Lanes, row_blocks as blocks};
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

impl Lanes for Flux {
    type V = __m512i;
    const WORDS: usize = 16;

    // SAFETY (every method): a `Flux` is built only by `Flux::new`, compiled for AVX-512 F and
    // BW, so the CPU has them.
    #[inline(always)]
    fn zero(&self) -> __m512i {
        // SAFETY: see above.
        unsafe { _mm512_setzero_si512() }
    }

    #[inline(always)]
    fn top(&self, w: i32) -> __m512i {
        // SAFETY: see above.
        unsafe { _mm512_maskz_set1_epi32(1 << 15, w) }
    }

    #[inline(always)]
    fn load(&self, s: &[i32]) -> __m512i {
        // SAFETY: see above.
        unsafe { load(s, 0) }.unwrap_or_else(|| self.zero())
    }

    #[inline(always)]
    fn store(&self, s: &mut [i32], at: usize, x: __m512i) -> Option<()> {
        // SAFETY: see above.
        unsafe { store(s, at, x) }
    }

    #[inline(always)]
    fn word(&self, x: __m512i, i: usize) -> i32 {
        let mut l = [0i32; 16];
        // SAFETY: see above; writes the 64 bytes of `l`.
        unsafe { _mm512_storeu_si512(l.as_mut_ptr().cast(), x) };
        l.get(i).copied().unwrap_or(0)
    }

    #[inline(always)]
    fn flux(&self, d: __m512i) -> __m512i {
        // SAFETY: see above.
        unsafe { self.apply(d) }
    }

    #[inline(always)]
    fn sub(&self, a: __m512i, b: __m512i) -> __m512i {
        // SAFETY: see above.
        unsafe { _mm512_sub_epi16(a, b) }
    }

    #[inline(always)]
    fn adds(&self, a: __m512i, b: __m512i) -> __m512i {
        // SAFETY: see above.
        unsafe { _mm512_adds_epi16(a, b) }
    }

    #[inline(always)]
    fn subs(&self, a: __m512i, b: __m512i) -> __m512i {
        // SAFETY: see above.
        unsafe { _mm512_subs_epi16(a, b) }
    }

    #[inline(always)]
    fn max0(&self, a: __m512i) -> __m512i {
        // SAFETY: see above.
        unsafe { _mm512_max_epi16(a, _mm512_setzero_si512()) }
    }

    #[inline(always)]
    fn up<const K: usize>(&self, prev: __m512i, cur: __m512i) -> __m512i {
        // SAFETY: see above.
        unsafe {
            match K {
                1 => _mm512_alignr_epi32::<15>(cur, prev),
                _ => _mm512_alignr_epi32::<14>(cur, prev),
            }
        }
    }
}

/// Runs the row loop of `Diffusion::row` (`simd.rs`) on whole blocks of sixteen pixels from
/// the start of the row, updating `carry`; returns the pixels done.
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
    blocks(&Flux::new(fx), p, q, north, out, carry)
}
