//! The core's registration (`fusion_nostd::registration`) on host frames: a thermal frame of
//! an offset camera pair warped onto the visible grid at a range, for the CLI (`fusion
//! register`, `fusion fuse --rig --range`), the Python package and the benchmarks.

use anyhow::{Result, anyhow, ensure};
use fusion_io::Gray;
use fusion_nostd::registration::{
    Border, Interpolation, NODE_STEP, RemapSample, Rig, RigMap, node_count, register as register_core,
};

/// Visible rows of map per strip (6 bytes a pixel: 96 KiB at 1024 wide).
pub const STRIP_ROWS: usize = 16;

/// `tir` (the rig's thermal size) on the visible grid of `rig` for a target at `range_m`
/// metres along the visible optical axis.
pub fn register<T: RemapSample + Default>(
    tir: &Gray<T>,
    rig: &Rig,
    range_m: f64,
    interpolation: Interpolation,
    border: Border,
) -> Result<Gray<T>> {
    ensure!(
        (tir.width, tir.height) == (rig.tir.width, rig.tir.height),
        "the thermal image is {}x{}, the rig's thermal camera {}x{}",
        tir.width,
        tir.height,
        rig.tir.width,
        rig.tir.height
    );
    ensure!(
        range_m.is_finite() && range_m > 0.0,
        "the range must be a positive number of metres, not {range_m}"
    );
    let (w, h) = (rig.vis.width, rig.vis.height);
    let mut nodes = vec![[0.0f32; 2]; node_count(w, h, NODE_STEP)];
    let map = RigMap::new(rig, range_m as f32, NODE_STEP, &mut nodes).map_err(|e| anyhow!("{e}"))?;
    let mut out = Gray::<T>::new(w, h);
    let (mut xy, mut frac) = (vec![0i16; 2 * STRIP_ROWS * w], vec![0u16; STRIP_ROWS * w]);
    register_core(tir.view()?, &map, out.view_mut()?, interpolation, border, &mut xy, &mut frac)
        .map_err(|e| anyhow!("{e}"))?;
    Ok(out)
}

/// The remap interpolation, as named on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum InterpolationArg {
    /// Bilinear (`cv2.INTER_LINEAR`).
    Linear,
    /// Keys bicubic, a = −0.75 (`cv2.INTER_CUBIC`).
    Cubic,
}

impl From<InterpolationArg> for Interpolation {
    fn from(i: InterpolationArg) -> Self {
        match i {
            InterpolationArg::Linear => Interpolation::Linear,
            InterpolationArg::Cubic => Interpolation::Cubic,
        }
    }
}

/// What the registered frame shows where the thermal camera did not see, as named on the
/// command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum BorderArg {
    /// A constant (`cv2.BORDER_CONSTANT`; the value given with it, 0 by default: cold space).
    Constant,
    /// The nearest edge pixel (`cv2.BORDER_REPLICATE`).
    Replicate,
}

impl BorderArg {
    /// The core's border, a constant of `value`.
    pub fn with_value(self, value: u16) -> Border {
        match self {
            BorderArg::Constant => Border::Constant(value),
            BorderArg::Replicate => Border::Replicate,
        }
    }
}
