//! MATLAB `imresize(…, 'bicubic')` as IFEVIP's published run uses it, in fixed point.
//!
//! * Kernel: Keys cubic, a = −0.5. Shrinking (out < in) widens it by in/out (antialiasing,
//!   `h(x) = s·cubic(s·x)`, s = out/in).
//! * Coordinates: output sample `x` (1-based) sits at `u = x/s + ½(1 − 1/s)` in the input.
//!   With `A = 2x·in + out − in` the distance to input sample `j` (1-based) is
//!   `(A − 2j·out)/(2·out)` and the kernel argument (after the antialias scaling) is
//!   `σ/D`, `σ = A − 2j·out`, `D = 2·max(in, out)`. So `2D³·cubic(σ/D)` is an exact integer
//!   ([`kernel_num`], < 2⁴⁹) and the normalised weights `K_j / Σ K` are exact rationals.
//! * Ends: tap indices outside the input are reflected symmetrically with the end sample
//!   repeated (`[1:n, n:-1:1]` periodic), the rule of the published run; taps that land on
//!   the same input sample are merged, so each output reads one contiguous input run.
//! * Weights are stored in Q30 (`i32`), rounded, with the rounding residual put on the
//!   largest weight so that they sum to exactly 2³⁰ (a constant stays constant). Error per
//!   weight ≤ 2⁻³¹ · (taps merged into it).
//!
//! Tables live in a caller `i32` slice: per output sample `[start, count, w₀ … w_{T−1}]`
//! with the fixed row length `T + 2` (`Taps::stride`).

use crate::{Error, FrameMut, FrameRef};
use core::num::NonZeroU64;

/// Fractional bits of the stored weights.
pub const WEIGHT_BITS: u32 = 30;

/// `2D³·cubic(σ/D)` for the Keys kernel with a = −0.5 (exact; 0 for |σ| ≥ 2D).
pub fn kernel_num(sigma: i64, d: i64) -> i64 {
    let s = sigma.abs();
    if s <= d {
        3 * s * s * s - 5 * s * s * d + 2 * d * d * d
    } else if s < 2 * d {
        -s * s * s + 5 * s * s * d - 8 * s * d * d + 4 * d * d * d
    } else {
        0
    }
}

/// 0-based index of the 0-based, possibly out-of-range, position `j` in `0..n`: symmetric
/// reflection with the end sample repeated.
fn reflect(j: i64, n: i64) -> i64 {
    if (0..n).contains(&j) {
        return j; // the common case, without a 64-bit division
    }
    // The Euclidean remainder by a period ≥ 1 (spelled out: neither zero nor −1, so no panic
    // path, which LLVM's AArch64 code kept behind `rem_euclid`).
    let period = 2 * n;
    if period <= 0 {
        return 0;
    }
    let m = j % period;
    let m = if m < 0 { m + period } else { m };
    if m < n { m } else { period - 1 - m }
}

/// `a / b` rounded toward −∞ (b > 0).
fn floor_div(a: i64, b: i64) -> i64 {
    a.checked_div_euclid(b).unwrap_or(0)
}

/// A built tap table (see the module docs).
#[derive(Debug)]
pub struct Taps<'a> {
    table: &'a [i32],
    stride: usize,
}

impl<'a> Taps<'a> {
    #[cfg(test)]
    /// Elements per output sample in the table (`2 + taps`).
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// `(start, weights)` of every output sample, in order.
    pub fn iter(&self) -> impl Iterator<Item = (usize, &'a [i32])> + '_ {
        self.table.chunks_exact(self.stride.max(1)).map(|c| match c {
            [start, count, ws @ ..] => (*start as usize, ws.get(..*count as usize).unwrap_or(&[])),
            _ => (0, &[][..]),
        })
    }
}

/// Table length needed for a resize from `in_len` to `out_len` samples.
pub fn table_len(in_len: usize, out_len: usize) -> usize {
    out_len.saturating_mul(max_taps(in_len, out_len) + 2)
}

/// Taps per output sample after merging: `min(in, ⌈4·max(in,out)/out⌉ + 2)`.
pub fn max_taps(in_len: usize, out_len: usize) -> usize {
    let big = in_len.max(out_len);
    let p = (4 * big).div_ceil(out_len.max(1)) + 2;
    p.min(in_len)
}

/// The taps of output sample `x` (1-based) before reflection: `(A, D, left, P)` — the
/// kernel argument numerator `A`, the denominator `D`, the first input index `left`
/// (1-based, possibly outside `1..=n_in`) and the tap count `P`.
fn tap_window(x: i64, n_in: i64, n_out: i64) -> (i64, i64, i64, i64) {
    let d = 2 * n_in.max(n_out);
    let p = (4 * n_in.max(n_out) + n_out - 1) / n_out + 2;
    let a = 2 * x * n_in + n_out - n_in;
    (a, d, floor_div(a - 2 * d, 2 * n_out), p)
}

/// Whether every tap of output sample `x` (1-based) lies inside the input (no reflection).
fn interior(x: i64, n_in: i64, n_out: i64) -> bool {
    let (_, _, left, p) = tap_window(x, n_in, n_out);
    left >= 1 && left + p - 1 <= n_in
}

/// The exact kernel numerators of output sample `x` (1-based): calls `f(index, K)` for every
/// tap with a non-zero kernel (index reflected into `0..in`), returns `Σ K`.
fn for_taps(x: i64, n_in: i64, n_out: i64, mut f: impl FnMut(i64, i64)) -> i128 {
    let (a, d, left, p) = tap_window(x, n_in, n_out);
    let mut total: i128 = 0;
    for j in left..left + p {
        let k = kernel_num(a - 2 * j * n_out, d);
        if k != 0 {
            total += i128::from(k);
            f(reflect(j - 1, n_in), k);
        }
    }
    total
}

/// The greatest common divisor of `|a|` and `|b|` (`a` when `b` is 0).
fn gcd(a: i64, b: i64) -> u64 {
    let (mut a, mut b) = (a.unsigned_abs(), b.unsigned_abs());
    while let Some(d) = NonZeroU64::new(b) {
        (a, b) = (b, a % d);
    }
    a
}

/// Builds the taps of a resize from `in_len` to `out_len` samples into `buf`. Every output
/// reads the same number of consecutive input samples (the widest merged run; runs at the
/// ends are shifted inward and padded with zero weights).
///
/// The kernel is periodic: output `x + P` (`P = out / gcd(in, out)`) sees the same kernel
/// arguments as `x`, `in / gcd(in, out)` samples further on. Where both rows' taps lie inside
/// the input (no reflection, no inward shift) the row is a copy of row `x − P` — the exact
/// divisions are done only for the first period and the ends (2 of 512 rows at 2:1).
pub fn build(in_len: usize, out_len: usize, buf: &mut [i32]) -> Result<Taps<'_>, Error> {
    build_with(in_len, out_len, buf, true)
}

fn build_with(in_len: usize, out_len: usize, buf: &mut [i32], reuse: bool) -> Result<Taps<'_>, Error> {
    if in_len == 0 || out_len == 0 {
        return Err(Error::ZeroDimension);
    }
    let (n_in, n_out) = (in_len as i64, out_len as i64);
    let g = NonZeroU64::new(gcd(n_in, n_out)).unwrap_or(NonZeroU64::MIN);
    let (period, shift) = ((n_out.unsigned_abs() / g) as i64, (n_in.unsigned_abs() / g) as i64);
    // The widest merged run (an interior row has the run of the row one period back).
    let mut taps = 1usize;
    for x in 1..=n_out {
        if reuse && x > period && interior(x, n_in, n_out) && interior(x - period, n_in, n_out) {
            continue;
        }
        let (mut lo, mut hi) = (i64::MAX, i64::MIN);
        for_taps(x, n_in, n_out, |idx, _| {
            lo = lo.min(idx);
            hi = hi.max(idx);
        });
        taps = taps.max((hi - lo + 1).max(1) as usize);
    }
    let taps = taps.min(in_len);
    // Never 0 (an explicit check: the optimiser could not prove it and kept a panic path).
    let Some(stride) = core::num::NonZeroUsize::new(taps.wrapping_add(2)) else {
        return Err(Error::InvalidParameter { name: "resize" });
    };
    let stride = stride.get();
    let needed = out_len.saturating_mul(stride);
    let capacity = buf.len();
    let table = buf.get_mut(..needed).ok_or(Error::ScratchTooSmall { needed, capacity })?;
    for x in 1..=n_out {
        let at = (x - 1) as usize * stride;
        let Some((done, rest)) = table.split_at_mut_checked(at) else { break };
        let Some(row) = rest.get_mut(..stride) else { break };
        let mut lo = i64::MAX;
        let total = for_taps(x, n_in, n_out, |idx, _| lo = lo.min(idx));
        if total <= 0 || lo == i64::MAX {
            return Err(Error::InvalidParameter { name: "resize" });
        }
        let start = lo.min(n_in - taps as i64).max(0);
        // The same row one period back, when both are plain interior rows.
        let earlier = (x - period - 1).max(0) as usize * stride;
        let source = done.get(earlier..earlier + stride).filter(|prev| {
            reuse
                && x > period
                && start == lo
                && interior(x, n_in, n_out)
                && interior(x - period, n_in, n_out)
                && prev.first().map(|&s| i64::from(s)) == Some(lo - shift)
        });
        if let Some(prev) = source {
            for (o, &p) in row.iter_mut().zip(prev) {
                *o = p;
            }
            if let Some(s) = row.first_mut() {
                *s = start as i32;
            }
            continue;
        }
        row.fill(0);
        let Some((head, ws)) = row.split_at_mut_checked(2) else { continue };
        if let [s, c] = head {
            *s = start as i32;
            *c = taps as i32;
        }
        let mut sum: i64 = 0;
        for_taps(x, n_in, n_out, |idx, k| {
            let num = (i128::from(k) << WEIGHT_BITS) + total / 2;
            let w = num.checked_div_euclid(total).unwrap_or(0) as i64;
            if let Some(slot) = ws.get_mut((idx - start) as usize) {
                *slot += w as i32;
                sum += w;
            }
        });
        // The residual goes to the largest weight: the weights sum to exactly 2^30.
        let residual = (1i64 << WEIGHT_BITS) - sum;
        if let Some(big) = ws.iter_mut().max_by_key(|w| **w) {
            *big += residual as i32;
        }
    }
    Ok(Taps { table, stride })
}

impl Taps<'_> {
    /// The same table copied into `buf` (the second axis of a square frame: no rebuild).
    pub fn copy_into<'b>(&self, buf: &'b mut [i32]) -> Result<Taps<'b>, Error> {
        let (needed, capacity) = (self.table.len(), buf.len());
        let table = buf.get_mut(..needed).ok_or(Error::ScratchTooSmall { needed, capacity })?;
        table.copy_from_slice(self.table);
        Ok(Taps { table, stride: self.stride })
    }

    /// Number of output samples.
    pub fn outputs(&self) -> usize {
        self.table.len() / self.stride.max(1)
    }

    /// Input samples every output reads (the widest merged run; shorter ones are padded with
    /// zero weights, and no run reaches past the input).
    pub fn taps(&self) -> usize {
        self.stride.saturating_sub(2)
    }

    /// The first input sample output `x` reads (`None` past the last output).
    pub fn start(&self, x: usize) -> Option<usize> {
        self.table.get(x * self.stride).map(|&s| s as usize)
    }

    /// The table of outputs `outputs` alone, read from an input that begins at input sample
    /// `first` (every start moved back by `first`), in `buf`: a pass over a window of the
    /// input gives these outputs with the whole input's bits, provided the window holds their
    /// runs. Errors when a run begins before `first` or `buf` is short.
    pub fn window<'b>(
        &self,
        outputs: core::ops::Range<usize>,
        first: usize,
        buf: &'b mut [i32],
    ) -> Result<Taps<'b>, Error> {
        let stride = self.stride.max(1);
        let rows = self
            .table
            .get(outputs.start * stride..outputs.end * stride)
            .ok_or(Error::InvalidParameter { name: "rows" })?;
        let (needed, capacity) = (rows.len(), buf.len());
        let table = buf.get_mut(..needed).ok_or(Error::ScratchTooSmall { needed, capacity })?;
        for (dst, src) in table.chunks_exact_mut(stride).zip(rows.chunks_exact(stride)) {
            for (d, &v) in dst.iter_mut().zip(src) {
                *d = v;
            }
            let start = src.first().map_or(0, |&v| v as usize);
            let shifted = start.checked_sub(first).ok_or(Error::InvalidParameter { name: "rows" })?;
            if let Some(d) = dst.first_mut() {
                *d = shifted as i32;
            }
        }
        Ok(Taps { table, stride: self.stride })
    }

    /// `(start, weights)` of output sample `x`.
    fn get(&self, x: usize) -> Option<(usize, &[i32])> {
        let row = self.table.get(x * self.stride..(x + 1) * self.stride)?;
        match row {
            [start, count, ws @ ..] => Some((*start as usize, ws.get(..*count as usize)?)),
            _ => None,
        }
    }
}

/// Upper bound of the table length of [`build_smoothed`] (both of its tables).
pub fn smoothed_len(in_len: usize, out_len: usize, gauss_len: usize) -> usize {
    let r = gauss_len / 2;
    let taps = (max_taps(in_len, out_len) + (2 * r * in_len).div_ceil(out_len.max(1)) + 2).min(in_len);
    table_len(in_len, out_len) + out_len.saturating_mul(taps + 2)
}

/// Taps of the resize from `in_len` to `out_len` samples followed by the zero-padded
/// correlation with `gauss` (Q30, odd length) on the output grid: one linear operator, so
/// `F = G_v·G_h·R_h·R_v·B` is two passes instead of four. Output sample `x` gets
/// `c_j = Σ_t g_t·w_{x+t−r, j}` over the `x + t − r` inside the output (zero padding); each
/// term is rounded to Q30 (error ≤ 2⁻³¹ per term, ≤ n·2⁻³¹ per weight). `buf` holds the plain
/// resize table first, then the combined one ([`smoothed_len`]).
pub fn build_smoothed<'a>(
    in_len: usize,
    out_len: usize,
    gauss: &[i32],
    buf: &'a mut [i32],
) -> Result<Taps<'a>, Error> {
    let split = table_len(in_len, out_len).min(buf.len());
    let (rbuf, cbuf) = buf.split_at_mut(split);
    let resize = build(in_len, out_len, rbuf)?;
    let r = gauss.len() / 2;
    let outputs = |x: usize| (x.saturating_sub(r)..(x + r + 1).min(out_len)).filter_map(|xx| resize.get(xx));
    // The widest combined run.
    let mut taps = 1usize;
    for x in 0..out_len {
        let lo = outputs(x).map(|(s, _)| s).min().unwrap_or(0);
        let hi = outputs(x).map(|(s, ws)| s + ws.len()).max().unwrap_or(0);
        taps = taps.max(hi.saturating_sub(lo));
    }
    let taps = taps.min(in_len);
    let stride = taps + 2;
    let needed = split + out_len.saturating_mul(stride);
    let capacity = split + cbuf.len();
    let table = cbuf.get_mut(..out_len * stride).ok_or(Error::ScratchTooSmall { needed, capacity })?;
    for (x, row) in table.chunks_exact_mut(stride.max(1)).enumerate() {
        let lo = outputs(x).map(|(s, _)| s).min().unwrap_or(0);
        let start = lo.min(in_len - taps);
        row.fill(0);
        let (head, cs) = row.split_at_mut(2);
        if let [s, c] = head {
            *s = start as i32;
            *c = taps as i32;
        }
        for (xx, &g) in
            (x.saturating_sub(r)..(x + r + 1).min(out_len)).zip(gauss.iter().skip(r.saturating_sub(x)))
        {
            if let Some((s, ws)) = resize.get(xx) {
                for (k, &w) in ws.iter().enumerate() {
                    let term = (i64::from(g) * i64::from(w) + (1 << (WEIGHT_BITS - 1))) >> WEIGHT_BITS;
                    if let Some(c) = cs.get_mut(s + k - start) {
                        *c += term as i32;
                    }
                }
            }
        }
    }
    Ok(Taps { table, stride })
}

/// [`build_smoothed`] with the combined table moved to the front of `buf`; returns it and
/// the rest of `buf` (free again: the plain table is dropped).
pub fn build_smoothed_front<'a>(
    in_len: usize,
    out_len: usize,
    gauss: &[i32],
    buf: &'a mut [i32],
) -> Result<(Taps<'a>, &'a mut [i32]), Error> {
    let (offset, len, stride) = {
        let base = buf.as_ptr() as usize;
        let taps = build_smoothed(in_len, out_len, gauss, buf)?;
        ((taps.table.as_ptr() as usize - base) / 4, taps.table.len(), taps.stride)
    };
    let capacity = buf.len();
    if offset + len > capacity {
        return Err(Error::ScratchTooSmall { needed: offset + len, capacity });
    }
    // Toward the front: a forward copy never reads what it already overwrote.
    for i in 0..len {
        if let Some(&v) = buf.get(offset + i)
            && let Some(o) = buf.get_mut(i)
        {
            *o = v;
        }
    }
    let (table, rest) =
        buf.split_at_mut_checked(len).ok_or(Error::ScratchTooSmall { needed: len, capacity })?;
    Ok((Taps { table, stride }, rest))
}

/// What a pass does with its Q30 sums.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// Integer input, `uint8` output: round half up (the sums are never negative ties) and
    /// saturate to 0..=255, as MATLAB's cast of the pass result.
    U8,
    /// Fixed-point input and output in the same Q format (the `double` passes): round to
    /// nearest.
    Same,
}

/// The Q30 sum to the pass's output. `Same` needs no clamp: its inputs are backgrounds in
/// `[0, 255]·2²⁰` (the Bézier surface stays in the hull of its control points, 0..=255) and
/// each pass multiplies the range by at most `Σ|w| < 1.2`, so results stay below 2²⁹.
/// (`U8`: [`Output::U8`], else [`Output::Same`]; a constant, so the kernels have no branch.)
#[inline(always)]
fn finish<const U8: bool>(acc: i64) -> i32 {
    let r = (acc + (1 << (WEIGHT_BITS - 1))) >> WEIGHT_BITS;
    if U8 { r.clamp(0, 255) as i32 } else { r as i32 }
}

/// `Σ v·w` of `N` samples and weights.
#[inline(always)]
fn dot<T: Copy + Into<i64>, const N: usize>(seg: &[T; N], ws: &[i32; N]) -> i64 {
    seg.iter().zip(ws).fold(0, |acc, (&v, &w)| acc + v.into() * i64::from(w))
}

/// `(start, weights)` of one table row when it has `N` weights.
#[inline(always)]
fn row_n<const N: usize>(row: &[i32]) -> Option<(usize, &[i32; N])> {
    let ([start, _count], ws) = row.split_first_chunk::<2>()?;
    Some((*start as usize, ws.first_chunk::<N>()?))
}

#[inline(always)]
fn rows_n<T: Copy + Into<i64>, const N: usize, const U8: bool>(
    src: FrameRef<'_, T>,
    taps: &Taps<'_>,
    dst: FrameMut<'_, i32>,
) {
    rows_with::<T, N, U8>(src, taps, dst, dot)
}

/// The row pass with `N` taps and the dot product `dot`.
#[inline(always)]
fn rows_with<T: Copy + Into<i64>, const N: usize, const U8: bool>(
    src: FrameRef<'_, T>,
    taps: &Taps<'_>,
    mut dst: FrameMut<'_, i32>,
    dot: impl Fn(&[T; N], &[i32; N]) -> i64,
) {
    for (s, d) in src.rows().zip(dst.rows_mut()) {
        for (o, row) in d.iter_mut().zip(taps.table.chunks_exact(taps.stride.max(1))) {
            let acc = row_n::<N>(row)
                .and_then(|(start, ws)| Some(dot(s.get(start..)?.first_chunk::<N>()?, ws)))
                .unwrap_or(0);
            *o = finish::<U8>(acc);
        }
    }
}

#[inline(always)]
fn rows_any<T: Copy + Into<i64>, const U8: bool>(
    src: FrameRef<'_, T>,
    taps: &Taps<'_>,
    mut dst: FrameMut<'_, i32>,
) {
    for (s, d) in src.rows().zip(dst.rows_mut()) {
        for (o, (start, ws)) in d.iter_mut().zip(taps.iter()) {
            let seg = s.get(start..).unwrap_or(&[]);
            let acc: i64 = seg.iter().zip(ws).map(|(&v, &w)| v.into() * i64::from(w)).sum();
            *o = finish::<U8>(acc);
        }
    }
}

/// Taps counts with a kernel of their own (the rest take the general loop).
macro_rules! by_taps {
    ($n:expr, $out:expr, $kernel:ident, $any:ident, $($arg:expr),*) => {
        match $out {
            Output::U8 => by_taps!(@n $n, true, $kernel, $any, $($arg),*),
            Output::Same => by_taps!(@n $n, false, $kernel, $any, $($arg),*),
        }
    };
    (@n $n:expr, $u8:literal, $kernel:ident, $any:ident, $($arg:expr),*) => {
        match $n {
            4 => $kernel::<_, 4, $u8>($($arg),*),
            5 => $kernel::<_, 5, $u8>($($arg),*),
            6 => $kernel::<_, 6, $u8>($($arg),*),
            7 => $kernel::<_, 7, $u8>($($arg),*),
            8 => $kernel::<_, 8, $u8>($($arg),*),
            9 => $kernel::<_, 9, $u8>($($arg),*),
            10 => $kernel::<_, 10, $u8>($($arg),*),
            11 => $kernel::<_, 11, $u8>($($arg),*),
            12 => $kernel::<_, 12, $u8>($($arg),*),
            13 => $kernel::<_, 13, $u8>($($arg),*),
            14 => $kernel::<_, 14, $u8>($($arg),*),
            16 => $kernel::<_, 16, $u8>($($arg),*),
            _ => $any::<_, $u8>($($arg),*),
        }
    };
}

#[inline(always)]
fn rows_kernel<T: Copy + Into<i64>>(
    src: FrameRef<'_, T>,
    taps: &Taps<'_>,
    dst: FrameMut<'_, i32>,
    out: Output,
) {
    by_taps!(taps.stride - 2, out, rows_n, rows_any, src, taps, dst)
}

#[inline(always)]
fn rows_u8(src: FrameRef<'_, u8>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) {
    rows_kernel(src, taps, dst, out)
}

#[inline(always)]
fn rows_i32(src: FrameRef<'_, i32>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) {
    rows_kernel(src, taps, dst, out)
}

crate::cpu::dispatch! {
    fn rows_u8_best(src: FrameRef<'_, u8>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) => rows_u8
}
crate::cpu::dispatch! {
    fn rows_i32_best(src: FrameRef<'_, i32>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) => rows_i32
}

/// A pass source: `u8` frames and `i32` planes.
pub trait Sample: Copy + Into<i64> {
    /// Resizes every row of `src` (see [`pass_rows`]).
    fn pass_rows(src: FrameRef<'_, Self>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output);
    /// Resizes every column of `src` (see [`pass_cols`]).
    fn pass_cols(src: FrameRef<'_, Self>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output);
}

impl Sample for u8 {
    fn pass_rows(src: FrameRef<'_, u8>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) {
        rows_u8_best(src, taps, dst, out)
    }
    #[cfg_attr(not(all(target_arch = "aarch64", target_feature = "neon")), allow(unused_mut))]
    fn pass_cols(src: FrameRef<'_, u8>, taps: &Taps<'_>, mut dst: FrameMut<'_, i32>, out: Output) {
        #[cfg(fusion_arm_dsp)]
        if taps.stride == 8 + 2 && matches!(out, Output::U8) {
            armv7em::cols8::<u8, true>(src, taps, dst, armv7em::u8_to_u8);
            return;
        }
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        if taps.stride == 8 + 2
            && matches!(out, Output::U8)
            && crate::cpu::has_neon()
            && neon::cols8(src, taps, dst.reborrow())
        {
            return;
        }
        cols_u8_best(src, taps, dst, out)
    }
}

impl Sample for i32 {
    #[cfg_attr(not(fusion_arm_dsp), allow(unused_mut))]
    fn pass_rows(src: FrameRef<'_, i32>, taps: &Taps<'_>, mut dst: FrameMut<'_, i32>, out: Output) {
        #[cfg(fusion_arm_dsp)]
        if taps.stride == 8 + 2 {
            match out {
                Output::U8 => rows_with::<i32, 8, true>(src, taps, dst, armv7em::dot8_arm),
                Output::Same => {
                    if !armv7em::rows8::<false>(src, taps, dst.reborrow()) {
                        rows_with::<i32, 8, false>(src, taps, dst, armv7em::dot8_arm);
                    }
                }
            }
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if taps.stride == 8 + 2 && crate::cpu::has_avx2() {
            // SAFETY: the CPU has AVX2 (checked at run time).
            unsafe {
                match out {
                    Output::U8 => avx2::rows8::<true>(src, taps, dst),
                    Output::Same => avx2::rows8::<false>(src, taps, dst),
                }
            }
            return;
        }
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        if taps.stride == 8 + 2 && crate::cpu::has_neon() {
            match out {
                Output::U8 => rows_with::<i32, 8, true>(src, taps, dst, neon::dot8),
                Output::Same => rows_with::<i32, 8, false>(src, taps, dst, neon::dot8),
            }
            return;
        }
        rows_i32_best(src, taps, dst, out)
    }
    #[cfg_attr(not(all(target_arch = "aarch64", target_feature = "neon")), allow(unused_mut))]
    fn pass_cols(src: FrameRef<'_, i32>, taps: &Taps<'_>, mut dst: FrameMut<'_, i32>, out: Output) {
        #[cfg(fusion_arm_dsp)]
        if taps.stride == 8 + 2 && matches!(out, Output::Same) {
            armv7em::cols8::<i32, false>(src, taps, dst, armv7em::i32_to_same);
            return;
        }
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        if taps.stride == 8 + 2
            && matches!(out, Output::Same)
            && crate::cpu::has_neon()
            && neon::cols8(src, taps, dst.reborrow())
        {
            return;
        }
        cols_i32_best(src, taps, dst, out)
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2;

/// Resizes every row (along the width) with `taps`: `dst` must be `taps`' output length wide
/// and as high as `src`.
pub fn pass_rows<T: Sample>(src: FrameRef<'_, T>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) {
    T::pass_rows(src, taps, dst, out)
}

/// Columns per block of the column pass: each output row is computed `COLS` columns at a
/// time from `N` fixed-size row segments, so the inner loops index constant-size arrays (no
/// bounds checks) and keep one accumulator in registers.
const COLS: usize = 32;

#[inline(always)]
fn cols_n<T: Copy + Into<i64> + Default, const N: usize, const U8: bool>(
    src: FrameRef<'_, T>,
    taps: &Taps<'_>,
    mut dst: FrameMut<'_, i32>,
) {
    let zero = [T::default(); COLS];
    for (d, row) in dst.rows_mut().zip(taps.table.chunks_exact(taps.stride.max(1))) {
        let Some((start, ws)) = row_n::<N>(row) else {
            d.fill(0);
            continue;
        };
        let rows: [&[T]; N] =
            core::array::from_fn(|t| if start + t < src.height() { src.row(start + t) } else { &[] });
        let (blocks, tail) = d.as_chunks_mut::<COLS>();
        for (b, block) in blocks.iter_mut().enumerate() {
            let segs: [&[T; COLS]; N] = core::array::from_fn(|t| {
                rows.get(t)
                    .and_then(|r| r.get(b * COLS..))
                    .and_then(|r| r.first_chunk::<COLS>())
                    .unwrap_or(&zero)
            });
            for (k, o) in block.iter_mut().enumerate() {
                let acc = segs.iter().zip(ws).fold(0i64, |acc, (seg, &w)| {
                    acc + seg.get(k).copied().unwrap_or_default().into() * i64::from(w)
                });
                *o = finish::<U8>(acc);
            }
        }
        let x0 = blocks.len() * COLS;
        for (k, o) in tail.iter_mut().enumerate() {
            let acc = rows.iter().zip(ws).fold(0i64, |acc, (r, &w)| {
                acc + r.get(x0 + k).copied().unwrap_or_default().into() * i64::from(w)
            });
            *o = finish::<U8>(acc);
        }
    }
}

#[inline(always)]
fn cols_any<T: Copy + Into<i64> + Default, const U8: bool>(
    src: FrameRef<'_, T>,
    taps: &Taps<'_>,
    mut dst: FrameMut<'_, i32>,
) {
    for (d, (start, ws)) in dst.rows_mut().zip(taps.iter()) {
        for (x, o) in d.iter_mut().enumerate() {
            let acc = ws.iter().enumerate().fold(0i64, |acc, (t, &w)| {
                let v = if start + t < src.height() { src.row(start + t).get(x).copied() } else { None };
                acc + v.unwrap_or_default().into() * i64::from(w)
            });
            *o = finish::<U8>(acc);
        }
    }
}

#[inline(always)]
fn cols_kernel<T: Copy + Into<i64> + Default>(
    src: FrameRef<'_, T>,
    taps: &Taps<'_>,
    dst: FrameMut<'_, i32>,
    out: Output,
) {
    by_taps!(taps.stride - 2, out, cols_n, cols_any, src, taps, dst)
}

#[inline(always)]
fn cols_u8(src: FrameRef<'_, u8>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) {
    cols_kernel(src, taps, dst, out)
}

#[inline(always)]
fn cols_i32(src: FrameRef<'_, i32>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) {
    cols_kernel(src, taps, dst, out)
}

crate::cpu::dispatch! {
    fn cols_u8_best(src: FrameRef<'_, u8>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) => cols_u8
}
crate::cpu::dispatch! {
    fn cols_i32_best(src: FrameRef<'_, i32>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) => cols_i32
}

#[cfg(fusion_arm_dsp)]
mod armv7em;
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
mod neon;

/// [`pass_rows`] into [`Output::U8`] of a source whose samples all lie in `0..=255` (the
/// output of a `U8` pass), which lets the Cortex-M kernel round in 32 bits; the same bytes as
/// [`pass_rows`] (which it runs on other targets, or when a table row reaches outside).
pub(crate) fn pass_rows_u8_range(src: FrameRef<'_, i32>, taps: &Taps<'_>, mut dst: FrameMut<'_, i32>) {
    #[cfg(fusion_arm_dsp)]
    if armv7em::rows8::<true>(src, taps, dst.reborrow()) {
        return;
    }
    pass_rows(src, taps, dst.reborrow(), Output::U8)
}

/// Resizes every column (along the height) with `taps`: `dst` must be as wide as `src` and
/// `taps`' output length high.
pub fn pass_cols<T: Sample>(src: FrameRef<'_, T>, taps: &Taps<'_>, dst: FrameMut<'_, i32>, out: Output) {
    T::pass_cols(src, taps, dst, out)
}

#[cfg(test)]
mod tests;
