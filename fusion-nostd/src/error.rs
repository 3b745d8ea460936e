//! The core's one error type.

use core::fmt;

/// Why a core call refused its input. Small, `Copy`, allocation-free.
///
/// Every public entry point of the core returns `Err(Error)` for bad input instead of
/// panicking or producing a silently wrong frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Error {
    /// A width or height of zero.
    ZeroDimension,
    /// A width or height above [`crate::MAX_DIMENSION`].
    DimensionTooLarge {
        /// The offending width or height.
        value: usize,
    },
    /// A row stride smaller than the row width.
    StrideTooSmall {
        /// The stride given.
        stride: usize,
        /// The width it must at least be.
        width: usize,
    },
    /// A pixel buffer shorter than the view it is meant to hold.
    BufferTooSmall {
        /// Elements needed.
        needed: usize,
        /// Elements given.
        got: usize,
    },
    /// Two frames that must have the same size do not.
    SizeMismatch {
        /// Width and height of the first frame.
        expected: (usize, usize),
        /// Width and height of the second frame.
        got: (usize, usize),
    },
    /// The requested operation needs an exact size relation that the frames do not have
    /// (for example a 2× rescale between sizes that are not in a 2:1 ratio).
    UnsupportedRatio,
    /// The caller's scratch space is too small for this frame size.
    ScratchTooSmall {
        /// Pixels the operation needs per plane.
        needed: usize,
        /// Pixels the scratch holds per plane.
        capacity: usize,
    },
    /// A NaN or infinite value in a floating-point input.
    NonFinite,
    /// A sample outside the range the operation accepts: an `f32` magnitude above
    /// [`crate::rescalers::F32_MAX_MAGNITUDE`] (where a filter's overshoot could overflow to ±∞),
    /// or a sample above a declared bit depth.
    ValueOutOfRange,
    /// A parameter outside its documented range.
    InvalidParameter {
        /// Which parameter.
        name: &'static str,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::ZeroDimension => write!(f, "frame width or height is zero"),
            Error::DimensionTooLarge { value } => {
                write!(f, "frame dimension {value} exceeds the maximum {}", crate::MAX_DIMENSION)
            }
            Error::StrideTooSmall { stride, width } => {
                write!(f, "row stride {stride} is smaller than the width {width}")
            }
            Error::BufferTooSmall { needed, got } => {
                write!(f, "pixel buffer holds {got} elements, the view needs {needed}")
            }
            Error::SizeMismatch { expected, got } => {
                write!(f, "frame size {}x{} does not match {}x{}", got.0, got.1, expected.0, expected.1)
            }
            Error::UnsupportedRatio => {
                write!(f, "the frame sizes are not in the ratio this operation needs")
            }
            Error::ScratchTooSmall { needed, capacity } => {
                write!(f, "scratch holds {capacity} pixels per plane, this frame needs {needed}")
            }
            Error::NonFinite => write!(f, "non-finite (NaN or infinite) value in the input"),
            Error::ValueOutOfRange => write!(f, "sample value outside the accepted range"),
            Error::InvalidParameter { name } => write!(f, "parameter `{name}` out of range"),
        }
    }
}

impl core::error::Error for Error {}
