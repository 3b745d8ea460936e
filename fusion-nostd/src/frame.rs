//! Frames: owned const-generic storage and borrowed, validated views.
//!
//! Storage is [`Frame<T, W, H>`], sized at compile time so it can live in a `static`
//! (a linker section in external SDRAM on a flight board). Every algorithm works on the
//! views [`FrameRef`] / [`FrameMut`], which carry width, height and row stride and are
//! validated once, when built; loops then trust them. [`Rect`] is a rectangle of pixels on a
//! frame (the scene's target window, a strip's window).

use crate::Error;

/// The largest width or height the core accepts (2¹⁴).
///
/// It bounds every intermediate of the integer kernels: with this limit the exact area
/// rescaler's numerators (≤ 65535 · 2¹⁴ · 2¹⁴) fit an `i64`.
pub const MAX_DIMENSION: usize = 1 << 14;

/// Checks a view's geometry and returns how many elements its buffer must hold.
fn required_len(width: usize, height: usize, stride: usize) -> Result<usize, Error> {
    if width == 0 || height == 0 {
        return Err(Error::ZeroDimension);
    }
    for value in [width, height] {
        if value > MAX_DIMENSION {
            return Err(Error::DimensionTooLarge { value });
        }
    }
    if stride < width {
        return Err(Error::StrideTooSmall { stride, width });
    }
    // (height - 1) * stride + width, without overflow on any target.
    (height - 1)
        .checked_mul(stride)
        .and_then(|n| n.checked_add(width))
        .ok_or(Error::BufferTooSmall { needed: usize::MAX, got: 0 })
}

/// A read-only view of a 2-D frame: `height` rows of `width` pixels, rows `stride` apart.
///
/// ```
/// use fusion_nostd::FrameRef;
/// let pixels = [1u8, 2, 3, 0, 4, 5, 6, 0];
/// let view = FrameRef::with_stride(&pixels, 3, 2, 4)?;
/// assert_eq!(view.row(1), &[4, 5, 6]);
/// assert!(FrameRef::new(&pixels, 3, 3).is_err()); // buffer too short
/// # Ok::<(), fusion_nostd::Error>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct FrameRef<'a, T> {
    data: &'a [T],
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a, T: Copy> FrameRef<'a, T> {
    /// A tightly packed view (`stride == width`).
    pub fn new(data: &'a [T], width: usize, height: usize) -> Result<Self, Error> {
        Self::with_stride(data, width, height, width)
    }

    /// A view with an explicit row stride (elements between row starts).
    pub fn with_stride(data: &'a [T], width: usize, height: usize, stride: usize) -> Result<Self, Error> {
        let needed = required_len(width, height, stride)?;
        if data.len() < needed {
            return Err(Error::BufferTooSmall { needed, got: data.len() });
        }
        Ok(Self { data, width, height, stride })
    }

    /// Pixels per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Elements between the starts of two consecutive rows.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// `(width, height)`.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Row `y` (`width` pixels). Out-of-range `y` gives an empty slice.
    #[inline]
    pub fn row(&self, y: usize) -> &'a [T] {
        debug_assert!(y < self.height);
        let start = y * self.stride;
        self.data.get(start..start + self.width).unwrap_or(&[])
    }

    /// Row `y` clamped into `0..height` (replicate border), for signed row indices.
    #[inline]
    pub fn row_clamped(&self, y: isize) -> &'a [T] {
        self.row(clamp_index(y, self.height))
    }

    /// The pixel at `(x, y)`, or `None` outside the frame.
    pub fn get(&self, x: usize, y: usize) -> Option<T> {
        if x >= self.width || y >= self.height {
            return None;
        }
        self.row(y).get(x).copied()
    }

    /// All rows, top to bottom.
    pub fn rows(&self) -> impl ExactSizeIterator<Item = &'a [T]> + DoubleEndedIterator + 'a {
        let width = self.width;
        // `max(1)`: stride ≥ width ≥ 1 already; it lets the optimiser drop chunks()'s panic path.
        self.data.chunks(self.stride.max(1)).take(self.height).map(move |row| row.get(..width).unwrap_or(&[]))
    }

    /// The rows `y0..y1` as a view of their own (for strip processing).
    pub fn sub_rows(&self, y0: usize, y1: usize) -> Result<FrameRef<'a, T>, Error> {
        if y0 >= y1 || y1 > self.height {
            return Err(Error::InvalidParameter { name: "rows" });
        }
        let data = self.data.get(y0 * self.stride..).unwrap_or(&[]);
        FrameRef::with_stride(data, self.width, y1 - y0, self.stride)
    }

    /// The `w × h` window whose top-left pixel is `(x0, y0)` as a view of its own (for
    /// region-of-interest processing); [`Error::InvalidParameter`] (`"rect"`) when it does not
    /// lie inside the frame or is empty.
    pub fn sub_rect(&self, x0: usize, y0: usize, w: usize, h: usize) -> Result<FrameRef<'a, T>, Error> {
        let start = window_start(self.size(), self.stride, (x0, y0, w, h))?;
        let data = self.data.get(start..).unwrap_or(&[]);
        FrameRef::with_stride(data, w, h, self.stride)
    }
}

/// The buffer offset of the window `(x0, y0, w, h)` of a `size` frame with row `stride`, after
/// checking the window is non-empty and inside the frame.
fn window_start(
    size: (usize, usize),
    stride: usize,
    (x0, y0, w, h): (usize, usize, usize, usize),
) -> Result<usize, Error> {
    let inside = |o: usize, n: usize, len: usize| n > 0 && o.checked_add(n).is_some_and(|e| e <= len);
    if !inside(x0, w, size.0) || !inside(y0, h, size.1) {
        return Err(Error::InvalidParameter { name: "rect" });
    }
    y0.checked_mul(stride).and_then(|o| o.checked_add(x0)).ok_or(Error::InvalidParameter { name: "rect" })
}

/// A writable view of a 2-D frame; see [`FrameRef`].
#[derive(Debug)]
pub struct FrameMut<'a, T> {
    data: &'a mut [T],
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a, T: Copy> FrameMut<'a, T> {
    /// A tightly packed view (`stride == width`).
    pub fn new(data: &'a mut [T], width: usize, height: usize) -> Result<Self, Error> {
        Self::with_stride(data, width, height, width)
    }

    /// A view with an explicit row stride.
    pub fn with_stride(data: &'a mut [T], width: usize, height: usize, stride: usize) -> Result<Self, Error> {
        let needed = required_len(width, height, stride)?;
        if data.len() < needed {
            return Err(Error::BufferTooSmall { needed, got: data.len() });
        }
        Ok(Self { data, width, height, stride })
    }

    /// Pixels per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Elements between the starts of two consecutive rows.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// `(width, height)`.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// A read-only view of the same pixels.
    pub fn as_ref(&self) -> FrameRef<'_, T> {
        FrameRef { data: self.data, width: self.width, height: self.height, stride: self.stride }
    }

    /// A shorter-lived writable view of the same pixels.
    pub fn reborrow(&mut self) -> FrameMut<'_, T> {
        FrameMut { data: self.data, width: self.width, height: self.height, stride: self.stride }
    }

    /// Row `y` for writing. Out-of-range `y` gives an empty slice.
    #[inline]
    pub fn row_mut(&mut self, y: usize) -> &mut [T] {
        debug_assert!(y < self.height);
        let start = y * self.stride;
        self.data.get_mut(start..start + self.width).unwrap_or(&mut [])
    }

    /// All rows for writing, top to bottom.
    pub fn rows_mut(&mut self) -> impl ExactSizeIterator<Item = &mut [T]> + DoubleEndedIterator {
        let width = self.width;
        self.data
            .chunks_mut(self.stride.max(1))
            .take(self.height)
            .map(move |row| row.get_mut(..width).unwrap_or(&mut []))
    }

    /// Sets every pixel of the view to `value`.
    pub fn fill(&mut self, value: T) {
        for row in self.rows_mut() {
            row.fill(value);
        }
    }

    /// The rows `y0..y1` as a writable view of their own.
    pub fn sub_rows_mut(&mut self, y0: usize, y1: usize) -> Result<FrameMut<'_, T>, Error> {
        if y0 >= y1 || y1 > self.height {
            return Err(Error::InvalidParameter { name: "rows" });
        }
        let data = self.data.get_mut(y0 * self.stride..).unwrap_or(&mut []);
        FrameMut::with_stride(data, self.width, y1 - y0, self.stride)
    }

    /// The `w × h` window whose top-left pixel is `(x0, y0)` as a writable view of its own;
    /// see [`FrameRef::sub_rect`].
    pub fn sub_rect_mut(
        &mut self,
        x0: usize,
        y0: usize,
        w: usize,
        h: usize,
    ) -> Result<FrameMut<'_, T>, Error> {
        let start = window_start(self.size(), self.stride, (x0, y0, w, h))?;
        let data = self.data.get_mut(start..).unwrap_or(&mut []);
        FrameMut::with_stride(data, w, h, self.stride)
    }
}

/// Clamps a signed index into `0..len` (replicate border). `len` must be non-zero.
#[inline]
pub(crate) fn clamp_index(i: isize, len: usize) -> usize {
    if i <= 0 { 0 } else { (i as usize).min(len.saturating_sub(1)) }
}

/// Owned frame storage of `W × H` pixels, sized at compile time.
///
/// Meant for `static` placement (firmware) or one heap box (host). The size is checked at
/// compile time: a `Frame<_, 0, _>` does not build.
///
/// ```
/// use fusion_nostd::Frame;
/// let mut frame = Frame::<u8, 4, 2>::filled(7);
/// frame.view_mut().row_mut(1)[3] = 9;
/// assert_eq!(frame.view().get(3, 1), Some(9));
/// ```
#[derive(Debug, Clone)]
#[repr(C)]
pub struct Frame<T, const W: usize, const H: usize> {
    rows: [[T; W]; H],
}

impl<T: Copy, const W: usize, const H: usize> Frame<T, W, H> {
    const CHECK_SIZE: () = assert!(
        W > 0 && H > 0 && W <= MAX_DIMENSION && H <= MAX_DIMENSION,
        "frame dimensions must be in 1..=MAX_DIMENSION"
    );

    /// Width in pixels.
    pub const WIDTH: usize = W;
    /// Height in pixels.
    pub const HEIGHT: usize = H;

    /// A frame with every pixel set to `value` (usable in `static` initialisers).
    pub const fn filled(value: T) -> Self {
        let () = Self::CHECK_SIZE;
        Self { rows: [[value; W]; H] }
    }

    /// The whole frame as a read-only view.
    pub fn view(&self) -> FrameRef<'_, T> {
        let () = Self::CHECK_SIZE;
        FrameRef { data: self.rows.as_flattened(), width: W, height: H, stride: W }
    }

    /// The whole frame as a writable view.
    pub fn view_mut(&mut self) -> FrameMut<'_, T> {
        let () = Self::CHECK_SIZE;
        FrameMut { data: self.rows.as_flattened_mut(), width: W, height: H, stride: W }
    }

    /// The pixels in row-major order.
    pub fn pixels(&self) -> &[T] {
        self.rows.as_flattened()
    }

    /// The pixels in row-major order, writable.
    pub fn pixels_mut(&mut self) -> &mut [T] {
        self.rows.as_flattened_mut()
    }
}

/// An 8-bit 512 × 512 frame (the TIR sensor's grid).
pub type Frame512 = Frame<u8, 512, 512>;
/// An 8-bit 1024 × 1024 frame (the VIS sensor's grid).
pub type Frame1024 = Frame<u8, 1024, 1024>;

/// A rectangle of pixels `x0..x1` × `y0..y1` (half-open).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Rect {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// One past the last column.
    pub x1: usize,
    /// One past the last row.
    pub y1: usize,
}

impl Rect {
    /// The whole `w × h` frame.
    pub const fn full((w, h): (usize, usize)) -> Rect {
        Rect { x0: 0, y0: 0, x1: w, y1: h }
    }

    /// Columns.
    pub const fn width(&self) -> usize {
        self.x1.saturating_sub(self.x0)
    }

    /// Rows.
    pub const fn height(&self) -> usize {
        self.y1.saturating_sub(self.y0)
    }

    /// Pixels.
    pub const fn area(&self) -> usize {
        self.width().saturating_mul(self.height())
    }

    /// Whether it holds no pixel.
    pub const fn is_empty(&self) -> bool {
        self.width() == 0 || self.height() == 0
    }

    /// Whether `(x, y)` is inside.
    pub const fn contains(&self, x: usize, y: usize) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }

    /// The smallest rectangle holding both boxes that are there (`None` when neither is).
    #[must_use]
    pub fn join(a: Option<Rect>, b: Option<Rect>) -> Option<Rect> {
        match (a, b) {
            (Some(a), Some(b)) => Some(a.union(b)),
            (a, b) => a.or(b),
        }
    }

    /// The smallest rectangle holding both (an empty one is ignored).
    #[must_use]
    pub fn union(self, other: Rect) -> Rect {
        if self.is_empty() {
            return other;
        }
        if other.is_empty() {
            return self;
        }
        Rect {
            x0: self.x0.min(other.x0),
            y0: self.y0.min(other.y0),
            x1: self.x1.max(other.x1),
            y1: self.y1.max(other.y1),
        }
    }

    /// The pixels inside both (empty — [`Rect::default`] — when they do not overlap).
    #[must_use]
    pub fn intersect(self, other: Rect) -> Rect {
        let r = Rect {
            x0: self.x0.max(other.x0),
            y0: self.y0.max(other.y0),
            x1: self.x1.min(other.x1),
            y1: self.y1.min(other.y1),
        };
        if r.is_empty() { Rect::default() } else { r }
    }

    /// Grown by `r` on every side, clipped to a `w × h` frame.
    #[must_use]
    pub fn grow(self, r: usize, (w, h): (usize, usize)) -> Rect {
        Rect {
            x0: self.x0.saturating_sub(r),
            y0: self.y0.saturating_sub(r),
            x1: self.x1.saturating_add(r).min(w),
            y1: self.y1.saturating_add(r).min(h),
        }
    }

    /// Shrunk by `r` on every side that is not on the edge of a `w × h` frame (what stays
    /// exact when a filter of radius `r` runs on this window alone: at the frame's own edge the
    /// window's border rule is the frame's).
    #[must_use]
    pub fn shrink_inner(self, r: usize, (w, h): (usize, usize)) -> Rect {
        let lo = |v: usize| if v == 0 { 0 } else { v.saturating_add(r) };
        let hi = |v: usize, n: usize| if v >= n { v } else { v.saturating_sub(r) };
        let s = Rect { x0: lo(self.x0), y0: lo(self.y0), x1: hi(self.x1, w), y1: hi(self.y1, h) };
        if s.is_empty() { Rect::default() } else { s }
    }

    /// Whether every pixel of `other` is inside.
    pub const fn covers(&self, other: &Rect) -> bool {
        other.is_empty()
            || (self.x0 <= other.x0 && self.y0 <= other.y0 && self.x1 >= other.x1 && self.y1 >= other.y1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn views_validate_their_geometry() {
        let buf = [0u8; 12];
        assert_eq!(FrameRef::new(&buf, 0, 3).err(), Some(Error::ZeroDimension));
        assert_eq!(FrameRef::new(&buf, 3, 0).err(), Some(Error::ZeroDimension));
        assert_eq!(
            FrameRef::with_stride(&buf, 4, 2, 3).err(),
            Some(Error::StrideTooSmall { stride: 3, width: 4 })
        );
        assert_eq!(FrameRef::new(&buf, 4, 4).err(), Some(Error::BufferTooSmall { needed: 16, got: 12 }));
        // Last row needs only `width` elements, not a whole stride.
        assert!(FrameRef::with_stride(&buf, 2, 3, 5).is_ok());
        assert!(FrameRef::with_stride(&buf, 3, 3, 5).is_err());
        assert_eq!(
            FrameRef::new(&buf, MAX_DIMENSION + 1, 1).err(),
            Some(Error::DimensionTooLarge { value: MAX_DIMENSION + 1 })
        );
        assert!(FrameRef::with_stride(&buf, 1, 2, usize::MAX).is_err());
    }

    #[test]
    fn rows_respect_stride() -> Result<(), Error> {
        let buf: [u8; 11] = core::array::from_fn(|i| i as u8);
        let view = FrameRef::with_stride(&buf, 3, 3, 4)?;
        let mut rows = view.rows();
        assert_eq!(rows.next(), Some(&[0u8, 1, 2][..]));
        assert_eq!(rows.next(), Some(&[4u8, 5, 6][..]));
        assert_eq!(rows.next(), Some(&[8u8, 9, 10][..]));
        assert_eq!(rows.next(), None);
        assert_eq!(view.row_clamped(-5), &[0, 1, 2]);
        assert_eq!(view.row_clamped(7), &[8, 9, 10]);
        let strip = view.sub_rows(1, 3)?;
        assert_eq!(strip.size(), (3, 2));
        assert_eq!(strip.row(1), &[8, 9, 10]);
        assert!(view.sub_rows(2, 2).is_err());
        let win = view.sub_rect(1, 1, 2, 2)?;
        assert_eq!((win.row(0), win.row(1)), (&[5u8, 6][..], &[9u8, 10][..]));
        assert!(view.sub_rect(2, 0, 2, 1).is_err());
        assert!(view.sub_rect(0, 0, 0, 1).is_err());
        assert!(view.sub_rect(usize::MAX, 0, 2, 1).is_err());
        Ok(())
    }

    #[test]
    fn writable_views_write_only_their_pixels() -> Result<(), Error> {
        let mut buf = [0u8; 8];
        let mut view = FrameMut::with_stride(&mut buf, 3, 2, 4)?;
        view.fill(5);
        assert_eq!(buf, [5, 5, 5, 0, 5, 5, 5, 0]);
        Ok(())
    }
}
