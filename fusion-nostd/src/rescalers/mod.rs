//! Rescalers: bicubic (Keys, a = −0.75) and area, with OpenCV `cv2.resize` conventions.
//!
//! One entry point, [`rescale`], for `u8`, `u16` and `f32` frames of any sizes (up to
//! [`crate::MAX_DIMENSION`]). The destination view's size is the requested output size.
//!
//! | sample | 2× up / 2× down | other ratios |
//! |---|---|---|
//! | `u8` | dedicated integer kernels, **bit-exact** with `cv2.resize` | exact integer path; area exact, cubic within ±1 level of the exact formula |
//! | `u16` | exact integer rule (cv2 itself is within ±1 of it) | as `u8` |
//! | `f32` | `f32` evaluation, within `1e-6·max|input|` of the exact value | same |
//!
//! The integer paths use no floating point. See `docs/reference/rescale-semantics.md` and
//! the module docs of `taps` (coordinates), `bicubic` and `area` (the 2× kernels).

mod area;
mod bicubic;
mod general;
mod taps;

use crate::{Error, FrameMut, FrameRef};

/// The interpolation filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Filter {
    /// Keys cubic convolution, a = −0.75 (`cv2.INTER_CUBIC`). No antialiasing when shrinking.
    Cubic,
    /// Pixel-area relation (`cv2.INTER_AREA`): box average when shrinking, replication with
    /// boundary blending when enlarging.
    Area,
}

/// A sample type the rescalers accept.
pub trait Sample: Copy + sealed::Sealed {
    /// Rescales `src` into `dst` (already validated views). See [`rescale`].
    #[doc(hidden)]
    fn rescale_views(src: FrameRef<'_, Self>, dst: FrameMut<'_, Self>, filter: Filter) -> Result<(), Error>;
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for u8 {}
    impl Sealed for u16 {}
    impl Sealed for f32 {}
}

/// How `dst` relates to `src` along both axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Ratio {
    Same,
    Up2,
    Down2,
    Other,
}

fn ratio(src: (usize, usize), dst: (usize, usize)) -> Ratio {
    if src == dst {
        Ratio::Same
    } else if dst.0 == 2 * src.0 && dst.1 == 2 * src.1 {
        Ratio::Up2
    } else if src.0 == 2 * dst.0 && src.1 == 2 * dst.1 {
        Ratio::Down2
    } else {
        Ratio::Other
    }
}

fn copy_frame<T: Copy>(src: FrameRef<'_, T>, mut dst: FrameMut<'_, T>) {
    for (out, row) in dst.rows_mut().zip(src.rows()) {
        for (o, v) in out.iter_mut().zip(row) {
            *o = *v;
        }
    }
}

impl Sample for u8 {
    fn rescale_views(src: FrameRef<'_, u8>, dst: FrameMut<'_, u8>, filter: Filter) -> Result<(), Error> {
        match (ratio(src.size(), dst.size()), filter) {
            (Ratio::Same, _) => copy_frame(src, dst),
            (Ratio::Up2, Filter::Cubic) => bicubic::up2_u8(src, dst),
            (Ratio::Down2, Filter::Cubic) => bicubic::down2_u8(src, dst),
            (Ratio::Up2, Filter::Area) => area::up2(src, dst),
            (Ratio::Down2, Filter::Area) => area::down2_u8(src, dst),
            (Ratio::Other, _) => general::rescale_integer(src, dst, filter),
        }
        Ok(())
    }
}

impl Sample for u16 {
    fn rescale_views(src: FrameRef<'_, u16>, dst: FrameMut<'_, u16>, filter: Filter) -> Result<(), Error> {
        match (ratio(src.size(), dst.size()), filter) {
            (Ratio::Same, _) => copy_frame(src, dst),
            (Ratio::Up2, Filter::Area) => area::up2(src, dst),
            (Ratio::Down2, Filter::Area) => area::down2_u16(src, dst),
            _ => general::rescale_integer(src, dst, filter),
        }
        Ok(())
    }
}

/// The largest magnitude the `f32` rescaler accepts: 2¹²⁰ ≈ 1.33·10³⁶.
///
/// Every output is a weighted sum of inputs whose weights' absolute values add up to at most
/// 1.375² < 2 (Keys cubic, a = −0.75, both axes) or exactly 1 (area; the 2× area kernel adds four
/// samples before scaling, ≤ 4·max), and no partial sum exceeds that, so with inputs within
/// ±2¹²⁰ every intermediate stays below 2¹²³, far from `f32::MAX` ≈ 2¹²⁸: the output is finite.
/// Larger finite inputs could overflow to ±∞ and are refused with [`Error::ValueOutOfRange`].
pub const F32_MAX_MAGNITUDE: f32 = (1u128 << 120) as f32;

/// `NonFinite` if any sample is NaN or ±∞, else `ValueOutOfRange` if any magnitude exceeds
/// [`F32_MAX_MAGNITUDE`]. Denormals and signed zeros are ordinary values.
fn check_f32_input(src: FrameRef<'_, f32>) -> Result<(), Error> {
    let mut too_large = false;
    for row in src.rows() {
        for v in row {
            if !v.is_finite() {
                return Err(Error::NonFinite);
            }
            too_large |= v.abs() > F32_MAX_MAGNITUDE;
        }
    }
    if too_large { Err(Error::ValueOutOfRange) } else { Ok(()) }
}

impl Sample for f32 {
    fn rescale_views(src: FrameRef<'_, f32>, dst: FrameMut<'_, f32>, filter: Filter) -> Result<(), Error> {
        check_f32_input(src)?;
        match (ratio(src.size(), dst.size()), filter) {
            (Ratio::Same, _) => copy_frame(src, dst),
            (Ratio::Up2, Filter::Area) => area::up2(src, dst),
            (Ratio::Down2, Filter::Area) => area::down2_f32(src, dst),
            _ => general::rescale_float(src, dst, filter),
        }
        Ok(())
    }
}

/// Rescales `src` to the size of `dst` with `filter`.
///
/// Any sizes from 1×1 up to [`crate::MAX_DIMENSION`] on each axis; the views were
/// validated when built, so the only errors concern `f32` input: NaN or ±∞
/// ([`Error::NonFinite`]) and magnitudes above [`F32_MAX_MAGNITUDE`]
/// ([`Error::ValueOutOfRange`]); `dst` is then left untouched. Integer samples saturate
/// (never wrap); `u16` frames use the full 16-bit range (there is no bit-depth parameter).
///
/// ```
/// use fusion_nostd::{rescale, Filter, FrameMut, FrameRef};
/// let src = [10u8, 20, 30, 40];
/// let mut out = [0u8; 16];
/// rescale(FrameRef::new(&src, 2, 2)?, FrameMut::new(&mut out, 4, 4)?, Filter::Area)?;
/// assert_eq!(&out[..4], &[10, 10, 20, 20]);
/// # Ok::<(), fusion_nostd::Error>(())
/// ```
pub fn rescale<T: Sample>(src: FrameRef<'_, T>, dst: FrameMut<'_, T>, filter: Filter) -> Result<(), Error> {
    T::rescale_views(src, dst, filter)
}

/// The exact integer path for any ratio, bypassing the 2× kernels (u8).
///
/// Public so tests and benchmarks can check the dedicated kernels against it; pipelines
/// call [`rescale`].
pub fn rescale_general_u8(src: FrameRef<'_, u8>, dst: FrameMut<'_, u8>, filter: Filter) {
    general::rescale_integer(src, dst, filter);
}

#[cfg(test)]
mod tests {
    use super::*;

    // rescale-semantics.md §4.1, 4×4 → 8×8.
    const UP_IN: [u8; 16] = [188, 255, 213, 168, 255, 255, 0, 248, 0, 195, 182, 194, 45, 88, 221, 49];
    const UP_CUBIC: [u8; 64] = [
        173, 198, 240, 255, 250, 216, 176, 152, 207, 226, 255, 238, 179, 155, 178, 191, 255, 255, 255, 201,
        60, 51, 181, 255, 198, 220, 255, 190, 46, 46, 189, 255, 38, 96, 192, 213, 145, 141, 200, 234, 0, 23,
        119, 196, 212, 202, 169, 150, 17, 41, 80, 148, 212, 199, 115, 65, 47, 51, 55, 120, 213, 197, 82, 14,
    ];
    // §4.2, 16 wide × 8 high → 8 × 4.
    const DOWN_IN: [u8; 128] = [
        255, 86, 192, 88, 188, 239, 131, 201, 255, 255, 156, 136, 183, 20, 158, 215, 34, 55, 255, 166, 138,
        50, 37, 0, 170, 0, 255, 42, 47, 156, 0, 153, 0, 159, 57, 238, 36, 244, 203, 0, 0, 227, 87, 21, 31,
        246, 73, 0, 76, 235, 0, 255, 55, 83, 41, 217, 0, 220, 141, 229, 45, 0, 129, 0, 60, 0, 114, 0, 0, 40,
        21, 255, 255, 0, 62, 0, 151, 255, 246, 0, 0, 119, 0, 0, 255, 56, 118, 47, 0, 197, 0, 124, 131, 243,
        211, 0, 7, 171, 194, 21, 140, 0, 0, 138, 55, 219, 221, 111, 47, 48, 64, 99, 255, 129, 255, 101, 192,
        128, 78, 80, 173, 143, 0, 102, 0, 41, 105, 5,
    ];
    const DOWN_CUBIC: [u8; 32] = [
        87, 193, 160, 67, 169, 164, 101, 135, 154, 139, 96, 131, 114, 121, 57, 40, 29, 0, 103, 115, 118, 4,
        240, 118, 135, 152, 119, 70, 156, 122, 8, 70,
    ];
    const DOWN_AREA: [u8; 32] = [
        108, 175, 154, 92, 170, 147, 102, 132, 118, 138, 105, 115, 112, 120, 81, 51, 45, 29, 88, 110, 113,
        47, 195, 114, 141, 143, 115, 74, 148, 109, 34, 68,
    ];

    fn run(
        src: &[u8],
        sw: usize,
        sh: usize,
        dw: usize,
        dh: usize,
        filter: Filter,
    ) -> Result<[u8; 64], Error> {
        let mut out = [0u8; 64];
        rescale(FrameRef::new(src, sw, sh)?, FrameMut::new(&mut out, dw, dh)?, filter)?;
        Ok(out)
    }

    fn run_general(
        src: &[u8],
        sw: usize,
        sh: usize,
        dw: usize,
        dh: usize,
        filter: Filter,
    ) -> Result<[u8; 64], Error> {
        let mut out = [0u8; 64];
        rescale_general_u8(FrameRef::new(src, sw, sh)?, FrameMut::new(&mut out, dw, dh)?, filter);
        Ok(out)
    }

    #[test]
    fn worked_example_cubic_up() -> Result<(), Error> {
        assert_eq!(run(&UP_IN, 4, 4, 8, 8, Filter::Cubic)?, UP_CUBIC);
        assert_eq!(run_general(&UP_IN, 4, 4, 8, 8, Filter::Cubic)?, UP_CUBIC);
        Ok(())
    }

    #[test]
    fn worked_example_area_up_replicates() -> Result<(), Error> {
        for out in [run(&UP_IN, 4, 4, 8, 8, Filter::Area)?, run_general(&UP_IN, 4, 4, 8, 8, Filter::Area)?] {
            for (i, v) in out.iter().enumerate() {
                let (x, y) = (i % 8, i / 8);
                assert_eq!(Some(v), UP_IN.get((y / 2) * 4 + x / 2), "({x}, {y})");
            }
        }
        Ok(())
    }

    #[test]
    fn worked_example_down() -> Result<(), Error> {
        for (filter, expect) in [(Filter::Cubic, DOWN_CUBIC), (Filter::Area, DOWN_AREA)] {
            for out in [run(&DOWN_IN, 16, 8, 8, 4, filter)?, run_general(&DOWN_IN, 16, 8, 8, 4, filter)?] {
                assert_eq!(out.get(..32), Some(&expect[..]), "{filter:?}");
            }
        }
        Ok(())
    }

    #[test]
    fn worked_example_area_down_f32_is_exact() -> Result<(), Error> {
        let src: [f32; 128] = core::array::from_fn(|i| f32::from(DOWN_IN.get(i).copied().unwrap_or(0)));
        let mut out = [0f32; 32];
        rescale(FrameRef::new(&src, 16, 8)?, FrameMut::new(&mut out, 8, 4)?, Filter::Area)?;
        assert_eq!(out.get(..3), Some(&[107.5f32, 175.25, 153.75][..]));
        assert_eq!(out.get(24..27), Some(&[140.5f32, 142.75, 115.0][..]));
        Ok(())
    }

    #[test]
    fn worked_example_cubic_up_f32_row0() -> Result<(), Error> {
        let src: [f32; 16] = core::array::from_fn(|i| f32::from(UP_IN.get(i).copied().unwrap_or(0)));
        let mut out = [0f32; 64];
        rescale(FrameRef::new(&src, 4, 4)?, FrameMut::new(&mut out, 8, 8)?, Filter::Cubic)?;
        let exact = [11345717, 13002411, 15746969, 17108448, 16416768, 14169399, 11539077, 9932451];
        for (o, n) in out.iter().zip(exact) {
            let e = f64::from(n) / 65536.0;
            assert!((f64::from(*o) - e).abs() <= 1e-6 * 255.0, "{o} vs {e}");
        }
        Ok(())
    }

    #[test]
    fn non_finite_f32_is_rejected() -> Result<(), Error> {
        let src = [1.0f32, f32::NAN, 0.0, 0.0];
        let mut out = [7f32; 16];
        let r = rescale(FrameRef::new(&src, 2, 2)?, FrameMut::new(&mut out, 4, 4)?, Filter::Cubic);
        assert_eq!(r, Err(Error::NonFinite));
        assert!(out.iter().all(|v| *v == 7.0));
        Ok(())
    }
}
