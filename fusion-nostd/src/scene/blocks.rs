//! Block statistics: the frame in square blocks whose side grows with the pixel noise, the
//! blocks' means and their spread, and the main run of signal blocks ([`block_stats`]).

#[allow(unused_imports)]
use super::*;

/// Block side for a band whose pixel spread is `spread_q8`: the smallest power of two (`2..=16`)
/// that brings white noise to half of `max_noise_spread` (`σ/b`; half, for the margin 1/f
/// noise needs: its block means fall more slowly). The study's noise: 4 in both bands.
pub fn block_side(spread_q8: u16, max_noise_spread: u8) -> usize {
    let limit = u32::from(max_noise_spread.max(1)) << 7; // half of max, Q8
    let mut b = 2usize;
    while b < 16 && u32::from(spread_q8) > b as u32 * limit {
        b *= 2;
    }
    b
}

/// Columns a block-row pass reads at a time (a multiple of every block side).
pub(super) const BLOCK_CHUNK: usize = 1024;

/// `each(bx, by, sum, count)` of every `b × b` block (`b` even; edge blocks partial) of every
/// `step`-th block row. The rows of a block row are added four pixels to a word — two 16-bit
/// lanes, each the sum of a pixel pair (`(w & 0x00ff00ff) + ((w >> 8) & 0x00ff00ff)`; at most
/// 16 rows · 510 < 2¹⁶) — so a block sums its pairs: ≈ 1.3 instructions per pixel on the
/// Cortex-M7.
pub(super) fn for_each_block(
    f: FrameRef<'_, u8>,
    b: usize,
    step: usize,
    mut each: impl FnMut(usize, usize, u32, u32),
) {
    let (w, h) = f.size();
    let b = b.max(2);
    for by in (0..h.div_ceil(b)).step_by(step.max(1)) {
        let y0 = by * b;
        let rows = b.min(h.saturating_sub(y0));
        let mut x0 = 0;
        while x0 < w {
            let cols = (w - x0).min(BLOCK_CHUNK);
            let mut acc = [0u32; BLOCK_CHUNK / 4];
            let mut tail = [0u32; 4];
            for y in y0..y0 + rows {
                let row = f.row(y).get(x0..x0 + cols).unwrap_or(&[]);
                let (words, rest) = row.as_chunks::<4>();
                for (a, q) in acc.iter_mut().zip(words) {
                    let v = u32::from_le_bytes(*q);
                    *a += (v & 0x00ff_00ff) + ((v >> 8) & 0x00ff_00ff);
                }
                for (t, &p) in tail.iter_mut().zip(rest) {
                    *t += u32::from(p);
                }
            }
            let full = cols / 4 * 4;
            let pair = |c: usize| acc.get(c / 4).map_or(0, |&a| (a >> (8 * (c % 4))) & 0xffff);
            for bx in 0..cols.div_ceil(b) {
                let (c0, c1) = (bx * b, (bx * b + b).min(cols));
                let mut sum = 0u32;
                let mut c = c0;
                while c + 1 < c1 && c + 1 < full {
                    sum += pair(c);
                    c += 2;
                }
                while c < c1 {
                    sum += tail.get(c.wrapping_sub(full)).copied().unwrap_or(0);
                    c += 1;
                }
                each(x0 / b + bx, by, sum, ((c1 - c0) * rows) as u32);
            }
            x0 += cols;
        }
    }
}

/// Blocks of empty columns (rows) that still join two parts of one target.
pub(super) const BLOCK_GAP: usize = 8;

/// The run of set bits of `set` in `lo..=hi` around `anchor` (clamped into the range) that
/// bridges gaps of at most [`BLOCK_GAP`] clear bits: `(first, last)`.
pub(super) fn main_run(set: &[u32], anchor: usize, lo: usize, hi: usize) -> (usize, usize) {
    let on = |v: usize| set.get(v / 32).is_some_and(|&w| w >> (v % 32) & 1 == 1);
    let anchor = anchor.max(lo).min(hi.max(lo)); // not clamp: its min ≤ max assert
    // The nearest set bit to the anchor (there is one: lo and hi are set).
    let start = (0..=hi.saturating_sub(lo))
        .flat_map(|d| [anchor.checked_sub(d), Some(anchor + d)])
        .flatten()
        .find(|&v| (lo..=hi).contains(&v) && on(v))
        .unwrap_or(anchor);
    let (mut first, mut last) = (start, start);
    let mut v = start;
    while v > lo {
        match (1..=BLOCK_GAP + 1).map(|g| v.saturating_sub(g)).find(|&u| u >= lo && on(u)) {
            Some(u) => {
                first = u;
                v = u;
            }
            None => break,
        }
    }
    let mut v = start;
    while v < hi {
        match (1..=BLOCK_GAP + 1).map(|g| v + g).find(|&u| u <= hi && on(u)) {
            Some(u) => {
                last = u;
                v = u;
            }
            None => break,
        }
    }
    (first, last)
}

/// The block analysis of a band (see [`BlockStats`]): one pass for the histogram of the block
/// means (rounded), one for the box of the blocks whose mean is above the threshold, compared
/// as sums (no division).
pub fn block_stats(f: FrameRef<'_, u8>, pixel_spread_q8: u16, p: &SceneParams) -> BlockStats {
    let b = block_side(pixel_spread_q8, p.max_noise_spread);
    let mut hist = [0u32; 256];
    let mut n = 0u32;
    // The histogram from every other block row (thousands of blocks either way).
    for_each_block(f, b, 2, |_, _, sum, count| {
        let mean = (sum + count / 2) / count.max(1);
        if let Some(h) = hist.get_mut(mean.min(255) as usize) {
            *h = h.saturating_add(1);
        }
        n = n.saturating_add(1);
    });
    let background = median_of(&hist, n);
    let spread_q8 = upper_quartile_q8(&hist, n)
        .saturating_sub(u32::from(background) << 8)
        .min(u32::from(u16::MAX)) as u16;
    let spread = (u64::from(spread_q8) * u64::from(p.block_k_sigma_tenths) * 14826).div_ceil(100_000 << 8);
    let delta = spread.max(u64::from(p.min_delta)).min(256) as u16;
    let threshold = u16::from(background) + delta;
    let mut hit: Option<(usize, usize, usize, usize)> = None;
    // A signal block needs a neighbour (8-connected) above the threshold too, as the pixels
    // need their 2-pixel runs, or a mean twice as far above the background (10σ): a lone block
    // of 1/f noise does not stretch the box. Each
    // adjacent pair is seen from its later block (left, or the row above); the rows' blocks
    // above the threshold are kept as bits.
    let mut rows = [[0u32; MAX_DIMENSION / 2 / 32]; 2];
    let mut row_of = usize::MAX;
    // The signal blocks' columns and rows (bits) and their mean position.
    let mut cols = [0u32; MAX_DIMENSION / 2 / 32];
    let mut rows_seen = [0u32; MAX_DIMENSION / 2 / 32];
    let (mut sx, mut sy, mut n) = (0u64, 0u64, 0u64);
    let mut add = |x: usize, y: usize| {
        hit = Some(match hit {
            None => (x, y, x, y),
            Some((x0, y0, x1, y1)) => (x0.min(x), y0.min(y), x1.max(x), y1.max(y)),
        });
        for (set, v) in [(&mut cols, x), (&mut rows_seen, y)] {
            if let Some(w) = set.get_mut(v / 32) {
                *w |= 1 << (v % 32);
            }
        }
        (sx, sy, n) = (sx + x as u64, sy + y as u64, n + 1);
    };
    let bit =
        |r: &[u32; MAX_DIMENSION / 2 / 32], x: usize| r.get(x / 32).is_some_and(|&w| w >> (x % 32) & 1 == 1);
    for_each_block(f, b, 1, |bx, by, sum, count| {
        if by != row_of {
            // A new block row: it becomes the current one, the current one the previous.
            let [prev, cur] = &mut rows;
            if by == row_of.wrapping_add(1) {
                *prev = *cur;
            } else {
                prev.fill(0);
            }
            cur.fill(0);
            row_of = by;
        }
        // mean > threshold ⇔ sum > threshold·count (integers)
        if u64::from(sum) <= u64::from(threshold) * u64::from(count) {
            return;
        }
        // A block twice as far above the background needs no neighbour (a small hot part).
        let strong = u64::from(sum) > (2 * u64::from(threshold) - u64::from(background)) * u64::from(count);
        let [prev, cur] = &mut rows;
        if let Some(w) = cur.get_mut(bx / 32) {
            *w |= 1 << (bx % 32);
        }
        let left = bx.checked_sub(1);
        let mut paired = strong;
        if let Some(l) = left.filter(|&l| bit(cur, l)) {
            add(l, by);
            paired = true;
        }
        if by > 0 {
            for x in [left, Some(bx), Some(bx + 1)].into_iter().flatten() {
                if bit(prev, x) {
                    add(x, by - 1);
                    paired = true;
                }
            }
        }
        if paired {
            add(bx, by);
        }
    });
    // The box is cut to the run of columns (rows) around the signal's mean position with gaps
    // of at most BLOCK_GAP blocks: a pair of noise blocks far from the target is dropped, not
    // joined.
    let hit = hit.map(|(x0, y0, x1, y1)| {
        let n = n.max(1);
        let ((a, b), (c, d)) =
            (main_run(&cols, (sx / n) as usize, x0, x1), main_run(&rows_seen, (sy / n) as usize, y0, y1));
        (a, c, b, d)
    });
    let signal = hit.map(|(x0, y0, x1, y1)| {
        Rect { x0: x0 * b, y0: y0 * b, x1: (x1 + 1) * b, y1: (y1 + 1) * b }.grow(b, f.size())
    });
    BlockStats { block: b, background, spread_q8, threshold, signal }
}
