//! ADF — anisotropic diffusion + Karhunen–Loève fusion (Bavirisetti & Dhuli, IEEE Sensors J.
//! 16(1), 2016), integer core. Spec: `docs/reference/fusion-algorithms.md`, ADF.
//!
//! # Steps and number formats
//!
//! | quantity | type | format | range / saturation |
//! |---|---|---|---|
//! | diffusion state `A_k` (base layer), both bands in one word (VIS low, TIR high half) | `i16` × 2 | Q7 grey levels | clamped to 0..=32767 (0 ..< 256 levels) after every update |
//! | neighbour difference `∇`, pair flux `F(∇) ≈ Δt/2·∇·exp(−(∇/κ)²)` | `i16` | Q7 | \|F\| ≤ 1760 for every parameter set |
//! | step `Σ = 2·Σ_axial F + Σ_diagonal F` (no rounding) | `i16` partial sums | Q7 | every partial sum < 12·1760 < 2¹⁵: no saturation |
//! | detail layer `D_k = 2⁷·I_k − A_k` | `i32` | Q7 | \|D\| < 2¹⁵ |
//! | covariance sums | `i32`/`i64` per 2¹⁵-pixel chunk, then `i128` | Q7, Q14 | exact |
//! | KL weight `p_IR` (`p_VIS = 1 − p_IR`) | `i64` | Q30 | classic: saturated to ±128; flight: [0, 1] |
//! | fused value before rounding `(A_IR + A_VIS + 2·D_VIS)·2²⁹ + p_IR·(D_IR − D_VIS)` | `i64` (flight: `i32` and one 32 × 32 → 64 product) | Q37 | < 2⁵⁵, no overflow for any weight |
//! | fused raw value [`fuse_adf_raw`] | `i32` | Q16 ([`RAW_FRAC_BITS`]), rounded half up | saturated to the `i32` range (only reachable with classic weights ≫ 1) |
//!
//! **Diffusion** (module `diffusion`, where the flux function, its table, the row loops and the
//! row pipeline are documented): the published 8-neighbour Perona–Malik scheme, `A ← A +
//! Δt·(Σ_axial c∇ + ½Σ_diagonal c∇)`, `c = exp(−(∇/κ)²)`, with each neighbour pair's flux taken
//! once for both pixels, the flux a piecewise-linear function on 64 segments defined by integer
//! operations (tabulated on Cortex-M and RV32, evaluated 32 lanes at a time with AVX-512), both
//! bands in one pass. Error against the f64 reference: ≤ 0.0075 grey levels per pair flux at
//! κ = 30; on the VIFB pairs the fused frame is within 0.5 levels before the 8-bit cast, max 1
//! level after. The
//! state is clamped to 0 ..< 256 levels, where the reference is not: for Δt > 1/6 (allowed up to
//! 0.25) the explicit scheme can overshoot at high-contrast single pixels, and there the core
//! departs from the reference.
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
//! Three `i32` planes of W·H (the pipeline's common scratch): the packed base layers of both
//! bands; the second plane is not used; the diffusion's work plane (taken at its full capacity,
//! even for a window) — the flux table (32 768 words, where a table is read) and the pipeline's
//! stage rows (3·(W+2) words per iteration; frames of fewer than about 3 rows use it as the
//! Jacobi ping-pong plane instead).

mod diffusion;
/// The strip form ([`crate::strips::StripForm`]).
mod strips;

/// The Armv7E-M forms of the covariance loop and the flight output row.
#[cfg(fusion_arm_dsp)]
mod armv7em;
/// The AVX2 forms of the covariance loop and the flight output row.
#[cfg(target_arch = "x86_64")]
mod avx2;

use diffusion::STATE_BITS;
pub use diffusion::{Band, diffuse_pair};
pub(crate) use diffusion::{diffuse_rows, stream_words};

use super::{Guards, Variant, check_sizes};
use crate::filters::border::Border;
use crate::sequence::{FrameKey, Link, Pass, Restart};
use crate::{Error, FrameMut, FrameRef, ScratchMut};

/// Fractional bits of the raw fused value written by [`fuse_adf_raw`] (Q16: `raw / 65536` is
/// the real result in grey levels, before the 8-bit cast).
pub const RAW_FRAC_BITS: u32 = 16;

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

/// Pixels per covariance chunk: 2¹⁵ details (`|D| < 2¹⁵`) sum below 2³⁰ in `i32`, their
/// products below 2⁴⁵ in `i64`; the chunk sums then go to `i128`.
const COV_CHUNK: usize = 1 << 15;

/// The details of one pixel from its packed base-layer word: `D = 2⁷·I − A` (Q7, `|D| < 2¹⁵`),
/// `(D_VIS, D_IR)`.
#[inline(always)]
fn details(iv: u8, it: u8, a: i32) -> (i32, i32) {
    ((i32::from(iv) << STATE_BITS) - diffusion::lo(a), (i32::from(it) << STATE_BITS) - diffusion::hi(a))
}

/// `[ΣD_IR, ΣD_VIS, ΣD_IR², ΣD_IR·D_VIS, ΣD_VIS²]`, exactly.
type Moments = [i128; 5];

/// The moments of a chunk of at most [`COV_CHUNK`] pixels (`i32` and `i64` sums, exact).
#[inline(always)]
fn chunk_moments(iv: &[u8], it: &[u8], a: &[i32]) -> Moments {
    #[cfg(fusion_arm_dsp)]
    let (done, [mut s1, mut s2], [mut s11, mut s12, mut s22]) = armv7em::moments_pairs(iv, it, a);
    #[cfg(target_arch = "x86_64")]
    let (done, [mut s1, mut s2], [mut s11, mut s12, mut s22]) = if crate::cpu::isa() == crate::cpu::Isa::Avx2
    {
        // SAFETY: the best set the CPU has (and the cap allows) is AVX2.
        unsafe { avx2::moments_blocks(iv, it, a) }
    } else {
        (0, [0i32; 2], [0i64; 3])
    };
    #[cfg(not(any(fusion_arm_dsp, target_arch = "x86_64")))]
    let (done, [mut s1, mut s2], [mut s11, mut s12, mut s22]) = (0, [0i32; 2], [0i64; 3]);
    let ([r1, r2], [r11, r12, r22]) = moments_rest(
        iv.get(done..).unwrap_or(&[]),
        it.get(done..).unwrap_or(&[]),
        a.get(done..).unwrap_or(&[]),
    );
    (s1, s2, s11, s12, s22) = (s1 + r1, s2 + r2, s11 + r11, s12 + r12, s22 + r22);
    [i128::from(s1), i128::from(s2), i128::from(s11), i128::from(s12), i128::from(s22)]
}

crate::cpu::dispatch! {
    /// The moments of a run of at most [`COV_CHUNK`] pixels (what the assembly loop leaves).
    fn moments_rest(iv: &[u8], it: &[u8], a: &[i32]) -> ([i32; 2], [i64; 3]) => moments_kernel
}

#[inline(always)]
fn moments_kernel(iv: &[u8], it: &[u8], a: &[i32]) -> ([i32; 2], [i64; 3]) {
    let (mut s1, mut s2, mut s11, mut s12, mut s22) = (0i32, 0i32, 0i64, 0i64, 0i64);
    for ((&iv, &it), &a) in iv.iter().zip(it).zip(a) {
        let (d2, d1) = details(iv, it, a);
        s1 += d1;
        s2 += d2;
        s11 += i64::from(d1) * i64::from(d1);
        s12 += i64::from(d1) * i64::from(d2);
        s22 += i64::from(d2) * i64::from(d2);
    }
    ([s1, s2], [s11, s12, s22])
}

/// The exact covariance sums of the detail layers `D = 2⁷·I − A` (Q7): integer sums, so the
/// order rows are added in (whole frame, window, strips) does not change them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Covariance {
    sums: Moments,
}

impl Covariance {
    pub(crate) const fn new() -> Self {
        Self { sums: [0; 5] }
    }

    /// Adds one row (or part of one): the pixels of both bands and their packed base layers.
    pub(crate) fn add_row(&mut self, iv: &[u8], it: &[u8], a: &[i32]) {
        let chunks = iv.chunks(COV_CHUNK).zip(it.chunks(COV_CHUNK)).zip(a.chunks(COV_CHUNK));
        for ((iv, it), a) in chunks {
            for (s, v) in self.sums.iter_mut().zip(chunk_moments(iv, it, a)) {
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
        Fusion::new(kl.p_ir_q30, kl.guards)
    }
}

impl Link<'_> {
    /// The key of a frame of `pixels` covariance pixels fused with `params`.
    fn key(&self, params: &AdfParams, pixels: usize) -> FrameKey {
        FrameKey { method: *params, illumination: self.illumination, pixels }
    }

    /// The carried fusion rule for this frame, or why there is none.
    pub(crate) fn carried(&self, params: &AdfParams, pixels: usize) -> Result<Fusion, Restart> {
        self.seq.carried(&self.key(params, pixels)).map(|(p, g)| Fusion::new(p, g))
    }

    /// Records the frame: fused with `used` (carried when `carried` is `Ok`), its own rule
    /// `own` carried on.
    pub(crate) fn record(
        &mut self,
        params: &AdfParams,
        pixels: usize,
        carried: Result<(), Restart>,
        used: &Fusion,
        own: &Fusion,
    ) {
        let pass = match carried {
            Ok(()) => Pass::Carried,
            Err(r) => Pass::Own(r),
        };
        let key = self.key(params, pixels);
        self.seq.record(&key, pass, used.p_ir, (own.p_ir, own.guards));
    }

    /// The rule a frame is fused with once its own is known (the whole-frame forms): the
    /// carried one when the rule allows it, else its own; recorded.
    fn pick(&mut self, params: &AdfParams, pixels: usize, own: Fusion) -> Fusion {
        let (used, carried) = match self.carried(params, pixels) {
            Ok(f) => (f, Ok(())),
            Err(r) => (own, Err(r)),
        };
        self.record(params, pixels, carried, &used, &own);
        used
    }
}

/// The rule of a frame of `pixels` covariance pixels: its own, or in a sequence the one the
/// link picks.
fn rule(link: Option<&mut Link<'_>>, params: &AdfParams, pixels: usize, own: Fusion) -> Fusion {
    match link {
        Some(l) => l.pick(params, pixels, own),
        None => own,
    }
}

/// The frame's fusion rule once its covariance is known.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Fusion {
    p_ir: i64,
    /// `p_IR` when it fits `i32` (always in the flight variant): a 32 × 32 → 64-bit product.
    p32: Option<i32>,
    /// The guards the KL weights fired.
    pub(crate) guards: Guards,
}

impl Fusion {
    /// The rule of the weight `p_ir` (Q30) and the guards it fired.
    fn new(p_ir: i64, guards: Guards) -> Self {
        Fusion { p_ir, p32: i32::try_from(p_ir).ok(), guards }
    }

    /// Fuses one row into raw Q16 values.
    #[inline]
    fn raw_row(&self, iv: &[u8], it: &[u8], a: &[i32], out: &mut [i32]) {
        let pixels = out.iter_mut().zip(iv).zip(it).zip(a);
        match self.p32 {
            Some(p) => pixels.for_each(|(((o, &iv), &it), &a)| *o = fused32(p, iv, it, a)),
            None => pixels.for_each(|(((o, &iv), &it), &a)| *o = fused(self.p_ir, iv, it, a)),
        }
    }

    /// Fuses one row into 8-bit values; `true` when some value saturated.
    pub(crate) fn u8_row(&self, iv: &[u8], it: &[u8], a: &[i32], out: &mut [u8]) -> bool {
        #[cfg(fusion_arm_dsp)]
        let (done, mut saturated) = match self.p32 {
            Some(p) => armv7em::u8_pixels(p, iv, it, a, out),
            None => (0, false),
        };
        #[cfg(target_arch = "x86_64")]
        let (done, mut saturated) = match self.p32 {
            // SAFETY: the best set the CPU has (and the cap allows) is AVX2.
            Some(p) if crate::cpu::isa() == crate::cpu::Isa::Avx2 => unsafe {
                avx2::u8_blocks(p, iv, it, a, out)
            },
            _ => (0, false),
        };
        #[cfg(not(any(fusion_arm_dsp, target_arch = "x86_64")))]
        let (done, mut saturated) = (0, false);
        let (iv, it, a) =
            (iv.get(done..).unwrap_or(&[]), it.get(done..).unwrap_or(&[]), a.get(done..).unwrap_or(&[]));
        let out = out.get_mut(done..).unwrap_or(&mut []);
        match self.p32 {
            Some(p) => saturated |= u8_rest(p, iv, it, a, out),
            None => {
                for (((o, &iv), &it), &a) in out.iter_mut().zip(iv).zip(it).zip(a) {
                    let v = fused(self.p_ir, iv, it, a);
                    saturated |= raw_saturates(v);
                    *o = raw_to_u8(v);
                }
            }
        }
        saturated
    }
}

crate::cpu::dispatch! {
    /// The 8-bit fused values of a run of pixels with `|p_IR| < 2³¹` (what the assembly loop
    /// leaves); `true` when some value saturated.
    fn u8_rest(p: i32, iv: &[u8], it: &[u8], a: &[i32], out: &mut [u8]) -> bool => u8_kernel
}

#[inline(always)]
fn u8_kernel(p: i32, iv: &[u8], it: &[u8], a: &[i32], out: &mut [u8]) -> bool {
    let mut saturated = false;
    for (((o, &iv), &it), &a) in out.iter_mut().zip(iv).zip(it).zip(a) {
        let v = fused32(p, iv, it, a);
        saturated |= raw_saturates(v);
        *o = raw_to_u8(v);
    }
    saturated
}

/// Whether the 8-bit cast of a raw Q16 value saturates (it rounds outside `0..=255`).
#[inline(always)]
fn raw_saturates(v: i32) -> bool {
    !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&v)
}

/// One fused raw value (Q16): `F = ½(A_IR + A_VIS) + D_VIS + p_IR·(D_IR − D_VIS)` in Q37,
/// `(A_IR + A_VIS + 2·D_VIS)·2²⁹ + p_IR·(D_IR − D_VIS)` (`|·| < 2¹⁸·2²⁹ + 2³⁸·2¹⁶ < 2⁵⁵`, no
/// overflow for any weight up to the classic ±128), rounded half up to Q16 and saturated to
/// `i32` (only classic weights ≫ 1 reach it). With `|p_IR| < 2³¹` the product is one `smlal`.
#[inline(always)]
fn fused(p_ir: i64, iv: u8, it: u8, a: i32) -> i32 {
    let (d_vis, d_ir) = details(iv, it, a);
    let s = diffusion::hi(a) + diffusion::lo(a) + 2 * d_vis;
    let v = (i64::from(s) << (WEIGHT_BITS - 1)) + p_ir * i64::from(d_ir - d_vis) + (1 << (Q_SHIFT - 1));
    (v >> Q_SHIFT).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// [`fused`] for `|p_IR| < 2³¹` (every flight weight): the term `(A_IR + A_VIS + 2·D_VIS)·2²⁹`
/// is a multiple of `2^Q_SHIFT`, so the rounded shift splits into `(…)·2⁸ + ⌊(p·ΔD + 2²⁰)/2²¹⌋`
/// (exact), one 32 × 32 → 64-bit product and no saturation (`|raw| < 2²⁷`).
#[inline(always)]
fn fused32(p_ir: i32, iv: u8, it: u8, a: i32) -> i32 {
    let (d_vis, d_ir) = details(iv, it, a);
    let s = diffusion::hi(a) + diffusion::lo(a) + 2 * d_vis;
    let x = i64::from(p_ir) * i64::from(d_ir - d_vis) + (1 << (Q_SHIFT - 1));
    (s << (WEIGHT_BITS - 1 - Q_SHIFT)) + (x >> Q_SHIFT) as i32
}

/// From the Q37 fused value to the raw Q16.
const Q_SHIFT: u32 = WEIGHT_BITS + STATE_BITS - RAW_FRAC_BITS;

/// The one code path: diffuse both bands, KL weights, then hand each row — its pixels and
/// packed base layers — to `emit(fusion, y, VIS row, TIR row, base-layer row)`, which fuses it.
fn run(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    params: &AdfParams,
    scratch: &mut ScratchMut<'_>,
    link: Option<&mut Link<'_>>,
    mut emit: impl FnMut(&Fusion, usize, &[u8], &[u8], &[i32]),
) -> Result<Guards, Error> {
    params.validate()?;
    let (w, h) = vis.size();
    let [a, _, work] = full_planes(scratch, w * h)?;
    diffuse_pair(Band::Frame(vis), Band::Frame(tir), (w, h), params, a, work)?;
    let a = &*a;
    let rows = || vis.rows().zip(tir.rows()).zip(a.chunks_exact(w.max(1)));
    let mut cov = Covariance::new();
    for ((iv, it), a) in rows() {
        cov.add_row(iv, it, a);
    }
    let fusion = rule(link, params, w * h, cov.weights(w * h, params.variant));
    for (y, ((iv, it), a)) in rows().enumerate() {
        emit(&fusion, y, iv, it, a);
    }
    Ok(fusion.guards)
}

/// The three scratch planes, the first two cut to `pixels`, the third (the diffusion's work:
/// the flux table and the row pipeline, even for a small window) at its full capacity.
fn full_planes<'s>(scratch: &'s mut ScratchMut<'_>, pixels: usize) -> Result<[&'s mut [i32]; 3], Error> {
    let capacity = scratch.capacity();
    let [a, b, c] = scratch.planes(capacity.max(pixels))?;
    let (Some(a), Some(b)) = (a.get_mut(..pixels), b.get_mut(..pixels)) else {
        return Err(Error::ScratchTooSmall { needed: pixels, capacity });
    };
    Ok([a, b, c])
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
    out: FrameMut<'_, u8>,
    params: &AdfParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    fuse_adf_linked(vis, tir, out, params, scratch, None)
}

/// [`fuse_adf`], in a sequence when `link` is given (the weights the sequence's rule picks).
pub(crate) fn fuse_adf_linked(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    mut out: FrameMut<'_, u8>,
    params: &AdfParams,
    scratch: &mut ScratchMut<'_>,
    link: Option<&mut Link<'_>>,
) -> Result<Guards, Error> {
    check_sizes(&vis, &tir, out.size())?;
    let mut saturated = false;
    let guards = run(vis, tir, params, scratch, link, |fusion, y, iv, it, a| {
        saturated |= fusion.u8_row(iv, it, a, out.row_mut(y));
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
    run(vis, tir, params, scratch, None, |fusion, y, iv, it, a| fusion.raw_row(iv, it, a, raw.row_mut(y)))
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
/// In a sequence (`link`), the weights are those the sequence's rule picks for a frame of
/// `frame_pixels` pixels.
///
/// Errors: as [`fuse_adf`], [`Error::InvalidParameter`] (`"rect"`) when `exact` is not inside
/// the window or `frame_pixels` is smaller than the window, (`"vis_level"`) for a non-zero
/// constant VIS with the classic (zero-padded) variant.
#[allow(clippy::too_many_arguments)]
pub fn fuse_adf_window(
    vis: Option<FrameRef<'_, u8>>,
    vis_level: u8,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    exact: crate::frame::Rect,
    frame_pixels: usize,
    params: &AdfParams,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    fuse_adf_window_linked(vis, vis_level, tir, out, exact, frame_pixels, params, scratch, None)
}

/// [`fuse_adf_window`], in a sequence when `link` is given.
#[allow(clippy::too_many_arguments)]
pub(crate) fn fuse_adf_window_linked(
    vis: Option<FrameRef<'_, u8>>,
    vis_level: u8,
    tir: FrameRef<'_, u8>,
    mut out: FrameMut<'_, u8>,
    exact: crate::frame::Rect,
    frame_pixels: usize,
    params: &AdfParams,
    scratch: &mut ScratchMut<'_>,
    link: Option<&mut Link<'_>>,
) -> Result<Guards, Error> {
    params.validate()?;
    if let Some(v) = &vis {
        check_sizes(v, &tir, out.size())?;
    } else if out.size() != tir.size() {
        return Err(Error::SizeMismatch { expected: tir.size(), got: out.size() });
    }
    let (w, h) = tir.size();
    if exact.is_empty() || !crate::frame::Rect::full((w, h)).covers(&exact) || frame_pixels < w * h {
        return Err(Error::InvalidParameter { name: "rect" });
    }
    if vis.is_none() && vis_level != 0 && params.variant == Variant::Classic {
        return Err(Error::InvalidParameter { name: "vis_level" });
    }
    let [a, _, work] = full_planes(scratch, w * h)?;
    // A constant VIS (the eclipse plan) is diffused as a level: it stays constant under the
    // replicate-border diffusion (every ∇ = 0), and under the zero border when it is 0.
    let vis_band = vis.map_or(Band::Level(vis_level), Band::Frame);
    diffuse_pair(vis_band, Band::Frame(tir), (w, h), params, a, work)?;
    let a = &*a;
    // A constant VIS is read from `level_row`, so the rows go a part of `PART` pixels at a time.
    const PART: usize = 1 << 11;
    let level_row = &[vis_level; PART];
    let (ex0, ex1) = (exact.x0, exact.x1);
    // The rows of `exact`, cut to its columns, a part at a time: (y, x, VIS pixels, TIR
    // pixels, packed base layers).
    let parts = || {
        (exact.y0..exact.y1).flat_map(move |y| {
            let it = tir.row(y).get(ex0..ex1).unwrap_or(&[]);
            let iv = vis.map(|v| v.row(y).get(ex0..ex1).unwrap_or(&[]));
            let ar = a.get(y * w + ex0..y * w + ex1).unwrap_or(&[]);
            (0..it.len()).step_by(PART).map(move |x| {
                let n = PART.min(it.len() - x);
                let iv = iv.map_or(level_row.get(..n), |r| r.get(x..x + n)).unwrap_or(&[]);
                (y, x, iv, it.get(x..x + n).unwrap_or(&[]), ar.get(x..x + n).unwrap_or(&[]))
            })
        })
    };
    let mut cov = Covariance::new();
    for (_, _, iv, it, ar) in parts() {
        cov.add_row(iv, it, ar);
    }
    let fusion = rule(link, params, frame_pixels, cov.weights(frame_pixels, params.variant));
    let mut saturated = false;
    for (y, x, iv, it, ar) in parts() {
        let dst = out.row_mut(y).get_mut(ex0 + x..ex0 + x + it.len()).unwrap_or(&mut []);
        saturated |= fusion.u8_row(iv, it, ar, dst);
    }
    Ok(if saturated { fusion.guards | Guards::OUTPUT_SATURATED } else { fusion.guards })
}

#[cfg(test)]
mod tests;
