//! Shannon entropy of 8-bit histograms and the entropy ratio `r_H = H(IR)/H(VIS)`, in integers.
//!
//! `N·H = N·log₂N − Σ c·log₂c` (counts `c` of the 256 bins), so the ratio needs no division
//! by `N`: `r_H = (N·H)_IR / (N·H)_VIS`. `log₂` is the bit-by-bit integer algorithm
//! ([`log2_q32`]: normalise to [1, 2), square, read one bit per squaring) in Q32; its error is
//! < 2⁻³⁰ (checked against `f64::log2` in the tests), so `N·H` is within `2N·2⁻³⁰` and `H`
//! within 2⁻²⁹ ≈ 1.9·10⁻⁹ bits. `r_H` is returned in Q32, rounded. A histogram with a single
//! occupied bin has `H = 0` exactly (tested by counting bins, not by comparing a rounded
//! value with 0).

/// `log₂(x)·2³²` for `x ≥ 1` (0 for `x = 0`), error < 2⁻³⁰ in `log₂` units.
pub fn log2_q32(x: u64) -> u64 {
    if x == 0 {
        return 0;
    }
    let e = 63 - u64::from(x.leading_zeros());
    // Mantissa in [1, 2) as Q62.
    let mut m: u128 = u128::from(x) << (62 - e);
    let mut frac: u64 = 0;
    for bit in (0..32).rev() {
        m = (m * m) >> 62;
        if m >= 1u128 << 63 {
            m >>= 1;
            frac |= 1u64 << bit;
        }
    }
    (e << 32) | frac
}

/// `N·H·2³²` of a histogram, and the number of occupied bins.
pub fn weighted_entropy(hist: &[u32; 256]) -> (u128, usize) {
    let n: u64 = hist.iter().map(|&c| u64::from(c)).sum();
    let bins = hist.iter().filter(|&&c| c > 0).count();
    let sum_c_log: u128 =
        hist.iter().filter(|&&c| c > 0).map(|&c| u128::from(c) * u128::from(log2_q32(u64::from(c)))).sum();
    let total = u128::from(n) * u128::from(log2_q32(n));
    (total.saturating_sub(sum_c_log), bins)
}

/// `round(2³²·a/b)` for `b > 0` (saturating at `u64::MAX`).
pub fn ratio_q32(a: u128, b: u128) -> u64 {
    if b == 0 {
        return u64::MAX;
    }
    let num = (a << 32).saturating_add(b / 2);
    u64::try_from(num / b).unwrap_or(u64::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log2_is_within_2_pow_minus_30() {
        for x in [1u64, 2, 3, 5, 7, 100, 255, 1000, 65535, 1 << 20, 1_000_003, (1 << 28) - 1, 1 << 28] {
            let got = log2_q32(x) as f64 / 4294967296.0;
            let want = libm::log2(x as f64);
            assert!((got - want).abs() < 1.0 / 1073741824.0, "log2({x}) = {got}, want {want}");
        }
    }

    #[test]
    fn entropy_of_two_equal_bins_is_one_bit() {
        let mut h = [0u32; 256];
        h[3] = 500;
        h[200] = 500;
        let (nh, bins) = weighted_entropy(&h);
        assert_eq!(bins, 2);
        // N·H = 1000 bits.
        assert!((nh as f64 / 4294967296.0 - 1000.0).abs() < 1e-5);
        let mut one = [0u32; 256];
        one[9] = 77;
        assert_eq!(weighted_entropy(&one), (0, 1));
        assert_eq!(ratio_q32(3, 2), 3 << 31);
    }
}
