//! Border rules and the 3×3 neighbourhood walker shared by the small integer filters.
//!
//! A 3×3 filter gets its three rows from the caller (`None` for a row outside the frame, read
//! as zeros) and walks the columns with [`map_neighbourhoods`], which pads one column on each
//! side by the chosen [`Border`] rule. No buffers, no indexing: the interior is a zip of
//! `windows(3)` (which the optimiser vectorises), the two edge pixels are built explicitly.

/// How samples outside the frame are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Border {
    /// Outside samples are 0 (MATLAB's default padding: `imfilter`, `medfilt2`, `conv2 'same'`).
    Zero,
    /// Outside samples repeat the nearest edge sample (`padarray(…, 'replicate')`).
    Replicate,
    /// The frame wraps around (`imfilter(…, 'circular')`): left of column 0 is column W−1.
    Circular,
}

/// One 3×3 neighbourhood: `[left, centre, right]` columns, each `[up, mid, down]`.
pub type Neighbourhood<T> = [[T; 3]; 3];

/// A per-pixel operation of [`map_neighbourhoods`]. Closures implement it; a hot kernel
/// implements it on a struct with an `#[inline(always)]` method, which the optimiser then
/// inlines at the three call sites of the walk (left edge, interior, right edge).
pub trait NeighbourhoodOp<T, U> {
    /// Handles one pixel.
    fn apply(&mut self, n: Neighbourhood<T>, item: U);
}

/// A closure as a [`NeighbourhoodOp`].
struct FnOp<F>(F);

impl<T, U, F: FnMut(Neighbourhood<T>, U)> NeighbourhoodOp<T, U> for FnOp<F> {
    #[inline(always)]
    fn apply(&mut self, n: Neighbourhood<T>, item: U) {
        (self.0)(n, item)
    }
}

/// Calls `f(neighbourhood, item)` for every pixel of `mid`, left to right, with the next
/// item of `out` (e.g. `row.iter_mut()`, or a zip of several per-pixel slices).
///
/// `up` / `down` are the rows above and below (`None`: outside the frame, read as
/// `T::default()`, i.e. zero). The caller chooses them by its row border rule (e.g.
/// `FrameRef::row_clamped` for replicate); the columns beyond the left and right edges follow
/// `border`. Rows and `out` should have the length of `mid`; extra elements are ignored and a
/// shorter row or `out` ends the walk early.
#[inline(always)]
pub fn map_neighbourhoods<T: Copy + Default, U>(
    up: Option<&[T]>,
    mid: &[T],
    down: Option<&[T]>,
    border: Border,
    out: impl IntoIterator<Item = U>,
    f: impl FnMut(Neighbourhood<T>, U),
) {
    map_neighbourhoods_op(up, mid, down, border, out, FnOp(f));
}

/// [`map_neighbourhoods`] with a [`NeighbourhoodOp`], handed back at the end (for ops that
/// collect something, e.g. a flag).
#[inline(always)]
pub fn map_neighbourhoods_op<T: Copy + Default, U, O: NeighbourhoodOp<T, U>>(
    up: Option<&[T]>,
    mid: &[T],
    down: Option<&[T]>,
    border: Border,
    out: impl IntoIterator<Item = U>,
    mut op: O,
) -> O {
    let out = out.into_iter();
    let f = &mut op;
    match (up, down) {
        (Some(u), Some(d)) => walk::<T, U, false, false>(u, mid, d, border, out, f),
        (None, Some(d)) => walk::<T, U, true, false>(mid, mid, d, border, out, f),
        (Some(u), None) => walk::<T, U, false, true>(u, mid, mid, border, out, f),
        (None, None) => walk::<T, U, true, true>(mid, mid, mid, border, out, f),
    }
    op
}

#[inline(always)]
fn walk<T: Copy + Default, U, const ZERO_UP: bool, const ZERO_DOWN: bool>(
    up: &[T],
    mid: &[T],
    down: &[T],
    border: Border,
    out: impl Iterator<Item = U>,
    f: &mut impl NeighbourhoodOp<T, U>,
) {
    let zero = T::default();
    let col = |u: T, m: T, d: T| [if ZERO_UP { zero } else { u }, m, if ZERO_DOWN { zero } else { d }];
    let at = |i: usize| match (up.get(i), mid.get(i), down.get(i)) {
        (Some(&u), Some(&m), Some(&d)) => Some(col(u, m, d)),
        _ => None,
    };
    let len = mid.len().min(up.len()).min(down.len());
    let (Some(first), Some(last)) = (at(0), len.checked_sub(1).and_then(at)) else { return };
    let (pad_left, pad_right) = match border {
        Border::Zero => ([zero; 3], [zero; 3]),
        Border::Replicate => (first, last),
        Border::Circular => (last, first),
    };
    let mut outs = out.take(len);
    if len == 1 {
        if let Some(o) = outs.next() {
            f.apply([pad_left, first, pad_right], o);
        }
        return;
    }
    if let Some(o) = outs.next() {
        f.apply([pad_left, first, at(1).unwrap_or(pad_right)], o);
    }
    let interior = up.windows(3).zip(mid.windows(3)).zip(down.windows(3)).take(len - 2);
    for (((u, m), d), o) in interior.zip(outs.by_ref()) {
        if let ([u0, u1, u2], [m0, m1, m2], [d0, d1, d2]) = (u, m, d) {
            f.apply([col(*u0, *m0, *d0), col(*u1, *m1, *d1), col(*u2, *m2, *d2)], o);
        }
    }
    if let Some(o) = outs.next() {
        f.apply([at(len - 2).unwrap_or(pad_left), last, pad_right], o);
    }
}

/// The three samples of column `x` (`−1 ≤ x ≤ len`) of the rows `up`, `mid`, `down`
/// (`None`: outside the frame, zeros), columns beyond the edges by `border`; `None` only for
/// an empty row.
#[inline]
pub fn column<T: Copy + Default>(rows: [Option<&[T]>; 3], x: isize, border: Border) -> Option<[T; 3]> {
    let len = rows[1].map_or(0, <[T]>::len);
    let x = if x >= 0 && (x as usize) < len {
        x as usize
    } else {
        match border {
            Border::Zero => return Some([T::default(); 3]),
            Border::Replicate => x.min(len as isize - 1).max(0) as usize,
            Border::Circular => x.rem_euclid(len.max(1) as isize) as usize,
        }
    };
    let at = |r: Option<&[T]>| match r {
        Some(r) => r.get(x).copied(),
        None => Some(T::default()),
    };
    Some([at(rows[0])?, at(rows[1])?, at(rows[2])?])
}

/// Calls `f(i, column)` for the `n + 2` columns `x0 − 1 ..= x0 + n` of the rows (see
/// [`column`](fn@column)), `i` counting from 0: the columns a 3×3 filter needs for the outputs
/// `x0 .. x0 + n`. The interior is a plain zip; only columns outside the row go through the
/// border rule.
#[inline(always)]
pub fn for_columns<T: Copy + Default>(
    rows: [Option<&[T]>; 3],
    border: Border,
    x0: usize,
    n: usize,
    mut f: impl FnMut(usize, [T; 3]),
) {
    let len = rows[1].map_or(0, <[T]>::len);
    let first = x0 as isize - 1;
    // Columns inside the row: x in [max(first, 0), min(x0 + n, len − 1)].
    let lo = x0.saturating_sub(1);
    let hi = (x0 + n + 1).min(len);
    let mut i = lo as isize - first; // 0 or 1
    if first < 0
        && let Some(c) = column(rows, first, border)
    {
        f(0, c);
    }
    if lo < hi {
        let zeros = [T::default(); 3];
        match rows {
            [Some(u), Some(m), Some(d)] => {
                let cols = u
                    .get(lo..hi)
                    .unwrap_or(&[])
                    .iter()
                    .zip(m.get(lo..hi).unwrap_or(&[]))
                    .zip(d.get(lo..hi).unwrap_or(&[]));
                for ((&u, &m), &d) in cols {
                    f(i as usize, [u, m, d]);
                    i += 1;
                }
            }
            [u, Some(m), d] => {
                for (k, &m) in m.get(lo..hi).unwrap_or(&[]).iter().enumerate() {
                    let pick = |r: Option<&[T]>| r.and_then(|r| r.get(lo + k).copied()).unwrap_or(zeros[0]);
                    f(i as usize, [pick(u), m, pick(d)]);
                    i += 1;
                }
            }
            _ => {}
        }
    }
    let last = (x0 + n) as isize;
    if last >= len as isize
        && let Some(c) = column(rows, last, border)
    {
        f(n + 1, c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn collect<const N: usize>(
        up: Option<&[i32]>,
        mid: &[i32],
        down: Option<&[i32]>,
        border: Border,
    ) -> [Neighbourhood<i32>; N] {
        let mut out = [[[0; 3]; 3]; N];
        map_neighbourhoods(up, mid, down, border, out.iter_mut(), |n, o| *o = n);
        out
    }

    #[test]
    fn borders_pad_one_column() {
        let up = [1i32, 2, 3];
        let mid = [4i32, 5, 6];
        let z: [_; 3] = collect(Some(&up[..]), &mid, None, Border::Zero);
        assert_eq!(z[0], [[0, 0, 0], [1, 4, 0], [2, 5, 0]]);
        assert_eq!(z[1], [[1, 4, 0], [2, 5, 0], [3, 6, 0]]);
        assert_eq!(z[2], [[2, 5, 0], [3, 6, 0], [0, 0, 0]]);
        let r: [_; 3] = collect(Some(&up[..]), &mid, Some(&up[..]), Border::Replicate);
        assert_eq!(r[0], [[1, 4, 1], [1, 4, 1], [2, 5, 2]]);
        assert_eq!(r[2], [[2, 5, 2], [3, 6, 3], [3, 6, 3]]);
        let c: [_; 3] = collect(None, &mid, None, Border::Circular);
        assert_eq!(c[0], [[0, 6, 0], [0, 4, 0], [0, 5, 0]]);
        assert_eq!(c[2], [[0, 5, 0], [0, 6, 0], [0, 4, 0]]);
        // One and two pixels per row.
        let one: [_; 1] = collect(None, &[7], None, Border::Replicate);
        assert_eq!(one[0], [[0, 7, 0], [0, 7, 0], [0, 7, 0]]);
        let two: [_; 2] = collect(None, &[7, 8], Some(&[1, 2][..]), Border::Zero);
        assert_eq!(two, [[[0, 0, 0], [0, 7, 1], [0, 8, 2]], [[0, 7, 1], [0, 8, 2], [0, 0, 0]]]);
    }
}
