//! Atomic PNG/JSON output: write to a temporary name in the target folder, then rename.

use crate::image::{Gray16Image, Image};
use anyhow::{Context, Result};
use image::{GrayImage, ImageFormat};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Writes a file through `write` under a temporary name next to `path`, then renames it into
/// place, so a failed run never leaves a partial file.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> Result<()>) -> Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| -> Result<()> {
        let file = File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        w.flush()?;
        Ok(())
    })();
    match result.and_then(|()| {
        std::fs::rename(&tmp, path).with_context(|| format!("cannot rename into {}", path.display()))
    }) {
        Ok(()) => Ok(()),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e).with_context(|| format!("cannot write {}", path.display()))
        }
    }
}

/// Writes an 8-bit grey PNG atomically.
pub fn write_png8(path: &Path, img: &GrayImage) -> Result<()> {
    write_atomic(path, |w| Ok(img.write_to(w, ImageFormat::Png)?))
}

/// Writes a 16-bit grey PNG atomically.
pub fn write_png16(path: &Path, img: &Gray16Image) -> Result<()> {
    write_atomic(path, |w| Ok(img.write_to(w, ImageFormat::Png)?))
}

/// Writes a float image as an 8-bit grey PNG atomically.
pub fn save_gray8(path: &Path, img: &Image) -> Result<()> {
    write_png8(path, &img.to_gray8())
}

/// Writes a value as pretty JSON atomically.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    write_atomic(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value)?;
        w.write_all(b"\n")?;
        Ok(())
    })
}
