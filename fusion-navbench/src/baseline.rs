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
use render_host::glam::{DMat3, DQuat, DVec2, DVec3};
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

/// The true camera attitude (camera → target) and position in the target's frame of a
/// rendered camera.
pub fn true_pose(cam: &Camera) -> (DQuat, DVec3) {
    (DQuat::from_mat3(&cam.pose.rotation.as_dmat3()).normalize(), cam.pose.position.as_dvec3())
}

/// The true pose target → camera of a rendered camera ([`true_pose`] inverted).
pub fn target_to_camera(cam: &Camera) -> RelativePose {
    let (q, p) = true_pose(cam);
    RelativePose { rotation: q.inverse(), translation: -(DMat3::from_quat(q).transpose() * p) }
}

/// Points (`points`, in some frame A) seen by camera 2 through the true pose A → camera 2,
/// with `noise_px` of white noise per axis ([`ORACLE_NOISE_PX`] for the oracle): the
/// normalised image coordinates, for the points in front of the camera that `visible` accepts.
pub fn observe(
    points: &[DVec3],
    truth: &RelativePose,
    focal_px: f64,
    noise_px: f64,
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
        let noise = DVec2::new(gaussian(rng), gaussian(rng)) * (noise_px / focal_px);
        p3.push(x);
        p2.push(u + noise);
    }
    (p3, p2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::TargetModel;
    use render_host::Scene;
    use render_host::sequence::{SequenceConfig, SequenceName, camera_pose, state};

    /// The target → camera pose projects a target-frame point where the camera does, and
    /// `observe` with no noise returns exactly those coordinates.
    #[test]
    fn the_true_pose_projects_as_the_camera_and_observe_adds_only_its_noise() {
        let scene = Scene::tango().expect("scene");
        let cfg = SequenceConfig::new(SequenceName::Flyaround);
        let cam = Camera::study(256, camera_pose(&state(&cfg, 30), &scene));
        let model = TargetModel::new(&scene);
        let (x0, y0, x1, y1) = model.image_box(&cam, 0.0).expect("box");
        let points: Vec<DVec3> = (0..8)
            .flat_map(|i| (0..8).map(move |j| (i, j)))
            .filter_map(|(i, j)| {
                let u = f64::from(x0) + (f64::from(i) + 0.5) / 8.0 * f64::from(x1 - x0);
                let v = f64::from(y0) + (f64::from(j) + 0.5) / 8.0 * f64::from(y1 - y0);
                model.back_project(&cam, u, v).map(|h| h.point)
            })
            .collect();
        assert!(points.len() >= 10, "{} points on the target", points.len());
        let truth = target_to_camera(&cam);
        let f = f64::from(cam.focal_px);
        for &x in &points {
            let (u, v) = cam.project(x.as_vec3()).expect("in front");
            let seen = normalised(&cam, f64::from(u), f64::from(v));
            let by_pose = truth.project(x).expect("in front");
            assert!((seen - by_pose).length() * f < 1e-3, "{seen:?} vs {by_pose:?}");
        }
        let mut rng = SplitMix64::new(7);
        let (p3, p2) = observe(&points, &truth, f, 0.0, &mut rng, |_| true);
        assert_eq!(p3, points);
        for (x, u) in p3.iter().zip(&p2) {
            assert_eq!(*u, truth.project(*x).expect("in front"));
        }
        // With noise, the spread in pixels is the one asked for (64 points: within 40 %).
        let (_, noisy) = observe(&points, &truth, f, 2.0, &mut rng, |_| true);
        let rms = (p2.iter().zip(&noisy).map(|(a, b)| (a - b).length_squared()).sum::<f64>()
            / (2.0 * p2.len() as f64))
            .sqrt()
            * f;
        assert!((rms - 2.0).abs() < 0.8, "noise {rms:.2} px per axis");
    }
}
