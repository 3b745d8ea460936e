//! TSIFSD — two-scale image fusion with saliency detection (Bavirisetti & Dhuli, Infrared
//! Phys. Technol. 76, 2016; VIFB "TIF"), integer core. Spec:
//! `shared/reference/fusion-algorithms.md`, TSIFSD.
//!
//! # Steps and number formats
//!
//! With `n` = mean window side (35), `N = n²` taps:
//!
//! | quantity | type | format | range |
//! |---|---|---|---|
//! | box sum `Σ_k` (base `B_k = Σ_k / N`) | `i32` | integer, implied scale 1/N | ≤ 255·N < 2²⁰ (n ≤ 63) |
//! | scaled detail `N·D_k = N·I_k − Σ_k` | `i64` | integer, scale 1/N | \|·\| < 2²⁰ |
//! | classic saliency `N²·S_k = (Σ_k − N·Med_k)²` | `u64` | integer, scale 1/N² | < 2⁴⁰ |
//! | flight saliency `S_k = \|Scharr_x\| + \|Scharr_y\|` | `u64` | integer | ≤ 8160 |
//! | weights | `i64` | `S_k`, both shifted right together until `S_VIS + S_IR < 2²³` | relative error < 2⁻²² |
//! | fused raw value | `i32` | Q16 ([`RAW_FRAC_BITS`]) | one exact rational division per pixel, rounded half away from zero; \|F\| < 2¹⁰ levels, never saturates |
//! | 8-bit output, `clamp(⌊U / (2N·σ)⌋, 0, 255)` (see `fused_u8`) | `i32` when `σ < 2¹⁴` (flight: always), else `i64` | integer | exact: the same bits as casting the raw value |
//!
//! Per pixel: `F = (Σ_VIS + Σ_IR)/(2N) + (S_VIS·N·D_VIS + S_IR·N·D_IR) / (N·(S_VIS + S_IR))`,
//! evaluated as one fraction `num / (N·σ)` in `i64` (|num| < 2⁶¹), so the only rounding is the
//! final one to Q16 (the classic core is exact up to that rounding and the 2⁻²² weight scaling).
//! The 8-bit output folds that rounding and the cast's into one floor division, which needs no
//! 64-bit division (a library call on the 32-bit targets): three 32-bit divisions for the
//! flight saliency. The 35×35 mean costs O(1) per pixel (running sums,
//! [`crate::filters::box_sum`]); the 3×3 median and the Scharr gradient sort or smooth each
//! column once for its three windows (row chunks of 256 pixels on the stack). The flight
//! 8-bit output has its own kernel (`flight_u8`): only `Σ_IR − Σ_VIS` enters it, so it keeps
//! the 35×35 window's column sums of `I_IR − I_VIS` in one padded row instead of two box-sum
//! planes; both bands' pixels sit in the two 16-bit lanes of one word, so one pass of `u32`
//! arithmetic (Arm: DSP lane instructions) smooths, differences and takes the Scharr gradients
//! of both; per pixel one weight-free word `q_VIS + q_IR·2⁹ + (r + taps)·2¹⁸` (see there) and
//! two unsigned 32-bit divisions give the output. It gives the same bytes and guards as the
//! general path (tested).
//!
//! # Variants and guards
//!
//! * [`Variant::Classic`]: 35×35 box mean with **circular** padding, 3×3 median with **zero**
//!   padding, saliency `(B − Med)²`, as published.
//! * [`Variant::Flight`]: the study's **Scharr-gradient saliency** `S = |Gx| + |Gy|` (L1, not
//!   smoothed; exact in integers, no square root), with **replicate** padding for the gradient (zero padding fakes a 16·I edge
//!   on every border pixel and hands the whole border to the brighter band) and for the 35×35
//!   mean (circular padding mixes the opposite edge of the frame into the base layer: a bright
//!   target at the bottom lightens the top rows).
//!
//!   The choice, measured on the four VIFB pairs with the f64 building blocks (test
//!   `flight_saliency_choice_measurement`): L1 and the magnitude `√(Gx² + Gy²)` give fused
//!   images 45–52 dB apart, the same average gradient (±0.3 %) and the same noise behaviour
//!   (±0.07 dB), so L1 wins on cost. Smoothing the saliency with a 5×5 box makes the output
//!   1.2–2.5 dB more robust to the study's sensor noise (fused noisy vs fused clean) but
//!   loses 6–18 % of the average gradient (detail); the raw gradient is kept, smoothing
//!   would be a parameter to add.
//! * Both: where `S_VIS + S_IR = 0` (the published 0/0 = NaN, cast to a black pixel) the
//!   weights are ½, ½, so `F = ½(I_VIS + I_IR)`; [`Guards::TSIFSD_ZERO_SALIENCY`] is reported.
//!   [`Guards::OUTPUT_SATURATED`] (u8 output only): a pixel was clamped to 0 or 255.
//!
//! # Scratch
//!
//! Three `i32` planes of W·H: the two box sums and the horizontal-pass plane; about 5 KiB of
//! stack for the row chunks. The flight 8-bit kernel uses only the start of two of them: one
//! row of column sums (`W + 2r + 1` entries) and a ring of `2r + 3` rows of lane words
//! (frames shorter than the ring take the general path, with the same bytes). Its memory does
//! not grow with the height and it can start at any row, which is what lets the strip
//! pipeline ([`crate::strips`]) run it in 152.1 KiB at W = 1024.

use super::{Guards, Variant, check_sizes};
use crate::filters::border::Border;
use crate::filters::box_sum::{box_sum_u8, horizontal};
use crate::filters::median3::{CHUNK, median3_chunk};
use crate::filters::scharr::{lane_pair, scharr_columns_pair, scharr_l1_chunk, scharr_l1_pair};
use crate::{Error, FrameMut, FrameRef, ScratchMut};
use core::num::NonZeroU32;

/// Fractional bits of the raw fused value written by [`fuse_tsifsd_raw`] (Q16).
pub const RAW_FRAC_BITS: u32 = 16;

/// TSIFSD parameters. [`Default`] is the published setting (`run_TIF.m`: 35×35 mean, 3×3
/// median) with the [`Variant::Flight`] variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TsifsdParams {
    /// Classic (mean/median saliency, published borders) or flight (Scharr saliency, replicate).
    pub variant: Variant,
    /// Side of the square mean filter, odd, `1..=63` (the median is always 3×3).
    pub mean_size: u16,
}

impl Default for TsifsdParams {
    fn default() -> Self {
        Self { variant: Variant::Flight, mean_size: 35 }
    }
}

impl TsifsdParams {
    /// Checks every field's documented range ([`Error::InvalidParameter`] names the field).
    pub fn validate(&self) -> Result<(), Error> {
        if self.mean_size.is_multiple_of(2) || !(1..=63).contains(&self.mean_size) {
            return Err(Error::InvalidParameter { name: "mean_size" });
        }
        Ok(())
    }

    /// Border rule of the 35×35 mean (classic: circular; flight: replicate).
    pub fn mean_border(&self) -> Border {
        match self.variant {
            Variant::Classic => Border::Circular,
            Variant::Flight => Border::Replicate,
        }
    }
}

/// `round(n / d)`, half away from zero, `d > 0`.
#[inline(always)]
fn div_round(n: i64, d: i64) -> i64 {
    let d = d.max(1); // d > 0 already; lets the optimiser drop the division's panic paths
    if n >= 0 { (2 * n + d) / (2 * d) } else { -((-2 * n + d) / (2 * d)) }
}

/// The weights of one pixel: `(w_VIS, w_IR, σ = w_VIS + w_IR)`, both saliencies shifted right
/// together until `σ < 2²³` (½, ½ when both are 0), and `true` when both were 0.
#[inline(always)]
fn weights(sal_v: u64, sal_i: u64) -> (i64, i64, i64, bool) {
    let zero = sal_v == 0 && sal_i == 0;
    let (sal_v, sal_i) = if zero { (1, 1) } else { (sal_v, sal_i) };
    let shift = (64 - (sal_v + sal_i).leading_zeros()).saturating_sub(23);
    let (wv, wi) = ((sal_v >> shift) as i64, (sal_i >> shift) as i64);
    (wv, wi, wv + wi, zero)
}

/// The fused value of one pixel as the fraction `num / den` (Q16 once divided), `den > 0`,
/// and `true` when both saliencies were 0.
#[inline(always)]
fn fraction(iv: u8, ii: u8, sum_v: i32, sum_i: i32, sal_v: u64, sal_i: u64, taps: i64) -> (i64, i64, bool) {
    let (wv, wi, sigma, zero) = weights(sal_v, sal_i); // σ ≥ 1 and < 2²³
    let (sv, si) = (i64::from(sum_v), i64::from(sum_i));
    let dv = taps * i64::from(iv) - sv;
    let di = taps * i64::from(ii) - si;
    let num = (((sv + si) * sigma) << 15) + ((wv * dv + wi * di) << 16);
    (num, taps * sigma, zero)
}

/// Fused Q16 value of one pixel; `true` when both saliencies were 0.
#[inline(always)]
fn combine(iv: u8, ii: u8, sum_v: i32, sum_i: i32, sal_v: u64, sal_i: u64, taps: i64) -> (i32, bool) {
    let (num, den, zero) = fraction(iv, ii, sum_v, sum_i, sal_v, sal_i, taps);
    (div_round(num, den) as i32, zero)
}

/// `⌊u / v⌋` for `u < 256·v` (`v > 0`) without a 64-bit division (a library call on the
/// 32-bit targets): estimated by one 32-bit division of the top bits
/// (`v` cut to 24 bits, so the estimate is off by at most one) and corrected exactly.
#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
#[inline(always)]
fn div_small(u: u64, v: u64) -> u32 {
    let s = (64 - v.leading_zeros()).saturating_sub(24);
    // u >> s < 256·((v >> s) + 1) ≤ 2³²; v >> s < 2²⁴.
    let (u2, v2) = ((u >> s) as u32, ((v >> s) as u32).max(1));
    let k = u2 / v2;
    let prod = u64::from(k) * v; // k ≤ 256, v < 2⁵³
    if prod > u {
        k.wrapping_sub(1)
    } else if u - prod >= v {
        k + 1
    } else {
        k
    }
}

/// `(⌊a / b⌋, a mod b)` (floor division, remainder in `0..b`) for `b > 0`.
#[inline(always)]
fn floor_divmod(a: i32, b: i32) -> (i32, i32) {
    let (q, r) = (a / b.max(1), a % b.max(1));
    if r < 0 { (q - 1, r + b) } else { (q, r) }
}

/// The 8-bit output of one pixel and whether it saturated, from its weights `w_VIS`, `w_IR`
/// (`σ = w_VIS + w_IR`, `1 ≤ σ < 2²³`), without a 64-bit division.
///
/// With `num / den` the fused Q16 value ([`fraction`]), `num = 2¹⁵·N`,
/// `N = 2·taps·S + (w_VIS − w_IR)·(Σ_IR − Σ_VIS)`, `S = w_VIS·I_VIS + w_IR·I_IR`,
/// `den = taps·σ`, the raw value is `q = round(num/den)` (half away from zero) and the output
/// [`round_away_sat_u8`](super::round_away_sat_u8)`(q, 16)`. Both roundings fold into one floor
/// (nested floors of integers): output `= clamp(k, 0, 255)` with
/// `k = ⌊U / (2·den)⌋`, `U = N + den + ⌊den / 2¹⁶⌋`; `q` lies outside `[−2¹⁵, 255·2¹⁶ + 2¹⁵)`
/// exactly when `k ≥ 256`, `U < 0`, or `U = 0` with `2¹⁶ | den`.
///
/// When `σ < 2¹⁴` (always for the flight saliency) everything fits `i32`: with
/// `Σ_IR − Σ_VIS = 2·taps·a + r` (`|a| ≤ 128`, `0 ≤ r < 2·taps`), `⌊U / (2·taps)⌋ =
/// S + (w_VIS − w_IR)·a + ⌊((w_VIS − w_IR)·r + den + ⌊den/2¹⁶⌋) / (2·taps)⌋` and `k` is that
/// floor-divided by `σ`: three 32-bit divisions. Otherwise `U` is formed in `i64` and divided
/// by [`div_small`] (or by the hardware on x86-64).
#[inline(always)]
fn fused_u8(iv: u8, ii: u8, sv: i32, si: i32, wv: u32, wi: u32, taps: u32) -> (u8, bool) {
    // x86-64: one f64 division beats three dependent integer divisions.
    #[cfg(not(target_arch = "x86_64"))]
    if wv + wi < 1 << 14 {
        return fused_u8_small(iv, ii, sv, si, wv, wi, taps);
    }
    fused_u8_wide(iv, ii, sv, si, wv, wi, taps)
}

/// [`fused_u8`] for `σ < 2¹⁴`, all in `i32` with three 32-bit floor divisions.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
fn fused_u8_small(iv: u8, ii: u8, sv: i32, si: i32, wv: u32, wi: u32, taps: u32) -> (u8, bool) {
    let (sigma, taps) = ((wv + wi) as i32, taps as i32);
    let s = (wv * u32::from(iv) + wi * u32::from(ii)) as i32; // < 255·2¹⁴
    let (wd, c) = (wv as i32 - wi as i32, 2 * taps);
    let den = taps * sigma; // < 2²⁶
    let (a, r) = floor_divmod(si - sv, c);
    let (f, rt) = floor_divmod(wd * r + den + (den >> 16), c); // |·| < 2²⁸
    let x = s + wd * a + f; // ⌊U / (2·taps)⌋
    finish_u8(floor_divmod(x, sigma).0, x == 0 && rt == 0, den & 0xFFFF)
}

/// [`fused_u8`] for any `σ < 2²³`: `U` in `i64` (`|U| < 2⁴⁶`), `⌊U / (2·den)⌋` by
/// [`quotient`].
#[inline(always)]
fn fused_u8_wide(iv: u8, ii: u8, sv: i32, si: i32, wv: u32, wi: u32, taps: u32) -> (u8, bool) {
    let sigma = wv + wi;
    // taps ≤ 63² < 2¹², σ < 2²³: S < 255·2²³ < 2³¹.
    let s = wv * u32::from(iv) + wi * u32::from(ii);
    let den = u64::from(taps) * u64::from(sigma); // < 2³⁵
    let n = i64::from(2 * taps) * i64::from(s) + (i64::from(wv) - i64::from(wi)) * i64::from(si - sv);
    let u = n + (den + (den >> 16)) as i64;
    let v = den << 1;
    let k = if u < 0 {
        -1
    } else if u as u64 >= v << 8 {
        256
    } else {
        quotient(u as u64, v) as i32
    };
    finish_u8(k, u == 0, (den & 0xFFFF) as i32)
}

/// The output and the saturation flag from `k` (see [`fused_u8`]).
#[inline(always)]
fn finish_u8(k: i32, u_zero: bool, den_low: i32) -> (u8, bool) {
    let saturated = !(0..256).contains(&k) || (u_zero && den_low == 0);
    (k.clamp(0, 255) as u8, saturated)
}

/// `⌊u / v⌋` for `u < 256·v`, `v < 2³⁷` (`u < 2⁴⁵`): by [`div_small`] on the 32-bit targets;
/// on x86-64 by one `f64` division, exact here: `u` and `v` convert exactly (< 2⁵³), and a
/// quotient below the integer `k` misses it by at least `1/v ≥ 2⁻³⁷`, far more than the
/// division's rounding error `k·2⁻⁵³ < 2⁻⁴⁴`, so it never rounds up to `k` (and an exact
/// integer quotient stays exact).
#[inline(always)]
fn quotient(u: u64, v: u64) -> u32 {
    #[cfg(target_arch = "x86_64")]
    let k = (u as f64 / v as f64) as u32;
    #[cfg(not(target_arch = "x86_64"))]
    let k = div_small(u, v);
    k
}

/// The weights of the classic saliencies `(Σ − N·Med)²` from the two signed differences
/// (`|·| < 2²⁰`), as [`weights`] gives them, and `true` when both saliencies are 0.
#[inline(always)]
fn weights_classic(dv: i32, di: i32) -> (u32, u32, bool) {
    let square = |d: i32| u64::from(d.unsigned_abs()) * u64::from(d.unsigned_abs());
    let (wv, wi, _, zero) = weights(square(dv), square(di));
    (wv as u32, wi as u32, zero)
}

/// The weights of the flight saliencies (gradients ≤ 8160: their sum is already below 2²³,
/// nothing to shift), as [`weights`] gives them, and `true` when both are 0.
#[inline(always)]
fn weights_flight(gv: i32, gi: i32) -> (u32, u32, bool) {
    let (gv, gi) = (gv.unsigned_abs(), gi.unsigned_abs());
    let zero = gv == 0 && gi == 0;
    if zero { (1, 1, true) } else { (gv, gi, false) }
}

/// The 8-bit output of one pixel, [`round_away_sat_u8`](super::round_away_sat_u8)`(combine(…), 16)`
/// (see [`fused_u8`]); returns `(output, both saliencies 0, saturated)`.
#[cfg(test)]
fn combine_u8(iv: u8, ii: u8, sum_v: i32, sum_i: i32, sal_v: u64, sal_i: u64, taps: i64) -> (u8, bool, bool) {
    let (wv, wi, _, zero) = weights(sal_v, sal_i);
    let (out, saturated) = fused_u8(iv, ii, sum_v, sum_i, wv as u32, wi as u32, taps as u32);
    (out, zero, saturated)
}

/// The guards of a run: some pixel had both saliencies 0, some 8-bit output saturated.
fn guards_of(zero: bool, saturated: bool) -> Guards {
    let mut guards = Guards::NONE;
    if zero {
        guards |= Guards::TSIFSD_ZERO_SALIENCY;
    }
    if saturated {
        guards |= Guards::OUTPUT_SATURATED;
    }
    guards
}

/// Where [`run`] puts the fused rows.
enum Out<'a> {
    /// The 8-bit output ([`combine_u8`]).
    U8(FrameMut<'a, u8>),
    /// The raw Q16 values ([`combine`]).
    Raw(FrameMut<'a, i32>),
}

/// One chunk's pixels: box sums, the two saliency values (`saliency` turns them into weights),
/// and the pixels themselves.
struct Chunk<'a> {
    iv: &'a [u8],
    ii: &'a [u8],
    sv: &'a [i32],
    si: &'a [i32],
    a: &'a [i32],
    b: &'a [i32],
}

/// Fuses one chunk into the 8-bit `out`: `(some pixel had both saliencies 0, some output
/// saturated)`. `weights` turns the two saliency values into `(w_VIS, w_IR, both 0)`.
#[inline(always)]
fn fuse_chunk_u8(
    c: &Chunk<'_>,
    taps: u32,
    weights: impl Fn(i32, i32) -> (u32, u32, bool),
    out: &mut [u8],
) -> (bool, bool) {
    let (mut zero, mut saturated) = (false, false);
    let pixels = out.iter_mut().zip(c.iv).zip(c.ii).zip(c.sv).zip(c.si).zip(c.a).zip(c.b);
    for ((((((o, &iv), &ii), &sv), &si), &a), &b) in pixels {
        let (wv, wi, z) = weights(a, b);
        let (v, s) = fused_u8(iv, ii, sv, si, wv, wi, taps);
        *o = v;
        zero |= z;
        saturated |= s;
    }
    (zero, saturated)
}

/// Fuses one chunk into the raw Q16 `out`: `true` when some pixel had both saliencies 0.
#[inline(always)]
fn fuse_chunk_raw(c: &Chunk<'_>, taps: i64, saliency: impl Fn(i32) -> u64, out: &mut [i32]) -> bool {
    let mut zero = false;
    let pixels = out.iter_mut().zip(c.iv).zip(c.ii).zip(c.sv).zip(c.si).zip(c.a).zip(c.b);
    for ((((((o, &iv), &ii), &sv), &si), &a), &b) in pixels {
        let (v, z) = combine(iv, ii, sv, si, saliency(a), saliency(b), taps);
        *o = v;
        zero |= z;
    }
    zero
}

/// The rows `y − 1, y, y + 1` of a frame: outside rows are `None` (zeros) for the classic
/// variant and repeat the edge row for the flight variant.
fn rows3(f: FrameRef<'_, u8>, y: usize, classic: bool) -> [Option<&[u8]>; 3] {
    let h = f.height();
    if classic {
        [y.checked_sub(1).map(|r| f.row(r)), Some(f.row(y)), (y + 1 < h).then(|| f.row(y + 1))]
    } else {
        [Some(f.row_clamped(y as isize - 1)), Some(f.row(y)), Some(f.row_clamped(y as isize + 1))]
    }
}

/// `s[x0 .. x0 + n]` (empty when out of range).
#[inline(always)]
fn cut<T>(s: &[T], x0: usize, n: usize) -> &[T] {
    s.get(x0..x0 + n).unwrap_or(&[])
}

/// The one code path: box sums, then row by row and chunk by chunk the two saliencies and the
/// fused pixels into `out`. Returns the guards (`OUTPUT_SATURATED` only for the 8-bit output).
fn run(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    params: &TsifsdParams,
    scratch: &mut ScratchMut<'_>,
    out: Out<'_>,
) -> Result<Guards, Error> {
    params.validate()?;
    let (w, h) = vis.size();
    let [tmp, sum_v, sum_i] = scratch.planes(w * h)?;
    let radius = usize::from(params.mean_size / 2);
    let taps = i64::from(params.mean_size) * i64::from(params.mean_size);
    let classic = params.variant == Variant::Classic;
    let (zero, saturated) = match out {
        // Only Σ_IR − Σ_VIS enters the flight kernel; it keeps the window's column sums in one
        // padded row of `tmp` (a fallback for frames smaller than that row).
        Out::U8(f) if !classic && flight_fits(w, radius, tmp.len(), sum_v.len()) => {
            flight_u8(vis, tir, taps as u32, radius, tmp, sum_v, f, 0)
        }
        out => {
            box_sum_u8(vis, radius, params.mean_border(), tmp, sum_v)?;
            box_sum_u8(tir, radius, params.mean_border(), tmp, sum_i)?;
            saliency_reconstruct(vis, tir, sum_v, sum_i, taps, classic, out)
        }
    };
    Ok(guards_of(zero, saturated))
}

/// The general saliency and reconstruction (both variants, both outputs) after the box sums:
/// row by row ([`reconstruct_row`]) into `out`. Returns (some pixel had both saliencies 0,
/// some 8-bit output saturated).
fn saliency_reconstruct(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    sum_v: &[i32],
    sum_i: &[i32],
    taps: i64,
    classic: bool,
    mut out: Out<'_>,
) -> (bool, bool) {
    let w = vis.width();
    let (mut zero, mut saturated) = (false, false);
    for (y, (sv, si)) in sum_v.chunks_exact(w.max(1)).zip(sum_i.chunks_exact(w.max(1))).enumerate() {
        let dst = match &mut out {
            Out::U8(f) => RowOut::U8(f.row_mut(y)),
            Out::Raw(f) => RowOut::Raw(f.row_mut(y)),
        };
        let (z, s) =
            reconstruct_row(rows3(vis, y, classic), rows3(tir, y, classic), sv, si, taps, classic, dst);
        zero |= z;
        saturated |= s;
    }
    (zero, saturated)
}

/// Where [`reconstruct_row`] puts one fused row.
enum RowOut<'a> {
    U8(&'a mut [u8]),
    Raw(&'a mut [i32]),
}

/// One row, chunk by chunk: the two saliencies from the rows `y − 1, y, y + 1` of each band
/// (`rows_*`, the centre row given; classic: zero-padded median, saliency `(Σ − N·Med)²`;
/// flight: replicate-padded Scharr L1) and the row's box sums `sv`, `si`, then the fused
/// pixels. Returns (some pixel had both saliencies 0, some 8-bit output saturated).
fn reconstruct_row(
    rows_v: [Option<&[u8]>; 3],
    rows_t: [Option<&[u8]>; 3],
    sv: &[i32],
    si: &[i32],
    taps: i64,
    classic: bool,
    mut out: RowOut<'_>,
) -> (bool, bool) {
    let (Some(iv), Some(ii)) = (rows_v[1], rows_t[1]) else { return (false, false) };
    let w = iv.len();
    let border = if classic { Border::Zero } else { Border::Replicate };
    let (mut zero, mut saturated) = (false, false);
    let mut x0 = 0;
    while x0 < w {
        let n = CHUNK.min(w - x0);
        let (mut a, mut b) = ([0i32; CHUNK], [0i32; CHUNK]);
        let (Some(a), Some(b)) = (a.get_mut(..n), b.get_mut(..n)) else { break };
        let part = |s| cut(s, x0, n);
        if classic {
            for (rows, sums, dst) in [(rows_v, part(sv), &mut *a), (rows_t, part(si), &mut *b)] {
                let mut med = [0u8; CHUNK];
                median3_chunk(rows, border, x0, med.get_mut(..n).unwrap_or(&mut []));
                for ((d, &m), &s) in dst.iter_mut().zip(&med).zip(sums) {
                    *d = s - taps as i32 * i32::from(m); // |Σ − N·Med| < 2²⁰
                }
            }
        } else {
            scharr_l1_chunk(rows_v, border, x0, a);
            scharr_l1_chunk(rows_t, border, x0, b);
        }
        let chunk = Chunk { iv: cut(iv, x0, n), ii: cut(ii, x0, n), sv: part(sv), si: part(si), a, b };
        let square = |v: i32| u64::from(v.unsigned_abs()) * u64::from(v.unsigned_abs());
        let plain = |v: i32| u64::from(v.unsigned_abs());
        match &mut out {
            RowOut::U8(row) => {
                let dst = row.get_mut(x0..x0 + n).unwrap_or(&mut []);
                let (z, s) = if classic {
                    fuse_chunk_u8(&chunk, taps as u32, weights_classic, dst)
                } else {
                    fuse_chunk_u8(&chunk, taps as u32, weights_flight, dst)
                };
                zero |= z;
                saturated |= s;
            }
            RowOut::Raw(row) => {
                let dst = row.get_mut(x0..x0 + n).unwrap_or(&mut []);
                zero |= if classic {
                    fuse_chunk_raw(&chunk, taps, square, dst)
                } else {
                    fuse_chunk_raw(&chunk, taps, plain, dst)
                };
            }
        }
        x0 += n;
    }
    (zero, saturated)
}

/// Rows of lane words the flight kernel keeps ([`flight_u8`]): the `2r + 2` rows of the
/// 35×35 window's entering and leaving rows plus one ahead (`2r + 3`).
pub(crate) const fn lane_ring_rows(radius: usize) -> usize {
    2 * radius + 3
}

/// `i32` words the flight kernel needs for a `w`-wide frame: the padded column-sum row
/// (`w + 2r + 1`) and the lane ring (`(2r + 3)·w`) — independent of the frame height.
pub(crate) const fn flight_words(w: usize, radius: usize) -> usize {
    w + 2 * radius + 1 + lane_ring_rows(radius) * w
}

/// Whether the flight kernel fits: `cols` words for the column sums, `lanes` for the ring.
fn flight_fits(w: usize, radius: usize, cols: usize, lanes: usize) -> bool {
    cols > w + 2 * radius && lanes >= lane_ring_rows(radius) * w
}

/// The flight variant's 8-bit fusion, row by row (replicate borders throughout): the rows
/// `y0 .. y0 + out.height()` of the frame pair `(vis, tir)` into `out`.
///
/// Both bands' pixels go into lane words ([`lane_pair`]: VIS + IR·2¹⁶), kept in a ring of
/// [`lane_ring_rows`] rows of `lanes` (`(2r + 3)·W` words): the rows `y − r − 1 ..= y + r + 1`
/// around output row `y`, keyed by their unclamped index (a key beyond the frame holds the
/// edge row), each converted once when it enters.
/// Only `d = Σ_IR − Σ_VIS` of the box sums enters ([`fused_u8`] in the form below), so the
/// window sums are of the difference `I_IR − I_VIS`: `cols` (at least `W + 2r + 1` entries)
/// keeps each column's vertical window sum at `r + x`, summed over the window at the first
/// row and then updated by one entering and one leaving row per output row ([`column_step`])
/// and padded with copies of the edge columns (`r` on the left, `r + 1` on the right), so the
/// horizontal running sum over it needs no border test. Then, chunk by chunk of the row, in short passes (few
/// live values each): the weight-free part of each pixel, packed as below; the Scharr columns
/// of both bands ([`scharr_columns_pair`]); per pixel the weights ([`scharr_l1_pair`],
/// `w_VIS + w_IR·2¹⁶`) and the output. Returns (some pixel had both gradients 0, some output
/// saturated). The memory does not grow with the frame height, and any row range gives the
/// rows of the whole-frame run: the strip pipeline ([`crate::strips`]) runs it on windows.
/// The caller checks the memory ([`flight_fits`], [`flight_words`]): with short `cols` or
/// `lanes` the kernel writes nothing and returns `(false, false)`.
///
/// With `c = 2·taps`, `d = c·(a − 128) + r` (`a = ⌊(d + 128c)/c⌋ ∈ [0, 255]`,
/// `0 ≤ r < c ≤ 7938`), `q_VIS = I_VIS + a ∈ [0, 510]`, `q_IR = I_IR − a + 255 ∈ [0, 510]`
/// (packed `q_VIS + q_IR·2⁹ + (r + taps)·2¹⁸`, `r + taps < 3·taps < 2¹⁴`), the numerator
/// of [`fused_u8`] is `U = c·(w_VIS·(q_VIS − 128) + w_IR·(q_IR − 128)) + w_VIS·r +
/// w_IR·(c − r) + e`, `e = den + ⌊den/2¹⁶⌋`, `den = taps·σ`, so `x = ⌊U/c⌋ = w_VIS·q_VIS +
/// w_IR·q_IR − 128σ + ⌊(w_VIS·(r + taps) + w_IR·(2c − r − taps) + ⌊den/2¹⁶⌋)/c⌋` (that
/// numerator is non-negative and below 2²⁸: one unsigned 32-bit division) and the output is
/// `k = ⌊x/σ⌋ = ⌊(x + 128σ)/σ⌋ − 128` (`x + 128σ ≥ 0`: another unsigned division) clamped
/// to `0..=255`, saturated exactly when `k ∉ 0..256` (σ ≤ 16320 < 2¹⁶ and `taps` is odd, so
/// `2¹⁶ ∤ den` and the `U = 0` edge of [`fused_u8`] never arises).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn flight_u8_kernel<const WIDE: bool>(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    taps: u32,
    radius: usize,
    cols: &mut [i32],
    lanes: &mut [i32],
    mut out: FrameMut<'_, u8>,
    y0: usize,
) -> (bool, bool) {
    const TWO: NonZeroU32 = NonZeroU32::MIN.saturating_add(1);
    let (w, h) = vis.size();
    let c = NonZeroU32::new(2 * taps).unwrap_or(TWO);
    let by_c = ByC(c);
    let bias = 128 * c.get() as i32; // d + 128c > 0: |d| ≤ 255·taps
    // q = I_VIS + I_IR·2⁹ + dd·2¹⁸ + a·(1 − 2⁹ − c·2¹⁸) + 255·2⁹ + taps·2¹⁸ (wrapping; exact
    // in the end).
    let a_factor = 1u32.wrapping_sub(1 << 9).wrapping_sub(c.get() << 18);
    let q_const = (255 << 9) + (taps << 18);
    let (mut zero, mut sat) = (false, 0i32);
    let k = Consts { c, by_c, inv_c: 1.0 / f64::from(c.get()), taps, a_factor, q_const };
    // Per column of a chunk: the two lane words of the Scharr columns and, one column to the
    // right of its pixel (the centre of its window), the packed weight-free part.
    let mut buf = [[0u32; 3]; CHUNK + 2];
    let mut wide = Wide::new();
    let span = 2 * radius + 1;
    let Some(cols) = cols.get_mut(..w + span) else { return (zero, false) };
    let ring = lane_ring_rows(radius) as isize;
    let Some(lanes) = lanes.get_mut(..ring as usize * w) else { return (zero, false) };
    let slot = |k: isize| k.checked_rem_euclid(ring).unwrap_or(0) as usize * w;
    // Converts the (clamped) frame row `k` into the ring slot of key `k`.
    let fill = |lanes: &mut [i32], k: isize| {
        let dst = lanes.get_mut(slot(k)..slot(k) + w).unwrap_or(&mut []);
        for ((o, &v), &t) in dst.iter_mut().zip(vis.row_clamped(k)).zip(tir.row_clamped(k)) {
            *o = lane_pair(v, t);
        }
    };
    let first = y0 as isize;
    for k in first - radius as isize - 1..=first + radius as isize + 1 {
        fill(lanes, k);
    }
    // The lane weights of `column_step` (opaque: kept in registers, not rebuilt per pixel).
    let lane_weights = core::hint::black_box(LANE_WEIGHTS);
    for (y, dst) in (y0..h).zip(out.rows_mut()) {
        let yi = y as isize;
        if yi > first {
            fill(lanes, yi + radius as isize + 1);
        }
        let (left, rest) = cols.split_at_mut(radius.min(cols.len()));
        let (mid, right) = rest.split_at_mut(w.min(rest.len()));
        let lane_row = |k: isize| lanes.get(slot(k)..slot(k) + w).unwrap_or(&[]);
        if yi == first {
            mid.fill(0);
            for k in yi - radius as isize..=yi + radius as isize {
                for ((m, &t), &v) in mid.iter_mut().zip(tir.row_clamped(k)).zip(vis.row_clamped(k)) {
                    *m += i32::from(t) - i32::from(v);
                }
            }
        } else {
            let (enter, leave) = (lane_row(yi + radius as isize), lane_row(yi - radius as isize - 1));
            for ((m, &e), &l) in mid.iter_mut().zip(enter).zip(leave) {
                *m = column_step(*m, e, l, lane_weights);
            }
        }
        let (first_col, last_col) = (mid.first().copied().unwrap_or(0), mid.last().copied().unwrap_or(0));
        left.fill(first_col);
        right.fill(last_col);
        let cols = &*cols;
        // The running window sum of the pixel x = the sum of cols[x ..= x + 2r], plus the bias.
        let mut sum = cols.iter().take(span).sum::<i32>() + bias;
        let rows = [lane_row(yi - 1), lane_row(yi), lane_row(yi + 1)];
        let (iv, ii) = (vis.row(y), tir.row(y));
        let mut x0 = 0;
        while x0 < w {
            let n = CHUNK.min(w - x0);
            let chunk = FlightChunk {
                enter: cols.get(x0 + span..x0 + span + n).unwrap_or(&[]),
                leave: cols.get(x0..x0 + n).unwrap_or(&[]),
                iv: cut(iv, x0, n),
                ii: cut(ii, x0, n),
                rows,
                x0,
            };
            let o = dst.get_mut(x0..x0 + n).unwrap_or(&mut []);
            if WIDE {
                chunk_wide(&chunk, &k, &mut sum, &mut wide, o, &mut zero, &mut sat);
            } else {
                chunk_portable(&chunk, &k, &mut sum, &mut buf, o, &mut zero, &mut sat);
            }
            x0 += n;
        }
    }
    (zero, sat != 0)
}

/// Whether the flight kernel's chunks take the wide form ([`chunk_wide`]: `f64` divisions in
/// separate passes the compiler vectorises, on x86-64) or the portable one ([`chunk_portable`]:
/// integer divisions in one pass, the fewest instructions on the flight targets). Both give
/// the same bytes (unit test `wide_and_portable_chunks_agree`).
const WIDE_CHUNKS: bool = cfg!(target_arch = "x86_64");

/// The per-frame constants of the flight kernel's output (see [`flight_u8_kernel`]).
struct Consts {
    c: NonZeroU32,
    by_c: ByC,
    /// `1/c` in `f64` for [`div_c_f64`].
    inv_c: f64,
    taps: u32,
    a_factor: u32,
    q_const: u32,
}

/// One chunk of a row: the column sums entering and leaving each pixel's window, the pixels,
/// the three lane rows of the Scharr columns and the chunk's first column.
struct FlightChunk<'a> {
    enter: &'a [i32],
    leave: &'a [i32],
    iv: &'a [u8],
    ii: &'a [u8],
    rows: [&'a [i32]; 3],
    x0: usize,
}

/// The packed weight-free part of a pixel (see [`flight_u8_kernel`]) from its window sum
/// `dd` (biased) and `a = ⌊dd/c⌋`.
#[inline(always)]
fn packed(k: &Consts, dd: u32, a: u32, iv: u8, ii: u8) -> u32 {
    let low = u32::from(iv) + (u32::from(ii) << 9) + k.q_const;
    a.wrapping_mul(k.a_factor).wrapping_add(dd << 18).wrapping_add(low)
}

/// The 8-bit output of a pixel from its weights (`σ = w_VIS + w_IR > 0`) and packed part,
/// with the two divisions given: `(value, k >> 8)` (non-zero when saturated).
#[inline(always)]
fn output(
    k: &Consts,
    (gv, gi, sigma): (u32, u32, u32),
    q: u32,
    div_c: impl Fn(u32) -> u32,
    div_s: impl Fn(u32, u32) -> u32,
) -> (u8, i32) {
    let (qv, qi, rt) = (q & 0x1FF, q >> 9 & 0x1FF, q >> 18);
    // w_VIS·r + w_IR·(c − r) + den = w_VIS·(r + taps) + w_IR·(2c − (r + taps)).
    let f = div_c(gv * rt + gi * (2 * k.c.get() - rt) + ((k.taps * sigma) >> 16));
    // ⌊x/σ⌋ = ⌊(x + 128σ)/σ⌋ − 128, and x + 128σ ≥ 0.
    let v = div_s(gv * qv + gi * qi + f, sigma) as i32 - 128;
    (v.clamp(0, 255) as u8, v >> 8)
}

/// One chunk in one pass with integer divisions (the flight targets: one `udiv` each).
#[inline(always)]
fn chunk_portable(
    ch: &FlightChunk<'_>,
    k: &Consts,
    sum: &mut i32,
    buf: &mut [[u32; 3]; CHUNK + 2],
    out: &mut [u8],
    zero: &mut bool,
    sat: &mut i32,
) {
    let n = out.len();
    let Some(buf) = buf.get_mut(..n + 2) else { return };
    let pixels = ch.iv.iter().zip(ch.ii);
    for ((b, (&enter, &leave)), (&iv, &ii)) in
        buf.iter_mut().skip(1).zip(ch.enter.iter().zip(ch.leave)).zip(pixels)
    {
        let dd = *sum as u32;
        *sum += enter - leave;
        b[2] = packed(k, dd, k.by_c.div(dd), iv, ii);
    }
    let store = |[s, d, _]: &mut [u32; 3], sm, df| (*s, *d) = (sm, df);
    scharr_columns_pair(ch.rows, Border::Replicate, ch.x0, buf, store);
    for (o, w) in out.iter_mut().zip(buf.windows(3)) {
        let &[[s0, d0, _], [_, d1, q], [s2, d2, _]] = w else { continue };
        let wts = scharr_l1_pair([s0, s2], [d0, d1, d2]);
        let (gv, gi) = (wts & 0xFFFF, wts >> 16);
        let (gv, gi, sigma) = match NonZeroU32::new(gv + gi) {
            Some(sigma) => (gv, gi, sigma),
            None => flat(zero),
        };
        let (v, s) = output(k, (gv, gi, sigma.get()), q, |n| k.by_c.div(n), |n, _| div_sigma(n, sigma));
        *o = v;
        *sat |= s;
    }
}

/// The wide form's chunk buffers: window sums, packed parts, Scharr columns.
struct Wide {
    dd: [u32; CHUNK],
    q: [u32; CHUNK],
    sd: [[u32; 2]; CHUNK + 2],
}

impl Wide {
    fn new() -> Self {
        Self { dd: [0; CHUNK], q: [0; CHUNK], sd: [[0; 2]; CHUNK + 2] }
    }
}

/// `⌊n / c⌋` in `f64` for `n < 2²⁸`, `c < 2¹³` (vectorisable): `n·fl(1/c)` is within 2⁻²⁵ of
/// `n/c`; adding 2⁻²⁰ lifts an exact quotient above its integer, and a non-integer quotient is
/// at least `1/c > 2⁻¹³` below the next one, so truncation gives the floor.
#[inline(always)]
fn div_c_f64(n: u32, inv_c: f64) -> u32 {
    trunc_u32(f64::from(n as i32) * inv_c + 1.0 / (1u32 << 20) as f64)
}

/// `⌊n / σ⌋` of the flight kernel's last division in `f32` (vectorisable, 8 lanes with AVX2):
/// `n < 2²⁴` and `σ ≤ 16320` are exact in `f32`, the quotient is below 2¹⁰ (`n ≤ 512σ + 1`),
/// so the correctly rounded quotient is within 2⁻²⁴·2¹⁰ = 2⁻¹⁴ of the true one, less than the
/// distance `≥ 1/σ > 2⁻¹⁴` of a non-integer quotient to the next integer: truncation gives the
/// floor (tested against the integer division over the whole range of `σ`).
#[inline(always)]
fn div_sigma_f32(n: u32, sigma: u32) -> u32 {
    const MAGIC: f32 = (1u32 << 23) as f32;
    let x = (n as i32) as f32 / (sigma as i32) as f32;
    let r = (x + MAGIC).to_bits() & 0x7F_FFFF;
    r - u32::from((r as i32) as f32 > x)
}

/// `⌊x⌋` for `0 ≤ x < 2³¹` in lane-wise arithmetic the compiler keeps vectorised (`as` would
/// add a saturation and NaN test per lane): adding 2⁵² rounds `x` to the nearest integer `r`
/// in the low mantissa bits; `r − 1` when that rounded up.
#[inline(always)]
fn trunc_u32(x: f64) -> u32 {
    const MAGIC: f64 = (1u64 << 52) as f64;
    let r = (x + MAGIC).to_bits() as u32;
    r - u32::from(f64::from(r as i32) > x)
}

/// One chunk in separate short passes without branches or integer divisions ([`div_c_f64`] in
/// `f64`, [`div_sigma_f32`] in `f32`), which the compiler vectorises (the AVX2 copy on x86-64).
#[inline(always)]
fn chunk_wide(
    ch: &FlightChunk<'_>,
    k: &Consts,
    sum: &mut i32,
    wide: &mut Wide,
    out: &mut [u8],
    zero: &mut bool,
    sat: &mut i32,
) {
    let n = out.len();
    let (Some(dd), Some(q), Some(sd)) = (wide.dd.get_mut(..n), wide.q.get_mut(..n), wide.sd.get_mut(..n + 2))
    else {
        return;
    };
    for (d, (&enter, &leave)) in dd.iter_mut().zip(ch.enter.iter().zip(ch.leave)) {
        *d = *sum as u32;
        *sum += enter - leave;
    }
    for ((q, &dd), (&iv, &ii)) in q.iter_mut().zip(&*dd).zip(ch.iv.iter().zip(ch.ii)) {
        *q = packed(k, dd, div_c_f64(dd, k.inv_c), iv, ii);
    }
    scharr_columns_pair(ch.rows, Border::Replicate, ch.x0, sd, |o: &mut [u32; 2], s, d| *o = [s, d]);
    let (left, mid, right) =
        (sd.get(..n).unwrap_or(&[]), sd.get(1..).unwrap_or(&[]), sd.get(2..).unwrap_or(&[]));
    let (mut flat_any, mut sat_any) = (0u32, 0i32);
    for ((((o, &q), &[s0, d0]), &[_, d1]), &[s2, d2]) in out.iter_mut().zip(&*q).zip(left).zip(mid).zip(right)
    {
        let wts = scharr_l1_pair([s0, s2], [d0, d1, d2]);
        let (gv, gi) = (wts & 0xFFFF, wts >> 16);
        let flat = u32::from(gv + gi == 0);
        flat_any |= flat;
        let (gv, gi) = (gv | flat, gi | flat); // both 0: the ½, ½ weights (1, 1)
        let sigma = gv + gi;
        let div_s = |n: u32, s: u32| div_sigma_f32(n, s);
        let (v, s) = output(k, (gv, gi, sigma), q, |n| div_c_f64(n, k.inv_c), div_s);
        *o = v;
        sat_any |= s;
    }
    *zero |= flat_any != 0;
    *sat |= sat_any;
}

crate::cpu::dispatch! {
    /// [`flight_u8_kernel`] in this target's chunk form (an AVX2-compiled copy on x86-64 CPUs
    /// that have AVX2).
    #[allow(clippy::too_many_arguments)]
    fn flight_u8(
        vis: FrameRef<'_, u8>,
        tir: FrameRef<'_, u8>,
        taps: u32,
        radius: usize,
        cols: &mut [i32],
        lanes: &mut [i32],
        out: FrameMut<'_, u8>,
        y0: usize,
    ) -> (bool, bool) => flight_u8_kernel::<WIDE_CHUNKS>
}

/// `⌊n / c⌋` for the frame's constant `c = 2·taps` (the portable chunk form: one `udiv` on the
/// flight targets; the wide form uses [`div_c_f64`]).
#[derive(Clone, Copy)]
struct ByC(NonZeroU32);

impl ByC {
    #[inline(always)]
    fn div(self, n: u32) -> u32 {
        n / self.0
    }
}

/// `⌊n / σ⌋` of the portable chunk form (the wide form uses [`div_sigma_f32`]).
#[inline(always)]
fn div_sigma(n: u32, sigma: NonZeroU32) -> u32 {
    n / sigma
}

/// The lane weights (−1, 1) and (1, −1) of [`column_step`] (low lane first).
const LANE_WEIGHTS: [i32; 2] = [0x0001_FFFF, 0xFFFF_0001u32 as i32];

/// `col + (I_IR − I_VIS)(entering) − (I_IR − I_VIS)(leaving)` from two lane words
/// ([`lane_pair`]: VIS + IR·2¹⁶): on Arm two dual multiply-accumulates (`smlad` with the lane
/// weights `[up, down]` = [`LANE_WEIGHTS`]), else lane by lane.
#[inline(always)]
#[cfg_attr(not(fusion_arm_dsp), allow(unused_variables))]
fn column_step(col: i32, enter: i32, leave: i32, [up, down]: [i32; 2]) -> i32 {
    #[cfg(fusion_arm_dsp)]
    {
        let out: i32;
        // SAFETY: register-only Armv7E-M DSP instructions (no memory, no stack, no flags but
        // the sticky Q, which cannot be set here: |products| ≤ 255 and |col| < 2³⁰).
        unsafe {
            core::arch::asm!(
                "smlad {o}, {e}, {up}, {c}",
                "smlad {o}, {l}, {down}, {o}",
                o = out(reg) out,
                e = in(reg) enter,
                l = in(reg) leave,
                c = in(reg) col,
                up = in(reg) up,
                down = in(reg) down,
                options(pure, nomem, nostack, preserves_flags),
            );
        }
        out
    }
    #[cfg(not(fusion_arm_dsp))]
    {
        let diff = |v: i32| (v >> 16) - (v & 0xFFFF);
        col + diff(enter) - diff(leave)
    }
}

/// The weights `(1, 1, σ = 2)` of a pixel whose two saliencies are 0, noting it in `zero`
/// (rare: kept out of the hot loop).
#[cold]
#[inline(never)]
fn flat(zero: &mut bool) -> (u32, u32, NonZeroU32) {
    *zero = true;
    (1, 1, NonZeroU32::MIN.saturating_add(1))
}

/// Fuses a VIS/TIR pair with TSIFSD into the 8-bit `out` (MATLAB `uint8` cast of the raw value).
///
/// All three frames must have the same size ([`Error::SizeMismatch`]); the scratch must hold
/// three planes of W·H ([`Error::ScratchTooSmall`]); bad parameters give
/// [`Error::InvalidParameter`]. Returns the guards fired (see the module docs).
pub fn fuse_tsifsd(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    params: &TsifsdParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    check_sizes(&vis, &tir, out.size())?;
    run(vis, tir, params, scratch, Out::U8(out))
}

/// Fuses like [`fuse_tsifsd`] but writes the real-valued result before the 8-bit cast in Q16
/// ([`RAW_FRAC_BITS`]; `raw / 65536.0` grey levels). [`fuse_tsifsd`] is this value cast with
/// [`round_away_sat_u8`](super::round_away_sat_u8)`(raw, 16)`.
pub fn fuse_tsifsd_raw(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    raw: FrameMut<'_, i32>,
    params: &TsifsdParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    check_sizes(&vis, &tir, raw.size())?;
    run(vis, tir, params, scratch, Out::Raw(raw))
}

/// The flight variant's 8-bit rows `y0 .. y0 + out.height()` of the TSIFSD fusion of the pair
/// `(vis, tir)`, the same bytes as those rows of [`fuse_tsifsd`] on the pair, from `work`
/// alone: [`flight_words`]`(W, r)` words whatever the height (the strip pipeline,
/// [`crate::strips`]). Returns the guards those rows fired.
///
/// Errors: [`Error::SizeMismatch`] (`vis`, `tir` sizes; `out` not `W` wide or reaching past the
/// frame's last row), [`Error::InvalidParameter`] (`"variant"` for the classic variant, whose
/// circular mean and zero-padded median have no row-local form here; bad parameters),
/// [`Error::ScratchTooSmall`].
pub(crate) fn fuse_tsifsd_flight_rows(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    y0: usize,
    params: &TsifsdParams,
    work: &mut [i32],
) -> Result<Guards, Error> {
    params.validate()?;
    if params.variant != Variant::Flight {
        return Err(Error::InvalidParameter { name: "variant" });
    }
    let (w, h) = vis.size();
    check_sizes(&vis, &tir, vis.size())?;
    if out.width() != w || y0 + out.height() > h {
        return Err(Error::SizeMismatch { expected: (w, h - y0.min(h)), got: out.size() });
    }
    let radius = usize::from(params.mean_size / 2);
    let needed = flight_words(w, radius);
    let capacity = work.len();
    let (cols, lanes) = work
        .get_mut(..needed)
        .and_then(|m| m.split_at_mut_checked(w + 2 * radius + 1))
        .ok_or(Error::ScratchTooSmall { needed, capacity })?;
    let taps = u32::from(params.mean_size) * u32::from(params.mean_size);
    let (zero, saturated) = flight_u8(vis, tir, taps, radius, cols, lanes, out, y0);
    Ok(guards_of(zero, saturated))
}

/// `i32` words [`fuse_tsifsd_classic_rows`] needs at width `w`: the window's column sums and
/// the box-sum row of both bands.
pub(crate) const fn classic_words(w: usize) -> usize {
    4 * w
}

/// The classic variant's 8-bit rows `rows` of the TSIFSD fusion of a `grid`-sized pair, the
/// same bytes as those rows of [`fuse_tsifsd`] on the whole pair, from `work` alone
/// ([`classic_words`]`(W)` words whatever the height; the strip pipeline, [`crate::strips`]).
/// `vis_row(y)` and `tir_row(y)` give grid row `y` (`W` pixels) of each band. The kernel asks
/// for the rows `y − r ..= y + r` of its output rows wrapped around the frame (the circular
/// mean: the top rows' windows read the bottom rows) and for `y ± 1` inside it (the
/// zero-padded median). It keeps the window's column sums and slides them one row at a time;
/// the horizontal circular sums of those columns are the box sums, exactly. Returns the guards
/// those rows fired.
///
/// Errors: [`Error::InvalidParameter`] (`"variant"` for the flight variant, bad parameters),
/// [`Error::SizeMismatch`] (`out` not `W × rows.len()`, `rows` past the frame; or a band row
/// the callbacks do not give at width `W`, reported as `got: (0, y)` for row `y` — a caller's
/// bug, which the strip walk never makes), [`Error::ScratchTooSmall`].
pub(crate) fn fuse_tsifsd_classic_rows<'a>(
    vis_row: impl Fn(usize) -> Option<&'a [u8]>,
    tir_row: impl Fn(usize) -> Option<&'a [u8]>,
    grid: (usize, usize),
    rows: core::ops::Range<usize>,
    mut out: FrameMut<'_, u8>,
    params: &TsifsdParams,
    work: &mut [i32],
) -> Result<Guards, Error> {
    params.validate()?;
    if params.variant != Variant::Classic {
        return Err(Error::InvalidParameter { name: "variant" });
    }
    let (w, h) = grid;
    if out.width() != w || out.height() != rows.len() || rows.end > h {
        return Err(Error::SizeMismatch { expected: (w, rows.len()), got: out.size() });
    }
    let needed = classic_words(w);
    let capacity = work.len();
    let too_small = Error::ScratchTooSmall { needed, capacity };
    let work = work.get_mut(..needed).ok_or(too_small)?;
    let (cols, sums) = work.split_at_mut_checked(2 * w).ok_or(too_small)?;
    let ((col_v, col_i), (sum_v, sum_i)) =
        (cols.split_at_mut_checked(w).ok_or(too_small)?, sums.split_at_mut_checked(w).ok_or(too_small)?);
    let band = |f: &dyn Fn(usize) -> Option<&'a [u8]>, y: usize| {
        f(y).filter(|r| r.len() == w).ok_or(Error::SizeMismatch { expected: (w, h), got: (0, y) })
    };
    let both = |y: usize| Ok::<_, Error>((band(&vis_row, y)?, band(&tir_row, y)?));
    // Row `y + k` wrapped into the frame, in unsigned arithmetic (no overflow case).
    let hh = h.max(1);
    let wrap = |y: usize, k: isize| {
        let (y, step) = (y % hh, k.unsigned_abs() % hh);
        if k < 0 { (y + hh - step) % hh } else { (y + step) % hh }
    };
    let radius = usize::from(params.mean_size / 2);
    let r = radius as isize;
    let taps = i64::from(params.mean_size) * i64::from(params.mean_size);
    // The column sums of the first row's window.
    col_v.fill(0);
    col_i.fill(0);
    for k in -r..=r {
        let (v, t) = both(wrap(rows.start, k))?;
        col_v.iter_mut().zip(v).for_each(|(c, &p)| *c += i32::from(p));
        col_i.iter_mut().zip(t).for_each(|(c, &p)| *c += i32::from(p));
    }
    let (mut zero, mut saturated) = (false, false);
    for (i, y) in rows.clone().enumerate() {
        if i > 0 {
            // Slide the window down one row: row y + r enters, row y − 1 − r leaves.
            let ((ev, et), (lv, lt)) = (both(wrap(y, r))?, both(wrap(y, -1 - r))?);
            for (c, (&e, &l)) in col_v.iter_mut().zip(ev.iter().zip(lv)) {
                *c += i32::from(e) - i32::from(l);
            }
            for (c, (&e, &l)) in col_i.iter_mut().zip(et.iter().zip(lt)) {
                *c += i32::from(e) - i32::from(l);
            }
        }
        horizontal(col_v, radius, Border::Circular, sum_v);
        horizontal(col_i, radius, Border::Circular, sum_i);
        // The median's rows: zero outside the frame (as `rows3`).
        let near = |k: isize| match y.checked_add_signed(k).filter(|&yy| yy < h) {
            Some(yy) => both(yy).map(Some),
            None => Ok(None),
        };
        let split = |p: Option<(&'a [u8], &'a [u8])>| (p.map(|p| p.0), p.map(|p| p.1));
        let ((v0, t0), (v1, t1), (v2, t2)) = (split(near(-1)?), split(near(0)?), split(near(1)?));
        let (z, s) =
            reconstruct_row([v0, v1, v2], [t0, t1, t2], sum_v, sum_i, taps, true, RowOut::U8(out.row_mut(i)));
        zero |= z;
        saturated |= s;
    }
    Ok(guards_of(zero, saturated))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::super::round_away_sat_u8;
    use super::*;
    use crate::Scratch;

    /// The 8-bit combine against the cast of the exact raw value, and its saturation flag,
    /// on random pixels (huge and zero saliencies, every tap count, extreme box sums).
    #[test]
    fn combine_u8_is_the_cast_of_combine() {
        let mut s = 11u64;
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            s >> 17
        };
        for k in 0..400_000u32 {
            let n = 2 * (next() % 32) as i64 + 1;
            let taps = n * n;
            let (iv, ii) = ((next() & 255) as u8, (next() & 255) as u8);
            let sum = |r: u64| match r % 4 {
                0 => 0,
                1 => (255 * taps) as i32,
                _ => (r % (255 * taps as u64 + 1)) as i32,
            };
            let (sv, si) = (sum(next()), sum(next()));
            let sal = |r: u64| match k.wrapping_add(r as u32) % 5 {
                0 => 0,
                1 => r % 8161,
                2 => r >> (r % 47),
                3 => 1 << (r % 41),
                _ => r % (1 << 40),
            };
            let (sal_v, sal_i) = (sal(next()), sal(next()));
            let (raw, zero) = combine(iv, ii, sv, si, sal_v, sal_i, taps);
            let want = round_away_sat_u8(i64::from(raw), RAW_FRAC_BITS);
            let want_sat = !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&raw);
            let got = combine_u8(iv, ii, sv, si, sal_v, sal_i, taps);
            assert_eq!(got, (want, zero, want_sat), "{iv} {ii} {sv} {si} {sal_v} {sal_i} {taps}");
        }
    }

    /// Small weights, every pixel pair class and a dense grid of box sums, exhaustively: the
    /// ties and the saturation edges (`U = 0`, `k = 256`) of [`fused_u8`] included.
    #[test]
    fn combine_u8_on_a_dense_small_grid() {
        for taps in [1i64, 9, 25] {
            let top = 255 * taps as i32;
            for wv in 0..6u64 {
                for wi in 0..6u64 {
                    for iv in [0u8, 1, 2, 127, 128, 254, 255] {
                        for ii in [0u8, 1, 128, 255] {
                            for sv in (0..=top).step_by((taps as usize * 7).max(1)) {
                                for si in (0..=top).step_by((taps as usize * 5).max(1)) {
                                    let (raw, zero) = combine(iv, ii, sv, si, wv, wi, taps);
                                    let want = round_away_sat_u8(i64::from(raw), RAW_FRAC_BITS);
                                    let want_sat = !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&raw);
                                    let got = combine_u8(iv, ii, sv, si, wv, wi, taps);
                                    assert_eq!(
                                        got,
                                        (want, zero, want_sat),
                                        "{iv} {ii} {sv} {si} {wv} {wi} {taps}"
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
    }

    /// `U = 0` with `2¹⁶ | den`: `N = −den − den/2¹⁶` (σ = 2¹⁷, taps = 1), the raw value is
    /// `round(−32768.5) = −32769`, saturated low although `k = 0`.
    #[test]
    fn combine_u8_low_saturation_edge() {
        let (raw, _) = combine(253, 0, 0, 2, 257, 130815, 1);
        assert_eq!(raw, -32769);
        assert_eq!(combine_u8(253, 0, 0, 2, 257, 130815, 1), (0, false, true));
        let (raw, zero) = combine(253, 0, 0, 2, 257, 130815, 9);
        let sat = !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&raw);
        assert_eq!(
            combine_u8(253, 0, 0, 2, 257, 130815, 9),
            (round_away_sat_u8(i64::from(raw), 16), zero, sat)
        );
    }

    /// Both forms of [`fused_u8`] (the `i32` one runs only on the 32-bit targets) on small
    /// weights, and the `f64` quotient against the integer division.
    #[test]
    fn small_and_wide_forms_agree() {
        let mut s = 77u64;
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            s >> 16
        };
        for k in 0..300_000u32 {
            let n = 2 * (next() % 32) as u32 + 1;
            let taps = n * n;
            let top = 255 * taps as u64 + 1;
            let (sv, si) = ((next() % top) as i32, (next() % top) as i32);
            let (iv, ii) = ((next() & 255) as u8, (next() & 255) as u8);
            let (mut wv, mut wi) = ((next() % (1 << 13)) as u32, (next() % (1 << 13)) as u32);
            if k % 7 == 0 {
                (wv, wi) = (wv % 3, wi % 3);
            }
            if wv + wi == 0 {
                wv = 1;
            }
            assert_eq!(
                fused_u8_small(iv, ii, sv, si, wv, wi, taps),
                fused_u8_wide(iv, ii, sv, si, wv, wi, taps),
                "{iv} {ii} {sv} {si} {wv} {wi} {taps}"
            );
            let v = (next() >> (next() % 28)).clamp(1, (1 << 37) - 1);
            let u = (next() % 256) * v + next() % v;
            assert_eq!(u64::from(quotient(u, v)), u / v, "{u} {v}");
            assert_eq!(u64::from(div_small(u, v)), u / v, "{u} {v}");
        }
    }

    #[test]
    fn div_small_is_exact() {
        let mut s = 5u64;
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            s
        };
        for _ in 0..1_000_000 {
            let v = (next() >> (11 + next() % 53)).max(1);
            let k = next() % 256;
            let u = k * v + next() % v;
            assert_eq!(u64::from(div_small(u, v)), u / v, "{u} {v}");
        }
        for v in [1u64, 2, 3, (1 << 24) - 1, 1 << 24, (1 << 24) + 1, (1 << 52) - 1] {
            for u in [0, v - 1, v, 255 * v, 256 * v - 1] {
                assert_eq!(u64::from(div_small(u, v)), u / v, "{u} {v}");
            }
        }
    }

    /// The 8-bit path equals the cast of the raw path on whole frames (both variants; a
    /// checkerboard drives the classic output far out of range).
    #[test]
    fn u8_path_is_the_cast_of_the_raw_path() -> Result<(), Error> {
        let (w, h) = (37usize, 29usize);
        let mut s = 1u32;
        let mut frame = |checker: bool| -> std::vec::Vec<u8> {
            (0..w * h)
                .map(|i| {
                    s = s.wrapping_mul(1664525).wrapping_add(1013904223);
                    if checker { if (i % w + i / w) % 2 == 0 { 255 } else { 0 } } else { (s >> 24) as u8 }
                })
                .collect()
        };
        for (vis, tir) in [
            (frame(false), frame(false)),
            (frame(true), frame(false)),
            (std::vec![9u8; w * h], std::vec![9u8; w * h]),
        ] {
            for variant in [Variant::Classic, Variant::Flight] {
                for mean_size in [3u16, 35] {
                    let params = TsifsdParams { variant, mean_size };
                    let mut scratch = Scratch::<{ 37 * 29 }>::new();
                    let mut raw = std::vec![0i32; w * h];
                    let g_raw = fuse_tsifsd_raw(
                        FrameRef::new(&vis, w, h)?,
                        FrameRef::new(&tir, w, h)?,
                        FrameMut::new(&mut raw, w, h)?,
                        &params,
                        &mut scratch.view_mut(),
                    )?;
                    let mut out = std::vec![0u8; w * h];
                    let g = fuse_tsifsd(
                        FrameRef::new(&vis, w, h)?,
                        FrameRef::new(&tir, w, h)?,
                        FrameMut::new(&mut out, w, h)?,
                        &params,
                        &mut scratch.view_mut(),
                    )?;
                    let want: std::vec::Vec<u8> =
                        raw.iter().map(|&v| round_away_sat_u8(i64::from(v), RAW_FRAC_BITS)).collect();
                    assert_eq!(out, want);
                    let sat = raw.iter().any(|v| !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(v));
                    assert_eq!(g, if sat { g_raw | Guards::OUTPUT_SATURATED } else { g_raw });
                }
            }
        }
        Ok(())
    }

    /// The flight 8-bit kernel against the general path (the cast of the exact value) on
    /// random, checkerboard, flat and two-level frames of many shapes and every window size
    /// class: the same pixels and the same guards.
    #[test]
    fn flight_kernel_equals_general_path() -> Result<(), Error> {
        let mut s = 99u32;
        let mut next = move || {
            s = s.wrapping_mul(1664525).wrapping_add(1013904223);
            s >> 8
        };
        for (k, (w, h)) in [
            (1usize, 1usize),
            (1, 7),
            (7, 1),
            (2, 2),
            (3, 5),
            (2, 40),
            (37, 29),
            (300, 4),
            (257, 3),
            (600, 9),
        ]
        .into_iter()
        .enumerate()
        {
            for pattern in 0..5u32 {
                let mut frame = |salt: u32| -> std::vec::Vec<u8> {
                    (0..w * h)
                        .map(|i| {
                            let r = next();
                            match pattern {
                                0 => r as u8,
                                1 => {
                                    if (i % w + i / w + salt as usize).is_multiple_of(2) {
                                        255
                                    } else {
                                        0
                                    }
                                }
                                2 => 77,
                                3 => {
                                    if r % 3 == 0 {
                                        255
                                    } else {
                                        0
                                    }
                                }
                                _ => ((i % w) * 3 + salt as usize * 40) as u8 ^ (r % 4) as u8,
                            }
                        })
                        .collect()
                };
                let (vis, tir) = (frame(0), frame(1));
                let (vis, tir) = (FrameRef::new(&vis, w, h)?, FrameRef::new(&tir, w, h)?);
                for mean_size in [1u16, 3, 35, 63] {
                    let params = TsifsdParams { variant: Variant::Flight, mean_size };
                    let radius = usize::from(mean_size / 2);
                    let taps = i64::from(mean_size) * i64::from(mean_size);
                    let (mut tmp, mut sv, mut si) =
                        (std::vec![0i32; w * h], std::vec![0i32; w * h], std::vec![0i32; w * h]);
                    box_sum_u8(vis, radius, params.mean_border(), &mut tmp, &mut sv)?;
                    box_sum_u8(tir, radius, params.mean_border(), &mut tmp, &mut si)?;
                    let (mut want, mut got) = (std::vec![0u8; w * h], std::vec![0u8; w * h]);
                    let g_want = saliency_reconstruct(
                        vis,
                        tir,
                        &sv,
                        &si,
                        taps,
                        false,
                        Out::U8(FrameMut::new(&mut want, w, h)?),
                    );
                    // The ring alone (dirty), whatever the height.
                    let (mut cols, mut lanes) =
                        (std::vec![7i32; w + 2 * radius + 1], std::vec![-3i32; lane_ring_rows(radius) * w]);
                    let out = FrameMut::new(&mut got, w, h)?;
                    let g_got = flight_u8(vis, tir, taps as u32, radius, &mut cols, &mut lanes, out, 0);
                    assert_eq!(
                        (&got, g_got),
                        (&want, g_want),
                        "case {k} {w}x{h} pattern {pattern} n {mean_size}"
                    );
                    // Any row range gives those rows of the whole-frame run (the strip form).
                    for (y0, n) in [(1, h - 1), (h / 2, h - h / 2), (h - 1, 1), (h / 3, 1.max(h / 3))] {
                        if n == 0 || y0 + n > h {
                            continue;
                        }
                        let mut rows = std::vec![0u8; w * n];
                        let out = FrameMut::new(&mut rows, w, n)?;
                        flight_u8(vis, tir, taps as u32, radius, &mut cols, &mut lanes, out, y0);
                        assert_eq!(
                            rows[..],
                            want[y0 * w..(y0 + n) * w],
                            "rows {y0}+{n} {w}x{h} n {mean_size}"
                        );
                    }
                }
            }
        }
        Ok(())
    }

    /// The divisions of the wide chunk form and of `ByC` against integer division, at and around
    /// every multiple that matters: `⌊n/c⌋` for every `c = 2·n²` (odd `n ≤ 63`) and `n` up to
    /// 2²⁸; `⌊n/σ⌋` for every `σ ≤ 16320` and quotients up to 512.
    #[test]
    fn division_helpers_are_exact() {
        for side in (1u32..=63).step_by(2) {
            let c = 2 * side * side;
            let by_c = ByC(NonZeroU32::new(c).unwrap());
            let inv_c = 1.0 / f64::from(c);
            let check = |n: u32| {
                assert_eq!(div_c_f64(n, inv_c), n / c, "n {n} c {c}");
                assert_eq!(by_c.div(n), n / c, "n {n} c {c}");
            };
            for k in (0..(1u32 << 28) / c).step_by(997).chain([(1 << 28) / c - 1]) {
                for n in [k * c, k * c + 1, k * c + c - 1, (k + 1) * c - 1] {
                    if n < 1 << 28 {
                        check(n);
                    }
                }
            }
        }
        for sigma in 1u32..=16320 {
            for k in [0u32, 1, 2, 127, 128, 255, 383, 510, 511, 512] {
                for n in [k * sigma, (k * sigma).saturating_sub(1), k * sigma + sigma - 1, k * sigma + 1] {
                    let want = n / sigma;
                    assert_eq!(div_sigma_f32(n, sigma), want, "n {n} sigma {sigma}");
                    assert_eq!(div_sigma(n, NonZeroU32::new(sigma).unwrap()), want, "n {n} sigma {sigma}");
                }
            }
        }
    }

    /// The wide chunk form (x86-64) gives the portable form's bytes and flags: random frames,
    /// flat ones (the zero-saliency guard), and full-swing checkerboards and stripes (the
    /// largest gradients, σ up to 16320, and saturated outputs), several widths and row ranges.
    #[test]
    fn wide_and_portable_chunks_agree() -> Result<(), Error> {
        let mut s = 0x2545_F491u32;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s
        };
        for (w, h) in [(300usize, 41usize), (257, 40), (600, 45), (64, 38)] {
            for pattern in 0..5 {
                let mut frame = |salt: usize| -> std::vec::Vec<u8> {
                    (0..w * h)
                        .map(|i| {
                            let (x, y) = (i % w, i / w);
                            match pattern {
                                0 => next() as u8,
                                1 => 90,
                                2 => (((x + y + salt) % 2) * 255) as u8,
                                3 => (((x / 3 + salt) % 2) * 255) as u8 ^ ((y % 2) * 255) as u8,
                                _ => {
                                    if next() % 7 == 0 {
                                        255
                                    } else {
                                        (x * salt) as u8
                                    }
                                }
                            }
                        })
                        .collect()
                };
                let (vis, tir) = (frame(1), frame(2));
                let (vis, tir) = (FrameRef::new(&vis, w, h)?, FrameRef::new(&tir, w, h)?);
                for mean_size in [1u16, 3, 35] {
                    let radius = usize::from(mean_size / 2);
                    let taps = u32::from(mean_size) * u32::from(mean_size);
                    let run = |wide: bool, y0: usize| {
                        let mut cols = std::vec![0i32; w + 2 * radius + 1];
                        let mut lanes = std::vec![0i32; lane_ring_rows(radius) * w];
                        let mut out = std::vec![0u8; w * (h - y0)];
                        let f = FrameMut::new(&mut out, w, h - y0).unwrap();
                        let flags = if wide {
                            flight_u8_kernel::<true>(vis, tir, taps, radius, &mut cols, &mut lanes, f, y0)
                        } else {
                            flight_u8_kernel::<false>(vis, tir, taps, radius, &mut cols, &mut lanes, f, y0)
                        };
                        (out, flags)
                    };
                    for y0 in [0, h / 2] {
                        assert_eq!(
                            run(true, y0),
                            run(false, y0),
                            "{w}x{h} pattern {pattern} n {mean_size} y0 {y0}"
                        );
                    }
                }
            }
        }
        Ok(())
    }

    /// The portable `column_step` against a model of the Arm `smlad` pair.
    #[test]
    fn column_step_matches_the_smlad_model() {
        let smlad = |a: i32, b: i32, acc: i32| {
            let lo = |v: i32| i32::from(v as i16);
            let hi = |v: i32| i32::from((v >> 16) as i16);
            acc + lo(a) * lo(b) + hi(a) * hi(b)
        };
        let mut s = 3u32;
        let mut next = move || {
            s = s.wrapping_mul(1664525).wrapping_add(1013904223);
            (s >> 24) as u8
        };
        for k in 0..100_000i32 {
            let (e, l) = (lane_pair(next(), next()), lane_pair(next(), next()));
            let col = (k - 50_000) * 9;
            let [up, down] = LANE_WEIGHTS;
            assert_eq!(column_step(col, e, l, LANE_WEIGHTS), smlad(l, down, smlad(e, up, col)));
        }
    }

    /// 3×3 frames, 3×3 circular mean (every window is the whole frame): VIS has one 90 in the
    /// centre, TIR is black. B_VIS = 10, every median 0, S_VIS = 100, S_IR = 0, so w_VIS = 1
    /// and F = ½·10 + (I_VIS − 10): 85 in the centre, −5 elsewhere.
    #[test]
    fn hand_computed_three_by_three() -> Result<(), Error> {
        let vis = [0u8, 0, 0, 0, 90, 0, 0, 0, 0];
        let tir = [0u8; 9];
        let params = TsifsdParams { variant: Variant::Classic, mean_size: 3 };
        let mut scratch = Scratch::<9>::new();
        let mut raw = [0i32; 9];
        let g = fuse_tsifsd_raw(
            FrameRef::new(&vis, 3, 3)?,
            FrameRef::new(&tir, 3, 3)?,
            FrameMut::new(&mut raw, 3, 3)?,
            &params,
            &mut scratch.view_mut(),
        )?;
        let want: [i32; 9] = core::array::from_fn(|i| if i == 4 { 85 << 16 } else { -5 << 16 });
        assert_eq!(raw, want);
        assert_eq!(g, Guards::NONE);
        let mut out = [7u8; 9];
        let g = fuse_tsifsd(
            FrameRef::new(&vis, 3, 3)?,
            FrameRef::new(&tir, 3, 3)?,
            FrameMut::new(&mut out, 3, 3)?,
            &params,
            &mut scratch.view_mut(),
        )?;
        assert_eq!(out, [0, 0, 0, 0, 85, 0, 0, 0, 0]);
        assert!(g.contains(Guards::OUTPUT_SATURATED));
        Ok(())
    }

    #[test]
    fn combine_is_the_exact_rational() {
        // N = 9, Σ_VIS = 90, Σ_IR = 45, I = 20 / 3, saliencies 3 : 1.
        // F = (90 + 45)/18 + (3·(180 − 90) + 1·(27 − 45)) / (9·4) = 7.5 + 7 = 14.5
        let (v, zero) = combine(20, 3, 90, 45, 3, 1, 9);
        assert_eq!((v, zero), ((29 << 16) / 2, false));
        let (v, zero) = combine(20, 3, 90, 45, 0, 0, 9);
        assert_eq!((v, zero), ((23 << 16) / 2, true), "½, ½: (20 + 3)/2");
        // Scaling of huge saliencies keeps the ratio.
        let (v, _) = combine(20, 3, 90, 45, 3 << 38, 1 << 38, 9);
        assert_eq!(v, (29 << 16) / 2);
    }

    #[test]
    fn params_are_validated() {
        for size in [0u16, 2, 64, 65] {
            let p = TsifsdParams { mean_size: size, ..TsifsdParams::default() };
            assert_eq!(p.validate(), Err(Error::InvalidParameter { name: "mean_size" }));
        }
        assert_eq!(TsifsdParams::default().validate(), Ok(()));
    }
}
