//! The AVX2 form of the row loop (x86-64 hosts without AVX-512): [`Lanes`] on eight pixels ×
//! two bands (16 lanes of `i16`) for the loop of `simd.rs`. AVX2 has no permute of 16-bit words
//! over 64 entries (AVX-512's `vpermi2w`), so the flux function's 64 segments are held as three
//! 64-entry byte tables (the nodes' low and high bytes, the rises) of four registers each, read
//! with `vpshufb` and three blends per table: 12 shuffles and 10 blends per 16 fluxes, against
//! two `vpgatherdd` of the 128 KiB table before (the diffusion at 1024² 34–35 ms instead of
//! 57–76 ms on an AMD EPYC with AVX2, BENCHMARKS.md). The same values as the portable loop, so the same bits (checked by
//! `avx2_rows_equal_the_portable_rows` and `table_and_avx512_equal_the_function_exhaustively`).

use super::simd::{Lanes, row_blocks as blocks};
use super::{FluxFn, RowCarry, SEGMENTS};
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

/// A 64-entry byte table as four 16-byte quarters, each in both 128-bit halves (`vpshufb`
/// looks up within a half).
#[derive(Clone, Copy)]
struct Bytes([__m256i; 4]);

impl Bytes {
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(t: &[u8; SEGMENTS]) -> Self {
        Bytes(core::array::from_fn(|q| {
            let quarter: [u8; 16] =
                t.get(16 * q..16 * q + 16).and_then(|c| c.try_into().ok()).unwrap_or([0; 16]);
            // SAFETY: reads the 16 bytes of `quarter`.
            _mm256_broadcastsi128_si256(unsafe { _mm_loadu_si128(quarter.as_ptr().cast()) })
        }))
    }

    /// Entry `j` in every byte that holds `j` (0..64) in `idx`; `b4`, `b5` hold bits 4 and 5 of
    /// each byte's `j` in its bit 7: `vpshufb` reads the low four bits of the index (bit 7 is
    /// 0), three blends pick the quarter.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn lookup(&self, idx: __m256i, b4: __m256i, b5: __m256i) -> __m256i {
        let [t0, t1, t2, t3] = self.0;
        let q01 = _mm256_blendv_epi8(_mm256_shuffle_epi8(t0, idx), _mm256_shuffle_epi8(t1, idx), b4);
        let q23 = _mm256_blendv_epi8(_mm256_shuffle_epi8(t2, idx), _mm256_shuffle_epi8(t3, idx), b4);
        _mm256_blendv_epi8(q01, q23, b5)
    }
}

/// The flux function in registers: its 64 nodes `n_j` (low and high bytes) and rises `ρ_j`
/// (bytes) as [`Bytes`] tables, read by `vpshufb`.
struct Flux {
    limit: __m256i,
    /// `k`.
    shift: __m128i,
    /// `15 − k`: `ρ_j·2^(15−k)` is the slope of the Q15 product.
    slope_shift: __m128i,
    /// `2ᵏ − 1`: `q = m mod 2ᵏ`.
    low_bits: __m256i,
    node_lo: Bytes,
    node_hi: Bytes,
    rise: Bytes,
}

impl Flux {
    /// The registers of `fx`, `None` when a rise does not fit a byte (never with the
    /// parameters' ranges: `|ρ_j| ≤ Δt/2·2ᵏ + 1 ≤ 65`; the row loop then takes the table).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(fx: &FluxFn) -> Option<Self> {
        let (node, rise) = fx.nodes_and_rises()?;
        let bytes = |f: fn(i16) -> u8| Bytes::new(&node.map(f));
        Some(Flux {
            limit: _mm256_set1_epi16(fx.limit as i16),
            shift: _mm_cvtsi32_si128(fx.shift as i32),
            slope_shift: _mm_cvtsi32_si128(15 - fx.shift as i32),
            low_bits: _mm256_set1_epi16(((1u32 << fx.shift) - 1) as i16),
            node_lo: bytes(|n| n.to_le_bytes()[0]),
            node_hi: bytes(|n| n.to_le_bytes()[1]),
            rise: Bytes::new(&rise.map(|r| r as u8)),
        })
    }

    /// [`FluxFn::eval`] on sixteen differences in `−32767..=32767`: `m = min(|∇|, limit)`,
    /// `j = m >> k`, `q = m mod 2ᵏ`, `n_j + ⌊(q·ρ_j + 2^(k−1)) / 2ᵏ⌋` (the rounded Q15 product
    /// `vpmulhrsw(q, ρ_j·2^(15−k))`, the portable `mulhrs` of `m` less `j·ρ_j`; see
    /// [`FluxFn::magnitude`]), the sign of `∇` back (`vpsignw`; `F(0) = n_0 = 0`).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn apply(&self, d: __m256i) -> __m256i {
        let m = _mm256_min_epu16(_mm256_abs_epi16(d), self.limit);
        let j = _mm256_srl_epi16(m, self.shift);
        let idx = _mm256_or_si256(j, _mm256_slli_epi16::<8>(j));
        let (b4, b5) = (_mm256_slli_epi16::<3>(idx), _mm256_slli_epi16::<2>(idx));
        let high_bytes = _mm256_set1_epi16(0xFF00u16 as i16);
        let node = _mm256_blendv_epi8(
            self.node_lo.lookup(idx, b4, b5),
            self.node_hi.lookup(idx, b4, b5),
            high_bytes,
        );
        let rise = _mm256_srai_epi16::<8>(self.rise.lookup(idx, b4, b5));
        let slope = _mm256_sll_epi16(rise, self.slope_shift);
        let q = _mm256_and_si256(m, self.low_bits);
        _mm256_sign_epi16(_mm256_add_epi16(node, _mm256_mulhrs_epi16(q, slope)), d)
    }
}

/// [`Flux::apply`] on sixteen values (for the tests); `None` as [`Flux::new`].
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(test)]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn flux16(fx: &FluxFn, x: [i16; 16]) -> Option<[i16; 16]> {
    let mut out = [0i16; 16];
    let flux = Flux::new(fx)?;
    // SAFETY: reads the 32 bytes of `x`, writes the 32 bytes of `out`.
    unsafe {
        let v = _mm256_loadu_si256(x.as_ptr().cast());
        _mm256_storeu_si256(out.as_mut_ptr().cast(), flux.apply(v));
    }
    Some(out)
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
/// start of the row with the flux function `fx`, updating `carry`; returns the pixels done (0
/// when `fx` does not fit the registers, see [`Flux::new`]).
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn row_blocks(
    fx: &FluxFn,
    p: &[i32],
    q: &[i32],
    north: &mut [i32],
    out: &mut [i32],
    carry: &mut RowCarry,
) -> usize {
    match Flux::new(fx) {
        Some(flux) => blocks(&flux, p, q, north, out, carry),
        None => 0,
    }
}
