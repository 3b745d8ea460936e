//! Frame-to-frame relative pose from tracked features, by PnP against the rendered depth.
//!
//! **Why PnP.** The chaser's navigation filter tracks an uncooperative but known-shape target:
//! features found in frame k sit on the target's surface, whose depth a model-based tracker
//! gets from its model (here: the rendered depth of frame k, `render_host::truth::depth`), and
//! their positions in frame k + 1 give the camera's motion by Perspective-n-Point. An essential
//! matrix would need no depth but degenerates on the planar views that dominate this target
//! (the solar panel, one bus side), and a homography holds only for those. The PnP solver is
//! `sqpnp_simple` (SQPnP, Terzakis & Lourakis 2020: globally optimal, planar or not); the
//! RANSAC loop around it (seeded 6-point samples, reprojection threshold in pixels, refit on
//! the inliers) is written here, as no maintained crate offers one for it.

use render_host::glam::{DMat3, DQuat, DVec2, DVec3};

/// Reprojection threshold of an inlier, px.
pub const INLIER_THRESHOLD_PX: f64 = 2.0;
/// RANSAC iterations.
pub const RANSAC_ITERATIONS: usize = 200;
/// Sample size of one hypothesis.
pub const SAMPLE: usize = 6;
/// Fewer inliers than this: tracking is lost on this frame pair.
pub const MIN_INLIERS: usize = 8;

/// A relative pose `X₂ = R X₁ + t` (camera 1 coordinates to camera 2 coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelativePose {
    /// Rotation.
    pub rotation: DQuat,
    /// Translation, m.
    pub translation: DVec3,
}

impl RelativePose {
    /// The true relative pose of two cameras given as camera-to-target rotations (columns: the
    /// camera axes in the target frame) and positions in the target frame.
    pub fn between(r1: DMat3, p1: DVec3, r2: DMat3, p2: DVec3) -> RelativePose {
        let r = r2.transpose() * r1;
        RelativePose { rotation: DQuat::from_mat3(&r).normalize(), translation: r2.transpose() * (p1 - p2) }
    }

    /// Angle between the two rotations, degrees.
    pub fn rotation_error_deg(&self, truth: &RelativePose) -> f64 {
        let d = (self.rotation * truth.rotation.inverse()).normalize();
        (2.0 * d.w.abs().min(1.0).acos()).to_degrees()
    }

    /// Angle between the two translation directions, degrees (NaN when either is zero).
    pub fn translation_direction_error_deg(&self, truth: &RelativePose) -> f64 {
        let (a, b) = (self.translation.normalize_or_zero(), truth.translation.normalize_or_zero());
        if a == DVec3::ZERO || b == DVec3::ZERO {
            return f64::NAN;
        }
        a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
    }

    fn project(&self, x: DVec3) -> Option<DVec2> {
        let y = self.rotation * x + self.translation;
        (y.z > 1e-9).then(|| DVec2::new(y.x / y.z, y.y / y.z))
    }
}

/// The result of [`pnp_ransac`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PnpResult {
    /// The pose refit on the inliers.
    pub pose: RelativePose,
    /// Inliers of that pose.
    pub inliers: usize,
}

/// RANSAC over SQPnP: `points` in camera-1 coordinates (m), `image` their normalised image
/// coordinates in camera 2 (`(u − cx)/f, (v − cy)/f`), `focal_px` to turn the threshold into
/// normalised units. `None` with fewer than [`SAMPLE`] correspondences or no hypothesis.
pub fn pnp_ransac(points: &[DVec3], image: &[DVec2], focal_px: f64, seed: u64) -> Option<PnpResult> {
    let n = points.len().min(image.len());
    if n < SAMPLE {
        return None;
    }
    let threshold = INLIER_THRESHOLD_PX / focal_px;
    let inliers_of = |pose: &RelativePose| -> Vec<usize> {
        (0..n)
            .filter(|&i| pose.project(points[i]).is_some_and(|p| (p - image[i]).length() <= threshold))
            .collect()
    };
    let mut state = seed ^ 0xD1B5_4A32_D192_ED03;
    let mut best: Option<(RelativePose, Vec<usize>)> = None;
    for _ in 0..RANSAC_ITERATIONS {
        let mut sample = Vec::with_capacity(SAMPLE);
        while sample.len() < SAMPLE {
            state = render_host::noise::mix64(state);
            let i = (state % n as u64) as usize;
            if !sample.contains(&i) {
                sample.push(i);
            }
        }
        let Some(pose) = solve(points, image, &sample) else { continue };
        let inl = inliers_of(&pose);
        if best.as_ref().is_none_or(|(_, b)| inl.len() > b.len()) {
            best = Some((pose, inl));
        }
    }
    let (pose, inl) = best?;
    // Refit on the inliers, keep the refit only if it keeps at least as many.
    let (pose, inliers) = match solve(points, image, &inl) {
        Some(refit) => {
            let again = inliers_of(&refit);
            if again.len() >= inl.len() { (refit, again.len()) } else { (pose, inl.len()) }
        }
        None => (pose, inl.len()),
    };
    Some(PnpResult { pose, inliers })
}

/// SQPnP on the chosen correspondences.
fn solve(points: &[DVec3], image: &[DVec2], pick: &[usize]) -> Option<RelativePose> {
    if pick.len() < 3 {
        return None;
    }
    let p3: Vec<(f64, f64, f64)> = pick.iter().map(|&i| (points[i].x, points[i].y, points[i].z)).collect();
    let p2: Vec<(f64, f64)> = pick.iter().map(|&i| (image[i].x, image[i].y)).collect();
    let (r, t) = sqpnp_simple::sqpnp_solve(&p3, &p2)?;
    let axis = DVec3::new(r.0, r.1, r.2);
    let pose =
        RelativePose { rotation: DQuat::from_scaled_axis(axis), translation: DVec3::new(t.0, t.1, t.2) };
    (pose.rotation.is_finite() && pose.translation.is_finite()).then_some(pose)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on two planes (a box corner: the degenerate case of the essential matrix is one
    /// plane; SQPnP handles both), a known motion, 30 % of the correspondences replaced by
    /// garbage: RANSAC recovers the motion to 1e-6° and counts the inliers.
    #[test]
    fn recovers_a_known_motion_through_outliers() {
        let truth = RelativePose {
            rotation: DQuat::from_scaled_axis(DVec3::new(0.01, -0.02, 0.015)),
            translation: DVec3::new(0.05, -0.02, 0.3),
        };
        let mut points = Vec::new();
        for k in 0..60 {
            let (a, b) = (f64::from(k % 10) * 0.05 - 0.25, f64::from(k / 10) * 0.05 - 0.15);
            points.push(if k % 2 == 0 { DVec3::new(a, b, 5.0) } else { DVec3::new(0.3, a, 5.0 + b) });
        }
        let mut image: Vec<DVec2> = points.iter().map(|&p| truth.project(p).unwrap()).collect();
        for (k, p) in image.iter_mut().enumerate() {
            if k % 10 < 3 {
                *p += DVec2::new(0.01 * (k as f64).sin(), -0.012);
            }
        }
        let r = pnp_ransac(&points, &image, 1600.0, 7).expect("a pose");
        assert!(r.pose.rotation_error_deg(&truth) < 1e-6, "{}", r.pose.rotation_error_deg(&truth));
        assert!(r.pose.translation_direction_error_deg(&truth) < 1e-4);
        assert_eq!(r.inliers, 42);
        // Too few correspondences: no pose.
        assert!(pnp_ransac(&points[..5], &image[..5], 1600.0, 7).is_none());
    }

    /// The truth from two camera poses: a point seen from both maps by it.
    #[test]
    fn relative_pose_between_two_cameras_maps_points() {
        let r1 = DMat3::from_quat(DQuat::from_scaled_axis(DVec3::new(0.2, 0.1, -0.3)));
        let r2 = DMat3::from_quat(DQuat::from_scaled_axis(DVec3::new(0.25, 0.05, -0.2)));
        let (p1, p2) = (DVec3::new(1.0, -6.0, 0.5), DVec3::new(1.3, -5.8, 0.4));
        let x_target = DVec3::new(0.1, 0.2, -0.05);
        let (x1, x2) = (r1.transpose() * (x_target - p1), r2.transpose() * (x_target - p2));
        let rel = RelativePose::between(r1, p1, r2, p2);
        assert!((rel.rotation * x1 + rel.translation - x2).length() < 1e-12);
        assert_eq!(rel.rotation_error_deg(&rel), 0.0);
    }
}
