//! The 8-tap row pass of `i32` planes on x86-64 with AVX2 (IFEVIP's passes at 1024² all have
//! 8 taps): `vpmuldq` forms the exact `i64` products four at a time, four outputs are reduced
//! together. The same sums, hence the same bits, as [`rows_n`] (test
//! `avx2_rows_equal_portable_rows`).

use super::{Taps, WEIGHT_BITS, finish, row_n};
use crate::{FrameMut, FrameRef};
use core::arch::x86_64::*;

#[target_feature(enable = "avx2")]
#[inline]
fn load8(s: &[i32; 8]) -> __m256i {
    // SAFETY: `s` is exactly 32 readable bytes; unaligned load.
    unsafe { _mm256_loadu_si256(s.as_ptr().cast()) }
}

/// The 8 products `s·w` (exact, `i64`) summed pairwise into 4 lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn products(s: &[i32; 8], w: &[i32; 8]) -> __m256i {
    let (s, w) = (load8(s), load8(w));
    let even = _mm256_mul_epi32(s, w);
    let odd = _mm256_mul_epi32(_mm256_srli_epi64::<32>(s), _mm256_srli_epi64::<32>(w));
    _mm256_add_epi64(even, odd)
}

#[target_feature(enable = "avx2")]
pub(super) fn rows8<const U8: bool>(src: FrameRef<'_, i32>, taps: &Taps<'_>, mut dst: FrameMut<'_, i32>) {
    let half = _mm256_set1_epi64x(1 << (WEIGHT_BITS - 1));
    let low_words = _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0);
    for (s, d) in src.rows().zip(dst.rows_mut()) {
        let mut table = taps.table.chunks_exact(taps.stride.max(1));
        let sum = |row: Option<&[i32]>| {
            row.and_then(row_n::<8>)
                .and_then(|(start, ws)| Some(products(s.get(start..)?.first_chunk::<8>()?, ws)))
                .unwrap_or(_mm256_setzero_si256())
        };
        let (quads, tail) = d.as_chunks_mut::<4>();
        for quad in quads {
            let [s0, s1, s2, s3] = [(); 4].map(|_| sum(table.next()));
            // Lane i of `total` = Σ of the four partials of s_i.
            let a = _mm256_add_epi64(_mm256_unpacklo_epi64(s0, s1), _mm256_unpackhi_epi64(s0, s1));
            let b = _mm256_add_epi64(_mm256_unpacklo_epi64(s2, s3), _mm256_unpackhi_epi64(s2, s3));
            let total = _mm256_add_epi64(
                _mm256_permute2x128_si256::<0x20>(a, b),
                _mm256_permute2x128_si256::<0x31>(a, b),
            );
            // (Σ + 2²⁹) >> 30: the low 32 bits of a logical shift are the arithmetic ones
            // (every result fits an i32, see `finish`).
            let r = _mm256_srli_epi64::<{ WEIGHT_BITS as i32 }>(_mm256_add_epi64(total, half));
            let mut v = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(r, low_words));
            if U8 {
                v = _mm_min_epi32(_mm_max_epi32(v, _mm_setzero_si128()), _mm_set1_epi32(255));
            }
            let mut out = [0i32; 4];
            // SAFETY: `out` is 16 writable bytes; unaligned store.
            unsafe { _mm_storeu_si128(out.as_mut_ptr().cast(), v) };
            *quad = out;
        }
        for o in tail {
            let acc = table
                .next()
                .and_then(row_n::<8>)
                .and_then(|(start, ws)| Some(super::dot(s.get(start..)?.first_chunk::<8>()?, ws)))
                .unwrap_or(0);
            *o = finish::<U8>(acc);
        }
    }
}
