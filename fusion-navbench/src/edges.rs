//! The model's edges: an absolute pose cue (moving edges, after Harris's RAPiD and the
//! edge trackers flown for proximity operations).
//!
//! The tracked corners of [`crate::tracker`] get their 3D points from the model at the
//! *estimate*, so they measure motion, not pose: an error of the estimate stays in every later
//! measurement. The model's sharp edges tie the image to the model itself. At the predicted
//! pose each visible crease of the model (two faces meeting at more than
//! [`MIN_CREASE_DEG`], or a mesh boundary) is sampled every [`SAMPLE_SPACING_PX`]; from each
//! sample the image is searched along the edge's normal for the nearest strong intensity step
//! ([`search`]); the pose that puts the samples on their steps is found by Gauss–Newton over
//! six degrees of freedom with Tukey weights, searched again and refitted as the pose
//! converges, and handed to the filter as a pose measurement with its covariance.
//!
//! Written here: no maintained Rust crate tracks a model's edges (ViSP's moving edges are C++).

use crate::filter::PoseMeasurement;
use crate::model::{TargetModel, camera_at};
use crate::region::Region;
use image::GrayImage;
use nalgebra::{Matrix6, Vector6};
use render_host::glam::{DMat3, DQuat, DVec2, DVec3};
use render_host::{Camera, Scene};
use std::collections::HashMap;

/// Two faces meeting at more than this angle between their normals make a crease the
/// tracker looks for, degrees (a box's edges, 90°; not the 60° facets of a rod).
pub const MIN_CREASE_DEG: f64 = 70.0;
/// Spacing of the samples along a projected edge, px.
pub const SAMPLE_SPACING_PX: f64 = 5.0;
/// Samples closer than this to the image border are dropped, px (beyond the search range).
pub const BORDER_PX: f64 = 2.0;
/// Smallest intensity step (grey levels per pixel, on the smoothed image) taken as an edge.
pub const MIN_STEP: f64 = 2.0;
/// The edges are fitted only when the model's bounding sphere is predicted at least this wide,
/// px: on a smaller image its creases are too few and too close to fix an attitude.
pub const MIN_TARGET_PX: u32 = 96;
/// A step counts as the crease's when it is at least this share of the strongest step in the
/// search range; of those, the nearest to the prediction is taken.
pub const STRONG_FRACTION: f64 = 0.5;
/// Smallest number of samples with an edge found for a fit.
pub const MIN_SAMPLES: usize = 24;
/// Tukey's constant in units of the residuals' robust σ.
pub const TUKEY_C: f64 = 4.685;
/// Floor of the robust σ of the residuals, px.
pub const SIGMA_FLOOR_PX: f64 = 0.5;
/// The search ranges of the rounds (px, each at least [`MIN_RANGE_PX`]): the first from the
/// prediction's 3σ, clamped to [`MAX_RANGE_PX`].
pub const MIN_RANGE_PX: f64 = 4.0;
/// Largest search range, px.
pub const MAX_RANGE_PX: f64 = 40.0;
/// Search-and-fit rounds.
pub const ROUNDS: usize = 3;
/// Gauss–Newton iterations per round.
pub const ITERATIONS: usize = 6;
/// The fit's residual variance is the residuals' robust σ² times this: the samples of one
/// crease share their errors (blur, texture beside the crease), so they are not independent.
pub const INFLATION: f64 = 4.0;
/// Added to the fit's attitude variance: its error between frames is not white (the same
/// creases, the same blur), ° (1σ).
pub const FLOOR_ATT_DEG: f64 = 0.5;
/// Added to its position variance, share of the range (1σ).
pub const FLOOR_POS_FRAC: f64 = 0.01;

/// One crease of the model: a segment between two 3D points (target frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crease {
    /// One end, m.
    pub a: DVec3,
    /// The other end, m.
    pub b: DVec3,
}

/// The model's creases.
#[derive(Clone, Debug)]
pub struct ModelEdges {
    creases: Vec<Crease>,
}

/// A crease sampled at a pose: its 3D point, where it projects and the unit normal of its
/// projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeSample {
    /// The point, target frame, m.
    pub point: DVec3,
    /// Its projection (continuous image coordinates), px.
    pub image: DVec2,
    /// Unit normal of the projected crease at the point.
    pub normal: DVec2,
}

/// A pose fitted to the edges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeFit {
    /// The pose and its covariance, the filter's convention.
    pub measurement: PoseMeasurement,
    /// Samples with an edge found in the last round.
    pub found: usize,
    /// Of them, inliers (non-zero Tukey weight).
    pub inliers: usize,
    /// Robust σ of the last round's residuals, px.
    pub sigma_px: f64,
}

/// A mesh edge's ends, quantised to 10 µm and ordered: the same for both triangles sharing it.
type EdgeKey = ([i64; 3], [i64; 3]);

fn key(v: DVec3) -> [i64; 3] {
    let q = |x: f64| (x * 1e5).round() as i64;
    [q(v.x), q(v.y), q(v.z)]
}

impl ModelEdges {
    /// The creases of a scene's triangles: edges shared by triangles whose normals differ by
    /// more than [`MIN_CREASE_DEG`], and edges of one triangle only (a mesh boundary).
    pub fn new(scene: &Scene) -> Self {
        let cos_min = MIN_CREASE_DEG.to_radians().cos();
        let mut by_edge: HashMap<EdgeKey, (Crease, Vec<DVec3>)> = HashMap::new();
        for t in &scene.triangles {
            let v = [t.v0, t.v1, t.v2].map(|p| DVec3::new(f64::from(p.x), f64::from(p.y), f64::from(p.z)));
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            for (a, b) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
                let (ka, kb) = (key(a), key(b));
                let k = if ka <= kb { (ka, kb) } else { (kb, ka) };
                by_edge.entry(k).or_insert_with(|| (Crease { a, b }, Vec::new())).1.push(n);
            }
        }
        let mut creases: Vec<(EdgeKey, Crease)> = by_edge
            .into_iter()
            .filter(|(_, (_, normals))| match normals.as_slice() {
                [_] => true,
                [n1, n2] => n1.dot(*n2) <= cos_min,
                _ => true,
            })
            .map(|(k, (c, _))| (k, c))
            .collect();
        // A fixed order (the map's is random): the fit's sums in the same order every run.
        creases.sort_by_key(|(k, _)| *k);
        ModelEdges { creases: creases.into_iter().map(|(_, c)| c).collect() }
    }

    /// The creases.
    pub fn creases(&self) -> &[Crease] {
        &self.creases
    }

    /// The creases seen by `cam`, sampled every [`SAMPLE_SPACING_PX`] of their projection, each
    /// sample visible (not hidden by the model) and at least `border` px inside the image.
    pub fn samples(&self, cam: &Camera, model: &TargetModel<'_>, border: f64) -> Vec<EdgeSample> {
        let project =
            |x: DVec3| cam.project(x.as_vec3()).map(|(u, v)| DVec2::new(f64::from(u), f64::from(v)));
        let whole = Region::whole(cam.width, cam.height);
        let mut out = Vec::new();
        for c in &self.creases {
            let (Some(pa), Some(pb)) = (project(c.a), project(c.b)) else { continue };
            let n = ((pb - pa).length() / SAMPLE_SPACING_PX).floor() as usize;
            for k in 0..n {
                let t = (k as f64 + 0.5) / n as f64;
                let x = c.a + (c.b - c.a) * t;
                let Some(p) = project(x) else { continue };
                if !whole.holds(p.x, p.y, border) {
                    continue;
                }
                // The local direction of the projection (a lens bends a straight crease).
                let dt = 0.5 / n as f64;
                let (Some(p0), Some(p1)) =
                    (project(c.a + (c.b - c.a) * (t - dt)), project(c.a + (c.b - c.a) * (t + dt)))
                else {
                    continue;
                };
                let d = (p1 - p0).normalize_or_zero();
                if d == DVec2::ZERO || !model.visible(cam, x) {
                    continue;
                }
                out.push(EdgeSample { point: x, image: p, normal: DVec2::new(-d.y, d.x) });
            }
        }
        out
    }
}

/// Bilinear sample of `img` at continuous coordinates `(u, v)` (pixel centres at `x + 0.5`);
/// `None` outside.
fn bilinear(img: &GrayImage, u: f64, v: f64) -> Option<f64> {
    let (x, y) = (u - 0.5, v - 0.5);
    let (w, h) = (f64::from(img.width()), f64::from(img.height()));
    if x < 0.0 || y < 0.0 || x > w - 1.0 || y > h - 1.0 {
        return None;
    }
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as u32, y0 as u32);
    let (x1, y1) = ((x0 + 1).min(img.width() - 1), (y0 + 1).min(img.height() - 1));
    let p = |x, y| f64::from(img.get_pixel(x, y)[0]);
    Some(
        (p(x0, y0) * (1.0 - fx) + p(x1, y0) * fx) * (1.0 - fy)
            + (p(x0, y1) * (1.0 - fx) + p(x1, y1) * fx) * fy,
    )
}

/// Shortest search profile, samples: a profile cut shorter by the scene's region has no room
/// for a step.
const MIN_PROFILE: usize = 5;

/// The offset (px, along `s.normal`) of the crease's intensity step within `range` px of the
/// prediction: of the local maxima of the profile's derivative at least [`MIN_STEP`] and
/// [`STRONG_FRACTION`] of the strongest strong, the nearest to the prediction, refined to
/// sub-pixel by a parabola. The profile stops where it would leave `valid`, the part of the
/// image that holds the scene ([`crate::region`]): the edge of a skipped fusion's window is not
/// the target's; a sample outside it finds nothing, and outside the image `None` as well.
pub fn search(img: &GrayImage, valid: Region, s: &EdgeSample, range: f64) -> Option<f64> {
    let r = range.ceil() as i32 + 1;
    let at = |k: i32| s.image + s.normal * f64::from(k);
    // Bilinear reads pixel centres within half a pixel of the point.
    let inside = |k: i32| {
        let p = at(k);
        valid.holds(p.x, p.y, 0.5)
    };
    if !inside(0) {
        return None;
    }
    let before = (1..=r).take_while(|&k| inside(-k)).last().unwrap_or(0);
    let after = (1..=r).take_while(|&k| inside(k)).last().unwrap_or(0);
    let profile: Vec<f64> = (-before..=after)
        .map(|k| {
            let p = at(k);
            bilinear(img, p.x, p.y)
        })
        .collect::<Option<_>>()?;
    if profile.len() < MIN_PROFILE {
        return None;
    }
    let g: Vec<f64> = (1..profile.len() - 1).map(|i| 0.5 * (profile[i + 1] - profile[i - 1]).abs()).collect();
    let peaks: Vec<(f64, f64)> = (1..g.len() - 1)
        .filter(|&i| g[i] >= MIN_STEP && g[i] >= g[i - 1] && g[i] >= g[i + 1])
        .map(|i| {
            let offset = (i as i32 + 1 - before) as f64;
            let denom = g[i - 1] - 2.0 * g[i] + g[i + 1];
            let sub = if denom < 0.0 { (0.5 * (g[i - 1] - g[i + 1]) / denom).clamp(-0.5, 0.5) } else { 0.0 };
            (g[i], offset + sub)
        })
        .filter(|(_, o)| o.abs() <= range)
        .collect();
    let strongest = peaks.iter().map(|p| p.0).fold(0.0, f64::max);
    peaks
        .iter()
        .filter(|p| p.0 >= STRONG_FRACTION * strongest)
        .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map(|p| p.1)
}

/// One observation of the fit: a model point, the image point its crease was found at and the
/// normal along which it was searched.
struct Observation {
    point: DVec3,
    found: DVec2,
    normal: DVec2,
}

/// The residual (px, along the normal) and its Jacobian with respect to the pose error
/// `(δθ, δp)` (right camera-frame rotation, target-frame position) of an observation seen by
/// `cam`.
fn linearise(cam: &Camera, o: &Observation) -> Option<(f64, Vector6<f64>)> {
    let rot: DMat3 = cam.pose.rotation.as_dmat3();
    let c = rot.transpose() * (o.point - cam.pose.position.as_dvec3());
    if c.z <= 1e-6 {
        return None;
    }
    let (u, v) = cam.project(o.point.as_vec3())?;
    let r = o.normal.dot(DVec2::new(f64::from(u), f64::from(v)) - o.found);
    let f = f64::from(cam.focal_px);
    // dπ/dc: the pinhole's, through the lens's distortion where it has one; then dc/dδ:
    // c(δ) = exp(−[δθ]) (c − Rᵀ δp) ≈ c + [c]ₓ δθ − Rᵀ δp.
    let mut du = DVec3::new(f / c.z, 0.0, -f * c.x / (c.z * c.z));
    let mut dv = DVec3::new(0.0, f / c.z, -f * c.y / (c.z * c.z));
    if cam.dist != [0.0; 5] {
        let j = distortion_jacobian(&cam.dist, c.x / c.z, c.y / c.z);
        (du, dv) = (du * j[0][0] + dv * j[0][1], du * j[1][0] + dv * j[1][1]);
    }
    let g = du * o.normal.x + dv * o.normal.y; // d r / d c
    // d r / d δθ: gᵀ (c × δθ) = (g × c) · δθ; d r / d δp = −gᵀ Rᵀ = −(R g)ᵀ.
    let dth = g.cross(c);
    let dp = -(rot * g);
    Some((r, Vector6::new(dth.x, dth.y, dth.z, dp.x, dp.y, dp.z)))
}

/// The Jacobian `∂(x_d, y_d)/∂(x, y)` of OpenCV's radial–tangential distortion (`dist` =
/// k1, k2, p1, p2, k3) at the normalised point `(x, y)`:
/// `x_d = x·L + 2p1·xy + p2·(r² + 2x²)`, `y_d = y·L + p1·(r² + 2y²) + 2p2·xy`,
/// `L = 1 + k1·r² + k2·r⁴ + k3·r⁶`.
pub fn distortion_jacobian(dist: &[f32; 5], x: f64, y: f64) -> [[f64; 2]; 2] {
    let [k1, p1, p2, k2, k3] = [dist[0], dist[2], dist[3], dist[1], dist[4]].map(f64::from);
    let r2 = x * x + y * y;
    let l = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
    // dL/d(r²)
    let dl = k1 + 2.0 * k2 * r2 + 3.0 * k3 * r2 * r2;
    [
        [l + 2.0 * x * x * dl + 2.0 * p1 * y + 6.0 * p2 * x, 2.0 * x * y * dl + 2.0 * p1 * x + 2.0 * p2 * y],
        [2.0 * x * y * dl + 2.0 * p1 * x + 2.0 * p2 * y, l + 2.0 * y * y * dl + 6.0 * p1 * y + 2.0 * p2 * x],
    ]
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// `attitude`, `position` moved by the pose error `d = (δθ, δp)`.
fn moved(attitude: DQuat, position: DVec3, d: &Vector6<f64>) -> (DQuat, DVec3) {
    let q = (attitude * DQuat::from_scaled_axis(DVec3::new(d[0], d[1], d[2]))).normalize();
    (q, position + DVec3::new(d[3], d[4], d[5]))
}

/// Fits the pose to the model's edges in `img` (smoothed), starting at the prediction
/// `attitude`, `position` whose 1σ in the image is `sigma_px`: [`ROUNDS`] rounds of sampling
/// the creases at the current pose, searching each along its normal (the first range
/// 3 × `sigma_px`, then 3 × the residuals' σ), and Gauss–Newton with Tukey weights. The edges
/// alone decide (the prediction is only the start), so the result is a measurement independent
/// of the filter: its covariance is [`INFLATION`]` × σ² (Jᵀ W J)⁻¹` (σ the residuals' robust σ)
/// plus [`FLOOR_ATT_DEG`]² and ([`FLOOR_POS_FRAC`] × range)² on the diagonal. `cam` gives the
/// intrinsics; `valid` the part of `img` that holds the scene (no search reads past it). `None`
/// with fewer than [`MIN_SAMPLES`] edges found or a singular fit.
pub fn fit(
    img: &GrayImage,
    valid: Region,
    cam: &Camera,
    model: &TargetModel<'_>,
    edges: &ModelEdges,
    (attitude, position): (DQuat, DVec3),
    sigma_px: f64,
) -> Option<EdgeFit> {
    let (mut q, mut p) = (attitude, position);
    let mut range = (3.0 * sigma_px).clamp(MIN_RANGE_PX, MAX_RANGE_PX);
    let mut last = None;
    for round in 0..ROUNDS {
        let at = camera_at(cam, q, p);
        let obs: Vec<Observation> = edges
            .samples(&at, model, range + BORDER_PX)
            .iter()
            .filter_map(|s| {
                search(img, valid, s, range).map(|d| Observation {
                    point: s.point,
                    found: s.image + s.normal * d,
                    normal: s.normal,
                })
            })
            .collect();
        if obs.len() < MIN_SAMPLES {
            return last;
        }
        let mut sigma = SIGMA_FLOOR_PX;
        for _ in 0..ITERATIONS {
            let cur = camera_at(cam, q, p);
            let lin: Vec<(f64, Vector6<f64>)> = obs.iter().filter_map(|o| linearise(&cur, o)).collect();
            if lin.len() < MIN_SAMPLES {
                return last;
            }
            sigma = (1.4826 * median(lin.iter().map(|(r, _)| r.abs()).collect())).max(SIGMA_FLOOR_PX);
            let c = TUKEY_C * sigma;
            let (mut a, mut g) = (Matrix6::<f64>::zeros(), Vector6::<f64>::zeros());
            let mut inliers = 0;
            for (r, j) in &lin {
                let x = r / c;
                if x.abs() >= 1.0 {
                    continue;
                }
                let w = (1.0 - x * x).powi(2);
                a += j * j.transpose() * w;
                g += j * (w * r);
                inliers += 1;
            }
            if inliers < MIN_SAMPLES {
                return last;
            }
            // A little damping keeps a weakly seen direction from running off; the first round,
            // on the widest search, moves only what the image fixes well (the position and
            // the roll about the boresight), not the attitude out of the image plane.
            let mut damped = a + Matrix6::from_diagonal(&a.diagonal()) * 1e-6;
            if round == 0 {
                for k in 0..2 {
                    damped.row_mut(k).fill(0.0);
                    damped.column_mut(k).fill(0.0);
                    damped[(k, k)] = 1.0;
                    g[k] = 0.0;
                }
            }
            let step = -(damped.try_inverse()? * g);
            (q, p) = moved(q, p, &step);
            let range_m = (p - model.centre()).length().max(1e-3);
            let mut cov = a.try_inverse()? * (sigma * sigma * INFLATION);
            for i in 0..3 {
                cov[(i, i)] += FLOOR_ATT_DEG.to_radians().powi(2);
                cov[(3 + i, 3 + i)] += (FLOOR_POS_FRAC * range_m).powi(2);
            }
            last = Some(EdgeFit {
                measurement: PoseMeasurement { attitude: q, position: p, covariance: cov },
                found: obs.len(),
                inliers,
                sigma_px: sigma,
            });
            if step.fixed_rows::<3>(0).norm() < 1e-7 && step.fixed_rows::<3>(3).norm() < 1e-6 {
                break;
            }
        }
        range = (3.0 * sigma).clamp(MIN_RANGE_PX, range);
    }
    last
}

/// Search range of [`support`], px.
pub const SUPPORT_RANGE_PX: f64 = 3.0;
/// A sample supports a pose when its crease's step lies within this of where the pose puts it,
/// px.
pub const SUPPORT_TOLERANCE_PX: f64 = 1.5;

/// Whether the image shows one crease sample where a pose puts it: a step within
/// [`SUPPORT_TOLERANCE_PX`] ([`search`] over [`SUPPORT_RANGE_PX`]).
pub fn supported(img: &GrayImage, s: &EdgeSample) -> bool {
    search(img, Region::whole(img.width(), img.height()), s, SUPPORT_RANGE_PX)
        .is_some_and(|d| d.abs() <= SUPPORT_TOLERANCE_PX)
}

/// How much of the model's outline and creases the image shows at the pose of `cam`
/// (intrinsics and pose): the share of the visible crease samples that are [`supported`], and
/// their number. A diagnostic (`examples/edge_overlay.rs` draws it): on the rendered
/// fly-around a pose 5–8° off can reach the true pose's share, so it does not tell a right fit
/// from a wrong one (BENCHMARKS.md, "Holding the target").
pub fn support(img: &GrayImage, cam: &Camera, model: &TargetModel<'_>, edges: &ModelEdges) -> (f64, usize) {
    let samples = edges.samples(cam, model, SUPPORT_RANGE_PX + BORDER_PX);
    if samples.is_empty() {
        return (0.0, 0);
    }
    let near = samples.iter().filter(|s| supported(img, s)).count();
    (near as f64 / samples.len() as f64, samples.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use render_host::sequence::{SequenceConfig, SequenceName, camera_pose, state};

    /// A crease at x = 40 (90 → 30 grey levels) and, at x = 60, the edge of a skipped fusion's
    /// window (30 → the background value 0): searched from x = 50 across both, the whole image's
    /// search takes the window's edge (the stronger step, and as near); searched inside the
    /// window it finds the crease, and from a point with only the window's edge in reach,
    /// nothing.
    #[test]
    fn the_search_stops_at_the_window() {
        let img = GrayImage::from_fn(100, 20, |x, _| {
            image::Luma([if x < 40 {
                90
            } else if x < 60 {
                30
            } else {
                0
            }])
        });
        let window = Region { x0: 0, y0: 0, x1: 60, y1: 20 };
        let at = |x: f64| EdgeSample { point: DVec3::ZERO, image: DVec2::new(x, 10.0), normal: DVec2::X };
        // Steps lie between pixel centres 39.5 | 40.5 and 59.5 | 60.5: at u = 40 and u = 60.
        let whole = search(&img, Region::whole(100, 20), &at(52.0), 15.0).expect("a step");
        assert!((whole - 8.0).abs() < 0.6, "{whole}");
        let inside = search(&img, window, &at(52.0), 15.0).expect("a step");
        assert!((inside + 12.0).abs() < 0.6, "{inside}");
        assert_eq!(search(&img, window, &at(56.0), 3.0), None);
        assert_eq!(search(&img, window, &at(61.0), 15.0), None, "a sample outside the window");
    }

    /// The distortion's Jacobian against central differences of the lens model itself.
    #[test]
    fn distortion_jacobian_matches_the_lens() {
        let dist = [-0.08f32, 0.02, 0.0004, -0.0003, 0.001];
        let apply = |x: f64, y: f64| {
            let [k1, k2, p1, p2, k3] = dist.map(f64::from);
            let r2 = x * x + y * y;
            let l = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
            (
                x * l + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                y * l + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
            )
        };
        for (x, y) in [(0.0, 0.0), (0.21, -0.13), (-0.26, 0.26), (0.05, 0.3)] {
            let j = distortion_jacobian(&dist, x, y);
            let h = 1e-6;
            let (a, b) = (apply(x + h, y), apply(x - h, y));
            let (c, d) = (apply(x, y + h), apply(x, y - h));
            let num = [
                [(a.0 - b.0) / (2.0 * h), (c.0 - d.0) / (2.0 * h)],
                [(a.1 - b.1) / (2.0 * h), (c.1 - d.1) / (2.0 * h)],
            ];
            for r in 0..2 {
                for k in 0..2 {
                    assert!(
                        (j[r][k] - num[r][k]).abs() < 1e-8,
                        "({x}, {y}) [{r}][{k}]: {} vs {}",
                        j[r][k],
                        num[r][k]
                    );
                }
            }
        }
    }

    /// The Tango model's creases: the bus box (open at the top, under the panel) and the
    /// panel slab give straight creases; the rods' 60° facets do not count.
    #[test]
    fn creases_of_the_model() {
        let scene = Scene::tango().expect("scene");
        let edges = ModelEdges::new(&scene);
        let n = edges.creases().len();
        // Panel: 12 box edges, 2 triangles per face add no crease along the diagonals.
        assert!(n >= 24, "{n} creases");
        for c in edges.creases() {
            assert!((c.b - c.a).length() > 1e-4);
        }
    }

    /// A 1024² image of the Tango model on a fly-around pose, each pixel shaded by the face it
    /// sees so inner creases show as steps too; the camera.
    fn shaded_view() -> (Scene, Camera, GrayImage) {
        let scene = Scene::tango().expect("scene");
        let pose = camera_pose(&state(&SequenceConfig::new(SequenceName::Flyaround), 3), &scene);
        let size = 1024;
        let truth = Camera::study(size, pose);
        let depth = render_host::truth::depth(&scene, &truth);
        let mut img = GrayImage::new(size, size);
        for y in 0..size {
            for x in 0..size {
                if depth[(y * size + x) as usize].is_some() {
                    let hit = scene
                        .intersect(truth.pose.position, truth.pixel_ray(x, y), 0.0)
                        .expect("a hit where the depth is");
                    let shade = 60.0 + 150.0 * f64::from(hit.normal.dot(-truth.pixel_ray(x, y)).abs());
                    img.put_pixel(x, y, image::Luma([shade as u8]));
                }
            }
        }
        (scene, truth, crate::tracker::smooth(&img))
    }

    /// At the true pose most crease samples find their step (not all: some faces meet at
    /// similar shades); moved 8 px along the image diagonal, under half as many do (the
    /// tolerance is 1.5 px; creases along the diagonal keep theirs).
    #[test]
    fn support_is_high_at_the_true_pose_only() {
        let (scene, truth, img) = shaded_view();
        let model = TargetModel::new(&scene);
        let edges = ModelEdges::new(&scene);
        let (at_truth, n) = support(&img, &truth, &model, &edges);
        let range = model.centre_in_camera(&truth).z;
        let q = DQuat::from_mat3(&truth.pose.rotation.as_dmat3());
        // 8 px along the image diagonal at the target's range.
        let step = q * DVec3::new(1.0, 1.0, 0.0).normalize() * (8.0 * range / f64::from(truth.focal_px));
        let moved = camera_at(&truth, q, truth.pose.position.as_dvec3() + step);
        let (off, _) = support(&img, &moved, &model, &edges);
        assert!(n > 100 && at_truth > 0.6 && off < 0.5 * at_truth, "truth {at_truth} of {n}, moved {off}");
    }

    /// A step image of the model's rendered mask: started 1° and 4 cm off the truth, the fit
    /// comes back within 0.2° and 1 cm.
    #[test]
    fn fit_returns_to_the_true_pose_on_a_mask() {
        let (scene, truth, img) = shaded_view();
        let model = TargetModel::new(&scene);
        let edges = ModelEdges::new(&scene);
        let pose = truth.pose;
        let q0 = DQuat::from_mat3(&pose.rotation.as_dmat3());
        let p0 = pose.position.as_dvec3();
        let q = q0 * DQuat::from_scaled_axis(DVec3::new(0.6, -0.8, 0.0).normalize() * 0.3f64.to_radians());
        let p = p0 + DVec3::new(0.015, -0.01, 0.01);
        let whole = Region::whole(img.width(), img.height());
        let f = fit(&img, whole, &truth, &model, &edges, (q, p), 10.0).expect("a fit");
        let m = f.measurement;
        let att = crate::filter::rotation_vector(m.attitude.inverse() * q0).length().to_degrees();
        let pos = (m.position - p0).length();
        assert!(att < 0.2 && pos < 0.01, "attitude {att}°, position {pos} m ({} found)", f.found);
    }
}
