//! The core's thermal AGC (`fusion_nostd::agc`) on host images: one call for the CLI, the
//! budget's host comparison and the examples.

use crate::io::Gray;
use anyhow::Result;
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
