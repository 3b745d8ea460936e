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
//!
//! Per pixel: `F = (Σ_VIS + Σ_IR)/(2N) + (S_VIS·N·D_VIS + S_IR·N·D_IR) / (N·(S_VIS + S_IR))`,
//! evaluated as one fraction `num / (N·σ)` in `i64` (|num| < 2⁶¹), so the only rounding is the
//! final one to Q16 (the classic core is exact up to that rounding and the 2⁻²² weight scaling).
//! The 35×35 mean costs O(1) per pixel (running sums, [`crate::filters::box_sum`]).
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
//! Three `i32` planes of W·H: the two box sums and the horizontal-pass plane (which then holds
//! the raw output rows).

use super::{Guards, Variant, round_away_sat_u8};
use crate::filters::border::{Border, Neighbourhood, NeighbourhoodOp, map_neighbourhoods_op};
use crate::filters::box_sum::box_sum_u8;
use crate::filters::median3::{median3_row, median9};
use crate::filters::scharr::{scharr_l1, scharr_l1_row};
use crate::{Error, FrameMut, FrameRef, ScratchMut};

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
    if n >= 0 { (2 * n + d) / (2 * d) } else { -((-2 * n + d) / (2 * d)) }
}

/// Fused Q16 value of one pixel; `true` when both saliencies were 0.
#[inline(always)]
fn combine(iv: u8, ii: u8, sum_v: i32, sum_i: i32, sal_v: u64, sal_i: u64, taps: i64) -> (i32, bool) {
    let zero = sal_v == 0 && sal_i == 0;
    let (sal_v, sal_i) = if zero { (1, 1) } else { (sal_v, sal_i) };
    let shift = (64 - (sal_v + sal_i).leading_zeros()).saturating_sub(23);
    let (wv, wi) = ((sal_v >> shift) as i64, (sal_i >> shift) as i64);
    let sigma = wv + wi; // ≥ 1 and < 2²³
    let (sv, si) = (i64::from(sum_v), i64::from(sum_i));
    let dv = taps * i64::from(iv) - sv;
    let di = taps * i64::from(ii) - si;
    let num = (((sv + si) * sigma) << 15) + ((wv * dv + wi * di) << 16);
    (div_round(num, taps * sigma) as i32, zero)
}

fn check_sizes(vis: &FrameRef<'_, u8>, tir: &FrameRef<'_, u8>, out: (usize, usize)) -> Result<(), Error> {
    if vis.size() != tir.size() {
        return Err(Error::SizeMismatch { expected: vis.size(), got: tir.size() });
    }
    if out != vis.size() {
        return Err(Error::SizeMismatch { expected: vis.size(), got: out });
    }
    Ok(())
}

/// The per-pixel fusion of one row, as a [`NeighbourhoodOp`] over the TIR neighbourhoods.
/// The item's `i32` holds the VIS saliency value on entry (classic: the signed `Σ − N·Med`,
/// flight: the gradient) and the raw fused value on return.
struct FusePixel<S, G> {
    taps: i64,
    /// Saliency from (value, box sum).
    saliency: S,
    /// TIR saliency value from the neighbourhood.
    sal_tir: G,
    any_zero: bool,
}

type Item<'a> = ((((&'a mut i32, &'a u8), &'a u8), &'a i32), &'a i32);

impl<'a, S: Fn(i32, i32) -> u64, G: Fn(Neighbourhood<u8>) -> i32> NeighbourhoodOp<u8, Item<'a>>
    for FusePixel<S, G>
{
    #[inline(always)]
    fn apply(&mut self, n: Neighbourhood<u8>, ((((o, &iv), &ii), &sv), &si): Item<'a>) {
        let (sal_v, sal_i) = ((self.saliency)(*o, sv), (self.saliency)((self.sal_tir)(n), si));
        let (v, zero) = combine(iv, ii, sv, si, sal_v, sal_i, self.taps);
        *o = v;
        self.any_zero |= zero;
    }
}

/// One output row (see [`FusePixel`]); `true` when some pixel had both saliencies 0.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fuse_row(
    rows_tir: (Option<&[u8]>, &[u8], Option<&[u8]>),
    border: Border,
    iv: &[u8],
    sum_v: &[i32],
    sum_i: &[i32],
    taps: i64,
    saliency: impl Fn(i32, i32) -> u64,
    sal_tir: impl Fn(Neighbourhood<u8>) -> i32,
    out: &mut [i32],
) -> bool {
    let op = FusePixel { taps, saliency, sal_tir, any_zero: false };
    let pixels = out.iter_mut().zip(iv).zip(rows_tir.1).zip(sum_v).zip(sum_i);
    map_neighbourhoods_op(rows_tir.0, rows_tir.1, rows_tir.2, border, pixels, op).any_zero
}

/// The one code path: box sums, saliencies, weights; hands each raw Q16 row to `emit(y, row)`.
fn run(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    params: &TsifsdParams,
    scratch: &mut ScratchMut<'_>,
    mut emit: impl FnMut(usize, &[i32]),
) -> Result<Guards, Error> {
    params.validate()?;
    let (w, h) = vis.size();
    let [tmp, sum_v, sum_i] = scratch.planes(w * h)?;
    let radius = usize::from(params.mean_size / 2);
    let taps = i64::from(params.mean_size) * i64::from(params.mean_size);
    box_sum_u8(vis, radius, params.mean_border(), tmp, sum_v)?;
    box_sum_u8(tir, radius, params.mean_border(), tmp, sum_i)?;
    let mut guards = Guards::NONE;
    for (y, ((sv, si), out)) in
        sum_v.chunks_exact(w).zip(sum_i.chunks_exact(w)).zip(tmp.chunks_exact_mut(w)).enumerate()
    {
        let (iv, ii) = (vis.row(y), tir.row(y));
        let zero = match params.variant {
            Variant::Classic => {
                // Saliency (Σ − N·Med)², zero-padded median.
                let above = y.checked_sub(1);
                let below = (y + 1 < h).then_some(y + 1);
                let med_v = |m: u8, o: &mut i32| *o = i32::from(m);
                median3_row(
                    above.map(|r| vis.row(r)),
                    iv,
                    below.map(|r| vis.row(r)),
                    Border::Zero,
                    out.iter_mut(),
                    med_v,
                );
                let tir_rows = (above.map(|r| tir.row(r)), ii, below.map(|r| tir.row(r)));
                let saliency = |med: i32, sum: i32| {
                    let d = i64::from(sum) - taps * i64::from(med);
                    d.unsigned_abs() * d.unsigned_abs()
                };
                fuse_row(tir_rows, Border::Zero, iv, sv, si, taps, saliency, |n| i32::from(median9(n)), out)
            }
            Variant::Flight => {
                let (yu, yd) = (y as isize - 1, y as isize + 1);
                let grad_v = |g: i32, o: &mut i32| *o = g;
                scharr_l1_row(
                    Some(vis.row_clamped(yu)),
                    iv,
                    Some(vis.row_clamped(yd)),
                    Border::Replicate,
                    out.iter_mut(),
                    grad_v,
                );
                let tir_rows = (Some(tir.row_clamped(yu)), ii, Some(tir.row_clamped(yd)));
                let saliency = |g: i32, _| u64::from(g.unsigned_abs());
                fuse_row(tir_rows, Border::Replicate, iv, sv, si, taps, saliency, scharr_l1, out)
            }
        };
        if zero {
            guards |= Guards::TSIFSD_ZERO_SALIENCY;
        }
        emit(y, out);
    }
    Ok(guards)
}

/// Fuses a VIS/TIR pair with TSIFSD into the 8-bit `out` (MATLAB `uint8` cast of the raw value).
///
/// All three frames must have the same size ([`Error::SizeMismatch`]); the scratch must hold
/// three planes of W·H ([`Error::ScratchTooSmall`]); bad parameters give
/// [`Error::InvalidParameter`]. Returns the guards fired (see the module docs).
pub fn fuse_tsifsd(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    mut out: FrameMut<'_, u8>,
    params: &TsifsdParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    check_sizes(&vis, &tir, out.size())?;
    let mut saturated = false;
    let guards = run(vis, tir, params, scratch, |y, raw| {
        for (o, &v) in out.row_mut(y).iter_mut().zip(raw) {
            saturated |= !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&v);
            *o = round_away_sat_u8(i64::from(v), RAW_FRAC_BITS);
        }
    })?;
    Ok(if saturated { guards | Guards::OUTPUT_SATURATED } else { guards })
}

/// Fuses like [`fuse_tsifsd`] but writes the real-valued result before the 8-bit cast in Q16
/// ([`RAW_FRAC_BITS`]; `raw / 65536.0` grey levels). [`fuse_tsifsd`] is this value cast with
/// [`round_away_sat_u8`]`(raw, 16)`.
pub fn fuse_tsifsd_raw(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    mut raw: FrameMut<'_, i32>,
    params: &TsifsdParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    check_sizes(&vis, &tir, raw.size())?;
    run(vis, tir, params, scratch, |y, row| {
        for (o, &v) in raw.row_mut(y).iter_mut().zip(row) {
            *o = v;
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scratch;

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
