//! TSIFSD — two-scale image fusion with saliency detection (Bavirisetti & Dhuli, Infrared
//! Phys. Technol. 76, 2016; VIFB "TIF"), integer core. Spec:
//! `docs/reference/fusion-algorithms.md`, TSIFSD.
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
//! `crate::filters::box_sum`); the 3×3 median and the Scharr gradient sort or smooth each
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
    ) -> (bool, bool) => flight_u8_chunks
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
    // `%` by a `NonZeroUsize`: no division-by-zero path, whatever the inlining.
    let hh = core::num::NonZeroUsize::new(h).unwrap_or(core::num::NonZeroUsize::MIN);
    let wrap = |y: usize, k: isize| {
        let (y, step) = (y % hh, k.unsigned_abs() % hh);
        if k < 0 { (y + hh.get() - step) % hh } else { (y + step) % hh }
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

mod flight;
mod general;
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
mod neon;
mod x86_64;

pub(crate) use flight::flight_words;
use flight::*;
use general::*;
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
use neon::*;
use x86_64::*;

/// The strip form ([`crate::strips::StripForm`]).
mod strips;
#[cfg(test)]
mod tests;
