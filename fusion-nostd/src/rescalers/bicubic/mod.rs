//! Bicubic (Keys, a = −0.75) 2× kernels for u8 frames, bit-exact with OpenCV `INTER_CUBIC`.
//!
//! At factor 2 the weights are exact dyadic numbers:
//!
//! | case | taps | weights |
//! |---|---|---|
//! | up, even output `2m` | `m−2 … m+1` | `(−9, 67, 225, −27)/256` |
//! | up, odd output `2m+1` | `m−1 … m+2` | `(−27, 225, 67, −9)/256` |
//! | down, output `d` | `2d−1 … 2d+2` | `(−3, 19, 19, −3)/32` |
//!
//! Arithmetic (Q formats): the horizontal pass keeps the exact `i32` sum of `weight·pixel`
//! (Q8 up, Q5 down; never rounded or clamped — the range is `[−9180, 74460]` up and
//! `[−1530, 9690]` down). The vertical pass forms the exact numerator `N` (Q16 up, max
//! `22 072 800`; Q10 down, `|N| ≤ 377 400`), all in `i32`, then rounds half to even and
//! saturates to `0..=255`. No floating point.
//!
//! The frame is processed in column chunks so the horizontal rows live in a small stack
//! buffer (4 rows × 512 `i32` = 8 KiB) whatever the frame width; a ring of those 4 rows
//! holds each source row's horizontal pass for all the output rows that read it.

use crate::{FrameMut, FrameRef};

/// The Armv7E-M form of the vertical pass.
#[cfg(fusion_arm_dsp)]
mod armv7em;

/// Source columns per chunk (the up kernel writes twice as many output columns).
const CHUNK: usize = 256;
/// Horizontal-pass row length per chunk.
const HROW: usize = 2 * CHUNK;

/// Rounds `n / 2^S` half to even and saturates to u8.
#[inline(always)]
fn round_even_sat<const S: u32>(n: i32) -> u8 {
    let half_minus_one = (1i32 << (S - 1)) - 1;
    let q = (n + half_minus_one + ((n >> S) & 1)) >> S;
    q.clamp(0, 255) as u8
}

/// A ring of horizontal-pass rows keyed by their (unclamped) source row index.
struct RowRing {
    rows: [[i32; HROW]; 4],
    keys: [isize; 4],
}

impl RowRing {
    fn new() -> Self {
        Self { rows: [[0; HROW]; 4], keys: [isize::MIN; 4] }
    }

    /// The horizontal row for source row `r`, computed by `fill` if not cached. Callers ask
    /// for windows of 4 consecutive rows, so slot `r mod 4` never evicts a row still needed.
    #[inline(always)]
    fn get(&mut self, r: isize, fill: impl FnOnce(isize, &mut [i32; HROW])) -> &[i32; HROW] {
        let slot = r.rem_euclid(4) as usize;
        let (key, row) = match (self.keys.get_mut(slot), self.rows.get_mut(slot)) {
            (Some(k), Some(row)) => (k, row),
            _ => return &EMPTY_ROW, // unreachable: slot < 4
        };
        if *key != r {
            fill(r, row);
            *key = r;
        }
        row
    }

    /// The four rows `r0 … r0+3`, filling missing ones.
    #[inline(always)]
    fn window(&mut self, r0: isize, mut fill: impl FnMut(isize, &mut [i32; HROW])) -> [&[i32; HROW]; 4] {
        for r in r0..r0 + 4 {
            self.get(r, &mut fill);
        }
        let slot = |r: isize| r.rem_euclid(4) as usize;
        let row = |r: isize| self.rows.get(slot(r)).unwrap_or(&EMPTY_ROW);
        [row(r0), row(r0 + 1), row(r0 + 2), row(r0 + 3)]
    }
}

static EMPTY_ROW: [i32; HROW] = [0; HROW];

/// Copies source columns `c0 - left .. c0 + n + right` of `row` into `pad` with replicate
/// border and returns the filled prefix.
#[inline(always)]
fn padded_segment<'p>(
    row: &[u8],
    c0: usize,
    n: usize,
    left: usize,
    right: usize,
    pad: &'p mut [i32],
) -> &'p [i32] {
    let len = n + left + right;
    let seg = pad.get_mut(..len).unwrap_or(&mut []);
    // Columns before the row start take the first pixel, after its end the last; the rest is a
    // plain widening copy (which the compiler vectorises).
    let before = left.saturating_sub(c0).min(len);
    let start = c0.saturating_sub(left);
    let inside = row.len().saturating_sub(start).min(len - before);
    let first = i32::from(row.first().copied().unwrap_or(0));
    let last = i32::from(row.last().copied().unwrap_or(0));
    let Some((head, rest)) = seg.split_at_mut_checked(before) else { return &[] };
    let Some((body, tail)) = rest.split_at_mut_checked(inside) else { return &[] };
    head.fill(first);
    for (p, v) in body.iter_mut().zip(row.get(start..).unwrap_or(&[])) {
        *p = i32::from(*v);
    }
    tail.fill(last);
    seg
}

crate::cpu::dispatch! {
    /// 2× upscale: `src` W×H → `dst` 2W×2H (sizes checked by the caller).
    pub(crate) fn up2_u8(src: FrameRef<'_, u8>, dst: FrameMut<'_, u8>) => up2_u8_kernel
}

crate::cpu::dispatch! {
    /// 2× downscale: `src` 2W×2H → `dst` W×H (sizes checked by the caller).
    pub(crate) fn down2_u8(src: FrameRef<'_, u8>, dst: FrameMut<'_, u8>) => down2_u8_kernel
}

/// Horizontal 2× up pass of one source row over a chunk: `2n` interleaved outputs (Q8).
#[inline(always)]
fn horizontal_up(row: &[u8], c0: usize, n: usize, pad: &mut [i32; CHUNK + 4], out: &mut [i32; HROW]) {
    let p = padded_segment(row, c0, n, 2, 2, pad);
    let at = |k: usize| p.get(k..).unwrap_or(&[]);
    let taps = p.iter().zip(at(1)).zip(at(2)).zip(at(3)).zip(at(4));
    for (o, ((((a, b), c), d), e)) in out.chunks_exact_mut(2).zip(taps) {
        if let [even, odd] = o {
            *even = -9 * a + 67 * b + 225 * c - 27 * d;
            *odd = -27 * b + 225 * c + 67 * d - 9 * e;
        }
    }
}

/// Horizontal 2× down pass of one source row over a chunk: `n` outputs (Q5).
#[inline(always)]
fn horizontal_down(row: &[u8], c0: usize, n: usize, pad: &mut [i32; HROW + 4], out: &mut [i32; HROW]) {
    let p = padded_segment(row, 2 * c0, 2 * n, 1, 2, pad);
    let pairs = p.chunks_exact(2).zip(p.get(2..).unwrap_or(&[]).chunks_exact(2));
    for (o, (ab, cd)) in out.iter_mut().zip(pairs).take(n) {
        if let ([a, b], [c, d]) = (ab, cd) {
            *o = -3 * a + 19 * b + 19 * c - 3 * d;
        }
    }
}

#[inline(always)]
fn up2_u8_kernel(src: FrameRef<'_, u8>, mut dst: FrameMut<'_, u8>) {
    let (w, h) = src.size();
    let mut ring = RowRing::new();
    let mut pad = [0i32; CHUNK + 4];
    for c0 in (0..w).step_by(CHUNK) {
        let n = CHUNK.min(w - c0);
        ring.keys = [isize::MIN; 4];
        let mut fill =
            |r: isize, out: &mut [i32; HROW]| horizontal_up(src.row_clamped(r), c0, n, &mut pad, out);
        for m in 0..h as isize {
            let rows = ring.window(m - 2, &mut fill);
            let out = dst.row_mut(2 * m as usize).get_mut(2 * c0..2 * (c0 + n)).unwrap_or(&mut []);
            vertical::<16, -9, 67, 225, -27>(out, rows);
            let rows = ring.window(m - 1, &mut fill);
            let out = dst.row_mut(2 * m as usize + 1).get_mut(2 * c0..2 * (c0 + n)).unwrap_or(&mut []);
            vertical::<16, -27, 225, 67, -9>(out, rows);
        }
    }
}

#[inline(always)]
fn down2_u8_kernel(src: FrameRef<'_, u8>, mut dst: FrameMut<'_, u8>) {
    let (w, h) = dst.size();
    let mut ring = RowRing::new();
    let mut pad = [0i32; HROW + 4];
    // A chunk of `CHUNK` output columns reads 2·CHUNK + 3 source columns.
    for c0 in (0..w).step_by(CHUNK) {
        let n = CHUNK.min(w - c0);
        ring.keys = [isize::MIN; 4];
        let mut fill =
            |r: isize, out: &mut [i32; HROW]| horizontal_down(src.row_clamped(r), c0, n, &mut pad, out);
        for d in 0..h {
            let rows = ring.window(2 * d as isize - 1, &mut fill);
            let out = dst.row_mut(d).get_mut(c0..c0 + n).unwrap_or(&mut []);
            vertical::<10, -3, 19, 19, -3>(out, rows);
        }
    }
}

/// Vertical pass: `out[x] = sat(round_even(Σ W_j · rows_j[x] / 2^S))`, weights as constants
/// so the compiler can strength-reduce and vectorise.
#[inline(always)]
fn vertical<const S: u32, const W0: i32, const W1: i32, const W2: i32, const W3: i32>(
    out: &mut [u8],
    rows: [&[i32; HROW]; 4],
) {
    #[cfg(fusion_arm_dsp)]
    let done = armv7em::vertical_arm::<S>(out, rows, [W0, W1, W2, W3]);
    #[cfg(not(fusion_arm_dsp))]
    let done = 0;
    let out = out.get_mut(done..).unwrap_or(&mut []);
    let [r0, r1, r2, r3] = rows.map(|r| r.get(done..).unwrap_or(&[]));
    for (o, (((a, b), c), d)) in out.iter_mut().zip(r0.iter().zip(r1).zip(r2).zip(r3)) {
        *o = round_even_sat::<S>(W0 * a + W1 * b + W2 * c + W3 * d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_goes_to_even_and_saturates() {
        assert_eq!(round_even_sat::<16>(250 * 65536 + 32768), 250);
        assert_eq!(round_even_sat::<16>(251 * 65536 + 32768), 252);
        assert_eq!(round_even_sat::<16>(7 * 65536 + 32769), 8);
        assert_eq!(round_even_sat::<16>(-35 * 65536), 0);
        assert_eq!(round_even_sat::<16>(300 * 65536), 255);
        assert_eq!(round_even_sat::<10>(164 * 1024 + 512), 164);
        assert_eq!(round_even_sat::<10>(-1545), 0);
    }
}
