//! Image and array I/O for the host tools: PNG, JPEG, TIFF and binary PGM/PPM in (8/16-bit grey,
//! 8-bit colour), PNG, TIFF and PGM out (chosen by the output's extension, [`OutFormat`]), float32
//! `.npy`.
//!
//! JPEG is decoded by libjpeg-turbo with libjpeg's defaults (`jpeg.rs`): the bytes MATLAB's
//! `imread`, OpenCV and Pillow give, so metrics on JPEGs match the field's published values; every
//! other format by the `image` crate.
//!
//! Every output goes through the one write path, [`crate::output`] ([`write_atomic`],
//! [`Batch`](crate::output::Batch)): an exclusive temporary in the destination folder, synced, renamed into place;
//! related files all or none. Inputs are judged by their header against the memory limit
//! ([`crate::memory`]) before they are decoded.

use crate::output::write_atomic;
use anyhow::{Context, Result, bail};
use image::ImageEncoder;
use std::path::Path;

/// An owned grey image, row-major, tightly packed.
#[derive(Debug, Clone, PartialEq)]
pub struct Gray<T> {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width * height` samples.
    pub data: Vec<T>,
}

impl<T: Copy + Default> Gray<T> {
    /// A `width × height` image filled with `T::default()`.
    pub fn new(width: usize, height: usize) -> Self {
        Self { width, height, data: vec![T::default(); width * height] }
    }

    /// A core view of the pixels.
    pub fn view(&self) -> Result<fusion_nostd::FrameRef<'_, T>> {
        Ok(fusion_nostd::FrameRef::new(&self.data, self.width, self.height)?)
    }

    /// A writable core view of the pixels.
    pub fn view_mut(&mut self) -> Result<fusion_nostd::FrameMut<'_, T>> {
        Ok(fusion_nostd::FrameMut::new(&mut self.data, self.width, self.height)?)
    }

    /// The sample at `(x, y)` (panics outside; host-side convenience).
    pub fn at(&self, x: usize, y: usize) -> T {
        self.data[y * self.width + x]
    }
}

/// An image as it was stored, in grey: 8-bit or 16-bit.
#[derive(Debug, Clone, PartialEq)]
pub enum GrayInput {
    /// 8-bit grey.
    U8(Gray<u8>),
    /// 16-bit grey.
    U16(Gray<u16>),
}

/// What to do with a colour image where grey is needed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColorPolicy {
    /// Refuse it with an error.
    Refuse,
    /// Convert to grey with MATLAB `rgb2gray` weights (BT.601: 0.2989, 0.5870, 0.1140),
    /// rounded half away from zero; alpha is dropped.
    Bt601,
}

/// The input formats: the name used in messages.
fn format_name(f: image::ImageFormat) -> Option<&'static str> {
    match f {
        image::ImageFormat::Png => Some("PNG"),
        image::ImageFormat::Jpeg => Some("JPEG"),
        image::ImageFormat::Tiff => Some("TIFF"),
        image::ImageFormat::Pnm => Some("PGM/PPM"),
        _ => None,
    }
}

/// The `image` crate's reader of a file.
type Reader = image::ImageReader<std::io::BufReader<std::fs::File>>;

/// An input opened by its content (a PNG named `.jpg` is read as PNG), its header read and
/// nothing of the image data yet: JPEG for libjpeg-turbo, the other formats for `image`.
enum Opened {
    /// A JPEG file (`jpeg.rs`).
    Jpeg(crate::jpeg::Jpeg),
    /// A PNG, TIFF or PGM/PPM file, with its format's name.
    Image(Reader, &'static str),
}

/// Opens an input. The format is judged by the file's first bytes; a file that is none of PNG,
/// JPEG, TIFF and PGM/PPM is refused by its extension's name.
fn open(path: &Path) -> Result<Opened> {
    let reader = image::ImageReader::open(path)
        .with_context(|| format!("cannot open {}", path.display()))?
        .with_guessed_format()
        .with_context(|| format!("cannot read {}", path.display()))?;
    let by_name = image::ImageFormat::from_path(path).ok().and_then(format_name);
    let Some(name) = reader.format().and_then(format_name).or(by_name) else {
        bail!("{} is not a PNG, JPEG, TIFF or PGM/PPM file", path.display());
    };
    if name == "JPEG" {
        return Ok(Opened::Jpeg(crate::jpeg::Jpeg::open(path)?));
    }
    refuse_several_images(path, name)?;
    Ok(Opened::Image(reader, name))
}

/// Refuses a file that holds more than one image (an animated PNG, a multi-page TIFF): reading
/// its first image alone would drop the rest without a word. A file whose header cannot be read
/// here is left to the decoder, which says why.
fn refuse_several_images(path: &Path, name: &str) -> Result<()> {
    let Ok(file) = std::fs::File::open(path) else { return Ok(()) };
    let file = std::io::BufReader::new(file);
    let images = match name {
        "PNG" => {
            let Ok(reader) = png::Decoder::new(file).read_info() else { return Ok(()) };
            let info = reader.info();
            // APNG: the frames of `acTL`, plus the default image when it is not the first frame.
            info.animation_control
                .map_or(1, |a| a.num_frames as usize + usize::from(info.frame_control.is_none()))
        }
        "TIFF" => {
            let Ok(mut decoder) = tiff::decoder::Decoder::new(file) else { return Ok(()) };
            let mut pages = 1;
            while decoder.more_images() && pages < 1_000 {
                if decoder.next_image().is_err() {
                    break;
                }
                pages += 1;
            }
            pages
        }
        _ => 1,
    };
    if images > 1 {
        let what = if name == "PNG" { "an animated PNG of" } else { "a multi-page TIFF of" };
        bail!("{} is {what} {images} images; one image per file is needed here", path.display());
    }
    Ok(())
}

/// The `image` crate's decoder of a PNG, TIFF or PGM/PPM, its header read.
fn decoder(path: &Path, reader: Reader, name: &str) -> Result<impl image::ImageDecoder> {
    reader.into_decoder().map_err(|e| {
        use image::error::{ImageError, UnsupportedErrorKind};
        match &e {
            ImageError::Unsupported(u) => match u.kind() {
                UnsupportedErrorKind::Color(color) => anyhow::anyhow!(
                    "{} is a {name} of {} samples, which is not read here: 8-bit grey or colour, or 14/16-bit grey counts are needed",
                    path.display(),
                    sample_kind(color)
                ),
                _ => anyhow::anyhow!("{} is a {name} this reader does not take: {e}", path.display()),
            },
            _ => anyhow::Error::new(e).context(format!("{} is not a valid {name}", path.display())),
        }
    })
}

/// A colour type the decoders do not take, in words.
fn sample_kind(color: image::ExtendedColorType) -> String {
    match color {
        image::ExtendedColorType::Unknown(bits) => {
            format!("{bits}-bit (floating-point or {bits}-bit integer)")
        }
        other => format!("{other:?}"),
    }
}

/// Refuses decoding `w × h` pixels of `bytes_per_pixel` over the memory limit (from the header,
/// before anything is allocated for it: a small file can declare a huge frame).
fn check_decode_memory(path: &Path, w: u64, h: u64, bytes_per_pixel: u64) -> Result<()> {
    let bytes = crate::memory::estimate(w.saturating_mul(h), bytes_per_pixel);
    crate::memory::check(&path.display().to_string(), &format!("decoding its {w}x{h} pixels"), bytes)
}

fn decode(path: &Path, reader: Reader, name: &str) -> Result<image::DynamicImage> {
    // The header first: a small file can declare a huge frame (a 1-bit PNG of 10⁹ pixels), so
    // the size is judged before anything is allocated for it.
    let mut decoder = decoder(path, reader, name)?;
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    let bytes_per_pixel = u64::from(image::ImageDecoder::color_type(&decoder).bytes_per_pixel());
    let per_pixel = bytes_per_pixel * crate::memory::per_pixel::DECODE;
    check_decode_memory(path, u64::from(w), u64::from(h), per_pixel)?;
    let mut limits = image::Limits::no_limits();
    limits.max_alloc = Some(crate::memory::limit());
    image::ImageDecoder::set_limits(&mut decoder, limits)
        .with_context(|| format!("{}: over the decoder's limits", path.display()))?;
    image::DynamicImage::from_decoder(decoder)
        .with_context(|| format!("{} is not a valid {name}", path.display()))
}

/// The width, height and channel count (alpha not counted) an input's header declares,
/// without decoding it.
pub fn image_header(path: &Path) -> Result<(usize, usize, usize)> {
    match open(path)? {
        Opened::Jpeg(jpeg) => Ok((jpeg.width, jpeg.height, jpeg.channels)),
        Opened::Image(reader, name) => {
            let decoder = decoder(path, reader, name)?;
            let (w, h) = image::ImageDecoder::dimensions(&decoder);
            let color = image::ImageDecoder::color_type(&decoder);
            let channels = usize::from(color.channel_count()) - usize::from(color.has_alpha());
            Ok((w as usize, h as usize, channels))
        }
    }
}

/// A JPEG as a [`Picture`]: grey or RGB, as libjpeg decodes it.
fn load_jpeg(path: &Path, jpeg: crate::jpeg::Jpeg) -> Result<Picture> {
    let (w, h, channels) = (jpeg.width, jpeg.height, jpeg.channels);
    // A progressive JPEG's coefficients are held whole by libjpeg: 2 bytes a sample, per channel
    // (at most; less with chroma subsampled).
    let coefficients = if jpeg.progressive { 2 * channels as u64 } else { 0 };
    let per_pixel = channels as u64 * crate::memory::per_pixel::DECODE + coefficients;
    check_decode_memory(path, w as u64, h as u64, per_pixel)?;
    let pixels = jpeg.decode(path)?;
    Ok(if channels == 1 {
        Picture::Gray8(Gray { width: w, height: h, data: pixels })
    } else {
        let planes = (0..3).map(|k| pixels.iter().skip(k).step_by(3).copied().collect()).collect();
        Picture::Rgb8(Channels { width: w, height: h, planes })
    })
}

/// `rgb2gray` on 8-bit samples: round(0.2989 R + 0.5870 G + 0.1140 B).
pub fn rgb_to_gray_bt601(r: u8, g: u8, b: u8) -> u8 {
    let v = 0.2989 * f64::from(r) + 0.5870 * f64::from(g) + 0.1140 * f64::from(b);
    v.round().clamp(0.0, 255.0) as u8
}

/// An input image as stored: 8-bit grey, 16-bit grey, or 8-bit colour (alpha dropped).
#[derive(Debug, Clone, PartialEq)]
pub enum Picture {
    /// 8-bit grey.
    Gray8(Gray<u8>),
    /// 16-bit grey (a thermal camera's counts).
    Gray16(Gray<u16>),
    /// 8-bit colour, three planes R, G, B.
    Rgb8(Channels),
}

impl Picture {
    /// Width and height.
    pub fn size(&self) -> (usize, usize) {
        match self {
            Picture::Gray8(g) => (g.width, g.height),
            Picture::Gray16(g) => (g.width, g.height),
            Picture::Rgb8(c) => (c.width, c.height),
        }
    }
}

/// Loads a PNG, JPEG, TIFF or PGM/PPM as it is stored ([`Picture`]). 16-bit colour and floating-point
/// images are refused.
pub fn load_picture(path: &Path) -> Result<Picture> {
    let img = match open(path)? {
        Opened::Jpeg(jpeg) => return load_jpeg(path, jpeg),
        Opened::Image(reader, name) => decode(path, reader, name)?,
    };
    let (w, h) = (img.width() as usize, img.height() as usize);
    if w == 0 || h == 0 {
        bail!("{} has zero size", path.display());
    }
    use image::DynamicImage as D;
    let gray = |data| Gray { width: w, height: h, data };
    Ok(match img {
        D::ImageLuma8(buf) => Picture::Gray8(gray(buf.into_raw())),
        D::ImageLuma16(buf) => Picture::Gray16(Gray { width: w, height: h, data: buf.into_raw() }),
        D::ImageLumaA8(buf) => Picture::Gray8(gray(buf.pixels().map(|p| p.0[0]).collect())),
        D::ImageLumaA16(buf) => {
            Picture::Gray16(Gray { width: w, height: h, data: buf.pixels().map(|p| p.0[0]).collect() })
        }
        D::ImageRgb8(_) | D::ImageRgba8(_) => {
            let rgb = img.to_rgb8();
            let planes = (0..3).map(|k| rgb.pixels().map(|p| p.0[k]).collect()).collect();
            Picture::Rgb8(Channels { width: w, height: h, planes })
        }
        D::ImageRgb16(_) | D::ImageRgba16(_) => bail!(
            "{} is a 16-bit colour image; an 8-bit colour or an 8/16-bit grey one is needed here",
            path.display()
        ),
        other => bail!(
            "{} is a {:?} image; an 8-bit colour or an 8/16-bit grey one is needed here",
            path.display(),
            other.color()
        ),
    })
}

/// Loads an image as 8- or 16-bit grey (colour converted with BT.601 if `color` allows it).
pub fn load_image(path: &Path, color: ColorPolicy) -> Result<GrayInput> {
    Ok(match load_picture(path)? {
        Picture::Gray8(g) => GrayInput::U8(g),
        Picture::Gray16(g) => GrayInput::U16(g),
        Picture::Rgb8(c) => match color {
            ColorPolicy::Refuse => {
                bail!("{} is a colour image; give an 8- or 16-bit grey one", path.display())
            }
            ColorPolicy::Bt601 => GrayInput::U8(c.to_gray()),
        },
    })
}

/// An 8-bit image as stored: one grey plane, or three colour planes (R, G, B); row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Channels {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// One plane (grey) or three (R, G, B), each `width * height` samples.
    pub planes: Vec<Vec<u8>>,
}

impl Channels {
    /// The pixels interleaved, plane values of one pixel side by side (`R G B R G B …` for
    /// colour, the plane itself for grey): the layout of encoders and numpy's `(H, W, 3)`.
    pub fn interleaved(&self) -> Vec<u8> {
        let n = self.width * self.height;
        (0..n).flat_map(|i| self.planes.iter().map(move |p| p.get(i).copied().unwrap_or(0))).collect()
    }

    /// A grey image as one plane.
    pub fn from_gray(g: Gray<u8>) -> Self {
        Self { width: g.width, height: g.height, planes: vec![g.data] }
    }

    /// Each plane as a grey image (for per-channel processing such as rescaling).
    pub fn plane(&self, k: usize) -> Gray<u8> {
        Gray { width: self.width, height: self.height, data: self.planes[k].clone() }
    }

    /// The image in grey: its one plane, or BT.601 ([`rgb_to_gray_bt601`]) of its three.
    pub fn to_gray(&self) -> Gray<u8> {
        if self.planes.len() == 1 {
            return self.plane(0);
        }
        let p = &self.planes;
        let data =
            (0..self.width * self.height).map(|i| rgb_to_gray_bt601(p[0][i], p[1][i], p[2][i])).collect();
        Gray { width: self.width, height: self.height, data }
    }
}

/// Loads an 8-bit image keeping its colour: grey (with or without alpha) as one plane, colour
/// as three (alpha dropped). 16-bit images are refused.
pub fn load_channels_u8(path: &Path) -> Result<Channels> {
    match load_picture(path)? {
        Picture::Gray8(g) => Ok(Channels::from_gray(g)),
        Picture::Rgb8(c) => Ok(c),
        Picture::Gray16(_) => {
            bail!("{} is a 16-bit image; an 8-bit grey or colour one is needed here", path.display())
        }
    }
}

/// One named VIS/IR pair: `(NAME, VIS, IR)`.
pub type NamedPair = (String, Gray<u8>, Gray<u8>);

/// The VIFB-style pairs of a folder (`NAME_VIS.png` with `NAME_IR.png`), sorted by name,
/// colour converted with BT.601. An error when the folder has none.
pub fn vifb_pairs(dir: &Path) -> Result<Vec<NamedPair>> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list {}", dir.display()))?
        .filter_map(|e| e.ok()?.file_name().to_str()?.strip_suffix("_VIS.png").map(str::to_string))
        .collect();
    names.sort();
    if names.is_empty() {
        bail!("no *_VIS.png pairs in {}", dir.display());
    }
    names
        .into_iter()
        .map(|name| {
            let vis = load_gray_u8(&dir.join(format!("{name}_VIS.png")), ColorPolicy::Bt601)?;
            let ir = load_gray_u8(&dir.join(format!("{name}_IR.png")), ColorPolicy::Bt601)?;
            Ok((name, vis, ir))
        })
        .collect()
}

/// Loads an 8-bit grey image (colour converted with BT.601 if `color` allows it; 16-bit refused).
pub fn load_gray_u8(path: &Path, color: ColorPolicy) -> Result<Gray<u8>> {
    match load_image(path, color)? {
        GrayInput::U8(g) => Ok(g),
        GrayInput::U16(_) => bail!("{} is a 16-bit image; an 8-bit one is needed here", path.display()),
    }
}

/// An output format, chosen by the output's extension (or, for a folder run, by `--format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum OutFormat {
    /// `.png`
    Png,
    /// `.tif`, `.tiff`
    Tiff,
    /// `.pgm`: binary 8/16-bit grey (P5), the format of C flight tools (`fusion-ffi/examples`).
    Pgm,
}

impl OutFormat {
    /// The extension an output of this format gets in a folder run.
    pub fn extension(self) -> &'static str {
        match self {
            OutFormat::Png => "png",
            OutFormat::Tiff => "tif",
            OutFormat::Pgm => "pgm",
        }
    }

    /// The format `path`'s extension names (case-insensitive); anything else is refused, so no
    /// file carries bytes its name does not say.
    pub fn of(path: &Path) -> Result<OutFormat> {
        // What the write path refuses first (a folder, a device…), in its words.
        crate::output::check_destination(path)?;
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(OutFormat::Png),
            Some("tif" | "tiff") => Ok(OutFormat::Tiff),
            Some("pgm") => Ok(OutFormat::Pgm),
            _ => bail!(
                "{}: an output must end in .png, .tif, .tiff or .pgm (the format follows the extension)",
                path.display()
            ),
        }
    }
}

/// Encodes an image in `format` into `out` (for [`Batch::add`](crate::output::Batch::add)).
pub fn encode_image(
    out: &mut (impl std::io::Write + std::io::Seek),
    format: OutFormat,
    w: usize,
    h: usize,
    color: image::ExtendedColorType,
    bytes: &[u8],
) -> Result<()> {
    match format {
        OutFormat::Png => encode_png(out, w, h, color, bytes),
        OutFormat::Tiff => {
            image::codecs::tiff::TiffEncoder::new(out).write_image(bytes, w as u32, h as u32, color)?;
            Ok(())
        }
        OutFormat::Pgm => {
            if !matches!(color, image::ExtendedColorType::L8 | image::ExtendedColorType::L16) {
                bail!(
                    "a PGM holds grey only: write a colour image as .png or .tif (or fuse with --color gray)"
                );
            }
            // Binary P5, header `P5\n<w> <h> <maxval>\n`; 16-bit samples big-endian (the PGM rule).
            let encoder = image::codecs::pnm::PnmEncoder::new(out).with_subtype(
                image::codecs::pnm::PnmSubtype::Graymap(image::codecs::pnm::SampleEncoding::Binary),
            );
            let be: Vec<u8>;
            let bytes = if color == image::ExtendedColorType::L16 {
                be = bytes
                    .chunks_exact(2)
                    .flat_map(|c| u16::from_ne_bytes([c[0], c[1]]).to_be_bytes())
                    .collect();
                &be
            } else {
                bytes
            };
            encoder.write_image(bytes, w as u32, h as u32, color)?;
            Ok(())
        }
    }
}

/// Encodes 8-bit grey (one plane) or colour (three planes, interleaved as RGB) in `format`.
pub fn encode_channels(
    out: &mut (impl std::io::Write + std::io::Seek),
    format: OutFormat,
    img: &Channels,
) -> Result<()> {
    match img.planes.as_slice() {
        [g] => encode_image(out, format, img.width, img.height, image::ExtendedColorType::L8, g),
        [_, _, _] => encode_image(
            out,
            format,
            img.width,
            img.height,
            image::ExtendedColorType::Rgb8,
            &img.interleaved(),
        ),
        _ => bail!("an image of {} planes cannot be written", img.planes.len()),
    }
}

/// Saves an 8-bit grey PNG, TIFF or PGM, by the extension (atomically).
pub fn save_gray_u8(path: &Path, img: &Gray<u8>) -> Result<()> {
    save_by_extension(path, img.width, img.height, image::ExtendedColorType::L8, &img.data)
}

/// Saves a 16-bit grey PNG, TIFF or PGM, by the extension (atomically).
pub fn save_gray_u16(path: &Path, img: &Gray<u16>) -> Result<()> {
    let bytes: Vec<u8> = img.data.iter().flat_map(|v| v.to_ne_bytes()).collect();
    save_by_extension(path, img.width, img.height, image::ExtendedColorType::L16, &bytes)
}

/// Saves in the format `path`'s extension names ([`OutFormat`]: `.png`, `.tif`, `.tiff`, `.pgm`;
/// anything else refused before anything is written).
fn save_by_extension(
    path: &Path,
    w: usize,
    h: usize,
    color: image::ExtendedColorType,
    bytes: &[u8],
) -> Result<()> {
    let format = OutFormat::of(path)?;
    write_atomic(path, |out| encode_image(out, format, w, h, color, bytes))
}

/// Encodes a PNG into `out` (for [`Batch::add`](crate::output::Batch::add)).
pub fn encode_png(
    out: &mut impl std::io::Write,
    w: usize,
    h: usize,
    color: image::ExtendedColorType,
    bytes: &[u8],
) -> Result<()> {
    image::codecs::png::PngEncoder::new(out).write_image(bytes, w as u32, h as u32, color)?;
    Ok(())
}

/// `img` on a `grid` (width, height) by the core's rescaler (`filter`: area down, bicubic up, as
/// the pipeline brings VIS and TIR onto its fusion grid); a copy when it is already there. For
/// metrics against the sources, contact sheets and colour planes.
pub fn source_on_grid(
    img: &Gray<u8>,
    grid: (usize, usize),
    filter: fusion_nostd::Filter,
) -> Result<Gray<u8>> {
    if (img.width, img.height) == grid {
        return Ok(img.clone());
    }
    let mut out = Gray::new(grid.0, grid.1);
    fusion_nostd::rescale(img.view()?, out.view_mut()?, filter)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::npy::{read_npy_2d, write_npy_f32};

    #[test]
    fn png_and_npy_round_trip() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let img = Gray { width: 3, height: 2, data: vec![0u8, 1, 2, 253, 254, 255] };
        let p = dir.path().join("a.png");
        save_gray_u8(&p, &img)?;
        assert_eq!(load_image(&p, ColorPolicy::Refuse)?, GrayInput::U8(img));
        let img16 = Gray { width: 2, height: 2, data: vec![0u16, 1000, 40000, 65535] };
        save_gray_u16(&p, &img16)?;
        assert_eq!(load_image(&p, ColorPolicy::Refuse)?, GrayInput::U16(img16));
        let n = dir.path().join("a.npy");
        write_npy_f32(&n, 3, 2, &[0.5, -1.0, 2.0, 3.0, 4.0, 262.25])?;
        let back = read_npy_2d(&n)?;
        assert_eq!((back.width, back.height), (3, 2));
        assert_eq!(back.data, vec![0.5, -1.0, 2.0, 3.0, 4.0, 262.25]);
        let names: Vec<_> = std::fs::read_dir(dir.path())?.collect();
        assert_eq!(names.len(), 2, "no temporary files left behind");
        Ok(())
    }

    #[test]
    fn colour_is_refused_or_converted() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let p = dir.path().join("rgb.png");
        image::save_buffer(&p, &[255, 0, 0, 0, 255, 0], 2, 1, image::ExtendedColorType::Rgb8)?;
        assert!(load_image(&p, ColorPolicy::Refuse).is_err());
        let g = load_gray_u8(&p, ColorPolicy::Bt601)?;
        assert_eq!(g.data, vec![76, 150]); // 0.2989·255 = 76.2, 0.5870·255 = 149.7
        let bad = dir.path().join("bad.png");
        std::fs::write(&bad, b"not an image")?;
        assert!(load_image(&bad, ColorPolicy::Refuse).is_err());
        assert!(load_image(&dir.path().join("missing.png"), ColorPolicy::Refuse).is_err());
        Ok(())
    }

    #[test]
    fn reads_the_published_reference_arrays() -> Result<()> {
        let p = crate::testdata::file("vifb/fight_ADF_ref.npy");
        let a = read_npy_2d(&p)?;
        assert_eq!((a.width, a.height), (452, 332));
        assert!(a.data.iter().any(|v| *v > 255.0), "ADF keeps values above 255 before the cast");
        // The published 8-bit output is the array after MATLAB's uint8 cast.
        let png = load_gray_u8(&p.with_extension("png"), ColorPolicy::Refuse)?;
        let cast = |v: f64| v.round().clamp(0.0, 255.0) as u8;
        assert!(a.data.iter().zip(&png.data).all(|(v, p)| cast(*v) == *p));
        Ok(())
    }
}
