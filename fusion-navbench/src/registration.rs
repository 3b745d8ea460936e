//! Offset cameras: the thermal frame put on the visible grid of a sequence rendered through a
//! rig (`fusion render --rig`), and how far that leaves the target's two images apart.
//!
//! On board the registration's range comes from the navigation filter: the depth of the
//! target along the visible camera's axis at the predicted pose ([`Registration::Filter`]).
//! The plane homography is exact only at that depth; the target's own depth and the filter's
//! range error leave a misregistration, measured here from the rendered depth: each visible
//! target pixel's surface point projected into the thermal camera, against where the map sends
//! the pixel ([`misregistration`]).

use crate::bench::quantile;
use anyhow::Result;
use fusion_io::Gray;
use fusion_nostd::registration::{Border, Interpolation, Rig};
use render_host::Camera;

/// How the thermal frame of an offset rig reaches the visible grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Registration {
    /// Through the rig at the range the stream's own filter predicts (as on board).
    #[default]
    Filter,
    /// Through the rig at the true range (the ceiling of the registration).
    Truth,
    /// Not at all: the cameras taken as aligned (the core's bicubic rescale), as today's
    /// fusion path does.
    None,
}

impl Registration {
    /// Parses `filter`, `truth` or `none`.
    pub fn parse(s: &str) -> Result<Registration> {
        match s {
            "filter" => Ok(Registration::Filter),
            "truth" => Ok(Registration::Truth),
            "none" => Ok(Registration::None),
            _ => anyhow::bail!("unknown registration '{s}'; it is filter, truth or none"),
        }
    }
}

/// Sampling step of the misregistration over the visible target pixels, px.
pub const SAMPLE_STEP: usize = 2;

/// The thermal frame `tir` on the `w × h` visible grid: registered through `rig` at `range_m`
/// (linear, black outside), or, without one, the core's bicubic rescale (aligned cameras).
pub fn on_vis_grid(tir: &Gray<u8>, w: usize, h: usize, through: Option<(&Rig, f64)>) -> Result<Gray<u8>> {
    match through {
        Some((rig, range)) => {
            fusion_engine::registration::register(tir, rig, range, Interpolation::Linear, Border::Constant(0))
        }
        None => {
            let mut up = Gray::<u8>::new(w, h);
            fusion_nostd::rescale(tir.view()?, up.view_mut()?, fusion_nostd::Filter::Cubic)?;
            Ok(up)
        }
    }
}

/// The misregistration of a frame, visible px: for every [`SAMPLE_STEP`]-th visible target
/// pixel (rendered `depth` along its ray), the distance between the thermal pixel its surface
/// point projects to (`tir`, the true thermal camera) and the one the registration reads for
/// it (`through`: the rig's map at that range; `None`: the aligned rescale's), scaled by the
/// cameras' focal ratio. Returns the median and the 95th percentile; `None` without target
/// pixels.
pub fn misregistration(
    vis: &Camera,
    tir: &Camera,
    depth: &[Option<f32>],
    through: Option<(&Rig, f64)>,
) -> Option<(f64, f64)> {
    let (w, h) = (vis.width as usize, vis.height as usize);
    let scale = f64::from(vis.focal_px) / f64::from(tir.focal_px);
    let mut d = Vec::new();
    for y in (0..h).step_by(SAMPLE_STEP) {
        for x in (0..w).step_by(SAMPLE_STEP) {
            let Some(t) = depth[y * w + x] else { continue };
            let point = vis.pose.position + vis.pixel_ray(x as u32, y as u32) * t;
            let Some((tu, tv)) = tir.project(point) else { continue };
            // Both in continuous coordinates (pixel centres at x + 0.5).
            let mapped = match through {
                Some((rig, range)) => rig
                    .tir_position(x as f32, y as f32, range as f32)
                    .map(|(u, v)| (f64::from(u) + 0.5, f64::from(v) + 0.5)),
                None => Some((
                    (x as f64 + 0.5) * f64::from(tir.width) / w as f64,
                    (y as f64 + 0.5) * f64::from(tir.height) / h as f64,
                )),
            };
            let Some((mu, mv)) = mapped else { continue };
            d.push((f64::from(tu) - mu).hypot(f64::from(tv) - mv) * scale);
        }
    }
    Some((quantile(d.clone(), 0.5)?, quantile(d, 0.95)?))
}
