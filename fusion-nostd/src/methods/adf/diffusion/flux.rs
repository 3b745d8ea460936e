//! The flux function of the diffusion, `F(∇) ≈ Δt/2·∇·exp(−(∇/κ)²)` (state units), and its
//! tables: [`FluxFn`] (the per-call segments), the 128 KiB table of every 16-bit difference
//! ([`TABLE_WORDS`], read through [`FluxSource`]), the byte tables of the shuffle forms and the
//! bound [`MAX_FLUX`] on `|F|`.
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

use super::super::AdfParams;
use super::STATE_BITS;

/// The largest difference of two states; the flux function takes any `∇` as
/// `clamp(∇, −D_MAX, D_MAX)`.
const D_MAX: i32 = i16::MAX as i32;
/// Entries of the flux table: one per 16-bit difference `−32768..=32767` (−32768, which two
/// states cannot differ by, reads as −32767), so any 16-bit difference is a valid index.
pub(super) const TABLE_ENTRIES: usize = 1 << 16;
/// Work words the flux table takes (two entries per word).
pub(crate) const TABLE_WORDS: usize = TABLE_ENTRIES / 2;
/// Index of difference 0 in the table.
pub(super) const TABLE_CENTRE: usize = 1 << 15;

/// `(a·b + 2¹⁴) >> 15` for 16-bit `a`, `b` (`vpmulhrsw`; not both −32768).
#[inline(always)]
fn mulhrs(a: i32, b: i32) -> i32 {
    (a * b + (1 << 14)) >> 15
}

/// Segments of the piecewise-linear flux function (the AVX-512 loop holds each of its two
/// 64-entry tables in two 512-bit registers, the NEON loop each 64-entry byte table in four
/// 128-bit ones).
pub(super) const SEGMENTS: usize = 64;

/// A bound on `|F|` for every parameter set (κ ≤ 255, Δt ≤ 0.25): an interpolated value lies
/// between its segment's nodes, and a node is at most `Δt/2·0.4306·κ_q + ½` (the largest
/// `t·exp(−t²)`, 0.4289, the curvature term at the peak, the rounding) ≤ 1757.4;
/// `12·MAX_FLUX < 2¹⁵`. Checked for every κ by `flux_is_odd_bounded_and_zero_far_away`.
pub(super) const MAX_FLUX: i32 = 1760;
const _: () = assert!(12 * MAX_FLUX < 1 << 15, "every partial sum stays inside i16");

/// The flux function's per-call constants (see the module docs): a piecewise-linear `F(|∇|)`
/// on [`SEGMENTS`] segments of `2ᵏ` state units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct FluxFn {
    /// `min(64·2ᵏ − 1, 32767)`: the clamp of `|∇|`.
    pub(super) limit: i32,
    /// `k`, the segment width's shift (3 ..= 9).
    pub(super) shift: u32,
    /// Segment `j`'s base `n_j − j·ρ_j` (see [`FluxFn::magnitude`]; `|·|` below about 3.4·10³).
    pub(super) base: [i16; SEGMENTS],
    /// Segment `j`'s slope `ρ_j·2^(15−k)`, `ρ_j = n_{j+1} − n_j` its rise (`|ρ_j| ≤ Δt/2·2ᵏ +
    /// 1`, so `|slope| ≤ 2¹³`; test `flux_is_the_interpolation_of_its_nodes` would see a wrap).
    pub(super) slope: [i16; SEGMENTS],
}

/// [`FluxFn`] as byte tables ([`FluxFn::byte_tables`]): `F(m) = n_j + ⌊(q·ρ_j + 2^(k−1)) /
/// 2ᵏ⌋` for `m = j·2ᵏ + q` (the rounded Q15 product `mulhrs(q, ρ_j·2^(15−k))`; the same value
/// as [`FluxFn::magnitude`]'s `base_j + mulhrs(m, slope_j)`, since `j·ρ_j·2¹⁵` is a multiple
/// of 2¹⁵).
#[cfg(any(target_arch = "x86_64", all(target_arch = "aarch64", target_feature = "neon")))]
#[derive(Debug, Clone, Copy)]
pub(super) struct ByteTables {
    /// The nodes' low bytes (the whole node, as `i8`, when `node_hi` is `None`).
    pub(super) node_lo: [u8; SEGMENTS],
    /// The nodes' high bytes, when some node does not fit an `i8`.
    pub(super) node_hi: Option<[u8; SEGMENTS]>,
    /// The rises `ρ_j·2^max(7 − k, 0)` as `i8`: moved to a 16-bit lane's high byte and shifted
    /// right (arithmetic) by `rise_shift`, the slope `ρ_j·2^(15−k)` (exact: `k ≤ 9`, and the
    /// shift drops zero bits).
    pub(super) rise: [u8; SEGMENTS],
    /// `max(k − 7, 0)`.
    pub(super) rise_shift: u32,
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
    pub(super) fn nodes(params: &AdfParams) -> (u32, [i32; SEGMENTS + 1]) {
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
    pub(super) fn byte_tables(&self) -> Option<ByteTables> {
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
    pub(super) fn tabulate(&self, table: &mut [i16]) {
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
pub(super) trait FluxSource {
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
pub(super) struct Table<'t>(pub(super) &'t [i16]);

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
pub(super) fn table_view(words: &mut [i32]) -> Option<&mut [i16]> {
    let words = words.get_mut(..TABLE_WORDS)?;
    // SAFETY: the `TABLE_WORDS` `i32` words are `TABLE_ENTRIES` properly aligned `i16`s of the
    // same borrowed memory (every bit pattern is valid for both types); the mutable borrow of
    // `words` is moved into the returned slice.
    Some(unsafe { core::slice::from_raw_parts_mut(words.as_mut_ptr().cast::<i16>(), TABLE_ENTRIES) })
}
