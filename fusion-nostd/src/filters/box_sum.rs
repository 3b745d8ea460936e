//! Box sums with running sums: O(1) work per pixel whatever the window size.
//!
//! [`box_sum_u8`] writes, for every pixel, the exact integer sum of the `(2r+1)²` samples of
//! its window (no division: the caller divides by the tap count where it needs the mean, or
//! keeps the sum as a fixed-point value with the implied scale `1/(2r+1)²`). The sums are
//! exact for any border rule and any frame size, windows larger than the frame included
//! (circular windows then wrap more than once, as MATLAB's `padarray(…, 'circular')`).
//!
//! Range: a sum is at most `255 · (2r+1)²`; `MAX_RADIUS` keeps it below 2³¹.

use super::border::Border;
use crate::{Error, FrameRef};

/// The largest radius accepted (window 2·1000+1 = 2001 taps a side, sums < 2³¹).
pub const MAX_RADIUS: usize = 1000;

/// A sample position walking one step at a time, with its wrapped (circular) twin kept
/// incrementally (no division per pixel).
#[derive(Debug, Clone, Copy)]
struct Tap {
    raw: isize,
    wrapped: usize,
    len: usize,
}

impl Tap {
    fn new(raw: isize, len: usize) -> Self {
        let n = len.max(1) as isize;
        Self { raw, wrapped: raw.rem_euclid(n) as usize, len: len.max(1) }
    }

    #[inline]
    fn step(&mut self) {
        self.raw += 1;
        self.wrapped += 1;
        if self.wrapped >= self.len {
            self.wrapped = 0;
        }
    }

    /// The index to read under `border`, `None` for a zero sample.
    #[inline]
    fn index(&self, border: Border) -> Option<usize> {
        match border {
            Border::Circular => Some(self.wrapped),
            Border::Replicate => Some(if self.raw <= 0 { 0 } else { (self.raw as usize).min(self.len - 1) }),
            Border::Zero => (self.raw >= 0 && (self.raw as usize) < self.len).then_some(self.raw as usize),
        }
    }
}

#[inline]
fn sample<T: Copy + Into<i32>>(row: &[T], tap: &Tap, border: Border) -> i32 {
    tap.index(border).and_then(|i| row.get(i)).map_or(0, |&v| v.into())
}

/// Window sums of the positions `x0..x1` of `out` by the generic taps (border-aware).
fn horizontal_taps<T: Copy + Into<i32>>(
    row: &[T],
    radius: usize,
    border: Border,
    sum: &mut i32,
    x0: usize,
    out: &mut [i32],
) {
    let len = row.len();
    let r = radius as isize;
    let mut enter = Tap::new(x0 as isize + r + 1, len);
    let mut leave = Tap::new(x0 as isize - r, len);
    for o in out.iter_mut() {
        *o = *sum;
        let delta = sample(row, &enter, border) - sample(row, &leave, border);
        *sum += delta;
        enter.step();
        leave.step();
    }
}

/// One row's horizontal window sums into `out` (same length as `row`).
pub(crate) fn horizontal<T: Copy + Into<i32>>(row: &[T], radius: usize, border: Border, out: &mut [i32]) {
    let len = row.len();
    let mut tap = Tap::new(-(radius as isize), len);
    let mut sum = 0i32;
    for _ in 0..2 * radius + 1 {
        sum += sample(row, &tap, border);
        tap.step();
    }
    // Interior: every tap inside the row (x − r ≥ 0 and x + r + 1 ≤ len − 1).
    let (start, end) = if len > 2 * radius + 1 { (radius, len - radius - 1) } else { (len, len) };
    let Some((head, rest)) = out.split_at_mut_checked(start) else {
        horizontal_taps(row, radius, border, &mut sum, 0, out);
        return;
    };
    horizontal_taps(row, radius, border, &mut sum, 0, head);
    let Some((middle, tail)) = rest.split_at_mut_checked(end - start) else { return };
    let entering = row.get(start + radius + 1..).unwrap_or(&[]);
    let leaving = start.checked_sub(radius).and_then(|i| row.get(i..)).unwrap_or(&[]);
    for ((o, &e), &l) in middle.iter_mut().zip(entering).zip(leaving) {
        *o = sum;
        let delta = e.into() - l.into();
        sum += delta;
    }
    horizontal_taps(row, radius, border, &mut sum, end, tail);
}

/// `out[y][x] = Σ` of `src` over the `(2·radius+1)²` window around `(x, y)`, outside samples
/// by `border`. `tmp` and `out` are packed `width × height` planes (the horizontal pass goes
/// to `tmp`). Errors: [`Error::InvalidParameter`] for a radius above `MAX_RADIUS`,
/// [`Error::ScratchTooSmall`] for short planes.
pub fn box_sum_u8(
    src: FrameRef<'_, u8>,
    radius: usize,
    border: Border,
    tmp: &mut [i32],
    out: &mut [i32],
) -> Result<(), Error> {
    if radius > MAX_RADIUS {
        return Err(Error::InvalidParameter { name: "radius" });
    }
    let (w, h) = src.size();
    let pixels = w * h;
    let capacity = tmp.len().min(out.len());
    let (Some(tmp), Some(out)) = (tmp.get_mut(..pixels), out.get_mut(..pixels)) else {
        return Err(Error::ScratchTooSmall { needed: pixels, capacity });
    };
    for (row, t) in src.rows().zip(tmp.chunks_exact_mut(w.max(1))) {
        horizontal(row, radius, border, t);
    }
    vertical(tmp, w, h, radius, border, out);
    Ok(())
}

/// The vertical pass over whole rows of the packed plane `tmp` (`w × h`) into `out`.
fn vertical(tmp: &[i32], w: usize, h: usize, radius: usize, border: Border, out: &mut [i32]) {
    let row = |tap: &Tap| tap.index(border).and_then(|y| tmp.get(y * w..y * w + w));
    let r = radius as isize;
    let mut rows_out = out.chunks_exact_mut(w.max(1));
    let Some(first) = rows_out.next() else { return };
    first.fill(0);
    let mut tap = Tap::new(-r, h);
    for _ in 0..2 * radius + 1 {
        if let Some(src) = row(&tap) {
            for (o, s) in first.iter_mut().zip(src) {
                *o += s;
            }
        }
        tap.step();
    }
    let mut enter = tap;
    let mut leave = Tap::new(-r, h);
    let mut prev: &mut [i32] = first;
    for cur in rows_out {
        match (row(&enter), row(&leave)) {
            (Some(e), Some(l)) => {
                for (((c, p), e), l) in cur.iter_mut().zip(prev.iter()).zip(e).zip(l) {
                    *c = p + e - l;
                }
            }
            (Some(e), None) => {
                for ((c, p), e) in cur.iter_mut().zip(prev.iter()).zip(e) {
                    *c = p + e;
                }
            }
            (None, Some(l)) => {
                for ((c, p), l) in cur.iter_mut().zip(prev.iter()).zip(l) {
                    *c = p - l;
                }
            }
            (None, None) => {
                for (c, p) in cur.iter_mut().zip(prev.iter()) {
                    *c = *p;
                }
            }
        }
        enter.step();
        leave.step();
        prev = cur;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Direct O(r²) sum for comparison.
    fn naive(src: &[u8], w: usize, h: usize, r: isize, border: Border, x: usize, y: usize) -> i32 {
        let mut s = 0;
        for dy in -r..=r {
            for dx in -r..=r {
                let (sx, sy) = (x as isize + dx, y as isize + dy);
                let pick = |i: isize, n: usize| match border {
                    Border::Zero => (i >= 0 && i < n as isize).then_some(i as usize),
                    Border::Replicate => Some(i.clamp(0, n as isize - 1) as usize),
                    Border::Circular => Some(i.rem_euclid(n as isize) as usize),
                };
                if let (Some(a), Some(b)) = (pick(sx, w), pick(sy, h)) {
                    s += i32::from(src.get(b * w + a).copied().unwrap_or(0));
                }
            }
        }
        s
    }

    #[test]
    fn running_sums_equal_direct_sums() -> Result<(), Error> {
        let mut seed = 12345u32;
        let mut buf = [0u8; 7 * 5];
        for v in buf.iter_mut() {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            *v = (seed >> 24) as u8;
        }
        for (w, h) in [(7usize, 5usize), (1, 5), (7, 1), (1, 1), (3, 2)] {
            let src = FrameRef::new(&buf, w, h)?;
            for r in [0usize, 1, 2, 4, 9] {
                for border in [Border::Zero, Border::Replicate, Border::Circular] {
                    let mut tmp = [0i32; 35];
                    let mut out = [0i32; 35];
                    box_sum_u8(src, r, border, &mut tmp, &mut out)?;
                    for y in 0..h {
                        for x in 0..w {
                            let want = naive(&buf, w, h, r as isize, border, x, y);
                            assert_eq!(
                                out.get(y * w + x).copied(),
                                Some(want),
                                "{w}x{h} r{r} {border:?} ({x},{y})"
                            );
                        }
                    }
                }
            }
        }
        let src = FrameRef::new(&buf, 7, 5)?;
        let mut small = [0i32; 10];
        let mut out = [0i32; 35];
        assert!(matches!(
            box_sum_u8(src, 1, Border::Zero, &mut small, &mut out),
            Err(Error::ScratchTooSmall { .. })
        ));
        assert!(box_sum_u8(src, MAX_RADIUS + 1, Border::Zero, &mut out.clone(), &mut out).is_err());
        Ok(())
    }
}
