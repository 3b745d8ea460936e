//! Exact 3×3 median of `u8` samples, as an iterator over one row.
//!
//! Each column of the window is sorted (3 compare-exchanges), then the median of the nine
//! samples is `med3(max of the lows, med3 of the middles, min of the highs)`, an exact
//! identity for 3×3 windows. Rows outside the frame are `None` (zeros, MATLAB `medfilt2`'s
//! default); the columns beyond the edges follow the [`Border`] rule.

use super::border::{Border, for_columns};
#[cfg(test)]
use super::border::{Neighbourhood, map_neighbourhoods};

#[inline]
fn sort3([a, b, c]: [u8; 3]) -> [u8; 3] {
    let (lo, hi) = (a.min(b), a.max(b));
    let (mid, hi) = (hi.min(c), hi.max(c));
    let (lo, mid) = (lo.min(mid), lo.max(mid));
    [lo, mid, hi]
}

#[inline]
fn med3(a: u8, b: u8, c: u8) -> u8 {
    a.max(b).min(a.min(b).max(c))
}

#[cfg(test)]
/// The exact median of a 3×3 neighbourhood.
#[inline(always)]
pub fn median9([l, c, r]: Neighbourhood<u8>) -> u8 {
    let [l0, l1, l2] = sort3(l);
    let [c0, c1, c2] = sort3(c);
    let [r0, r1, r2] = sort3(r);
    med3(l0.max(c0).max(r0), med3(l1, c1, r1), l2.min(c2).min(r2))
}

#[cfg(test)]
/// Calls `f(median, item)` with the 3×3 median of every pixel of `mid` (left to right) with the next item of `out`,
/// rows `up` / `down` around it (`None`: zeros).
#[inline(always)]
pub fn median3_row<U>(
    up: Option<&[u8]>,
    mid: &[u8],
    down: Option<&[u8]>,
    border: Border,
    out: impl IntoIterator<Item = U>,
    mut f: impl FnMut(u8, U),
) {
    map_neighbourhoods(up, mid, down, border, out, |n, o| f(median9(n), o));
}

/// Most outputs of one [`median3_chunk`] call (its column buffers live on the stack).
pub const CHUNK: usize = 256;

/// The medians of the pixels `x0 .. x0 + out.len()` (at most [`CHUNK`]) of `mid`, rows `up` /
/// `down` around it (`None`: zeros), columns beyond the edges by `border`: the same values as
/// `median3_row`, with each column sorted once for its three windows.
#[inline(always)]
pub fn median3_chunk(rows: [Option<&[u8]>; 3], border: Border, x0: usize, out: &mut [u8]) {
    let n = out.len().min(CHUNK);
    let mut lo = [0u8; CHUNK + 2];
    let mut mi = [0u8; CHUNK + 2];
    let mut hi = [0u8; CHUNK + 2];
    for_columns(rows, border, x0, n, |i, c| {
        if let (Some(l), Some(m), Some(h)) = (lo.get_mut(i), mi.get_mut(i), hi.get_mut(i)) {
            [*l, *m, *h] = sort3(c);
        }
    });
    let cols = lo.windows(3).zip(mi.windows(3)).zip(hi.windows(3));
    for (((l, m), h), o) in cols.zip(out.iter_mut().take(n)) {
        if let (&[l0, l1, l2], &[m0, m1, m2], &[h0, h1, h2]) = (l, m, h) {
            *o = med3(l0.max(l1).max(l2), med3(m0, m1, m2), h0.min(h1).min(h2));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(v: [u8; 9]) -> u8 {
        let mut v = v;
        v.sort_unstable();
        v.get(4).copied().unwrap_or(0)
    }

    #[test]
    fn equals_sorting_on_random_windows() {
        let mut seed = 7u32;
        let mut next = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            // Few distinct values so that ties are common.
            ((seed >> 24) % 6) as u8 * 40
        };
        for _ in 0..2000 {
            let up: [u8; 3] = core::array::from_fn(|_| next());
            let mid: [u8; 3] = core::array::from_fn(|_| next());
            let dn: [u8; 3] = core::array::from_fn(|_| next());
            let mut row = [0u8; 3];
            median3_row(Some(&up[..]), &mid, Some(&dn[..]), Border::Zero, row.iter_mut(), |m, o| *o = m);
            let got = row.get(1).copied();
            let [a, b, c] = up;
            let [d, e, f] = mid;
            let [g, h, i] = dn;
            assert_eq!(got, Some(brute([a, b, c, d, e, f, g, h, i])));
        }
    }

    /// The chunked medians equal the neighbourhood medians, every border, chunk offsets and
    /// missing rows included.
    #[test]
    fn chunks_equal_rows() {
        let mut seed = 3u32;
        let mut row = |n: usize| -> [u8; 40] {
            let mut r = [0u8; 40];
            for v in r.iter_mut().take(n) {
                seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                *v = ((seed >> 24) % 5) as u8 * 60;
            }
            r
        };
        for w in [1usize, 2, 3, 9, 40] {
            let (a, b, c) = (row(w), row(w), row(w));
            let (a, b, c) = (&a[..w], &b[..w], &c[..w]);
            for (up, down) in [(Some(a), Some(c)), (None, Some(c)), (Some(a), None), (None, None)] {
                for border in [Border::Zero, Border::Replicate, Border::Circular] {
                    let mut want = [0u8; 40];
                    median3_row(up, b, down, border, want.iter_mut(), |m, o| *o = m);
                    for x0 in 0..w {
                        for n in 1..=w - x0 {
                            let mut got = [0u8; 40];
                            median3_chunk([up, Some(b), down], border, x0, &mut got[..n]);
                            assert_eq!(got[..n], want[x0..x0 + n], "w {w} x0 {x0} n {n} {border:?}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn zero_padding_makes_corners_zero() {
        let mid = [200u8, 200, 200];
        let dn = [200u8, 200, 200];
        let mut row = [9u8; 3];
        median3_row(None, &mid, Some(&dn[..]), Border::Zero, row.iter_mut(), |m, o| *o = m);
        // Corner: 4 samples of 200, 5 zeros → 0. Edge: 6 of 200, 3 zeros → 200.
        assert_eq!(row, [0, 200, 0]);
    }
}
