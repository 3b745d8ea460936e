//! ADF — anisotropic diffusion + Karhunen–Loève fusion (Bavirisetti & Dhuli, IEEE Sensors J.
//! 16(1), 2016), integer core. Spec: `shared/reference/fusion-algorithms.md`, ADF.
//!
//! # Steps and number formats
//!
//! | quantity | type | format | range / saturation |
//! |---|---|---|---|
//! | diffusion state `A_k` (base layer) | `i32` | Q16 grey levels | within ≈ [−1, 256] levels (< 2²⁵) for the published parameters |
//! | neighbour difference `∇` | `i32` | Q16 | \|∇\| < 2²⁵ |
//! | normalised flux `g = c·∇/κ = t·exp(−t²)`, `t = ∇/κ` | `i16` → `i32` | Q16, from [`EXP_FLUX`] with its sign | \|g\| ≤ 28107 |
//! | per-pixel sum `Σ = 2·Σ_axial g + Σ_diag g` | `i32` | Q16 | \|Σ\| ≤ 12·28107 < 2¹⁹ |
//! | `κ·Δt/2` (`scale`) | `i32` | Q16 | < 2²² |
//! | update `round(Σ·κΔt/2)` = `mul_hi_round(Σ << 12, scale << 4)` = `⌊(Σ·scale + 2¹⁵)/2¹⁶⌋` | `i32` (the product in 64 bits: one `smmulr` on Arm) | Q16 | exact for every parameter set (`Σ << 12 < 2³¹`); the state add saturates at the `i32` range (unreachable for sane parameters) |
//! | detail layer `D_k = 2¹⁶·I_k − A_k` | `i32` (`i64` beyond 2²⁶) | Q16 | \|D\| < 2²⁵ for sane states |
//! | covariance sums | `i64` per 2¹¹-pixel chunk (when every \|D\| < 2²⁶), then `i128` | Q32 | exact |
//! | KL weight `p_IR` (`p_VIS = 1 − p_IR`) | `i64` | Q30 | classic: saturated to ±128; flight: [0, 1] |
//! | fused value before rounding `(A_IR + A_VIS + 2·D_VIS + 1)·2²⁹ + p_IR·(D_IR − D_VIS)` | `i64` | Q46 | < 2⁵⁹ when every \|D\| < 2²⁶ and \|p_IR\| < 2³¹; otherwise saturating |
//! | fused raw value [`fuse_adf_raw`] | `i32` | Q16 ([`RAW_FRAC_BITS`]) | saturated to the `i32` range (only reachable with classic weights ≫ 1) |
//!
//! **Conduction table.** The flux `c·∇ = ∇·exp(−(∇/κ)²) = κ·g(t)` with `g(t) = t·exp(−t²)`,
//! `t = ∇/κ`, is read from a static table: [`EXP_FLUX`] (8193 `u16` entries, step 1/2048 in
//! `t`, built at compile time by a `const fn` exp) stored with its sign for `t` in `(−4, 4)`
//! (16 385 `i16`, 32 KiB of flash); beyond `|t| = 4` (g < 5·10⁻⁷) the flux is 0. The signed
//! index is `2048·∇/κ` rounded half up: one multiply of `∇` by `round(2²⁷/κ)`, computed once
//! per call, keeping the rounded high word (`smmulr`, then `ssat #14` and `ldrsh` on Arm, see
//! `Diffusion`). Error of `g` against `t·exp(−t²)`: ≤ 2.4·10⁻⁴ (index rounding: slope ≤ 1 ·
//! half a step) + 7.6·10⁻⁶ (Q16 entries) + the multiplier's rounding (< 0.01 of a step),
//! measured 2.5·10⁻⁴, i.e. ≤ 0.0075 grey levels per neighbour flux at κ = 30 (unit test
//! `flux_table_error_is_within_its_bound`, both signs).
//!
//! **Update** (Jacobi, one iterate in, the next out):
//! `A ← A + round(κΔt/2 · (2·Σ_axial g + Σ_diagonal g))`, i.e. the published
//! `Δt·(Σ_axial c∇ + ½Σ_diagonal c∇)`.
//!
//! **Speed** (the same bits as the per-pixel form, checked by the unit tests): each neighbour
//! pair's flux is taken once, as `flux(later − earlier)` in row-major order, and enters both
//! pixels with opposite signs — 4 table reads per pixel and iteration instead of 8 (the
//! per-pixel form takes every pair in the same orientation, so both forms give the same bits). The iterations run as a row pipeline
//! (temporal blocking): stage `k` turns each new row of iterate `k` into a row of iterate
//! `k + 1` and hands it straight to stage `k + 1`, so the frame is read and written once per
//! group of iterations and the work rows stay in cache. On x86-64 with AVX2 the row loop runs
//! eight pixels at a time with `vpgatherdd` table reads.
//!
//! **KL weights.** With `a = n·ΣD_IR² − (ΣD_IR)²`, `b = n·ΣD_IR·D_VIS − ΣD_IR·ΣD_VIS`,
//! `c = n·ΣD_VIS² − (ΣD_VIS)²` (exact `i128`, the covariance times `n(n−1)`), the eigenvector
//! of the larger eigenvalue is `(2b, (c−a) + R)` when `c ≥ a` and `((a−c) + R, 2b)` otherwise,
//! `R = √((c−a)² + 4b²)` by an integer square root (no cancellation in either form; the three
//! values are first shifted together so the largest has exactly 61 bits). `p_IR = v₁/(v₁+v₂)` in Q30.
//!
//! # Variants and guards
//!
//! * [`Variant::Classic`]: zero padding in the diffusion; the published weights, unclamped
//!   (saturated at ±128, where the published output is lost to cancellation anyway). An exact
//!   eigenvalue tie (a = c, b = 0, zero covariance included) takes the first eigenvector as
//!   MATLAB's `eig` does: `p_IR = 1`. Only `v₁ + v₂ = 0` — a = c and b < 0, where the
//!   published code divides by zero — is guarded: weights ½, ½.
//! * [`Variant::Flight`]: replicate padding in the diffusion (zero padding drains dark border
//!   pixels toward 0 and leaves a bright rim in the detail layer — see the spec's border
//!   note); weights `p = |v| / (|v₁| + |v₂|)`, which equal the published weights whenever those
//!   are in [0, 1], stay in [0, 1] for negatively correlated details (continuous, no 1/0), and
//!   ½, ½ on a tie or a zero covariance.
//!
//! A 1-pixel frame has no covariance (the published `cov` of a single row would even change
//! meaning): it takes the zero-covariance rule of its variant.
//!
//! Bits reported (every variant): [`Guards::ADF_ZERO_COVARIANCE`] (a = b = c = 0),
//! [`Guards::ADF_DEGENERATE_EIGENVECTOR`] (tie, or \|v₁+v₂\| ≤ 2⁻¹⁶(\|v₁\|+\|v₂\|)),
//! [`Guards::ADF_WEIGHT_CLAMPED`] (flight only: the published weights would leave [0, 1]),
//! [`Guards::OUTPUT_SATURATED`] (u8 output only: a pixel was clamped to 0 or 255).
//!
//! # Scratch
//!
//! Three `i32` planes of W·H: the two diffusion states and the work plane — the pipeline's
//! stage rows (3·(W+2) values per iteration; frames of fewer than about 3 rows use it as the
//! Jacobi ping-pong plane instead), then the raw output rows.

use super::{Guards, Variant};
use crate::filters::border::{Border, Neighbourhood, NeighbourhoodOp, map_neighbourhoods_op};
use crate::{Error, FrameMut, FrameRef, ScratchMut};

/// Fractional bits of the raw fused value written by [`fuse_adf_raw`] (Q16: `raw / 65536` is
/// the real result in grey levels, before the 8-bit cast).
pub const RAW_FRAC_BITS: u32 = 16;

/// Fractional bits of the diffusion state.
const STATE_BITS: u32 = 16;
/// Table steps per unit of `t = |∇|/κ`.
const LUT_STEPS_PER_UNIT: usize = 2048;
/// Table length without the final 0: `t` in `[0, 4)`.
const LUT_LEN: usize = 4 * LUT_STEPS_PER_UNIT;
/// Fractional bits of the weights.
const WEIGHT_BITS: u32 = 30;

/// `exp(−x)` for `0 ≤ x ≤ 20` in `f64`, usable in `const` context (range reduction by ln 2,
/// 24-term Taylor series; relative error < 10⁻¹⁴ — checked against `libm::exp` in the tests).
const fn exp_neg(x: f64) -> f64 {
    const LN2: f64 = core::f64::consts::LN_2;
    let mut k = 0u32;
    let mut r = x;
    while r >= LN2 {
        r -= LN2;
        k += 1;
    }
    // exp(−r), 0 ≤ r < ln 2.
    let mut term = 1.0;
    let mut sum = 1.0;
    let mut i = 1;
    while i < 24 {
        term = term * (-r) / (i as f64);
        sum += term;
        i += 1;
    }
    while k > 0 {
        sum *= 0.5;
        k -= 1;
    }
    sum
}

// Evaluated at compile time only (for the `static`): an out-of-range index would be a
// compile error, never a run-time panic; `get_mut` is not usable in a `const fn` loop here.
#[allow(clippy::indexing_slicing)]
const fn build_lut() -> [u16; LUT_LEN + 1] {
    let mut lut = [0u16; LUT_LEN + 1];
    let mut j = 0;
    while j < LUT_LEN {
        let t = j as f64 / LUT_STEPS_PER_UNIT as f64;
        lut[j] = (t * exp_neg(t * t) * 65536.0 + 0.5) as u16;
        j += 1;
    }
    lut
}

/// Normalised Perona–Malik flux table: entry `j` is `g(t) = t·exp(−t²)` in Q16 (rounded) at
/// `t = j/2048`, `j` in `0..8192`, and entry 8192 is 0 (every `t ≥ 4`: g < 5·10⁻⁷).
/// Built at compile time; 16 KiB. The flux of a difference `∇` is `c·∇ = κ·g(|∇|/κ)·sign(∇)`,
/// so one table serves every κ and Δt. Maximum entry 28107 (g(1/√2) = 0.4289).
pub static EXP_FLUX: [u16; LUT_LEN + 1] = build_lut();

// Evaluated at compile time only, like `build_lut`.
#[allow(clippy::indexing_slicing)]
const fn build_signed() -> [i16; 2 * LUT_LEN + 1] {
    let mut lut = [0i16; 2 * LUT_LEN + 1];
    let mut j = 0;
    while j <= LUT_LEN {
        // Every entry is ≤ 28107 < 2¹⁵ (checked by `max_entry`).
        lut[LUT_LEN + j] = EXP_FLUX[j] as i16;
        lut[LUT_LEN - j] = -(EXP_FLUX[j] as i16);
        j += 1;
    }
    lut
}

/// [`EXP_FLUX`] with its sign: entry `LUT_LEN + k` is `sign(k)·EXP_FLUX[|k|]` for `k` in
/// `−8192..=8192` (32 KiB), so the flux of a signed difference is one signed index and one
/// read, with no absolute value and no conditional negation (see `Diffusion::flux`).
static SIGNED_FLUX: [i16; 2 * LUT_LEN + 1] = build_signed();

/// ADF parameters. [`Default`] is the published setting (`run_ADF.m`: N = 10, Δt = 0.15,
/// κ = 30, exponential conduction) with the [`Variant::Flight`] variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AdfParams {
    /// Classic (published, step for step) or flight (guarded, replicate border).
    pub variant: Variant,
    /// Diffusion iterations N, `1..=1000`.
    pub iterations: u16,
    /// Time step Δt in thousandths (150 = 0.15), `1..=250`.
    pub dt_milli: u16,
    /// Conduction constant κ in grey levels (0..255 units), `1..=255`.
    pub kappa: u16,
}

impl Default for AdfParams {
    fn default() -> Self {
        Self { variant: Variant::Flight, iterations: 10, dt_milli: 150, kappa: 30 }
    }
}

impl AdfParams {
    /// Checks every field's documented range ([`Error::InvalidParameter`] names the field).
    pub fn validate(&self) -> Result<(), Error> {
        if !(1..=1000).contains(&self.iterations) {
            return Err(Error::InvalidParameter { name: "iterations" });
        }
        if !(1..=250).contains(&self.dt_milli) {
            return Err(Error::InvalidParameter { name: "dt_milli" });
        }
        if !(1..=255).contains(&self.kappa) {
            return Err(Error::InvalidParameter { name: "kappa" });
        }
        Ok(())
    }

    /// Δt in floating point (for the f64 reference): `dt_milli / 1000`.
    pub fn dt(&self) -> f64 {
        f64::from(self.dt_milli) / 1000.0
    }

    /// The diffusion border rule of the variant (classic: zero; flight: replicate).
    pub fn border(&self) -> Border {
        match self.variant {
            Variant::Classic => Border::Zero,
            Variant::Flight => Border::Replicate,
        }
    }
}

/// The largest table entry, 28107 (`g(1/√2)` in Q16): bounds every flux and the per-pixel sum.
const MAX_FLUX: i32 = max_entry();

/// Largest index the flux reads. Entries from 7404 on are 0, so clamping the signed index to
/// `−LUT_LEN..=LUT_LAST` reads the same 0s as `±LUT_LEN` would (and is one `ssat #14` on Arm).
const LUT_LAST: u32 = (LUT_LEN - 1) as u32;

// Evaluated at compile time only, like `build_lut`: an out-of-range index would be a compile
// error, never a run-time panic.
#[allow(clippy::indexing_slicing)]
const fn max_entry() -> i32 {
    let mut j = 0;
    let mut max = 0;
    while j <= LUT_LEN {
        if EXP_FLUX[j] > max {
            max = EXP_FLUX[j];
        }
        j += 1;
    }
    // The facts the fast paths rely on.
    assert!(max == 28107);
    assert!(EXP_FLUX[LUT_LEN - 1] == 0 && EXP_FLUX[LUT_LEN] == 0, "the last two entries are 0");
    const { assert!(LUT_LAST == (1 << 13) - 1 && LUT_LEN == 1 << 13, "ssat #14 clamps to -LUT_LEN..=LUT_LAST") };
    max as i32
}

/// `⌊(x·k + 2³¹) / 2³²⌋`: the rounded high word of the 64-bit product (one `smmulr` on
/// Armv7E-M). The diffusion's two multiplies — the table index and the update — are both this.
#[inline(always)]
fn mul_hi_round(x: i32, k: i32) -> i32 {
    #[cfg(fusion_arm_dsp)]
    {
        let hi: i32;
        // SAFETY: one register-only ALU instruction (Armv7E-M DSP): no memory, no flags.
        unsafe {
            core::arch::asm!(
                "smmulr {h}, {x}, {k}",
                h = out(reg) hi,
                x = in(reg) x,
                k = in(reg) k,
                options(pure, nomem, nostack, preserves_flags),
            );
        }
        hi
    }
    #[cfg(not(fusion_arm_dsp))]
    {
        ((i64::from(x) * i64::from(k) + (1 << 31)) >> 32) as i32
    }
}

/// Bits the per-pixel sum is shifted up before the update multiply: `|Σ| ≤ 12·28107 < 2¹⁹`,
/// so `Σ << 12` fits `i32`, and `STEP_UP + 4 = 16` bits of the Q16 scale go to `step_mul`.
const STEP_UP: u32 = 12;
const _: () = assert!((12 * MAX_FLUX as i64) << STEP_UP <= i32::MAX as i64, "Σ << STEP_UP fits i32");

/// Per-call constants of the diffusion.
#[derive(Debug, Clone, Copy)]
struct Diffusion {
    /// The signed table index of `∇` (Q16) is `mul_hi_round(∇, index_mul)`,
    /// `index_mul = round(2²⁷/κ)`, i.e. `2048·∇/(2¹⁶·κ)` rounded half up, clamped to
    /// `−LUT_LEN..=LUT_LAST` (one `ssat #14` on Arm). `2¹⁹ < index_mul ≤ 2²⁷` (κ in
    /// 1..=255): the 64-bit product never overflows, and the multiplier's rounding moves the
    /// index by less than `2⁻²⁰` of itself (< 0.01 of a table step).
    index_mul: i32,
    /// The update `round(κΔt/2 · Σ)` (Q16 · Q16 → Q16, half up) is
    /// `mul_hi_round(Σ << STEP_UP, step_mul)`, `step_mul = (κΔt/2 in Q16) << 4 < 2²⁶`:
    /// `⌊(Σ·scale + 2¹⁵)/2¹⁶⌋` exactly, for every parameter set.
    step_mul: i32,
    /// Use the AVX2 row loop (x86-64 with AVX2).
    #[cfg(target_arch = "x86_64")]
    avx2: bool,
    border: Border,
}

impl Diffusion {
    fn new(params: &AdfParams) -> Self {
        let kappa = i64::from(params.kappa.max(1));
        // κ·Δt/2 = κ·dt_milli/2000, in Q16, rounded; ≤ 255·250·2¹⁶/2000 < 2²².
        let scale = (((kappa * i64::from(params.dt_milli)) << 16) + 1000) / 2000;
        Self {
            index_mul: (((1i64 << 27) + kappa / 2) / kappa) as i32,
            step_mul: (scale.max(1) << (16 - STEP_UP)) as i32,
            #[cfg(target_arch = "x86_64")]
            avx2: crate::cpu::has_avx2(),
            border: params.border(),
        }
    }

    /// `g(∇/κ)` in Q16 for a signed `∇` in Q16 (the flux divided by κ, with its sign): the
    /// entry of [`SIGNED_FLUX`] at [`Self::index`]. Not exactly odd (the index rounds half up,
    /// not symmetrically, so `flux(−∇)` may sit one table step from `−flux(∇)` at a tie):
    /// every pair of pixels therefore takes its flux in one orientation only, `flux(later −
    /// earlier)` in row-major order, and both pixels use it (see [`Self::update`]).
    #[inline(always)]
    fn flux(&self, d: i32) -> i32 {
        let k = self.index(d) + LUT_LEN as i32; // 0 ..= 2·LUT_LEN − 1
        SIGNED_FLUX.get(k as usize).map_or(0, |&g| i32::from(g))
    }

    /// The signed table index of `∇`: `clamp(mul_hi_round(∇, index_mul), −LUT_LEN,
    /// LUT_LAST)`. Entries from ±7404 on are 0, so the clamp changes no value.
    #[inline(always)]
    fn index(&self, d: i32) -> i32 {
        mul_hi_round(d, self.index_mul).clamp(-(LUT_LEN as i32), LUT_LAST as i32)
    }

    /// `round(κΔt/2 · acc)` in Q16 for the per-pixel sum `acc` (|acc| ≤ 12·[`MAX_FLUX`]).
    #[inline(always)]
    fn step(&self, acc: i32) -> i32 {
        mul_hi_round(acc << STEP_UP, self.step_mul)
    }

    /// The next iterate of one pixel from its 3×3 neighbourhood (all eight fluxes; the path
    /// for frames too small for the row pipeline). Each pair's flux is taken as `flux(later −
    /// earlier)` in row-major order, as the row pipeline takes it once for both pixels: the
    /// later neighbours (E, S, SW, SE) add `flux(n − c)`, the earlier ones (W, N, NW, NE)
    /// subtract `flux(c − n)`.
    #[inline(always)]
    fn update(&self, [l, c, r]: Neighbourhood<i32>) -> i32 {
        let centre = c[1];
        let later = |v: i32| self.flux(v.wrapping_sub(centre));
        let earlier = |v: i32| self.flux(centre.wrapping_sub(v));
        let axial = later(c[2]) + later(r[1]) - earlier(c[0]) - earlier(l[1]);
        let diagonal = later(l[2]) + later(r[2]) - earlier(l[0]) - earlier(r[0]);
        let acc = 2 * axial + diagonal; // |acc| ≤ 12·28107 < 2¹⁹
        centre.saturating_add(self.step(acc))
    }

    /// One Jacobi iteration of the packed `w`-wide plane `src` into `dst`.
    fn iterate(&self, src: &[i32], dst: &mut [i32], w: usize) {
        let h = src.len() / w.max(1);
        for (y, out) in dst.chunks_exact_mut(w.max(1)).enumerate() {
            let row = |yy: usize| src.get(yy * w..yy * w + w);
            let Some(mid) = row(y) else { return };
            let (up, down) = match self.border {
                Border::Replicate => (row(y.saturating_sub(1)), row((y + 1).min(h - 1))),
                _ => (y.checked_sub(1).and_then(row), row(y + 1)),
            };
            map_neighbourhoods_op(up, mid, down, self.border, out.iter_mut(), Update(self));
        }
    }

    /// The north fluxes `2·flux(C − N) + flux(C − NW) + flux(C − NE)` of the top pad row
    /// `top` with every pixel of the first row `q` (both padded, `w + 2` long), into
    /// `north[1..=w]` (pairs in the `flux(later − earlier)` orientation; a pixel subtracts
    /// them).
    fn top_north(&self, top: &[i32], q: &[i32], north: &mut [i32]) {
        let f = |a: i32, b: i32| self.flux(b.wrapping_sub(a));
        let pixels = top.windows(3).zip(q.iter().skip(1)).zip(north.iter_mut().skip(1));
        for ((t, &c), n) in pixels {
            if let &[nw, n0, ne] = t {
                *n = 2 * f(n0, c) + f(nw, c) + f(ne, c);
            }
        }
    }

    /// One output row of a Jacobi iteration by pair fluxes. `p` is the row being updated and
    /// `q` the row below, both padded by one column on each side (`w + 2`); `north[i]` holds
    /// the fluxes of the pairs of pixel `i` of `p` with the row above (`2·flux(C − N) +
    /// flux(C − NW) + flux(C − NE)`, which the pixel subtracts) and is replaced by those of
    /// `q` with `p`. Per pixel four table reads: the pairs east (`h`), south (`v`), south-east
    /// (`dr`) and south-west (`dl`), each `flux(later − earlier)`. Each enters this pixel's
    /// sum and, subtracted, its partner's: the west flux is `−h` of the previous pixel, and
    /// the pairs to `q` become `q`'s north fluxes `2·v(i) + dr(i−1) + dl(i+1)`. The same sum,
    /// hence the same bits, as [`Self::update`] with its eight table reads. The next iterate
    /// goes to `out` (`w`).
    #[inline(never)]
    fn row(&self, p: &[i32], q: &[i32], north: &mut [i32], out: &mut [i32]) {
        let f = |a: i32, b: i32| self.flux(b.wrapping_sub(a));
        let (Some(&p0), Some(&p1), Some(&q1)) = (p.first(), p.get(1), q.get(1)) else { return };
        // The left pad's pairs: p[0]–p[1] (the first west flux) and p[0]–q[1].
        #[cfg_attr(not(any(target_arch = "x86_64", fusion_arm_dsp)), allow(unused_mut))]
        let mut carry = RowCarry { h_prev: f(p0, p1), dr_prev: f(p0, q1), partial: 0 };
        #[cfg(target_arch = "x86_64")]
        let done = if self.avx2 {
            // SAFETY: `avx2` is set only when the CPU has AVX2 (checked at run time).
            unsafe { avx2::row_blocks(self, p, q, north, out, &mut carry) }
        } else {
            0
        };
        #[cfg(fusion_arm_dsp)]
        let done = arm::row_pixels(self, p, q, north, out, &mut carry);
        #[cfg(not(any(target_arch = "x86_64", fusion_arm_dsp)))]
        let done = 0;
        let RowCarry { mut h_prev, mut dr_prev, mut partial } = carry;
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
            let h = f(pc, pr);
            let v = f(pc, qc);
            let dr = f(pc, qr);
            let dl = f(pc, ql);
            let acc = 2 * (h - h_prev + v) + dr + dl - n_here.get();
            *o = pc.saturating_add(self.step(acc));
            n_prev.set(partial + dl);
            partial = 2 * v + dr_prev;
            dr_prev = dr;
            h_prev = h;
        }
        // The right pad's pair p[w+1]–q[w] completes q's last north fluxes.
        let n = p.len();
        if let (Some(last), Some(&pr), Some(&ql)) =
            (north.get(n.wrapping_sub(2)), p.get(n.wrapping_sub(1)), q.get(n.wrapping_sub(2)))
        {
            last.set(partial + f(pr, ql));
        }
    }
}

/// What [`Diffusion::row`] carries from one pixel to the next: the previous east flux (this
/// pixel's west, negated), the previous south-east flux, and `2·v(i−1) + dr(i−2)`.
#[derive(Debug, Clone, Copy)]
struct RowCarry {
    h_prev: i32,
    dr_prev: i32,
    partial: i32,
}

/// The Armv7E-M copy of the row loop (Cortex-M4/M7): the portable loop's operations in
/// assembly, one pixel per pass, the flux as `sub`, `smmulr`, `ssat #14`, `ldrsh` (LLVM's
/// schedule of the same loop kept the table base out of the address and spilled the carried
/// values: ≈ 60 instructions per pixel; this one is 37). The same bits as the portable loop
/// (the firmware's bit-exactness jobs compare the target's frames with the host's).
#[cfg(fusion_arm_dsp)]
mod arm {
    use super::{Diffusion, LUT_LEN, RowCarry, SIGNED_FLUX, STEP_UP};

    /// Runs the row loop of [`Diffusion::row`] on every pixel of `out`, updating `carry`;
    /// returns the pixels done (0 when a slice is too short, and the portable loop runs).
    pub(super) fn row_pixels(
        d: &Diffusion,
        p: &[i32],
        q: &[i32],
        north: &mut [i32],
        out: &mut [i32],
        carry: &mut RowCarry,
    ) -> usize {
        let w = out.len();
        if w == 0 || p.len() < w + 2 || q.len() < w + 2 || north.len() < w + 2 {
            return 0;
        }
        const { assert!(STEP_UP == 12, "the loop shifts the sum by #12") };
        let centre = SIGNED_FLUX.as_ptr().wrapping_add(LUT_LEN);
        let end = out.as_mut_ptr().wrapping_add(w);
        let RowCarry { mut h_prev, mut dr_prev, mut partial } = *carry;
        // SAFETY: pixel i (0 ≤ i < w) reads p[i + 1], p[i + 2], q[i], q[i + 1], q[i + 2],
        // north[i + 1], writes north[i] and out[i]: all inside the slices, whose lengths are
        // checked above (p, q, north ≥ w + 2). The table reads are at `centre + 2·k`,
        // k in −8192..=8191 (`ssat #14`), inside the 2·8192 + 1 entries. The loop runs while
        // the output pointer has not reached `end` (w ≥ 1 passes). r6 and r7 are pushed and
        // popped around the loop; every other register written is declared.
        unsafe {
            core::arch::asm!(
                // r6 and r7 (LLVM's base and frame pointers, not available as operands) are
                // saved and hold the update multiplier (r6) and the end pointer (r7).
                "push {{r6, r7}}",
                "mov r6, r12",
                "mov r7, r11",
                "2:",
                "ldrd r11, r12, [r0], #4",    // pc, pr
                "ldr lr, [r1], #4",           // ql
                "sub lr, lr, r11",
                "smmulr lr, lr, r5",
                "ssat lr, #14, lr",
                "ldrsh lr, [r4, lr, lsl #1]", // dl
                "add r10, r10, lr",           // north fluxes of q's pixel i − 1
                "str r10, [r2], #4",
                "ldr r10, [r2]",              // this pixel's north fluxes
                "sub lr, lr, r10",            // dl − north
                "sub r12, r12, r11",
                "smmulr r12, r12, r5",
                "ssat r12, #14, r12",
                "ldrsh r12, [r4, r12, lsl #1]", // h
                "sub r10, r12, r8",           // h − h_prev
                "mov r8, r12",
                "ldr r12, [r1]",              // qc
                "sub r12, r12, r11",
                "smmulr r12, r12, r5",
                "ssat r12, #14, r12",
                "ldrsh r12, [r4, r12, lsl #1]", // v
                "add r10, r10, r12",          // h − h_prev + v
                "add lr, lr, r10, lsl #1",
                "add r10, r9, r12, lsl #1",   // partial = dr_prev + 2·v
                "ldr r12, [r1, #4]",          // qr
                "sub r12, r12, r11",
                "smmulr r12, r12, r5",
                "ssat r12, #14, r12",
                "ldrsh r12, [r4, r12, lsl #1]", // dr
                "add lr, lr, r12",            // the sum
                "mov r9, r12",
                "lsl lr, lr, #12",
                "smmulr lr, lr, r6",          // the update
                "qadd lr, r11, lr",           // pc + update, saturated
                "str lr, [r3], #4",
                "cmp r3, r7",
                "bne 2b",
                "pop {{r6, r7}}",
                inout("r0") p.as_ptr().wrapping_add(1) => _,
                inout("r1") q.as_ptr() => _,
                inout("r2") north.as_mut_ptr() => _,
                inout("r3") out.as_mut_ptr() => _,
                in("r4") centre,
                in("r5") d.index_mul,
                inout("r8") h_prev,
                inout("r9") dr_prev,
                inout("r10") partial,
                inout("r11") end => _,
                inout("r12") d.step_mul => _,
                out("lr") _,
            );
        }
        *carry = RowCarry { h_prev, dr_prev, partial };
        w
    }
}

/// The AVX2 copy of the row loop (x86-64 hosts): eight pixels at a time, the table read by
/// `vpgatherdd`. The same integer values as the portable loop, so the same bits
/// (checked by `avx2_rows_equal_the_portable_rows`).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Diffusion, LUT_LAST, LUT_LEN, RowCarry, SIGNED_FLUX, STEP_UP};
    use core::arch::x86_64::*;

    /// Eight `i32` at `s[at..at + 8]`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn load(s: &[i32], at: usize) -> Option<__m256i> {
        let v: &[i32; 8] = s.get(at..at + 8)?.try_into().ok()?;
        // SAFETY: reads the 32 bytes of `v` (unaligned load).
        Some(unsafe { _mm256_loadu_si256(v.as_ptr().cast()) })
    }

    /// Stores eight `i32` to `s[at..at + 8]`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn store(s: &mut [i32], at: usize, x: __m256i) -> Option<()> {
        let v: &mut [i32; 8] = s.get_mut(at..at + 8)?.try_into().ok()?;
        // SAFETY: writes the 32 bytes of `v` (unaligned store).
        unsafe { _mm256_storeu_si256(v.as_mut_ptr().cast(), x) };
        Some(())
    }

    /// `[prev[8 − k..], cur[..8 − k]]`: `cur` shifted up by `k` lanes (`k` = 1 or 2), the
    /// vacated lanes taken from the top of `prev`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn shift_in<const BYTES: i32>(prev: __m256i, cur: __m256i) -> __m256i {
        _mm256_alignr_epi8::<BYTES>(cur, _mm256_permute2x128_si256::<0x21>(prev, cur))
    }

    /// [`super::mul_hi_round`] on eight lanes: `⌊(x·k + 2³¹)/2³²⌋` from the two 64-bit
    /// products of the even and the odd lanes (`k` broadcast, `half` = 2³¹ per 64-bit lane).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn mul_hi_round(x: __m256i, k: __m256i, half: __m256i) -> __m256i {
        let even = _mm256_add_epi64(_mm256_mul_epi32(x, k), half);
        let odd = _mm256_add_epi64(_mm256_mul_epi32(_mm256_srli_epi64::<32>(x), k), half);
        _mm256_blend_epi32::<0b1010_1010>(_mm256_srli_epi64::<32>(even), odd)
    }

    /// The constants of [`Diffusion::flux`] and [`Diffusion::step`], broadcast.
    struct Flux {
        index_mul: __m256i,
        step_mul: __m256i,
        half: __m256i,
        first: __m256i,
        last: __m256i,
    }

    impl Flux {
        #[target_feature(enable = "avx2")]
        #[inline]
        fn new(d: &Diffusion) -> Self {
            Flux {
                index_mul: _mm256_set1_epi32(d.index_mul),
                step_mul: _mm256_set1_epi32(d.step_mul),
                half: _mm256_set1_epi64x(1 << 31),
                first: _mm256_set1_epi32(-(LUT_LEN as i32)),
                last: _mm256_set1_epi32(LUT_LAST as i32),
            }
        }

        /// `flux(d)` on eight lanes: the signed index `mul_hi_round(d, index_mul)` clamped to
        /// `−LUT_LEN..=LUT_LAST`, the entry by a 32-bit gather at byte offset `2·idx` from the
        /// table's centre (entries `idx` and `idx + 1`, both inside the table), its low half
        /// sign-extended.
        #[target_feature(enable = "avx2")]
        #[inline]
        fn apply(&self, d: __m256i) -> __m256i {
            let idx = mul_hi_round(d, self.index_mul, self.half);
            let idx = _mm256_max_epi32(_mm256_min_epi32(idx, self.last), self.first);
            let centre = SIGNED_FLUX.as_ptr().wrapping_add(LUT_LEN);
            // SAFETY: every index is in −LUT_LEN..=LUT_LAST, so the 4 bytes read at `2·idx`
            // from the centre lie inside the 2·(2·LUT_LEN + 1)-element table.
            let g = unsafe { _mm256_i32gather_epi32::<2>(centre.cast(), idx) };
            _mm256_srai_epi32::<16>(_mm256_slli_epi32::<16>(g))
        }

        /// `step(acc)` on eight lanes.
        #[target_feature(enable = "avx2")]
        #[inline]
        fn step(&self, acc: __m256i) -> __m256i {
            mul_hi_round(_mm256_slli_epi32::<{ STEP_UP as i32 }>(acc), self.step_mul, self.half)
        }
    }

    /// [`Flux::apply`] and [`Flux::step`] on eight values (for the tests).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(test)]
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn flux8(d: &Diffusion, x: [i32; 8]) -> ([i32; 8], [i32; 8]) {
        let flux = Flux::new(d);
        // SAFETY: reads the 32 bytes of `x`, writes the 32 bytes of each output.
        let v = unsafe { _mm256_loadu_si256(x.as_ptr().cast()) };
        let (mut f, mut s) = ([0i32; 8], [0i32; 8]);
        unsafe { _mm256_storeu_si256(f.as_mut_ptr().cast(), flux.apply(v)) };
        unsafe { _mm256_storeu_si256(s.as_mut_ptr().cast(), flux.step(v)) };
        (f, s)
    }

    /// Runs the row loop of [`Diffusion::row`] on whole blocks of eight
    /// pixels from the start of the row, updating `carry`; returns the pixels done.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn row_blocks(
        d: &Diffusion,
        p: &[i32],
        q: &[i32],
        north: &mut [i32],
        out: &mut [i32],
        carry: &mut RowCarry,
    ) -> usize {
        let flux = Flux::new(d);
        let max = _mm256_set1_epi32(i32::MAX);
        let mut h_prev = _mm256_set_epi32(carry.h_prev, 0, 0, 0, 0, 0, 0, 0);
        let mut v_prev = _mm256_setzero_si256();
        // Lane 7 holds the carried value; the other lanes (and `v_prev`) are 0, so that the
        // first block writes the unused `north[0]` exactly as the portable loop does.
        let mut dr_prev = _mm256_set_epi32(carry.dr_prev, 0, 0, 0, 0, 0, 0, 0);
        let (mut h, mut v, mut dr) = (h_prev, v_prev, dr_prev);
        let mut x = 0;
        while x + 8 <= out.len() {
            let (Some(pc), Some(pr), Some(ql), Some(qc), Some(qr), Some(n_here)) = (
                load(p, x + 1),
                load(p, x + 2),
                load(q, x),
                load(q, x + 1),
                load(q, x + 2),
                load(north, x + 1),
            ) else {
                break;
            };
            h = flux.apply(_mm256_sub_epi32(pr, pc));
            v = flux.apply(_mm256_sub_epi32(qc, pc));
            dr = flux.apply(_mm256_sub_epi32(qr, pc));
            let dl = flux.apply(_mm256_sub_epi32(ql, pc));
            let west = shift_in::<12>(h_prev, h);
            let axial = _mm256_add_epi32(_mm256_sub_epi32(h, west), v);
            let acc = _mm256_sub_epi32(
                _mm256_add_epi32(_mm256_add_epi32(axial, axial), _mm256_add_epi32(dr, dl)),
                n_here,
            );
            let step = flux.step(acc);
            // pc + step, saturated to the i32 range.
            let sum = _mm256_add_epi32(pc, step);
            let overflow = _mm256_and_si256(_mm256_xor_si256(pc, sum), _mm256_xor_si256(step, sum));
            let limit = _mm256_xor_si256(_mm256_srai_epi32::<31>(pc), max);
            let next = _mm256_castps_si256(_mm256_blendv_ps(
                _mm256_castsi256_ps(sum),
                _mm256_castsi256_ps(limit),
                _mm256_castsi256_ps(overflow),
            ));
            // The north fluxes of the row below at x − 1 .. x + 6 (pixel indices 0-based):
            // 2·v(k) + dr(k − 1) + dl(k + 1).
            let v_up = shift_in::<12>(v_prev, v);
            let dr_up = shift_in::<8>(dr_prev, dr);
            let below = _mm256_add_epi32(_mm256_add_epi32(v_up, v_up), _mm256_add_epi32(dr_up, dl));
            if store(out, x, next).is_none() || store(north, x, below).is_none() {
                break;
            }
            (h_prev, v_prev, dr_prev) = (h, v, dr);
            x += 8;
        }
        if x > 0 {
            let lane = |a: __m256i, i: usize| {
                let mut l = [0i32; 8];
                // SAFETY: writes the 32 bytes of `l`.
                unsafe { _mm256_storeu_si256(l.as_mut_ptr().cast(), a) };
                l.get(i).copied().unwrap_or(0)
            };
            *carry =
                RowCarry { h_prev: lane(h, 7), dr_prev: lane(dr, 7), partial: 2 * lane(v, 7) + lane(dr, 6) };
        }
        x
    }
}

/// The per-pixel update as a [`NeighbourhoodOp`] (inlined into the row walk).
struct Update<'a>(&'a Diffusion);

impl<'a, 'o> NeighbourhoodOp<i32, &'o mut i32> for Update<'a> {
    #[inline(always)]
    fn apply(&mut self, n: Neighbourhood<i32>, out: &'o mut i32) {
        *out = self.0.update(n);
    }
}

/// Rows of `tmp` per stage of the row pipeline, each padded (`w + 2`): two state rows and the
/// north contributions.
const STAGE_ROWS: usize = 3;

/// Where the first stage of a pipeline group reads its rows.
#[derive(Clone, Copy)]
enum Input<'a> {
    /// The source frame (first group: `u8` → Q16).
    Frame(FrameRef<'a, u8>),
    /// The state plane itself (later groups, read before being overwritten).
    State,
}

/// Where the last stage of a pipeline group writes its rows.
enum Output<'s> {
    /// The state plane (`w·h`, row `y` at `y·w`).
    Plane(&'s mut [i32]),
    /// One row (`w`): each output row replaces the previous one (the streaming form; the
    /// input must then be [`Input::Frame`]).
    Row(&'s mut [i32]),
}

impl Output<'_> {
    /// Where output row `y` goes.
    fn row(&mut self, y: usize, w: usize) -> &mut [i32] {
        match self {
            Output::Plane(p) => p.get_mut(y * w..y * w + w).unwrap_or(&mut []),
            Output::Row(r) => r.get_mut(..w).unwrap_or(&mut []),
        }
    }

    /// Input row `t` of a later group (the plane, before it is overwritten).
    fn state_row(&self, t: usize, w: usize) -> &[i32] {
        match self {
            Output::Plane(p) => p.get(t * w..t * w + w).unwrap_or(&[]),
            Output::Row(_) => &[],
        }
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

/// One stage's memory: the two state rows (row `j` in slot `j % 2`) and the north
/// contributions to the oldest row not yet updated.
fn stage_rows(mem: &mut [i32], stride: usize) -> Option<[&mut [i32]; STAGE_ROWS]> {
    let mut rows = mem.chunks_exact_mut(stride.max(1));
    Some([rows.next()?, rows.next()?, rows.next()?])
}

impl Diffusion {
    /// Runs `stages` Jacobi iterations in one pass down the frame (temporal blocking): stage
    /// `s` keeps the last two rows of iterate `s` and the north contributions of their pairs, and
    /// turns each new row of iterate `s` into the previous row of iterate `s + 1`, which goes
    /// straight into stage `s + 1` (the last stage writes `state`). All the work rows live in
    /// `mem` (`stages · STAGE_ROWS · (w + 2)` values), so the frame is read and written once
    /// per group of iterations and the working set stays in cache.
    fn run_group(
        &self,
        input: Input<'_>,
        state: &mut [i32],
        mem: &mut [i32],
        (w, h): (usize, usize),
        stages: usize,
    ) {
        let Some(mem) = mem.get_mut(..stages * STAGE_ROWS * (w + 2)) else { return };
        mem.fill(0);
        let mut out = Output::Plane(state);
        for t in 0..h + stages {
            self.pipeline_step(t, input, &mut out, mem, (w, h), stages);
        }
    }

    /// Step `t` (`0 .. h + stages`) of a pipeline group: input row `t` enters stage 0 and
    /// every stage passes on the row it can now finish; the last stage writes row
    /// `t − stages` (when `t ≥ stages`) to `out`. `mem` holds the group's zeroed work rows
    /// (`stages · STAGE_ROWS · (w + 2)` values) and is carried from step to step.
    fn pipeline_step(
        &self,
        t: usize,
        input: Input<'_>,
        state: &mut Output<'_>,
        mem: &mut [i32],
        (w, h): (usize, usize),
        stages: usize,
    ) {
        let stride = w + 2;
        let per_stage = STAGE_ROWS * stride;
        let mut chunks = mem.chunks_exact_mut(per_stage.max(1));
        let mut cur = chunks.next();
        // The input row t enters stage 0.
        if t < h
            && let Some([s0, s1, _]) = cur.as_deref_mut().and_then(|m| stage_rows(m, stride))
        {
            let slot = if t.is_multiple_of(2) { s0 } else { s1 };
            let dst = slot.get_mut(1..=w).unwrap_or(&mut []);
            match input {
                Input::Frame(src) => {
                    for (d, &v) in dst.iter_mut().zip(src.row(t)) {
                        *d = i32::from(v) << STATE_BITS;
                    }
                }
                Input::State => {
                    for (d, &v) in dst.iter_mut().zip(state.state_row(t, w)) {
                        *d = v;
                    }
                }
            }
            set_pads(slot, self.border);
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
                    let top: &[i32] = match self.border {
                        Border::Replicate => newer,
                        _ => {
                            older.fill(0);
                            older
                        }
                    };
                    self.top_north(top, newer, north);
                } else {
                    // Output row j − 1 of iterate s + 1, from rows j − 1 (`older`) and j
                    // (`newer`), or the bottom pad row when j = h.
                    let (p, q): (&[i32], &[i32]) = if j < h {
                        (older, newer)
                    } else {
                        // Row h − 1 is `older`; the free slot becomes the zero pad row.
                        match self.border {
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
                            self.row(p, q, north, slot.get_mut(1..=w).unwrap_or(&mut []));
                            set_pads(slot, self.border);
                        }
                        None => self.row(p, q, north, state.row(y, w)),
                    }
                }
            }
            cur = next.take();
        }
    }
}

/// Diffuses `src` (u8) with `params.iterations` Perona–Malik steps into `state` (Q16,
/// packed `w × h`), using `tmp` as work memory. Both planes hold at least `w·h` elements.
/// This is step 1 of ADF (the base layer), public for tests and benches.
///
/// The iterations run in groups through a row pipeline (see `Diffusion::run_group`) that
/// needs `3·(w + 2)` values of `tmp` per iteration; frames too small for even one stage
/// (fewer than about 3 rows) fall back to plain Jacobi sweeps with `tmp` as the ping-pong
/// plane. Both give the same bits.
pub fn diffuse(
    src: FrameRef<'_, u8>,
    params: &AdfParams,
    state: &mut [i32],
    tmp: &mut [i32],
) -> Result<(), Error> {
    params.validate()?;
    let (w, h) = src.size();
    let pixels = w * h;
    let capacity = state.len().min(tmp.len());
    let (Some(state), Some(tmp)) = (state.get_mut(..pixels), tmp.get_mut(..pixels)) else {
        return Err(Error::ScratchTooSmall { needed: pixels, capacity });
    };
    let diffusion = Diffusion::new(params);
    let per_stage = STAGE_ROWS * (w + 2);
    let group = (pixels / per_stage.max(1)).min(usize::from(params.iterations));
    if group == 0 {
        diffuse_sweeps(src, &diffusion, params.iterations, state, tmp, w);
        return Ok(());
    }
    let mut done = 0;
    let mut input = Input::Frame(src);
    while done < usize::from(params.iterations) {
        let stages = group.min(usize::from(params.iterations) - done);
        diffusion.run_group(input, state, tmp, (w, h), stages);
        input = Input::State;
        done += stages;
    }
    Ok(())
}

/// Plain Jacobi sweeps (8 fluxes per pixel), `tmp` as the ping-pong plane.
fn diffuse_sweeps(
    src: FrameRef<'_, u8>,
    diffusion: &Diffusion,
    iterations: u16,
    state: &mut [i32],
    tmp: &mut [i32],
    w: usize,
) {
    for (row, dst) in src.rows().zip(state.chunks_exact_mut(w.max(1))) {
        for (d, &v) in dst.iter_mut().zip(row) {
            *d = i32::from(v) << STATE_BITS;
        }
    }
    for i in 0..iterations {
        if i % 2 == 0 {
            diffusion.iterate(state, tmp, w);
        } else {
            diffusion.iterate(tmp, state, w);
        }
    }
    if !iterations.is_multiple_of(2) {
        for (s, t) in state.iter_mut().zip(tmp.iter()) {
            *s = *t;
        }
    }
}

/// The KL weight and the guards it fired.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KlWeights {
    /// Weight of the IR detail layer in Q30 (`p_VIS = 2³⁰ − p_IR`).
    pub p_ir_q30: i64,
    /// Guards fired while computing it.
    pub guards: Guards,
}

/// Integer square root of a `u128` (floor), by Newton's method from a power-of-two start.
fn isqrt_u128(n: u128) -> u128 {
    if n < 2 {
        return n;
    }
    let bits = 128 - n.leading_zeros();
    let mut x: u128 = 1 << bits.div_ceil(2); // ≥ √n
    loop {
        let y = (x + n.checked_div(x).unwrap_or(0)) / 2; // x ≥ 1 (checked: no panic path)
        if y >= x {
            return x;
        }
        x = y;
    }
}

/// KL weight of the first (IR) layer from the covariance-like values `a = var(IR)`,
/// `b = cov(IR, VIS)`, `c = var(VIS)` (any common positive scale, here `n(n−1)·cov`).
pub fn kl_weight(a: i128, b: i128, c: i128, variant: Variant) -> KlWeights {
    let one = 1i64 << WEIGHT_BITS;
    let half = one / 2;
    let mut guards = Guards::NONE;
    if a == 0 && b == 0 && c == 0 {
        guards |= Guards::ADF_ZERO_COVARIANCE.with(Guards::ADF_DEGENERATE_EIGENVECTOR);
    }
    // Scale the three values together into 61 bits.
    let m = a.unsigned_abs().max(b.unsigned_abs()).max(c.unsigned_abs());
    let bits = 128 - m.leading_zeros();
    let (a, b, c) = if bits > 61 {
        let s = bits - 61;
        (a >> s, b >> s, c >> s)
    } else {
        let s = 61 - bits;
        (a << s, b << s, c << s)
    };
    let diff = c - a; // < 2⁶²
    let r = isqrt_u128(diff.unsigned_abs().pow(2) + (2 * b).unsigned_abs().pow(2)) as i128;
    let (v1, v2) = if diff >= 0 { (2 * b, diff + r) } else { (-diff + r, 2 * b) };
    if v1 == 0 && v2 == 0 {
        // Exact tie (a = c, b = 0): MATLAB's eig returns the identity, the first column wins.
        guards |= Guards::ADF_DEGENERATE_EIGENVECTOR;
        let p = match variant {
            Variant::Classic => one,
            Variant::Flight => half,
        };
        return KlWeights { p_ir_q30: p, guards };
    }
    let sum = v1 + v2;
    let abs_sum = v1.abs() + v2.abs();
    if sum.abs() <= abs_sum >> 16 {
        guards |= Guards::ADF_DEGENERATE_EIGENVECTOR;
    }
    let p = match variant {
        Variant::Classic => {
            if sum == 0 {
                half
            } else {
                let limit = 128i128 << WEIGHT_BITS;
                // max/min rather than clamp: clamp panics if its bounds cross, which the
                // optimiser cannot rule out for the product (issue 9: no panic path).
                let bound = limit.saturating_mul(sum.saturating_abs());
                div_round((v1 << WEIGHT_BITS).max(-bound).min(bound), sum).max(-limit).min(limit) as i64
            }
        }
        Variant::Flight => {
            if (v1 < 0 && v2 > 0) || (v1 > 0 && v2 < 0) {
                guards |= Guards::ADF_WEIGHT_CLAMPED;
            }
            div_round(v1.abs() << WEIGHT_BITS, abs_sum) as i64
        }
    };
    KlWeights { p_ir_q30: p, guards }
}

/// `round(n / d)` (half away from zero) for `d ≠ 0`; 0 for `d = 0`.
fn div_round(n: i128, d: i128) -> i128 {
    if d == 0 {
        return 0;
    }
    let (n, d) = if d < 0 { (-n, -d) } else { (n, d) };
    // `checked_div`: the operands are far inside i128 (< 2⁹³), but the optimiser cannot see
    // it; without it a division-overflow panic path stays in the image (issue 9).
    let q = |a: i128, b: i128| a.checked_div(b).unwrap_or(0);
    if n >= 0 { q(2 * n + d, 2 * d) } else { -q(-2 * n + d, 2 * d) }
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

/// `|D|` bound (Q16, 1024 grey levels) under which the covariance sums run in `i64` chunks and
/// the output in 32 × 32 → 64-bit products. Sane states are far below it (`|D| < 2²⁵`); a
/// chunk or frame beyond it takes the general path, with the same result.
const SMALL_DETAIL: u32 = 1 << 26;

/// Pixels per `i64` covariance chunk: 2¹¹ products below 2⁵² sum below 2⁶³.
const COV_CHUNK: usize = 1 << 11;

/// The detail `D = 2¹⁶·I − A` in `i32`: exact when `|D| < 2³¹`, otherwise wrapped to a value
/// of magnitude ≥ 2³¹ − 2²⁴ (still beyond [`SMALL_DETAIL`]).
#[inline(always)]
fn detail32(i: u8, a: i32) -> i32 {
    (i32::from(i) << STATE_BITS).wrapping_sub(a)
}

/// `[ΣD_IR, ΣD_VIS, ΣD_IR², ΣD_IR·D_VIS, ΣD_VIS²]` of one chunk, exactly.
type Moments = [i128; 5];

/// The moments of a chunk in `i64` (`None` when some `|D| ≥` [`SMALL_DETAIL`]).
#[inline(always)]
fn moments_small(iv: &[u8], it: &[u8], av: &[i32], at: &[i32]) -> Option<Moments> {
    let (mut s1, mut s2, mut s11, mut s12, mut s22) = (0i64, 0i64, 0i64, 0i64, 0i64);
    let mut bits = 0u32;
    for (((&iv, &it), &av), &at) in iv.iter().zip(it).zip(av).zip(at) {
        let (d1, d2) = (detail32(it, at), detail32(iv, av));
        bits |= d1.unsigned_abs() | d2.unsigned_abs();
        let (d1, d2) = (i64::from(d1), i64::from(d2));
        s1 += d1;
        s2 += d2;
        s11 += d1 * d1;
        s12 += d1 * d2;
        s22 += d2 * d2;
    }
    (bits < SMALL_DETAIL).then_some([s1, s2, s11, s12, s22].map(i128::from))
}

/// The moments of a chunk in `i128` (any state).
fn moments_exact(iv: &[u8], it: &[u8], av: &[i32], at: &[i32]) -> Moments {
    let mut m = [0i128; 5];
    for (((&iv, &it), &av), &at) in iv.iter().zip(it).zip(av).zip(at) {
        let d1 = (i128::from(it) << STATE_BITS) - i128::from(at);
        let d2 = (i128::from(iv) << STATE_BITS) - i128::from(av);
        for (s, v) in m.iter_mut().zip([d1, d2, d1 * d1, d1 * d2, d2 * d2]) {
            *s += v;
        }
    }
    m
}

/// The exact covariance sums of the detail layers `D = 2¹⁶·I − A` (Q16): `i64` chunk sums
/// while every `|D|` of a chunk is below [`SMALL_DETAIL`], `i128` otherwise. Integer sums, so
/// the order rows are added in (whole frame, strips) does not change them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Covariance {
    sums: Moments,
    /// Every chunk so far was small (the output may then use [`fused_small`]).
    small: bool,
}

impl Covariance {
    pub(crate) const fn new() -> Self {
        Self { sums: [0; 5], small: true }
    }

    /// Adds one row (or part of one): pixels and base layers of both bands.
    pub(crate) fn add_row(&mut self, iv: &[u8], it: &[u8], av: &[i32], at: &[i32]) {
        let chunks = iv
            .chunks(COV_CHUNK)
            .zip(it.chunks(COV_CHUNK))
            .zip(av.chunks(COV_CHUNK))
            .zip(at.chunks(COV_CHUNK));
        for (((iv, it), av), at) in chunks {
            let m = moments_small(iv, it, av, at).unwrap_or_else(|| {
                self.small = false;
                moments_exact(iv, it, av, at)
            });
            for (s, v) in self.sums.iter_mut().zip(m) {
                *s += v;
            }
        }
    }

    /// The KL weights of a frame of `pixels` pixels, from the rows added so far: every pixel of
    /// the frame not added must have zero detail (`fuse_adf_window` relies on that; the whole
    /// frame and the strips add every pixel).
    pub(crate) fn weights(&self, pixels: usize, variant: Variant) -> Fusion {
        let [s1, s2, s11, s12, s22] = self.sums;
        let n = pixels as i128;
        let kl = kl_weight(n * s11 - s1 * s1, n * s12 - s1 * s2, n * s22 - s2 * s2, variant);
        let p_ir = kl.p_ir_q30;
        Fusion { p_ir, p32: i32::try_from(p_ir).ok().filter(|_| self.small), guards: kl.guards }
    }
}

/// The frame's fusion rule once its covariance is known.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Fusion {
    p_ir: i64,
    /// `p_IR` for [`fused_small`] when every detail was small.
    p32: Option<i32>,
    /// The guards the KL weights fired.
    pub(crate) guards: Guards,
}

impl Fusion {
    /// One fused raw value (Q16).
    #[inline(always)]
    fn value(&self, iv: u8, it: u8, av: i32, at: i32) -> i32 {
        match self.p32 {
            Some(p) => fused_small(p, iv, it, av, at),
            None => fused_general(self.p_ir, iv, it, av, at),
        }
    }

    /// Fuses one row into raw Q16 values.
    #[inline]
    fn raw_row(&self, iv: &[u8], it: &[u8], av: &[i32], at: &[i32], out: &mut [i32]) {
        let pixels = out.iter_mut().zip(iv).zip(it).zip(av).zip(at);
        match self.p32 {
            // Every |D| < 2²⁶, so |A| < 2²⁷ and |p_IR| < 2³¹: the sum stays under 2⁵⁹, the
            // same value as the general form without any saturation.
            Some(p) => {
                for ((((o, &iv), &it), &av), &at) in pixels {
                    *o = fused_small(p, iv, it, av, at);
                }
            }
            None => {
                for ((((o, &iv), &it), &av), &at) in pixels {
                    *o = fused_general(self.p_ir, iv, it, av, at);
                }
            }
        }
    }

    /// Fuses one row into 8-bit values; `true` when some value saturated.
    pub(crate) fn u8_row(&self, iv: &[u8], it: &[u8], av: &[i32], at: &[i32], out: &mut [u8]) -> bool {
        let mut saturated = false;
        for ((((o, &iv), &it), &av), &at) in out.iter_mut().zip(iv).zip(it).zip(av).zip(at) {
            let v = self.value(iv, it, av, at);
            saturated |= raw_saturates(v);
            *o = raw_to_u8(v);
        }
        saturated
    }
}

/// Whether the 8-bit cast of a raw Q16 value saturates (it rounds outside `0..=255`).
#[inline(always)]
fn raw_saturates(v: i32) -> bool {
    !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&v)
}

/// The one code path: diffuse both bands, KL weights, then hand each fused raw row (Q16) to
/// `emit(y, row)`.
fn run(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    params: &AdfParams,
    scratch: &mut ScratchMut<'_>,
    mut emit: impl FnMut(usize, &[i32]),
) -> Result<Guards, Error> {
    params.validate()?;
    let (w, h) = vis.size();
    let [a_vis, a_tir, tmp] = scratch.planes(w * h)?;
    diffuse(vis, params, a_vis, tmp)?;
    diffuse(tir, params, a_tir, tmp)?;
    let rows =
        || vis.rows().zip(tir.rows()).zip(a_vis.chunks_exact(w.max(1))).zip(a_tir.chunks_exact(w.max(1)));
    let mut cov = Covariance::new();
    for (((iv, it), av), at) in rows() {
        cov.add_row(iv, it, av, at);
    }
    let fusion = cov.weights(w * h, params.variant);
    // F = ½(A_IR + A_VIS) + D_VIS + p_IR·(D_IR − D_VIS), in Q46, rounded to Q16.
    for (y, ((((iv, it), av), at), out)) in rows().zip(tmp.chunks_exact_mut(w.max(1))).enumerate() {
        fusion.raw_row(iv, it, av, at, out);
        emit(y, out);
    }
    Ok(fusion.guards)
}

/// Work words [`diffuse_pair_rows`] needs for `w`-wide frames: both bands' row pipelines
/// (`iterations · 3 · (w + 2)` each) and one output row each — independent of the height.
pub(crate) fn stream_words(w: usize, params: &AdfParams) -> usize {
    2 * (usize::from(params.iterations) * STAGE_ROWS * (w + 2) + w)
}

/// `work` cut into four consecutive slices of these lengths (`None` when it is too short).
fn split4(work: &mut [i32], [a, b, c, d]: [usize; 4]) -> Option<[&mut [i32]; 4]> {
    let (first, rest) = work.split_at_mut_checked(a)?;
    let (second, rest) = rest.split_at_mut_checked(b)?;
    let (third, rest) = rest.split_at_mut_checked(c)?;
    Some([first, second, third, rest.get_mut(..d)?])
}

/// Diffuses both bands together through one row pipeline each (all iterations in one group,
/// the streaming form of [`diffuse`], the same bits) and hands every row `y < until` of the
/// two base layers to `sink(y, A_VIS row, A_TIR row)`, top to bottom; rows from `until` on
/// are not finished (row `y` needs the input only up to row `y + iterations`). Memory: `work`,
/// [`stream_words`] words; no plane. The strip pipeline ([`crate::strips`]) runs it on windows.
pub(crate) fn diffuse_pair_rows(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    params: &AdfParams,
    work: &mut [i32],
    until: usize,
    mut sink: impl FnMut(usize, &[i32], &[i32]),
) -> Result<(), Error> {
    params.validate()?;
    check_sizes(&vis, &tir, vis.size())?;
    let (w, h) = vis.size();
    let stages = usize::from(params.iterations);
    let needed = stream_words(w, params);
    let capacity = work.len();
    let per_band = stages * STAGE_ROWS * (w + 2);
    let [mem_v, mem_t, row_v, row_t] =
        split4(work, [per_band, per_band, w, w]).ok_or(Error::ScratchTooSmall { needed, capacity })?;
    mem_v.fill(0);
    mem_t.fill(0);
    let diffusion = Diffusion::new(params);
    let (mut out_v, mut out_t) = (Output::Row(row_v), Output::Row(row_t));
    for t in 0..until.min(h) + stages {
        diffusion.pipeline_step(t, Input::Frame(vis), &mut out_v, mem_v, (w, h), stages);
        diffusion.pipeline_step(t, Input::Frame(tir), &mut out_t, mem_t, (w, h), stages);
        if let Some(y) = t.checked_sub(stages) {
            sink(y, out_v.row(y, w), out_t.row(y, w));
        }
    }
    Ok(())
}

/// One fused raw value (Q16): `F = ½(A_IR + A_VIS) + D_VIS + p_IR·(D_IR − D_VIS)` in Q46,
/// rounded half up to Q16, saturating (only pathological states or weights saturate).
#[inline(always)]
fn fused_general(p_ir: i64, iv: u8, it: u8, av: i32, at: i32) -> i32 {
    let d_ir = (i64::from(it) << STATE_BITS) - i64::from(at);
    let d_vis = (i64::from(iv) << STATE_BITS) - i64::from(av);
    let base = (i64::from(av) + i64::from(at)) << (WEIGHT_BITS - 1);
    let v = base
        .saturating_add(d_vis << WEIGHT_BITS)
        .saturating_add(p_ir.saturating_mul(d_ir - d_vis))
        .saturating_add(1 << (WEIGHT_BITS - 1));
    let q = v >> WEIGHT_BITS;
    q.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// [`fused_general`] when `|D| <` [`SMALL_DETAIL`] for both bands and `|p_IR| < 2³¹`: then
/// `|A| < 2²⁷`, the Q46 sum `(A_IR + A_VIS + 2·D_VIS + 1)·2²⁹ + p_IR·(D_IR − D_VIS)` stays
/// under 2⁵⁹ and nothing saturates (on Arm: one `smlal`).
#[inline(always)]
fn fused_small(p_ir: i32, iv: u8, it: u8, av: i32, at: i32) -> i32 {
    let (d_ir, d_vis) = (detail32(it, at), detail32(iv, av));
    let s = av + at + 2 * d_vis + 1;
    let v = (i64::from(s) << (WEIGHT_BITS - 1)) + i64::from(p_ir) * i64::from(d_ir - d_vis);
    (v >> WEIGHT_BITS) as i32
}

/// [`round_away_sat_u8`](super::round_away_sat_u8)`(raw, 16)` for an `i32` raw value, in `i32` arithmetic: for
/// `raw ≥ 0` it is `(raw + 2¹⁵) >> 16 = ((raw >> 1) + 2¹⁴) >> 15` (no overflow), saturated; a
/// negative raw value rounds to ≤ 0 either way and saturates to 0.
#[inline(always)]
fn raw_to_u8(raw: i32) -> u8 {
    (((raw >> 1) + (1 << 14)) >> 15).clamp(0, 255) as u8
}

/// Fuses a VIS/TIR pair with ADF into the 8-bit `out` (MATLAB `uint8` cast of the raw value).
///
/// All three frames must have the same size ([`Error::SizeMismatch`]); the scratch must hold
/// three planes of W·H ([`Error::ScratchTooSmall`]); bad parameters give
/// [`Error::InvalidParameter`]. Returns the guards fired (see the module docs).
pub fn fuse_adf(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    mut out: FrameMut<'_, u8>,
    params: &AdfParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    check_sizes(&vis, &tir, out.size())?;
    let mut saturated = false;
    let guards = run(vis, tir, params, scratch, |y, raw| {
        for (o, &v) in out.row_mut(y).iter_mut().zip(raw) {
            saturated |= raw_saturates(v);
            *o = raw_to_u8(v);
        }
    })?;
    Ok(if saturated { guards | Guards::OUTPUT_SATURATED } else { guards })
}

/// Fuses like [`fuse_adf`] but writes the real-valued result before the 8-bit cast, in Q16
/// ([`RAW_FRAC_BITS`]; `raw / 65536.0` grey levels). [`fuse_adf`] is this value cast with
/// [`round_away_sat_u8`](super::round_away_sat_u8)`(raw, 16)`.
pub fn fuse_adf_raw(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    mut raw: FrameMut<'_, i32>,
    params: &AdfParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    check_sizes(&vis, &tir, raw.size())?;
    run(vis, tir, params, scratch, |y, row| {
        for (o, &v) in raw.row_mut(y).iter_mut().zip(row) {
            *o = v;
        }
    })
}

/// ADF of a whole frame computed on a window of it, for the pipeline's scene skipping
/// ([`crate::pipeline::SkipPolicy`]).
///
/// `vis` and `tir` are the window `C` of the frame pair (`vis = None`: VIS is the constant
/// `vis_level` everywhere, the eclipse plan) and `out` the same window of the output. The
/// caller guarantees that outside the sub-window `exact` (coordinates inside `C`) the frame's
/// detail layers are exactly zero — every input pixel within `iterations` of such a pixel
/// equals its band's constant level, and (classic) that level is 0 — and that `exact` lies at
/// least `iterations` pixels inside `C` on every side not on the frame's edge. Then the
/// frame-global covariance is the sum over `exact` with `n = frame_pixels` (the rest adds 0),
/// the KL weights are the whole frame's, and the pixels of `exact` written to `out` are the
/// whole-frame result bit for bit; the rest of `out` is not written. Returns the guards the
/// whole frame would fire ([`Guards::OUTPUT_SATURATED`] for the `exact` pixels only).
///
/// Errors: as [`fuse_adf`], [`Error::InvalidParameter`] (`"rect"`) when `exact` is not inside
/// the window or `frame_pixels` is smaller than the window, (`"vis_level"`) for a non-zero
/// constant VIS with the classic (zero-padded) variant.
#[allow(clippy::too_many_arguments)]
pub fn fuse_adf_window(
    vis: Option<FrameRef<'_, u8>>,
    vis_level: u8,
    tir: FrameRef<'_, u8>,
    mut out: FrameMut<'_, u8>,
    exact: crate::scene::Rect,
    frame_pixels: usize,
    params: &AdfParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    params.validate()?;
    if let Some(v) = &vis {
        check_sizes(v, &tir, out.size())?;
    } else if out.size() != tir.size() {
        return Err(Error::SizeMismatch { expected: tir.size(), got: out.size() });
    }
    let (w, h) = tir.size();
    if exact.is_empty() || !crate::scene::Rect::full((w, h)).covers(&exact) || frame_pixels < w * h {
        return Err(Error::InvalidParameter { name: "rect" });
    }
    if vis.is_none() && vis_level != 0 && params.variant == Variant::Classic {
        return Err(Error::InvalidParameter { name: "vis_level" });
    }
    let [a_vis, a_tir, tmp] = scratch.planes(w * h)?;
    diffuse(tir, params, a_tir, tmp)?;
    match vis {
        Some(v) => diffuse(v, params, a_vis, tmp)?,
        // A constant frame stays constant under the replicate-border diffusion (every ∇ = 0),
        // and under the zero border when the constant is 0.
        None => a_vis.get_mut(..w * h).unwrap_or(&mut []).fill(i32::from(vis_level) << STATE_BITS),
    }
    let (a_vis, a_tir) = (&*a_vis, &*a_tir);
    let level_row = [vis_level; COV_CHUNK];
    let (ex0, ex1) = (exact.x0, exact.x1);
    // The rows of `exact`: (VIS pixels, TIR pixels, A_VIS, A_TIR), cut to its columns.
    let rows = || {
        (exact.y0..exact.y1).map(move |y| {
            let iv = vis.map(|v| v.row(y).get(ex0..ex1).unwrap_or(&[]));
            let it = tir.row(y).get(ex0..ex1).unwrap_or(&[]);
            let av = a_vis.get(y * w + ex0..y * w + ex1).unwrap_or(&[]);
            let at = a_tir.get(y * w + ex0..y * w + ex1).unwrap_or(&[]);
            (iv, it, av, at)
        })
    };
    let mut cov = Covariance::new();
    for (iv, it, av, at) in rows() {
        let mut x = 0;
        while x < it.len() {
            let n = COV_CHUNK.min(it.len() - x);
            let iv = iv.map_or(level_row.get(..n), |r| r.get(x..x + n)).unwrap_or(&[]);
            let (av, at) = (av.get(x..x + n).unwrap_or(&[]), at.get(x..x + n).unwrap_or(&[]));
            cov.add_row(iv, it.get(x..x + n).unwrap_or(&[]), av, at);
            x += n;
        }
    }
    let fusion = cov.weights(frame_pixels, params.variant);
    let mut saturated = false;
    for (y, (iv, it, av, at)) in (exact.y0..).zip(rows()) {
        let dst = out.row_mut(y).get_mut(ex0..ex1).unwrap_or(&mut []);
        saturated |= match iv {
            Some(iv) => fusion.u8_row(iv, it, av, at, dst),
            // VIS is the constant level: the rows of `level_row`, a chunk at a time.
            None => {
                let parts = dst.chunks_mut(COV_CHUNK).zip(it.chunks(COV_CHUNK)).zip(av.chunks(COV_CHUNK));
                parts.zip(at.chunks(COV_CHUNK)).fold(false, |sat, (((d, it), av), at)| {
                    sat | fusion.u8_row(level_row.get(..d.len()).unwrap_or(&[]), it, av, at, d)
                })
            }
        };
    }
    Ok(if saturated { fusion.guards | Guards::OUTPUT_SATURATED } else { fusion.guards })
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::super::round_away_sat_u8;
    use super::*;

    #[test]
    fn const_exp_matches_libm() {
        for i in 0..=2000 {
            let x = f64::from(i) / 100.0;
            let want = libm::exp(-x);
            assert!((exp_neg(x) - want).abs() <= 1e-14 * want.max(1e-300) + 1e-300, "x = {x}");
        }
    }

    /// The flux error as the core sees it: for every Q16 difference on a fine grid, both
    /// signs, the table's `g` against `t·exp(−t²)`, `t = ∇/κ`.
    #[test]
    fn flux_table_error_is_within_its_bound() {
        let d = Diffusion::new(&AdfParams::default());
        let mut max_err = 0.0f64;
        for dq in (-(200 << 16)..(200 << 16)).step_by(97) {
            let got = f64::from(d.flux(dq)) / 65536.0;
            let t = f64::from(dq) / 65536.0 / 30.0;
            let want = t * libm::exp(-t * t);
            max_err = max_err.max((got - want).abs());
        }
        std::println!(
            "flux table: max |g_table − t·exp(−t²)| = {max_err:.3e} (= {:.4} grey levels per flux at κ = 30)",
            30.0 * max_err
        );
        // Index rounding: ≤ 1 · 2⁻¹² = 2.44e-4; entries: 2⁻¹⁷; the multiplier's rounding < 0.01 step.
        assert!(max_err < 2.9e-4, "max flux error {max_err:e}");
        assert!(max_err > 1e-5, "the bound should be nearly reached: {max_err:e}");
    }

    /// The flux written out in `i64` (the rounded product's floor, the clamp, the unsigned
    /// table with the index's sign): the fast forms must give the same value.
    fn flux_first_form(kappa: u16, d: i32) -> i32 {
        let kappa = i64::from(kappa);
        let m = ((1i64 << 27) + kappa / 2) / kappa;
        let idx =
            (i64::from(d) * m + (1 << 31)).div_euclid(1 << 32).clamp(-(LUT_LEN as i64), i64::from(LUT_LAST));
        let g = EXP_FLUX.get(idx.unsigned_abs() as usize).map_or(0, |&g| i32::from(g));
        if idx < 0 { -g } else { g }
    }

    /// Every κ, both sides of every index step (the first `∇` of each index and its
    /// neighbours, up to past the clamp on both sides — the flux is constant between them),
    /// the extremes; on x86-64 also the AVX2 flux, lane by lane.
    #[test]
    fn fast_flux_equals_the_first_form_exhaustively() {
        for kappa in 1..=255u16 {
            let d = Diffusion::new(&AdfParams { kappa, ..AdfParams::default() });
            let m = i64::from(d.index_mul);
            let mut values = std::vec![i32::MIN, i32::MIN + 1, i32::MAX, 0, -1, 1];
            for k in -(LUT_LEN as i64) - 2..=LUT_LEN as i64 + 2 {
                // The smallest ∇ with index ≥ k: ⌈(k·2³² − 2³¹)/m⌉.
                let first = ((k << 32) - (1 << 31) + m - 1).div_euclid(m);
                for x in [first - 1, first, first + 1] {
                    values.push(x.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32);
                }
            }
            for &x in &values {
                assert_eq!(d.flux(x), flux_first_form(kappa, x), "kappa {kappa} d {x}");
            }
            #[cfg(target_arch = "x86_64")]
            if crate::cpu::has_avx2() {
                for block in values.chunks(8) {
                    let mut lanes = [0i32; 8];
                    lanes.iter_mut().zip(block).for_each(|(l, &v)| *l = v);
                    // SAFETY: the CPU has AVX2 (checked above).
                    let (got, _) = unsafe { avx2::flux8(&d, lanes) };
                    let want = lanes.map(|x| d.flux(x));
                    assert_eq!(got, want, "kappa {kappa} lanes {lanes:?}");
                }
            }
        }
    }

    /// The update is `⌊(Σ·scale + 2¹⁵)/2¹⁶⌋` (κΔt/2 in Q16, rounded half up) for every
    /// reachable sum and the extreme parameters; on x86-64 the AVX2 step too.
    #[test]
    fn step_is_the_rounded_product_for_every_sum() {
        for (kappa, dt_milli) in [(30u16, 150u16), (1, 1), (255, 250), (255, 249), (7, 133), (200, 100)] {
            let d = Diffusion::new(&AdfParams { kappa, dt_milli, ..AdfParams::default() });
            let scale = (((i64::from(kappa) * i64::from(dt_milli)) << 16) + 1000) / 2000;
            let bound = 12 * MAX_FLUX;
            let sums: std::vec::Vec<i32> =
                (-bound..=bound).step_by(7).chain([bound, -bound, 0, 1, -1]).collect();
            for &acc in &sums {
                let want = ((i64::from(acc) * scale + (1 << 15)) >> 16) as i32;
                assert_eq!(d.step(acc), want, "kappa {kappa} dt {dt_milli} acc {acc}");
            }
            #[cfg(target_arch = "x86_64")]
            if crate::cpu::has_avx2() {
                for block in sums.chunks_exact(8) {
                    let lanes: [i32; 8] = block.try_into().unwrap_or([0; 8]);
                    // SAFETY: the CPU has AVX2 (checked above).
                    let (_, got) = unsafe { avx2::flux8(&d, lanes) };
                    assert_eq!(got, lanes.map(|a| d.step(a)), "kappa {kappa} dt {dt_milli}");
                }
            }
        }
    }

    fn noise(n: usize, seed: u32, levels: u32) -> std::vec::Vec<u8> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(1664525).wrapping_add(1013904223);
                ((s >> 24) % levels) as u8 * (255 / (levels - 1).max(1)) as u8
            })
            .collect()
    }

    /// The row pipeline (pair fluxes, grouped iterations) against plain Jacobi sweeps with all
    /// eight fluxes per pixel, bit for bit: sizes from one row to one column, both borders,
    /// one group and several groups, parameters with the `i64` step.
    #[test]
    fn row_pipeline_equals_plain_sweeps() -> Result<(), Error> {
        let sizes = [
            (1usize, 6usize),
            (6, 1),
            (7, 2),
            (5, 6),
            (1, 60),
            (2, 40),
            (3, 50),
            (17, 9),
            (31, 40),
            (64, 23),
        ];
        let params = [
            AdfParams::default(),
            AdfParams { iterations: 7, dt_milli: 250, kappa: 5, ..AdfParams::default() },
            AdfParams { iterations: 23, dt_milli: 100, kappa: 200, ..AdfParams::default() },
            AdfParams { iterations: 3, dt_milli: 250, kappa: 255, ..AdfParams::default() },
            AdfParams { iterations: 2, dt_milli: 1, kappa: 1, ..AdfParams::default() },
        ];
        for (k, &(w, h)) in sizes.iter().enumerate() {
            for levels in [2u32, 256] {
                let src = noise(w * h, 7 + k as u32, levels);
                let frame = FrameRef::new(&src, w, h)?;
                for p in params {
                    for variant in [Variant::Classic, Variant::Flight] {
                        let p = AdfParams { variant, ..p };
                        let d = Diffusion::new(&p);
                        let (mut want, mut tmp) = (std::vec![0i32; w * h], std::vec![0i32; w * h]);
                        diffuse_sweeps(frame, &d, p.iterations, &mut want, &mut tmp, w);
                        let mut got = std::vec![0i32; w * h];
                        diffuse(frame, &p, &mut got, &mut tmp)?;
                        assert_eq!(got, want, "{w}x{h} {p:?}");
                    }
                }
            }
        }
        Ok(())
    }

    /// The AVX2 row loop against the portable one on random rows: typical Q16 states, huge
    /// values (saturating updates, wrapped differences, `i32::MIN`), every κ class, widths
    /// around the block size.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_rows_equal_the_portable_rows() {
        if !crate::cpu::has_avx2() {
            return;
        }
        let mut seed = 99u32;
        let mut next = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            seed
        };
        for kappa in [1u16, 2, 7, 30, 100, 255] {
            for dt_milli in [1u16, 150, 250] {
                let params = AdfParams { kappa, dt_milli, ..AdfParams::default() };
                let mut d = Diffusion::new(&params);
                for w in [1usize, 7, 8, 9, 16, 23, 64] {
                    for scale in [0u32, 1, 2] {
                        let mut value = || match scale {
                            0 => (next() >> 8) as i32 & ((1 << 24) - 1),
                            1 => (next() >> 12) as i32 - (1 << 19),
                            _ => [i32::MIN, i32::MAX, next() as i32, 0][(next() >> 30) as usize],
                        };
                        let p: std::vec::Vec<i32> = (0..w + 2).map(|_| value()).collect();
                        let q: std::vec::Vec<i32> = (0..w + 2).map(|_| value()).collect();
                        let north: std::vec::Vec<i32> =
                            (0..w + 2).map(|_| (next() >> 13) as i32 - (1 << 18)).collect();
                        let mut results = [(std::vec![], std::vec![]), (std::vec![], std::vec![])];
                        for (avx2, r) in [false, true].into_iter().zip(results.iter_mut()) {
                            d.avx2 = avx2;
                            let (mut n, mut o) = (north.clone(), std::vec![0i32; w]);
                            d.row(&p, &q, &mut n, &mut o);
                            *r = (n, o);
                        }
                        assert_eq!(results[0], results[1], "kappa {kappa} dt {dt_milli} w {w} scale {scale}");
                    }
                }
            }
        }
    }

    #[test]
    fn raw_to_u8_is_the_matlab_cast() {
        let mut v = i32::MIN;
        loop {
            assert_eq!(raw_to_u8(v), round_away_sat_u8(i64::from(v), RAW_FRAC_BITS), "{v}");
            match v.checked_add(4093) {
                Some(n) => v = n,
                None => break,
            }
        }
        for v in
            [i32::MAX, i32::MAX - 1, -1, 0, 1, (1 << 15) - 1, 1 << 15, 255 << 16, (255 << 16) + (1 << 15)]
        {
            assert_eq!(raw_to_u8(v), round_away_sat_u8(i64::from(v), RAW_FRAC_BITS), "{v}");
        }
    }

    /// The chunked `i64` moments against the `i128` ones, and their refusal of large details.
    #[test]
    fn small_moments_equal_exact_moments() {
        let iv = noise(300, 5, 256);
        let it = noise(300, 6, 256);
        let mut s = 17u32;
        let mut state = |i: &u8| {
            s = s.wrapping_mul(1664525).wrapping_add(1013904223);
            (i32::from(*i) << 16) + (s >> 7) as i32 % (1 << 25)
        };
        let av: std::vec::Vec<i32> = iv.iter().map(&mut state).collect();
        let at: std::vec::Vec<i32> = it.iter().map(&mut state).collect();
        assert_eq!(moments_small(&iv, &it, &av, &at), Some(moments_exact(&iv, &it, &av, &at)));
        for bad in [i32::MIN, i32::MAX, -(1 << 26), (255 << 16) + (1 << 26)] {
            let mut at = at.clone();
            at[7] = bad;
            assert_eq!(moments_small(&iv, &it, &av, &at), None, "{bad}");
        }
    }

    #[test]
    fn small_fusion_equals_general_fusion() {
        let mut s = 3u32;
        let mut next = || {
            s = s.wrapping_mul(1664525).wrapping_add(1013904223);
            s
        };
        for k in 0..200_000 {
            let (iv, it) = ((next() >> 24) as u8, (next() >> 24) as u8);
            let d = |r: u32| (r >> 5) as i32 - (1 << 26) + 1; // |D| < 2²⁶
            let (av, at) = ((i32::from(iv) << 16) - d(next()), (i32::from(it) << 16) - d(next()));
            let p = match k % 4 {
                0 => (next() >> 1) as i32,
                1 => -((next() >> 1) as i32),
                2 => [i32::MAX, i32::MIN + 1, 0, 1 << 30][(next() >> 30) as usize],
                _ => (next() >> 1) as i32 >> (next() >> 27),
            };
            assert_eq!(fused_small(p, iv, it, av, at), fused_general(i64::from(p), iv, it, av, at));
        }
    }

    /// Nearly odd: `flux(−∇)` is at most one table step from `−flux(∇)` (the orientation
    /// rule of the pair fluxes is what makes the forms agree, not oddness); 0 beyond 4κ.
    #[test]
    fn flux_is_nearly_odd_and_zero_far_away() {
        let d = Diffusion::new(&AdfParams::default());
        let step = EXP_FLUX.windows(2).map(|w| (i32::from(w[1]) - i32::from(w[0])).abs()).max().unwrap_or(0);
        for dq in (0..(125 << 16)).step_by(61) {
            assert!((d.flux(dq) + d.flux(-dq)).abs() <= step, "{dq}");
        }
        assert_eq!(d.flux(1 << 16), -d.flux(-(1 << 16)), "exact away from a rounding tie");
        for dq in [121 << 16, -(121 << 16), i32::MIN, i32::MAX, i32::MIN + 1] {
            assert_eq!(d.flux(dq), 0, "beyond 4κ the conduction is 0: {dq}");
        }
    }

    fn f64_weight(a: f64, b: f64, c: f64) -> f64 {
        let theta = 0.5 * libm::atan2(2.0 * b, a - c);
        let (v1, v2) = (libm::cos(theta), libm::sin(theta));
        v1 / (v1 + v2)
    }

    #[test]
    fn kl_weights_against_the_closed_form() {
        let one = (1i64 << 30) as f64;
        for (a, b, c) in [
            (5i128, 2i128, 3i128),
            (1, 0, 4),
            (4, 0, 1),
            (100, 99, 100),
            (7, 3, 7),
            (1 << 90, 1 << 88, 1 << 89),
        ] {
            for variant in [Variant::Classic, Variant::Flight] {
                let w = kl_weight(a, b, c, variant);
                let want = f64_weight(a as f64, b as f64, c as f64);
                assert!(
                    (w.p_ir_q30 as f64 / one - want).abs() < 1e-8,
                    "{a} {b} {c}: {} vs {want}",
                    w.p_ir_q30 as f64 / one
                );
                assert_eq!(w.guards, Guards::NONE);
            }
        }
    }

    #[test]
    fn kl_weight_guards() {
        let one = 1i64 << 30;
        // Zero covariance: MATLAB's eig gives the identity, first column → p_IR = 1 (classic);
        // flight ½.
        let z = kl_weight(0, 0, 0, Variant::Classic);
        assert_eq!(z.p_ir_q30, one);
        assert!(z.guards.contains(Guards::ADF_ZERO_COVARIANCE));
        assert_eq!(kl_weight(0, 0, 0, Variant::Flight).p_ir_q30, one / 2);
        // Equal variances, negatively correlated: v = (1, −1), v₁ + v₂ = 0.
        let n = kl_weight(9, -4, 9, Variant::Classic);
        assert_eq!(n.p_ir_q30, one / 2);
        assert!(n.guards.contains(Guards::ADF_DEGENERATE_EIGENVECTOR));
        let nf = kl_weight(9, -4, 9, Variant::Flight);
        assert_eq!(nf.p_ir_q30, one / 2);
        assert!(nf.guards.contains(Guards::ADF_WEIGHT_CLAMPED.with(Guards::ADF_DEGENERATE_EIGENVECTOR)));
        // Negatively correlated, unequal variances: published weights leave [0, 1].
        let c = kl_weight(9, -4, 3, Variant::Classic);
        let want = f64_weight(9.0, -4.0, 3.0);
        assert!(!(0.0..=1.0).contains(&want));
        assert!((c.p_ir_q30 as f64 / one as f64 - want).abs() < 1e-8);
        let f = kl_weight(9, -4, 3, Variant::Flight);
        assert!((0..=one).contains(&f.p_ir_q30));
        assert!(f.guards.contains(Guards::ADF_WEIGHT_CLAMPED));
        // Nearly degenerate: classic weights saturate at ±128.
        let s = kl_weight(1 << 40, -(1 << 40) + 1, (1 << 40) + 3, Variant::Classic);
        assert!(s.p_ir_q30.abs() <= 128 * one);
    }

    #[test]
    fn isqrt_is_exact() {
        for n in [0u128, 1, 2, 3, 4, 15, 16, 17, u128::from(u64::MAX), (1 << 125) - 1, 1 << 124] {
            let r = isqrt_u128(n);
            assert!(r * r <= n && (r + 1) * (r + 1) > n, "{n}");
        }
    }

    #[test]
    fn params_are_validated() {
        let bad = [
            (AdfParams { iterations: 0, ..AdfParams::default() }, "iterations"),
            (AdfParams { dt_milli: 251, ..AdfParams::default() }, "dt_milli"),
            (AdfParams { kappa: 0, ..AdfParams::default() }, "kappa"),
        ];
        for (p, name) in bad {
            assert_eq!(p.validate(), Err(Error::InvalidParameter { name }));
        }
        assert_eq!(AdfParams::default().validate(), Ok(()));
    }

    /// One iteration on a 1×1 frame, by hand: the 8 neighbours are outside (zero padding),
    /// so `u ← u − Δt·6·u·exp(−(u/κ)²)`.
    #[test]
    fn one_pixel_one_iteration_by_hand() -> Result<(), Error> {
        let params = AdfParams { variant: Variant::Classic, iterations: 1, ..AdfParams::default() };
        for v in [0u8, 10, 30, 60, 255] {
            let src = [v];
            let mut state = [0i32; 1];
            let mut tmp = [0i32; 1];
            diffuse(FrameRef::new(&src, 1, 1)?, &params, &mut state, &mut tmp)?;
            let u = f64::from(v);
            let want = u - 0.15 * 6.0 * u * libm::exp(-(u / 30.0) * (u / 30.0));
            let got = f64::from(state[0]) / 65536.0;
            // Bound: Δt · 6 neighbour weights · 0.008 levels per flux.
            assert!((got - want).abs() < 0.15 * 6.0 * 0.008, "{v}: {got} vs {want}");
        }
        Ok(())
    }
}
