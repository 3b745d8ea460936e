//! Separable `'valid'` correlation of `f64` planes in strips: SSIM's Gaussian window (MATLAB
//! `filter2(w, X, 'valid')` of an outer-product kernel `k ⊗ k`).
//!
//! Each strip of output rows is one pass along the rows and one along the columns, each a sum
//! of shifted `out += k[t]·row` updates over whole rows that the compiler vectorises — compiled
//! for AVX2/AVX-512/NEON where the CPU has them (`multiversion`). No fused multiply–add is
//! formed, so every target gives the same bits. The strip's buffers stay in the cache and are
//! allocated once per call, not once per plane.

use multiversion::multiversion;

/// Output rows per strip.
const STRIP: usize = 16;

/// The `'valid'` 2-D correlation with `taps ⊗ taps` (odd length `2r + 1`) of `planes` planes of
/// size `w × h`, streamed in strips of output rows; the output is `(w − 2r) × (h − 2r)`.
/// `fill(p, y, row)` writes input row `y` of plane `p`; `consume(y0, n, outs)` receives output
/// rows `y0..y0 + n` of every plane (the first `n` rows of `outs[p]`).
pub(super) fn correlate_valid_in_strips(
    planes: usize,
    (w, h): (usize, usize),
    taps: &[f64],
    mut fill: impl FnMut(usize, usize, &mut [f64]),
    mut consume: impl FnMut(usize, usize, &[Vec<f64>]),
) {
    let r = taps.len() / 2;
    let (ow, oh) = (w.saturating_sub(2 * r), h.saturating_sub(2 * r));
    if ow == 0 || oh == 0 {
        return;
    }
    let mut input = vec![0f64; (STRIP + 2 * r) * w];
    let mut rows = vec![0f64; (STRIP + 2 * r) * ow];
    let mut outs = vec![vec![0f64; STRIP * ow]; planes];
    let mut y0 = 0;
    while y0 < oh {
        let n = STRIP.min(oh - y0);
        let count = n + 2 * r; // input rows y0..y0 + count
        for (p, out) in outs.iter_mut().enumerate() {
            for (k, row) in input[..count * w].chunks_exact_mut(w).enumerate() {
                fill(p, y0 + k, row);
            }
            along_rows(&input[..count * w], w, taps, &mut rows[..count * ow]);
            along_columns(&rows[..count * ow], ow, taps, &mut out[..n * ow]);
        }
        consume(y0, n, &outs);
        y0 += n;
    }
}

/// `dst[i] += k·src[i]`.
#[inline(always)]
fn axpy(dst: &mut [f64], k: f64, src: &[f64]) {
    for (d, &s) in dst.iter_mut().zip(src) {
        *d += k * s;
    }
}

/// Along each row of `input` (`w` wide) into `out` (`w − 2r` wide).
#[multiversion(targets(
    "x86_64+avx2+fma",
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl",
    "aarch64+neon"
))]
fn along_rows(input: &[f64], w: usize, taps: &[f64], out: &mut [f64]) {
    let ow = w - (taps.len() - 1);
    for (src, dst) in input.chunks_exact(w).zip(out.chunks_exact_mut(ow)) {
        dst.fill(0.0);
        for (t, &k) in taps.iter().enumerate() {
            axpy(dst, k, &src[t..t + ow]);
        }
    }
}

/// Along the columns: output row `y` of `out` is `Σ_t taps[t]·rows[y + t]` (rows `w` wide).
#[multiversion(targets(
    "x86_64+avx2+fma",
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl",
    "aarch64+neon"
))]
fn along_columns(rows: &[f64], w: usize, taps: &[f64], out: &mut [f64]) {
    for (y, dst) in out.chunks_exact_mut(w).enumerate() {
        dst.fill(0.0);
        for (t, &k) in taps.iter().enumerate() {
            axpy(dst, k, &rows[(y + t) * w..(y + t + 1) * w]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_equal_the_2d_definition() {
        // 40 rows: more than two strips, the last one partial.
        let (w, h) = (23, 40);
        let img: Vec<f64> = (0..w * h).map(|i| ((i * 7919) % 251) as f64).collect();
        let second: Vec<f64> = img.iter().map(|v| v * v - 3.0).collect();
        let taps = [0.5, 1.0, 3.0, 1.0, 0.25];
        let mut got = [Vec::new(), Vec::new()];
        correlate_valid_in_strips(
            2,
            (w, h),
            &taps,
            |p, y, row| row.copy_from_slice(&[&img, &second][p][y * w..(y + 1) * w]),
            |_, n, outs| {
                for (g, o) in got.iter_mut().zip(outs) {
                    g.extend_from_slice(&o[..n * (w - 4)]);
                }
            },
        );
        for (p, plane) in [&img, &second].iter().enumerate() {
            let mut want = Vec::new();
            for y in 0..h - 4 {
                for x in 0..w - 4 {
                    let mut s = 0.0;
                    for (i, ki) in taps.iter().enumerate() {
                        for (j, kj) in taps.iter().enumerate() {
                            s += ki * kj * plane[(y + i) * w + x + j];
                        }
                    }
                    want.push(s);
                }
            }
            assert_eq!(got[p].len(), want.len());
            for (a, b) in got[p].iter().zip(&want) {
                assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0), "plane {p}: {a} vs {b}");
            }
        }
        // A kernel wider than the image has no valid output.
        let mut called = false;
        correlate_valid_in_strips(1, (w, h), &[1.0; 31], |_, _, _| {}, |_, _, _| called = true);
        assert!(!called);
    }
}
