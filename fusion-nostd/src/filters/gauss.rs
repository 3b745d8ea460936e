//! Separable Gaussian correlation with zero padding (MATLAB `imfilter(I, fspecial('gaussian',
//! n, σ))`, the default border), on fixed-point `i32` planes.
//!
//! `fspecial`'s 2-D kernel `exp(−(x²+y²)/2σ²)/Σ` is the outer product of the normalised 1-D
//! kernel `g(x) = exp(−x²/2σ²)/Σ`, so one horizontal and one vertical pass give it. The 1-D
//! weights are stored in Q30 ([`GAUSS_BITS`]), rounded and corrected so that they sum to
//! exactly 2³⁰; `exp` comes from `libm` (software, the same bits on every target) and is
//! evaluated once per call, not per pixel. Weight error ≤ 2⁻³¹ each (the centre one
//! ≤ n·2⁻³¹). Zero padding: taps outside the image are dropped (not renormalised), so the
//! result darkens within `n/2` pixels of the border, as published.
//!
//! Input and output share one Q format; the sums are exact `i64` (|value| < 2³¹, weights
//! < 2³⁰, at most 31 taps) and rounded to nearest once per pass.

use crate::Error;
#[cfg(test)]
use crate::{FrameMut, FrameRef};

/// Fractional bits of the Gaussian weights.
pub const GAUSS_BITS: u32 = 30;

/// Largest kernel side.
pub const MAX_SIZE: usize = 31;

/// The normalised 1-D Gaussian of odd `size ≤ 31` and `σ = sigma_num / sigma_den`, in Q30,
/// summing to exactly 2³⁰. Returns the weights and their count.
pub fn weights(size: usize, sigma_num: u32, sigma_den: u32) -> Result<([i32; MAX_SIZE], usize), Error> {
    if size.is_multiple_of(2) || size > MAX_SIZE || sigma_num == 0 || sigma_den == 0 {
        return Err(Error::InvalidParameter { name: "gauss_size" });
    }
    let sigma = f64::from(sigma_num) / f64::from(sigma_den);
    let half = (size / 2) as i32;
    let mut g = [0f64; MAX_SIZE];
    for (i, v) in g.iter_mut().take(size).enumerate() {
        let x = f64::from(i as i32 - half);
        *v = libm::exp(-(x * x) / (2.0 * sigma * sigma));
    }
    let sum: f64 = g.iter().take(size).sum();
    let mut w = [0i32; MAX_SIZE];
    let mut total: i64 = 0;
    for (q, v) in w.iter_mut().zip(&g).take(size) {
        *q = libm::round(v / sum * f64::from(1u32 << GAUSS_BITS)) as i32;
        total += i64::from(*q);
    }
    if let Some(c) = w.get_mut(size / 2) {
        *c += ((1i64 << GAUSS_BITS) - total) as i32;
    }
    Ok((w, size))
}

#[cfg(test)]
#[inline(always)]
fn round_q(acc: i64) -> i32 {
    ((acc + (1 << (GAUSS_BITS - 1))) >> GAUSS_BITS) as i32
}

#[cfg(test)]
/// Strip width of the accumulators.
const STRIP: usize = 64;

#[cfg(test)]
#[inline(always)]
fn rows_kernel(src: FrameRef<'_, i32>, mut dst: FrameMut<'_, i32>, w: &[i32]) {
    let n = w.len();
    let r = n / 2;
    for (s, d) in src.rows().zip(dst.rows_mut()) {
        let width = s.len();
        if width >= n {
            // Interior: every tap inside; output x = r + i reads inputs i … i + n − 1.
            let interior = d.get_mut(r..width - r).unwrap_or(&mut []);
            for (strip, dchunk) in interior.chunks_mut(STRIP).enumerate() {
                let x0 = strip * STRIP;
                let mut acc = [0i64; STRIP];
                for (t, &k) in w.iter().enumerate() {
                    let seg = s.get(x0 + t..).unwrap_or(&[]);
                    for (a, &v) in acc.iter_mut().zip(seg.iter().take(STRIP)) {
                        *a += i64::from(v) * i64::from(k);
                    }
                }
                for (o, &a) in dchunk.iter_mut().zip(&acc) {
                    *o = round_q(a);
                }
            }
        }
        // Borders (and rows shorter than the kernel): clipped taps.
        for x in (0..width).filter(|&x| x < r || x + r >= width || width < n) {
            let lo = x.saturating_sub(r);
            let hi = (x + r).min(width - 1);
            let first_tap = lo + r - x;
            let seg = s.get(lo..=hi).unwrap_or(&[]);
            let acc: i64 =
                seg.iter().zip(w.iter().skip(first_tap)).map(|(&v, &k)| i64::from(v) * i64::from(k)).sum();
            if let Some(o) = d.get_mut(x) {
                *o = round_q(acc);
            }
        }
    }
}

#[cfg(test)]
#[inline(always)]
fn cols_kernel(src: FrameRef<'_, i32>, mut dst: FrameMut<'_, i32>, w: &[i32]) {
    let height = src.height();
    let r = w.len() / 2;
    for (y, d) in dst.rows_mut().enumerate() {
        let lo = y.saturating_sub(r);
        let hi = (y + r).min(height - 1);
        let first_tap = lo + r - y;
        for (strip, dchunk) in d.chunks_mut(STRIP).enumerate() {
            let x0 = strip * STRIP;
            let mut acc = [0i64; STRIP];
            for (yy, &k) in (lo..=hi).zip(w.iter().skip(first_tap)) {
                let seg = src.row(yy).get(x0..).unwrap_or(&[]);
                for (a, &v) in acc.iter_mut().zip(seg.iter().take(STRIP)) {
                    *a += i64::from(v) * i64::from(k);
                }
            }
            for (o, &a) in dchunk.iter_mut().zip(&acc) {
                *o = round_q(a);
            }
        }
    }
}

#[cfg(test)]
crate::cpu::dispatch! {
    fn rows_best(src: FrameRef<'_, i32>, dst: FrameMut<'_, i32>, w: &[i32]) => rows_kernel
}
#[cfg(test)]
crate::cpu::dispatch! {
    fn cols_best(src: FrameRef<'_, i32>, dst: FrameMut<'_, i32>, w: &[i32]) => cols_kernel
}

#[cfg(test)]
/// Horizontal pass: `dst[y][x] = Σ_t w[t]·src[y][x + t − r]`, samples outside dropped.
pub fn correlate_rows(src: FrameRef<'_, i32>, dst: FrameMut<'_, i32>, w: &[i32]) -> Result<(), Error> {
    if src.size() != dst.size() {
        return Err(Error::SizeMismatch { expected: src.size(), got: dst.size() });
    }
    rows_best(src, dst, w);
    Ok(())
}

#[cfg(test)]
/// Vertical pass: `dst[y][x] = Σ_t w[t]·src[y + t − r][x]`, rows outside dropped.
pub fn correlate_cols(src: FrameRef<'_, i32>, dst: FrameMut<'_, i32>, w: &[i32]) -> Result<(), Error> {
    if src.size() != dst.size() {
        return Err(Error::SizeMismatch { expected: src.size(), got: dst.size() });
    }
    cols_best(src, dst, w);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_are_normalised_and_symmetric() -> Result<(), Error> {
        let (w, n) = weights(9, 9, 2)?;
        assert_eq!(n, 9);
        assert_eq!(w.iter().take(n).map(|&v| i64::from(v)).sum::<i64>(), 1 << GAUSS_BITS);
        for i in 0..4 {
            assert_eq!(w[i], w[8 - i]);
        }
        // exp(−16/40.5)/Σ for the outermost tap, Σ = Σ_x exp(−x²/40.5).
        let sum: f64 = (-4..=4).map(|x: i32| libm::exp(-f64::from(x * x) / 40.5)).sum();
        let want = libm::exp(-16.0 / 40.5) / sum * f64::from(1u32 << 30);
        assert!((f64::from(w[0]) - want).abs() <= 1.0);
        assert!(weights(8, 4, 1).is_err());
        Ok(())
    }

    #[test]
    fn constant_interior_is_kept_and_border_darkens() -> Result<(), Error> {
        let (w, n) = weights(5, 5, 2)?;
        let src = [1000i32 << 8; 12 * 7];
        let mut tmp = [0i32; 12 * 7];
        let mut out = [0i32; 12 * 7];
        correlate_rows(FrameRef::new(&src, 12, 7)?, FrameMut::new(&mut tmp, 12, 7)?, &w[..n])?;
        correlate_cols(FrameRef::new(&tmp, 12, 7)?, FrameMut::new(&mut out, 12, 7)?, &w[..n])?;
        assert_eq!(out[3 * 12 + 5], 1000 << 8);
        assert!(out[0] < (1000 << 8) / 2 + 1000, "corner keeps about a quarter+: {}", out[0]);
        assert!(out[3 * 12] < 1000 << 8);
        Ok(())
    }
}
