//! Caller-owned work memory. The core never allocates: every plane a method needs is
//! borrowed from a [`Scratch`] the caller owns (a `static` on the firmware, one box on the host).

use crate::Error;

/// Number of `i32` work planes in a [`Scratch`]. Every method documents how many it uses
/// (none uses more than this).
pub const SCRATCH_PLANES: usize = 3;

/// Work memory for frames of up to `PIXELS` pixels: [`SCRATCH_PLANES`] planes of `i32` for
/// the fusion methods plus one `u8` plane for the rescaled band of the pipeline.
///
/// `Scratch<{ 1024 * 1024 }>` is 13 MiB; place it in a `static` (firmware) or on the heap
/// (host: `fusion_engine::CoreScratch`), never on a small stack.
#[derive(Debug, Clone)]
#[repr(C)]
pub struct Scratch<const PIXELS: usize> {
    planes: [[i32; PIXELS]; SCRATCH_PLANES],
    band: [u8; PIXELS],
}

/// Scratch for 512 × 512 frames.
pub type Scratch512 = Scratch<{ 512 * 512 }>;
/// Scratch for 1024 × 1024 frames.
pub type Scratch1024 = Scratch<{ 1024 * 1024 }>;

impl<const PIXELS: usize> Scratch<PIXELS> {
    /// Zeroed scratch (usable in `static` initialisers).
    pub const fn new() -> Self {
        Self { planes: [[0; PIXELS]; SCRATCH_PLANES], band: [0; PIXELS] }
    }

    /// Borrows all planes as an unsized view (code is written once for every `PIXELS`).
    pub fn view_mut(&mut self) -> ScratchMut<'_> {
        let [a, b, c] = &mut self.planes;
        ScratchMut { planes: [a, b, c], band: &mut self.band }
    }
}

impl<const PIXELS: usize> Default for Scratch<PIXELS> {
    fn default() -> Self {
        Self::new()
    }
}

/// Borrowed work planes, each at least `capacity()` pixels long, and the pipeline's band plane.
#[derive(Debug)]
pub struct ScratchMut<'a> {
    planes: [&'a mut [i32]; SCRATCH_PLANES],
    band: &'a mut [u8],
}

impl<'a> ScratchMut<'a> {
    /// Work planes from caller-provided slices (e.g. `Vec`s on the host), without a band plane
    /// (enough to call a fusion method directly). The capacity is the shortest slice's length.
    pub fn from_slices(planes: [&'a mut [i32]; SCRATCH_PLANES]) -> Self {
        Self { planes, band: &mut [] }
    }

    /// Work planes plus the `u8` band plane the pipeline rescales into.
    pub fn with_band(planes: [&'a mut [i32]; SCRATCH_PLANES], band: &'a mut [u8]) -> Self {
        Self { planes, band }
    }

    /// Splits off the band plane (cut to `pixels`), leaving the work planes for a method.
    pub fn split_band(&mut self, pixels: usize) -> Result<(&mut [u8], ScratchMut<'_>), Error> {
        let capacity = self.band.len();
        let band = self.band.get_mut(..pixels).ok_or(Error::ScratchTooSmall { needed: pixels, capacity })?;
        let [a, b, c] = &mut self.planes;
        Ok((band, ScratchMut { planes: [a, b, c], band: &mut [] }))
    }

    /// Pixels each plane can hold.
    pub fn capacity(&self) -> usize {
        self.planes.iter().map(|p| p.len()).min().unwrap_or(0)
    }

    /// All planes, each cut to `pixels` elements, or [`Error::ScratchTooSmall`].
    pub fn planes(&mut self, pixels: usize) -> Result<[&mut [i32]; SCRATCH_PLANES], Error> {
        let capacity = self.capacity();
        if pixels > capacity {
            return Err(Error::ScratchTooSmall { needed: pixels, capacity });
        }
        let [a, b, c] = &mut self.planes;
        match (a.get_mut(..pixels), b.get_mut(..pixels), c.get_mut(..pixels)) {
            (Some(a), Some(b), Some(c)) => Ok([a, b, c]),
            _ => Err(Error::ScratchTooSmall { needed: pixels, capacity }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planes_are_checked_against_capacity() -> Result<(), Error> {
        let mut s = Scratch::<16>::new();
        let mut v = s.view_mut();
        assert_eq!(v.capacity(), 16);
        let [a, b, c] = v.planes(12)?;
        assert_eq!((a.len(), b.len(), c.len()), (12, 12, 12));
        assert_eq!(v.planes(17).err(), Some(Error::ScratchTooSmall { needed: 17, capacity: 16 }));
        let (band, mut rest) = v.split_band(10)?;
        assert_eq!(band.len(), 10);
        assert_eq!(rest.capacity(), 16);
        assert!(rest.split_band(1).is_err(), "the band is handed out once");
        Ok(())
    }
}
