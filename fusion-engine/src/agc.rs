//! The core's thermal AGC (`fusion_nostd::agc`) on host images: one call for the CLI, the
//! budget's host comparison and the examples.

use anyhow::Result;
use fusion_io::Gray;
use fusion_nostd::{Agc, AgcParams, agc_frame};

/// `counts` mapped to 8 bits with `agc`'s state (smoothing carries over from its last frame).
pub fn map_counts(agc: &mut Agc, counts: &Gray<u16>, params: &AgcParams) -> Result<Gray<u8>> {
    let mut out = Gray::<u8>::new(counts.width, counts.height);
    agc_frame(agc, counts.view()?, out.view_mut()?, params)?;
    Ok(out)
}

/// A fresh AGC state on the heap (112 KiB: too large for a small thread's stack).
pub fn fresh() -> Box<Agc> {
    Box::new(Agc::new())
}

/// The core AGC parameters for a frame of `pixels`: `mode`'s defaults (linear 1–99.9 %, or
/// plateau `max(1, pixels / 2¹⁸)`), `plateau` pixels per bin instead for plateau (ignored for
/// linear: the callers refuse that combination), `smoothing`. The CLI's `--agc`/`--plateau`/
/// `--agc-smoothing` and the Python package's `agc=`/`plateau=` both map here.
pub fn params(mode: crate::methods::AgcArg, plateau: Option<u32>, smoothing: u8, pixels: usize) -> AgcParams {
    let mut p = match mode {
        crate::methods::AgcArg::Plateau => AgcParams::plateau(pixels),
        crate::methods::AgcArg::Linear => AgcParams::linear(),
    };
    if let (Some(limit), fusion_nostd::AgcMode::Plateau { .. }) = (plateau, p.mode) {
        p.mode = fusion_nostd::AgcMode::Plateau { limit };
    }
    p.smoothing = smoothing;
    p
}
