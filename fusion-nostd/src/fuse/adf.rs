//! ADF — anisotropic diffusion + Karhunen–Loève fusion (Bavirisetti & Dhuli, IEEE Sensors J.
//! 16(1), 2016), integer core. Spec: `shared/reference/fusion-algorithms.md`, ADF.
//!
//! # Steps and number formats
//!
//! | quantity | type | format | range / saturation |
//! |---|---|---|---|
//! | diffusion state `A_k` (base layer) | `i32` | Q16 grey levels | within ≈ [−1, 256] levels (< 2²⁵) for the published parameters |
//! | neighbour difference `∇` | `i32` | Q16 | \|∇\| < 2²⁵ |
//! | normalised flux `g = c·∇/κ = t·exp(−t²)`, `t = \|∇\|/κ` | `u16` → `i32` | Q16, from [`EXP_FLUX`] | \|g\| ≤ 28109 |
//! | per-pixel sum `2·Σ_axial g + Σ_diag g` | `i32` | Q16 | < 2¹⁹ |
//! | `κ·Δt/2` | `i64` | Q16 | ≤ 2²¹ |
//! | update `(Σ · κΔt/2) >> 16` | `i64` → `i32` | Q16 | state add saturates at the `i32` range (unreachable for sane parameters) |
//! | detail layer `D_k = 2¹⁶·I_k − A_k` | `i64` | Q16 | \|D\| < 2²⁵ |
//! | covariance sums | `i128` | Q32 | exact |
//! | KL weight `p_IR` (`p_VIS = 1 − p_IR`) | `i64` | Q30 | classic: saturated to ±128; flight: [0, 1] |
//! | fused raw value [`fuse_adf_raw`] | `i32` | Q16 ([`RAW_FRAC_BITS`]) | saturated to the `i32` range (only reachable with classic weights ≫ 1) |
//!
//! **Conduction table.** The flux `c·∇ = ∇·exp(−(∇/κ)²) = κ·g(t)` with `g(t) = t·exp(−t²)`,
//! `t = |∇|/κ`, is read from the static table [`EXP_FLUX`] (8193 `u16` entries, step 1/2048
//! in `t`, built at compile time by a `const fn` exp; 16 KiB of flash); beyond `t = 4`
//! (g < 5·10⁻⁷) the flux is 0. The index is `round(2048·|∇|/κ)`, one multiply by a
//! reciprocal computed once per call, in `u32` (see `Diffusion`). Error of `g` against
//! `t·exp(−t²)`: ≤ 2.4·10⁻⁴ (index rounding: slope ≤ 1 · half a step) + 7.6·10⁻⁶ (Q16
//! entries) + the index arithmetic's truncation, measured 2.6·10⁻⁴, i.e. ≤ 0.008 grey levels
//! per neighbour flux at κ = 30 (unit test `flux_table_error_is_within_its_bound`).
//!
//! **Update** (Jacobi, one iterate in, the next out):
//! `A ← A + round(κΔt/2 · (2·Σ_axial g + Σ_diagonal g))`, i.e. the published
//! `Δt·(Σ_axial c∇ + ½Σ_diagonal c∇)`.
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
//! Three `i32` planes of W·H: the two diffusion states and the Jacobi ping-pong plane (which
//! then holds the raw output rows).

use super::{Guards, Variant, round_away_sat_u8};
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
/// so one table serves every κ and Δt. Maximum entry 28109 (g(1/√2) = 0.4289).
pub static EXP_FLUX: [u16; LUT_LEN + 1] = build_lut();

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

/// Per-call constants of the diffusion.
#[derive(Debug, Clone, Copy)]
struct Diffusion {
    /// `|∇|` (Q16) is clamped to `limit` (where the table index reaches its final 0 entry)…
    limit: u32,
    /// … shifted right by `shift` = 1 + bit length of κ …
    shift: u32,
    /// … and multiplied by `recip = round(2^(11+shift)/κ)` (4096 ≤ recip < 8192): the table
    /// index is `((|∇| >> shift)·recip + 2¹⁵) >> 16` = `round(2048·|∇|/κ)`, all in `u32`
    /// (the product stays below 2³⁰).
    recip: u32,
    /// `κ·Δt/2` in Q16 (147456 = 2.25 exactly for the published κ = 30, Δt = 0.15).
    scale: i64,
    border: Border,
}

impl Diffusion {
    fn new(params: &AdfParams) -> Self {
        let kappa = u32::from(params.kappa.max(1));
        let shift = 1 + (32 - kappa.leading_zeros());
        let recip = ((1u32 << (11 + shift)) + kappa / 2) / kappa;
        let limit = (4 * kappa + 1) << 16;
        // κ·Δt/2 = κ·dt_milli/2000, in Q16, rounded.
        let scale = (((i64::from(params.kappa) * i64::from(params.dt_milli)) << 16) + 1000) / 2000;
        Self { limit, shift, recip, scale, border: params.border() }
    }

    /// `g(|∇|/κ)·sign(∇)` in Q16 for `∇` in Q16 (the flux divided by κ).
    #[inline(always)]
    fn flux(&self, d: i32) -> i32 {
        let a = d.unsigned_abs().min(self.limit) >> self.shift;
        let idx = ((a * self.recip + (1 << 15)) >> 16).min(LUT_LEN as u32) as usize;
        let g = EXP_FLUX.get(idx).map_or(0, |&g| i32::from(g));
        if d < 0 { -g } else { g }
    }

    /// The next iterate of one pixel from its 3×3 neighbourhood.
    #[inline(always)]
    fn update(&self, [l, c, r]: Neighbourhood<i32>) -> i32 {
        let centre = c[1];
        let f = |v: i32| self.flux(v.wrapping_sub(centre));
        let axial = f(c[0]) + f(c[2]) + f(l[1]) + f(r[1]);
        let diagonal = f(l[0]) + f(l[2]) + f(r[0]) + f(r[2]);
        let acc = i64::from(2 * axial + diagonal); // |acc| ≤ 12·28109 < 2¹⁹
        // Q16 · Q16 → Q32; back to Q16 with rounding (half up).
        let step = (acc * self.scale + (1 << 15)) >> 16;
        centre.saturating_add(step as i32)
    }

    /// One Jacobi iteration of the packed `w`-wide plane `src` into `dst`.
    fn iterate(&self, src: &[i32], dst: &mut [i32], w: usize) {
        let h = src.len() / w.max(1);
        for (y, out) in dst.chunks_exact_mut(w).enumerate() {
            let row = |yy: usize| src.get(yy * w..yy * w + w);
            let Some(mid) = row(y) else { return };
            let (up, down) = match self.border {
                Border::Replicate => (row(y.saturating_sub(1)), row((y + 1).min(h - 1))),
                _ => (y.checked_sub(1).and_then(row), row(y + 1)),
            };
            diffuse_row(self, up, mid, down, out);
        }
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

#[inline(always)]
fn diffuse_row_kernel(d: &Diffusion, up: Option<&[i32]>, mid: &[i32], down: Option<&[i32]>, out: &mut [i32]) {
    map_neighbourhoods_op(up, mid, down, d.border, out.iter_mut(), Update(d));
}

crate::cpu::dispatch! {
    /// One row of a Jacobi iteration.
    fn diffuse_row(d: &Diffusion, up: Option<&[i32]>, mid: &[i32], down: Option<&[i32]>, out: &mut [i32]) => diffuse_row_kernel
}

/// Diffuses `src` (u8) with `params.iterations` Perona–Malik steps into `state` (Q16,
/// packed `w × h`), using `tmp` as the Jacobi ping-pong plane. Both planes hold at least
/// `w·h` elements. This is step 1 of ADF (the base layer), public for tests and benches.
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
    for (row, dst) in src.rows().zip(state.chunks_exact_mut(w)) {
        for (d, &v) in dst.iter_mut().zip(row) {
            *d = i32::from(v) << STATE_BITS;
        }
    }
    let diffusion = Diffusion::new(params);
    for i in 0..params.iterations {
        if i % 2 == 0 {
            diffusion.iterate(state, tmp, w);
        } else {
            diffusion.iterate(tmp, state, w);
        }
    }
    if !params.iterations.is_multiple_of(2) {
        for (s, t) in state.iter_mut().zip(tmp.iter()) {
            *s = *t;
        }
    }
    Ok(())
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
        let y = (x + n / x) / 2;
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
                div_round((v1 << WEIGHT_BITS).clamp(-limit * sum.abs(), limit * sum.abs()), sum)
                    .clamp(-limit, limit) as i64
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
    if n >= 0 { (2 * n + d) / (2 * d) } else { -((-2 * n + d) / (2 * d)) }
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

    // Covariance of the detail layers D = 2¹⁶·I − A (Q16), exact in i128.
    let (mut s1, mut s2, mut s11, mut s12, mut s22) = (0i128, 0i128, 0i128, 0i128, 0i128);
    for (((iv, it), av), at) in
        vis.rows().zip(tir.rows()).zip(a_vis.chunks_exact(w)).zip(a_tir.chunks_exact(w))
    {
        // Row sums (|D| < 2³³ even for a saturated state; a row ≤ 2¹⁴ pixels: Σ < 2⁴⁷).
        let (mut r1, mut r2, mut r11, mut r12, mut r22) = (0i64, 0i64, 0i128, 0i128, 0i128);
        for (((&iv, &it), &av), &at) in iv.iter().zip(it).zip(av).zip(at) {
            let d_ir = (i64::from(it) << STATE_BITS) - i64::from(at);
            let d_vis = (i64::from(iv) << STATE_BITS) - i64::from(av);
            r1 += d_ir;
            r2 += d_vis;
            let (d1, d2) = (i128::from(d_ir), i128::from(d_vis));
            r11 += d1 * d1;
            r12 += d1 * d2;
            r22 += d2 * d2;
        }
        s1 += i128::from(r1);
        s2 += i128::from(r2);
        s11 += r11;
        s12 += r12;
        s22 += r22;
    }
    let n = (w * h) as i128;
    let a = n * s11 - s1 * s1;
    let b = n * s12 - s1 * s2;
    let c = n * s22 - s2 * s2;
    let weights = kl_weight(a, b, c, params.variant);
    let p_ir = weights.p_ir_q30;

    // F = ½(A_IR + A_VIS) + D_VIS + p_IR·(D_IR − D_VIS), in Q46, rounded to Q16.
    for (y, ((((iv, it), av), at), out)) in vis
        .rows()
        .zip(tir.rows())
        .zip(a_vis.chunks_exact(w))
        .zip(a_tir.chunks_exact(w))
        .zip(tmp.chunks_exact_mut(w))
        .enumerate()
    {
        for ((((o, &iv), &it), &av), &at) in out.iter_mut().zip(iv).zip(it).zip(av).zip(at) {
            let d_ir = (i64::from(it) << STATE_BITS) - i64::from(at);
            let d_vis = (i64::from(iv) << STATE_BITS) - i64::from(av);
            let base = (i64::from(av) + i64::from(at)) << (WEIGHT_BITS - 1);
            // |p_IR| ≤ 2³⁷ and |D| < 2²⁵ on any sane state: no saturation; saturating ops
            // only keep pathological parameter choices from overflowing.
            let v = base
                .saturating_add(d_vis << WEIGHT_BITS)
                .saturating_add(p_ir.saturating_mul(d_ir - d_vis))
                .saturating_add(1 << (WEIGHT_BITS - 1));
            let q = v >> WEIGHT_BITS;
            *o = q.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        }
        emit(y, out);
    }
    Ok(weights.guards)
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
            saturated |= !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&v);
            *o = round_away_sat_u8(i64::from(v), RAW_FRAC_BITS);
        }
    })?;
    Ok(if saturated { guards | Guards::OUTPUT_SATURATED } else { guards })
}

/// Fuses like [`fuse_adf`] but writes the real-valued result before the 8-bit cast, in Q16
/// ([`RAW_FRAC_BITS`]; `raw / 65536.0` grey levels). [`fuse_adf`] is this value cast with
/// [`round_away_sat_u8`]`(raw, 16)`.
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

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    #[test]
    fn const_exp_matches_libm() {
        for i in 0..=2000 {
            let x = f64::from(i) / 100.0;
            let want = libm::exp(-x);
            assert!((exp_neg(x) - want).abs() <= 1e-14 * want.max(1e-300) + 1e-300, "x = {x}");
        }
    }

    /// The flux error as the core sees it: for every Q16 difference on a fine grid, the
    /// table's `g` against `t·exp(−t²)`, `t = ∇/κ`.
    #[test]
    fn flux_table_error_is_within_its_bound() {
        let d = Diffusion::new(&AdfParams::default());
        let mut max_err = 0.0f64;
        for dq in (0..(200 << 16)).step_by(97) {
            let got = f64::from(d.flux(dq)) / 65536.0;
            let t = f64::from(dq) / 65536.0 / 30.0;
            let want = t * libm::exp(-t * t);
            max_err = max_err.max((got - want).abs());
        }
        std::println!(
            "flux table: max |g_table − t·exp(−t²)| = {max_err:.3e} (= {:.4} grey levels per flux at κ = 30)",
            30.0 * max_err
        );
        // Index rounding: ≤ 1 · 2⁻¹² = 2.44e-4; entries: 2⁻¹⁷; index truncation ≈ 2⁻¹⁶.
        assert!(max_err < 2.8e-4, "max flux error {max_err:e}");
        assert!(max_err > 1e-5, "the bound should be nearly reached: {max_err:e}");
    }

    #[test]
    fn flux_is_antisymmetric_and_zero_far_away() {
        let d = Diffusion::new(&AdfParams::default());
        for dq in [1, 100, 65536, 30 << 16, 119 << 16] {
            assert_eq!(d.flux(dq), -d.flux(-dq));
        }
        assert_eq!(d.flux(121 << 16), 0, "beyond 4κ the conduction is 0");
        assert_eq!(d.flux(i32::MIN + 1), 0);
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
