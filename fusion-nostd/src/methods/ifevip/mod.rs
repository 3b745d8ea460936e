//! IFEVIP — infrared feature extraction and visual information preservation (Zhang, Zhang,
//! Bai, Zhang, Infrared Phys. Technol. 83, 2017), integer core. Spec:
//! `docs/reference/fusion-algorithms.md`, IFEVIP (Part B) and Part A's guards.
//!
//! # Steps and number formats
//!
//! | step | where | format | error against exact arithmetic |
//! |---|---|---|---|
//! | 1. IR → `D×D` (`D` = 512), MATLAB bicubic, `uint8` after each pass (`imresize`) | plane B | integers 0..=255 | weights Q30 (sum exactly 2³⁰), sums exact `i64`; differs from exact only within ≈ 2⁻²² of a .5 tie |
//! | 2. quadtree (`max − min > 51`, sides 512…32) (`quadtree`) | stack, `heapless` | integers | exact |
//! | 3. 32×32 erosion at the control points only (`crate::filters::erode`) | plane C | integers | exact |
//! | 4. Bézier patches (`bezier`) | plane A | Q20 (`BG_BITS`) | exact numerator, one rounding: ≤ 2⁻²¹ |
//! | 5. back to W×H, `double` bicubic | plane C | Q20 | ≤ 2⁻²¹ per pass + weight rounding (≈ 2⁻³¹ × local variation) |
//! | 6. 9×9 Gaussian σ 4.5, zero padded (`crate::filters::gauss`) | plane B | Q20 | ≤ 2⁻²¹ per pass + 9·2⁻³¹·255 |
//! | 7. `R = IR ⊖ uint8(bg)` | plane B | integers | flips only where bg is within ≈ 10⁻⁶ of a .5 tie |
//! | 8. `r_H = H(IR)/H(VIS)` (`entropy`) | — | Q32 (keys use Q24) | `H` within 2⁻²⁹ bits |
//! | 9. keys `max(Feat, 0) + VIS` = `VIS·2²⁴ + max(R·2²⁴ + (IR−VIS)·r_H,24, 0)`: counted per key class `(v + R, IR − VIS)` or `v` (`peak::Classes`) | plane A (counts) | `i64` Q24 (`peak::KEY_BITS`) | ≤ 255·2⁻²⁵ from `r_H`'s Q24 |
//! | 10. `m·k` = exact sum of the top `k` keys by histogram selection over the classes (`peak`) | plane B (candidates) | `i128` Q24 | exact given the keys |
//! | 11. `g = min(255/m, 0.8)` as `G = g·2⁴⁰`, `B = g·r_H·2⁴⁰` (B saturated at 2⁵²) | — | Q40 | ≤ 2⁻⁴¹ |
//! | 12. `F = VIS ⊕ uint8(R·G + (IR−VIS)·B)` | out (frames ≥ 8·256·511 px: the added value tabulated per `(R, IR−VIS)` in plane A) | `i64` Q40, round half away, saturate | ≤ 2⁻³² before rounding |
//!
//! The output differs from the exact-arithmetic result only where a rounding (steps 1, 7, 12)
//! sits within the stated error of a .5 tie; the VIFB tests count those pixels.
//!
//! # Variants and guards
//!
//! Both variants compute the published method; they differ only in its undefined cases.
//! * `H(VIS) = 0` (constant visible image, [`Guards::IFEVIP_ZERO_ENTROPY`]): classic returns
//!   `F = VIS`, which is what the published code's `Inf`/`NaN` arithmetic and the final
//!   `uint8` cast produce (`g = 0` or `Feat = ±Inf/NaN` everywhere); flight sets `r_H = 1`:
//!   the visible image carries nothing, so the IR−VIS difference is added at unit weight (in
//!   eclipse, black VIS, the output is the scaled IR with its bright features).
//! * `N·0.001 < 1` (fewer than 1000 pixels, [`Guards::IFEVIP_FEW_PIXELS`]): `k = round(0.001·N)`;
//!   classic keeps the published `k = 0 → g = 0.8` (`min(NaN, 0.8)` in MATLAB), flight uses
//!   `k = max(1, ·)`.
//! * `m = 0` ([`Guards::IFEVIP_ZERO_PEAK`]): `g = 0.8` in both (MATLAB's `min(Inf, 0.8)`).
//! * [`Guards::OUTPUT_SATURATED`]: some `uint8(g·Feat)` exceeded 255 or `VIS + uint8(g·Feat)`
//!   was clipped at 255 — the in-light saturation the study reports.
//!
//! # Scratch
//!
//! Three `i32` planes of [`scratch_pixels`] each: `max(W·H, D², 261 377)` (the last: the key
//! classes of step 9, `peak::CLASSES`) plus the resizes' intermediate frames and tap tables
//! (`D` × the shorter side, ≤ 4·max(W,H)+2·D entries); at most `W·H` for frames from 512² up
//! to 1024² — even a 1×1 frame needs `D²`. No other memory except stack for the histograms
//! and the quadtree: ≈ 12 KiB on the flight targets, ≈ 30 KiB on x86-64.
//!
//! The strip form ([`crate::strips::fuse_strips`], module `stream`) computes the same bytes in
//! the 512 KiB strip scratch: three passes over the grid (analysis, keys, output) that keep
//! the quadtree's block ranges, the erosion at the candidate control points, the exact top-`k`
//! keys and, between passes 2 and 3, `R` in the output frame.

#[doc(hidden)]
pub mod bezier;
#[doc(hidden)]
pub mod entropy;
#[doc(hidden)]
pub mod imresize;
#[doc(hidden)]
pub mod peak;
#[doc(hidden)]
pub mod quadtree;
pub(crate) mod stream;
/// The strip form ([`crate::strips::StripForm`]).
mod strips;

/// The Armv7E-M forms of the output rows and the Bézier walk.
#[cfg(fusion_arm_dsp)]
mod armv7em;
/// The AVX2 form of the tabulated output row.
#[cfg(target_arch = "x86_64")]
mod avx2;

use super::{Guards, Variant};
use crate::filters::{erode, gauss};
use crate::{Error, FrameMut, FrameRef, ScratchMut};
use imresize::Output;

/// Largest `quad_norm_dim`.
const MAX_NORM_DIM: usize = 1024;

/// Fractional bits of the background planes (steps 4–6).
pub const BG_BITS: u32 = 20;

/// Fractional bits of the final gains `G`, `B`.
const GAIN_BITS: u32 = 40;

/// IFEVIP parameters. [`Default`] gives the published ones (`run_IFEVIP.m`) with
/// [`Variant::Flight`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct IfevipParams {
    /// Classic (published) or flight (guarded).
    pub variant: Variant,
    /// Side of the square grid the IR image is resized to for the quadtree (`QuadNormDim`, 512).
    /// A power of two in `8..=1024`.
    pub quad_norm_dim: u16,
    /// Smallest quadtree leaf side (`QuadMinDim`, 32). A power of two, `4 ≤ min ≤ norm`,
    /// `norm / min ≤ 16`.
    pub quad_min_dim: u16,
    /// A block is split while `max − min` exceeds this many grey levels (`0.2·255 = 51`).
    pub split_threshold: u8,
    /// Side of the square erosion window giving the local-minimum image (32), `1..=256`.
    pub erode_size: u16,
    /// Side of the square Gaussian (`GaussScale`, 9), odd, `1..=31`; σ = side / 2.
    pub gauss_size: u8,
    /// Fraction of the pixels averaged for the peak `m`, in parts per million
    /// (`MaxRatio` 0.001 = 1000 ppm), `1..=1_000_000`.
    pub top_ppm: u32,
    /// Gain cap in percent (`StdRatio` 0.8 = 80), `1..=100`.
    pub gain_cap_percent: u8,
}

impl Default for IfevipParams {
    fn default() -> Self {
        Self {
            variant: Variant::Flight,
            quad_norm_dim: 512,
            quad_min_dim: 32,
            split_threshold: 51,
            erode_size: 32,
            gauss_size: 9,
            top_ppm: 1000,
            gain_cap_percent: 80,
        }
    }
}

impl IfevipParams {
    /// The parameters for a crop of a frame (the crop semantics of scene skipping,
    /// [`crate::pipeline`]): the quadtree grid `D` scaled with the crop, so that one of its
    /// pixels covers about as many frame pixels as in the whole frame's fusion, and a small
    /// crop is not resized up to `D²`. `D′` = the power of two nearest (in ratio) to
    /// `D · crop_side / frame_side` (the longer sides), within `8..=D`; the leaf side kept, but
    /// within `D′/16..=D′` (the validated range). Everything else unchanged; `D′ = D` for the
    /// whole frame.
    pub fn on_crop(&self, crop_side: usize, frame_side: usize) -> IfevipParams {
        let d = u64::from(self.quad_norm_dim);
        let (n, g) = (d * crop_side as u64, (frame_side as u64).max(1));
        // p = the largest power of two with p·g ≤ n; then p or 2p, whichever is nearer in ratio
        // (2p when n/g ≥ √2·p).
        let mut p = 1u64;
        while 2 * p * g <= n && p < d {
            p *= 2;
        }
        let p = if p < d && u128::from(n) * u128::from(n) >= 2 * u128::from(p * g) * u128::from(p * g) {
            2 * p
        } else {
            p
        };
        // `max` then `min` (not `clamp`, whose bound check is a panic path): 8 ≤ D′ ≤ D, and
        // D′/16 ≤ leaf ≤ D′.
        let norm = p.max(8).min(d.max(8)) as u16;
        let min = self.quad_min_dim.max((norm / 16).max(4)).min(norm);
        IfevipParams { quad_norm_dim: norm, quad_min_dim: min, ..*self }
    }

    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), Error> {
        let norm = self.quad_norm_dim;
        let min = self.quad_min_dim;
        if !norm.is_power_of_two() || !(8..=MAX_NORM_DIM as u16).contains(&norm) {
            return Err(Error::InvalidParameter { name: "quad_norm_dim" });
        }
        if !min.is_power_of_two() || min < 4 || min > norm || norm / min > 16 {
            return Err(Error::InvalidParameter { name: "quad_min_dim" });
        }
        if !(1..=256).contains(&self.erode_size) {
            return Err(Error::InvalidParameter { name: "erode_size" });
        }
        if self.gauss_size.is_multiple_of(2) || self.gauss_size > 31 {
            return Err(Error::InvalidParameter { name: "gauss_size" });
        }
        if !(1..=1_000_000).contains(&self.top_ppm) {
            return Err(Error::InvalidParameter { name: "top_ppm" });
        }
        if !(1..=100).contains(&self.gain_cap_percent) {
            return Err(Error::InvalidParameter { name: "gain_cap_percent" });
        }
        Ok(())
    }
}

/// Pixels each of the three scratch planes must hold for a `width × height` frame.
pub fn scratch_pixels(width: usize, height: usize, params: &IfevipParams) -> usize {
    let d = usize::from(params.quad_norm_dim);
    // Steps 9-10: the key class counts and the candidate classes.
    let mut need = (width * height).max(d * d).max(peak::CLASSES);
    // Step 1: IR → D×D (the wider side's pass first), tables for both axes.
    if width != d && height != d {
        need = need.max(if width > height { d * height } else { width * d });
    }
    // Steps 5–6: D×D → D×H → W×H, tables of the combined operators.
    let g = usize::from(params.gauss_size);
    need = need.max(d * height);
    need = need.max(imresize::table_len(width, d)).max(imresize::table_len(height, d));
    need = need.max(imresize::smoothed_len(d, height, g)).max(imresize::smoothed_len(d, width, g));
    need
}

fn view<'a>(plane: &'a [i32], w: usize, h: usize) -> Result<FrameRef<'a, i32>, Error> {
    FrameRef::new(plane, w, h)
}

fn view_mut<'a>(plane: &'a mut [i32], w: usize, h: usize) -> Result<FrameMut<'a, i32>, Error> {
    FrameMut::new(plane, w, h)
}

/// Step 1: the IR frame to `d×d` in `dst` (integers), with `tmp` for the first pass and
/// `table` for the taps. The dimension with the smaller scale (the wider side) goes first.
fn resize_ir(
    tir: FrameRef<'_, u8>,
    d: usize,
    tmp: &mut [i32],
    dst: &mut [i32],
    table: &mut [i32],
) -> Result<(), Error> {
    let (w, h) = tir.size();
    match (w == d, h == d) {
        (true, true) => {
            for (row, out) in tir.rows().zip(dst.chunks_exact_mut(d)) {
                for (o, &v) in out.iter_mut().zip(row) {
                    *o = i32::from(v);
                }
            }
        }
        (false, true) => {
            let taps = imresize::build(w, d, table)?;
            imresize::pass_rows(tir, &taps, view_mut(dst, d, d)?, Output::U8);
        }
        (true, false) => {
            let taps = imresize::build(h, d, table)?;
            imresize::pass_cols(tir, &taps, view_mut(dst, d, d)?, Output::U8);
        }
        (false, false) if w > h => {
            let taps = imresize::build(w, d, table)?;
            imresize::pass_rows(tir, &taps, view_mut(tmp, d, h)?, Output::U8);
            let taps = imresize::build(h, d, table)?;
            imresize::pass_cols(view(tmp, d, h)?, &taps, view_mut(dst, d, d)?, Output::U8);
        }
        (false, false) => {
            let taps = imresize::build(h, d, table)?;
            imresize::pass_cols(tir, &taps, view_mut(tmp, w, d)?, Output::U8);
            // `tmp` holds a U8 pass's output (0..=255).
            if w == h {
                // A square frame: the rows take the same table.
                imresize::pass_rows_u8_range(view(tmp, w, d)?, &taps, view_mut(dst, d, d)?);
            } else {
                let taps = imresize::build(w, d, table)?;
                imresize::pass_rows_u8_range(view(tmp, w, d)?, &taps, view_mut(dst, d, d)?);
            }
        }
    }
    Ok(())
}

/// Interleaved partial histograms on x86-64: runs of equal values then update different
/// counters (no chain of dependent increments through memory); one on the flight targets,
/// where the indexing would only add instructions.
const PARTS: usize = if cfg!(target_arch = "x86_64") { 4 } else { 1 };

/// The partial histogram of pixel `i`.
#[inline(always)]
fn part(i: usize) -> usize {
    i & (PARTS.next_power_of_two() - 1).max(usize::from(PARTS > 1))
}

/// Grey-level histogram ([`PARTS`] interleaved partial histograms, summed at the end).
pub(crate) fn histogram(frame: FrameRef<'_, u8>) -> [u32; 256] {
    let mut parts = [[0u32; 256]; PARTS];
    for row in frame.rows() {
        for (i, &v) in row.iter().enumerate() {
            if let Some(h) = parts.get_mut(part(i)).and_then(|p| p.get_mut(usize::from(v))) {
                *h += 1;
            }
        }
    }
    let mut hist = [0u32; 256];
    for part in &parts {
        for (h, &c) in hist.iter_mut().zip(part) {
            *h += c;
        }
    }
    hist
}

/// Steps 1–6: the smoothed IR background (Q20, `BG_BITS`) for every pixel, row-major in
/// the first `W·H` elements of the third plane of `scratch` (public for tests and tools).
pub fn background(
    tir: FrameRef<'_, u8>,
    params: &IfevipParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<(), Error> {
    params.validate()?;
    let (w, h) = tir.size();
    let d = usize::from(params.quad_norm_dim);
    let [a, b, c] = scratch.planes(scratch_pixels(w, h, params))?;
    // 1. IR → D×D in B.
    resize_ir(tir, d, a, b, c)?;
    // 2. Quadtree leaves.
    let leaves = quadtree::decompose(
        view(b, d, d)?,
        usize::from(params.quad_min_dim),
        i32::from(params.split_threshold),
    )?;
    // 3. Local minimum in C, at the control points only (A holds one row of column minima).
    let size = usize::from(params.erode_size);
    let origin = size.div_ceil(2).max(1);
    let (before, after) = (origin - 1, size - origin);
    let (mut rows, mut cols) = ([false; MAX_NORM_DIM], [false; MAX_NORM_DIM]);
    bezier::control_lines(&leaves, d, &mut rows, &mut cols);
    erode::min_at_crossings(view(b, d, d)?, &rows, &cols, before, after, a, view_mut(c, d, d)?)?;
    // 4. Bézier background in A (Q20).
    bezier::render(&leaves, view(c, d, d)?, view_mut(a, d, d)?)?;
    // 5 + 6. Back to W×H and the Gaussian, as one operator per axis: A → B (D×H) → C (W×H).
    let (weights, n) = gauss::weights(usize::from(params.gauss_size), u32::from(params.gauss_size), 2)?;
    let weights = weights.get(..n).unwrap_or(&[]);
    let taps = imresize::build_smoothed(d, h, weights, c)?;
    imresize::pass_cols(view(a, d, d)?, &taps, view_mut(b, d, h)?, Output::Same);
    // The row table in A (free now): a copy of the column table when the frame is square.
    let taps = if w == h { taps.copy_into(a)? } else { imresize::build_smoothed(d, w, weights, a)? };
    imresize::pass_rows(view(b, d, h)?, &taps, view_mut(c, w, h)?, Output::Same);
    Ok(())
}

/// `uint8(bg)` of a Q20 background value (round half away; the value is never a negative
/// tie). Backgrounds stay below 2²⁹ in magnitude (see `imresize::finish`), so the rounding
/// add cannot overflow; the clamp is one `usat` on the Cortex-M.
#[inline(always)]
pub(crate) fn bg_u8(bg: i32) -> i32 {
    (bg.wrapping_add(1 << (BG_BITS - 1)) >> BG_BITS).clamp(0, 255)
}

/// Entries of the step-12 table: one per `(R, IR − VIS)`, `R` in `0..=255`, `IR − VIS` in
/// `−255..=255`.
const ADD_TABLE_LEN: usize = 256 * 511;

/// Step 12: `F = VIS ⊕ uint8(R·G + (IR − VIS)·B)` (Q40 gains, round half away, saturate) for
/// every pixel; returns whether some output saturated. The added value depends on
/// `(R, IR − VIS)` only; with a `table` of [`ADD_TABLE_LEN`] it is computed once per pair
/// instead of once per pixel (the same values).
pub(crate) fn output_pass(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    r_plane: &[i32],
    mut out: FrameMut<'_, u8>,
    g_q: i64,
    b_q: i64,
    table: Option<&mut [i32]>,
) -> bool {
    let w = vis.width();
    let half = 1i64 << (GAIN_BITS - 1);
    // uint8(g·Feat), or 256 when it saturates.
    let add = |r: i32, d: i32| {
        let val = i64::from(r) * g_q + i64::from(d) * b_q;
        if val <= 0 { 0 } else { ((val + half) >> GAIN_BITS).min(256) as i32 }
    };
    let mut saturated = false;
    // Rows (or blocks) done by the Cortex-M and AVX2 loops report here.
    #[cfg_attr(not(any(fusion_arm_dsp, target_arch = "x86_64")), allow(unused_mut))]
    let mut rows_saturated = false;
    // `add` is in 0..=511 (0..=256 from the closure, which fills the big table: its AVX2 and
    // Cortex-M loops test bit 8 of the sum, exact only for sums ≤ 511; up to 511 from
    // `GainTables`), so the sum is in 0..=766: the clamp is a `min` (branch-free; a branch on
    // the freshly loaded table value mispredicted on noisy frames).
    let mut put = |o: &mut u8, v: u8, add: i32| {
        let sum = (i32::from(v) + add) as u32;
        saturated |= sum > 255;
        *o = sum.min(255) as u8;
    };
    let rows = out.rows_mut().zip(vis.rows()).zip(tir.rows()).zip(r_plane.chunks_exact(w.max(1)));
    match table.and_then(|t| t.first_chunk_mut::<ADD_TABLE_LEN>()) {
        Some(table) => {
            for (r, row) in table.chunks_exact_mut(511).enumerate() {
                for (d, slot) in row.iter_mut().enumerate() {
                    *slot = add(r as i32, d as i32 - 255);
                }
            }
            // A fixed-size table: every index below is provably in range (no check per pixel).
            let table: &[i32; ADD_TABLE_LEN] = table;
            #[cfg(target_arch = "x86_64")]
            let avx2 = crate::cpu::has_avx2();
            for (((o, v), t), rr) in rows {
                #[cfg(fusion_arm_dsp)]
                if let Some(sat) = armv7em::output_row_arm(o, v, t, rr, table) {
                    rows_saturated |= sat;
                    continue;
                }
                // On x86-64 with AVX2 the row's whole blocks of eight, then the rest below.
                #[cfg(target_arch = "x86_64")]
                let (o, v, t, rr) = {
                    let done = if avx2 {
                        // SAFETY: the CPU has AVX2 (checked at run time).
                        let (done, sat) = unsafe { avx2::blocks(o, v, t, rr, table) };
                        rows_saturated |= sat;
                        done
                    } else {
                        0
                    };
                    let (v, t) = (v.get(done..).unwrap_or(&[]), t.get(done..).unwrap_or(&[]));
                    (o.get_mut(done..).unwrap_or(&mut []), v, t, rr.get(done..).unwrap_or(&[]))
                };
                for (((o, &v), &t), &r) in o.iter_mut().zip(v).zip(t).zip(rr) {
                    // R = max(IR − uint8(bg), 0) ∈ 0..=255 (the cast keeps it).
                    let idx = usize::from(r as u8) * 511 + (usize::from(t) + 255 - usize::from(v));
                    put(o, v, table.get(idx).copied().unwrap_or(0));
                }
            }
        }
        None => {
            let tables = GainTables::new(g_q, b_q);
            for (((o, v), t), rr) in rows {
                for (((o, &v), &t), &r) in o.iter_mut().zip(v).zip(t).zip(rr) {
                    // R = max(IR − uint8(bg), 0) ∈ 0..=255 (the cast keeps it).
                    put(o, v, tables.add(r as u8, v, t));
                }
            }
        }
    }
    saturated || rows_saturated
}

/// Step 12 without the 511 KiB table: `R·G + ½` and `(IR − VIS)·B` (Q40) tabulated per `R`
/// and per `IR − VIS` (6 KiB), so the added value is one 64-bit addition and a shift — the
/// exact sum the per-pixel products give. Small frames and the strip form use it.
pub(crate) struct GainTables {
    r_term: [i64; 256],
    d_term: [i64; 511],
}

impl GainTables {
    /// The tables of the gains `G`, `B` (Q40, as [`Gains`]).
    pub(crate) fn new(g_q: i64, b_q: i64) -> Self {
        let half = 1i64 << (GAIN_BITS - 1);
        let mut r_term = [0i64; 256];
        for (r, t) in r_term.iter_mut().enumerate() {
            *t = r as i64 * g_q + half;
        }
        let mut d_term = [0i64; 511];
        for (d, t) in d_term.iter_mut().enumerate() {
            *t = (d as i64 - 255) * b_q;
        }
        Self { r_term, d_term }
    }

    /// `uint8(R·G + (IR − VIS)·B)` with the saturated values folded: any value in 256..=511
    /// stands for "256 or more", which [`output_pass`]'s `put` treats alike (the sum with VIS
    /// exceeds 255 either way). Values ≤ 0 round to 0 (branch-free: |sum| < 2⁶¹, so the
    /// rounded value fits an `i32`).
    #[inline(always)]
    pub(crate) fn add(&self, r: u8, v: u8, t: u8) -> i32 {
        let di = usize::from(t) + 255 - usize::from(v);
        let val =
            self.r_term.get(usize::from(r)).copied().unwrap_or(0) + self.d_term.get(di).copied().unwrap_or(0);
        ((val >> GAIN_BITS) as i32).clamp(0, 511)
    }

    /// One row in place for the strip form: `out` holds `R` and receives `F = VIS ⊕ add`;
    /// returns whether a sum exceeded 255.
    pub(crate) fn row_in_place(&self, out: &mut [u8], vis: &[u8], tir: &[u8]) -> bool {
        #[cfg(fusion_arm_dsp)]
        if let Some(saturated) = self.row_in_place_arm(out, vis, tir) {
            return saturated;
        }
        let mut any = 0u32;
        for ((o, &v), &t) in out.iter_mut().zip(vis).zip(tir) {
            let sum = i32::from(v) + self.add(*o, v, t);
            any |= sum as u32;
            // sum ≥ 0: the clamp is one `usat` on the Cortex-M.
            *o = sum.clamp(0, 255) as u8;
        }
        // Sums are below 767: one exceeded 255 exactly when bit 8 or 9 is set in some sum.
        any & 0x300 != 0
    }
}

/// Step 8: the entropy ratio `r_H = H(IR)/H(VIS)` in Q32 and Q24 (shared by the whole-frame
/// and the strip forms).
#[derive(Debug, Clone, Copy)]
pub(crate) struct EntropyRatio {
    pub(crate) q32: u64,
    pub(crate) q24: i64,
}

impl EntropyRatio {
    /// The ratio from the grey-level histograms of both frames; `None` when the classic variant
    /// returns `F = VIS` (a constant visible image). Adds the guard that fired to `guards`.
    pub(crate) fn of(
        hist_ir: &[u32; 256],
        hist_vis: &[u32; 256],
        params: &IfevipParams,
        guards: &mut Guards,
    ) -> Option<Self> {
        let (nh_ir, _) = entropy::weighted_entropy(hist_ir);
        let (nh_vis, vis_bins) = entropy::weighted_entropy(hist_vis);
        let q32 = if vis_bins <= 1 {
            *guards |= Guards::IFEVIP_ZERO_ENTROPY;
            if params.variant != Variant::Flight {
                return None;
            }
            1u64 << 32
        } else {
            entropy::ratio_q32(nh_ir, nh_vis)
        };
        let q24 = i64::try_from(((q32 >> 7) + 1) >> 1).unwrap_or(i64::MAX);
        Some(Self { q32, q24 })
    }
}

/// Step 10's `k = round(N·ppm / 10⁶)` for `n` pixels (flight: at least 1); adds
/// [`Guards::IFEVIP_FEW_PIXELS`].
pub(crate) fn top_k(n: u64, params: &IfevipParams, guards: &mut Guards) -> u64 {
    let ppm = u64::from(params.top_ppm);
    if n * ppm < 1_000_000 {
        *guards |= Guards::IFEVIP_FEW_PIXELS;
    }
    let k = (n * ppm + 500_000) / 1_000_000;
    if params.variant == Variant::Flight { k.max(1) } else { k }
}

/// Step 11: the gains `G = g·2⁴⁰` and `B = g·r_H·2⁴⁰` from the sum of the top `k` keys.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Gains {
    pub(crate) g_q: i64,
    pub(crate) b_q: i64,
}

impl Gains {
    /// The gains (adds [`Guards::IFEVIP_ZERO_PEAK`] when the peak is 0).
    pub(crate) fn new(top: i128, k: u64, ratio_q32: u64, params: &IfevipParams, guards: &mut Guards) -> Self {
        let cap = u128::from(params.gain_cap_percent);
        let gain_q40: u128 = if k == 0 || top <= 0 {
            if k > 0 {
                *guards |= Guards::IFEVIP_ZERO_PEAK;
            }
            ((cap << GAIN_BITS) + 50) / 100
        } else {
            let top = top as u128;
            // g = 255·k/m' with m' = top/2²⁴; capped when that is ≥ cap/100.
            let num = (255u128 * u128::from(k)) << peak::KEY_BITS;
            if num * 100 >= cap * top {
                ((cap << GAIN_BITS) + 50) / 100
            } else {
                ((num << GAIN_BITS) + top / 2) / top
            }
        };
        let ratio_gain = ((gain_q40 * u128::from(ratio_q32)) + (1 << 31)) >> 32;
        let g_q = i64::try_from(gain_q40).unwrap_or(i64::MAX);
        let b_q = i64::try_from(ratio_gain.min(1 << 52)).unwrap_or(1 << 52);
        Self { g_q, b_q }
    }
}

/// IFEVIP of an aligned VIS/TIR pair into `out` (see the module docs). Returns the guards that
/// fired. Errors: invalid parameters, frames of different sizes, scratch planes shorter than
/// [`scratch_pixels`].
pub fn fuse_ifevip(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    mut out: FrameMut<'_, u8>,
    params: &IfevipParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    params.validate()?;
    let (w, h) = vis.size();
    if tir.size() != (w, h) {
        return Err(Error::SizeMismatch { expected: (w, h), got: tir.size() });
    }
    if out.size() != (w, h) {
        return Err(Error::SizeMismatch { expected: (w, h), got: out.size() });
    }
    let needed = scratch_pixels(w, h, params);
    if scratch.capacity() < needed {
        return Err(Error::ScratchTooSmall { needed, capacity: scratch.capacity() });
    }
    let mut guards = Guards::NONE;
    let n = (w * h) as u64;

    // Entropy ratio (step 8) first: classic with H(VIS) = 0 needs nothing else.
    let Some(ratio) = EntropyRatio::of(&histogram(tir), &histogram(vis), params, &mut guards) else {
        for (o, v) in out.rows_mut().zip(vis.rows()) {
            for (o, v) in o.iter_mut().zip(v) {
                *o = *v;
            }
        }
        return Ok(guards);
    };
    let EntropyRatio { q32: ratio_q32, q24: ratio_q24 } = ratio;

    background(tir, params, scratch)?;
    let [a, b, c] = scratch.planes(needed)?;

    // 7 + 9. R = IR ⊖ uint8(bg) in place in C; each pixel's key class counted in A (on
    // x86-64 odd pixels in B, added to A afterwards: two independent chains of increments).
    let classes = peak::Classes::new(ratio_q24);
    let (counts, odd) = (a.get_mut(..peak::CLASSES).unwrap_or(&mut []), b.get_mut(..peak::CLASSES));
    counts.fill(0);
    let mut odd = odd.filter(|_| PARTS > 1);
    if let Some(o) = odd.as_deref_mut() {
        o.fill(0);
    }
    let rows = c.chunks_exact_mut(w.max(1)).zip(tir.rows()).zip(vis.rows());
    let mut i = 0usize;
    match odd {
        Some(odd) => {
            for ((rr, ir), vv) in rows {
                for ((r, &t), &v) in rr.iter_mut().zip(ir).zip(vv) {
                    let feat_r = (i32::from(t) - bg_u8(*r)).max(0);
                    *r = feat_r;
                    let table = if i & 1 == 0 { &mut *counts } else { &mut *odd };
                    if let Some(n) = table.get_mut(classes.class(v, t, feat_r)) {
                        *n += 1;
                    }
                    i += 1;
                }
            }
            for (n, &o) in counts.iter_mut().zip(odd.iter()) {
                *n += o;
            }
        }
        None => {
            for ((rr, ir), vv) in rows {
                for ((r, &t), &v) in rr.iter_mut().zip(ir).zip(vv) {
                    let feat_r = (i32::from(t) - bg_u8(*r)).max(0);
                    *r = feat_r;
                    if let Some(n) = counts.get_mut(classes.class(v, t, feat_r)) {
                        *n += 1;
                    }
                }
            }
        }
    }
    let r_plane: &[i32] = c;

    // 10 + 11. Peak m·k (the sum of the top k keys) and the gains.
    let k = top_k(n, params, &mut guards);
    let top = peak::top_k_sum(counts, &classes, k, b);
    let Gains { g_q, b_q } = Gains::new(top, k, ratio_q32, params, &mut guards);

    // 12. F = VIS ⊕ uint8(g·Feat), tabulated for large frames in plane A (free after step 10).
    let table = a.get_mut(..ADD_TABLE_LEN).filter(|_| w * h >= 8 * ADD_TABLE_LEN);
    let saturated = output_pass(vis, tir, r_plane, out, g_q, b_q, table);
    if saturated {
        guards |= Guards::OUTPUT_SATURATED;
    }
    Ok(guards)
}

#[cfg(test)]
mod tests;
