//! A sequence of frame pairs fused in order with the core's sequence mode
//! ([`fusion_nostd::sequence`]): ADF's KL weights carried from each frame to the next, whole
//! frame or in strips (the same bytes), what the CLI's folder form, `fusion navbench` and the
//! Python package call.
//!
//! ```
//! use fusion_engine::sequence::{Form, SequenceFuser};
//! use fusion_io::Gray;
//! use fusion_nostd::pipeline::{FuseConfig, Method};
//! use fusion_nostd::sequence::{Pass, SequenceParams};
//! use fusion_nostd::AdfParams;
//!
//! let config = FuseConfig { method: Method::Adf(AdfParams::default()), ..FuseConfig::default() };
//! let mut whole = SequenceFuser::new(config, SequenceParams::default(), Form::WholeFrame);
//! let mut strips = SequenceFuser::new(config, SequenceParams::default(), Form::Strips { max_rows: 24 });
//! for k in 0..3u8 {
//!     let vis = Gray { width: 64, height: 64, data: (0..64 * 64).map(|i| ((i * 7 + usize::from(k) * 5) % 251) as u8).collect() };
//!     let tir = Gray { width: 32, height: 32, data: (0..32 * 32).map(|i| ((i % 32) * 6 + usize::from(k)) as u8).collect() };
//!     let a = whole.fuse(&vis, &tir)?;
//!     let b = strips.fuse(&vis, &tir)?;
//!     assert_eq!(a.image.data, b.image.data);
//!     assert_eq!(a.step.pass, if k == 0 { Pass::Own(fusion_nostd::sequence::Restart::First) } else { Pass::Carried });
//! }
//! # Ok::<(), anyhow::Error>(())
//! ```

use anyhow::{Context, Result};
use fusion_io::Gray;
use fusion_nostd::pipeline::{FuseConfig, FuseReport, fuse_in_sequence, fusion_grid};
use fusion_nostd::sequence::{Sequence, SequenceParams, SequenceStep};
use fusion_nostd::strips::{StripReport, fuse_strips_in_sequence};

use crate::CoreScratch;
use crate::strips::HostStripScratch;

/// Where the core fuses each frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// [`fusion_nostd::pipeline::fuse_in_sequence`] in whole-frame planes (scene skipping as
    /// the configuration says).
    WholeFrame,
    /// [`fusion_nostd::strips::fuse_strips_in_sequence`] in the 512 KiB strip scratch, strips of
    /// at most `max_rows` rows (`usize::MAX`: as tall as the scratch allows).
    Strips {
        /// Largest strip height.
        max_rows: usize,
    },
}

/// One fused frame of a sequence.
#[derive(Debug, Clone)]
pub struct SequenceFrame {
    /// The fused frame (the fusion grid).
    pub image: Gray<u8>,
    /// The pipeline's report.
    pub report: FuseReport,
    /// How the sequence fused it (carried or own weights, per frame).
    pub step: SequenceStep,
    /// The strip report, in [`Form::Strips`].
    pub strips: Option<StripReport>,
}

/// Fuses the frames of one sequence in order, carrying the core's [`Sequence`] state and the
/// scratch from frame to frame.
pub struct SequenceFuser {
    config: FuseConfig,
    form: Form,
    seq: Sequence,
    scratch: Option<CoreScratch>,
    strip_scratch: Option<HostStripScratch>,
}

impl SequenceFuser {
    /// A sequence with nothing carried yet.
    pub fn new(config: FuseConfig, params: SequenceParams, form: Form) -> Self {
        Self { config, form, seq: Sequence::new(params), scratch: None, strip_scratch: None }
    }

    /// The configuration every frame is fused with.
    pub fn config(&self) -> &FuseConfig {
        &self.config
    }

    /// Forgets the carried weights (the next frame takes its own).
    pub fn reset(&mut self) {
        self.seq.reset();
    }

    /// Fuses the next frame pair of the sequence.
    pub fn fuse(&mut self, vis: &Gray<u8>, tir: &Gray<u8>) -> Result<SequenceFrame> {
        let (vs, ts) = ((vis.width, vis.height), (tir.width, tir.height));
        let (w, h) = fusion_grid(vs, ts, self.config.rescale)?;
        let mut image = Gray::new(w, h);
        let (report, strips) = match self.form {
            Form::WholeFrame => {
                let pixels = self.config.scratch_pixels(vs, ts)?;
                let scratch = match &mut self.scratch {
                    Some(s) if s.pixels() >= pixels => s,
                    slot => slot.insert(CoreScratch::new(pixels)),
                };
                let r = fuse_in_sequence(
                    vis.view()?,
                    tir.view()?,
                    image.view_mut()?,
                    &mut scratch.view_mut(),
                    &self.config,
                    &mut self.seq,
                )?;
                (r, None)
            }
            Form::Strips { max_rows } => {
                let scratch = self.strip_scratch.get_or_insert_with(HostStripScratch::default);
                let (r, s) = fuse_strips_in_sequence(
                    vis.view()?,
                    tir.view()?,
                    image.view_mut()?,
                    &mut scratch.view_mut(),
                    &self.config,
                    max_rows,
                    &mut self.seq,
                )?;
                (r, Some(s))
            }
        };
        let step = self.seq.last_step().context("the core reported no sequence step")?;
        Ok(SequenceFrame { image, report, step, strips })
    }
}
