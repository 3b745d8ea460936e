//! The model-based front end: features tracked over many frames, their 3D positions from the
//! target model at the estimated pose, the pose by PnP inside RANSAC and a non-linear
//! refinement.
//!
//! Per frame:
//! 1. **Track** the features into this frame, in two steps. Coarse: pyramidal Lucas–Kanade
//!    with a forward–backward check (`optical-flow-lk`: OpenCV's `calcOpticalFlowPyrLK`
//!    scheme) from the previous frame, seeded at the feature's 3D point projected with the
//!    filter's predicted pose. Exact: the feature's window cut in the frame it was anchored in,
//!    warped by its model face's plane to the prediction and matched by Gauss–Newton
//!    ([`crate::warp`]), so that the track stays on its 3D point however long it lives (a
//!    translation-only window slides off it by a fraction of a pixel per frame as the face
//!    turns). A feature the model says is hidden at the prediction is dropped, and so is one
//!    whose window no longer correlates with its template.
//! 2. **Pose**: RANSAC over SQPnP on the tracked features ([`crate::pose::pnp_ransac`], 2 px),
//!    then Levenberg–Marquardt on the inliers ([`crate::pose::refine`]) with its covariance.
//!    Features outside the refined pose's 2 px are dropped. Fewer than
//!    [`crate::pose::MIN_INLIERS`] inliers: no pose this frame (the filter coasts).
//! 3. **Replenish** ([`ModelTracker::replenish`], after the filter's update): when fewer than
//!    [`TrackerParams::min_tracks`] remain, Shi–Tomasi corners (`optical-flow-lk`'s detector,
//!    on a grid, kept clear of the surviving tracks) inside the box where the model stands at
//!    the estimate, each back-projected onto the model at the estimate
//!    ([`crate::model::TargetModel::back_project`]).
//!
//! Nothing here reads the true pose: the truth enters the run only through the first frame's
//! (perturbed) initialisation of the filter.

use crate::features::PRESMOOTH_SIGMA;
use crate::model::{TargetModel, normalised};
use crate::pose::{INLIER_THRESHOLD_PX, RefinedPose, estimate};
use crate::region::Region;
use crate::warp::{GradientImage, Template};
use image::GrayImage;
use imageproc::filter::gaussian_blur_f32;
use optical_flow_lk::{DetectorContext, Grid, TrackParams, TrackStatus, build_pyramid, calc_optical_flow_fb};
use render_host::Camera;
use render_host::glam::{DVec2, DVec3};

/// Tuning of the front end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackerParams {
    /// Lucas–Kanade window side, px (odd).
    pub window: usize,
    /// Pyramid levels (level 0 included).
    pub levels: usize,
    /// Iterations per level.
    pub iterations: usize,
    /// Forward–backward round trip allowed, px.
    pub fb_threshold: f32,
    /// Below this many tracks, new features are detected.
    pub min_tracks: usize,
    /// At most this many tracks.
    pub max_tracks: usize,
    /// Shi–Tomasi quality level (of the strongest corner in the box).
    pub quality: f32,
    /// Smallest spacing of two features, px.
    pub min_distance: u32,
    /// Lucas–Kanade refuses a window whose smaller gradient eigenvalue (per pixel,
    /// (grey levels / px)²) is below this: flat or noise-only windows drift.
    pub min_eigen: f32,
    /// Largest move of the template match away from the Lucas–Kanade position, px.
    pub max_refinement_px: f32,
}

impl Default for TrackerParams {
    fn default() -> Self {
        TrackerParams {
            window: 21,
            levels: 4,
            iterations: 30,
            fb_threshold: 1.0,
            min_tracks: 150,
            max_tracks: 300,
            quality: 0.02,
            min_distance: 6,
            min_eigen: 2.0,
            max_refinement_px: 3.0,
        }
    }
}

/// A feature followed over frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// Position in the last frame, px (pixel centres at integers, as `optical-flow-lk`).
    pub pos: (f32, f32),
    /// Its point on the model, target frame, m.
    pub point: DVec3,
    /// Frames it has been followed since it was anchored.
    pub age: usize,
    /// Its window in the anchor frame on its model face, warped into each later frame.
    pub template: Template,
}

/// What the front end made of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontEndFrame {
    /// Tracks carried into this frame (before RANSAC).
    pub tracked: usize,
    /// PnP inliers.
    pub inliers: usize,
    /// The refined pose (target → camera) and covariance, when there were enough inliers.
    pub pose: Option<RefinedPose>,
}

/// The front end's state over a sequence.
pub struct ModelTracker {
    params: TrackerParams,
    tracks: Vec<Track>,
    detector: DetectorContext,
    /// The pyramid of the frame last tracked.
    previous: Option<Vec<GrayImage>>,
    seed: u64,
}

/// The smoothed frame the tracker works on ([`PRESMOOTH_SIGMA`], as the detector of the
/// frame-to-frame front end).
pub fn smooth(img: &GrayImage) -> GrayImage {
    gaussian_blur_f32(img, PRESMOOTH_SIGMA)
}

impl ModelTracker {
    /// A front end with no tracks; `seed` seeds its RANSAC.
    pub fn new(params: TrackerParams, seed: u64) -> Self {
        ModelTracker { params, tracks: Vec::new(), detector: DetectorContext::new(), previous: None, seed }
    }

    /// The current tracks.
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// Tracks the features into `frame` (already [`smooth`]ed), `predicted` the camera at the
    /// filter's prediction for it, and measures the pose. `index` seeds this frame's RANSAC.
    /// `valid`: the part of `frame` that holds the scene ([`crate::region`]); a track whose
    /// window reaches past it is dropped (its window would match the region's edge).
    pub fn track(
        &mut self,
        frame: &GrayImage,
        valid: Region,
        predicted: &Camera,
        model: &TargetModel,
        index: u64,
    ) -> FrontEndFrame {
        let p = self.params;
        let pyramid = build_pyramid(frame, p.levels);
        match self.previous.take() {
            Some(previous) if !self.tracks.is_empty() && previous[0].dimensions() == frame.dimensions() => {
                let params = TrackParams {
                    window_size: p.window,
                    max_iterations: p.iterations,
                    min_eigen_threshold: p.min_eigen,
                };
                let from: Vec<(f32, f32)> = self.tracks.iter().map(|t| t.pos).collect();
                let guess: Vec<(f32, f32)> = self
                    .tracks
                    .iter()
                    .map(|t| predicted.project(t.point.as_vec3()).map_or(t.pos, |(u, v)| (u - 0.5, v - 0.5)))
                    .collect();
                let results =
                    calc_optical_flow_fb(&previous, &pyramid, &from, Some(&guess), params, p.fb_threshold);
                let gradients = GradientImage::new(frame);
                let tracks = std::mem::take(&mut self.tracks);
                let inside = valid.shrunk(p.window as u32 / 2);
                for (t, r) in tracks.into_iter().zip(&results) {
                    if r.status != TrackStatus::Tracked
                        || !inside.holds(f64::from(r.pos.0) + 0.5, f64::from(r.pos.1) + 0.5, 0.0)
                        || !model.visible(predicted, t.point)
                    {
                        continue;
                    }
                    let Some(q) = t.template.refine(&gradients, predicted, r.pos) else { continue };
                    if (q.0 - r.pos.0).hypot(q.1 - r.pos.1) <= p.max_refinement_px {
                        self.tracks.push(Track { pos: q, age: t.age + 1, ..t });
                    }
                }
            }
            _ => self.tracks.clear(),
        }
        self.previous = Some(pyramid);
        let tracked = self.tracks.len();
        let points: Vec<DVec3> = self.tracks.iter().map(|t| t.point).collect();
        let image: Vec<DVec2> = self
            .tracks
            .iter()
            .map(|t| normalised(predicted, f64::from(t.pos.0) + 0.5, f64::from(t.pos.1) + 0.5))
            .collect();
        let f = f64::from(predicted.focal_px);
        let Some((found, pose)) = estimate(&points, &image, f, self.seed ^ index.wrapping_mul(0x9E37_79B9))
        else {
            return FrontEndFrame { tracked, inliers: 0, pose: None };
        };
        if pose.is_none() {
            return FrontEndFrame { tracked, inliers: found.inliers, pose: None };
        }
        // Keep the features the final pose explains.
        let final_pose = pose.map_or(found.pose, |r| r.pose);
        let threshold = INLIER_THRESHOLD_PX / f;
        let keep: Vec<bool> = points
            .iter()
            .zip(&image)
            .map(|(&x, &u)| final_pose.project(x).is_some_and(|q| (q - u).length() <= threshold))
            .collect();
        let mut k = keep.iter();
        self.tracks.retain(|_| *k.next().unwrap_or(&false));
        FrontEndFrame { tracked, inliers: found.inliers, pose }
    }

    /// Tops the tracks up from `frame` (the one just tracked) when fewer than
    /// [`TrackerParams::min_tracks`] remain: corners inside the model's box at the estimate
    /// `estimate` whose window lies inside `valid` ([`crate::region`]), back-projected onto the
    /// model there.
    /// Returns how many were added.
    pub fn replenish(
        &mut self,
        frame: &GrayImage,
        valid: Region,
        estimate: &Camera,
        model: &TargetModel,
    ) -> usize {
        let p = self.params;
        if self.tracks.len() >= p.min_tracks {
            return 0;
        }
        let Some(bbox) = model.image_box(estimate, 0.1) else { return 0 };
        let Some((x0, y0, x1, y1)) = valid.shrunk(p.window as u32 / 2).clip(bbox) else { return 0 };
        let (w, h) = (x1 - x0, y1 - y0);
        if w < 16 || h < 16 {
            return 0;
        }
        let crop = image::imageops::crop_imm(frame, x0, y0, w, h).to_image();
        let existing: Vec<(f32, f32)> =
            self.tracks.iter().map(|t| (t.pos.0 - x0 as f32, t.pos.1 - y0 as f32)).collect();
        let cells = (w.max(h) / 32).clamp(2, 12);
        // Cells over space hold only noise corners, which the model refuses below: give each
        // cell room for a share of the whole budget, not of the cell count.
        let per_cell = ((p.max_tracks as u32) / 16).max(2);
        let grid = Grid { cols: cells, rows: cells, max_per_cell: per_cell };
        let corners = self.detector.detect_grid(&crop, grid, p.quality, p.min_distance, &existing).to_vec();
        let mut added = 0;
        for c in corners {
            if self.tracks.len() >= p.max_tracks {
                break;
            }
            let (x, y) = (c.x + x0, c.y + y0);
            let pos = (x as f32, y as f32);
            let Some(hit) = model.back_project(estimate, f64::from(pos.0) + 0.5, f64::from(pos.1) + 0.5)
            else {
                continue;
            };
            let Some(template) =
                Template::cut(frame, estimate, model, (x, y), hit.point, (hit.face, hit.normal))
            else {
                continue;
            };
            self.tracks.push(Track { pos, point: hit.point, template, age: 0 });
            added += 1;
        }
        added
    }
}
