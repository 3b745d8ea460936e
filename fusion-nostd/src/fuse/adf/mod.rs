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

mod diffusion;

pub use diffusion::{Band, diffuse_pair};
pub(crate) use diffusion::{diffuse_rows, stream_words};

use super::{Guards, Variant};
use crate::filters::border::Border;
use crate::{Error, FrameMut, FrameRef, ScratchMut};

/// Fractional bits of the raw fused value written by [`fuse_adf_raw`] (Q16: `raw / 65536` is
/// the real result in grey levels, before the 8-bit cast).
pub const RAW_FRAC_BITS: u32 = 16;

/// Fractional bits of the base layers handed from the diffusion to the fusion (Q16).
const STATE_BITS: u32 = 16;
/// Fractional bits of the weights.
const WEIGHT_BITS: u32 = 30;

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
    let [a_vis, a_tir, tmp] = full_planes(scratch, w * h)?;
    diffuse_pair(Band::Frame(vis), Band::Frame(tir), (w, h), params, a_vis, a_tir, tmp)?;
    let (a_vis, a_tir) = (&*a_vis, &*a_tir);
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

/// The three scratch planes at their full capacity (the diffusion's work plane holds the flux
/// table and the row pipeline even for a small window), the first two cut to `pixels`.
fn full_planes<'s>(scratch: &'s mut ScratchMut<'_>, pixels: usize) -> Result<[&'s mut [i32]; 3], Error> {
    let capacity = scratch.capacity();
    let [a, b, c] = scratch.planes(capacity.max(pixels))?;
    let (Some(a), Some(b)) = (a.get_mut(..pixels), b.get_mut(..pixels)) else {
        return Err(Error::ScratchTooSmall { needed: pixels, capacity });
    };
    Ok([a, b, c])
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
    let [a_vis, a_tir, tmp] = full_planes(scratch, w * h)?;
    // A constant VIS (the eclipse plan) is diffused as a level: it stays constant under the
    // replicate-border diffusion (every ∇ = 0), and under the zero border when it is 0.
    let vis_band = vis.map_or(Band::Level(vis_level), Band::Frame);
    diffuse_pair(vis_band, Band::Frame(tir), (w, h), params, a_vis, a_tir, tmp)?;
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

    fn noise(n: usize, seed: u32, levels: u32) -> std::vec::Vec<u8> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(1664525).wrapping_add(1013904223);
                ((s >> 24) % levels) as u8 * (255 / (levels - 1).max(1)) as u8
            })
            .collect()
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
}
