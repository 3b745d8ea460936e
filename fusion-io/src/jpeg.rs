//! JPEG input as the field decodes it: libjpeg-turbo itself (its C source, bundled by the
//! `turbojpeg` crate and built with cmake), with libjpeg's defaults — the integer "islow" IDCT,
//! fancy (smooth) chroma upsampling and libjpeg's YCbCr→RGB.
//!
//! Why: published fusion metrics (VIFB's MATLAB code) read their JPEGs with MATLAB's `imread`,
//! which is libjpeg; OpenCV and Pillow bundle libjpeg-turbo too, and all three give the same
//! bytes. Any other decoder — the `image` crate's zune-jpeg used to be this crate's — differs
//! from them by a level on some pixels (on the repository's VIFB JPEGs zune-jpeg differed on
//! 0.3–0.5 % of a grey file's pixels and 12–20 % of a colour file's), enough to move entropy-
//! and histogram-based scores off the published values. `fusion-io/tests/jpeg_libjpeg.rs`
//! checks the decodes against Pillow's, byte for byte.
//!
//! What comes out: a 1-component JPEG as grey, a YCbCr (or RGB) one as RGB — MATLAB's `imread`
//! shapes. Grey from a colour JPEG is the RGB decode converted with BT.601 by the caller, never
//! libjpeg's own grey output (its Y plane, which differs from `rgb2gray(imread(…))`).
//! Refused, each in one line: CMYK/YCCK JPEGs (libjpeg gives them only as CMYK; MATLAB's
//! `imread` returns four channels, which no metric here takes), 12- and 16-bit JPEGs (the
//! binding wraps libjpeg's 8-bit interface only), and damaged files — libjpeg-turbo's warnings
//! ("Premature end of JPEG file", "Corrupt JPEG data: …") are errors here, where MATLAB and
//! OpenCV warn and fill the rest with grey: a damaged input is not scored silently.

use anyhow::{Result, bail};
use std::path::Path;

/// A JPEG file read into memory with its header parsed; nothing decoded yet.
pub(crate) struct Jpeg {
    data: Vec<u8>,
    decompressor: turbojpeg::Decompressor,
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// 1 (grey) or 3 (R, G, B).
    pub channels: usize,
    /// Progressive (libjpeg holds every coefficient while it decodes).
    pub progressive: bool,
}

/// libjpeg's message alone (the binding prefixes "TurboJPEG error: "), on one line.
fn reason(e: &turbojpeg::Error) -> String {
    let text = match e {
        turbojpeg::Error::TurboJpegError(m) => m.clone(),
        other => other.to_string(),
    };
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

impl Jpeg {
    /// Reads `path` and its JPEG header: the size and the channels it will decode to.
    pub(crate) fn open(path: &Path) -> Result<Jpeg> {
        let invalid = |why: &str| anyhow::anyhow!("{} is not a valid JPEG: {why}", path.display());
        let data = std::fs::read(path).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
        if data.is_empty() {
            return Err(invalid("the file is empty"));
        }
        let mut decompressor = turbojpeg::Decompressor::new().map_err(|e| invalid(&reason(&e)))?;
        let header = decompressor.read_header(&data).map_err(|e| invalid(&reason(&e)))?;
        let channels = match header.colorspace {
            turbojpeg::Colorspace::Gray => 1,
            turbojpeg::Colorspace::YCbCr | turbojpeg::Colorspace::RGB => 3,
            turbojpeg::Colorspace::CMYK | turbojpeg::Colorspace::YCCK => {
                bail!("{} is a CMYK JPEG; an 8-bit grey or colour one is needed here", path.display())
            }
        };
        Ok(Jpeg {
            data,
            decompressor,
            width: header.width,
            height: header.height,
            channels,
            progressive: header.is_progressive,
        })
    }

    /// Decodes the pixels, interleaved (`R G B R G B …` or grey), row-major.
    pub(crate) fn decode(mut self, path: &Path) -> Result<Vec<u8>> {
        let (width, height, channels) = (self.width, self.height, self.channels);
        if width == 0 || height == 0 {
            bail!("{} has zero size", path.display());
        }
        let format = if channels == 1 { turbojpeg::PixelFormat::GRAY } else { turbojpeg::PixelFormat::RGB };
        let mut pixels = vec![0u8; width * height * channels];
        let image =
            turbojpeg::Image { pixels: &mut pixels[..], width, pitch: width * channels, height, format };
        self.decompressor
            .decompress(&self.data, image)
            .map_err(|e| anyhow::anyhow!("{} is not a valid JPEG: {}", path.display(), reason(&e)))?;
        Ok(pixels)
    }
}
