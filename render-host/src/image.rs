//! A float grey image and its conversion to 8-/16-bit PNG buffers.

use anyhow::Result;
use image::{GrayImage, ImageBuffer, ImageFormat, Luma};
use std::path::Path;

/// A 16-bit grey image buffer from the `image` crate.
pub type Gray16Image = ImageBuffer<Luma<u16>, Vec<u16>>;

/// A grey image with `f32` samples, nominally in `[0, 1]`, row-major and tightly packed.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width × height` samples.
    pub data: Vec<f32>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Image {
        Image { width, height, data: vec![0.0; width as usize * height as usize] }
    }

    /// The sample at `(x, y)` (panics outside).
    pub fn at(&self, x: u32, y: u32) -> f32 {
        self.data[y as usize * self.width as usize + x as usize]
    }

    /// Mean of the samples in the rectangle `[x0, x1) × [y0, y1)`.
    pub fn mean_in(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> f64 {
        let mut s = 0.0;
        for y in y0..y1 {
            for x in x0..x1 {
                s += f64::from(self.at(x, y));
            }
        }
        s / f64::from((x1 - x0) * (y1 - y0)).max(1.0)
    }

    /// Mean of all samples.
    pub fn mean(&self) -> f64 {
        self.data.iter().map(|&v| f64::from(v)).sum::<f64>() / self.data.len().max(1) as f64
    }

    /// Clips every sample to `[0, 1]` (NaN becomes 0).
    pub fn clip(&mut self) {
        for v in &mut self.data {
            *v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        }
    }

    /// 8-bit grey: `round(255 v)` after clipping to `[0, 1]`.
    pub fn to_gray8(&self) -> GrayImage {
        let data = self.data.iter().map(|&v| (v.clamp(0.0, 1.0) * 255.0).round() as u8).collect();
        GrayImage::from_raw(self.width, self.height, data).unwrap_or_else(|| GrayImage::new(0, 0))
    }

    /// [`Image::to_gray8`] as the host tools' grey image (`fusion_io::Gray`).
    pub fn to_gray_u8(&self) -> fusion_io::Gray<u8> {
        let g = self.to_gray8();
        fusion_io::Gray { width: g.width() as usize, height: g.height() as usize, data: g.into_raw() }
    }

    /// 16-bit grey: `round(65535 v)` after clipping to `[0, 1]`.
    pub fn to_gray16(&self) -> Gray16Image {
        let data = self.data.iter().map(|&v| (v.clamp(0.0, 1.0) * 65535.0).round() as u16).collect();
        Gray16Image::from_raw(self.width, self.height, data).unwrap_or_else(|| Gray16Image::new(0, 0))
    }

    /// A `size × size` thumbnail of the square `[x0, x0 + side) × [y0, y0 + side)` (continuous
    /// pixel coordinates, may reach outside the image, which reads as 0): each output pixel is
    /// the mean of the source pixels whose centres fall in its cell (the nearest pixel when the
    /// cell is smaller than a pixel).
    pub fn crop_thumbnail(&self, x0: f32, y0: f32, side: f32, size: u32) -> Image {
        let mut out = Image::new(size, size);
        if size == 0 || side <= 0.0 {
            return out;
        }
        let cell = side / size as f32;
        // Source index range [lo, hi) of pixel centres in [a, a + cell), at least one pixel.
        let span = |a: f32| -> (i64, i64) {
            let lo = (a - 0.5).ceil() as i64;
            let hi = ((a + cell - 0.5).ceil() as i64).max(lo + 1);
            (lo, hi)
        };
        for ty in 0..size {
            let (ya, yb) = span(y0 + ty as f32 * cell);
            for tx in 0..size {
                let (xa, xb) = span(x0 + tx as f32 * cell);
                let mut s = 0.0f64;
                for y in ya..yb {
                    for x in xa..xb {
                        if (0..i64::from(self.width)).contains(&x) && (0..i64::from(self.height)).contains(&y)
                        {
                            s += f64::from(self.at(x as u32, y as u32));
                        }
                    }
                }
                out.data[(ty * size + tx) as usize] = (s / ((yb - ya) * (xb - xa)) as f64) as f32;
            }
        }
        out
    }

    /// Area-average downscale to `size × size` (a thumbnail; any ratio).
    pub fn thumbnail(&self, size: u32) -> Image {
        let mut out = Image::new(size, size);
        let sx = self.width as f32 / size as f32;
        let sy = self.height as f32 / size as f32;
        for ty in 0..size {
            let (y0, y1) =
                ((ty as f32 * sy) as u32, (((ty + 1) as f32 * sy) as u32).max(ty + 1).min(self.height));
            for tx in 0..size {
                let (x0, x1) =
                    ((tx as f32 * sx) as u32, (((tx + 1) as f32 * sx) as u32).max(tx + 1).min(self.width));
                out.data[(ty * size + tx) as usize] = self.mean_in(x0, y0, x1, y1) as f32;
            }
        }
        out
    }
}

/// Writes an 8-bit grey PNG atomically (`fusion_io::output`).
pub fn write_png8(path: &Path, img: &GrayImage) -> Result<()> {
    fusion_io::write_atomic(path, |w| Ok(img.write_to(w, ImageFormat::Png)?))
}

/// Writes a 16-bit grey PNG atomically.
pub fn write_png16(path: &Path, img: &Gray16Image) -> Result<()> {
    fusion_io::write_atomic(path, |w| Ok(img.write_to(w, ImageFormat::Png)?))
}

/// Writes a float image as an 8-bit grey PNG atomically.
pub fn save_gray8(path: &Path, img: &Image) -> Result<()> {
    write_png8(path, &img.to_gray8())
}
