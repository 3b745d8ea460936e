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

use crate::filter::PoseMeasurement;
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DVector, Dyn, Matrix3, Matrix6, Owned, U6, Vector6};
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

    /// The normalised image coordinates of `x` (camera-1 coordinates), `None` behind camera 2.
    pub fn project(&self, x: DVec3) -> Option<DVec2> {
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
    let (points, image) = (&points[..n], &image[..n]);
    let inliers_of = |pose: &RelativePose| inliers(pose, points, image, focal_px);
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

/// The inliers of `pose` among the correspondences: reprojection within
/// [`INLIER_THRESHOLD_PX`].
pub fn inliers(pose: &RelativePose, points: &[DVec3], image: &[DVec2], focal_px: f64) -> Vec<usize> {
    let threshold = INLIER_THRESHOLD_PX / focal_px;
    (0..points.len().min(image.len()))
        .filter(|&i| pose.project(points[i]).is_some_and(|p| (p - image[i]).length() <= threshold))
        .collect()
}

/// Floor of the reprojection noise assumed by [`refine`]'s covariance, px: tracks on noisy
/// frames drift by a few tenths of a pixel per frame and their errors are correlated (one
/// template, one model pose), so a small residual overstates the pose's accuracy.
pub const MIN_REPROJECTION_SD_PX: f64 = 1.0;

/// A pose refined by [`refine`], with its covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefinedPose {
    /// The pose minimising the reprojection error.
    pub pose: RelativePose,
    /// Covariance of `(ω, t)`, the left rotation perturbation (`R = exp(ω) R̂`, rad) and the
    /// translation (m): `σ² (JᵀJ)⁻¹` at the optimum.
    pub covariance: Matrix6<f64>,
    /// RMS reprojection error, px.
    pub rms_px: f64,
}

impl RefinedPose {
    /// The pose as the navigation filter takes it: the camera's attitude (camera → target)
    /// and position in the target frame, the covariance carried over to the filter's
    /// right-perturbation attitude error and position (first order).
    pub fn measurement(&self) -> PoseMeasurement {
        let r = DMat3::from_quat(self.pose.rotation);
        let t = self.pose.translation;
        let rt = Matrix3::from_column_slice(&r.transpose().to_cols_array());
        let tx = Matrix3::new(0.0, -t.z, t.y, t.z, 0.0, -t.x, -t.y, t.x, 0.0);
        // δθ = −ω, δp = −Rᵀ[t]ₓ ω − Rᵀ δt.
        let mut g = Matrix6::zeros();
        g.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-Matrix3::identity()));
        g.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-rt * tx));
        g.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-rt));
        PoseMeasurement {
            attitude: self.pose.rotation.inverse(),
            position: -(r.transpose() * t),
            covariance: g * self.covariance * g.transpose(),
        }
    }
}

/// The reprojection problem of [`refine`] for `levenberg-marquardt`: parameters `(ω, t)`,
/// residuals in pixels.
struct Reprojection<'a> {
    base: DQuat,
    params: Vector6<f64>,
    points: &'a [DVec3],
    image: &'a [DVec2],
    focal_px: f64,
}

impl Reprojection<'_> {
    fn pose(&self) -> RelativePose {
        let w = DVec3::new(self.params[0], self.params[1], self.params[2]);
        RelativePose {
            rotation: (DQuat::from_scaled_axis(w) * self.base).normalize(),
            translation: DVec3::new(self.params[3], self.params[4], self.params[5]),
        }
    }
}

impl LeastSquaresProblem<f64, Dyn, U6> for Reprojection<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, U6>;
    type ParameterStorage = Owned<f64, U6>;

    fn set_params(&mut self, x: &Vector6<f64>) {
        self.params = *x;
    }

    fn params(&self) -> Vector6<f64> {
        self.params
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let pose = self.pose();
        let mut r = DVector::zeros(2 * self.points.len());
        for (i, (&x, &u)) in self.points.iter().zip(self.image).enumerate() {
            let p = pose.project(x)?;
            r[2 * i] = (p.x - u.x) * self.focal_px;
            r[2 * i + 1] = (p.y - u.y) * self.focal_px;
        }
        Some(r)
    }

    fn jacobian(&self) -> Option<nalgebra::OMatrix<f64, Dyn, U6>> {
        let pose = self.pose();
        let mut j = nalgebra::OMatrix::<f64, Dyn, U6>::zeros(2 * self.points.len());
        for (i, &x) in self.points.iter().enumerate() {
            let rx = pose.rotation * x;
            let y = rx + pose.translation;
            if y.z <= 1e-9 {
                return None;
            }
            let f = self.focal_px;
            // d(u, v)/dy, then dy/dω = −[R x]ₓ, dy/dt = I.
            let du = [f / y.z, 0.0, -f * y.x / (y.z * y.z)];
            let dv = [0.0, f / y.z, -f * y.y / (y.z * y.z)];
            // Columns of −[R x]ₓ: d(exp(ω) R x)/dω = ω × (R x) = −(R x) × ω.
            let cols =
                [DVec3::new(0.0, -rx.z, rx.y), DVec3::new(rx.z, 0.0, -rx.x), DVec3::new(-rx.y, rx.x, 0.0)];
            for (k, c) in cols.iter().enumerate() {
                j[(2 * i, k)] = du[0] * c.x + du[1] * c.y + du[2] * c.z;
                j[(2 * i + 1, k)] = dv[0] * c.x + dv[1] * c.y + dv[2] * c.z;
            }
            for k in 0..3 {
                j[(2 * i, 3 + k)] = du[k];
                j[(2 * i + 1, 3 + k)] = dv[k];
            }
        }
        Some(j)
    }
}

/// Levenberg–Marquardt (`levenberg-marquardt`, MINPACK's algorithm) on the reprojection error
/// of the correspondences, started at `pose`, and the covariance of the result. `None` with
/// fewer than [`SAMPLE`] correspondences or when a point falls behind the camera.
pub fn refine(pose: &RelativePose, points: &[DVec3], image: &[DVec2], focal_px: f64) -> Option<RefinedPose> {
    let n = points.len().min(image.len());
    if n < SAMPLE {
        return None;
    }
    let t = pose.translation;
    let problem = Reprojection {
        base: pose.rotation,
        params: Vector6::new(0.0, 0.0, 0.0, t.x, t.y, t.z),
        points: &points[..n],
        image: &image[..n],
        focal_px,
    };
    let (problem, report) = LevenbergMarquardt::new().minimize(problem);
    if !report.termination.was_successful() && report.number_of_evaluations == 0 {
        return None;
    }
    let refined = problem.pose();
    let r = problem.residuals()?;
    let j = problem.jacobian()?;
    let dof = (2 * n).saturating_sub(6).max(1) as f64;
    let rss = r.norm_squared();
    let sigma2 = (rss / dof).max(MIN_REPROJECTION_SD_PX * MIN_REPROJECTION_SD_PX);
    let jtj: Matrix6<f64> = (j.transpose() * &j).fixed_view::<6, 6>(0, 0).into_owned();
    let covariance = jtj.try_inverse()? * sigma2;
    Some(RefinedPose { pose: refined, covariance, rms_px: (rss / n as f64).sqrt() })
}

/// The estimator every pose of the benchmark goes through, streams and oracle alike:
/// [`pnp_ransac`], then [`refine`] on its inliers (`None` in the second place when the
/// refinement fails or RANSAC found fewer than [`MIN_INLIERS`]).
pub fn estimate(
    points: &[DVec3],
    image: &[DVec2],
    focal_px: f64,
    seed: u64,
) -> Option<(PnpResult, Option<RefinedPose>)> {
    let found = pnp_ransac(points, image, focal_px, seed)?;
    if found.inliers < MIN_INLIERS {
        return Some((found, None));
    }
    let inl = inliers(&found.pose, points, image, focal_px);
    let (a, b): (Vec<DVec3>, Vec<DVec2>) = inl.iter().map(|&i| (points[i], image[i])).unzip();
    Some((found, refine(&found.pose, &a, &b, focal_px)))
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

    /// Levenberg–Marquardt on noisy reprojections: started 0.5° and 5 cm off, it lands on the
    /// truth within the noise, and its covariance is the spread of the estimates over noise
    /// draws (Monte Carlo, 200 draws: each axis' standard deviation within 25 % of the
    /// covariance's, the noise being 0.5 px as the covariance's floor assumes). The
    /// measurement carried to the filter's frame maps back to the camera pose.
    #[test]
    fn refinement_reaches_the_truth_and_its_covariance_is_the_spread() {
        let truth = RelativePose {
            rotation: DQuat::from_scaled_axis(DVec3::new(0.2, -0.1, 0.05)),
            translation: DVec3::new(0.1, -0.2, 8.0),
        };
        let points: Vec<DVec3> = (0..80)
            .map(|k| {
                let (a, b) = (f64::from(k % 10) * 0.15 - 0.7, f64::from(k / 10) * 0.15 - 0.5);
                DVec3::new(a, b, 0.3 * (a * 3.0).sin())
            })
            .collect();
        let f = 1600.0;
        let clean: Vec<DVec2> = points.iter().map(|&p| truth.project(p).unwrap()).collect();
        let start = RelativePose {
            rotation: truth.rotation * DQuat::from_rotation_y(0.5f64.to_radians()),
            translation: truth.translation + DVec3::new(0.05, 0.0, 0.0),
        };
        let mut rng = render_host::noise::SplitMix64::new(3);
        let mut omegas = Vec::new();
        let mut last = None;
        for _ in 0..200 {
            let noisy: Vec<DVec2> = clean
                .iter()
                .map(|&u| {
                    let n =
                        DVec2::new(crate::baseline::gaussian(&mut rng), crate::baseline::gaussian(&mut rng));
                    u + n * (MIN_REPROJECTION_SD_PX / f)
                })
                .collect();
            let r = refine(&start, &points, &noisy, f).expect("refined");
            assert!(r.pose.rotation_error_deg(&truth) < 1.0, "{}", r.pose.rotation_error_deg(&truth));
            omegas.push(crate::filter::rotation_vector(r.pose.rotation * truth.rotation.inverse()));
            last = Some(r);
        }
        let r = last.unwrap();
        for axis in 0..3 {
            let v: Vec<f64> = omegas.iter().map(|w| w.to_array()[axis]).collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
            let predicted = r.covariance[(axis, axis)].sqrt();
            assert!((sd / predicted - 1.0).abs() < 0.25, "axis {axis}: spread {sd}, covariance {predicted}");
        }
        let m = r.measurement();
        let back = RelativePose {
            rotation: m.attitude.inverse(),
            translation: -(m.attitude.inverse() * m.position),
        };
        assert!(
            back.rotation_error_deg(&r.pose) < 1e-9
                && (back.translation - r.pose.translation).length() < 1e-9
        );
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
