//! Status codes and error details.

use core::ffi::c_char;
use fusion_nostd::Error;

/// What a call did: `FUSION_STATUS_OK` (0) or why it refused its input. Every value is stable
/// (flight software may log or downlink the number).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FusionStatus {
    /// Success.
    Ok = 0,
    /// A required pointer (configuration, image data, scratch, state) was NULL.
    NullPointer = 1,
    /// A width or height of zero.
    ZeroDimension = 2,
    /// A width or height above 16384 (`values[0]`: the side).
    DimensionTooLarge = 3,
    /// A row stride below the width (`values[0]`: stride, `values[1]`: width).
    StrideTooSmall = 4,
    /// An image whose extent `(height − 1)·stride + width` overflows the address space
    /// (`values[0]`: elements needed, `values[1]`: given).
    BufferTooSmall = 5,
    /// Frames whose sizes do not fit the rescale policy, or an output that is not on the fusion
    /// grid (`values[0..2]`: the size expected, `values[2..4]`: the size given).
    SizeMismatch = 6,
    /// A strip run whose rescale is not an exact 2× of the policy's filter.
    UnsupportedRatio = 7,
    /// The scratch is too small (`values[0]`: bytes needed, `values[1]`: bytes given; for the
    /// core's own per-plane check, pixels).
    ScratchTooSmall = 8,
    /// A sample outside the accepted range.
    ValueOutOfRange = 9,
    /// A parameter outside its documented range (`name`: which one).
    InvalidParameter = 10,
    /// The scratch or AGC state is not 4-byte aligned.
    Misaligned = 11,
    /// The output overlaps an input, the scratch or the state.
    Overlap = 12,
    /// An error this version of the library has no code for (a newer core).
    Unknown = 255,
}

impl FusionStatus {
    /// The status of a numeric value (`Unknown` for a value that is none).
    pub(crate) fn from_code(code: core::ffi::c_int) -> Self {
        use FusionStatus::*;
        [
            Ok,
            NullPointer,
            ZeroDimension,
            DimensionTooLarge,
            StrideTooSmall,
            BufferTooSmall,
            SizeMismatch,
            UnsupportedRatio,
            ScratchTooSmall,
            ValueOutOfRange,
            InvalidParameter,
            Misaligned,
            Overlap,
        ]
        .into_iter()
        .find(|s| *s as core::ffi::c_int == code)
        .unwrap_or(Unknown)
    }
}

/// Details of a refused call. Pass one (or NULL) to any function that returns a
/// [`FusionStatus`]; it is written on every return, with `status` equal to the returned value.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FusionError {
    /// The returned status.
    pub status: FusionStatus,
    /// The numbers of the error, as documented on each [`FusionStatus`] value (else 0).
    pub values: [usize; 4],
    /// For `FUSION_STATUS_INVALID_PARAMETER`: the parameter's name, NUL-terminated (cut to 31
    /// bytes); else the empty string.
    pub name: [c_char; 32],
}

impl FusionError {
    /// The detail record of `status` with no numbers and no name.
    pub(crate) const fn of(status: FusionStatus) -> Self {
        FusionError { status, values: [0; 4], name: [0; 32] }
    }

    /// The detail record of a core error.
    pub(crate) fn from_core(e: Error) -> Self {
        let (status, values) = match e {
            Error::ZeroDimension => (FusionStatus::ZeroDimension, [0; 4]),
            Error::DimensionTooLarge { value } => (FusionStatus::DimensionTooLarge, [value, 0, 0, 0]),
            Error::StrideTooSmall { stride, width } => (FusionStatus::StrideTooSmall, [stride, width, 0, 0]),
            Error::BufferTooSmall { needed, got } => (FusionStatus::BufferTooSmall, [needed, got, 0, 0]),
            Error::SizeMismatch { expected, got } => {
                (FusionStatus::SizeMismatch, [expected.0, expected.1, got.0, got.1])
            }
            Error::UnsupportedRatio => (FusionStatus::UnsupportedRatio, [0; 4]),
            Error::ScratchTooSmall { needed, capacity } => {
                (FusionStatus::ScratchTooSmall, [needed, capacity, 0, 0])
            }
            Error::ValueOutOfRange | Error::NonFinite => (FusionStatus::ValueOutOfRange, [0; 4]),
            Error::InvalidParameter { name } => return Self::invalid(name),
            _ => (FusionStatus::Unknown, [0; 4]),
        };
        FusionError { status, values, name: [0; 32] }
    }

    /// `FUSION_STATUS_INVALID_PARAMETER` naming `name`.
    pub(crate) fn invalid(name: &str) -> Self {
        let mut e = Self::of(FusionStatus::InvalidParameter);
        for (d, s) in e.name.iter_mut().take(31).zip(name.bytes()) {
            *d = s as c_char;
        }
        e
    }
}

/// Writes `e` to the caller's record (if any) and returns its status.
pub(crate) fn report(e: FusionError, out: *mut FusionError) -> FusionStatus {
    // SAFETY: the caller passes NULL or a pointer to a writable `FusionError` (header contract).
    if let Some(slot) = unsafe { out.as_mut() } {
        *slot = e;
    }
    e.status
}

/// Runs `body` and reports its outcome to `out`.
pub(crate) fn run(out: *mut FusionError, body: impl FnOnce() -> Result<(), FusionError>) -> FusionStatus {
    report(body().err().unwrap_or(FusionError::of(FusionStatus::Ok)), out)
}

/// One line of English for a status value, NUL-terminated, static (never freed); a value
/// that is no status gives `"unknown error"`.
#[unsafe(no_mangle)]
pub extern "C" fn fusion_status_text(status: core::ffi::c_int) -> *const c_char {
    let text: &'static core::ffi::CStr = match FusionStatus::from_code(status) {
        FusionStatus::Ok => c"success",
        FusionStatus::NullPointer => c"a required pointer is NULL",
        FusionStatus::ZeroDimension => c"frame width or height is zero",
        FusionStatus::DimensionTooLarge => c"frame dimension exceeds 16384",
        FusionStatus::StrideTooSmall => c"row stride is smaller than the width",
        FusionStatus::BufferTooSmall => c"image extent overflows the address space",
        FusionStatus::SizeMismatch => c"frame sizes do not fit the rescale policy or the output grid",
        FusionStatus::UnsupportedRatio => c"strips need an exact 2x rescale",
        FusionStatus::ScratchTooSmall => c"scratch too small for this frame",
        FusionStatus::ValueOutOfRange => c"sample value outside the accepted range",
        FusionStatus::InvalidParameter => c"parameter out of range",
        FusionStatus::Misaligned => c"scratch or state is not 4-byte aligned",
        FusionStatus::Overlap => c"the output overlaps an input, the scratch or the state",
        FusionStatus::Unknown => c"unknown error",
    };
    text.as_ptr()
}

/// The library's version, `"MAJOR.MINOR.PATCH"`, NUL-terminated, static.
#[unsafe(no_mangle)]
pub extern "C" fn fusion_version() -> *const c_char {
    const VERSION: &core::ffi::CStr =
        match core::ffi::CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
            Ok(v) => v,
            Err(_) => c"unknown",
        };
    VERSION.as_ptr()
}
