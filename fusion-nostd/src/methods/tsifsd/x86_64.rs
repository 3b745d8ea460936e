//! x86-64's form of the flight kernel's chunk (its wide form there, on every x86-64 CPU: the
//! baseline build and the AVX2 and AVX-512 copies of `flight_u8` alike): the divisions in
//! `f64`/`f32`, in separate passes the compiler vectorises (the portable chunk,
//! [`super::flight`], divides in integers in one pass; AArch64 has its own NEON chunk,
//! `neon.rs`, dividing by [`MagicC`]). All give the same bytes (unit test
//! `wide_and_portable_chunks_agree`; on AArch64 the SIMD-forms test under `qemu-aarch64`).
// Compiled on every target. On AArch64 only `Wide` (its Scharr columns) and `MagicC` serve the
// NEON chunk; the rest is x86-64's, kept compiled there for the division tests.
#![cfg_attr(all(target_arch = "aarch64", target_feature = "neon"), allow(dead_code))]

use super::*;

/// The wide forms' chunk buffers (this chunk's; the NEON chunk uses the Scharr columns):
/// window sums, packed parts, Scharr columns.
pub(super) struct Wide {
    pub(super) dd: [u32; CHUNK],
    pub(super) q: [u32; CHUNK],
    pub(super) sd: [[u32; 2]; CHUNK + 2],
}

impl Wide {
    pub(super) fn new() -> Self {
        Self { dd: [0; CHUNK], q: [0; CHUNK], sd: [[0; 2]; CHUNK + 2] }
    }
}

/// `⌊n / c⌋` in `f64` for `n < 2²⁸`, `c < 2¹³` (vectorisable): `n·fl(1/c)` is within 2⁻²⁵ of
/// `n/c`; adding 2⁻²⁰ lifts an exact quotient above its integer, and a non-integer quotient is
/// at least `1/c > 2⁻¹³` below the next one, so truncation gives the floor.
#[inline(always)]
pub(super) fn div_c_f64(n: u32, inv_c: f64) -> u32 {
    trunc_u32(f64::from(n as i32) * inv_c + 1.0 / (1u32 << 20) as f64)
}

/// `⌊n / c⌋` for `n < 2²⁸` and the frame's constant `c < 2¹⁴` as `(n·m) >> s` (Granlund and
/// Montgomery's division by an invariant integer): with `l = ⌈log₂ c⌉`, `s = max(28 + l, 31)`
/// and `m = ⌈2ˢ/c⌉ = (2ˢ + e)/c`, `0 ≤ e < c ≤ 2ˡ`, the product is `n/c + n·e/(c·2ˢ)` with
/// `n·e < 2²⁸⁺ˡ ≤ 2ˢ`, so less than `1/c` above `n/c`: not enough to reach the next integer.
/// For `c ≥ 2`, `m < 2³¹` (`m ≤ 2²⁹ + 1` when `s = 28 + l`, `m ≤ 2³⁰ + 1` when `s = 31`): the
/// NEON chunk takes `⌊n·m / 2³¹⌋` with one `sqdmulh` (`n`, `m` non-negative `i32`, so it
/// neither rounds nor saturates) and shifts by `s − 31`; elsewhere it is only tested.
#[derive(Debug, Clone, Copy)]
#[cfg_attr(not(all(target_arch = "aarch64", target_feature = "neon")), allow(dead_code))]
pub(super) struct MagicC {
    /// `m`.
    pub(super) m: u64,
    /// `s`.
    pub(super) s: u32,
}

#[cfg_attr(not(all(target_arch = "aarch64", target_feature = "neon")), allow(dead_code))]
impl MagicC {
    pub(super) fn new(c: NonZeroU32) -> Self {
        let l = u32::BITS - (c.get() - 1).leading_zeros();
        let s = (28 + l).max(31);
        let c64 = core::num::NonZeroU64::from(c);
        Self { m: ((1u64 << s) + c64.get() - 1) / c64, s }
    }

    #[inline(always)]
    pub(super) fn div(self, n: u32) -> u32 {
        ((u64::from(n) * self.m) >> self.s) as u32
    }
}

/// `⌊n / σ⌋` of the flight kernel's last division in `f32` (vectorisable, 8 lanes with AVX2):
/// `n < 2²⁴` and `σ ≤ 16320` are exact in `f32`, the quotient is below 2¹⁰ (`n ≤ 512σ + 1`),
/// so the correctly rounded quotient is within 2⁻²⁴·2¹⁰ = 2⁻¹⁴ of the true one, less than the
/// distance `≥ 1/σ > 2⁻¹⁴` of a non-integer quotient to the next integer: truncation gives the
/// floor (tested against the integer division over the whole range of `σ`).
/// (The NEON chunk truncates the same quotient with `fcvtzu`, which has no saturation test to
/// avoid.)
#[inline(always)]
pub(super) fn div_sigma_f32(n: u32, sigma: u32) -> u32 {
    const MAGIC: f32 = (1u32 << 23) as f32;
    let x = (n as i32) as f32 / (sigma as i32) as f32;
    let r = (x + MAGIC).to_bits() & 0x7F_FFFF;
    r - u32::from((r as i32) as f32 > x)
}

/// `⌊x⌋` for `0 ≤ x < 2³¹` in lane-wise arithmetic the compiler keeps vectorised (`as` would
/// add a saturation and NaN test per lane): adding 2⁵² rounds `x` to the nearest integer `r`
/// in the low mantissa bits; `r − 1` when that rounded up.
#[inline(always)]
pub(super) fn trunc_u32(x: f64) -> u32 {
    const MAGIC: f64 = (1u64 << 52) as f64;
    let r = (x + MAGIC).to_bits() as u32;
    r - u32::from(f64::from(r as i32) > x)
}

/// One chunk in separate short passes without branches or integer divisions ([`div_c_f64`] in
/// `f64`, [`div_sigma_f32`] in `f32`), which the compiler vectorises (the AVX2 copy on x86-64).
#[inline(always)]
pub(super) fn chunk_wide(
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
