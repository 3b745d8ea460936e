//! The judge's floor and ceiling, run through the same estimators as the image streams.
//!
//! * **zero-motion** predicts no motion: its frame-to-frame pose is the identity, and its
//!   filter never gets a measurement, so its estimate stays at the first frame's
//!   initialisation. Any stream that does not beat it has not measured the motion.
//! * **oracle** is fed ground-truth correspondences: target surface points (from the rendered
//!   depth) projected into the image with the rendered pose, perturbed by
//!   [`ORACLE_NOISE_PX`] of white noise, through the same PnP-RANSAC, refinement and filter
//!   as the streams. It is what a perfect feature front end would give; no stream can be
//!   expected to do better.

use crate::model::normalised;
use crate::pose::RelativePose;
use render_host::Camera;
use render_host::glam::{DVec2, DVec3};
use render_host::noise::SplitMix64;

/// The oracle's image noise, px (1σ per axis).
pub const ORACLE_NOISE_PX: f64 = 0.3;
/// About this many oracle correspondences per frame (a grid over the target's pixels).
pub const ORACLE_POINTS: usize = 150;

/// A standard normal deviate (Box–Muller on two uniforms of `rng`).
pub fn gaussian(rng: &mut SplitMix64) -> f64 {
    let u1 = ((rng.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64;
    let u2 = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A random unit vector.
pub fn unit_vector(rng: &mut SplitMix64) -> DVec3 {
    loop {
        let v = DVec3::new(gaussian(rng), gaussian(rng), gaussian(rng));
        if v.length() > 1e-6 {
            return v.normalize();
        }
    }
}

/// Camera-frame target points of a frame: a grid over the pixels that see the target, about
/// [`ORACLE_POINTS`] of them, each at its rendered depth along its pixel's ray.
pub fn surface_points(cam: &Camera, depth: &[Option<f32>]) -> Vec<DVec3> {
    let w = cam.width as usize;
    let hits = depth.iter().filter(|d| d.is_some()).count();
    if hits == 0 {
        return Vec::new();
    }
    let step = ((hits as f64 / ORACLE_POINTS as f64).sqrt().floor() as usize).max(1);
    let mut out = Vec::new();
    for y in (0..depth.len() / w.max(1)).step_by(step) {
        for x in (0..w).step_by(step) {
            if let Some(d) = depth[y * w + x] {
                out.push(
                    normalised(cam, x as f64 + 0.5, y as f64 + 0.5).extend(1.0).normalize() * f64::from(d),
                );
            }
        }
    }
    out
}

/// Points (`points`, in some frame A) seen by camera 2 through the true pose A → camera 2,
/// with the oracle's noise: the normalised image coordinates, for the points in front of the
/// camera that `visible` accepts.
pub fn observe(
    points: &[DVec3],
    truth: &RelativePose,
    focal_px: f64,
    rng: &mut SplitMix64,
    visible: impl Fn(DVec3) -> bool,
) -> (Vec<DVec3>, Vec<DVec2>) {
    let mut p3 = Vec::new();
    let mut p2 = Vec::new();
    for &x in points {
        let Some(u) = truth.project(x) else { continue };
        if !visible(x) {
            continue;
        }
        let noise = DVec2::new(gaussian(rng), gaussian(rng)) * (ORACLE_NOISE_PX / focal_px);
        p3.push(x);
        p2.push(u + noise);
    }
    (p3, p2)
}
