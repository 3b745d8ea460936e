//! The navigation filter over a sequence: a multiplicative extended Kalman filter (MEKF) on the
//! relative pose of the chaser's camera and the target, fed by pose measurements (the model
//! edges' fit, the oracle's PnP poses) and relative-position measurements (the outline).
//!
//! **State.** The camera attitude `q` (camera → target, a unit quaternion) and its angular rate
//! `ω` in the camera frame; the target's reference point (the model's centre, the point the
//! chaser keeps in view) in the camera frame, `t`, and its velocity `u` in that frame. The
//! camera's position in the target frame follows: `p = c − R(q) t`. The error state is
//! 12-dimensional: `δθ` (the attitude error as a right, camera-frame rotation vector,
//! `q_true = q ⊗ exp(δθ)`), `δω`, `δt`, `δu` (Markley 2003; Markley & Crassidis,
//! *Fundamentals of Spacecraft Attitude Determination and Control*, § 6.2).
//!
//! **Model.** Constant rate and constant velocity between frames, driven by white angular and
//! linear acceleration of spectral densities [`FilterParams::angular_accel`] and
//! [`FilterParams::linear_accel_per_m`] (the latter in proportion to the range; the
//! discretised "nearly constant velocity" model, each axis `Q = q [[dt³/3, dt²/2], [dt²/2,
//! dt]]`). A tumbling target seen from a chaser on a fly-around is close to that: the relative
//! rate is constant to a fraction of a degree per second. The
//! translation is carried in the camera frame because the chaser points its camera at the
//! target: there the target's centre moves only with the range (a fly-around keeps it still,
//! an approach closes along the boresight), while the camera's position in the target frame
//! turns with the relative attitude (a circle on a fly-around), which a constant velocity
//! cannot follow through a coast (an eclipse, a lost track).
//!
//! **Measurement.** A pose `(q_m, p_m)` with its 6 × 6 covariance (attitude then position in
//! the target frame) from [`crate::pose::refine`] or [`crate::edges::fit`]; the innovation is
//! `(log(q⁻¹ ⊗ q_m), p_m − p)`, linearised as `δp = R [t]× δθ − R δt`. A measurement
//! whose squared Mahalanobis distance exceeds [`FilterParams::gate`] (χ²₆ at 99.9 % by
//! default) is refused and the filter coasts; after [`FilterParams::reacquire_after`] refusals
//! in a row the filter restarts on the next measurement (rates kept, covariance reset), the
//! on-board answer to a lost track. Updates use the Joseph form.
//!
//! Written here: no maintained crate offers an MEKF; the linear algebra is `nalgebra`'s.

use nalgebra::{Matrix3, Matrix6, SMatrix, SVector, Vector3, Vector6};
use render_host::glam::{DQuat, DVec3};

/// The 12 × 12 error-state covariance.
pub type Cov12 = SMatrix<f64, 12, 12>;

/// Tuning of the filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterParams {
    /// Spectral density of the angular acceleration, (rad/s²)²·s.
    pub angular_accel: f64,
    /// Spectral density of the linear acceleration per metre of range, (1/s²)²·s: the density is
    /// `(linear_accel_per_m · |t|)²`. A chaser steers its approach by range (the closing speed
    /// in proportion to the range, a constant time to go), so the relative velocity changes in
    /// proportion to the range too.
    pub linear_accel_per_m: f64,
    /// Largest squared Mahalanobis distance of an accepted measurement (6 degrees of freedom).
    pub gate: f64,
    /// Refused measurements in a row after which the filter restarts on the next one.
    pub reacquire_after: usize,
    /// 1σ of the initial angular rate, rad/s.
    pub initial_rate_sd: f64,
    /// 1σ of the initial velocity, m/s.
    pub initial_velocity_sd: f64,
    /// 1σ of a restart's angular rate (a difference of two measurements), rad/s.
    pub restart_rate_sd: f64,
    /// 1σ of a restart's velocity, m/s.
    pub restart_velocity_sd: f64,
}

impl Default for FilterParams {
    fn default() -> Self {
        FilterParams {
            // A rate that changes by ≈ 0.1°/s over 10 s; a velocity changing by 0.25 % of the
            // range per s² (the approach's, closing from 50 m to 5 m at a constant time to go,
            // by 0.04 %).
            angular_accel: (0.02f64.to_radians()).powi(2),
            linear_accel_per_m: 0.0025f64.powi(2),
            gate: 22.46,
            reacquire_after: 3,
            initial_rate_sd: 5f64.to_radians(),
            initial_velocity_sd: 2.0,
            restart_rate_sd: 2f64.to_radians(),
            restart_velocity_sd: 0.5,
        }
    }
}

/// A pose measurement: camera attitude (camera → target) and position in the target frame,
/// with the covariance of `(δθ, δp)` (δθ a right, camera-frame rotation vector).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseMeasurement {
    /// Camera → target rotation.
    pub attitude: DQuat,
    /// Camera position in the target frame, m.
    pub position: DVec3,
    /// Covariance of the attitude (rad²) and position (m²) errors.
    pub covariance: Matrix6<f64>,
}

/// What the filter did with a measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdateOutcome {
    /// Used.
    Accepted,
    /// Outside the gate: the filter coasts.
    Refused,
    /// The filter restarted on it after a run of refusals.
    Restarted,
}

/// The MEKF.
#[derive(Clone, Debug)]
pub struct PoseFilter {
    /// Camera → target attitude.
    pub attitude: DQuat,
    /// Angular rate in the camera frame, rad/s.
    pub rate: DVec3,
    /// The target's reference point in the camera frame, m.
    pub target: DVec3,
    /// Its velocity in the camera frame, m/s.
    pub target_velocity: DVec3,
    /// Error-state covariance, order `(δθ, δω, δt, δu)`.
    pub covariance: Cov12,
    /// The target's reference point in the target frame, m.
    centre: DVec3,
    params: FilterParams,
    refused_in_a_row: usize,
    /// Time since the start, s (the sum of the predictions).
    time: f64,
    /// The last measurement offered (accepted or not) and its time: a restart takes its rate
    /// and velocity from it.
    last_offered: Option<(f64, PoseMeasurement)>,
}

fn v3(v: DVec3) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

fn d3(v: &Vector3<f64>) -> DVec3 {
    DVec3::new(v.x, v.y, v.z)
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The rotation vector of a unit quaternion (the shorter way round).
pub fn rotation_vector(q: DQuat) -> DVec3 {
    let q = if q.w < 0.0 { -q } else { q };
    let s = DVec3::new(q.x, q.y, q.z);
    let n = s.length();
    if n < 1e-12 {
        return 2.0 * s;
    }
    s * (2.0 * n.atan2(q.w) / n)
}

/// The target's reference point `centre` (target frame) as the camera at `attitude` (camera →
/// target) and `position` (target frame) sees it: in the camera's frame, m.
pub fn relative_position(attitude: DQuat, position: DVec3, centre: DVec3) -> DVec3 {
    attitude.inverse() * (centre - position)
}

/// `(δθ, δp) ↦ (δθ, δt)` at attitude `r` (camera → target) and target point `t` (camera frame):
/// `δt = [t]× δθ − Rᵀ δp`, the inverse of [`PoseFilter::pose_jacobian`]'s pose block.
fn to_target_errors(r: &Matrix3<f64>, t: &Vector3<f64>) -> Matrix6<f64> {
    let mut k = Matrix6::identity();
    k.fixed_view_mut::<3, 3>(3, 0).copy_from(&skew(t));
    k.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-r.transpose()));
    k
}

fn rotation_matrix(q: DQuat) -> Matrix3<f64> {
    let m = render_host::glam::DMat3::from_quat(q);
    Matrix3::from_column_slice(&m.to_cols_array())
}

impl PoseFilter {
    /// A filter started on a pose (camera → target attitude, camera position in the target
    /// frame) with the given 1σ attitude (rad) and position (m) errors; `centre` is the target's
    /// reference point (target frame) whose position in the camera frame the filter carries.
    /// Rate and velocity start at zero with [`FilterParams`]' initial spreads.
    pub fn new(
        attitude: DQuat,
        position: DVec3,
        centre: DVec3,
        (att_sd, pos_sd): (f64, f64),
        params: FilterParams,
    ) -> PoseFilter {
        let attitude = attitude.normalize();
        let target = relative_position(attitude, position, centre);
        let mut pose = Matrix6::zeros();
        for i in 0..3 {
            pose[(i, i)] = att_sd * att_sd;
            pose[(3 + i, 3 + i)] = pos_sd * pos_sd;
        }
        let mut p = Cov12::zeros();
        Self::set_pose_block(&mut p, attitude, target, &pose);
        for i in 0..3 {
            p[(3 + i, 3 + i)] = params.initial_rate_sd.powi(2);
            p[(9 + i, 9 + i)] = params.initial_velocity_sd.powi(2);
        }
        PoseFilter {
            attitude,
            rate: DVec3::ZERO,
            target,
            target_velocity: DVec3::ZERO,
            covariance: p,
            centre,
            params,
            refused_in_a_row: 0,
            time: 0.0,
            last_offered: None,
        }
    }

    /// Writes `pose`, a covariance of the pose errors `(δθ, δp)` at `attitude` and `target`, into
    /// the `(δθ, δt)` blocks of `p` ([`to_target_errors`]).
    fn set_pose_block(p: &mut Cov12, attitude: DQuat, target: DVec3, pose: &Matrix6<f64>) {
        let k = to_target_errors(&rotation_matrix(attitude), &v3(target));
        let m = k * pose * k.transpose();
        const IDX: [usize; 6] = [0, 1, 2, 6, 7, 8];
        for (r, &i) in IDX.iter().enumerate() {
            for (c, &j) in IDX.iter().enumerate() {
                p[(i, j)] = m[(r, c)];
            }
        }
    }

    /// The camera's position in the target frame, m.
    pub fn position(&self) -> DVec3 {
        self.centre - self.attitude * self.target
    }

    /// Propagates the state and covariance by `dt` seconds.
    pub fn predict(&mut self, dt: f64) {
        let w = v3(self.rate);
        let mut f = Cov12::identity();
        // δθ' = exp(−ω dt) δθ + dt δω (first order in ω dt).
        let rot = Matrix3::identity() - skew(&(w * dt));
        f.fixed_view_mut::<3, 3>(0, 0).copy_from(&rot);
        f.fixed_view_mut::<3, 3>(0, 3).copy_from(&(Matrix3::identity() * dt));
        f.fixed_view_mut::<3, 3>(6, 9).copy_from(&(Matrix3::identity() * dt));
        let mut q = Cov12::zeros();
        let linear = self.params.linear_accel_per_m * self.target.length_squared();
        for (base, density) in [(0usize, self.params.angular_accel), (6, linear)] {
            for i in 0..3 {
                q[(base + i, base + i)] = density * dt.powi(3) / 3.0;
                q[(base + i, base + 3 + i)] = density * dt.powi(2) / 2.0;
                q[(base + 3 + i, base + i)] = density * dt.powi(2) / 2.0;
                q[(base + 3 + i, base + 3 + i)] = density * dt;
            }
        }
        self.covariance = f * self.covariance * f.transpose() + q;
        self.attitude = (self.attitude * DQuat::from_scaled_axis(self.rate * dt)).normalize();
        self.target += self.target_velocity * dt;
        self.time += dt;
    }

    /// The Jacobian of the pose errors `(δθ, δp)` (δp of the camera position in the target
    /// frame) with respect to the error state: `δθ = δθ`, `δp = R [t]× δθ − R δt`.
    fn pose_jacobian(&self) -> SMatrix<f64, 6, 12> {
        let r = rotation_matrix(self.attitude);
        let mut g = SMatrix::<f64, 6, 12>::zeros();
        g.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
        g.fixed_view_mut::<3, 3>(3, 0).copy_from(&(r * skew(&v3(self.target))));
        g.fixed_view_mut::<3, 3>(3, 6).copy_from(&(-r));
        g
    }

    /// The 6 × 6 covariance of the pose errors `(δθ, δp)` (δp of the camera position in the
    /// target frame).
    pub fn pose_covariance(&self) -> Matrix6<f64> {
        let g = self.pose_jacobian();
        g * self.covariance * g.transpose()
    }

    /// The innovation of a measurement, its covariance and the measurement Jacobian.
    fn innovation(&self, m: &PoseMeasurement) -> (Vector6<f64>, Matrix6<f64>, SMatrix<f64, 6, 12>) {
        let dq = rotation_vector(self.attitude.inverse() * m.attitude);
        let dp = m.position - self.position();
        let y = Vector6::new(dq.x, dq.y, dq.z, dp.x, dp.y, dp.z);
        let h = self.pose_jacobian();
        (y, h * self.covariance * h.transpose() + m.covariance, h)
    }

    /// The squared Mahalanobis distance of a measurement from the prediction (∞ when the
    /// innovation covariance is singular).
    pub fn mahalanobis2(&self, m: &PoseMeasurement) -> f64 {
        let (y, s, _) = self.innovation(m);
        s.try_inverse().map_or(f64::INFINITY, |si| (y.transpose() * si * y)[(0, 0)])
    }

    /// Uses a measurement when it lies inside the gate ([`FilterParams::gate`]), without the
    /// restart bookkeeping of [`Self::update`]: for a cue that may fail on its own (e.g.
    /// [`crate::edges::fit`]) and must never restart the filter. Whether it was used.
    pub fn update_if_consistent(&mut self, m: &PoseMeasurement) -> bool {
        let d2 = self.mahalanobis2(m);
        if d2.is_nan() || d2 > self.params.gate {
            return false;
        }
        self.apply(m)
    }

    /// Uses a measurement (after [`Self::predict`] to its time).
    pub fn update(&mut self, m: &PoseMeasurement) -> UpdateOutcome {
        let previous = self.last_offered.replace((self.time, *m));
        let d2 = self.mahalanobis2(m);
        // A NaN distance (a singular innovation) is refused too.
        if d2.is_nan() || d2 > self.params.gate {
            self.refused_in_a_row += 1;
            if self.refused_in_a_row > self.params.reacquire_after {
                self.restart(m, previous);
                return UpdateOutcome::Restarted;
            }
            return UpdateOutcome::Refused;
        }
        self.refused_in_a_row = 0;
        if self.apply(m) { UpdateOutcome::Accepted } else { UpdateOutcome::Refused }
    }

    /// The Kalman correction by a pose measurement already past the gate; `false` (nothing
    /// changed) when the innovation covariance is singular.
    fn apply(&mut self, m: &PoseMeasurement) -> bool {
        let (y, s, h) = self.innovation(m);
        let Some(si) = s.try_inverse() else { return false };
        self.correct(&h, &y, &m.covariance, &si);
        true
    }

    /// The Kalman correction for a measurement `y = H δx + v` (`r` its noise covariance, `si`
    /// the inverse innovation covariance): the Joseph-form covariance update, then the error
    /// state injected into the attitude (multiplicatively), rate, target point and velocity.
    fn correct<const M: usize>(
        &mut self,
        h: &SMatrix<f64, M, 12>,
        y: &SVector<f64, M>,
        r: &SMatrix<f64, M, M>,
        si: &SMatrix<f64, M, M>,
    ) {
        let k = self.covariance * h.transpose() * si;
        let dx: SVector<f64, 12> = k * y;
        let ikh = Cov12::identity() - k * h;
        self.covariance = ikh * self.covariance * ikh.transpose() + k * r * k.transpose();
        self.covariance = 0.5 * (self.covariance + self.covariance.transpose());
        let dtheta = d3(&dx.fixed_rows::<3>(0).into_owned());
        self.attitude = (self.attitude * DQuat::from_scaled_axis(dtheta)).normalize();
        self.rate += d3(&dx.fixed_rows::<3>(3).into_owned());
        self.target += d3(&dx.fixed_rows::<3>(6).into_owned());
        self.target_velocity += d3(&dx.fixed_rows::<3>(9).into_owned());
    }

    /// Uses a measurement `t` of the relative position alone (the target's reference point in
    /// the camera frame, m; e.g. from its outline, [`crate::silhouette`]) with covariance `r`
    /// (camera frame; after [`Self::predict`] to its time); refused outside χ²₃ at 99.9 %
    /// (16.27). Whether it was used.
    pub fn update_relative(&mut self, t: DVec3, r: &Matrix3<f64>) -> bool {
        let y = v3(t - self.target);
        let mut h = SMatrix::<f64, 3, 12>::zeros();
        h.fixed_view_mut::<3, 3>(0, 6).copy_from(&Matrix3::identity());
        let s = h * self.covariance * h.transpose() + r;
        let Some(si) = s.try_inverse() else { return false };
        if (y.transpose() * si * y)[(0, 0)] > 16.27 {
            return false;
        }
        self.correct(&h, &y, r, &si);
        true
    }

    /// Restarts on a measurement: its pose and covariance; the rate and velocity from the
    /// difference with the measurement offered before it (kept as they were without one), with
    /// the restart spreads.
    fn restart(&mut self, m: &PoseMeasurement, previous: Option<(f64, PoseMeasurement)>) {
        self.refused_in_a_row = 0;
        let target = relative_position(m.attitude, m.position, self.centre);
        if let Some((t0, p)) = previous
            && self.time - t0 > 1e-9
        {
            let dt = self.time - t0;
            self.rate = rotation_vector(p.attitude.inverse() * m.attitude) / dt;
            self.target_velocity = (target - relative_position(p.attitude, p.position, self.centre)) / dt;
        }
        self.attitude = m.attitude.normalize();
        self.target = target;
        let mut p = Cov12::zeros();
        Self::set_pose_block(&mut p, self.attitude, target, &m.covariance);
        for i in 0..3 {
            p[(3 + i, 3 + i)] = self.params.restart_rate_sd.powi(2);
            p[(9 + i, 9 + i)] = self.params.restart_velocity_sd.powi(2);
        }
        self.covariance = p;
    }

    /// The pose error against the truth: attitude error vector (rad, camera frame, `q_true = q ⊗
    /// exp(e)`) and position error (m, `p_true − p`, the camera in the target frame).
    pub fn error(&self, true_attitude: DQuat, true_position: DVec3) -> (DVec3, DVec3) {
        (rotation_vector(self.attitude.inverse() * true_attitude), true_position - self.position())
    }

    /// Normalised estimation error squared of the pose part: `eᵀ P⁻¹ e` for `e = (δθ, δp)`;
    /// its mean over a consistent filter's runs is 6.
    pub fn nees(&self, true_attitude: DQuat, true_position: DVec3) -> f64 {
        let (a, p) = self.error(true_attitude, true_position);
        let e = Vector6::new(a.x, a.y, a.z, p.x, p.y, p.z);
        self.pose_covariance().try_inverse().map_or(f64::INFINITY, |pi| (e.transpose() * pi * e)[(0, 0)])
    }

    /// 3σ of the attitude error (rad, the largest axis) and of the position error (m, the
    /// camera in the target frame, the largest axis).
    pub fn three_sigma(&self) -> (f64, f64) {
        let c = self.pose_covariance();
        let att = (0..3).map(|i| c[(i, i)]).fold(0.0f64, f64::max).sqrt();
        let pos = (3..6).map(|i| c[(i, i)]).fold(0.0f64, f64::max).sqrt();
        (3.0 * att, 3.0 * pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use render_host::noise::SplitMix64;

    /// The target's reference point, target frame, m.
    const CENTRE: DVec3 = DVec3::new(0.1, -0.2, 0.3);

    /// Truth: a camera turning at a constant rate, the target's centre moving at a constant
    /// velocity in the camera frame (closing from 8 m); the camera pose (attitude, position in
    /// the target frame).
    fn truth(t: f64) -> (DQuat, DVec3) {
        let w = DVec3::new(0.01, -0.02, 0.015);
        let q0 = DQuat::from_scaled_axis(DVec3::new(0.3, -0.2, 1.0));
        let q = q0 * DQuat::from_scaled_axis(w * t);
        let seen = DVec3::new(0.2, -0.1, 8.0) + DVec3::new(0.01, -0.02, -0.03) * t;
        (q, CENTRE - q * seen)
    }

    fn gauss(rng: &mut SplitMix64) -> f64 {
        // Box–Muller from two uniforms in (0, 1].
        let u1 = ((rng.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64;
        let u2 = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// Noisy pose measurements of a constant-rate motion: the filter converges below the
    /// measurement noise and its NEES averages near 6 (a consistent filter), its 3σ bounds
    /// hold the error on ≥ 95 % of the frames.
    #[test]
    fn converges_and_is_consistent_on_constant_rate_motion() {
        let (att_sd, pos_sd) = (0.3f64.to_radians(), 0.03);
        let mut rng = SplitMix64::new(11);
        let (q0, p0) = truth(0.0);
        let mut f = PoseFilter::new(
            q0 * DQuat::from_scaled_axis(DVec3::new(0.01, 0.0, -0.01)),
            p0 + DVec3::new(0.05, 0.0, 0.0),
            CENTRE,
            (1f64.to_radians(), 0.1),
            FilterParams::default(),
        );
        let mut nees = Vec::new();
        let mut inside = 0;
        let mut late_sq = Vec::new();
        for k in 1..=200 {
            let t = f64::from(k);
            f.predict(1.0);
            let (qt, pt) = truth(t);
            let na = DVec3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng)) * att_sd;
            let np = DVec3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng)) * pos_sd;
            let mut cov = Matrix6::zeros();
            for i in 0..3 {
                cov[(i, i)] = att_sd * att_sd;
                cov[(3 + i, 3 + i)] = pos_sd * pos_sd;
            }
            let m = PoseMeasurement {
                attitude: qt * DQuat::from_scaled_axis(na),
                position: pt + np,
                covariance: cov,
            };
            assert_ne!(f.update(&m), UpdateOutcome::Restarted, "frame {k}");
            let (ea, ep) = f.error(qt, pt);
            let (a3, p3) = f.three_sigma();
            if k > 20 {
                nees.push(f.nees(qt, pt));
                let ok = [ea.x, ea.y, ea.z].iter().all(|e| e.abs() <= a3)
                    && [ep.x, ep.y, ep.z].iter().all(|e| e.abs() <= p3);
                inside += usize::from(ok);
            }
            if k > 100 {
                late_sq.push(ea.length_squared());
            }
        }
        let late_rms = (late_sq.iter().sum::<f64>() / late_sq.len() as f64).sqrt();
        let mean = nees.iter().sum::<f64>() / nees.len() as f64;
        assert!((3.0..10.0).contains(&mean), "mean NEES {mean}");
        assert!(inside * 100 >= nees.len() * 95, "{inside} of {} inside 3σ", nees.len());
        assert!(late_rms < att_sd, "attitude RMS over the last 100 frames {}°", late_rms.to_degrees());
        // The rate was learned.
        let w = DVec3::new(0.01, -0.02, 0.015);
        assert!((f.rate - w).length() < 0.002, "{:?}", f.rate);
    }

    /// A measurement far outside the gate is refused; a run of them restarts the filter on
    /// the next one.
    #[test]
    fn gates_outliers_and_restarts_after_a_run_of_them() {
        let (q0, p0) = truth(0.0);
        let params = FilterParams { initial_rate_sd: 0.1f64.to_radians(), ..FilterParams::default() };
        let mut f = PoseFilter::new(q0, p0, CENTRE, (0.5f64.to_radians(), 0.05), params);
        let cov = Matrix6::identity() * 1e-6;
        let wrong =
            PoseMeasurement { attitude: q0 * DQuat::from_rotation_x(0.5), position: p0, covariance: cov };
        for _ in 0..3 {
            f.predict(1.0);
            assert_eq!(f.update(&wrong), UpdateOutcome::Refused);
        }
        f.predict(1.0);
        assert_eq!(f.update(&wrong), UpdateOutcome::Restarted);
        assert!(f.error(wrong.attitude, p0).0.length() < 1e-12);
    }

    /// A cue that may fail on its own never restarts the filter: any number of wrong poses are
    /// refused and the estimate stays; a pose inside the gate is used, exactly as by `update`.
    #[test]
    fn update_if_consistent_refuses_without_restarting() {
        let (q0, p0) = truth(0.0);
        let params = FilterParams { initial_rate_sd: 0.1f64.to_radians(), ..FilterParams::default() };
        let mut f = PoseFilter::new(q0, p0, CENTRE, (0.5f64.to_radians(), 0.05), params);
        let cov = Matrix6::identity() * 1e-6;
        let wrong =
            PoseMeasurement { attitude: q0 * DQuat::from_rotation_x(0.5), position: p0, covariance: cov };
        for _ in 0..10 {
            f.predict(1.0);
            assert!(!f.update_if_consistent(&wrong));
        }
        assert!(f.error(q0, p0).0.length() < 0.1, "the wrong pose moved the estimate");
        let (q1, p1) = truth(10.0);
        let near = PoseMeasurement { attitude: f.attitude, position: f.position(), covariance: cov * 1e4 };
        let mut g = f.clone();
        assert!(f.update_if_consistent(&near));
        assert_eq!(g.update(&near), UpdateOutcome::Accepted);
        assert!(f.error(q1, p1) == g.error(q1, p1), "the same update as `update`");
    }

    /// A camera 8 m from the target's centre, looking at it; the same camera turned by 1° about
    /// the centre (its attitude turned, its position carried round the centre): the position
    /// moves by 2 · 8 m · sin(0.5°) = 13.96 cm (1.75 % of the range) while the target's centre
    /// stays where it was in the camera's frame. A camera moved 10 cm sideways moves the
    /// relative position by the same 10 cm.
    #[test]
    fn relative_position_ignores_a_turn_about_the_centre() {
        let centre = DVec3::new(0.1, -0.2, 0.3);
        // Camera axes (columns, target frame): looking along +x from 8 m in front.
        let q = DQuat::from_mat3(&render_host::glam::DMat3::from_cols(DVec3::Y, DVec3::Z, DVec3::X));
        let p = centre - DVec3::X * 8.0;
        assert!((relative_position(q, p, centre) - DVec3::new(0.0, 0.0, 8.0)).length() < 1e-12);
        let turn = DQuat::from_scaled_axis(DVec3::X * 1f64.to_radians());
        let q2 = q * turn;
        let p2 = centre - render_host::glam::DMat3::from_quat(q2) * DVec3::new(0.0, 0.0, 8.0);
        let moved = (p2 - p).length();
        assert!((moved - 2.0 * 8.0 * 0.5f64.to_radians().sin()).abs() < 1e-12, "{moved}");
        assert!((relative_position(q2, p2, centre) - relative_position(q, p, centre)).length() < 1e-12);
        let side = relative_position(q, p + DVec3::Y * 0.1, centre) - relative_position(q, p, centre);
        assert!((side.length() - 0.1).abs() < 1e-12);
    }

    /// A fly-around: the camera circles the target at 8 m and 2.5° per second about a fixed
    /// axis, pointing at its centre. After 30 s of measurements the filter coasts for 40 s (an
    /// eclipse, a lost track): the relative attitude turns at the rate it learned and the
    /// centre stays where it is in the camera frame, so the coasted pose is still within 1°
    /// and 2 % of the range (navigation still available; inside the filter's 3σ), where the
    /// camera's position in the target frame has swung through 100° of arc (its last velocity
    /// in that frame, carried on, leaves it metres off). The process noise is a tenth of the default's, so that what is
    /// tested is the model, not the tuning (with the default's the learned rate and velocity
    /// are looser and so is the coast, by as much as its 3σ says).
    #[test]
    fn coasts_through_a_fly_around() {
        let axis = DVec3::new(0.2, 1.0, 0.3).normalize();
        let rate = 2.5f64.to_radians();
        // Camera axes at t = 0: looking along +x (target frame) from 8 m, image x along y.
        let q0 = DQuat::from_mat3(&render_host::glam::DMat3::from_cols(DVec3::Y, DVec3::Z, DVec3::X));
        let pose = |t: f64| {
            let turn = DQuat::from_scaled_axis(axis * rate * t);
            let q = turn * q0;
            (q, CENTRE - q * DVec3::new(0.0, 0.0, 8.0))
        };
        let (qs, ps) = pose(0.0);
        let params = FilterParams {
            angular_accel: 0.002f64.to_radians().powi(2),
            linear_accel_per_m: 0.00025f64.powi(2),
            ..FilterParams::default()
        };
        let mut f = PoseFilter::new(qs, ps, CENTRE, (0.5f64.to_radians(), 0.08), params);
        let mut cov = Matrix6::identity() * 0.2f64.to_radians().powi(2);
        for i in 3..6 {
            cov[(i, i)] = 0.02f64.powi(2);
        }
        let mut rng = SplitMix64::new(3);
        for k in 1..=30 {
            f.predict(1.0);
            let (q, p) = pose(f64::from(k));
            let na = DVec3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng)) * 0.2f64.to_radians();
            let np = DVec3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng)) * 0.02;
            let m = PoseMeasurement {
                attitude: q * DQuat::from_scaled_axis(na),
                position: p + np,
                covariance: cov,
            };
            assert_eq!(f.update(&m), UpdateOutcome::Accepted, "frame {k}");
        }
        for _ in 0..40 {
            f.predict(1.0);
        }
        let (q, p) = pose(70.0);
        let (ea, ep) = f.error(q, p);
        let (a3, p3) = f.three_sigma();
        assert!(ea.length() < a3 && ep.length() < p3, "outside 3σ: {ea:?} {ep:?}");
        assert!(ea.length().to_degrees() < 1.0, "attitude {}°", ea.length().to_degrees());
        assert!(ep.length() < 0.16, "position {} m", ep.length());
        // The camera's last velocity in the target frame, carried on for 40 s, misses by metres.
        let straight = pose(30.0).1 + (pose(30.0).1 - pose(29.0).1) * 40.0;
        assert!((straight - p).length() > 3.0, "{}", (straight - p).length());
    }

    #[test]
    fn rotation_vector_inverts_from_scaled_axis() {
        for v in [DVec3::new(0.1, -0.2, 0.3), DVec3::new(1e-9, 0.0, 0.0), DVec3::new(0.0, 3.0, 0.0)] {
            assert!((rotation_vector(DQuat::from_scaled_axis(v)) - v).length() < 1e-9, "{v:?}");
        }
    }
}
