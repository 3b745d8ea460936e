//! Fusion methods: ADF, TSIFSD, IFEVIP (specs: `docs/reference/fusion-algorithms.md`) and
//! the illumination-adaptive fusion for navigation ([`adaptive`]).
//!
//! Every method takes two aligned `u8` frames of the same size (VIS, TIR), writes a `u8`
//! fused frame and borrows its work planes from a [`crate::ScratchMut`].

pub mod adaptive;
pub mod adf;
pub mod ifevip;
pub mod tsifsd;

/// Which guards a fusion call fired: a bit set (`Guards(bits)`), [`Guards::NONE`] when none.
///
/// A guard replaces a step of the published method that would give NaN, an infinity or an
/// undefined value by a documented rule (see each method's module docs). The bits are
/// reported in every variant; which rule applies depends on the variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Guards(pub u32);

impl Guards {
    /// No guard fired.
    pub const NONE: Guards = Guards(0);
    /// ADF: the 2×2 covariance of the detail layers is zero (constant detail layers).
    pub const ADF_ZERO_COVARIANCE: Guards = Guards(1 << 0);
    /// ADF: the KL eigenvector is degenerate (v₁ + v₂ ≈ 0, or an exact eigenvalue tie).
    pub const ADF_DEGENERATE_EIGENVECTOR: Guards = Guards(1 << 1);
    /// ADF: the published KL weights leave [0, 1] (negatively correlated details); the flight
    /// rule replaced them.
    pub const ADF_WEIGHT_CLAMPED: Guards = Guards(1 << 2);
    /// TSIFSD: at some pixel both saliencies are 0 (the published 0/0); weights ½, ½ used.
    pub const TSIFSD_ZERO_SALIENCY: Guards = Guards(1 << 3);
    /// IFEVIP: the visible image has zero entropy.
    pub const IFEVIP_ZERO_ENTROPY: Guards = Guards(1 << 4);
    /// IFEVIP: fewer than 1/0.001 pixels, top-k with k ≥ 1 used.
    pub const IFEVIP_FEW_PIXELS: Guards = Guards(1 << 5);
    /// IFEVIP: the peak mean m is 0, gain 0.8 used.
    pub const IFEVIP_ZERO_PEAK: Guards = Guards(1 << 6);
    /// Some output pixel was saturated to 0 or 255 by the final 8-bit cast.
    pub const OUTPUT_SATURATED: Guards = Guards(1 << 7);
    /// Adaptive (a decision, not a repair): VIS had no usable signal, the TIR frame passed
    /// through unchanged.
    pub const ADAPTIVE_TIR_ONLY: Guards = Guards(1 << 8);
    /// Adaptive (a decision): some pixel's smoothed VIS was above the glare level and took
    /// (part of) the TIR pixel instead.
    pub const ADAPTIVE_GLARE: Guards = Guards(1 << 9);
    /// Adaptive (a decision): the target was large, the frame was fused by ADF
    /// (`AdaptiveParams::adf`; ADF's own guards are reported beside this one).
    pub const ADAPTIVE_ADF: Guards = Guards(1 << 10);

    /// Every guard with its short name (`fusion fuse` prints these), in bit order.
    pub const NAMED: [(Guards, &'static str); 11] = [
        (Guards::ADF_ZERO_COVARIANCE, "adf-zero-covariance"),
        (Guards::ADF_DEGENERATE_EIGENVECTOR, "adf-degenerate-eigenvector"),
        (Guards::ADF_WEIGHT_CLAMPED, "adf-weight-clamped"),
        (Guards::TSIFSD_ZERO_SALIENCY, "tsifsd-zero-saliency"),
        (Guards::IFEVIP_ZERO_ENTROPY, "ifevip-zero-entropy"),
        (Guards::IFEVIP_FEW_PIXELS, "ifevip-few-pixels"),
        (Guards::IFEVIP_ZERO_PEAK, "ifevip-zero-peak"),
        (Guards::OUTPUT_SATURATED, "saturated"),
        (Guards::ADAPTIVE_TIR_ONLY, "adaptive-tir-only"),
        (Guards::ADAPTIVE_GLARE, "adaptive-glare"),
        (Guards::ADAPTIVE_ADF, "adaptive-adf"),
    ];

    /// Whether every bit of `other` is set in `self`.
    pub const fn contains(self, other: Guards) -> bool {
        self.0 & other.0 == other.0
    }

    /// `self` with the bits of `other` added.
    #[must_use]
    pub const fn with(self, other: Guards) -> Guards {
        Guards(self.0 | other.0)
    }

    /// Whether no bit is set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
}

/// The names of the guards that fired, comma-separated (`none` when empty); a bit without a
/// name prints as hexadecimal.
impl core::fmt::Display for Guards {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.is_empty() {
            return f.write_str("none");
        }
        let mut rest = self.0;
        let mut first = true;
        let mut sep = |f: &mut core::fmt::Formatter<'_>| -> core::fmt::Result {
            if !core::mem::take(&mut first) {
                f.write_str(", ")?;
            }
            Ok(())
        };
        for (g, name) in Guards::NAMED {
            if self.contains(g) {
                sep(f)?;
                f.write_str(name)?;
                rest &= !g.0;
            }
        }
        if rest != 0 {
            sep(f)?;
            write!(f, "{rest:#x}")?;
        }
        Ok(())
    }
}

impl core::ops::BitOr for Guards {
    type Output = Guards;
    fn bitor(self, rhs: Guards) -> Guards {
        Guards(self.0 | rhs.0)
    }
}

impl core::ops::BitOrAssign for Guards {
    fn bitor_assign(&mut self, rhs: Guards) {
        self.0 |= rhs.0;
    }
}

/// Which flavour of a method to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Variant {
    /// The published implementation step for step (border rules included); guarded only where
    /// the original would produce NaN or a panic.
    Classic,
    /// The study's changes plus every unguarded case guarded (pipeline default).
    #[default]
    Flight,
}

/// The size contract of the two-frame methods: VIS, TIR and the output all the same size
/// ([`crate::Error::SizeMismatch`] names the first that differs).
pub(crate) fn check_sizes(
    vis: &crate::FrameRef<'_, u8>,
    tir: &crate::FrameRef<'_, u8>,
    out: (usize, usize),
) -> Result<(), crate::Error> {
    if vis.size() != tir.size() {
        return Err(crate::Error::SizeMismatch { expected: vis.size(), got: tir.size() });
    }
    if out != vis.size() {
        return Err(crate::Error::SizeMismatch { expected: vis.size(), got: out });
    }
    Ok(())
}

/// Rounds half away from zero and saturates to `0..=255`, as MATLAB's `uint8()` cast, for a
/// value in fixed point with `frac_bits` fractional bits.
#[inline]
pub fn round_away_sat_u8(value: i64, frac_bits: u32) -> u8 {
    let r = if frac_bits == 0 {
        value
    } else {
        let half = 1i64 << (frac_bits - 1);
        if value >= 0 { (value + half) >> frac_bits } else { -((-value + half) >> frac_bits) }
    };
    r.clamp(0, 255) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matlab_uint8_cast() {
        assert_eq!(round_away_sat_u8(5 << 7, 8), 3); // 2.5 → 3
        assert_eq!(round_away_sat_u8(-(5 << 7), 8), 0);
        assert_eq!(round_away_sat_u8(262 << 8, 8), 255);
        assert_eq!(round_away_sat_u8((3 << 8) + 127, 8), 3);
        assert_eq!(round_away_sat_u8(17, 0), 17);
    }

    use core::fmt::Write;

    fn shown(g: Guards) -> heapless::String<128> {
        let mut s = heapless::String::new();
        let _ = write!(s, "{g}");
        s
    }

    #[test]
    fn guards_print_as_names_in_bit_order() {
        assert_eq!(shown(Guards::NONE).as_str(), "none");
        assert_eq!(
            shown(Guards::OUTPUT_SATURATED | Guards::TSIFSD_ZERO_SALIENCY).as_str(),
            "tsifsd-zero-saliency, saturated"
        );
        // A bit without a name is not hidden.
        assert_eq!(
            shown(Guards::ADF_WEIGHT_CLAMPED | Guards(1 << 20)).as_str(),
            "adf-weight-clamped, 0x100000"
        );
        // Every named guard is one distinct bit.
        let all = Guards::NAMED.iter().fold(0u32, |acc, (g, _)| {
            assert_eq!(g.0.count_ones(), 1);
            assert_eq!(acc & g.0, 0);
            acc | g.0
        });
        assert_eq!(all, (1 << Guards::NAMED.len()) - 1);
    }
}
