//! Scharr gradient, L1 magnitude `|Gx| + |Gy|`, as an iterator over one row.
//!
//! Kernels (correlation, not normalised): `Gx = [[-3, 0, 3], [-10, 0, 10], [-3, 0, 3]]`,
//! `Gy` its transpose. On `u8` input each of `|Gx|`, `|Gy|` is at most 16·255 = 4080, so the
//! L1 magnitude is at most 8160 (13 bits), exact in `i32`.

use super::border::{Border, Neighbourhood, for_columns, map_neighbourhoods};
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
