//! Arrays as NumPy `.npy` files: the published reference outputs are read as `f64`
//! ([`read_npy_2d`]), float results written as `float32` ([`write_npy_f32`], through the atomic
//! write path).

use crate::Gray;
use crate::output::write_atomic;
use anyhow::{Context, Result, bail};
use std::path::Path;

/// Reads a float32, float64, uint8, uint16 or int16 `.npy` array of shape `(H, W)` (C or
/// Fortran order) as `f64` (every value exact), row-major.
pub fn read_npy_2d(path: &Path) -> Result<Gray<f64>> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let npy =
        npyz::NpyFile::new(&bytes[..]).with_context(|| format!("{} is not a .npy file", path.display()))?;
    let shape = npy.shape().to_vec();
    let [h, w] = shape[..] else { bail!("{}: expected a 2-D array, got shape {shape:?}", path.display()) };
    let (h, w) = (h as usize, w as usize);
    let fortran = npy.order() == npyz::Order::Fortran;
    let data: Vec<f64> = match npy.dtype() {
        npyz::DType::Plain(t) if t.type_char() == npyz::TypeChar::Float && t.size_field() == 4 => {
            npy.into_vec::<f32>()?.into_iter().map(f64::from).collect()
        }
        npyz::DType::Plain(t) if t.type_char() == npyz::TypeChar::Float && t.size_field() == 8 => {
            npy.into_vec::<f64>()?
        }
        npyz::DType::Plain(t) if t.type_char() == npyz::TypeChar::Uint && t.size_field() == 1 => {
            npy.into_vec::<u8>()?.into_iter().map(f64::from).collect()
        }
        npyz::DType::Plain(t) if t.type_char() == npyz::TypeChar::Uint && t.size_field() == 2 => {
            npy.into_vec::<u16>()?.into_iter().map(f64::from).collect()
        }
        npyz::DType::Plain(t) if t.type_char() == npyz::TypeChar::Int && t.size_field() == 2 => {
            npy.into_vec::<i16>()?.into_iter().map(f64::from).collect()
        }
        other => bail!("{}: unsupported dtype {other:?}", path.display()),
    };
    if data.len() != w * h {
        bail!("{}: {} values for shape ({h}, {w})", path.display(), data.len());
    }
    let data = if fortran {
        // Column-major storage: element (r, c) sits at c·H + r.
        (0..h).flat_map(|r| (0..w).map(move |c| (r, c))).map(|(r, c)| data[c * h + r]).collect()
    } else {
        data
    };
    Ok(Gray { width: w, height: h, data })
}

/// Writes a 2-D float32 `.npy` array of shape `(H, W)` (atomically).
pub fn write_npy_f32(path: &Path, width: usize, height: usize, data: &[f32]) -> Result<()> {
    write_atomic(path, |out| encode_npy_f32(out, width, height, data))
}

/// Encodes a 2-D float32 `.npy` array of shape `(H, W)` into `out` (for [`crate::output::Batch::add`]).
pub fn encode_npy_f32(
    out: &mut impl std::io::Write,
    width: usize,
    height: usize,
    data: &[f32],
) -> Result<()> {
    if data.len() != width * height {
        bail!("array of {} values does not have shape {height}x{width}", data.len());
    }
    use npyz::WriterBuilder;
    let mut writer = npyz::WriteOptions::<f32>::new()
        .default_dtype()
        .shape(&[height as u64, width as u64])
        .writer(out)
        .begin_nd()?;
    writer.extend(data.iter().copied())?;
    writer.finish()?;
    Ok(())
}
