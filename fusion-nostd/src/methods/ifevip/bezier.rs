//! Per-leaf cubic Bézier background (`QuadReconstructRefined`), exact in integers.
//!
//! For a leaf of side `n = 2^L` at `t = k/n` the Bernstein basis times `n³` is the integer
//! vector `b(k) = [(n−k)³, 3k(n−k)², 3k²(n−k), k³]` (it sums to `n³`). The patch value
//! `T(t_i)·M·P·M·T(t_j)ᵀ` is therefore `Σ_a Σ_b b_a(i)·P_ab·b_b(j) / n⁶` exactly, with the
//! numerator < 255·2⁵⁴ < 2⁶² for n ≤ 512 (an `i64`). Per row `i` the four sums
//! `Q_b = Σ_a b_a(i)·P_ab` are formed once; along the row the numerator is a cubic in `j`,
//! stepped by forward differences (three wrapping additions per pixel, exact: the true values
//! fit, and wrapping arithmetic is exact modulo 2⁶⁴). The result is rounded once to the
//! background's Q20 ([`super::BG_BITS`]): error ≤ 2⁻²¹ grey levels.

use super::BG_BITS;
use super::quadtree::Leaf;
use crate::{Error, FrameMut, FrameRef};

/// Bernstein basis times `n³` at `k`.
#[inline]
fn basis(n: i64, k: i64) -> [i64; 4] {
    let m = n - k;
    [m * m * m, 3 * k * m * m, 3 * k * k * m, k * k * k]
}

/// Local (0-based) offsets of the control points of a leaf of side `n`, along both axes:
/// `{0, n/2 − 1, 3n/4 − 1, n}` (the published 1-based `{1, n/2, 3n/4, n+1}`).
pub fn control_offsets(n: usize) -> [usize; 4] {
    [0, (n / 2).saturating_sub(1), (3 * n / 4).saturating_sub(1), n]
}

/// Marks in `rows` and `cols` (each at least `d` long) every grid row and column that holds a
/// control point of some leaf, clamped into the `d×d` grid (the replicate pad): the minimum
/// image is read only at the crossings of these lines.
pub fn control_lines(leaves: &[Leaf], d: usize, rows: &mut [bool], cols: &mut [bool]) {
    for leaf in leaves {
        for off in control_offsets(usize::from(leaf.side)) {
            let clamp = |p: usize| p.min(d.saturating_sub(1));
            if let Some(r) = rows.get_mut(clamp(usize::from(leaf.row) + off)) {
                *r = true;
            }
            if let Some(c) = cols.get_mut(clamp(usize::from(leaf.col) + off)) {
                *c = true;
            }
        }
    }
}

/// Marks in `lines` (at least `d` long) every grid line that holds a control point of *some*
/// quadtree a `d×d` grid with smallest side `min_dim` can have: the [`control_lines`] of every
/// block of every side from `min_dim` to `d`. The strip form erodes at these lines' crossings
/// while the grid streams by, before the tree is known (64 lines per axis for the published
/// 512 / 32, against ≈ 49 for a typical tree).
pub fn candidate_lines(d: usize, min_dim: usize, lines: &mut [bool]) {
    let mut n = min_dim.max(1);
    while n <= d.min(super::MAX_NORM_DIM) {
        for r0 in (0..d).step_by(n) {
            for off in control_offsets(n) {
                if let Some(l) = lines.get_mut((r0 + off).min(d.saturating_sub(1))) {
                    *l = true;
                }
            }
        }
        n *= 2;
    }
}

/// Writes every leaf's `(n+1)×(n+1)` patch into `bg` (Q20) in the given order, dropping what
/// falls outside (the one-pixel pad). Control points come from `minimum` at the local offsets
/// [`control_offsets`], clamped into the grid (the replicate pad); nothing else of `minimum`
/// is read (the crossings of [`control_lines`]).
pub fn render(leaves: &[Leaf], minimum: FrameRef<'_, i32>, bg: FrameMut<'_, i32>) -> Result<(), Error> {
    let d = minimum.width();
    if minimum.size() != bg.size() || minimum.height() != d {
        return Err(Error::SizeMismatch { expected: minimum.size(), got: bg.size() });
    }
    let control = |r: usize, c: usize| minimum.row(r).get(c).copied().unwrap_or(0);
    render_rows(leaves, d, control, 0, bg)
}

/// Rows `first .. first + bg.height()` of the `d×d` background (`bg` is `d` wide): what
/// [`render`] writes there, leaf by leaf in the given order, so every pixel keeps the last
/// patch that covers it. `control(row, col)` is the minimum image at a control point (row and
/// column already clamped into the grid). [`render`] is this over all rows; the strip form
/// renders the rows its background window needs.
pub fn render_rows(
    leaves: &[Leaf],
    d: usize,
    control: impl Fn(usize, usize) -> i32,
    first: usize,
    mut bg: FrameMut<'_, i32>,
) -> Result<(), Error> {
    if bg.width() != d {
        return Err(Error::SizeMismatch { expected: (d, bg.height()), got: bg.size() });
    }
    let end = (first + bg.height()).min(d);
    for leaf in leaves {
        let (r0, c0, n) = (usize::from(leaf.row), usize::from(leaf.col), usize::from(leaf.side));
        if !n.is_power_of_two() || !(4..=512).contains(&n) {
            return Err(Error::InvalidParameter { name: "quad_min_dim" });
        }
        // The patch's rows r0 ..= r0 + n inside the grid and inside the requested rows.
        let (lo, hi) = (r0.max(first), (r0 + n + 1).min(end));
        if lo >= hi {
            continue;
        }
        let bits = 6 * n.trailing_zeros();
        let offsets = control_offsets(n);
        let mut p = [[0i64; 4]; 4];
        for (pa, &oa) in p.iter_mut().zip(&offsets) {
            for (v, &ob) in pa.iter_mut().zip(&offsets) {
                *v = i64::from(control(
                    (r0 + oa).min(d.saturating_sub(1)),
                    (c0 + ob).min(d.saturating_sub(1)),
                ));
            }
        }
        let to_q = |f: i64| -> i32 {
            if bits > BG_BITS {
                ((f + (1i64 << (bits - BG_BITS - 1))) >> (bits - BG_BITS)) as i32
            } else {
                (f << (BG_BITS - bits)) as i32
            }
        };
        let ni = n as i64;
        for y in lo..hi {
            let bi = basis(ni, (y - r0) as i64);
            let mut q = [0i64; 4];
            for (qb, b) in q.iter_mut().zip(0..4) {
                *qb = bi.iter().zip(&p).map(|(&ba, pa)| ba * pa.get(b).copied().unwrap_or(0)).sum();
            }
            let f = |j: i64| -> i64 { basis(ni, j).iter().zip(&q).map(|(&bb, &qb)| bb * qb).sum() };
            let (f0, f1, f2, f3) = (f(0), f(1), f(2), f(3));
            let mut v = f0;
            let mut d1 = f1.wrapping_sub(f0);
            let mut d2 = f2.wrapping_sub(f1.wrapping_mul(2)).wrapping_add(f0);
            let d3 = f3.wrapping_sub(f2.wrapping_mul(3)).wrapping_add(f1.wrapping_mul(3)).wrapping_sub(f0);
            let out = bg.row_mut(y - first);
            let seg = out.get_mut(c0..).unwrap_or(&mut []);
            let len = seg.len().min(n + 1);
            #[cfg(fusion_arm_dsp)]
            if bits > BG_BITS && bits - BG_BITS < 32 {
                let half = 1i64 << (bits - BG_BITS - 1);
                super::armv7em::step_row_arm(
                    seg.get_mut(..len).unwrap_or(&mut []),
                    [v.wrapping_add(half), d1, d2, d3],
                    bits - BG_BITS,
                );
                continue;
            }
            for o in seg.iter_mut().take(len) {
                *o = to_q(v);
                v = v.wrapping_add(d1);
                d1 = d1.wrapping_add(d2);
                d2 = d2.wrapping_add(d3);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 512 / 32: the 49 lines of the 32-blocks (32k for k ≤ 16 with 512 clamped to 511,
    /// 32k + 15, 32k + 23), then the new ones per level: 64k + 31 (8), 128k + 63 (4),
    /// 256k + 127 (2), 255 (1) — the other offsets of the larger blocks coincide with lines
    /// already marked. 64 in all; a single-level tree uses the first 49.
    #[test]
    fn candidate_lines_of_the_published_grid() {
        let mut lines = [false; 512];
        candidate_lines(512, 32, &mut lines);
        assert_eq!(lines.iter().filter(|&&l| l).count(), 64);
        for leaf_side in [32usize, 64, 128, 256, 512] {
            for r0 in (0..512).step_by(leaf_side) {
                for off in control_offsets(leaf_side) {
                    assert!(lines[(r0 + off).min(511)], "side {leaf_side} at {r0} + {off}");
                }
            }
        }
    }

    #[test]
    fn constant_controls_give_a_constant_patch_and_corners_interpolate() -> Result<(), Error> {
        let d = 32;
        let mut minimum = [77i32; 32 * 32];
        let mut bg = [0i32; 32 * 32];
        let leaves = [Leaf { row: 0, col: 0, side: 32 }];
        render(&leaves, FrameRef::new(&minimum, d, d)?, FrameMut::new(&mut bg, d, d)?)?;
        assert!(bg.iter().all(|&v| v == 77 << BG_BITS));
        // Corner control point (0,0) is interpolated exactly.
        minimum[0] = 10;
        minimum[15] = 200; // control (0, n/2 − 1)
        render(&leaves, FrameRef::new(&minimum, d, d)?, FrameMut::new(&mut bg, d, d)?)?;
        assert_eq!(bg[0], 10 << BG_BITS);
        // Row 0 at t = j/32 against the f64 Bernstein sum.
        for (j, &v) in bg.iter().enumerate().take(32) {
            let t = j as f64 / 32.0;
            let u = 1.0 - t;
            let b = [u * u * u, 3.0 * t * u * u, 3.0 * t * t * u, t * t * t];
            let want = b[0] * 10.0 + b[1] * 200.0 + (b[2] + b[3]) * 77.0;
            let got = f64::from(v) / f64::from(1 << BG_BITS);
            assert!((got - want).abs() < 1e-6, "j {j}: {got} vs {want}");
        }
        Ok(())
    }
}
