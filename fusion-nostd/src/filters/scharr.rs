//! Scharr gradient, L1 magnitude `|Gx| + |Gy|`, as an iterator over one row.
//!
//! Kernels (correlation, not normalised): `Gx = [[-3, 0, 3], [-10, 0, 10], [-3, 0, 3]]`,
//! `Gy` its transpose. On `u8` input each of `|Gx|`, `|Gy|` is at most 16·255 = 4080, so the
//! L1 magnitude is at most 8160 (13 bits), exact in `i32`.
//!
//! Row kernels either keep each column's smoothing `3u + 10m + 3d` and difference `d − u` in
//! two arrays ([`scharr_l1_chunk`]) or, for two bands at once, each in the two 16-bit lanes of
//! a `u32` ([`scharr_columns_pair`]: band `a` + band `b`·2¹⁶, differences biased by 256),
//! from which [`scharr_l1_pair`] takes both bands' `Gx` with one subtraction and both `Gy`
//! with one weighted sum (on Arm with the DSP lane instructions).

use super::border::{Border, column, for_columns};
#[cfg(test)]
use super::border::{Neighbourhood, map_neighbourhoods};
pub use super::median3::CHUNK;

#[cfg(test)]
/// The largest value `scharr_l1_row` can yield (8160).
pub const SCHARR_L1_MAX: i32 = 2 * 16 * 255;

#[cfg(test)]
/// `|Gx| + |Gy|` of one 3×3 neighbourhood.
#[inline(always)]
pub fn scharr_l1([l, c, r]: Neighbourhood<u8>) -> i32 {
    let smooth = |[u, m, d]: [u8; 3]| 3 * i32::from(u) + 10 * i32::from(m) + 3 * i32::from(d);
    let dy = |[u, _, d]: [u8; 3]| i32::from(d) - i32::from(u);
    let gx = smooth(r) - smooth(l);
    let gy = 3 * dy(l) + 10 * dy(c) + 3 * dy(r);
    gx.abs() + gy.abs()
}

#[cfg(test)]
/// Calls `f(|Gx| + |Gy|, item)` for the pixels of `mid` (left to right) with the next item of `out`, rows `up` / `down`
/// around it (`None`: zeros), columns beyond the edges by `border`.
#[inline(always)]
pub fn scharr_l1_row<U>(
    up: Option<&[u8]>,
    mid: &[u8],
    down: Option<&[u8]>,
    border: Border,
    out: impl IntoIterator<Item = U>,
    mut f: impl FnMut(i32, U),
) {
    map_neighbourhoods(up, mid, down, border, out, |n, o| f(scharr_l1(n), o));
}

/// `|Gx| + |Gy|` of the pixels `x0 .. x0 + out.len()` (at most [`CHUNK`]) of `mid`, rows
/// `up` / `down` around it (`None`: zeros), columns beyond the edges by `border`: the same
/// values as `scharr_l1_row`, with each column's smoothing `3u + 10m + 3d` and difference
/// `d − u` computed once for its three windows.
#[inline(always)]
pub fn scharr_l1_chunk(rows: [Option<&[u8]>; 3], border: Border, x0: usize, out: &mut [i32]) {
    let n = out.len().min(CHUNK);
    let mut smooth = [0i32; CHUNK + 2];
    let mut dy = [0i32; CHUNK + 2];
    for_columns(rows, border, x0, n, |i, [u, m, d]| {
        if let (Some(s), Some(g)) = (smooth.get_mut(i), dy.get_mut(i)) {
            let (u, m, d) = (i32::from(u), i32::from(m), i32::from(d));
            *s = 3 * (u + d) + 10 * m;
            *g = d - u;
        }
    });
    for ((s, g), o) in smooth.windows(3).zip(dy.windows(3)).zip(out.iter_mut().take(n)) {
        if let (&[sl, _, sr], &[gl, gc, gr]) = (s, g) {
            let gx = sr - sl;
            let gy = 3 * (gl + gr) + 10 * gc;
            *o = gx.abs() + gy.abs();
        }
    }
}

/// Two `u8` samples in the two 16-bit lanes of a lane word: `a + b·2¹⁶` (kept as an `i32`
/// bit pattern, the scratch planes' type), the input of [`scharr_columns_pair`].
#[inline(always)]
pub fn lane_pair(a: u8, b: u8) -> i32 {
    (u32::from(a) | u32::from(b) << 16) as i32
}

/// The columns `x0 − 1 ..= x0 + n` (`n + 2 = out.len()` entries, `n ≤` [`CHUNK`]) of two
/// bands at once, from rows of lane words ([`lane_pair`]: band `a` + band `b`·2¹⁶; all three
/// rows inside the frame), columns beyond the edges by `border`, handed to
/// `store(&mut out[i], sm, df)` as two words of two 16-bit lanes each: `sm` the smoothing
/// `3(u + d) + 10m` and `df` the difference plus 256, `d − u + 256 ∈ [1, 511]`. Every lane
/// is non-negative, so sums and multiples of these words stay lane by lane while each lane
/// stays below 2¹⁶. [`scharr_l1_pair`] takes both gradients from three of them.
#[inline(always)]
pub fn scharr_columns_pair<C>(
    rows: [&[i32]; 3],
    border: Border,
    x0: usize,
    out: &mut [C],
    store: impl Fn(&mut C, u32, u32),
) {
    let n = out.len().saturating_sub(2).min(CHUNK);
    let len = rows[1].len();
    #[inline(always)]
    fn pair([u, m, d]: [i32; 3]) -> (u32, u32) {
        let (u, m, d) = (u as u32, m as u32, d as u32);
        (3 * (u + d) + 10 * m, d + DF_BIAS - u)
    }
    let edge = |x: isize| column([Some(rows[0]), Some(rows[1]), Some(rows[2])], x, border).map(pair);
    // Output i is column x0 − 1 + i; the columns inside the rows are lo..hi.
    let lo = x0.saturating_sub(1);
    let hi = (x0 + n + 1).min(len);
    let first = usize::from(x0 == 0); // output of column lo (column −1 is an edge column)
    if x0 == 0
        && let (Some((s, d)), Some(o)) = (edge(-1), out.first_mut())
    {
        store(o, s, d);
    }
    if lo < hi {
        fn cut(r: &[i32], lo: usize, hi: usize) -> &[i32] {
            r.get(lo..hi).unwrap_or(&[])
        }
        let cols = cut(rows[0], lo, hi).iter().zip(cut(rows[1], lo, hi)).zip(cut(rows[2], lo, hi));
        for (((&u, &m), &d), o) in cols.zip(out.get_mut(first..).unwrap_or(&mut [])) {
            let (s, d) = pair([u, m, d]);
            store(o, s, d);
        }
    }
    let last = x0 + n; // column of output n + 1
    if last >= len
        && let (Some((s, d)), Some(o)) = (edge(last as isize), out.get_mut(n + 1))
    {
        store(o, s, d);
    }
}

/// The bias of each lane of the differences written by [`scharr_columns_pair`].
const DF_BIAS: u32 = 256 | 256 << 16;
/// The bias of each lane of `3(l + r) + 10c` of three biased differences: 16·256.
const GY_BIAS: u32 = 4096 | 4096 << 16;

/// `|Gx| + |Gy|` of both bands, packed `band a + band b·2¹⁶` (each ≤ 8160), from the lane
/// columns ([`scharr_columns_pair`]) left, centre and right of a pixel (the smoothings of the
/// left and right ones, the differences of all three): `Gx` is the lane
/// difference of the smoothings (`|·| ≤ 4080`), `Gy` the lane sum `3(l + r) + 10c` of the
/// biased differences, `Gy + 4096 ∈ [16, 8176]` in each lane (no carry between lanes).
///
/// On Arm, seven DSP lane instructions (`ssub16`, `sel`, `uadd16`: each lane difference and
/// its negation, the absolute value by selecting the negation where it is non-negative, the
/// lane sums); else
/// the same values lane by lane: the low lane of `Gx` is the sign-extended low half (taken
/// shifted up by 16), the high lane what remains (an exact multiple of 2¹⁶).
#[inline(always)]
pub fn scharr_l1_pair([sm_l, sm_r]: [u32; 2], df: [u32; 3]) -> u32 {
    let gy = df[0].wrapping_add(df[2]).wrapping_mul(3).wrapping_add(df[1].wrapping_mul(10));
    #[cfg(fusion_arm_dsp)]
    {
        crate::arch::lane_abs_sum(sm_l, sm_r, gy, GY_BIAS)
    }
    #[cfg(not(fusion_arm_dsp))]
    {
        let gx = sm_r.wrapping_sub(sm_l);
        let low = ((gx << 16) as i32).unsigned_abs() >> 16;
        let high = (gx.wrapping_sub(i32::from(gx as i16) as u32) as i32).unsigned_abs() >> 16;
        let lane = |v: u32| (v as i32 - 4096).unsigned_abs();
        let _ = GY_BIAS;
        (low + lane(gy & 0xFFFF)) | (high + lane(gy >> 16)) << 16
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    #[test]
    fn chunks_equal_rows() {
        let mut seed = 8u32;
        let mut row = || -> [u8; 40] {
            core::array::from_fn(|_| {
                seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                (seed >> 24) as u8
            })
        };
        for w in [1usize, 2, 3, 9, 40] {
            let (a, b, c) = (row(), row(), row());
            let (a, b, c) = (&a[..w], &b[..w], &c[..w]);
            for (up, down) in [(Some(a), Some(c)), (None, Some(c)), (Some(a), None), (None, None)] {
                for border in [Border::Zero, Border::Replicate, Border::Circular] {
                    let mut want = [0i32; 40];
                    scharr_l1_row(up, b, down, border, want.iter_mut(), |g, o| *o = g);
                    for x0 in 0..w {
                        for n in 1..=w - x0 {
                            let mut got = [0i32; 40];
                            scharr_l1_chunk([up, Some(b), down], border, x0, &mut got[..n]);
                            assert_eq!(got[..n], want[x0..x0 + n], "w {w} x0 {x0} n {n} {border:?}");
                        }
                    }
                }
            }
        }
    }

    /// The Arm path of [`scharr_l1_pair`] instruction by instruction (`ssub16`: lane
    /// differences, GE per lane where the difference is ≥ 0; `sel`: lanes of the first operand
    /// where GE, else of the second; `uadd16`: lane sums), for the tests on any host.
    fn dsp_model(sm: [u32; 2], df: [u32; 3]) -> u32 {
        let lanes = |v: u32| [v as u16 as i16, (v >> 16) as u16 as i16];
        let pack = |l: [i32; 2]| (l[0] as u16 as u32) | (l[1] as u16 as u32) << 16;
        let ssub16 = |a: u32, b: u32| {
            let (a, b) = (lanes(a), lanes(b));
            let d = [i32::from(a[0]) - i32::from(b[0]), i32::from(a[1]) - i32::from(b[1])];
            (pack(d), [d[0] >= 0, d[1] >= 0])
        };
        let sel = |a: u32, b: u32, ge: [bool; 2]| {
            let lane = |v: u32, i: usize| (v >> (16 * i)) & 0xFFFF;
            (if ge[0] { lane(a, 0) } else { lane(b, 0) })
                | (if ge[1] { lane(a, 1) } else { lane(b, 1) }) << 16
        };
        let uadd16 = |a: u32, b: u32| ((a & 0xFFFF) + (b & 0xFFFF)) & 0xFFFF | ((a >> 16) + (b >> 16)) << 16;
        let gy = df[0].wrapping_add(df[2]).wrapping_mul(3).wrapping_add(df[1].wrapping_mul(10));
        let (x, _) = ssub16(sm[1], sm[0]);
        let (t, ge) = ssub16(sm[0], sm[1]);
        let x = sel(t, x, ge);
        let (y, _) = ssub16(gy, GY_BIAS);
        let (t, ge) = ssub16(GY_BIAS, gy);
        let y = sel(t, y, ge);
        uadd16(x, y)
    }

    /// The two-band lane columns give both bands' gradients, every border and chunk offset.
    #[test]
    fn pair_columns_equal_rows() {
        let mut seed = 77u32;
        let mut row = || -> [u8; 40] {
            core::array::from_fn(|_| {
                seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                match (seed >> 29) % 4 {
                    0 => 0,
                    1 => 255,
                    _ => (seed >> 21) as u8,
                }
            })
        };
        for w in [1usize, 2, 3, 9, 40] {
            let rows: [[u8; 40]; 6] = core::array::from_fn(|_| row());
            let [a0, a1, a2, b0, b1, b2] = rows.each_ref().map(|r| &r[..w]);
            let lanes = |a: &[u8], b: &[u8]| -> std::vec::Vec<i32> {
                a.iter().zip(b).map(|(&a, &b)| lane_pair(a, b)).collect()
            };
            let (l0, l1, l2) = (lanes(a0, b0), lanes(a1, b1), lanes(a2, b2));
            for border in [Border::Zero, Border::Replicate, Border::Circular] {
                let (mut want_a, mut want_b) = ([0i32; 40], [0i32; 40]);
                scharr_l1_row(Some(a0), a1, Some(a2), border, want_a.iter_mut(), |g, o| *o = g);
                scharr_l1_row(Some(b0), b1, Some(b2), border, want_b.iter_mut(), |g, o| *o = g);
                for x0 in 0..w {
                    for n in 1..=w - x0 {
                        let mut cols = [(0u32, 0u32); 42];
                        let store = |c: &mut (u32, u32), s, d| *c = (s, d);
                        scharr_columns_pair([&l0, &l1, &l2], border, x0, &mut cols[..n + 2], store);
                        let (sm, df): (std::vec::Vec<u32>, std::vec::Vec<u32>) = cols.iter().copied().unzip();
                        for k in 0..n {
                            let got = scharr_l1_pair([sm[k], sm[k + 2]], [df[k], df[k + 1], df[k + 2]]);
                            let want = want_a[x0 + k] as u32 | (want_b[x0 + k] as u32) << 16;
                            assert_eq!(got, want, "w {w} x0 {x0} n {n} k {k} {border:?}");
                            let model = dsp_model([sm[k], sm[k + 2]], [df[k], df[k + 1], df[k + 2]]);
                            assert_eq!(model, want, "DSP model: w {w} x0 {x0} n {n} k {k} {border:?}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn hand_computed_gradients() {
        // A vertical step 0 | 100 between columns 0 and 1: Gx = 16·100 at both columns next
        // to the step, Gy = 0 with replicate rows.
        let row = [0u8, 100, 100, 100];
        let mut g = [0i32; 4];
        scharr_l1_row(Some(&row[..]), &row, Some(&row[..]), Border::Replicate, g.iter_mut(), |v, o| *o = v);
        assert_eq!(g, [1600, 1600, 0, 0]);
        // A horizontal step (up 0, down 50): Gy = 16·50 everywhere with replicate columns.
        let up = [0u8; 3];
        let dn = [50u8; 3];
        let mut g = [0i32; 3];
        scharr_l1_row(Some(&up[..]), &up, Some(&dn[..]), Border::Replicate, g.iter_mut(), |v, o| *o = v);
        assert_eq!(g, [800, 800, 800]);
        // A checkerboard stays within the documented maximum.
        let a = [255u8, 0, 255];
        let b = [0u8, 255, 0];
        let mut g = [0i32; 3];
        scharr_l1_row(Some(&a[..]), &b, Some(&a[..]), Border::Zero, g.iter_mut(), |v, o| *o = v);
        assert!(g.iter().all(|&v| (0..=SCHARR_L1_MAX).contains(&v)));
        assert_eq!(g.get(1), Some(&0), "symmetric centre: no gradient");
    }
}
