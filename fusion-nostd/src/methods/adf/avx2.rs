//! The AVX2 forms of ADF's two per-pixel passes after the diffusion (x86-64 hosts whose best set
//! is AVX2): the covariance moments of the detail layers ([`moments_blocks`], 16 pixels per
//! step, the squares by `vpmaddwd` into 64-bit sums) and the flight output row ([`u8_blocks`],
//! 32 pixels per step, `p_IR·(D_IR − D_VIS)` by `vpmuldq`). The same integers as the portable
//! kernels (`moments_kernel`, `u8_kernel`), so the same bits (tests `avx2_moments_are_exact`,
//! `avx2_output_rows_are_exact`). On AVX-512 hosts the compiler's AVX-512 vectorisation of the
//! portable kernels runs instead, as before.

use super::{COV_CHUNK, STATE_BITS};
use core::arch::x86_64::*;

/// The `N` bytes of `s` from `at`; `None` past the end.
#[target_feature(enable = "avx2")]
#[inline]
fn bytes<const N: usize>(s: &[u8], at: usize) -> Option<[u8; N]> {
    s.get(at..at + N)?.try_into().ok()
}

/// Eight words at `s[at..at + 8]` (unaligned; also the diffusion's AVX2 row loop's load).
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn words(s: &[i32], at: usize) -> Option<__m256i> {
    let v: &[i32; 8] = s.get(at..at + 8)?.try_into().ok()?;
    // SAFETY: reads the 32 bytes of `v`.
    Some(unsafe { _mm256_loadu_si256(v.as_ptr().cast()) })
}

/// Sixteen bytes `b` as 16-bit lanes in the order `b₀, b₈, b₁, b₉, …, b₇, b₁₅` (the order in
/// which [`moments_blocks`] pairs two words of packed base layers).
#[target_feature(enable = "avx2")]
#[inline]
fn interleaved(b: [u8; 16]) -> __m256i {
    // SAFETY: reads the 16 bytes of `b`.
    let v = unsafe { _mm_loadu_si128(b.as_ptr().cast()) };
    _mm256_cvtepu8_epi16(_mm_unpacklo_epi8(v, _mm_srli_si128::<8>(v)))
}

/// The four 64-bit lanes of `x` summed.
#[target_feature(enable = "avx2")]
#[inline]
fn sum_i64(x: __m256i) -> i64 {
    let mut l = [0i64; 4];
    // SAFETY: writes the 32 bytes of `l`.
    unsafe { _mm256_storeu_si256(l.as_mut_ptr().cast(), x) };
    l.iter().sum()
}

/// The eight 32-bit lanes of `x` summed (wrapping; the callers' sums fit).
#[target_feature(enable = "avx2")]
#[inline]
fn sum_i32(x: __m256i) -> i32 {
    let mut l = [0i32; 8];
    // SAFETY: writes the 32 bytes of `l`.
    unsafe { _mm256_storeu_si256(l.as_mut_ptr().cast(), x) };
    l.iter().fold(0i32, |s, &v| s.wrapping_add(v))
}

/// The sums `[ΣD_IR, ΣD_VIS]` and `[ΣD_IR², ΣD_IR·D_VIS, ΣD_VIS²]` of the first `16·⌊n/16⌋`
/// pixels (`n` the shortest slice, at most [`COV_CHUNK`]), and that pixel count. Per 16 pixels
/// the two words of eight packed base layers are split into a VIS and an IR register (pixel
/// `k` of the first word in lane `2k`, of the second in lane `2k + 1`), the pixels' `2⁷·I` in
/// the same order, so `D` of both bands is one 16-bit subtraction each (`|D| < 2¹⁵`). The
/// sums by `vpmaddwd` with ones (32-bit lanes: at most 2¹¹ blocks × 2 details < 2²⁸), the
/// squares and products by `vpmaddwd` of the details (two products per lane, `< 2³¹`) widened
/// into 64-bit sums.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn moments_blocks(iv: &[u8], it: &[u8], a: &[i32]) -> (usize, [i32; 2], [i64; 3]) {
    let n = iv.len().min(it.len()).min(a.len()).min(COV_CHUNK);
    let ones = _mm256_set1_epi16(1);
    let zero = _mm256_setzero_si256();
    let (mut s_ir, mut s_vis) = (zero, zero);
    let (mut s11, mut s12, mut s22) = (zero, zero, zero);
    // Non-negative 32-bit lanes into 64-bit sums.
    let widen_unsigned = |acc: __m256i, x: __m256i| {
        _mm256_add_epi64(
            _mm256_add_epi64(acc, _mm256_unpacklo_epi32(x, zero)),
            _mm256_unpackhi_epi32(x, zero),
        )
    };
    let mut x = 0;
    while x + 16 <= n {
        let (Some(v), Some(t), Some(a0), Some(a1)) =
            (bytes::<16>(iv, x), bytes::<16>(it, x), words(a, x), words(a, x + 8))
        else {
            break;
        };
        // [lo(a0[k]), lo(a1[k])] and [hi(a0[k]), hi(a1[k])] per word k.
        let a_vis = _mm256_blend_epi16::<0xAA>(a0, _mm256_slli_epi32::<16>(a1));
        let a_ir = _mm256_blend_epi16::<0xAA>(_mm256_srli_epi32::<16>(a0), a1);
        let d_vis = _mm256_sub_epi16(_mm256_slli_epi16::<{ STATE_BITS as i32 }>(interleaved(v)), a_vis);
        let d_ir = _mm256_sub_epi16(_mm256_slli_epi16::<{ STATE_BITS as i32 }>(interleaved(t)), a_ir);
        s_vis = _mm256_add_epi32(s_vis, _mm256_madd_epi16(d_vis, ones));
        s_ir = _mm256_add_epi32(s_ir, _mm256_madd_epi16(d_ir, ones));
        s11 = widen_unsigned(s11, _mm256_madd_epi16(d_ir, d_ir));
        s22 = widen_unsigned(s22, _mm256_madd_epi16(d_vis, d_vis));
        let cross = _mm256_madd_epi16(d_ir, d_vis);
        let (lo, hi) = (_mm256_castsi256_si128(cross), _mm256_extracti128_si256::<1>(cross));
        s12 = _mm256_add_epi64(_mm256_add_epi64(s12, _mm256_cvtepi32_epi64(lo)), _mm256_cvtepi32_epi64(hi));
        x += 16;
    }
    (x, [sum_i32(s_ir), sum_i32(s_vis)], [sum_i64(s11), sum_i64(s12), sum_i64(s22)])
}

/// [`super::fused32`] and the 8-bit cast of the first `32·⌊n/32⌋` pixels of `out` (`n` the
/// shortest slice), with `|p_IR| < 2³¹`; returns the pixels done and whether one saturated.
/// Per eight pixels in 32-bit lanes: the details, `(A_IR + A_VIS + 2·D_VIS)·2⁸`, the 64-bit
/// products `p·(D_IR − D_VIS) + 2²⁰` of the even and the odd lanes (`vpmuldq`), each shifted
/// so that bits 21..53 land in its 32-bit lane (a logical shift: those bits are the
/// arithmetic shift's), then `raw_saturates` by two comparisons and `raw_to_u8` by shifts and
/// the saturating packs (`vpackssdw`, `vpackuswb`: the clamp to 0..=255).
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn u8_blocks(p: i32, iv: &[u8], it: &[u8], a: &[i32], out: &mut [u8]) -> (usize, bool) {
    let n = iv.len().min(it.len()).min(a.len()).min(out.len());
    let weight = _mm256_set1_epi32(p);
    let round = _mm256_set1_epi64x(1 << (super::Q_SHIFT - 1));
    // raw_saturates: outside −2¹⁵ ..< 255·2¹⁶ + 2¹⁵.
    let (low, high) = (_mm256_set1_epi32(-(1 << 15)), _mm256_set1_epi32((255 << 16) + (1 << 15) - 1));
    let half = _mm256_set1_epi32(1 << 14);
    let order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
    let mut saturated = _mm256_setzero_si256();
    let eight = |v: [u8; 8], t: [u8; 8], a: __m256i| {
        // SAFETY (both loads): reads the 8 bytes of `v`, of `t`.
        let xv = _mm256_cvtepu8_epi32(unsafe { _mm_loadl_epi64(v.as_ptr().cast()) });
        let xt = _mm256_cvtepu8_epi32(unsafe { _mm_loadl_epi64(t.as_ptr().cast()) });
        let (lo, hi) = (_mm256_srai_epi32::<16>(_mm256_slli_epi32::<16>(a)), _mm256_srai_epi32::<16>(a));
        let d_vis = _mm256_sub_epi32(_mm256_slli_epi32::<{ STATE_BITS as i32 }>(xv), lo);
        let d_ir = _mm256_sub_epi32(_mm256_slli_epi32::<{ STATE_BITS as i32 }>(xt), hi);
        let s = _mm256_add_epi32(_mm256_add_epi32(hi, lo), _mm256_add_epi32(d_vis, d_vis));
        let delta = _mm256_sub_epi32(d_ir, d_vis);
        let even = _mm256_add_epi64(_mm256_mul_epi32(delta, weight), round);
        let odd = _mm256_add_epi64(_mm256_mul_epi32(_mm256_srli_epi64::<32>(delta), weight), round);
        let q = super::Q_SHIFT as i32;
        let product = _mm256_blend_epi32::<0xAA>(
            _mm256_srl_epi64(even, _mm_cvtsi32_si128(q)),
            _mm256_sll_epi64(odd, _mm_cvtsi32_si128(32 - q)),
        );
        let shift = (super::WEIGHT_BITS - 1 - super::Q_SHIFT) as i32;
        let raw = _mm256_add_epi32(_mm256_sll_epi32(s, _mm_cvtsi32_si128(shift)), product);
        let outside = _mm256_or_si256(_mm256_cmpgt_epi32(low, raw), _mm256_cmpgt_epi32(raw, high));
        let cast = _mm256_srai_epi32::<15>(_mm256_add_epi32(_mm256_srai_epi32::<1>(raw), half));
        (cast, outside)
    };
    let mut x = 0;
    while x + 32 <= n {
        let mut casts = [_mm256_setzero_si256(); 4];
        for (k, c) in casts.iter_mut().enumerate() {
            let at = x + 8 * k;
            let (Some(v), Some(t), Some(w)) = (bytes::<8>(iv, at), bytes::<8>(it, at), words(a, at)) else {
                return (x, _mm256_testz_si256(saturated, saturated) == 0);
            };
            let (cast, outside) = eight(v, t, w);
            saturated = _mm256_or_si256(saturated, outside);
            *c = cast;
        }
        let [c0, c1, c2, c3] = casts;
        let packed = _mm256_packus_epi16(_mm256_packs_epi32(c0, c1), _mm256_packs_epi32(c2, c3));
        let Some(dst) = out.get_mut(x..x + 32).and_then(|d| <&mut [u8; 32]>::try_from(d).ok()) else {
            break;
        };
        // SAFETY: writes the 32 bytes of `dst`.
        unsafe { _mm256_storeu_si256(dst.as_mut_ptr().cast(), _mm256_permutevar8x32_epi32(packed, order)) };
        x += 32;
    }
    (x, _mm256_testz_si256(saturated, saturated) == 0)
}
