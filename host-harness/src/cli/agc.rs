//! The thermal AGC's options, shared by `fuse` (which maps 14/16-bit thermal counts to 8 bits
//! before fusing) and `eval` (which maps a 14/16-bit thermal source the same way, so a fused
//! frame is scored against the thermal frame that went into it).

use anyhow::{Result, bail};
use clap::Args;
use fusion_engine::methods::AgcArg;

/// `--agc` and `--plateau`.
#[derive(Debug, Clone, Copy, Default, Args)]
pub struct AgcChoice {
    /// Thermal AGC for a 14/16-bit thermal image (its counts to 8 bits, in the core:
    /// `fusion_nostd::agc`) [default: linear]. An 8-bit thermal image is used as it is.
    #[arg(long, value_enum)]
    pub agc: Option<AgcArg>,
    /// The plateau of plateau equalisation, in pixels per histogram bin (bins of 4 counts); given
    /// alone it asks for --agc plateau [default: the thermal frame's pixels / 2^18, at least 1].
    #[arg(long, value_name = "PIXELS")]
    pub plateau: Option<u32>,
}

impl AgcChoice {
    /// Refuses contradictory options.
    pub fn check(&self) -> Result<()> {
        if let (Some(AgcArg::Linear), Some(_)) = (self.agc, self.plateau) {
            bail!("--plateau sets the plateau of --agc plateau; drop it with --agc linear");
        }
        if self.plateau == Some(0) {
            bail!("--plateau must be at least 1 pixel per bin");
        }
        Ok(())
    }

    /// Whether either option was given.
    pub fn given(&self) -> bool {
        self.agc.is_some() || self.plateau.is_some()
    }

    /// The core's parameters for a frame of `pixels` (linear unless `--agc plateau` or
    /// `--plateau` asks for plateau equalisation), with the temporal smoothing `smoothing`.
    pub fn params(&self, smoothing: u8, pixels: usize) -> fusion_nostd::AgcParams {
        let default = if self.plateau.is_some() { AgcArg::Plateau } else { AgcArg::Linear };
        fusion_engine::agc::params(self.agc.unwrap_or(default), self.plateau, smoothing, pixels)
    }
}
