//! Scharr gradient, L1 magnitude `|Gx| + |Gy|`, as an iterator over one row.
//!
//! Kernels (correlation, not normalised): `Gx = [[-3, 0, 3], [-10, 0, 10], [-3, 0, 3]]`,
//! `Gy` its transpose. On `u8` input each of `|Gx|`, `|Gy|` is at most 16·255 = 4080, so the
//! L1 magnitude is at most 8160 (13 bits), exact in `i32`.
//!
//! Row kernels either keep each column's smoothing `3u + 10m + 3d` and difference `d − u` in
//! two arrays ([`scharr_l1_chunk`]) or, for two bands at once, each in the two 16-bit lanes of
//! a `u32` ([`scharr_columns_pair`]: band `a` + band `b`·2¹⁶), from which
//! [`scharr_l1_pair`] takes both bands' `Gx` with one subtraction and both `Gy` with one
//! weighted sum.

use super::border::{Border, Neighbourhood, column, for_columns, map_neighbourhoods};
pub use super::median3::CHUNK;

/// The largest value [`scharr_l1_row`] can yield (8160).
pub const SCHARR_L1_MAX: i32 = 2 * 16 * 255;

/// `|Gx| + |Gy|` of one 3×3 neighbourhood.
#[inline(always)]
pub fn scharr_l1([l, c, r]: Neighbourhood<u8>) -> i32 {
    let smooth = |[u, m, d]: [u8; 3]| 3 * i32::from(u) + 10 * i32::from(m) + 3 * i32::from(d);
    let dy = |[u, _, d]: [u8; 3]| i32::from(d) - i32::from(u);
    let gx = smooth(r) - smooth(l);
    let gy = 3 * dy(l) + 10 * dy(c) + 3 * dy(r);
    gx.abs() + gy.abs()
}

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
/// values as [`scharr_l1_row`], with each column's smoothing `3u + 10m + 3d` and difference
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

/// The columns `x0 − 1 ..= x0 + n` (`n + 2 = sm.len() = df.len()` entries, `n ≤` [`CHUNK`]) of
/// two bands at once, rows `rows_a` and `rows_b` (all inside the frame), columns beyond the
/// edges by `border`, each in two lanes of a `u32`: `sm` holds the smoothings
/// `3(u + d) + 10m` (band `a` + band `b`·2¹⁶) and `df` the differences `d − u`
/// (band `a` + band `b`·2¹⁶, wrapping: the lanes are signed). [`scharr_l1_pair`] takes both
/// gradients from three of them.
#[inline(always)]
pub fn scharr_columns_pair(
    rows_a: [&[u8]; 3],
    rows_b: [&[u8]; 3],
    border: Border,
    x0: usize,
    sm: &mut [u32],
    df: &mut [u32],
) {
    let n = sm.len().min(df.len()).saturating_sub(2).min(CHUNK);
    let len = rows_a[1].len().min(rows_b[1].len());
    #[inline(always)]
    fn pair(a: [u8; 3], b: [u8; 3]) -> (u32, u32) {
        let lanes = |x: u8, y: u8| u32::from(x) | u32::from(y) << 16;
        let (u, m, d) = (lanes(a[0], b[0]), lanes(a[1], b[1]), lanes(a[2], b[2]));
        (3 * (u + d) + 10 * m, d.wrapping_sub(u))
    }
    let edge = |x: isize| {
        let a = column([Some(rows_a[0]), Some(rows_a[1]), Some(rows_a[2])], x, border);
        let b = column([Some(rows_b[0]), Some(rows_b[1]), Some(rows_b[2])], x, border);
        a.zip(b).map(|(a, b)| pair(a, b))
    };
    // Output i is column x0 − 1 + i; the columns inside the rows are lo..hi.
    let lo = x0.saturating_sub(1);
    let hi = (x0 + n + 1).min(len);
    let first = usize::from(x0 == 0); // output of column lo (column −1 is an edge column)
    if x0 == 0
        && let (Some((s, d)), Some(so), Some(dn)) = (edge(-1), sm.first_mut(), df.first_mut())
    {
        (*so, *dn) = (s, d);
    }
    if lo < hi {
        fn cut(r: &[u8], lo: usize, hi: usize) -> &[u8] {
            r.get(lo..hi).unwrap_or(&[])
        }
        let cut = |r| cut(r, lo, hi);
        let a = cut(rows_a[0]).iter().zip(cut(rows_a[1])).zip(cut(rows_a[2]));
        let b = cut(rows_b[0]).iter().zip(cut(rows_b[1])).zip(cut(rows_b[2]));
        let outs =
            sm.get_mut(first..).unwrap_or(&mut []).iter_mut().zip(df.get_mut(first..).unwrap_or(&mut []));
        for ((((&au, &am), &ad), ((&bu, &bm), &bd)), (so, dn)) in a.zip(b).zip(outs) {
            (*so, *dn) = pair([au, am, ad], [bu, bm, bd]);
        }
    }
    let last = x0 + n; // column of output n + 1
    if last >= len
        && let (Some((s, d)), Some(so), Some(dn)) =
            (edge(last as isize), sm.get_mut(n + 1), df.get_mut(n + 1))
    {
        (*so, *dn) = (s, d);
    }
}

/// `(|Gx| + |Gy|)` of both bands from the lane columns ([`scharr_columns_pair`]) left, centre
/// and right of a pixel: `Gx` is the lane difference of the smoothings, `Gy` the lane sum
/// `3(l + r) + 10c` of the differences (wrapping `u32` arithmetic). In each, the low lane is
/// the sign-extended low half (|·| ≤ 4080 < 2¹⁵), taken shifted up by 16; the high lane is
/// what remains, an exact multiple of 2¹⁶. The absolute values of each band are added in
/// that scale (sums < 2³⁰) and shifted down once.
#[inline(always)]
pub fn scharr_l1_pair(sm: [u32; 3], df: [u32; 3]) -> (u32, u32) {
    let gx = sm[2].wrapping_sub(sm[0]);
    let gy = df[0].wrapping_add(df[2]).wrapping_mul(3).wrapping_add(df[1].wrapping_mul(10));
    let low = |v: u32| ((v << 16) as i32).unsigned_abs();
    let high = |v: u32| (v.wrapping_sub(i32::from(v as i16) as u32) as i32).unsigned_abs();
    ((low(gx) + low(gy)) >> 16, (high(gx) + high(gy)) >> 16)
}

#[cfg(test)]
mod tests {
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
            for border in [Border::Zero, Border::Replicate, Border::Circular] {
                let (mut want_a, mut want_b) = ([0i32; 40], [0i32; 40]);
                scharr_l1_row(Some(a0), a1, Some(a2), border, want_a.iter_mut(), |g, o| *o = g);
                scharr_l1_row(Some(b0), b1, Some(b2), border, want_b.iter_mut(), |g, o| *o = g);
                for x0 in 0..w {
                    for n in 1..=w - x0 {
                        let (mut sm, mut df) = ([0u32; 42], [0u32; 42]);
                        scharr_columns_pair(
                            [a0, a1, a2],
                            [b0, b1, b2],
                            border,
                            x0,
                            &mut sm[..n + 2],
                            &mut df[..n + 2],
                        );
                        for k in 0..n {
                            let got =
                                scharr_l1_pair([sm[k], sm[k + 1], sm[k + 2]], [df[k], df[k + 1], df[k + 2]]);
                            let want = (want_a[x0 + k] as u32, want_b[x0 + k] as u32);
                            assert_eq!(got, want, "w {w} x0 {x0} n {n} k {k} {border:?}");
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
