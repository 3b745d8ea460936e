//! Offset camera pairs: the two cameras of a rig (OpenCV's stereo calibration,
//! `fusion_io::rig`) placed on the chaser, for sequences rendered as a flown rig sees them.
//!
//! The rig's convention is `stereoCalibrate`'s: `X_tir = R·X_vis + T` (metres). With the
//! visible camera at pose `(p, M)` (centre `p`, camera-to-target rotation `M`), the thermal
//! camera's rotation is `M·Rᵀ` and its centre `p − M·Rᵀ·T`.

use crate::camera::{Camera, Pose};
use anyhow::Result;
use fusion_nostd::registration::Rig;
use glam::{Mat3, Vec3};

/// The project's default offset rig (`fusion_io::rig::example_json`): a 1024² visible camera
/// of 30° and a 512² thermal camera of 35° 0.2 m to its right, toed in by 0.4°, both with
/// mild barrel distortion.
pub fn offset_rig() -> Result<Rig> {
    fusion_io::rig::from_text(fusion_io::rig::example_json())
}

/// The rig a command line names: `offset` ([`offset_rig`]) or an OpenCV stereo calibration
/// file (`fusion_io::rig::read`).
pub fn from_arg(arg: &std::path::Path) -> Result<Rig> {
    if arg.as_os_str() == "offset" { offset_rig() } else { fusion_io::rig::read(arg) }
}

/// The rig with its images scaled to `vis_size` and `tir_size` wide (the same lenses, fields
/// of view and pose; pixel centres kept): small rigs for tests and quick runs.
pub fn scaled(rig: &Rig, vis_size: usize, tir_size: usize) -> Rig {
    let scale = |c: fusion_nostd::registration::Camera, size: usize| {
        let k = size as f32 / c.width as f32;
        fusion_nostd::registration::Camera {
            fx: c.fx * k,
            fy: c.fy * k,
            cx: (c.cx + 0.5) * k - 0.5,
            cy: (c.cy + 0.5) * k - 0.5,
            width: size,
            height: (c.height as f32 * k).round() as usize,
            ..c
        }
    };
    Rig { vis: scale(rig.vis, vis_size), tir: scale(rig.tir, tir_size), ..*rig }
}

/// The rig's two cameras with the visible one at `vis_pose`.
pub fn cameras(rig: &Rig, vis_pose: Pose) -> Result<(Camera, Camera)> {
    // `rig.r` is row-major: read as columns it is Rᵀ.
    let rt = Mat3::from_cols_array_2d(&rig.r);
    let tir_pose = Pose {
        position: vis_pose.position - vis_pose.rotation * (rt * Vec3::from_array(rig.t)),
        rotation: vis_pose.rotation * rt,
    };
    Ok((Camera::from_rig(&rig.vis, vis_pose)?, Camera::from_rig(&rig.tir, tir_pose)?))
}
