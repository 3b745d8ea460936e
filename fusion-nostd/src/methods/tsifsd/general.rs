//! The general path, both variants and both outputs (8-bit and the raw Q16 value): the
//! saliencies and the reconstruction row by row after the box sums, in the published
//! arithmetic's exact integer form.

use super::*;

/// `round(n / d)`, half away from zero, `d > 0`.
#[inline(always)]
pub(super) fn div_round(n: i64, d: i64) -> i64 {
    let d = d.max(1); // d > 0 already; lets the optimiser drop the division's panic paths
    if n >= 0 { (2 * n + d) / (2 * d) } else { -((-2 * n + d) / (2 * d)) }
}

/// The weights of one pixel: `(w_VIS, w_IR, σ = w_VIS + w_IR)`, both saliencies shifted right
/// together until `σ < 2²³` (½, ½ when both are 0), and `true` when both were 0.
#[inline(always)]
pub(super) fn weights(sal_v: u64, sal_i: u64) -> (i64, i64, i64, bool) {
    let zero = sal_v == 0 && sal_i == 0;
    let (sal_v, sal_i) = if zero { (1, 1) } else { (sal_v, sal_i) };
    let shift = (64 - (sal_v + sal_i).leading_zeros()).saturating_sub(23);
    let (wv, wi) = ((sal_v >> shift) as i64, (sal_i >> shift) as i64);
    (wv, wi, wv + wi, zero)
}

/// The fused value of one pixel as the fraction `num / den` (Q16 once divided), `den > 0`,
/// and `true` when both saliencies were 0.
#[inline(always)]
pub(super) fn fraction(
    iv: u8,
    ii: u8,
    sum_v: i32,
    sum_i: i32,
    sal_v: u64,
    sal_i: u64,
    taps: i64,
) -> (i64, i64, bool) {
    let (wv, wi, sigma, zero) = weights(sal_v, sal_i); // σ ≥ 1 and < 2²³
    let (sv, si) = (i64::from(sum_v), i64::from(sum_i));
    let dv = taps * i64::from(iv) - sv;
    let di = taps * i64::from(ii) - si;
    let num = (((sv + si) * sigma) << 15) + ((wv * dv + wi * di) << 16);
    (num, taps * sigma, zero)
}

/// Fused Q16 value of one pixel; `true` when both saliencies were 0.
#[inline(always)]
pub(super) fn combine(
    iv: u8,
    ii: u8,
    sum_v: i32,
    sum_i: i32,
    sal_v: u64,
    sal_i: u64,
    taps: i64,
) -> (i32, bool) {
    let (num, den, zero) = fraction(iv, ii, sum_v, sum_i, sal_v, sal_i, taps);
    (div_round(num, den) as i32, zero)
}

/// `⌊u / v⌋` for `u < 256·v` (`v > 0`) without a 64-bit division (a library call on the
/// 32-bit targets): estimated by one 32-bit division of the top bits
/// (`v` cut to 24 bits, so the estimate is off by at most one) and corrected exactly.
#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
#[inline(always)]
pub(super) fn div_small(u: u64, v: u64) -> u32 {
    let s = (64 - v.leading_zeros()).saturating_sub(24);
    // u >> s < 256·((v >> s) + 1) ≤ 2³²; v >> s < 2²⁴.
    let (u2, v2) = ((u >> s) as u32, ((v >> s) as u32).max(1));
    let k = u2 / v2;
    let prod = u64::from(k) * v; // k ≤ 256, v < 2⁵³
    if prod > u {
        k.wrapping_sub(1)
    } else if u - prod >= v {
        k + 1
    } else {
        k
    }
}

/// `(⌊a / b⌋, a mod b)` (floor division, remainder in `0..b`) for `b > 0`.
#[inline(always)]
pub(super) fn floor_divmod(a: i32, b: i32) -> (i32, i32) {
    let (q, r) = (a / b.max(1), a % b.max(1));
    if r < 0 { (q - 1, r + b) } else { (q, r) }
}

/// The 8-bit output of one pixel and whether it saturated, from its weights `w_VIS`, `w_IR`
/// (`σ = w_VIS + w_IR`, `1 ≤ σ < 2²³`), without a 64-bit division.
///
/// With `num / den` the fused Q16 value ([`fraction`]), `num = 2¹⁵·N`,
/// `N = 2·taps·S + (w_VIS − w_IR)·(Σ_IR − Σ_VIS)`, `S = w_VIS·I_VIS + w_IR·I_IR`,
/// `den = taps·σ`, the raw value is `q = round(num/den)` (half away from zero) and the output
/// [`round_away_sat_u8`](super::round_away_sat_u8)`(q, 16)`. Both roundings fold into one floor
/// (nested floors of integers): output `= clamp(k, 0, 255)` with
/// `k = ⌊U / (2·den)⌋`, `U = N + den + ⌊den / 2¹⁶⌋`; `q` lies outside `[−2¹⁵, 255·2¹⁶ + 2¹⁵)`
/// exactly when `k ≥ 256`, `U < 0`, or `U = 0` with `2¹⁶ | den`.
///
/// When `σ < 2¹⁴` (always for the flight saliency) everything fits `i32`: with
/// `Σ_IR − Σ_VIS = 2·taps·a + r` (`|a| ≤ 128`, `0 ≤ r < 2·taps`), `⌊U / (2·taps)⌋ =
/// S + (w_VIS − w_IR)·a + ⌊((w_VIS − w_IR)·r + den + ⌊den/2¹⁶⌋) / (2·taps)⌋` and `k` is that
/// floor-divided by `σ`: three 32-bit divisions. Otherwise `U` is formed in `i64` and divided
/// by [`div_small`] (or by the hardware on x86-64).
#[inline(always)]
pub(super) fn fused_u8(iv: u8, ii: u8, sv: i32, si: i32, wv: u32, wi: u32, taps: u32) -> (u8, bool) {
    // x86-64: one f64 division beats three dependent integer divisions.
    #[cfg(not(target_arch = "x86_64"))]
    if wv + wi < 1 << 14 {
        return fused_u8_small(iv, ii, sv, si, wv, wi, taps);
    }
    fused_u8_wide(iv, ii, sv, si, wv, wi, taps)
}

/// [`fused_u8`] for `σ < 2¹⁴`, all in `i32` with three 32-bit floor divisions.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
pub(super) fn fused_u8_small(iv: u8, ii: u8, sv: i32, si: i32, wv: u32, wi: u32, taps: u32) -> (u8, bool) {
    let (sigma, taps) = ((wv + wi) as i32, taps as i32);
    let s = (wv * u32::from(iv) + wi * u32::from(ii)) as i32; // < 255·2¹⁴
    let (wd, c) = (wv as i32 - wi as i32, 2 * taps);
    let den = taps * sigma; // < 2²⁶
    let (a, r) = floor_divmod(si - sv, c);
    let (f, rt) = floor_divmod(wd * r + den + (den >> 16), c); // |·| < 2²⁸
    let x = s + wd * a + f; // ⌊U / (2·taps)⌋
    finish_u8(floor_divmod(x, sigma).0, x == 0 && rt == 0, den & 0xFFFF)
}

/// [`fused_u8`] for any `σ < 2²³`: `U` in `i64` (`|U| < 2⁴⁶`), `⌊U / (2·den)⌋` by
/// [`quotient`].
#[inline(always)]
pub(super) fn fused_u8_wide(iv: u8, ii: u8, sv: i32, si: i32, wv: u32, wi: u32, taps: u32) -> (u8, bool) {
    let sigma = wv + wi;
    // taps ≤ 63² < 2¹², σ < 2²³: S < 255·2²³ < 2³¹.
    let s = wv * u32::from(iv) + wi * u32::from(ii);
    let den = u64::from(taps) * u64::from(sigma); // < 2³⁵
    let n = i64::from(2 * taps) * i64::from(s) + (i64::from(wv) - i64::from(wi)) * i64::from(si - sv);
    let u = n + (den + (den >> 16)) as i64;
    let v = den << 1;
    let k = if u < 0 {
        -1
    } else if u as u64 >= v << 8 {
        256
    } else {
        quotient(u as u64, v) as i32
    };
    finish_u8(k, u == 0, (den & 0xFFFF) as i32)
}

/// The output and the saturation flag from `k` (see [`fused_u8`]).
#[inline(always)]
pub(super) fn finish_u8(k: i32, u_zero: bool, den_low: i32) -> (u8, bool) {
    let saturated = !(0..256).contains(&k) || (u_zero && den_low == 0);
    (k.clamp(0, 255) as u8, saturated)
}

/// `⌊u / v⌋` for `u < 256·v`, `v < 2³⁷` (`u < 2⁴⁵`): by [`div_small`] on the 32-bit targets;
/// on x86-64 by one `f64` division, exact here: `u` and `v` convert exactly (< 2⁵³), and a
/// quotient below the integer `k` misses it by at least `1/v ≥ 2⁻³⁷`, far more than the
/// division's rounding error `k·2⁻⁵³ < 2⁻⁴⁴`, so it never rounds up to `k` (and an exact
/// integer quotient stays exact).
#[inline(always)]
pub(super) fn quotient(u: u64, v: u64) -> u32 {
    #[cfg(target_arch = "x86_64")]
    let k = (u as f64 / v as f64) as u32;
    #[cfg(not(target_arch = "x86_64"))]
    let k = div_small(u, v);
    k
}

/// The weights of the classic saliencies `(Σ − N·Med)²` from the two signed differences
/// (`|·| < 2²⁰`), as [`weights`] gives them, and `true` when both saliencies are 0.
#[inline(always)]
pub(super) fn weights_classic(dv: i32, di: i32) -> (u32, u32, bool) {
    let square = |d: i32| u64::from(d.unsigned_abs()) * u64::from(d.unsigned_abs());
    let (wv, wi, _, zero) = weights(square(dv), square(di));
    (wv as u32, wi as u32, zero)
}

/// The weights of the flight saliencies (gradients ≤ 8160: their sum is already below 2²³,
/// nothing to shift), as [`weights`] gives them, and `true` when both are 0.
#[inline(always)]
pub(super) fn weights_flight(gv: i32, gi: i32) -> (u32, u32, bool) {
    let (gv, gi) = (gv.unsigned_abs(), gi.unsigned_abs());
    let zero = gv == 0 && gi == 0;
    if zero { (1, 1, true) } else { (gv, gi, false) }
}

/// The 8-bit output of one pixel, [`round_away_sat_u8`](super::round_away_sat_u8)`(combine(…), 16)`
/// (see [`fused_u8`]); returns `(output, both saliencies 0, saturated)`.
#[cfg(test)]
pub(super) fn combine_u8(
    iv: u8,
    ii: u8,
    sum_v: i32,
    sum_i: i32,
    sal_v: u64,
    sal_i: u64,
    taps: i64,
) -> (u8, bool, bool) {
    let (wv, wi, _, zero) = weights(sal_v, sal_i);
    let (out, saturated) = fused_u8(iv, ii, sum_v, sum_i, wv as u32, wi as u32, taps as u32);
    (out, zero, saturated)
}

/// One chunk's pixels: box sums, the two saliency values (`saliency` turns them into weights),
/// and the pixels themselves.
pub(super) struct Chunk<'a> {
    pub(super) iv: &'a [u8],
    pub(super) ii: &'a [u8],
    pub(super) sv: &'a [i32],
    pub(super) si: &'a [i32],
    pub(super) a: &'a [i32],
    pub(super) b: &'a [i32],
}

/// Fuses one chunk into the 8-bit `out`: `(some pixel had both saliencies 0, some output
/// saturated)`. `weights` turns the two saliency values into `(w_VIS, w_IR, both 0)`.
#[inline(always)]
pub(super) fn fuse_chunk_u8(
    c: &Chunk<'_>,
    taps: u32,
    weights: impl Fn(i32, i32) -> (u32, u32, bool),
    out: &mut [u8],
) -> (bool, bool) {
    let (mut zero, mut saturated) = (false, false);
    let pixels = out.iter_mut().zip(c.iv).zip(c.ii).zip(c.sv).zip(c.si).zip(c.a).zip(c.b);
    for ((((((o, &iv), &ii), &sv), &si), &a), &b) in pixels {
        let (wv, wi, z) = weights(a, b);
        let (v, s) = fused_u8(iv, ii, sv, si, wv, wi, taps);
        *o = v;
        zero |= z;
        saturated |= s;
    }
    (zero, saturated)
}

/// Fuses one chunk into the raw Q16 `out`: `true` when some pixel had both saliencies 0.
#[inline(always)]
pub(super) fn fuse_chunk_raw(
    c: &Chunk<'_>,
    taps: i64,
    saliency: impl Fn(i32) -> u64,
    out: &mut [i32],
) -> bool {
    let mut zero = false;
    let pixels = out.iter_mut().zip(c.iv).zip(c.ii).zip(c.sv).zip(c.si).zip(c.a).zip(c.b);
    for ((((((o, &iv), &ii), &sv), &si), &a), &b) in pixels {
        let (v, z) = combine(iv, ii, sv, si, saliency(a), saliency(b), taps);
        *o = v;
        zero |= z;
    }
    zero
}

/// The rows `y − 1, y, y + 1` of a frame: outside rows are `None` (zeros) for the classic
/// variant and repeat the edge row for the flight variant.
pub(super) fn rows3(f: FrameRef<'_, u8>, y: usize, classic: bool) -> [Option<&[u8]>; 3] {
    let h = f.height();
    if classic {
        [y.checked_sub(1).map(|r| f.row(r)), Some(f.row(y)), (y + 1 < h).then(|| f.row(y + 1))]
    } else {
        [Some(f.row_clamped(y as isize - 1)), Some(f.row(y)), Some(f.row_clamped(y as isize + 1))]
    }
}

/// `s[x0 .. x0 + n]` (empty when out of range).
#[inline(always)]
pub(super) fn cut<T>(s: &[T], x0: usize, n: usize) -> &[T] {
    s.get(x0..x0 + n).unwrap_or(&[])
}

/// The general saliency and reconstruction (both variants, both outputs) after the box sums:
/// row by row ([`reconstruct_row`]) into `out`. Returns (some pixel had both saliencies 0,
/// some 8-bit output saturated).
pub(super) fn saliency_reconstruct(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    sum_v: &[i32],
    sum_i: &[i32],
    taps: i64,
    classic: bool,
    mut out: Out<'_>,
) -> (bool, bool) {
    let w = vis.width();
    let (mut zero, mut saturated) = (false, false);
    for (y, (sv, si)) in sum_v.chunks_exact(w.max(1)).zip(sum_i.chunks_exact(w.max(1))).enumerate() {
        let dst = match &mut out {
            Out::U8(f) => RowOut::U8(f.row_mut(y)),
            Out::Raw(f) => RowOut::Raw(f.row_mut(y)),
        };
        let (z, s) =
            reconstruct_row(rows3(vis, y, classic), rows3(tir, y, classic), sv, si, taps, classic, dst);
        zero |= z;
        saturated |= s;
    }
    (zero, saturated)
}

/// Where [`reconstruct_row`] puts one fused row.
pub(super) enum RowOut<'a> {
    U8(&'a mut [u8]),
    Raw(&'a mut [i32]),
}

/// One row, chunk by chunk: the two saliencies from the rows `y − 1, y, y + 1` of each band
/// (`rows_*`, the centre row given; classic: zero-padded median, saliency `(Σ − N·Med)²`;
/// flight: replicate-padded Scharr L1) and the row's box sums `sv`, `si`, then the fused
/// pixels. Returns (some pixel had both saliencies 0, some 8-bit output saturated).
pub(super) fn reconstruct_row(
    rows_v: [Option<&[u8]>; 3],
    rows_t: [Option<&[u8]>; 3],
    sv: &[i32],
    si: &[i32],
    taps: i64,
    classic: bool,
    mut out: RowOut<'_>,
) -> (bool, bool) {
    let (Some(iv), Some(ii)) = (rows_v[1], rows_t[1]) else { return (false, false) };
    let w = iv.len();
    let border = if classic { Border::Zero } else { Border::Replicate };
    let (mut zero, mut saturated) = (false, false);
    let mut x0 = 0;
    while x0 < w {
        let n = CHUNK.min(w - x0);
        let (mut a, mut b) = ([0i32; CHUNK], [0i32; CHUNK]);
        let (Some(a), Some(b)) = (a.get_mut(..n), b.get_mut(..n)) else { break };
        let part = |s| cut(s, x0, n);
        if classic {
            for (rows, sums, dst) in [(rows_v, part(sv), &mut *a), (rows_t, part(si), &mut *b)] {
                let mut med = [0u8; CHUNK];
                median3_chunk(rows, border, x0, med.get_mut(..n).unwrap_or(&mut []));
                for ((d, &m), &s) in dst.iter_mut().zip(&med).zip(sums) {
                    *d = s - taps as i32 * i32::from(m); // |Σ − N·Med| < 2²⁰
                }
            }
        } else {
            scharr_l1_chunk(rows_v, border, x0, a);
            scharr_l1_chunk(rows_t, border, x0, b);
        }
        let chunk = Chunk { iv: cut(iv, x0, n), ii: cut(ii, x0, n), sv: part(sv), si: part(si), a, b };
        let square = |v: i32| u64::from(v.unsigned_abs()) * u64::from(v.unsigned_abs());
        let plain = |v: i32| u64::from(v.unsigned_abs());
        match &mut out {
            RowOut::U8(row) => {
                let dst = row.get_mut(x0..x0 + n).unwrap_or(&mut []);
                let (z, s) = if classic {
                    fuse_chunk_u8(&chunk, taps as u32, weights_classic, dst)
                } else {
                    fuse_chunk_u8(&chunk, taps as u32, weights_flight, dst)
                };
                zero |= z;
                saturated |= s;
            }
            RowOut::Raw(row) => {
                let dst = row.get_mut(x0..x0 + n).unwrap_or(&mut []);
                zero |= if classic {
                    fuse_chunk_raw(&chunk, taps, square, dst)
                } else {
                    fuse_chunk_raw(&chunk, taps, plain, dst)
                };
            }
        }
        x0 += n;
    }
    (zero, saturated)
}
