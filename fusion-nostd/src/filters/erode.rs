//! Grey erosion by a flat rectangle, O(1) per pixel (van Herk / Gil–Werman).
//!
//! Each row is split into blocks of the window length `L = before + 1 + after`; with the
//! suffix minimum `h` and the prefix minimum `g` of every block, the minimum over
//! `[x − before, x + after]` is `min(h[x − before], g[x + after])` — three comparisons per
//! pixel whatever `L`. Samples outside the image are ignored (the window is clipped), as
//! MATLAB's `imerode` does. The separable 2-D erosion is two row passes, each writing its
//! result transposed ([`min_rows_transposed`]), so the second pass gives the image back in
//! its own orientation. Any window length; one row of scratch.

use crate::{Error, FrameRef};

/// Rows per transposed tile: the row results go to `tmp` and are written to `dst` in runs of
/// this many (contiguous in the transposed plane) when `tmp` has room, instead of one
/// scattered element per column and row. Cache-bound hosts only: on the flight targets the
/// extra copy would cost more instructions than the scattered writes.
const TILE: usize = if cfg!(target_arch = "x86_64") { 16 } else { 1 };

/// For every row `y` of `src` and every `x`, `dst[x·H + y] = min(src[y][max(0, x−before) ..=
/// min(W−1, x+after)])`, where `dst` is the `H × W` transposed plane (`H` = `src.height()`).
/// `tmp` (at least `W` long) holds one row of suffix minima, and with `(TILE + 1)·W` the
/// results of `TILE` rows before they are written transposed.
pub fn min_rows_transposed(
    src: FrameRef<'_, i32>,
    dst: &mut [i32],
    tmp: &mut [i32],
    before: usize,
    after: usize,
) -> Result<(), Error> {
    let (w, h) = src.size();
    let needed = w * h;
    if dst.len() < needed {
        return Err(Error::ScratchTooSmall { needed, capacity: dst.len() });
    }
    let capacity = tmp.len();
    if capacity < w {
        return Err(Error::ScratchTooSmall { needed: w, capacity });
    }
    let tile = if TILE > 1 && capacity >= (TILE + 1) * w { TILE } else { 1 };
    let (suffix, rest) = tmp.split_at_mut(w);
    let mut y0 = 0;
    while y0 < h {
        let rows = tile.min(h - y0);
        if tile == 1 {
            // One row, written straight into its column slots.
            let row = src.row(y0);
            min_row(row, suffix, before, after, |x, m| {
                if let Some(d) = dst.get_mut(x * h + y0) {
                    *d = m;
                }
            });
        } else {
            for t in 0..rows {
                let row = src.row(y0 + t);
                let out = rest.get_mut(t * w..t * w + w).unwrap_or(&mut []);
                min_row(row, suffix, before, after, |x, m| {
                    if let Some(o) = out.get_mut(x) {
                        *o = m;
                    }
                });
            }
            for (x, column) in dst.chunks_exact_mut(h.max(1)).take(w).enumerate() {
                let run = column.get_mut(y0..y0 + rows).unwrap_or(&mut []);
                for (t, d) in run.iter_mut().enumerate() {
                    *d = rest.get(t * w + x).copied().unwrap_or(i32::MAX);
                }
            }
        }
        y0 += rows;
    }
    Ok(())
}

/// The window minima of one row, `put(x, min(row[max(0, x−before) ..= min(W−1, x+after)]))`
/// for every `x` in order; `tmp` (`W` long) holds the block suffix minima.
#[inline(always)]
fn min_row(row: &[i32], tmp: &mut [i32], before: usize, after: usize, mut put: impl FnMut(usize, i32)) {
    let w = row.len();
    let len = before + 1 + after;
    // Suffix minima within blocks.
    for (block, out) in row.chunks(len.max(1)).zip(tmp.chunks_mut(len.max(1))) {
        let mut m = i32::MAX;
        for (&v, o) in block.iter().zip(out.iter_mut()).rev() {
            m = m.min(v);
            *o = m;
        }
    }
    // Forward: prefix minimum up to x + after, suffix minimum from x − before. Block
    // indices and offsets are counted, not divided.
    let mut g = i32::MAX;
    let mut next = row.iter(); // samples entering the prefix minimum
    let (mut p, mut p_off, mut p_blk) = (0usize, 0usize, 0usize); // next sample, its offset and block
    let (mut hi_blk, mut lo_off, mut lo_blk) = (0usize, 0usize, 0usize);
    for x in 0..w {
        let hi = (x + after).min(w - 1);
        while p <= hi {
            let v = next.next().copied().unwrap_or(i32::MAX);
            g = if p_off == 0 { v } else { g.min(v) };
            hi_blk = p_blk;
            p += 1;
            p_off += 1;
            if p_off == len {
                p_off = 0;
                p_blk += 1;
            }
        }
        if x > before {
            lo_off += 1;
            if lo_off == len {
                lo_off = 0;
                lo_blk += 1;
            }
        }
        let lo = x.saturating_sub(before);
        let hlo = tmp.get(lo).copied().unwrap_or(i32::MAX);
        // `lo` and `hi` share a block only when `lo` starts it (then the prefix minimum
        // `g` is the window's) or `hi` is the row end (then the suffix minimum `h[lo]` is).
        let m = if lo_blk != hi_blk {
            hlo.min(g)
        } else if lo_off == 0 {
            g
        } else {
            hlo
        };
        put(x, m);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(row: &[i32], before: usize, after: usize) -> Vec<i32> {
        (0..row.len())
            .map(|x| {
                let lo = x.saturating_sub(before);
                let hi = (x + after).min(row.len() - 1);
                row[lo..=hi].iter().copied().min().unwrap()
            })
            .collect()
    }

    extern crate std;
    use std::vec::Vec;

    #[test]
    fn matches_brute_force() -> Result<(), Error> {
        let mut seed = 12345u32;
        for w in [1usize, 2, 5, 31, 32, 33, 100] {
            for (before, after) in [(0usize, 0usize), (15, 16), (1, 0), (0, 3), (4, 4), (40, 2)] {
                let h = 37;
                let data: Vec<i32> = (0..w * h)
                    .map(|_| {
                        seed = seed.wrapping_mul(1103515245).wrapping_add(12345);
                        ((seed >> 16) % 256) as i32
                    })
                    .collect();
                let src = FrameRef::new(&data, w, h)?;
                // One row of tmp (column writes) and room for tiles.
                for tmp_len in [w, (TILE.max(2) + 1) * w] {
                    let mut dst = std::vec![0i32; w * h];
                    let mut tmp = std::vec![0i32; tmp_len];
                    min_rows_transposed(src, &mut dst, &mut tmp, before, after)?;
                    for y in 0..h {
                        let want = brute(&data[y * w..(y + 1) * w], before, after);
                        for x in 0..w {
                            assert_eq!(dst[x * h + y], want[x], "w {w} ({before},{after}) x {x} y {y}");
                        }
                    }
                }
            }
        }
        Ok(())
    }
}
