//! The AVX2 copy of the row loop (x86-64 hosts without AVX-512): eight pixels × two bands
//! (16 lanes of `i16`) at a time, the fluxes read from the 128 KiB table with `vpgatherdd`
//! (AVX2 has no register permute of 16-bit words to hold the 64 segments, and the arithmetic
//! form took 18 operations; this takes 7 and two gathers). The same values as the portable
//! loop, so the same bits (checked by `avx2_rows_equal_the_portable_rows` and
//! `table_and_avx512_equal_the_function_exhaustively`).

use super::{RowCarry, TABLE_CENTRE, TABLE_ENTRIES, hi, lo, pack};
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

/// Runs the row loop of `Diffusion::row` on whole blocks of eight pixels from the start of
/// the row with the flux `table`, updating `carry`; returns the pixels done (0 when the
/// table is short).
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
    let flux = Flux::new(table);
    let zero = _mm256_setzero_si256();
    let mut h_prev = _mm256_set_epi32(carry.h_prev, 0, 0, 0, 0, 0, 0, 0);
    let mut v_prev = zero;
    // Word 7 holds the carried value; the other words (and `v_prev`) are 0, so that the
    // first block writes the unused `north[0]` exactly as the portable loop does.
    let mut dr_prev = _mm256_set_epi32(carry.dr_prev, 0, 0, 0, 0, 0, 0, 0);
    let mut x = 0;
    while x + 8 <= out.len() {
        let (Some(pc), Some(pr), Some(ql), Some(qc), Some(qr), Some(n_here)) =
            (load(p, x + 1), load(p, x + 2), load(q, x), load(q, x + 1), load(q, x + 2), load(north, x + 1))
        else {
            break;
        };
        let h = flux.apply(_mm256_sub_epi16(pr, pc));
        let v = flux.apply(_mm256_sub_epi16(qc, pc));
        let dr = flux.apply(_mm256_sub_epi16(qr, pc));
        let dl = flux.apply(_mm256_sub_epi16(ql, pc));
        let west = shift_in::<12>(h_prev, h);
        let t = _mm256_subs_epi16(_mm256_adds_epi16(h, v), west);
        let s = _mm256_subs_epi16(_mm256_adds_epi16(dr, dl), n_here);
        let step = _mm256_adds_epi16(_mm256_adds_epi16(t, t), s);
        let next = _mm256_max_epi16(_mm256_adds_epi16(pc, step), zero);
        // The north sums of the row below at x − 1 .. x + 6 (pixel indices 0-based):
        // 2·v(k) + dr(k − 1) + dl(k + 1).
        let v_up = shift_in::<12>(v_prev, v);
        let dr_up = shift_in::<8>(dr_prev, dr);
        let below = _mm256_adds_epi16(_mm256_adds_epi16(_mm256_adds_epi16(v_up, v_up), dr_up), dl);
        if store(out, x, next).is_none() || store(north, x, below).is_none() {
            break;
        }
        (h_prev, v_prev, dr_prev) = (h, v, dr);
        x += 8;
    }
    if x > 0 {
        let word = |a: __m256i, i: usize| {
            let mut l = [0i32; 8];
            // SAFETY: writes the 32 bytes of `l`.
            unsafe { _mm256_storeu_si256(l.as_mut_ptr().cast(), a) };
            l.get(i).copied().unwrap_or(0)
        };
        // The last whole block's fluxes (what the next block would take as `*_prev`).
        let (v7, dr6) = (word(v_prev, 7), word(dr_prev, 6));
        let partial = |f: fn(i32) -> i32| 2 * f(v7) + f(dr6);
        *carry = RowCarry {
            h_prev: word(h_prev, 7),
            dr_prev: word(dr_prev, 7),
            partial: pack(partial(lo), partial(hi)),
        };
    }
    x
}
