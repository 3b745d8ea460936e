//! ADF step 1: the Perona–Malik diffusion of both bands at once (the base layers).
//!
//! # Number formats
//!
//! | quantity | format | range |
//! |---|---|---|
//! | state `A_k` of one band | `i16`, Q7 grey levels | clamped to `0..=32767` (0 ..< 256 levels) after every update |
//! | one pixel of both bands (rows, pipeline, the base-layer plane) | `i32` word: VIS in the low half, TIR in the high half | — |
//! | neighbour difference `∇` | `i16` | `−32767..=32767` (two states) |
//! | pair flux `F(∇)` | `i16`, state units | \|F\| ≤ the largest node ≤ Δt/2·0.4306·κ_q + ½ ≤ [`MAX_FLUX`] = 1760 |
//! | step `Σ = 2·(h + v − h_prev) + (dr + dl − north)`, north sums | `i16` partial sums | every partial sum ≤ 12·1760 < 2¹⁵: nothing saturates |
//! | next state | `A + Σ`, clamped to `0..=32767` | — |
//!
//! The update is the published `A ← A + Δt·(Σ_axial c∇ + ½·Σ_diagonal c∇)`, `c = exp(−(∇/κ)²)`:
//! with `F = Δt/2·c·∇` (state units) it is `A + 2·Σ_axial F + Σ_diagonal F`, with no rounding
//! after the fluxes' own: the step is odd in the fluxes, so a band and its negative `255 − I`
//! diffuse to exact negatives, as in the f64 reference — as long as no state is clamped. The
//! clamp to 0..=32767 (which the f64 reference does not have) can act where the explicit scheme
//! overshoots: for Δt > 1/6 (the scheme's max-principle bound; the API allows up to 0.25) at
//! high-contrast single pixels, and by a few state units where the fluxes' rounding pushes a
//! pixel at 0 below it.
//!
//! **The flux function.** `F(∇)` is a piecewise-linear function of `m = |∇|` on 64 segments,
//! odd by construction, defined by integer operations so that every target computes the same
//! value. With `κ_q = 128κ` (κ in state units), the segment width `2ᵏ` is the smallest
//! (`k` in 3..=9) with `64·2ᵏ ≥ min(4κ_q, 2¹⁵)`; past `4κ`, `Δt/2·∇·exp(−(∇/κ)²)` rounds to 0.
//!
//! 1. The nodes, once per call (65 `f64` evaluations with `libm`, the same bits everywhere):
//!    `n_j = round(f(g) − f''(g)·2²ᵏ/16)` at `g = j·2ᵏ`, with `f(g) = Δt/2·g·exp(−(g/κ_q)²)`.
//!    The curvature term balances the chords' error (−f''h²/16 at the nodes, +f''h²/16
//!    mid-segment) instead of leaving it one-sided.
//! 2. `F = sign(∇)·(n_j + ⌊(q·ρ_j + 2^(k−1)) / 2ᵏ⌋)`, the linear interpolation rounded half
//!    up, with `m = min(|∇|, 64·2ᵏ − 1)`, `j = m >> k`, `q = m − j·2ᵏ`, `ρ_j = n_{j+1} − n_j`.
//!    Computed as `base_j + r(m, slope_j)` with `base_j = n_j − j·ρ_j`, `slope_j = ρ_j·2^(15−k)`
//!    and `r(a, b) = (a·b + 2¹⁴) >> 15` (`vpmulhrsw`): the same value, exactly (see
//!    [`FluxFn::magnitude`]).
//!
//! Error of `F` against `Δt/2·∇·exp(−(∇/κ)²)`: ≤ 0.97 state units (0.0075 grey levels) at the
//! published κ = 30, Δt = 0.15. That is the node's and the product's rounding plus ≤ 0.16 of
//! interpolation (unit test `flux_function_error_is_within_its_bound`, every difference). This
//! form replaced a fixed-point `exp` (0.59 units, but 18 vector operations with 11 multiplies
//! against 9 with one), which tripled the host's speed; the VIFB accuracy stays at max 1 level.
//!
//! Where a table read is cheaper than the arithmetic (Cortex-M, RV32, hosts without a SIMD
//! form), the function is tabulated once per call for all 65 535 differences (128 KiB of the
//! work plane, [`TABLE_WORDS`]). A pair flux is then one subtraction and one read: no index
//! arithmetic and no clamp (the states are clamped instead).
//! The AVX-512 row loop keeps the 64 bases and slopes in four registers and reads them with
//! `vpermi2w`, 32 lanes at a time; the AVX2 loop keeps the 64 nodes and rises as byte tables
//! (two, or three when a node needs two bytes) and reads them with `vpshufb`, 32 lanes (two
//! fluxes of 8 pixels × 2 bands) at a time, and the first 16 bases and slopes as four more for
//! the blocks whose differences all lie in the first 16 segments; the
//! NEON loop (AArch64) keeps the same byte tables ([`FluxFn::byte_tables`]) in four 128-bit
//! registers each and reads them with `tbl`, 16 lanes (two fluxes of 4 pixels × 2 bands) at a
//! time. All give the same bits: the table, the AVX-512, AVX2 and NEON forms are checked
//! exhaustively against the function (x86-64 hosts; the NEON form under `qemu-aarch64` in
//! CI), the NEON loop also against the host's frames on the emulated Cortex-A53 (`fusion
//! budget --target a53`).
//!
//! **Both bands at once.** A work word holds one pixel of both bands; the Armv7E-M loop takes
//! both differences with one `ssub16` and sums both bands' fluxes with `qadd16`/`qsub16`
//! (16-bit halves), the AVX-512 loop runs 16 pixels × 2 bands per vector, the portable loop sums
//! each band in `i32`: the same values, since no partial sum leaves `i16`.
//!
//! **Pair fluxes and the row pipeline.** Each neighbour pair's flux is taken once, as
//! `F(later − earlier)` in row-major order, and enters both pixels with opposite signs (4 flux
//! evaluations per pixel and iteration instead of 8). The iterations run as a row pipeline
//! (temporal blocking): stage `k` turns each new row of iterate `k` into a row of iterate
//! `k + 1` and hands it straight on, so the frame is read and written once per group of
//! iterations and the work rows stay in cache.

use super::AdfParams;
use crate::filters::border::Border;
use crate::{Error, FrameRef};

/// Fractional bits of the diffusion state.
pub(super) const STATE_BITS: u32 = 7;
/// The largest state (255.99 grey levels).
const STATE_MAX: i32 = i16::MAX as i32;
/// The largest difference of two states; the flux function takes any `∇` as
/// `clamp(∇, −D_MAX, D_MAX)`.
const D_MAX: i32 = i16::MAX as i32;
/// Entries of the flux table: one per 16-bit difference `−32768..=32767` (−32768, which two
/// states cannot differ by, reads as −32767), so any 16-bit difference is a valid index.
const TABLE_ENTRIES: usize = 1 << 16;
/// Work words the flux table takes (two entries per word).
pub(crate) const TABLE_WORDS: usize = TABLE_ENTRIES / 2;
/// Index of difference 0 in the table.
const TABLE_CENTRE: usize = 1 << 15;

/// Rows of work memory per pipeline stage, each `w + 2` words: two state rows and the north
/// fluxes.
const STAGE_ROWS: usize = 3;

/// One input band of the diffusion.
#[derive(Debug, Clone, Copy)]
pub enum Band<'a> {
    /// An 8-bit frame.
    Frame(FrameRef<'a, u8>),
    /// A constant frame of this level (the eclipse plan's VIS).
    Level(u8),
}

/// Two 8-bit values as a work word of Q7 states (both halves non-negative).
#[inline(always)]
fn pack_u8(vis: u8, tir: u8) -> i32 {
    (i32::from(tir) << (16 + STATE_BITS)) | (i32::from(vis) << STATE_BITS)
}

/// Writes row `y` of both bands, packed, into `dst` (`w` words).
fn fill_row(dst: &mut [i32], vis: &Band<'_>, tir: &Band<'_>, y: usize) {
    match (vis, tir) {
        (Band::Frame(v), Band::Frame(t)) => pack_rows(dst, v.row(y), t.row(y)),
        (Band::Level(a), Band::Frame(t)) => {
            for (d, &b) in dst.iter_mut().zip(t.row(y)) {
                *d = pack_u8(*a, b);
            }
        }
        (Band::Frame(v), Band::Level(b)) => {
            for (d, &a) in dst.iter_mut().zip(v.row(y)) {
                *d = pack_u8(a, *b);
            }
        }
        (Band::Level(a), Band::Level(b)) => dst.fill(pack_u8(*a, *b)),
    }
}

crate::cpu::dispatch! {
    /// Two 8-bit rows as work words.
    fn pack_rows(dst: &mut [i32], vis: &[u8], tir: &[u8]) => pack_rows_kernel
}

#[inline(always)]
fn pack_rows_kernel(dst: &mut [i32], vis: &[u8], tir: &[u8]) {
    for ((d, &a), &b) in dst.iter_mut().zip(vis).zip(tir) {
        *d = pack_u8(a, b);
    }
}

/// The low (VIS) half of a work word, sign-extended.
#[inline(always)]
pub(super) fn lo(w: i32) -> i32 {
    i32::from(w as i16)
}

/// The high (TIR) half of a work word.
#[inline(always)]
pub(super) fn hi(w: i32) -> i32 {
    w >> 16
}

/// A work word from two 16-bit values.
#[inline(always)]
pub(super) fn pack(lo: i32, hi: i32) -> i32 {
    (hi << 16) | (lo & 0xFFFF)
}

/// Half `b` of a word: 0 the low (VIS), 1 the high (TIR).
#[inline(always)]
fn half(w: i32, b: usize) -> i32 {
    if b == 0 { lo(w) } else { hi(w) }
}

/// `(a·b + 2¹⁴) >> 15` for 16-bit `a`, `b` (`vpmulhrsw`; not both −32768).
#[inline(always)]
fn mulhrs(a: i32, b: i32) -> i32 {
    (a * b + (1 << 14)) >> 15
}

/// Segments of the piecewise-linear flux function (the AVX-512 loop holds each of its two
/// 64-entry tables in two 512-bit registers, the NEON loop each 64-entry byte table in four
/// 128-bit ones).
const SEGMENTS: usize = 64;

/// The flux function's per-call constants (see the module docs): a piecewise-linear `F(|∇|)`
/// on [`SEGMENTS`] segments of `2ᵏ` state units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct FluxFn {
    /// `min(64·2ᵏ − 1, 32767)`: the clamp of `|∇|`.
    limit: i32,
    /// `k`, the segment width's shift (3 ..= 9).
    shift: u32,
    /// Segment `j`'s base `n_j − j·ρ_j` (see [`FluxFn::magnitude`]; `|·|` below about 3.4·10³).
    base: [i16; SEGMENTS],
    /// Segment `j`'s slope `ρ_j·2^(15−k)`, `ρ_j = n_{j+1} − n_j` its rise (`|ρ_j| ≤ Δt/2·2ᵏ +
    /// 1`, so `|slope| ≤ 2¹³`; test `flux_is_the_interpolation_of_its_nodes` would see a wrap).
    slope: [i16; SEGMENTS],
}

/// [`FluxFn`] as byte tables ([`FluxFn::byte_tables`]): `F(m) = n_j + ⌊(q·ρ_j + 2^(k−1)) /
/// 2ᵏ⌋` for `m = j·2ᵏ + q` (the rounded Q15 product `mulhrs(q, ρ_j·2^(15−k))`; the same value
/// as [`FluxFn::magnitude`]'s `base_j + mulhrs(m, slope_j)`, since `j·ρ_j·2¹⁵` is a multiple
/// of 2¹⁵).
#[cfg(any(target_arch = "x86_64", all(target_arch = "aarch64", target_feature = "neon")))]
#[derive(Debug, Clone, Copy)]
struct ByteTables {
    /// The nodes' low bytes (the whole node, as `i8`, when `node_hi` is `None`).
    node_lo: [u8; SEGMENTS],
    /// The nodes' high bytes, when some node does not fit an `i8`.
    node_hi: Option<[u8; SEGMENTS]>,
    /// The rises `ρ_j·2^max(7 − k, 0)` as `i8`: moved to a 16-bit lane's high byte and shifted
    /// right (arithmetic) by `rise_shift`, the slope `ρ_j·2^(15−k)` (exact: `k ≤ 9`, and the
    /// shift drops zero bits).
    rise: [u8; SEGMENTS],
    /// `max(k − 7, 0)`.
    rise_shift: u32,
}

impl FluxFn {
    pub(super) fn new(params: &AdfParams) -> Self {
        let (shift, node) = Self::nodes(params);
        let mut base = [0i16; SEGMENTS];
        let mut slope = [0i16; SEGMENTS];
        for (j, ((b, s), pair)) in base.iter_mut().zip(slope.iter_mut()).zip(node.windows(2)).enumerate() {
            if let &[here, next] = pair {
                let rise = next - here;
                (*b, *s) = ((here - j as i32 * rise) as i16, (rise << (15 - shift)) as i16);
            }
        }
        Self { limit: ((SEGMENTS << shift) - 1).min(D_MAX as usize) as i32, shift, base, slope }
    }

    /// The segment shift `k` and the 65 nodes `n_j` (state units) of the flux function.
    fn nodes(params: &AdfParams) -> (u32, [i32; SEGMENTS + 1]) {
        let kappa = u32::from(params.kappa.max(1));
        // Span the segments over |∇| < 4κ (past which the flux rounds to 0) or every difference.
        let span = (4 * (kappa << STATE_BITS)).min(1 << 15);
        let shift = (3..=9).find(|&k| (SEGMENTS as u32) << k >= span).unwrap_or(9);
        let kq = f64::from(kappa << STATE_BITS);
        let half_dt = f64::from(params.dt_milli) / 2000.0;
        let h2 = f64::from(1u32 << (2 * shift));
        let mut node = [0i32; SEGMENTS + 1];
        for (j, n) in node.iter_mut().enumerate() {
            // f(g) = Δt/2·g·exp(−(g/κ_q)²) less f''(g)·h²/16, so that the chords' error is
            // balanced (−f''h²/16 at the nodes, +f''h²/16 mid-segment) instead of one-sided.
            let g = f64::from((j as u32) << shift);
            let t = g / kq;
            let e = half_dt * libm::exp(-t * t);
            let curvature = e * (4.0 * t * t * t - 6.0 * t) / kq;
            *n = libm::round(g * e - curvature * h2 / 16.0) as i32;
        }
        (shift, node)
    }

    /// `F(∇)` (state units) for a difference `∇` of two states (any `i32` is accepted and
    /// taken as `clamp(∇, −32767, 32767)`). Odd: `F(−∇) = −F(∇)`.
    #[inline(always)]
    pub(super) fn eval(&self, d: i32) -> i32 {
        let d = d.clamp(-D_MAX, D_MAX);
        let f = self.magnitude(d.unsigned_abs());
        if d < 0 { -f } else { f }
    }

    /// The function as 64-entry byte tables for the forms that read them with a byte shuffle
    /// (AVX2 `vpshufb`, NEON `tbl`): segment `j`'s node `n_j = base_j + j·ρ_j` and rise `ρ_j`
    /// (from the slope; `|n_j| ≤ MAX_FLUX`, `|ρ_j| ≤ 2¹³`). `None` when a scaled rise does not
    /// fit a byte (never with the parameters' ranges: `|ρ_j| ≤ Δt/2·2ᵏ + 1`, so
    /// `|ρ_j|·2^(7−k) ≤ 32` for `k ≤ 7` and `|ρ_j| ≤ 65` for `k ≤ 9`); those forms then leave
    /// the row to the table.
    #[cfg(any(target_arch = "x86_64", all(target_arch = "aarch64", target_feature = "neon")))]
    fn byte_tables(&self) -> Option<ByteTables> {
        let rise_shift = self.shift.saturating_sub(7);
        let scale = 7u32.saturating_sub(self.shift);
        let (mut node_lo, mut node_hi, mut rise) = ([0u8; SEGMENTS], [0u8; SEGMENTS], [0u8; SEGMENTS]);
        let mut narrow = true;
        let entries = self.base.iter().zip(&self.slope).enumerate();
        for ((j, (&b, &s)), ((lo, hi), r)) in entries.zip(node_lo.iter_mut().zip(&mut node_hi).zip(&mut rise))
        {
            let rho = i32::from(s) >> (15 - self.shift);
            let node = i32::from(b) + j as i32 * rho;
            [*lo, *hi] = (node as i16).to_le_bytes();
            narrow &= i8::try_from(node).is_ok();
            *r = i8::try_from(rho << scale).ok()? as u8;
        }
        Some(ByteTables { node_lo, node_hi: (!narrow).then_some(node_hi), rise, rise_shift })
    }

    /// `F` for `|∇| = m`: with `m` clamped to `limit`, `j = m >> k` and `q = m − j·2ᵏ` the
    /// linear interpolation `n_j + ⌊(q·ρ_j + 2^(k−1)) / 2ᵏ⌋` between the nodes (rounded half
    /// up). Computed as the vector loop does, in one rounded Q15 product of `m` itself:
    /// `r(m, ρ_j·2^(15−k)) = ⌊(m·ρ_j + 2^(k−1)) / 2ᵏ⌋ = j·ρ_j + ⌊(q·ρ_j + 2^(k−1)) / 2ᵏ⌋`
    /// exactly, and the base `n_j − j·ρ_j` takes `j·ρ_j` back.
    #[inline(always)]
    fn magnitude(&self, m: u32) -> i32 {
        let m = m.min(self.limit as u32);
        let j = (m >> self.shift) as usize;
        let (Some(&b), Some(&s)) = (self.base.get(j), self.slope.get(j)) else { return 0 };
        i32::from(b) + mulhrs(m as i32, i32::from(s))
    }

    /// Writes the flux of every 16-bit difference into `table` (index `∇ + 32768`): the
    /// non-negative half by the function, the other half by oddness (−32768 as −32767).
    fn tabulate(&self, table: &mut [i16]) {
        let Some((neg, pos)) = table.split_at_mut_checked(TABLE_CENTRE) else { return };
        for (m, t) in pos.iter_mut().enumerate() {
            *t = self.magnitude(m as u32) as i16;
        }
        // neg[i] is ∇ = i − 32768: −pos[32768 − i], and −pos[32767] for i = 0.
        let mirrored = pos.last().into_iter().chain(pos.iter().skip(1).rev());
        for (n, &p) in neg.iter_mut().zip(mirrored) {
            *n = -p;
        }
    }
}

/// Where the row loops read a flux from.
trait FluxSource {
    fn flux(&self, d: i32) -> i32;
    /// The table behind the source, if it is one (the Armv7E-M loop reads the table).
    #[cfg_attr(not(fusion_arm_dsp), allow(dead_code))]
    fn table(&self) -> Option<&[i16]> {
        None
    }
}

impl FluxSource for FluxFn {
    #[inline(always)]
    fn flux(&self, d: i32) -> i32 {
        self.eval(d)
    }
}

/// The tabulated flux function ([`TABLE_ENTRIES`] entries).
struct Table<'t>(&'t [i16]);

impl FluxSource for Table<'_> {
    #[inline(always)]
    fn flux(&self, d: i32) -> i32 {
        self.0.get((d + TABLE_CENTRE as i32) as usize).map_or(0, |&f| i32::from(f))
    }

    fn table(&self) -> Option<&[i16]> {
        Some(self.0)
    }
}

/// `words` seen as the flux table's `i16` entries (the first [`TABLE_WORDS`] words), or `None`
/// when there are fewer.
fn table_view(words: &mut [i32]) -> Option<&mut [i16]> {
    let words = words.get_mut(..TABLE_WORDS)?;
    // SAFETY: the `TABLE_WORDS` `i32` words are `TABLE_ENTRIES` properly aligned `i16`s of the
    // same borrowed memory (every bit pattern is valid for both types); the mutable borrow of
    // `words` is moved into the returned slice.
    Some(unsafe { core::slice::from_raw_parts_mut(words.as_mut_ptr().cast::<i16>(), TABLE_ENTRIES) })
}

/// What the row loop carries from one pixel to the next, both bands per word: the previous
/// east flux (this pixel's west, negated), the previous south-east flux, and
/// `2·v(i−1) + dr(i−2)`.
#[derive(Debug, Clone, Copy)]
struct RowCarry {
    h_prev: i32,
    dr_prev: i32,
    partial: i32,
}

/// Per-call constants of the diffusion.
#[derive(Debug, Clone, Copy)]
pub(super) struct Diffusion {
    pub(super) fx: FluxFn,
    border: Border,
    /// Use the AVX-512 row loop (x86-64 with AVX-512 F, BW and VL).
    #[cfg(target_arch = "x86_64")]
    avx512: bool,
    /// Else use the AVX2 row loop (x86-64 with AVX2, and `avx2_tables` built).
    #[cfg(target_arch = "x86_64")]
    avx2: bool,
    /// The AVX2 loop's byte tables of `fx`.
    #[cfg(target_arch = "x86_64")]
    avx2_tables: Option<avx2::Tables>,
    /// Use the NEON row loop (AArch64, unless `cpu::limit_isa` capped it, and `neon_tables`
    /// built).
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    neon: bool,
    /// The NEON loop's byte tables of `fx`.
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    neon_tables: Option<ByteTables>,
}

/// One band's part of the row update: the step `Σ = 2·(h + v − h_prev) + (dr + dl − north)`
/// (exact: no rounding, so it is odd in the fluxes — a band and its negative `255 − I` diffuse
/// to exact negatives while no state is clamped, see the module docs). No partial sum here or in the north sums
/// exceeds `12·|F|max ≤ 12·1760 < 2¹⁵` ([`MAX_FLUX`]), so the 16-bit lanes of the Armv7E-M and
/// AVX-512 loops (saturating instructions, for defence) compute the same values as these plain
/// sums.
#[inline(always)]
fn update_band(c: i32, [h, v, dr, dl]: [i32; 4], h_prev: i32, n: i32) -> i32 {
    let step = 2 * (h + v - h_prev) + (dr + dl - n);
    (c + step).clamp(0, STATE_MAX)
}

/// A bound on `|F|` for every parameter set (κ ≤ 255, Δt ≤ 0.25): an interpolated value lies
/// between its segment's nodes, and a node is at most `Δt/2·0.4306·κ_q + ½` (the largest
/// `t·exp(−t²)`, 0.4289, the curvature term at the peak, the rounding) ≤ 1757.4;
/// `12·MAX_FLUX < 2¹⁵`. Checked for every κ by `flux_is_odd_bounded_and_zero_far_away`.
const MAX_FLUX: i32 = 1760;
const _: () = assert!(12 * MAX_FLUX < 1 << 15, "every partial sum stays inside i16");

/// One pixel of one band in the portable row loop: the four pair fluxes, the next state, the
/// north sum of the pixel below-left (returned) and the carried values.
#[inline(always)]
fn band_pixel<F: FluxSource>(
    f: &F,
    c: i32,
    [pr, qc, qr, ql]: [i32; 4],
    n: i32,
    [h_prev, dr_prev, partial]: &mut [i32; 3],
) -> (i32, i32) {
    let (h, v, dr, dl) = (f.flux(pr - c), f.flux(qc - c), f.flux(qr - c), f.flux(ql - c));
    let next = update_band(c, [h, v, dr, dl], *h_prev, n);
    let below = *partial + dl;
    *partial = 2 * v + *dr_prev;
    *dr_prev = dr;
    *h_prev = h;
    (next, below)
}

impl Diffusion {
    pub(super) fn new(params: &AdfParams) -> Self {
        let fx = FluxFn::new(params);
        #[cfg(target_arch = "x86_64")]
        let avx2_tables = avx2::Tables::new(&fx);
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        let neon_tables = fx.byte_tables();
        Self {
            fx,
            border: params.border(),
            #[cfg(target_arch = "x86_64")]
            avx512: crate::cpu::has_avx512bw(),
            #[cfg(target_arch = "x86_64")]
            avx2: crate::cpu::has_avx2() && avx2_tables.is_some(),
            #[cfg(target_arch = "x86_64")]
            avx2_tables,
            #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
            neon: crate::cpu::has_neon() && neon_tables.is_some(),
            #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
            neon_tables,
        }
    }

    /// Whether the row loops here read a table (false: the AVX-512, AVX2 and NEON loops keep
    /// the function in registers).
    fn wants_table(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx512 || self.avx2 {
            return false;
        }
        // The NEON loop keeps the function in registers too.
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        if self.neon {
            return false;
        }
        true
    }

    /// The next iterate of one pixel (both bands) from its 3×3 neighbourhood (columns left,
    /// centre, right, each top to bottom) with all eight fluxes: the path for frames too
    /// small for the row pipeline. The north sum and the west flux are formed exactly as the
    /// row pipeline forms them, so both give the same bits.
    fn update<F: FluxSource>(&self, f: &F, [l, c, r]: [[i32; 3]; 3]) -> i32 {
        let out = [0, 1].map(|b| {
            let band = |w: i32| half(w, b);
            let centre = band(c[1]);
            let later = |w: i32| f.flux(band(w) - centre);
            let earlier = |w: i32| f.flux(centre - band(w));
            let north = 2 * earlier(c[0]) + earlier(l[0]) + earlier(r[0]);
            update_band(centre, [later(r[1]), later(c[2]), later(r[2]), later(l[2])], earlier(l[1]), north)
        });
        pack(out[0], out[1])
    }

    /// One Jacobi iteration of the packed `w`-wide plane `src` into `dst`.
    fn iterate<F: FluxSource>(&self, f: &F, src: &[i32], dst: &mut [i32], w: usize) {
        let h = src.len() / w.max(1);
        for (y, out) in dst.chunks_exact_mut(w.max(1)).enumerate() {
            let row = |yy: usize| src.get(yy * w..yy * w + w);
            let Some(mid) = row(y) else { return };
            let (up, down) = match self.border {
                Border::Replicate => (row(y.saturating_sub(1)), row((y + 1).min(h - 1))),
                _ => (y.checked_sub(1).and_then(row), row(y + 1)),
            };
            crate::filters::border::map_neighbourhoods(up, mid, down, self.border, out.iter_mut(), |n, o| {
                *o = self.update(f, n)
            });
        }
    }

    /// The north fluxes of the top pad row `top` with every pixel of the first row `q` (both
    /// padded, `w + 2` long), into `north[1..=w]`, as the row loop forms them.
    fn top_north<F: FluxSource>(&self, f: &F, top: &[i32], q: &[i32], north: &mut [i32]) {
        let pixels = top.windows(3).zip(q.iter().skip(1)).zip(north.iter_mut().skip(1));
        for ((t, &c), n) in pixels {
            if let &[nw, n0, ne] = t {
                let band = |b: usize| {
                    let cb = half(c, b);
                    let fl = |w: i32| f.flux(cb - half(w, b));
                    2 * fl(n0) + fl(nw) + fl(ne)
                };
                *n = pack(band(0), band(1));
            }
        }
    }

    /// One output row of a Jacobi iteration by pair fluxes. `p` is the row being updated and
    /// `q` the row below, both padded by one column on each side (`w + 2`); `north[i]` holds
    /// the north sums of pixel `i` of `p` (`2·F(C − N) + F(C − NW) + F(C − NE)`,
    /// subtracted) and is replaced by those of `q`. Per pixel and band four fluxes: the pairs
    /// east (`h`), south (`v`), south-east (`dr`) and south-west (`dl`), each `F(later −
    /// earlier)`. Each enters this pixel's sum and, negated, its partner's: the west flux is
    /// the previous pixel's `h`, and the pairs to `q` become `q`'s north sums. The next
    /// iterate goes to `out` (`w`).
    #[inline(never)]
    fn row(&self, table: Option<&[i16]>, p: &[i32], q: &[i32], north: &mut [i32], out: &mut [i32]) {
        match table {
            Some(t) => self.row_with(&Table(t), p, q, north, out),
            None => self.row_with(&self.fx, p, q, north, out),
        }
    }

    #[inline(always)]
    fn row_with<F: FluxSource>(&self, f: &F, p: &[i32], q: &[i32], north: &mut [i32], out: &mut [i32]) {
        let fl = |a: i32, b: i32| pack(f.flux(lo(b) - lo(a)), f.flux(hi(b) - hi(a)));
        let (Some(&p0), Some(&p1), Some(&q1)) = (p.first(), p.get(1), q.get(1)) else { return };
        // The left pad's pairs: p[0]–p[1] (the first west flux) and p[0]–q[1].
        #[cfg_attr(
            not(any(
                target_arch = "x86_64",
                fusion_arm_dsp,
                all(target_arch = "aarch64", target_feature = "neon")
            )),
            allow(unused_mut)
        )]
        let mut carry = RowCarry { h_prev: fl(p0, p1), dr_prev: fl(p0, q1), partial: 0 };
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `avx512` is set only when the CPU has AVX-512 F, BW and VL, `avx2` only when
        // it has AVX2 (checked at run time).
        let done = if self.avx512 {
            unsafe { avx512::row_blocks(&self.fx, p, q, north, out, &mut carry) }
        } else if let (true, Some(t)) = (self.avx2, &self.avx2_tables) {
            unsafe { avx2::row_blocks(t, p, q, north, out, &mut carry) }
        } else {
            0
        };
        #[cfg(fusion_arm_dsp)]
        let done = match f.table() {
            Some(t) => armv7em::row_pixels(t, p, q, north, out, &mut carry),
            None => 0,
        };
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        let done = match (self.neon, &self.neon_tables) {
            (true, Some(t)) => {
                neon::row_blocks(t, (self.fx.limit, self.fx.shift), p, q, north, out, &mut carry)
            }
            _ => 0,
        };
        #[cfg(not(any(
            target_arch = "x86_64",
            fusion_arm_dsp,
            all(target_arch = "aarch64", target_feature = "neon")
        )))]
        let done = 0;
        let mut bands = [0, 1].map(|b| [carry.h_prev, carry.dr_prev, carry.partial].map(|w| half(w, b)));
        let north = core::cell::Cell::from_mut(north).as_slice_of_cells();
        // The rest of the row from pixel `done` (padded index done + 1).
        let (Some(pd), Some(qd), Some(nd), Some(od)) =
            (p.get(done..), q.get(done..), north.get(done..), out.get_mut(done..))
        else {
            return;
        };
        let pixels = pd.windows(2).skip(1).zip(qd.windows(3)).zip(nd.windows(2)).zip(od.iter_mut());
        for (((pw, qw), nw), o) in pixels {
            let (&[pc, pr], &[ql, qc, qr], [n_prev, n_here]) = (pw, qw, nw) else { continue };
            let n = n_here.get();
            let [b0, b1] = &mut bands;
            let (o0, s0) = band_pixel(f, lo(pc), [lo(pr), lo(qc), lo(qr), lo(ql)], lo(n), b0);
            let (o1, s1) = band_pixel(f, hi(pc), [hi(pr), hi(qc), hi(qr), hi(ql)], hi(n), b1);
            *o = pack(o0, o1);
            n_prev.set(pack(s0, s1));
        }
        // The right pad's pair p[w+1]–q[w] completes q's last north sums.
        let n = p.len();
        if let (Some(last), Some(&pr), Some(&ql)) =
            (north.get(n.wrapping_sub(2)), p.get(n.wrapping_sub(1)), q.get(n.wrapping_sub(2)))
        {
            let [[_, _, s0], [_, _, s1]] = bands;
            last.set(pack(s0 + f.flux(lo(ql) - lo(pr)), s1 + f.flux(hi(ql) - hi(pr))));
        }
    }
}

/// Where the first stage of a pipeline group reads its rows.
#[derive(Clone, Copy)]
enum Input<'a> {
    /// The two input bands (first group).
    Bands(Band<'a>, Band<'a>),
    /// The base layers themselves (later groups, read before being overwritten).
    Layers,
}

/// The base layers of both bands, packed Q7 words: a whole plane (`w·h`, row `y` at `y·w`), or
/// one row that every finished row replaces (the streaming form).
struct Layers<'s> {
    a: &'s mut [i32],
    whole: bool,
}

impl Layers<'_> {
    /// Where row `y` (`w` words) is.
    fn range(&self, y: usize, w: usize) -> core::ops::Range<usize> {
        if self.whole { y * w..y * w + w } else { 0..w }
    }

    fn row_mut(&mut self, y: usize, w: usize) -> &mut [i32] {
        let r = self.range(y, w);
        self.a.get_mut(r).unwrap_or(&mut [])
    }

    /// Row `y` (the last one finished, in the streaming form).
    fn row(&self, y: usize, w: usize) -> &[i32] {
        self.a.get(self.range(y, w)).unwrap_or(&[])
    }
}

/// Writes the one-column pads of a padded row (`row[0]`, `row[w+1]`) by the border rule.
#[inline]
fn set_pads(row: &mut [i32], border: Border) {
    let n = row.len();
    let (left, right) = match border {
        Border::Replicate => (row.get(1).copied(), row.get(n.wrapping_sub(2)).copied()),
        _ => (Some(0), Some(0)),
    };
    if let (Some(l), Some(first)) = (left, row.first_mut()) {
        *first = l;
    }
    if let (Some(r), Some(last)) = (right, row.last_mut()) {
        *last = r;
    }
}

/// One stage's memory: the two state rows (row `j` in slot `j % 2`) and the north sums of
/// the oldest row not yet updated.
fn stage_rows(mem: &mut [i32], stride: usize) -> Option<[&mut [i32]; STAGE_ROWS]> {
    let mut rows = mem.chunks_exact_mut(stride.max(1));
    Some([rows.next()?, rows.next()?, rows.next()?])
}

/// Work words of a pipeline group of `stages` iterations on `w`-wide rows: the stages' rows.
fn group_words(w: usize, stages: usize) -> usize {
    stages * STAGE_ROWS * (w + 2)
}

/// A running diffusion: the constants, the flux table if one is used, the frame size.
struct RowPipeline<'t> {
    d: Diffusion,
    table: Option<&'t [i16]>,
    size: (usize, usize),
}

impl<'t> RowPipeline<'t> {
    /// Splits the flux table off the front of `work` when the row loops read one and it fits
    /// (with at least `min_rest` words left), tabulates it, and returns the rest of `work`.
    fn new<'w: 't>(
        d: Diffusion,
        size: (usize, usize),
        work: &'w mut [i32],
        min_rest: usize,
    ) -> (Self, &'w mut [i32]) {
        if d.wants_table() && work.len() >= TABLE_WORDS + min_rest {
            let Some((tw, rest)) = work.split_at_mut_checked(TABLE_WORDS) else {
                return (Self { d, table: None, size }, &mut []);
            };
            let table = table_view(tw).map(|t| {
                d.fx.tabulate(t);
                &*t
            });
            return (Self { d, table, size }, rest);
        }
        (Self { d, table: None, size }, work)
    }

    /// Runs `stages` Jacobi iterations in one pass down the frame (temporal blocking): stage
    /// `s` keeps the last two rows of iterate `s` and the north sums of their pairs, and turns
    /// each new row of iterate `s` into the previous row of iterate `s + 1`, which goes
    /// straight into stage `s + 1` (the last stage writes `layers`). All the work rows live
    /// in `mem` ([`group_words`]), so the frame is read and written
    /// once per group of iterations and the working set stays in cache.
    fn run_group(&self, input: Input<'_>, layers: &mut Layers<'_>, mem: &mut [i32], stages: usize) {
        let (w, h) = self.size;
        let Some(mem) = mem.get_mut(..group_words(w, stages)) else { return };
        mem.fill(0);
        for t in 0..h + stages {
            self.step(t, input, layers, mem, stages);
        }
    }

    /// Step `t` (`0 .. h + stages`) of a pipeline group: input row `t` enters stage 0 and
    /// every stage passes on the row it can now finish; the last stage writes row
    /// `t − stages` (when `t ≥ stages`) to `layers`. `mem` holds the group's zeroed work
    /// ([`group_words`]) and is carried from step to step.
    fn step(&self, t: usize, input: Input<'_>, layers: &mut Layers<'_>, mem: &mut [i32], stages: usize) {
        let (w, h) = self.size;
        let stride = w + 2;
        let per_stage = STAGE_ROWS * stride;
        let Some(mem) = mem.get_mut(..stages * per_stage) else { return };
        let border = self.d.border;
        let mut chunks = mem.chunks_exact_mut(per_stage.max(1));
        let mut cur = chunks.next();
        // The input row t enters stage 0.
        if t < h
            && let Some([s0, s1, _]) = cur.as_deref_mut().and_then(|m| stage_rows(m, stride))
        {
            let slot = if t.is_multiple_of(2) { s0 } else { s1 };
            let dst = slot.get_mut(1..=w).unwrap_or(&mut []);
            match input {
                Input::Bands(vis, tir) => fill_row(dst, &vis, &tir, t),
                Input::Layers => dst.iter_mut().zip(layers.row(t, w)).for_each(|(d, &v)| *d = v),
            }
            set_pads(slot, border);
        }
        for s in 0..stages {
            let mut next = chunks.next();
            // Row j of iterate s has just arrived at stage s (j = h: the bottom pad).
            let Some(j) = t.checked_sub(s) else { break };
            if j <= h
                && let Some([s0, s1, north]) = cur.as_deref_mut().and_then(|m| stage_rows(m, stride))
            {
                let (older, newer) = if j % 2 == 0 { (s1, s0) } else { (s0, s1) };
                if j == 0 {
                    // The pairs between the top pad row and row 0.
                    let top: &[i32] = match border {
                        Border::Replicate => newer,
                        _ => {
                            older.fill(0);
                            older
                        }
                    };
                    match self.table {
                        Some(tb) => self.d.top_north(&Table(tb), top, newer, north),
                        None => self.d.top_north(&self.d.fx, top, newer, north),
                    }
                } else {
                    // Output row j − 1 of iterate s + 1, from rows j − 1 (`older`) and j
                    // (`newer`), or the bottom pad row when j = h.
                    let (p, q): (&[i32], &[i32]) = if j < h {
                        (older, newer)
                    } else {
                        // Row h − 1 is `older`; the free slot becomes the zero pad row.
                        match border {
                            Border::Replicate => (older, older),
                            _ => {
                                newer.fill(0);
                                (older, newer)
                            }
                        }
                    };
                    let y = j - 1;
                    match next.as_deref_mut().and_then(|m| stage_rows(m, stride)) {
                        Some([n0, n1, _]) => {
                            let slot = if y % 2 == 0 { n0 } else { n1 };
                            self.d.row(self.table, p, q, north, slot.get_mut(1..=w).unwrap_or(&mut []));
                            set_pads(slot, border);
                        }
                        None => self.d.row(self.table, p, q, north, layers.row_mut(y, w)),
                    }
                }
            }
            cur = next.take();
        }
    }

    /// Plain Jacobi sweeps (8 fluxes per pixel) between `state` and `spare` (frames too small
    /// for one pipeline stage); the result ends in `state`.
    fn sweeps(&self, vis: Band<'_>, tir: Band<'_>, state: &mut [i32], spare: &mut [i32], iterations: u16) {
        let (w, h) = self.size;
        let n = w * h;
        let (Some(a), Some(b)) = (state.get_mut(..n), spare.get_mut(..n)) else { return };
        for (y, row) in a.chunks_exact_mut(w.max(1)).enumerate().take(h) {
            fill_row(row, &vis, &tir, y);
        }
        for i in 0..iterations {
            let (src, dst) = if i % 2 == 0 { (&*a, &mut *b) } else { (&*b, &mut *a) };
            // (Sweeps run only when not even one stage fits, so no table was taken either.)
            self.d.iterate(&self.d.fx, src, dst, w);
        }
        if iterations % 2 == 1 {
            a.iter_mut().zip(b.iter()).for_each(|(a, &b)| *a = b);
        }
    }
}

/// Work words [`diffuse_rows`] needs for `w`-wide frames: the flux table, the row pipeline of
/// all iterations and the output row — independent of the height (64 572 words, 252.2 KiB,
/// at W = 1024 with 10 iterations).
pub(crate) fn stream_words(w: usize, params: &AdfParams) -> usize {
    TABLE_WORDS + group_words(w, usize::from(params.iterations)) + w
}

/// The size the bands share (a [`Band::Level`] takes any size).
fn band_size(vis: &Band<'_>, tir: &Band<'_>, size: (usize, usize)) -> Result<(), Error> {
    for b in [vis, tir] {
        if let Band::Frame(f) = b
            && f.size() != size
        {
            return Err(Error::SizeMismatch { expected: size, got: f.size() });
        }
    }
    Ok(())
}

/// Diffuses both bands with `params.iterations` Perona–Malik steps into the base layers,
/// `state` (`w·h` words: pixel `(x, y)` at `y·w + x`, VIS in the low and TIR in the high 16
/// bits, Q7), using `work` as work memory: the flux table and the row pipeline's rows. With
/// 32 768 (the table) `+ 3·(w + 2)·iterations` words all iterations run in one pass down the
/// frame; with less, in groups, and without the table when it does not fit; a frame too small
/// for one stage (fewer than about 3 rows) takes plain Jacobi sweeps with `work` (at least
/// `w·h`) as the second plane — the same bits every way. Step 1 of ADF, public for tests and
/// benches.
pub fn diffuse_pair(
    vis: Band<'_>,
    tir: Band<'_>,
    size: (usize, usize),
    params: &AdfParams,
    state: &mut [i32],
    work: &mut [i32],
) -> Result<(), Error> {
    params.validate()?;
    diffuse_with(Diffusion::new(params), vis, tir, size, params.iterations, state, work)
}

/// [`diffuse_pair`] with the given constants (the tests switch the row loops).
fn diffuse_with(
    d: Diffusion,
    vis: Band<'_>,
    tir: Band<'_>,
    size: (usize, usize),
    iterations: u16,
    state: &mut [i32],
    work: &mut [i32],
) -> Result<(), Error> {
    band_size(&vis, &tir, size)?;
    let (w, h) = size;
    let pixels = w * h;
    let capacity = state.len();
    let state = state.get_mut(..pixels).ok_or(Error::ScratchTooSmall { needed: pixels, capacity })?;
    let (pipe, mem) = RowPipeline::new(d, size, work, group_words(w, 1));
    let stages = usize::from(iterations);
    let group = stages.min(mem.len().checked_div(STAGE_ROWS * (w + 2)).unwrap_or(0));
    if group == 0 {
        let capacity = mem.len();
        if capacity < pixels {
            return Err(Error::ScratchTooSmall { needed: pixels, capacity });
        }
        pipe.sweeps(vis, tir, state, mem, iterations);
        return Ok(());
    }
    let mut layers = Layers { a: state, whole: true };
    let mut done = 0;
    let mut input = Input::Bands(vis, tir);
    while done < stages {
        let n = group.min(stages - done);
        pipe.run_group(input, &mut layers, mem, n);
        input = Input::Layers;
        done += n;
    }
    Ok(())
}

/// Diffuses both bands together through one row pipeline (all iterations in one group, the
/// streaming form of [`diffuse_pair`], the same bits) and hands every row `y < until` of the
/// packed base layers to `sink(y, row)`, top to bottom; rows from `until` on are not finished
/// (row `y` needs the input only up to row `y + iterations`). Memory: `work`,
/// [`stream_words`] words; no plane. The strip pipeline ([`crate::strips`]) runs it on windows.
pub(crate) fn diffuse_rows(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    params: &AdfParams,
    work: &mut [i32],
    until: usize,
    mut sink: impl FnMut(usize, &[i32]),
) -> Result<(), Error> {
    params.validate()?;
    let size = vis.size();
    band_size(&Band::Frame(vis), &Band::Frame(tir), size)?;
    let (w, h) = size;
    let stages = usize::from(params.iterations);
    let needed = stream_words(w, params);
    let capacity = work.len();
    let work = work.get_mut(..needed).ok_or(Error::ScratchTooSmall { needed, capacity })?;
    let (row, work) = work.split_at_mut_checked(w).ok_or(Error::ScratchTooSmall { needed, capacity })?;
    let (pipe, mem) = RowPipeline::new(Diffusion::new(params), size, work, group_words(w, stages));
    let mem = mem.get_mut(..group_words(w, stages)).ok_or(Error::ScratchTooSmall { needed, capacity })?;
    mem.fill(0);
    let mut layers = Layers { a: row, whole: false };
    let input = Input::Bands(Band::Frame(vis), Band::Frame(tir));
    for t in 0..until.min(h) + stages {
        pipe.step(t, input, &mut layers, mem, stages);
        if let Some(y) = t.checked_sub(stages) {
            sink(y, layers.row(y, w));
        }
    }
    Ok(())
}

#[cfg(fusion_arm_dsp)]
mod armv7em;

#[cfg(any(target_arch = "x86_64", all(target_arch = "aarch64", target_feature = "neon")))]
mod simd;

#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
mod neon;

#[cfg(target_arch = "x86_64")]
mod avx2;

#[cfg(target_arch = "x86_64")]
mod avx512;

#[cfg(test)]
mod tests;
