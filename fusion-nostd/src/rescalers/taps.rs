//! Per-axis resampling rules: which source samples an output sample reads, with what weight.
//!
//! Both filters are separable, so a 2-D rescale is one rule per axis. Coordinates follow
//! OpenCV's `cv2.resize` (see `docs/reference/rescale-semantics.md`):
//!
//! * **Cubic** — centres aligned: output `d` sits at source `u = (d + ½)·n_src/n_dst − ½`;
//!   `i = ⌊u⌋`, `t = u − i`; taps `i−1 … i+2` with Keys weights (a = −¾)
//!   `W(1+t), W(t), W(1−t), W(2−t)`; indices clamped (replicate border). No widening when
//!   shrinking.
//! * **Area, shrinking** — output `d` averages the source interval `[d·s, (d+1)·s)`,
//!   `s = n_src/n_dst`, each source pixel weighted by its overlap (exact integers in units of
//!   `1/n_dst` source pixels, so the weights are `overlap / n_src`).
//! * **Area, enlarging** — OpenCV's rule: output `d` copies source `i = ⌊d·s⌋`; only if it
//!   straddles the boundary to `i+1` does `i+1` get the fraction `f = (d+1) − (i+1)/s`.
//!   At an integer factor this is plain replication.
//!
//! Each axis picks its rule independently (OpenCV instead switches the whole frame to its
//! bilinear machinery when one axis enlarges under `INTER_AREA`; we keep the per-axis rule).
//!
//! Weights come in two forms: integer numerators over a per-axis denominator (used by the
//! u8/u16 paths, no FPU needed) and `f64` values (used by the `f32` path).

/// Fractional bits of the integer cubic weights on the general path.
///
/// At factor 2 every Keys weight is a multiple of 1/256, so Q20 weights are exact there and
/// the general path agrees bit for bit with the dedicated 2× kernels. With 16-bit samples the
/// exact numerator stays below 65535 · (1.4 · 2²⁰)² < 2⁵⁸, inside `i64`.
pub(crate) const CUBIC_WEIGHT_BITS: u32 = 20;

/// Fractional bits to which the cubic phase `t` is quantised on the integer path.
const CUBIC_PHASE_BITS: u32 = 24;

/// Keys cubic kernel with a = −0.75, in `f64`.
pub(crate) fn keys_f64(x: f64) -> f64 {
    const A: f64 = -0.75;
    let x = if x < 0.0 { -x } else { x };
    if x <= 1.0 {
        ((A + 2.0) * x - (A + 3.0)) * x * x + 1.0
    } else if x < 2.0 {
        ((A * x - 5.0 * A) * x + 8.0 * A) * x - 4.0 * A
    } else {
        0.0
    }
}

/// Keys kernel (a = −0.75) at `x = X / 2²⁴` (0 ≤ X < 2·2²⁴), as a numerator over 4·2⁷².
///
/// `W(x) = (5x³ − 9x² + 4)/4` on `[0, 1]` and `−3(x³ − 5x² + 8x − 4)/4` on `(1, 2)`.
/// Setup code (once per output row or column), so `i128` is fine on every target.
fn keys_q(x: i128) -> i128 {
    let one = 1i128 << CUBIC_PHASE_BITS;
    let x2 = x * x; // Q32
    let x3 = x2 * x; // Q48
    if x <= one {
        5 * x3 - 9 * (x2 << CUBIC_PHASE_BITS) + 4 * (one * one * one)
    } else {
        -3 * (x3 - 5 * (x2 << CUBIC_PHASE_BITS) + 8 * (x * one * one) - 4 * (one * one * one))
    }
}

/// Rounds `num / 2^shift` to the nearest integer, ties away from zero (setup code only).
fn round_shift(num: i128, shift: u32) -> i64 {
    let half = 1i128 << (shift - 1);
    let r = if num >= 0 { (num + half) >> shift } else { -((-num + half) >> shift) };
    r as i64
}

/// The resampling rule of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum AxisRule {
    /// Keys cubic, centres aligned.
    Cubic { n_src: usize, n_dst: usize },
    /// Box coverage (`n_src >= n_dst`).
    AreaShrink { n_src: usize, n_dst: usize },
    /// OpenCV's area enlargement (`n_src < n_dst`).
    AreaEnlarge { n_src: usize, n_dst: usize },
}

impl AxisRule {
    /// The rule for `filter` mapping `n_src` samples to `n_dst`.
    pub(crate) fn new(filter: super::Filter, n_src: usize, n_dst: usize) -> Self {
        match filter {
            super::Filter::Cubic => AxisRule::Cubic { n_src, n_dst },
            super::Filter::Area if n_src >= n_dst => AxisRule::AreaShrink { n_src, n_dst },
            super::Filter::Area => AxisRule::AreaEnlarge { n_src, n_dst },
        }
    }

    /// The common denominator of this axis's integer weights (they sum to it).
    pub(crate) fn denominator(&self) -> i64 {
        match *self {
            AxisRule::Cubic { .. } => 1 << CUBIC_WEIGHT_BITS,
            AxisRule::AreaShrink { n_src, .. } | AxisRule::AreaEnlarge { n_src, .. } => n_src as i64,
        }
    }

    /// `(i, r, den)` for cubic output `d`: `u = i + r/den`, `0 ≤ r < den`.
    fn cubic_phase(d: usize, n_src: usize, n_dst: usize) -> (i64, i64, i64) {
        let num = (2 * d as i64 + 1) * n_src as i64 - n_dst as i64;
        let den = 2 * n_dst as i64;
        // `den` is positive for validated sizes; the checked forms keep panics out of the binary.
        (num.checked_div_euclid(den).unwrap_or(0), num.checked_rem_euclid(den).unwrap_or(0), den)
    }

    /// Calls `f(source_index, weight_numerator)` for every tap of output sample `d`
    /// (source indices already clamped; clamped taps may repeat, their weights add).
    #[inline]
    pub(crate) fn for_each_tap_fixed(&self, d: usize, mut f: impl FnMut(usize, i64)) {
        match *self {
            AxisRule::Cubic { n_src, n_dst } => {
                let (i, r, den) = Self::cubic_phase(d, n_src, n_dst);
                // t in Q16, rounded to nearest (exact for the dyadic phases of factor 2).
                let t = ((i128::from(r) << CUBIC_PHASE_BITS) + i128::from(den / 2))
                    .checked_div(i128::from(den))
                    .unwrap_or(0);
                let one = 1i128 << CUBIC_PHASE_BITS;
                let shift = 2 + 3 * CUBIC_PHASE_BITS - CUBIC_WEIGHT_BITS;
                let w0 = round_shift(keys_q(one + t), shift);
                let w1 = round_shift(keys_q(t), shift);
                let w2 = round_shift(keys_q(one - t), shift);
                // Like OpenCV: the last weight makes the sum exact, so constants are kept.
                let w3 = (1 << CUBIC_WEIGHT_BITS) - w0 - w1 - w2;
                for (k, w) in [w0, w1, w2, w3].into_iter().enumerate() {
                    f(clamp(i - 1 + k as i64, n_src), w);
                }
            }
            AxisRule::AreaShrink { n_src, n_dst } => {
                area_shrink_taps(d, n_src, n_dst, &mut f);
            }
            AxisRule::AreaEnlarge { n_src, n_dst } => {
                let (i, frac) = area_enlarge_phase(d, n_src, n_dst);
                f(i, n_src as i64 - frac);
                if frac > 0 {
                    f(clamp(i as i64 + 1, n_src), frac);
                }
            }
        }
    }

    /// Calls `f(source_index, weight)` for every tap of output sample `d`, weights exact in
    /// `f64` (they sum to 1 up to rounding).
    #[inline]
    pub(crate) fn for_each_tap_float(&self, d: usize, mut f: impl FnMut(usize, f64)) {
        match *self {
            AxisRule::Cubic { n_src, n_dst } => {
                let (i, r, den) = Self::cubic_phase(d, n_src, n_dst);
                let t = r as f64 / den as f64;
                let w0 = keys_f64(1.0 + t);
                let w1 = keys_f64(t);
                let w2 = keys_f64(1.0 - t);
                let w3 = 1.0 - w0 - w1 - w2;
                for (k, w) in [w0, w1, w2, w3].into_iter().enumerate() {
                    f(clamp(i - 1 + k as i64, n_src), w);
                }
            }
            AxisRule::AreaShrink { n_src, n_dst } => {
                let den = n_src as f64;
                area_shrink_taps(d, n_src, n_dst, |k, overlap| f(k, overlap as f64 / den));
            }
            AxisRule::AreaEnlarge { n_src, n_dst } => {
                let (i, frac) = area_enlarge_phase(d, n_src, n_dst);
                let den = n_src as f64;
                f(i, (n_src as i64 - frac) as f64 / den);
                if frac > 0 {
                    f(clamp(i as i64 + 1, n_src), frac as f64 / den);
                }
            }
        }
    }
}

/// Clamps a signed source index into `0..n` (replicate border).
#[inline]
fn clamp(i: i64, n: usize) -> usize {
    if i <= 0 { 0 } else { (i as usize).min(n.saturating_sub(1)) }
}

/// Box-coverage taps of output `d` when shrinking `n_src → n_dst`: `f(k, overlap)` with
/// overlaps in units of `1/n_dst` source pixels (they sum to `n_src`).
#[inline]
fn area_shrink_taps(d: usize, n_src: usize, n_dst: usize, mut f: impl FnMut(usize, i64)) {
    let lo = d * n_src; // output interval [lo, hi) in units of 1/n_dst source pixels
    let hi = lo + n_src;
    let first = lo.checked_div(n_dst).unwrap_or(0);
    let last = (hi + n_dst.saturating_sub(1)).checked_div(n_dst).unwrap_or(0).min(n_src); // exclusive
    for k in first..last {
        let overlap = hi.min((k + 1) * n_dst).saturating_sub(lo.max(k * n_dst));
        if overlap > 0 {
            f(k, overlap as i64);
        }
    }
}

/// OpenCV's area enlargement for output `d`: the source pixel `i` it lies in and the share of
/// `i + 1` as a numerator over `n_src` (0 unless the output pixel straddles a boundary).
#[inline]
fn area_enlarge_phase(d: usize, n_src: usize, n_dst: usize) -> (usize, i64) {
    let i = (d * n_src).checked_div(n_dst).unwrap_or(0);
    // f = (d + 1) − (i + 1)·n_dst/n_src, times n_src:
    let frac = ((d + 1) * n_src) as i64 - ((i + 1) * n_dst) as i64;
    (i.min(n_src.saturating_sub(1)), frac.max(0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rescalers::Filter;

    fn taps(rule: AxisRule, d: usize) -> [(usize, i64); 4] {
        let mut out = [(0, 0); 4];
        let mut n = 0;
        rule.for_each_tap_fixed(d, |k, w| {
            if let Some(slot) = out.get_mut(n) {
                *slot = (k, w);
            }
            n += 1;
        });
        out
    }

    #[test]
    fn factor_two_cubic_weights_match_the_spec_table() {
        // Q14 = the spec's /256 numerators times 64.
        let up = AxisRule::new(Filter::Cubic, 8, 16);
        const S: i64 = 1 << (CUBIC_WEIGHT_BITS - 8);
        assert_eq!(taps(up, 5), [(1, -27 * S), (2, 225 * S), (3, 67 * S), (4, -9 * S)]);
        assert_eq!(taps(up, 6), [(1, -9 * S), (2, 67 * S), (3, 225 * S), (4, -27 * S)]);
        assert_eq!(taps(up, 0), [(0, -9 * S), (0, 67 * S), (0, 225 * S), (1, -27 * S)]);
        let down = AxisRule::new(Filter::Cubic, 16, 8);
        assert_eq!(taps(down, 3), [(5, -3 * 8 * S), (6, 19 * 8 * S), (7, 19 * 8 * S), (8, -3 * 8 * S)]);
    }

    #[test]
    fn area_rules_match_the_spec_examples() {
        // 4 → 10: i = 0,0,0,1,1,2,2,2,3,3 and f = 0,0,½,0,0,0,0,½,0,0 (numerators over 4).
        let rule = AxisRule::new(Filter::Area, 4, 10);
        let expect = [(0, 0), (0, 0), (0, 2), (1, 0), (1, 0), (2, 0), (2, 0), (2, 2), (3, 0), (3, 0)];
        for (d, (i, f)) in expect.into_iter().enumerate() {
            assert_eq!(area_enlarge_phase(d, 4, 10), (i, f), "d = {d}");
            let mut total = 0;
            rule.for_each_tap_fixed(d, |_, w| total += w);
            assert_eq!(total, 4);
        }
        // 5 → 2: [0, 2.5) and [2.5, 5), overlaps in halves.
        let shrink = AxisRule::new(Filter::Area, 5, 2);
        let mut seen = [0i64; 5];
        shrink.for_each_tap_fixed(1, |k, w| seen[k] += w);
        assert_eq!(seen, [0, 0, 1, 2, 2]);
    }

    #[test]
    fn cubic_weights_sum_to_one_and_track_the_float_kernel() {
        for (n_src, n_dst) in [(5usize, 7usize), (7, 5), (3, 11), (100, 33), (1, 4)] {
            let rule = AxisRule::new(Filter::Cubic, n_src, n_dst);
            for d in 0..n_dst {
                let mut sum = 0;
                let mut fixed = [0f64; 4];
                let mut float = [0f64; 4];
                let mut n = 0;
                rule.for_each_tap_fixed(d, |_, w| {
                    sum += w;
                    if let Some(s) = fixed.get_mut(n) {
                        *s = w as f64 / f64::from(1u32 << CUBIC_WEIGHT_BITS);
                    }
                    n += 1;
                });
                n = 0;
                rule.for_each_tap_float(d, |_, w| {
                    if let Some(s) = float.get_mut(n) {
                        *s = w;
                    }
                    n += 1;
                });
                assert_eq!(sum, 1 << CUBIC_WEIGHT_BITS);
                for (a, b) in fixed.iter().zip(&float) {
                    assert!((a - b).abs() < 2e-6, "{n_src}->{n_dst} d={d}: {a} vs {b}");
                }
            }
        }
    }
}
