//! Strip processing on the host: one fusion through [`fusion_nostd::strips::fuse_strips`] in a
//! 512 KiB strip scratch (shared by `fusion fuse --strips`, `fusion strip-study` and the tests).

use anyhow::Result;
use fusion_io::Gray;
use fusion_nostd::pipeline::{FuseConfig, FuseReport, fusion_grid};
use fusion_nostd::strips::{STRIP_BAND_BYTES, STRIP_WORK_WORDS, StripReport, StripScratchMut, fuse_strips};
use std::time::Instant;

/// A strip scratch of the firmware's size (512 KiB) on the heap.
pub struct HostStripScratch {
    work: Vec<i32>,
    band: Vec<u8>,
}

impl Default for HostStripScratch {
    fn default() -> Self {
        Self { work: vec![0; STRIP_WORK_WORDS], band: vec![0; STRIP_BAND_BYTES] }
    }
}

impl HostStripScratch {
    /// The borrowed view the core takes.
    pub fn view_mut(&mut self) -> StripScratchMut<'_> {
        StripScratchMut::from_slices(&mut self.work, &mut self.band)
    }
}

/// One strip fusion: the fused frame, both reports and the wall time in seconds (scratch
/// allocated outside the timed part). `max_rows` caps the strip height (`usize::MAX`: as
/// tall as the scratch allows).
pub fn fuse_strips_once(
    vis: &Gray<u8>,
    tir: &Gray<u8>,
    pipeline: &FuseConfig,
    max_rows: usize,
    scratch: &mut HostStripScratch,
) -> Result<(Gray<u8>, FuseReport, StripReport, f64)> {
    let (w, h) = fusion_grid((vis.width, vis.height), (tir.width, tir.height), pipeline.rescale)?;
    let mut out = Gray::new(w, h);
    let t0 = Instant::now();
    let (report, strips) =
        fuse_strips(vis.view()?, tir.view()?, out.view_mut()?, &mut scratch.view_mut(), pipeline, max_rows)?;
    Ok((out, report, strips, t0.elapsed().as_secs_f64()))
}
