//! The interpolation weights of OpenCV's `remap`, built at compile time by the same arithmetic:
//! for each of the 32 × 32 sub-pixel positions `(i, j)` of a fixed-point map, the 1-D weights at
//! `x = j/32` (and `y = i/32`) in `f32`, their outer product in `f32`, and for the 8-bit linear
//! path that product scaled to Q15 and rounded half to even.
//!
//! The builders index arrays: they are private `const fn`s evaluated only for the `static`
//! tables, by the compiler, where an index out of range is a build error — no runtime panic
//! path (the firmware's panic-check link proves it).
#![allow(clippy::indexing_slicing)]

/// Sub-pixel steps per pixel of a fixed-point map (OpenCV's `INTER_TAB_SIZE`).
pub const TAB_SIZE: usize = 32;
/// Bits of the sub-pixel index per axis (OpenCV's `INTER_BITS`).
pub const TAB_BITS: u32 = 5;
/// Fixed-point weight scale of the 8-bit linear kernel (OpenCV's `INTER_REMAP_COEF_SCALE`).
pub const COEF_SCALE: i32 = 1 << 15;

/// `x` rounded to the nearest integer, ties to even, for |x| < 2²² (the `f32` sum of
/// 1.5 · 2²³ and `x` keeps no fraction bits; what SSE's `cvtss2si` does in its default mode).
pub(crate) const fn round_even(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0;
    (x + MAGIC) - MAGIC
}

/// The 1-D weights at `x` (OpenCV's `interpolateLinear`).
const fn linear_1d(x: f32) -> [f32; 4] {
    [1.0 - x, x, 0.0, 0.0]
}

/// The 1-D weights at `x` (OpenCV's `interpolateCubic`, A = −0.75), in its `f32` order.
const fn cubic_1d(x: f32) -> [f32; 4] {
    const A: f32 = -0.75;
    let c0 = ((A * (x + 1.0) - 5.0 * A) * (x + 1.0) + 8.0 * A) * (x + 1.0) - 4.0 * A;
    let c1 = ((A + 2.0) * x - (A + 3.0)) * x * x + 1.0;
    let c2 = ((A + 2.0) * (1.0 - x) - (A + 3.0)) * (1.0 - x) * (1.0 - x) + 1.0;
    let c3 = 1.0 - c0 - c1 - c2;
    [c0, c1, c2, c3]
}

const fn position(i: usize) -> f32 {
    i as f32 * (1.0 / TAB_SIZE as f32)
}

const fn linear_f32() -> [[f32; 4]; TAB_SIZE * TAB_SIZE] {
    let mut out = [[0.0; 4]; TAB_SIZE * TAB_SIZE];
    let mut i = 0;
    while i < TAB_SIZE {
        let ty = linear_1d(position(i));
        let mut j = 0;
        while j < TAB_SIZE {
            let tx = linear_1d(position(j));
            let mut k1 = 0;
            while k1 < 2 {
                let mut k2 = 0;
                while k2 < 2 {
                    out[i * TAB_SIZE + j][k1 * 2 + k2] = ty[k1] * tx[k2];
                    k2 += 1;
                }
                k1 += 1;
            }
            j += 1;
        }
        i += 1;
    }
    out
}

const fn cubic_f32() -> [[f32; 16]; TAB_SIZE * TAB_SIZE] {
    let mut out = [[0.0; 16]; TAB_SIZE * TAB_SIZE];
    let mut i = 0;
    while i < TAB_SIZE {
        let ty = cubic_1d(position(i));
        let mut j = 0;
        while j < TAB_SIZE {
            let tx = cubic_1d(position(j));
            let mut k1 = 0;
            while k1 < 4 {
                let mut k2 = 0;
                while k2 < 4 {
                    out[i * TAB_SIZE + j][k1 * 4 + k2] = ty[k1] * tx[k2];
                    k2 += 1;
                }
                k1 += 1;
            }
            j += 1;
        }
        i += 1;
    }
    out
}

const fn linear_q15() -> [[i16; 4]; TAB_SIZE * TAB_SIZE] {
    let f = linear_f32();
    let mut out = [[0i16; 4]; TAB_SIZE * TAB_SIZE];
    let mut n = 0;
    while n < TAB_SIZE * TAB_SIZE {
        let mut w = [0i32; 4];
        let mut sum = 0;
        let mut k = 0;
        while k < 4 {
            // `saturate_cast<short>`: the weight 1.0 of the position (0, 0) is 2¹⁵ − 1.
            let v = round_even(f[n][k] * COEF_SCALE as f32) as i32;
            w[k] = if v > i16::MAX as i32 { i16::MAX as i32 } else { v };
            sum += w[k];
            k += 1;
        }
        // The products are multiples of 2⁻¹⁰, exact in `f32`, so only the saturated kernel at
        // (0, 0) misses 2¹⁵ (checked at compile time). OpenCV's correction then scans its
        // "central 2 × 2" from index 3 — for a 2 × 2 kernel that is the last weight and three
        // entries of the next kernel, still zero — and gives the missing 1 to weight 3:
        // [32767, 0, 0, 1]. (For 8-bit data this changes no result.)
        if sum != COEF_SCALE {
            assert!(n == 0);
            w[3] -= sum - COEF_SCALE;
        }
        out[n] = [w[0] as i16, w[1] as i16, w[2] as i16, w[3] as i16];
        n += 1;
    }
    out
}

/// The 8-bit linear kernel: Q15 weights (top-left, top-right, bottom-left, bottom-right) per
/// sub-pixel index `fy·32 + fx`.
pub static LINEAR_Q15: [[i16; 4]; TAB_SIZE * TAB_SIZE] = linear_q15();
/// The 16-bit linear kernel: `f32` weights, the same order.
pub static LINEAR_F32: [[f32; 4]; TAB_SIZE * TAB_SIZE] = linear_f32();
/// The cubic kernel (both depths): `f32` weights of the 4 × 4 neighbourhood, row-major from
/// `(x − 1, y − 1)`.
pub static CUBIC_F32: [[f32; 16]; TAB_SIZE * TAB_SIZE] = cubic_f32();
