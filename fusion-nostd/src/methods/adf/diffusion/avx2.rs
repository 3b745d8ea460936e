//! The AVX2 form of the row loop (x86-64 hosts without AVX-512): [`Lanes`] on eight pixels ×
//! two bands (16 lanes of `i16`) for the loop of `simd.rs`, the fluxes read from the 128 KiB
//! table with `vpgatherdd`
//! (AVX2 has no register permute of 16-bit words to hold the 64 segments, and the arithmetic
//! form took 18 operations; this takes 7 and two gathers). The same values as the portable
//! loop, so the same bits (checked by `avx2_rows_equal_the_portable_rows` and
//! `table_and_avx512_equal_the_function_exhaustively`).

use super::simd::{Lanes, row_blocks as blocks};
use super::{RowCarry, TABLE_CENTRE, TABLE_ENTRIES};
use core::arch::x86_64::*;

/// Eight words at `s[at..at + 8]`.
#[target_feature(enable = "avx2")]
#[inline]
fn load(s: &[i32], at: usize) -> Option<__m256i> {
    let v: &[i32; 8] = s.get(at..at + 8)?.try_into().ok()?;
    // SAFETY: reads the 32 bytes of `v` (unaligned load).
    Some(unsafe { _mm256_loadu_si256(v.as_ptr().cast()) })
}

/// Stores eight words to `s[at..at + 8]`.
#[target_feature(enable = "avx2")]
#[inline]
fn store(s: &mut [i32], at: usize, x: __m256i) -> Option<()> {
    let v: &mut [i32; 8] = s.get_mut(at..at + 8)?.try_into().ok()?;
    // SAFETY: writes the 32 bytes of `v` (unaligned store).
    unsafe { _mm256_storeu_si256(v.as_mut_ptr().cast(), x) };
    Some(())
}

/// `[prev[8 − k..], cur[..8 − k]]` in words: `cur` shifted up by `k` words (`BYTES` =
/// 16 − 4k), the vacated words taken from the top of `prev`.
#[target_feature(enable = "avx2")]
#[inline]
fn shift_in<const BYTES: i32>(prev: __m256i, cur: __m256i) -> __m256i {
    _mm256_alignr_epi8::<BYTES>(cur, _mm256_permute2x128_si256::<0x21>(prev, cur))
}

/// The flux table as the gathers read it.
struct Flux {
    /// Entry `TABLE_CENTRE − 1`, as the base of 4-byte reads.
    base: *const i32,
    /// −32767 in every lane: the table reads −32768 as −32767.
    floor: __m256i,
}

impl Flux {
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(table: &[i16; TABLE_ENTRIES]) -> Self {
        Flux {
            base: table.as_ptr().wrapping_add(TABLE_CENTRE - 1).cast(),
            floor: _mm256_set1_epi32(-i32::from(i16::MAX)),
        }
    }

    /// The table's fluxes of sixteen 16-bit differences (both halves of eight words). A
    /// word's low half is sign-extended, its high half shifted down; each gather reads the
    /// four bytes of entries `∇ − 1` and `∇` (from entry `TABLE_CENTRE − 1`), whose high
    /// half is `F(∇)`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn apply(&self, d: __m256i) -> __m256i {
        let lo = _mm256_max_epi32(_mm256_srai_epi32::<16>(_mm256_slli_epi32::<16>(d)), self.floor);
        let hi = _mm256_max_epi32(_mm256_srai_epi32::<16>(d), self.floor);
        // SAFETY: every index is in −32767..=32767, so each read covers the entries
        // `TABLE_CENTRE − 1 + i` and `TABLE_CENTRE + i`, both in 0..TABLE_ENTRIES (the
        // table is a `[i16; TABLE_ENTRIES]`); `base` points into it.
        let (g_lo, g_hi) = unsafe {
            (_mm256_i32gather_epi32::<2>(self.base, lo), _mm256_i32gather_epi32::<2>(self.base, hi))
        };
        _mm256_blend_epi16::<0xAA>(_mm256_srli_epi32::<16>(g_lo), g_hi)
    }
}

/// [`Flux::apply`] on sixteen values (for the tests): the halves of eight words.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(test)]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn flux16(table: &[i16; TABLE_ENTRIES], x: [i16; 16]) -> [i16; 16] {
    let mut out = [0i16; 16];
    // SAFETY: reads the 32 bytes of `x`, writes the 32 bytes of `out`.
    unsafe {
        let v = _mm256_loadu_si256(x.as_ptr().cast());
        _mm256_storeu_si256(out.as_mut_ptr().cast(), Flux::new(table).apply(v));
    }
    out
}

impl Lanes for Flux {
    type V = __m256i;
    const WORDS: usize = 8;

    // SAFETY (every method): a `Flux` is built only by `Flux::new`, compiled for AVX2, so the
    // CPU has AVX2.
    #[inline(always)]
    fn zero(&self) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_setzero_si256() }
    }

    #[inline(always)]
    fn top(&self, w: i32) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_set_epi32(w, 0, 0, 0, 0, 0, 0, 0) }
    }

    #[inline(always)]
    fn load(&self, s: &[i32]) -> __m256i {
        // SAFETY: see above.
        unsafe { load(s, 0) }.unwrap_or_else(|| self.zero())
    }

    #[inline(always)]
    fn store(&self, s: &mut [i32], at: usize, x: __m256i) -> Option<()> {
        // SAFETY: see above.
        unsafe { store(s, at, x) }
    }

    #[inline(always)]
    fn word(&self, x: __m256i, i: usize) -> i32 {
        let mut l = [0i32; 8];
        // SAFETY: see above; writes the 32 bytes of `l`.
        unsafe { _mm256_storeu_si256(l.as_mut_ptr().cast(), x) };
        l.get(i).copied().unwrap_or(0)
    }

    #[inline(always)]
    fn flux(&self, d: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { self.apply(d) }
    }

    #[inline(always)]
    fn sub(&self, a: __m256i, b: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_sub_epi16(a, b) }
    }

    #[inline(always)]
    fn adds(&self, a: __m256i, b: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_adds_epi16(a, b) }
    }

    #[inline(always)]
    fn subs(&self, a: __m256i, b: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_subs_epi16(a, b) }
    }

    #[inline(always)]
    fn max0(&self, a: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_max_epi16(a, _mm256_setzero_si256()) }
    }

    #[inline(always)]
    fn up<const K: usize>(&self, prev: __m256i, cur: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe {
            match K {
                1 => shift_in::<12>(prev, cur),
                _ => shift_in::<8>(prev, cur),
            }
        }
    }
}

/// Runs the row loop of `Diffusion::row` (`simd.rs`) on whole blocks of eight pixels from the
/// start of the row with the flux `table`, updating `carry`; returns the pixels done (0 when
/// the table is short).
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn row_blocks(
    table: &[i16],
    p: &[i32],
    q: &[i32],
    north: &mut [i32],
    out: &mut [i32],
    carry: &mut RowCarry,
) -> usize {
    let Some(table) = table.get(..TABLE_ENTRIES).and_then(|t| <&[i16; TABLE_ENTRIES]>::try_from(t).ok())
    else {
        return 0;
    };
    blocks(&Flux::new(table), p, q, north, out, carry)
}
