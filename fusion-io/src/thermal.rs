//! The thermal camera's calibration files: the two-point NUC tables and the bad-pixel map, as
//! `fusion fuse --nuc TABLES --bad-pixels MAP` reads them and the renderer writes them.
//!
//! **NUC tables** (`.nuc`, little-endian binary): the 8 bytes `VISTNUC1`, the array's width and
//! height as `u32`, then `width·height` gains as `u16` in Q2.14 (`round(G·16 384)`, 16 384 = a
//! gain of 1) and `width·height` offsets as `i16` in counts, both row-major — the tables of
//! `fusion_nostd::thermal::nuc` (`y = ⌊(g·x + 2¹³)/2¹⁴⌋ + O`). 16 + 4·width·height bytes.
//!
//! **Bad-pixel map**: an 8-bit grey PNG (or any image [`crate::load_image`] reads) of the
//! array's size, non-zero where a pixel is bad — easy to look at and to edit. It is packed into
//! the core's one-bit rows and checked by `fusion_nostd::thermal::BadPixelMap::new` (a bad
//! pixel with no valid neighbour and no valid pixel in its row is refused).

use crate::{ColorPolicy, Gray, GrayInput, load_image};
use anyhow::{Context, Result, bail};
use std::path::Path;

/// The first 8 bytes of a NUC table file.
pub const NUC_MAGIC: &[u8; 8] = b"VISTNUC1";

/// Two-point NUC tables of a `width × height` array.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NucTables {
    /// Array width, px.
    pub width: usize,
    /// Array height, px.
    pub height: usize,
    /// Per-pixel gain, Q2.14.
    pub gain: Vec<u16>,
    /// Per-pixel offset, counts.
    pub offset: Vec<i16>,
}

impl NucTables {
    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(16 + 4 * self.gain.len());
        b.extend_from_slice(NUC_MAGIC);
        b.extend_from_slice(&(self.width as u32).to_le_bytes());
        b.extend_from_slice(&(self.height as u32).to_le_bytes());
        self.gain.iter().for_each(|g| b.extend_from_slice(&g.to_le_bytes()));
        self.offset.iter().for_each(|o| b.extend_from_slice(&o.to_le_bytes()));
        b
    }

    /// Parses a file's bytes (`what` names it in the error).
    pub fn from_bytes(bytes: &[u8], what: &str) -> Result<NucTables> {
        let Some(rest) = bytes.strip_prefix(NUC_MAGIC) else {
            bail!("{what} is not a NUC table file (it does not start with VISTNUC1)");
        };
        let word = |i: usize| -> Option<usize> {
            Some(u32::from_le_bytes(rest.get(i..i + 4)?.try_into().ok()?) as usize)
        };
        let (Some(width), Some(height)) = (word(0), word(4)) else {
            bail!("{what} ends inside its header");
        };
        if width == 0
            || height == 0
            || width > fusion_nostd::MAX_DIMENSION
            || height > fusion_nostd::MAX_DIMENSION
        {
            bail!(
                "{what} declares a {width}x{height} array (each side must be 1..={})",
                fusion_nostd::MAX_DIMENSION
            );
        }
        let n = width * height;
        let body = rest.get(8..).unwrap_or(&[]);
        if body.len() != 4 * n {
            bail!("{what} holds {} bytes of tables; a {width}x{height} array needs {}", body.len(), 4 * n);
        }
        let (g, o) = body.split_at(2 * n);
        Ok(NucTables {
            width,
            height,
            gain: g.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect(),
            offset: o.chunks_exact(2).map(|c| i16::from_le_bytes([c[0], c[1]])).collect(),
        })
    }

    /// Reads a NUC table file.
    pub fn read(path: &Path) -> Result<NucTables> {
        let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
        Self::from_bytes(&bytes, &path.display().to_string())
    }

    /// Writes a NUC table file (atomically).
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::output::write_bytes(path, &self.to_bytes())
    }

    /// The core's view of the tables.
    pub fn view(&self) -> Result<fusion_nostd::thermal::NucTables<'_>> {
        fusion_nostd::thermal::NucTables::new(self.width, self.height, &self.gain, &self.offset)
            .map_err(|e| anyhow::anyhow!("NUC tables: {e}"))
    }
}

/// A bad-pixel map packed into the core's one-bit rows (see the module's documentation).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BadPixels {
    /// Array width, px.
    pub width: usize,
    /// Array height, px.
    pub height: usize,
    /// The core's bits: `⌈width/8⌉` bytes a row, pixel `x` in bit `x mod 8` of byte `x/8`.
    pub bits: Vec<u8>,
}

impl BadPixels {
    /// Packs a mask (`true` = bad).
    pub fn from_mask(width: usize, height: usize, bad: &[bool]) -> BadPixels {
        let mut bits = vec![0u8; fusion_nostd::thermal::bad_map_bytes(width, height)];
        for (i, _) in bad.iter().enumerate().filter(|(_, b)| **b) {
            let (byte, k) = fusion_nostd::thermal::bit_of(width, i % width, i / width);
            if let Some(b) = bits.get_mut(byte) {
                *b |= 1 << k;
            }
        }
        BadPixels { width, height, bits }
    }

    /// The map as an 8-bit image, 255 where bad.
    pub fn to_image(&self) -> Gray<u8> {
        let data = (0..self.width * self.height)
            .map(|i| if self.is_bad(i % self.width, i / self.width) { 255 } else { 0 })
            .collect();
        Gray { width: self.width, height: self.height, data }
    }

    /// Whether pixel `(x, y)` is bad.
    pub fn is_bad(&self, x: usize, y: usize) -> bool {
        let (byte, k) = fusion_nostd::thermal::bit_of(self.width, x, y);
        self.bits.get(byte).is_some_and(|b| b >> k & 1 == 1)
    }

    /// Bad pixels in the map.
    pub fn count(&self) -> usize {
        self.bits.iter().map(|b| b.count_ones() as usize).sum()
    }

    /// Reads a map image (non-zero = bad; 8- or 16-bit grey) and checks it with the core's rule.
    pub fn read(path: &Path) -> Result<BadPixels> {
        let (w, h, mask): (usize, usize, Vec<bool>) = match load_image(path, ColorPolicy::Refuse)
            .with_context(|| format!("cannot read the bad-pixel map {}", path.display()))?
        {
            GrayInput::U8(g) => (g.width, g.height, g.data.iter().map(|&v| v != 0).collect()),
            GrayInput::U16(g) => (g.width, g.height, g.data.iter().map(|&v| v != 0).collect()),
        };
        let map = BadPixels::from_mask(w, h, &mask);
        map.view().with_context(|| format!("the bad-pixel map {}", path.display()))?;
        Ok(map)
    }

    /// Writes the map as an 8-bit PNG (255 = bad).
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::save_gray_u8(path, &self.to_image())
    }

    /// The core's view of the map (checked).
    pub fn view(&self) -> Result<fusion_nostd::thermal::BadPixelMap<'_>> {
        fusion_nostd::thermal::BadPixelMap::new(self.width, self.height, &self.bits)
            .map_err(|e| anyhow::anyhow!("{e}"))
    }
}
