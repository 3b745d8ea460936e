//! # fusion-engine
//!
//! The `no_std` fusion core driven from the host: what every host tool (the `fusion` CLI, the
//! navigation judge, the budget runner, the Python package, the tests) calls to fuse.
//!
//! * [`methods`]: the core's methods and options by the names users give them ([`methods::MethodArg`],
//!   [`methods::VariantArg`], …), and the two engines every tool fuses through: the core
//!   pipeline ([`methods::fuse_core`]) and the `f64` references ([`methods::fuse_reference`]).
//! * [`CoreScratch`]: the core's work planes on the heap; [`strips`]: the 512 KiB strip scratch.
//! * [`registration`]: a thermal frame of an offset camera pair on the visible grid at a range.
//! * [`thermal`]: the thermal camera's front end (NUC, shutter, bad pixels, column filter) carried
//!   from frame to frame; [`agc`]: the thermal gain control on 16-bit frames; [`color`]: colour kept through a grey
//!   fusion (YCbCr, BT.601).
//! * [`sequence`]: a sequence of frame pairs fused in order, ADF's weights carried from frame
//!   to frame (the core's sequence mode), whole frame or in strips.
//! * [`skip`]: scene skipping, the error it adds and the crop semantics' reference
//!   ([`skip::fuse_crop`]); [`study`]: rendered datasets, timed
//!   fusions, the method list of the study; [`stress`]: every method over adversarial frames.
//!
//! The value enums derive `clap::ValueEnum` behind the `clap` feature (the CLI turns it on).
//!
//! ```
//! use fusion_engine::methods::{MethodArg, VariantArg, fuse_core, method_for};
//! use fusion_io::Gray;
//! use fusion_nostd::pipeline::FuseConfig;
//!
//! let vis = Gray { width: 16, height: 16, data: (0..256).map(|i| i as u8).collect() };
//! let tir = Gray { width: 8, height: 8, data: vec![180u8; 64] };
//! // TSIFSD, flight variant; TIR upscaled onto the VIS grid (the default rescale policy).
//! let config = FuseConfig { method: method_for(MethodArg::Tsifsd, VariantArg::Flight), ..FuseConfig::default() };
//! let fused = fuse_core(&vis, &tir, &config, false)?;
//! assert_eq!((fused.image.width, fused.image.height), (16, 16));
//! # Ok::<(), anyhow::Error>(())
//! ```

pub mod agc;
pub mod color;
pub mod methods;
pub mod registration;
pub mod sequence;
pub mod skip;
pub mod stress;
pub mod strips;
pub mod study;
pub mod thermal;

/// A host-side scratch for the core: the `i32` work planes and the `u8` band plane, on the heap.
pub struct CoreScratch {
    planes: [Vec<i32>; fusion_nostd::SCRATCH_PLANES],
    band: Vec<u8>,
}

impl CoreScratch {
    /// Scratch for frames of up to `pixels` pixels.
    pub fn new(pixels: usize) -> Self {
        Self { planes: std::array::from_fn(|_| vec![0; pixels]), band: vec![0; pixels] }
    }

    /// Pixels each plane holds.
    pub fn pixels(&self) -> usize {
        self.band.len()
    }

    /// The core view of the planes.
    pub fn view_mut(&mut self) -> fusion_nostd::ScratchMut<'_> {
        let [a, b, c] = &mut self.planes;
        fusion_nostd::ScratchMut::with_band([a, b, c], &mut self.band)
    }
}
