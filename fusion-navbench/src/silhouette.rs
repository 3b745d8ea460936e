//! The target's outline as a position measurement: where the target stands in the image and
//! how large it looks, against the model's outline at the estimate.
//!
//! Feature tracking measures the pose relative to the points it anchored at earlier
//! estimates, so an error in the estimate's range (the weakly observed direction of a target a
//! few degrees across) comes back in every later measurement and grows. The outline does not
//! depend on the estimate: the target, warm or lit against cold, dark space, is segmented
//! (a threshold over the space background's level and noise, both measured on the image's
//! border). Against a background that is not dark (the Earth: lit in VIS, warm in TIR, where
//! the target may be brighter or darker than what is behind it), the target is what differs
//! from its surroundings either way: level and spread are measured on a ring around the
//! predicted box, and pixels inside the box more than [`RING_SIGMAS`] spreads off that level,
//! above or below, are the target. Its centroid and area are compared with the model's
//! silhouette at the estimate
//! ([`crate::model::TargetModel::silhouette`]). To first order a lateral offset of the target
//! moves the centroid by `f·Δx/z`, and a range error scales the area by `(z/z')²`; the
//! measurement is the target-centre position those imply, in the target frame. Its errors are
//! those of the segmentation: the unlit side of a target in sunlight is not segmented in VIS,
//! which shifts the centroid and shrinks the area, hence the generous [`LATERAL_SD_PX`] and
//! [`RANGE_SD_FRAC`]. Standard practice at far range (centroiding and apparent size), written
//! here: no crate offers it.

use crate::model::{Silhouette, TargetModel};
use crate::region::Region;
use image::GrayImage;
use nalgebra::Matrix3;
use render_host::Camera;
use render_host::glam::DVec3;

/// 1σ of the centroid's error, px.
pub const LATERAL_SD_PX: f64 = 5.0;
/// 1σ of the range implied by the area, as a share of the range (at the true pose the
/// segmented area is 5–25 % off the model's on the rendered sequences in light: blur and noise
/// grow it at far range, unlit parts shrink it).
pub const RANGE_SD_FRAC: f64 = 0.10;
/// An outline whose area is outside this ratio of the model's is not the target's (half of
/// it in shadow or eclipse, or noise): no measurement.
pub const AREA_RATIO_RANGE: (f64, f64) = (0.6, 1.6);
/// Fewer segmented pixels than this: no measurement.
pub const MIN_AREA_PX: f64 = 40.0;
/// The segmentation threshold: this many noise standard deviations over the background.
pub const THRESHOLD_SIGMAS: f64 = 6.0;
/// The border band the background's level and noise are measured on, px.
pub const BORDER_PX: u32 = 16;
/// A border median above this (grey levels) is not dark space: the target is segmented
/// against the ring around its predicted box instead (dark space after the sensor's noise and
/// the front end's smoothing reads a median of a few grey levels).
pub const DARK_BACKGROUND: f64 = 24.0;
/// Against a background that is not dark: the ring around the predicted box the background is
/// measured on, as a share of the box's larger side on each side.
pub const RING_FRAC: f64 = 0.5;
/// Against a background that is not dark: the threshold, in the ring's spreads (1.4826 × its
/// median absolute deviation, at least 1 grey level), on either side of the ring's median.
pub const RING_SIGMAS: f64 = 3.0;

/// Median and spread (1.4826 × the median absolute deviation, at least 1) of `values`.
fn level_and_spread(mut values: Vec<u8>) -> (f64, f64) {
    values.sort_unstable();
    let median = f64::from(values[values.len() / 2]);
    let mut dev: Vec<f64> = values.iter().map(|&v| (f64::from(v) - median).abs()).collect();
    dev.sort_by(f64::total_cmp);
    (median, (1.4826 * dev[dev.len() / 2]).max(1.0))
}

/// The segmented target in `img` (the smoothed frame), inside `bbox`: against dark space (the
/// border band's median at most [`DARK_BACKGROUND`]) the pixels more than [`THRESHOLD_SIGMAS`]
/// background noise standard deviations above the border's median; against anything brighter
/// (the Earth) the pixels more than [`RING_SIGMAS`] spreads above or below the level of the
/// ring around `bbox` ([`RING_FRAC`]).
///
/// `valid` is the part of the frame that holds the scene ([`crate::region`]): the whole frame,
/// or a skipped fusion's window (outside it the core's flat background value would read as a
/// noiseless background, and every noise pixel inside the window would pass the threshold).
/// The border band is that region's, and only pixels inside it are segmented or taken into the
/// ring.
pub fn segment(img: &GrayImage, bbox: (u32, u32, u32, u32), valid: Region) -> Option<Silhouette> {
    let (w, h) = img.dimensions();
    let (vx0, vy0, vx1, vy1) = (valid.x0, valid.y0, valid.x1.min(w), valid.y1.min(h));
    if vx1 <= vx0 + 2 * BORDER_PX || vy1 <= vy0 + 2 * BORDER_PX {
        return None;
    }
    let mut border = Vec::new();
    for y in (vy0..vy1).step_by(2) {
        for x in (vx0..vx1).step_by(2) {
            if x < vx0 + BORDER_PX || y < vy0 + BORDER_PX || x >= vx1 - BORDER_PX || y >= vy1 - BORDER_PX {
                border.push(img.get_pixel(x, y)[0]);
            }
        }
    }
    let (median, sigma) = level_and_spread(border);
    let (x0, y0, x1, y1) = Region { x0: vx0, y0: vy0, x1: vx1, y1: vy1 }.clip(bbox)?;
    let target: Box<dyn Fn(f64) -> bool> = if median <= DARK_BACKGROUND {
        let threshold = median + THRESHOLD_SIGMAS * sigma;
        Box::new(move |v| v > threshold)
    } else {
        let grow = (f64::from((x1 - x0).max(y1 - y0)) * RING_FRAC).ceil() as u32;
        let (rx0, ry0) = (x0.saturating_sub(grow).max(vx0), y0.saturating_sub(grow).max(vy0));
        let (rx1, ry1) = ((x1 + grow).min(vx1), (y1 + grow).min(vy1));
        let mut ring = Vec::new();
        for y in ry0..ry1 {
            for x in rx0..rx1 {
                if !(x0..x1).contains(&x) || !(y0..y1).contains(&y) {
                    ring.push(img.get_pixel(x, y)[0]);
                }
            }
        }
        if ring.len() < 64 {
            return None;
        }
        let (level, spread) = level_and_spread(ring);
        Box::new(move |v| (v - level).abs() > RING_SIGMAS * spread)
    };
    let (mut n, mut sx, mut sy) = (0f64, 0f64, 0f64);
    for y in y0..y1 {
        for x in x0..x1 {
            if target(f64::from(img.get_pixel(x, y)[0])) {
                n += 1.0;
                sx += f64::from(x) + 0.5;
                sy += f64::from(y) + 0.5;
            }
        }
    }
    (n >= MIN_AREA_PX).then(|| Silhouette { area: n, cx: sx / n, cy: sy / n })
}

/// The target's centre in the camera frame that the image's silhouette implies, and its
/// covariance (camera frame), given the estimate `cam` and the model's silhouette there; `None`
/// when the areas differ by more than [`AREA_RATIO_RANGE`]. It says nothing of the attitude:
/// the filter takes it as a measurement of its relative position alone.
pub fn centre_measurement(
    image: &Silhouette,
    model_at_estimate: &Silhouette,
    cam: &Camera,
    model: &TargetModel,
) -> Option<(DVec3, Matrix3<f64>)> {
    let f = f64::from(cam.focal_px);
    let c = model.centre_in_camera(cam);
    let area_ratio = image.area / model_at_estimate.area;
    if !(AREA_RATIO_RANGE.0..=AREA_RATIO_RANGE.1).contains(&area_ratio) {
        return None;
    }
    let ratio = area_ratio.sqrt();
    let z = c.z / ratio;
    let (du, dv) = if cam.dist == [0.0; 5] {
        ((image.cx - model_at_estimate.cx) / f, (image.cy - model_at_estimate.cy) / f)
    } else {
        // Through the lens: the two centroids' rays, not their pixel offset over f.
        let (a, b) = (
            crate::model::normalised(cam, image.cx, image.cy),
            crate::model::normalised(cam, model_at_estimate.cx, model_at_estimate.cy),
        );
        (a.x - b.x, a.y - b.y)
    };
    let measured = DVec3::new((c.x / c.z + du) * z, (c.y / c.z + dv) * z, z);
    let lateral = LATERAL_SD_PX / f * z;
    let range = RANGE_SD_FRAC * z;
    Some((
        measured,
        Matrix3::from_diagonal(&nalgebra::Vector3::new(lateral * lateral, lateral * lateral, range * range)),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::camera_at;
    use render_host::Scene;
    use render_host::glam::DQuat;
    use render_host::sequence::{SequenceConfig, SequenceName, camera_pose, state};

    /// A fly-around frame at 512²: the target, the true camera's target mask, the true camera
    /// position, and an estimate 5 % too far and 10 cm to the side.
    struct Case {
        scene: Scene,
        mask: Vec<bool>,
        truth: DVec3,
        est: Camera,
    }

    fn wrong_estimate() -> Case {
        let scene = Scene::tango().expect("scene");
        let model = TargetModel::new(&scene);
        let pose = camera_pose(&state(&SequenceConfig::new(SequenceName::Flyaround), 3), &scene);
        let camera = Camera::study(512, pose);
        let mask = render_host::truth::target_mask(&scene, &camera);
        let q = DQuat::from_mat3(&pose.rotation.as_dmat3());
        let truth = pose.position.as_dvec3();
        let c = model.centre();
        let wrong = c + (truth - c) * 1.05 + DVec3::new(0.0, 0.0, 0.1);
        let est = camera_at(&camera, q, wrong);
        Case { scene, mask, truth, est }
    }

    /// The target centre in the camera frame at the truth and at the wrong estimate (the
    /// estimate's attitude is the true one).
    fn centres(model: &TargetModel, est: &Camera, truth: DVec3) -> (DVec3, DVec3) {
        let q = DQuat::from_mat3(&est.pose.rotation.as_dmat3());
        (model.centre_in_camera(&camera_at(est, q, truth)), model.centre_in_camera(est))
    }

    /// The true camera's rendered mask, segmented, measured against the model at the wrong
    /// estimate: the measurement lands within its 2σ of the true relative position, and much
    /// closer than the estimate.
    #[test]
    fn outline_pulls_a_wrong_estimate_back_to_the_truth() {
        let Case { scene, mask, truth, est } = wrong_estimate();
        let model = TargetModel::new(&scene);
        let (p, wrong) = centres(&model, &est, truth);
        let bbox = model.image_box(&est, 0.3).unwrap();
        let img =
            GrayImage::from_raw(512, 512, mask.iter().map(|&m| if m { 200 } else { 3 }).collect()).unwrap();
        let seen = segment(&img, bbox, Region::whole(512, 512)).expect("segmented");
        let at_est = model.silhouette(&est, bbox, 1).expect("model silhouette");
        let (m, cov) = centre_measurement(&seen, &at_est, &est, &model).expect("a measurement");
        let err = m - p;
        let e = nalgebra::Vector3::new(err.x, err.y, err.z);
        let d2 = (e.transpose() * cov.try_inverse().unwrap() * e)[(0, 0)];
        assert!(d2 < 4.0 * 3.0, "Mahalanobis² {d2}, error {err:?}");
        assert!(err.length() < 0.3 * (wrong - p).length(), "{} vs {}", err.length(), (wrong - p).length());
    }

    /// Against the Earth: the same outline on a bright, structured background (a level of 150
    /// with ±12 grey levels of slow pattern and ±4 of pixel noise), the target once colder
    /// (darker, as in TIR over a warm Earth) and once brighter: either way the measurement
    /// pulls the wrong estimate back as it does against dark space; the border-based threshold
    /// alone would see nothing darker than the background.
    #[test]
    fn against_the_earth_the_outline_is_what_differs_from_its_surroundings() {
        let Case { scene, mask, truth, est } = wrong_estimate();
        let model = TargetModel::new(&scene);
        let (p, wrong) = centres(&model, &est, truth);
        let bbox = model.image_box(&est, 0.3).unwrap();
        let mut rng = render_host::noise::SplitMix64::new(5);
        for target in [100u8, 210] {
            let data = mask
                .iter()
                .enumerate()
                .map(|(i, &m)| {
                    let (x, y) = ((i % 512) as f64, (i / 512) as f64);
                    let earth =
                        150.0 + 12.0 * (x / 37.0).sin() * (y / 53.0).cos() + (rng.next_u64() % 9) as f64
                            - 4.0;
                    if m { target } else { earth.round() as u8 }
                })
                .collect();
            let img = GrayImage::from_raw(512, 512, data).unwrap();
            let seen = segment(&img, bbox, Region::whole(512, 512)).expect("segmented");
            let at_est = model.silhouette(&est, bbox, 1).expect("model silhouette");
            let (m, _) = centre_measurement(&seen, &at_est, &est, &model).expect("a measurement");
            let err = m - p;
            assert!(
                err.length() < 0.3 * (wrong - p).length(),
                "target {target}: {} vs {}",
                err.length(),
                (wrong - p).length()
            );
        }
    }

    /// A skipped fusion's frame: the same target and space noise inside a window, the core's
    /// background value 0 outside. Segmented inside its window, it gives the whole frame's
    /// outline; judged against the frame's border (all zeros, no noise) the window's noise
    /// passes the threshold and the outline is lost in it.
    #[test]
    fn a_skipped_frame_is_segmented_inside_its_window() {
        let Case { scene, mask, est, .. } = wrong_estimate();
        let model = TargetModel::new(&scene);
        let bbox = model.image_box(&est, 0.3).unwrap();
        let mut rng = render_host::noise::SplitMix64::new(11);
        // Smoothed space: a level of 4 with ±3 grey levels of noise.
        let whole: Vec<u8> =
            mask.iter().map(|&m| if m { 200 } else { 1 + (rng.next_u64() % 7) as u8 }).collect();
        let (x0, y0, x1, y1) = bbox;
        let window =
            Region { x0: x0.saturating_sub(24), y0: y0.saturating_sub(24), x1: x1 + 24, y1: y1 + 24 };
        let skipped: Vec<u8> = whole
            .iter()
            .enumerate()
            .map(
                |(i, &v)| {
                    if window.holds((i % 512) as f64 + 0.5, (i / 512) as f64 + 0.5, 0.0) { v } else { 0 }
                },
            )
            .collect();
        let whole = GrayImage::from_raw(512, 512, whole).unwrap();
        let skipped = GrayImage::from_raw(512, 512, skipped).unwrap();
        let reference = segment(&whole, bbox, Region::whole(512, 512)).expect("segmented");
        let inside = segment(&skipped, bbox, window).expect("segmented");
        assert!((inside.area - reference.area).abs() <= 0.01 * reference.area, "{inside:?} vs {reference:?}");
        assert!((inside.cx - reference.cx).abs() < 0.2 && (inside.cy - reference.cy).abs() < 0.2);
        let blind = segment(&skipped, bbox, Region::whole(512, 512)).expect("segmented");
        assert!(blind.area > 1.5 * reference.area, "{blind:?} vs {reference:?}");
    }
}
