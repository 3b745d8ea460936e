//! The tabulated step 12 on x86-64 with AVX2, eight pixels at a time: the index
//! `(R as u8)·511 + IR − VIS + 255` in 32-bit lanes, the added value by `vpgatherdd`, the
//! clamp a `min`, the saturation flag the OR of the sums (bit 8, as on the Cortex-M). The same
//! values as the portable loop (test `tabulated_output_equals_direct_output`).

use super::ADD_TABLE_LEN;
use core::arch::x86_64::*;

/// Whole blocks of eight pixels of one row from the start; returns the pixels done and
/// whether a sum exceeded 255.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn blocks(
    out: &mut [u8],
    vis: &[u8],
    tir: &[u8],
    r: &[i32],
    table: &[i32; ADD_TABLE_LEN],
) -> (usize, bool) {
    let n = out.len().min(vis.len()).min(tir.len()).min(r.len());
    let (k511, k255, low8) = (_mm256_set1_epi32(511), _mm256_set1_epi32(255), _mm256_set1_epi32(0xFF));
    // Bytes 0, 4, 8, 12 of each 128-bit lane to its low dword, then lanes' dwords 0 and 4 together.
    let pick = _mm256_setr_epi8(
        0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1,
        -1, -1, -1, -1, -1,
    );
    let join = _mm256_setr_epi32(0, 4, 1, 1, 1, 1, 1, 1);
    let mut any = _mm256_setzero_si256();
    let mut x = 0;
    while x + 8 <= n {
        let (Some(o), Some(v), Some(t), Some(rr)) = (
            out.get_mut(x..x + 8),
            vis.get(x..x + 8).and_then(|s| <&[u8; 8]>::try_from(s).ok()),
            tir.get(x..x + 8).and_then(|s| <&[u8; 8]>::try_from(s).ok()),
            r.get(x..x + 8).and_then(|s| <&[i32; 8]>::try_from(s).ok()),
        ) else {
            break;
        };
        // SAFETY: 8-byte and 32-byte reads of the arrays above (unaligned loads).
        let (v8, t8, r8) = unsafe {
            (
                _mm256_cvtepu8_epi32(_mm_loadl_epi64(v.as_ptr().cast())),
                _mm256_cvtepu8_epi32(_mm_loadl_epi64(t.as_ptr().cast())),
                _mm256_and_si256(_mm256_loadu_si256(rr.as_ptr().cast()), low8),
            )
        };
        let idx =
            _mm256_add_epi32(_mm256_mullo_epi32(r8, k511), _mm256_add_epi32(_mm256_sub_epi32(t8, v8), k255));
        // SAFETY: every index is (R as u8)·511 + IR − VIS + 255 ≤ 130 815 < ADD_TABLE_LEN.
        let add = unsafe { _mm256_i32gather_epi32::<4>(table.as_ptr(), idx) };
        let sum = _mm256_add_epi32(v8, add);
        any = _mm256_or_si256(any, sum);
        let bytes = _mm256_permutevar8x32_epi32(_mm256_shuffle_epi8(_mm256_min_epu32(sum, k255), pick), join);
        let packed = (_mm256_extract_epi64::<0>(bytes) as u64).to_le_bytes();
        o.copy_from_slice(&packed);
        x += 8;
    }
    let mut lanes = [0u32; 8];
    // SAFETY: writes the 32 bytes of `lanes`.
    unsafe { _mm256_storeu_si256(lanes.as_mut_ptr().cast(), any) };
    (x, lanes.iter().any(|&l| l & 0x100 != 0))
}
