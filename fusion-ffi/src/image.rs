//! Images as C passes them, their checks, and the rescalers.

use crate::status::{FusionError, FusionStatus, run};
use fusion_nostd::{Error, Filter, FrameMut, FrameRef};

/// A read-only 8-bit image: `height` rows of `width` pixels, rows `stride` bytes apart.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FusionImage {
    /// First pixel of the first row.
    pub data: *const u8,
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Elements from one row's start to the next (≥ `width`).
    pub stride: usize,
}

/// A writable 8-bit image (see [`FusionImage`]).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FusionImageMut {
    /// First pixel of the first row.
    pub data: *mut u8,
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Elements from one row's start to the next (≥ `width`).
    pub stride: usize,
}

/// A read-only 16-bit image (thermal counts): `stride` in elements, not bytes.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FusionImage16 {
    /// First sample of the first row.
    pub data: *const u16,
    /// Samples per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Elements from one row's start to the next (≥ `width`).
    pub stride: usize,
}

/// A writable 16-bit image: `stride` in elements.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FusionImageMut16 {
    /// First sample of the first row.
    pub data: *mut u16,
    /// Samples per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Elements from one row's start to the next (≥ `width`).
    pub stride: usize,
}

/// The rescale filters.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FusionFilter {
    /// Keys cubic convolution, a = −0.75 (`cv2.INTER_CUBIC`).
    Cubic = 0,
    /// Pixel-area relation (`cv2.INTER_AREA`).
    Area = 1,
}

/// An image's element count `(height − 1)·stride + width`, checked the way the core checks a
/// view (zero and oversized sides, short stride, overflow), before any slice exists.
pub(crate) fn extent(width: usize, height: usize, stride: usize) -> Result<usize, FusionError> {
    let core = |e: Error| FusionError::from_core(e);
    for side in [width, height] {
        if side == 0 {
            return Err(core(Error::ZeroDimension));
        }
        if side > fusion_nostd::MAX_DIMENSION {
            return Err(core(Error::DimensionTooLarge { value: side }));
        }
    }
    if stride < width {
        return Err(core(Error::StrideTooSmall { stride, width }));
    }
    (height - 1)
        .checked_mul(stride)
        .and_then(|n| n.checked_add(width))
        .ok_or(core(Error::BufferTooSmall { needed: usize::MAX, got: 0 }))
}

/// An address range `[start, end)` in bytes, for the overlap checks.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Span(usize, usize);

impl Span {
    /// `len` elements of `T` from `ptr`.
    pub(crate) fn of<T>(ptr: *const T, len: usize) -> Span {
        let start = ptr as usize;
        Span(start, start.saturating_add(len.saturating_mul(core::mem::size_of::<T>())))
    }

    /// Whether the two ranges share a byte.
    pub(crate) fn overlaps(self, other: Span) -> bool {
        self.0 < other.1 && other.0 < self.1
    }
}

/// `Err(Overlap)` when `out` shares a byte with any of `others`.
pub(crate) fn disjoint(out: Span, others: &[Span]) -> Result<(), FusionError> {
    if others.iter().any(|&o| out.overlaps(o)) {
        return Err(FusionError::of(FusionStatus::Overlap));
    }
    Ok(())
}

/// Reads a caller's struct pointer (NULL → `NullPointer`).
pub(crate) fn deref<'a, T>(p: *const T) -> Result<&'a T, FusionError> {
    // SAFETY: the caller passes NULL or a pointer to a valid `T` (header contract).
    unsafe { p.as_ref() }.ok_or(FusionError::of(FusionStatus::NullPointer))
}

macro_rules! image_views {
    ($in:ty, $out:ty, $t:ty) => {
        impl $in {
            /// The core view of this image and its address range.
            pub(crate) fn view<'a>(&self) -> Result<(FrameRef<'a, $t>, Span), FusionError> {
                let len = extent(self.width, self.height, self.stride)?;
                if self.data.is_null() {
                    return Err(FusionError::of(FusionStatus::NullPointer));
                }
                // SAFETY: the caller guarantees `data` points to `len` readable elements that
                // no one writes during the call (header contract); `len` is checked above.
                let data = unsafe { core::slice::from_raw_parts(self.data, len) };
                let view = FrameRef::with_stride(data, self.width, self.height, self.stride)
                    .map_err(FusionError::from_core)?;
                Ok((view, Span::of(self.data, len)))
            }
        }

        impl $out {
            /// The address range this image covers, after the size checks.
            pub(crate) fn span(&self) -> Result<Span, FusionError> {
                let len = extent(self.width, self.height, self.stride)?;
                if self.data.is_null() {
                    return Err(FusionError::of(FusionStatus::NullPointer));
                }
                Ok(Span::of(self.data, len))
            }

            /// The core view of this image. Call only after [`Self::span`] was checked against
            /// every other buffer of the call (no aliasing).
            pub(crate) fn view_mut<'a>(&self) -> Result<FrameMut<'a, $t>, FusionError> {
                let len = extent(self.width, self.height, self.stride)?;
                if self.data.is_null() {
                    return Err(FusionError::of(FusionStatus::NullPointer));
                }
                // SAFETY: the caller guarantees `data` points to `len` writable elements that
                // nothing else accesses during the call; the overlap with this call's other
                // buffers was refused before.
                let data = unsafe { core::slice::from_raw_parts_mut(self.data, len) };
                FrameMut::with_stride(data, self.width, self.height, self.stride)
                    .map_err(FusionError::from_core)
            }
        }
    };
}

image_views!(FusionImage, FusionImageMut, u8);
image_views!(FusionImage16, FusionImageMut16, u16);

/// A filter from its number (`FusionFilter`), or `InvalidParameter "filter"`.
fn filter(code: u32) -> Result<Filter, FusionError> {
    match code {
        c if c == FusionFilter::Cubic as u32 => Ok(Filter::Cubic),
        c if c == FusionFilter::Area as u32 => Ok(Filter::Area),
        _ => Err(FusionError::invalid("filter")),
    }
}

/// Rescales `src` into `dst` (any sizes) with `filter` (`FUSION_FILTER_CUBIC` or
/// `FUSION_FILTER_AREA`), bit-exact with OpenCV's `cv2.resize` on 8-bit frames at factor 2.
///
/// # Safety
/// `src` and `dst` point to valid image descriptions whose `data` covers
/// `(height − 1)·stride + width` elements; `error` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_rescale_u8(
    src: *const FusionImage,
    dst: *const FusionImageMut,
    filter_code: u32,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let (src, dst, f) = (deref(src)?, deref(dst)?, filter(filter_code)?);
        let (view, span) = src.view()?;
        disjoint(dst.span()?, &[span])?;
        fusion_nostd::rescale(view, dst.view_mut()?, f).map_err(FusionError::from_core)
    })
}

/// [`fusion_rescale_u8`] for 16-bit samples (thermal counts; saturating, never wrapping).
///
/// # Safety
/// As [`fusion_rescale_u8`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_rescale_u16(
    src: *const FusionImage16,
    dst: *const FusionImageMut16,
    filter_code: u32,
    error: *mut FusionError,
) -> FusionStatus {
    run(error, || {
        let (src, dst, f) = (deref(src)?, deref(dst)?, filter(filter_code)?);
        let (view, span) = src.view()?;
        disjoint(dst.span()?, &[span])?;
        fusion_nostd::rescale(view, dst.view_mut()?, f).map_err(FusionError::from_core)
    })
}
