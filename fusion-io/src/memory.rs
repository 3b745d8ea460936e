//! Memory estimates before large allocations (issue 24): every verb that allocates in
//! proportion to its frames estimates its peak from the image headers and refuses, in one line
//! naming the input, a run that would exceed the limit (`--max-memory`, default
//! [`DEFAULT_LIMIT`]) — instead of an allocation-failure abort or minutes of swapping.
//!
//! The bytes-per-pixel figures are measured peak resident sizes (`/usr/bin/time -f %M`) at
//! 1024² (fusion), 4096² (metrics) and 1024²/2048² (rendering), rounded up with a margin of
//! about a third; README, "Robustness", lists them.

use anyhow::{Context, Result, bail};
use std::sync::atomic::{AtomicU64, Ordering};

/// The default limit: 8 GiB.
pub const DEFAULT_LIMIT: u64 = 8 << 30;

static LIMIT: AtomicU64 = AtomicU64::new(DEFAULT_LIMIT);

/// Sets the limit for the rest of the run (`--max-memory`).
pub fn set_limit(bytes: u64) {
    LIMIT.store(bytes, Ordering::Relaxed);
}

/// The limit in bytes.
pub fn limit() -> u64 {
    LIMIT.load(Ordering::Relaxed)
}

/// Peak bytes per pixel of the fusion grid (measured at 1024²: 18, 72 and 140 MB).
pub mod per_pixel {
    /// The no_std core (`--engine core`): frames, scratch planes, output.
    pub const FUSE_CORE: u64 = 32;
    /// The f64 references of ADF, TSIFSD, IFEVIP (`--engine reference`).
    pub const FUSE_REFERENCE: u64 = 96;
    /// The study's host methods (GFF, MGFF, TEPGFL, DRIF; f64).
    pub const FUSE_HOST_METHOD: u64 = 192;
    /// `eval --suite study` (measured 30 B/px at 4096²).
    pub const EVAL_STUDY: u64 = 48;
    /// `eval --suite vifb` (measured 170 B/px at 4096²: whole-frame FFT planes, made once per
    /// triple and reused across channels since issue 43).
    pub const EVAL_VIFB: u64 = 192;
    /// `render`, per VIS pixel (measured 70 and 64 B/px at 1024² and 2048²).
    pub const RENDER: u64 = 96;
    /// Decoding an image: the decoded buffer and one converted copy, per byte of a pixel.
    pub const DECODE: u64 = 2;
}

fn human(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= (1u64 << 30) as f64 {
        format!("{:.1} GiB", b / (1u64 << 30) as f64)
    } else {
        format!("{:.0} MiB", (b / (1u64 << 20) as f64).ceil())
    }
}

/// Refuses `bytes` for `what` over the limit, in one line naming `input`.
pub fn check(input: &str, what: &str, bytes: u64) -> Result<()> {
    if bytes > limit() {
        bail!(
            "{input}: {what} needs about {}, over the memory limit of {} (raise it with --max-memory)",
            human(bytes),
            human(limit())
        );
    }
    Ok(())
}

/// `pixels × per_pixel` without overflow (saturating: a saturated estimate is refused).
pub fn estimate(pixels: u64, per_pixel: u64) -> u64 {
    pixels.saturating_mul(per_pixel)
}

/// Parses a size: bytes, or a number with K, M, G or T (binary units, an optional `iB`/`B`).
pub fn parse_size(text: &str) -> Result<u64> {
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let value: f64 = num.parse().with_context(|| format!("{text:?} is not a size (e.g. 512M, 8G)"))?;
    let scale: u64 =
        match unit.trim().trim_end_matches("iB").trim_end_matches('B').to_ascii_uppercase().as_str() {
            "" => 1,
            "K" => 1 << 10,
            "M" => 1 << 20,
            "G" => 1 << 30,
            "T" => 1 << 40,
            other => bail!("{text:?}: unknown unit {other:?} (K, M, G or T)"),
        };
    let bytes = value * scale as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        bail!("{text:?} is not a usable memory size");
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_binary_units() {
        assert_eq!(parse_size("8G").unwrap(), 8 << 30);
        assert_eq!(parse_size("512MiB").unwrap(), 512 << 20);
        assert_eq!(parse_size("1.5K").unwrap(), 1536);
        assert_eq!(parse_size("4096").unwrap(), 4096);
        assert!(parse_size("lots").is_err());
        assert!(parse_size("3X").is_err());
        assert!(parse_size("0").is_err());
    }

    #[test]
    fn check_names_the_input_and_the_limit() {
        let e = check("big.png", "fusing", u64::MAX).unwrap_err().to_string();
        assert!(e.starts_with("big.png: fusing needs about") && e.contains("--max-memory"), "{e}");
        assert!(check("small.png", "fusing", 1 << 20).is_ok());
    }
}
