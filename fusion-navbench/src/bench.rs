//! `fusion navbench`: does a fused stream help relative navigation? Every image stream of a
//! rendezvous sequence — VIS, TIR upscaled, each core method and variant, with and without
//! scene skipping, and in a closed loop whose skip window is the box the stream's own filter
//! predicts ([`predicted_box`], `<method>-loop`) — and the two baselines (`zero-motion`, `oracle`: [`crate::baseline`])
//! through the same navigation chain, measured against the rendered ground truth, per
//! illumination phase.
//!
//! Per frame and stream:
//! * **CNR**: `|μ_target − μ_ring| / σ_ring`, the target mask (VIS grid) against a background
//!   ring 8–24 px outside it (σ floored at 0.5 grey levels).
//! * **target features**: corners of [`super::features::detect`] inside the target mask grown
//!   by 3 px.
//! * the **model-based front end** ([`crate::tracker`]): features tracked over the sequence,
//!   PnP against the target model at the estimate; **tracks**, **inliers**, and per frame pair
//!   (k − 1, k) the **rotation error** and **translation-direction error** of the relative
//!   pose between its two measured poses against the truth, **lost** when either frame has no
//!   pose.
//! * the **navigation filter** ([`crate::filter`]) fed by the absolute cues — the model's
//!   edges fitted at the prediction ([`crate::edges`]) where the target is predicted at least
//!   [`crate::edges::MIN_TARGET_PX`] wide, its outline's position ([`crate::silhouette`])
//!   where it is smaller or the edges fail — not by the tracks' pose (their 3D points come
//!   from the model at the estimate: they measure motion, and fed as a pose they drag the
//!   filter along their drift): attitude error (°),
//!   position error (% of range), their 3σ bounds, NEES, and **available** when the attitude
//!   error is ≤ [`AVAILABLE_ATT_DEG`] and the position error ≤ [`AVAILABLE_POS_PCT`] of the
//!   range. The position is the filter's state, the camera's position in the *target's* frame:
//!   an error of the relative attitude about the target's centre (the direction a compact
//!   target shows weakly) is in it too, 1° being 1.75 % of the range. Beside it the
//!   **relative position** — the target's centre in the *camera's* frame, the line-of-sight
//!   vector a chaser's guidance steers on (its own attitude comes from its star trackers) —
//!   which that attitude error leaves unchanged, and **available (relative)** with it in
//!   place of the position.
//! * today's **pairwise front end** beside it (`pairwise_*`): FAST-9 + BRIEF matched frame to
//!   frame, PnP-RANSAC against frame k − 1's rendered depth ([`super::track`],
//!   [`super::pose`]).
//!
//! A pair counts in the phase of its second frame. Medians of the errors are over the pairs
//! that were not lost. The filter starts on the first frame's true pose perturbed by
//! [`INIT_ATT_ERR_DEG`] and [`INIT_POS_ERR_FRAC`] (acquisition is out of scope); nothing else
//! in a stream reads the truth.

use super::baseline::{ORACLE_NOISE_PX, observe, surface_points, target_to_camera, true_pose, unit_vector};
use super::features::{detect, grow_mask};
use super::filter::{FilterParams, PoseFilter, PoseMeasurement, relative_position, rotation_vector};
use super::model::{TargetModel, camera_at, normalised};
use super::pose::{MIN_INLIERS, RelativePose, estimate, pnp_ransac};
use super::region::Region;
use super::registration::{Registration, misregistration, on_vis_grid};
use super::silhouette::{centre_measurement, segment};
use super::track::{Feature, describe, match_features, test_pairs};
use super::tracker::{ModelTracker, TrackerParams, smooth};
use anyhow::{Context, Result};
use fusion_engine::CoreScratch;
use fusion_io::{ColorPolicy, Gray, load_gray_u8};
use fusion_nostd::pipeline::{SkipPolicy, Skips};
use fusion_nostd::registration::Rig;
use fusion_nostd::scene::Rect;
use fusion_nostd::{AdaptiveParams, FuseConfig, Method, RescalePolicy, Sequence};
use image::GrayImage;
use rayon::prelude::*;
use render_host::Camera;
use render_host::glam::{DQuat, DVec2, DVec3};
use render_host::noise::{SplitMix64, mix64};
use render_host::sequence::{Phase, SequenceManifest, read_manifest};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Navigation is available on a frame whose attitude error is at most this, degrees …
pub const AVAILABLE_ATT_DEG: f64 = 2.0;
/// … and whose position error is at most this share of the range, %.
pub const AVAILABLE_POS_PCT: f64 = 2.0;
/// The filter's initialisation: the first frame's true attitude turned by this, degrees, about
/// a random axis (seeded by the sequence's seed) …
pub const INIT_ATT_ERR_DEG: f64 = 1.0;
/// … and its position moved by this share of the range in a random direction; …
pub const INIT_POS_ERR_FRAC: f64 = 0.01;
/// … its angular rate (the true one, from the first two frames' truth) off by this, °/s, …
pub const INIT_RATE_ERR_DEG_S: f64 = 0.2;
/// … and its velocity off by this share of the range per second.
pub const INIT_VEL_ERR_FRAC_S: f64 = 0.005;

/// One source judged by the benchmark: an image stream or a baseline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stream {
    /// Baseline: no motion ([`crate::baseline`]).
    ZeroMotion,
    /// Baseline: ground-truth correspondences with [`crate::baseline::ORACLE_NOISE_PX`] noise.
    Oracle,
    /// The visible camera alone.
    Vis,
    /// The thermal camera alone, upscaled to the VIS grid with the core's bicubic.
    Tir,
    /// A core fusion (TIR upscaled with bicubic, as in flight).
    Fused(FuseConfig),
    /// The same, closed loop as on board: its skip window ([`SkipPolicy::Window`]) is the
    /// target box the stream's own navigation filter predicts for the frame
    /// ([`predicted_box`]).
    Loop(FuseConfig),
    /// The thermal camera alone from its raw counts (sequences rendered with a focal plane,
    /// `fusion render --raw-tir`), through the front end up to `stage`, then the AGC.
    Sensor(SensorStage),
    /// A core fusion whose thermal frame comes from the raw counts through the whole front end.
    SensorFused(FuseConfig),
    /// A core fusion in sequence mode (`fusion_nostd::sequence`): ADF's weights carried from the
    /// stream's previous frame.
    InSequence(FuseConfig),
}

/// How far a raw-sensor stream's thermal frame goes through the front end
/// (`fusion_nostd::thermal`) before the AGC (linear, 1–99.9 %).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorStage {
    /// No correction: the raw counts straight into the AGC.
    Raw,
    /// The factory's two-point tables only (no shutter, no bad pixels, no column filter).
    Nuc,
    /// The whole chain: the tables re-levelled at every shutter frame, bad pixels replaced,
    /// the column filter ([`SENSOR_COLUMN_SMOOTHING`]).
    Chain,
}

impl SensorStage {
    const ALL: [SensorStage; 3] = [SensorStage::Raw, SensorStage::Nuc, SensorStage::Chain];
}

/// Temporal smoothing shift of the raw-sensor chain's column filter (the estimate follows
/// over about 2⁴ frames).
pub const SENSOR_COLUMN_SMOOTHING: u8 = 3;

impl Stream {
    /// Whether the stream needs the raw thermal counts.
    pub fn needs_raw(&self) -> bool {
        matches!(self, Stream::Sensor(_) | Stream::SensorFused(_))
    }
}

/// Grid pixels added around the predicted box of a closed-loop stream, beyond its 3σ growth:
/// the background ring the front end and the contrast measure look at (8–24 px outside the
/// target).
pub const LOOP_MARGIN_PX: f64 = 24.0;

/// The target box a navigation filter predicts for the frame of `cam`'s size, as handed to the
/// fusion in a closed loop: the image of the target model's bounding sphere at the filter's pose
/// (which holds the target whatever its attitude), grown on each side by 3σ of the filter's
/// attitude and position in pixels (`f·(σ_θ + σ_p/range)`, the root of each block's trace) and
/// [`LOOP_MARGIN_PX`]. Empty when the sphere is predicted behind the camera or off the image.
pub fn predicted_box(model: &TargetModel<'_>, filter: &PoseFilter, intrinsics: &Camera) -> Rect {
    let predicted = camera_at(intrinsics, filter.attitude, filter.position());
    let Some((x0, y0, x1, y1)) = model.image_box(&predicted, 0.0) else { return Rect::default() };
    let c = filter.pose_covariance();
    let sigma_att = (c[(0, 0)] + c[(1, 1)] + c[(2, 2)]).max(0.0).sqrt();
    let sigma_pos = (c[(3, 3)] + c[(4, 4)] + c[(5, 5)]).max(0.0).sqrt();
    let range = filter.position().length().max(1e-3);
    let f = f64::from(predicted.focal_px);
    let grow = 3.0 * f * (sigma_att + sigma_pos / range) + LOOP_MARGIN_PX;
    let (w, h) = (f64::from(predicted.width), f64::from(predicted.height));
    let at = |v: u32, d: f64, hi: f64| (f64::from(v) + d).clamp(0.0, hi) as usize;
    Rect { x0: at(x0, -grow, w), y0: at(y0, -grow, h), x1: at(x1, grow, w), y1: at(y1, grow, h) }
}

/// The sources of the benchmark with their names: the baselines `zero-motion` and `oracle`,
/// then `vis`, `tir`, `adaptive`, `adaptive-skip`, `<method>-<variant>`,
/// `<method>-<variant>-skip` (scene skipping with the eclipse plan, [`SkipPolicy::All`]).
pub fn streams() -> Vec<(String, Stream)> {
    let mut out = vec![
        ("zero-motion".to_string(), Stream::ZeroMotion),
        ("oracle".to_string(), Stream::Oracle),
        ("vis".to_string(), Stream::Vis),
        ("tir".to_string(), Stream::Tir),
    ];
    for skip in [SkipPolicy::None, SkipPolicy::All] {
        out.push((
            if skip == SkipPolicy::None { "adaptive" } else { "adaptive-skip" }.to_string(),
            Stream::Fused(FuseConfig {
                rescale: RescalePolicy::TirUp,
                method: Method::Adaptive(AdaptiveParams::default()),
                skip,
                ..FuseConfig::default()
            }),
        ));
    }
    // Closed loop: the adaptive method and each method's flight variant.
    for method in Method::all().into_iter().filter(|m| m.variant() != Some(fusion_nostd::Variant::Classic)) {
        out.push((
            format!("{}-loop", method.name()),
            Stream::Loop(FuseConfig { rescale: RescalePolicy::TirUp, method, ..FuseConfig::default() }),
        ));
    }
    // The raw thermal sensor (sequences with `tir_raw/`): each front-end stage alone, and the
    // adaptive fusion on the corrected chain.
    for (name, stage) in ["tir-raw", "tir-nuc", "tir-chain"].into_iter().zip(SensorStage::ALL) {
        out.push((name.to_string(), Stream::Sensor(stage)));
    }
    out.push((
        "adaptive-chain".to_string(),
        Stream::SensorFused(FuseConfig {
            rescale: RescalePolicy::TirUp,
            method: Method::Adaptive(AdaptiveParams::default()),
            ..FuseConfig::default()
        }),
    ));
    // In sequence mode (on request: SEQUENCE_SOURCES).
    let (flight, classic) = (fusion_nostd::Variant::Flight, fusion_nostd::Variant::Classic);
    for (name, kind, variant, skip) in [
        ("adf-flight-seq", "adf", flight, SkipPolicy::None),
        ("adf-classic-seq", "adf", classic, SkipPolicy::None),
        ("adf-flight-seq-skip", "adf", flight, SkipPolicy::All),
        ("tsifsd-flight-seq-skip", "tsifsd", flight, SkipPolicy::All),
        ("ifevip-flight-seq-skip", "ifevip", flight, SkipPolicy::All),
        ("adaptive-seq-skip", "adaptive", flight, SkipPolicy::All),
    ] {
        let method = Method::named(kind, variant).unwrap_or_default();
        out.push((
            name.to_string(),
            Stream::InSequence(FuseConfig {
                rescale: RescalePolicy::TirUp,
                method,
                skip,
                ..FuseConfig::default()
            }),
        ));
    }
    for skip in [SkipPolicy::None, SkipPolicy::All] {
        for method in Method::all().into_iter().filter(|m| m.variant().is_some()) {
            let name = if skip == SkipPolicy::None {
                method.name().to_string()
            } else {
                format!("{}-skip", method.name())
            };
            out.push((
                name,
                Stream::Fused(FuseConfig {
                    rescale: RescalePolicy::TirUp,
                    method,
                    skip,
                    ..FuseConfig::default()
                }),
            ));
        }
    }
    out
}

/// The baselines' names: always run, whatever `--sources` says.
pub const BASELINES: [&str; 2] = ["zero-motion", "oracle"];

/// The sources that run only when named (`fusion navbench --sequence-mode` names them): ADF in
/// sequence mode, whole frame and with scene skipping (a crop's weights carried), and every
/// method skipping in a sequence (the skip windows joined over the last frames,
/// `fusion_nostd::sequence::SequenceParams::window_frames`).
pub const SEQUENCE_SOURCES: [&str; 6] = [
    "adf-flight-seq",
    "adf-classic-seq",
    "adf-flight-seq-skip",
    "tsifsd-flight-seq-skip",
    "ifevip-flight-seq-skip",
    "adaptive-seq-skip",
];

/// The sources named in `only` (every source but [`SEQUENCE_SOURCES`] when `None`) and the baselines, in [`streams`] order.
pub fn selected(only: Option<&[String]>) -> Result<Vec<(String, Stream)>> {
    let all = streams();
    let Some(only) = only else {
        return Ok(all.into_iter().filter(|(s, _)| !SEQUENCE_SOURCES.contains(&s.as_str())).collect());
    };
    if let Some(bad) = only.iter().find(|n| !all.iter().any(|(s, _)| s == *n)) {
        let names: Vec<&str> = all.iter().map(|(s, _)| s.as_str()).collect();
        anyhow::bail!("unknown source '{bad}'; the sources are {}", names.join(", "));
    }
    Ok(all.into_iter().filter(|(s, _)| only.contains(s) || BASELINES.contains(&s.as_str())).collect())
}

/// What one source gave on one frame.
#[derive(Debug, Clone, Serialize)]
pub struct FrameResult {
    /// Sequence name.
    pub sequence: String,
    /// The sequence's noise seed.
    pub seed: u64,
    /// Frame index.
    pub frame: usize,
    /// Illumination phase.
    pub phase: Phase,
    /// Source name.
    pub source: String,
    /// Target contrast-to-noise ratio (NaN for the baselines).
    pub cnr: f64,
    /// Corners on the target.
    pub target_features: usize,
    /// Model-based front end: tracks carried into this frame (the oracle: its
    /// correspondences).
    pub tracks: usize,
    /// PnP-RANSAC inliers among them.
    pub inliers: usize,
    /// Rotation error of the frame-to-frame pose (between this frame's and the previous
    /// frame's measured poses), degrees (NaN when lost or first).
    pub rot_err_deg: f64,
    /// Translation-direction error, degrees (NaN when lost, first, or zero-motion).
    pub trans_dir_err_deg: f64,
    /// No frame-to-frame pose: either frame had no measured pose (false on the first frame).
    pub lost: bool,
    /// Filter: attitude error, degrees.
    pub att_err_deg: f64,
    /// Filter: position error, % of the range.
    pub pos_err_pct: f64,
    /// Filter: error of the target's centre relative to the camera, in the camera's frame, %
    /// of the range ([`relative_position`]).
    pub rel_pos_err_pct: f64,
    /// Filter: 3σ of the attitude error (largest axis), degrees.
    pub att_3sigma_deg: f64,
    /// Filter: 3σ of the position error (largest axis), % of the range.
    pub pos_3sigma_pct: f64,
    /// Filter: normalised estimation error squared of the pose (6 degrees of freedom).
    pub nees: f64,
    /// Navigation available: attitude and position errors within [`AVAILABLE_ATT_DEG`] and
    /// [`AVAILABLE_POS_PCT`].
    pub available: bool,
    /// The same with the relative position's error in place of the position's.
    pub available_rel: bool,
    /// On the first frame of a run of unavailable frames: frames until navigation is
    /// available again (to the end of the sequence when it never is); NaN elsewhere.
    pub reacquire_frames: f64,
    /// Pairwise front end: BRIEF matches with the previous frame.
    pub pairwise_tracks: usize,
    /// Pairwise front end: PnP-RANSAC inliers among them.
    pub pairwise_inliers: usize,
    /// Pairwise front end: rotation error, degrees (NaN when lost or first).
    pub pairwise_rot_err_deg: f64,
    /// Pairwise front end: translation-direction error, degrees.
    pub pairwise_trans_dir_err_deg: f64,
    /// Pairwise front end: lost on this pair.
    pub pairwise_lost: bool,
    /// Skip streams: fraction of the target pixels of both cameras' masks inside the window
    /// the method computed (1 for the others).
    pub target_coverage: f64,
    /// Skip streams: the computed window's share of the frame (1 for the others).
    pub window_frac: f64,
    /// Offset rigs, streams using the thermal frame: the median distance over the VIS target
    /// pixels between where their surface point is in the thermal frame and where the
    /// registration read it, VIS px ([`crate::registration::misregistration`]; NaN otherwise).
    pub misregistration_px: f64,
    /// The same, 95th percentile over the target pixels.
    pub misregistration_p95_px: f64,
}

impl FrameResult {
    fn new(sequence: &str, seed: u64, frame: usize, phase: Phase, source: &str) -> FrameResult {
        FrameResult {
            sequence: sequence.to_string(),
            seed,
            frame,
            phase,
            source: source.to_string(),
            cnr: f64::NAN,
            target_features: 0,
            tracks: 0,
            inliers: 0,
            rot_err_deg: f64::NAN,
            trans_dir_err_deg: f64::NAN,
            lost: false,
            att_err_deg: f64::NAN,
            pos_err_pct: f64::NAN,
            rel_pos_err_pct: f64::NAN,
            att_3sigma_deg: f64::NAN,
            pos_3sigma_pct: f64::NAN,
            nees: f64::NAN,
            available: false,
            available_rel: false,
            reacquire_frames: f64::NAN,
            pairwise_tracks: 0,
            pairwise_inliers: 0,
            pairwise_rot_err_deg: f64::NAN,
            pairwise_trans_dir_err_deg: f64::NAN,
            pairwise_lost: false,
            target_coverage: 1.0,
            window_frac: 1.0,
            misregistration_px: f64::NAN,
            misregistration_p95_px: f64::NAN,
        }
    }
}

/// Summary of one source in one phase (the `navbench.json` shape; over several seeds each
/// figure becomes `{"mean", "sd"}`).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PhaseSummary {
    /// Mean CNR over the phase's frames (`null` for the baselines).
    pub cnr: Option<f64>,
    /// Mean target features per frame.
    pub target_features: f64,
    /// Model-based front end: mean tracks per frame pair.
    pub tracks: f64,
    /// Mean inlier ratio (inliers / tracks; 0 where there were no tracks).
    pub inlier_ratio: f64,
    /// Median frame-to-frame rotation error over the pairs not lost, degrees (`null` when all
    /// were lost).
    pub rot_err_deg_median: Option<f64>,
    /// Median translation-direction error over the pairs not lost, degrees.
    pub trans_dir_err_deg_median: Option<f64>,
    /// Fraction of the phase's frame pairs without a frame-to-frame pose.
    pub lost_frac: f64,
    /// Share of the frames on which navigation is available.
    pub availability: f64,
    /// Share of the frames on which it is available by the relative position
    /// ([`FrameResult::available_rel`]).
    pub availability_rel: f64,
    /// RMS attitude error of the filter, degrees.
    pub att_rms_deg: f64,
    /// RMS position error of the filter, % of the range.
    pub pos_rms_pct: f64,
    /// RMS error of the relative position, % of the range.
    pub rel_pos_rms_pct: f64,
    /// Mean NEES of the filter's pose (6 for a consistent filter).
    pub nees: Option<f64>,
    /// Mean frames to re-acquire after a loss that starts in this phase (`null`: no loss).
    pub reacquire_frames: Option<f64>,
    /// Pairwise front end: mean matches per frame pair.
    pub pairwise_tracks: f64,
    /// Pairwise front end: mean inlier ratio.
    pub pairwise_inlier_ratio: f64,
    /// Pairwise front end: median rotation error, degrees.
    pub pairwise_rot_err_deg_median: Option<f64>,
    /// Pairwise front end: median translation-direction error, degrees.
    pub pairwise_trans_dir_err_deg_median: Option<f64>,
    /// Pairwise front end: fraction of the pairs lost.
    pub pairwise_lost_frac: f64,
    /// Offset rigs: the median over the frames of each frame's median misregistration, VIS
    /// px (`null` on aligned rigs and for VIS).
    pub misregistration_px_median: Option<f64>,
    /// Offset rigs: the 95th percentile over the frames of each frame's 95th-percentile
    /// misregistration, VIS px.
    pub misregistration_px_p95: Option<f64>,
    /// Frames in the phase (pairs are one fewer where the sequence starts in it).
    pub frames: usize,
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) })
}

/// The `q` quantile (nearest rank) of the finite values; `None` without one.
pub(crate) fn quantile(mut v: Vec<f64>, q: f64) -> Option<f64> {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[((v.len() - 1) as f64 * q).round() as usize])
}

fn mean_finite(v: impl Iterator<Item = f64>) -> Option<f64> {
    let (mut n, mut s) = (0usize, 0.0);
    for x in v.filter(|x| x.is_finite()) {
        n += 1;
        s += x;
    }
    (n > 0).then(|| s / n as f64)
}

/// Summarises the results of one source in one phase.
pub fn summarise(rows: &[&FrameResult]) -> PhaseSummary {
    let pairs: Vec<&&FrameResult> = rows.iter().filter(|r| r.frame > 0).collect();
    let n = rows.len().max(1) as f64;
    let np = pairs.len().max(1) as f64;
    let ratio = |a: usize, b: usize| if b > 0 { a as f64 / b as f64 } else { 0.0 };
    let rms = |f: &dyn Fn(&FrameResult) -> f64| (rows.iter().map(|r| f(r).powi(2)).sum::<f64>() / n).sqrt();
    PhaseSummary {
        cnr: mean_finite(rows.iter().map(|r| r.cnr)),
        target_features: rows.iter().map(|r| r.target_features as f64).sum::<f64>() / n,
        tracks: pairs.iter().map(|r| r.tracks as f64).sum::<f64>() / np,
        inlier_ratio: pairs.iter().map(|r| ratio(r.inliers, r.tracks)).sum::<f64>() / np,
        rot_err_deg_median: median(pairs.iter().filter(|r| !r.lost).map(|r| r.rot_err_deg).collect()),
        trans_dir_err_deg_median: median(
            pairs.iter().filter(|r| !r.lost).map(|r| r.trans_dir_err_deg).collect(),
        ),
        lost_frac: pairs.iter().filter(|r| r.lost).count() as f64 / np,
        availability: rows.iter().filter(|r| r.available).count() as f64 / n,
        availability_rel: rows.iter().filter(|r| r.available_rel).count() as f64 / n,
        att_rms_deg: rms(&|r| r.att_err_deg),
        pos_rms_pct: rms(&|r| r.pos_err_pct),
        rel_pos_rms_pct: rms(&|r| r.rel_pos_err_pct),
        nees: mean_finite(rows.iter().map(|r| r.nees)),
        reacquire_frames: mean_finite(rows.iter().map(|r| r.reacquire_frames)),
        pairwise_tracks: pairs.iter().map(|r| r.pairwise_tracks as f64).sum::<f64>() / np,
        pairwise_inlier_ratio: pairs
            .iter()
            .map(|r| ratio(r.pairwise_inliers, r.pairwise_tracks))
            .sum::<f64>()
            / np,
        pairwise_rot_err_deg_median: median(
            pairs.iter().filter(|r| !r.pairwise_lost).map(|r| r.pairwise_rot_err_deg).collect(),
        ),
        pairwise_trans_dir_err_deg_median: median(
            pairs.iter().filter(|r| !r.pairwise_lost).map(|r| r.pairwise_trans_dir_err_deg).collect(),
        ),
        pairwise_lost_frac: pairs.iter().filter(|r| r.pairwise_lost).count() as f64 / np,
        misregistration_px_median: median(rows.iter().map(|r| r.misregistration_px).collect()),
        misregistration_px_p95: quantile(rows.iter().map(|r| r.misregistration_p95_px).collect(), 0.95),
        frames: rows.len(),
    }
}

/// The contrast-to-noise ratio of `img` on `mask` against the ring `ring`.
pub fn cnr(img: &[u8], mask: &[bool], ring: &[bool]) -> f64 {
    let stats = |sel: &[bool]| {
        let (mut n, mut s, mut s2) = (0f64, 0f64, 0f64);
        for (&v, &m) in img.iter().zip(sel) {
            if m {
                let v = f64::from(v);
                n += 1.0;
                s += v;
                s2 += v * v;
            }
        }
        if n == 0.0 {
            return (0.0, 0.0);
        }
        let mean = s / n;
        (mean, (s2 / n - mean * mean).max(0.0).sqrt())
    };
    let (mt, _) = stats(mask);
    let (mb, sb) = stats(ring);
    (mt - mb).abs() / sb.max(0.5)
}

/// The background ring of a mask: between `inner` and `outer` pixels (Chebyshev) outside it.
pub fn ring(mask: &[bool], w: usize, h: usize, inner: usize, outer: usize) -> Vec<bool> {
    let a = grow_mask(mask, w, h, inner);
    let b = grow_mask(mask, w, h, outer);
    a.iter().zip(&b).map(|(&a, &b)| b && !a).collect()
}

/// One frame of a sequence, loaded: inputs, the masks every stream is measured on (computed
/// once per frame, not per stream) and the camera.
struct FrameData {
    vis: Gray<u8>,
    tir: Gray<u8>,
    /// The raw thermal counts through each [`SensorStage`] and the AGC (sequences with a
    /// focal plane, when a raw-sensor stream runs).
    sensor: Option<[Gray<u8>; 3]>,
    /// The VIS target mask (CNR's target).
    vis_mask: Vec<bool>,
    /// The VIS mask grown by 3 px: where features count as on the target.
    feature_mask: Vec<bool>,
    /// The CNR background ring, 8–24 px outside the VIS mask.
    ring_mask: Vec<bool>,
    /// Target pixels of either camera (TIR mask mapped to the VIS grid): the skip coverage.
    either_mask: Vec<bool>,
    camera: Camera,
    /// The thermal camera (the VIS camera's pose and the study's intrinsics on an aligned pair;
    /// the rig's otherwise).
    tir_camera: Camera,
    phase: Phase,
    /// Time of the frame, s.
    time_s: f64,
    /// Range to the target, m.
    range_m: f64,
}

/// Largest camera size (square, px) a manifest may give.
pub const MAX_CAMERA_SIZE: u32 = 16384;
/// Host memory per VIS pixel per frame held by a run: the frames, masks and rendered depth of
/// every frame (≈ 14 B, measured 1.8 GB peak for 120 frames at 1024²) and the streams'
/// working images beside them.
pub const BYTES_PER_PIXEL_FRAME: u64 = 16;

/// Refuses a manifest whose cameras cannot be run: sizes outside 16 px to
/// [`MAX_CAMERA_SIZE`], or a run of `n` frames whose memory exceeds `--max-memory`.
fn check_cameras(dir: &Path, m: &SequenceManifest, n: usize) -> Result<()> {
    let manifest = dir.join("manifest.json");
    for (name, size) in [("vis_camera", m.vis_camera.size), ("tir_camera", m.tir_camera.size)] {
        if !(16..=MAX_CAMERA_SIZE).contains(&size) {
            anyhow::bail!("{}: {name}.size {size} is outside 16 to {MAX_CAMERA_SIZE} px", manifest.display());
        }
    }
    let px = u64::from(m.vis_camera.size).pow(2) * n as u64;
    fusion_io::memory::check(
        &manifest.display().to_string(),
        "judging",
        fusion_io::memory::estimate(px, BYTES_PER_PIXEL_FRAME),
    )
}

/// Loads one of a frame's images and refuses it unless it is `size`² as the manifest says.
fn load_sized(path: &Path, size: u32) -> Result<Gray<u8>> {
    let img = load_gray_u8(path, ColorPolicy::Refuse)?;
    if img.width != size as usize || img.height != size as usize {
        anyhow::bail!("{}: {}×{}, the manifest says {size}×{size}", path.display(), img.width, img.height);
    }
    Ok(img)
}

fn load_frame(
    dir: &Path,
    m: &SequenceManifest,
    i: usize,
    clean: bool,
    rig: Option<&Rig>,
) -> Result<FrameData> {
    let f = &m.frames[i];
    let pick = |noisy: &String, clean_file: &Option<String>| -> Result<std::path::PathBuf> {
        if !clean {
            return Ok(dir.join(noisy));
        }
        let rel = clean_file.as_ref().context("the sequence was rendered without clean frames")?;
        Ok(dir.join(rel))
    };
    let (vs, ts) = (m.vis_camera.size, m.tir_camera.size);
    let vis = load_sized(&pick(&f.files.vis, &f.files.vis_clean)?, vs)?;
    let tir = load_sized(&pick(&f.files.tir, &f.files.tir_clean)?, ts)?;
    let vis_mask: Vec<bool> =
        load_sized(&dir.join(&f.files.vis_mask), vs)?.data.iter().map(|&v| v > 127).collect();
    let tir_mask = load_sized(&dir.join(&f.files.tir_mask), ts)?;
    let (camera, tir_camera) = match rig {
        Some(rig) => render_host::rig::cameras(rig, f.pose())?,
        None => (Camera::study(vs, f.pose()), Camera::study(ts, f.pose())),
    };
    let (w, h) = (vis.width, vis.height);
    let either_mask = match rig {
        // The thermal mask registered at the target centre's true depth.
        Some(rig) => {
            let depth = f64::from(camera.pose.rotation.transpose().mul_vec3(-camera.pose.position).z);
            let reg = on_vis_grid(&tir_mask, w, h, Some((rig, depth)))?;
            vis_mask.iter().zip(&reg.data).map(|(&v, &t)| v || t > 127).collect()
        }
        None => {
            let (sx, sy) = (tir_mask.width as f64 / w as f64, tir_mask.height as f64 / h as f64);
            (0..w * h)
                .map(|k| {
                    let (x, y) = ((k % w) as f64 * sx, (k / w) as f64 * sy);
                    vis_mask[k]
                        || tir_mask
                            .at((x as usize).min(tir_mask.width - 1), (y as usize).min(tir_mask.height - 1))
                            > 127
                })
                .collect()
        }
    };
    Ok(FrameData {
        feature_mask: grow_mask(&vis_mask, w, h, 3),
        ring_mask: ring(&vis_mask, w, h, 8, 24),
        either_mask,
        vis,
        tir,
        sensor: None,
        vis_mask,
        camera,
        tir_camera,
        phase: f.phase,
        time_s: f.time_s,
        range_m: f64::from(f.range_m),
    })
}

/// A raw-sensor stream's thermal frame.
fn sensor_frame(fd: &FrameData, stage: SensorStage) -> Result<&Gray<u8>> {
    let frames = fd.sensor.as_ref().context("the raw thermal frames were not prepared")?;
    Ok(&frames[stage as usize])
}

/// The raw thermal counts of the first `n` frames through each [`SensorStage`] and the AGC, in
/// order (the chain carries its state from frame to frame: the offsets re-levelled at each
/// shutter frame, the column filter's smoothed estimate). The column filter's threshold comes
/// from the first frame ([`fusion_engine::thermal::column_threshold`] after the tables and the
/// bad pixels).
pub fn sensor_frames(dir: &Path, m: &SequenceManifest, n: usize) -> Result<Vec<[Gray<u8>; 3]>> {
    use fusion_engine::thermal::{COLUMN_RADIUS, Column, ThermalChain, column_threshold};
    use fusion_nostd::thermal::ColumnParams;
    let read = |rel: &str| -> Result<Gray<u16>> {
        let p = dir.join(rel);
        match fusion_io::load_image(&p, ColorPolicy::Refuse)? {
            fusion_io::GrayInput::U16(g) => Ok(g),
            fusion_io::GrayInput::U8(_) => anyhow::bail!("{}: raw counts must be 16-bit", p.display()),
        }
    };
    let (nuc, bad) = fusion_engine::thermal::load(
        m.nuc.as_ref().map(|p| dir.join(p)).as_deref(),
        m.bad_pixels.as_ref().map(|p| dir.join(p)).as_deref(),
    )?;
    let first = read(m.frames[0].files.tir_raw.as_deref().context("no raw frame")?)?;
    let threshold = column_threshold(&ThermalChain::new(nuc.clone(), bad.clone(), None)?.correct(&first)?);
    let column = ColumnParams { threshold, radius: COLUMN_RADIUS, smoothing: SENSOR_COLUMN_SMOOTHING };
    let mut nuc_only = ThermalChain::new(nuc.clone(), None, None)?;
    let mut chain = ThermalChain::new(nuc, bad, Some(Column::Params(column)))?;
    let agc = |counts: &Gray<u16>| {
        fusion_engine::agc::map_counts(
            &mut fusion_engine::agc::fresh(),
            counts,
            &fusion_nostd::AgcParams::linear(),
        )
    };
    let mut out = Vec::with_capacity(n);
    for f in m.frames.iter().take(n) {
        let raw = read(f.files.tir_raw.as_deref().context("no raw frame")?)?;
        if let Some(sh) = &f.files.tir_shutter {
            chain.shutter(&read(sh)?)?;
        }
        out.push([agc(&raw)?, agc(&nuc_only.correct(&raw)?)?, agc(&chain.correct(&raw)?)?]);
    }
    Ok(out)
}

/// A stream's image of one frame (VIS grid).
struct StreamImage {
    image: Gray<u8>,
    /// The region holding the scene: the whole frame, or a skipped fusion's window (outside it
    /// the core writes its background value). On board the navigation knows it too: it is the
    /// window the fusion reports (or the one the navigation handed in).
    valid: Region,
    /// Share of the target pixels (both cameras' masks) inside `valid`.
    coverage: f64,
    /// `valid`'s share of the frame.
    window_frac: f64,
}

impl StreamImage {
    fn whole(image: Gray<u8>) -> StreamImage {
        let valid = Region::whole(image.width as u32, image.height as u32);
        StreamImage { image, valid, coverage: 1.0, window_frac: 1.0 }
    }
}

/// The stream's image of one frame (VIS grid); `window`: a closed-loop stream's predicted box;
/// `through`: an offset rig's thermal frame is registered through it at that range before it is
/// used (`None`: rescaled, as for aligned cameras).
fn stream_image(
    stream: &Stream,
    fd: &FrameData,
    window: Rect,
    through: Option<(&Rig, f64)>,
    sequence: &mut Sequence,
) -> Result<StreamImage> {
    let (w, h) = (fd.vis.width, fd.vis.height);
    let p = &match *stream {
        Stream::ZeroMotion | Stream::Oracle => anyhow::bail!("a baseline has no image"),
        Stream::Vis => return Ok(StreamImage::whole(fd.vis.clone())),
        Stream::Tir => return Ok(StreamImage::whole(on_vis_grid(&fd.tir, w, h, through)?)),
        Stream::Sensor(stage) => {
            return Ok(StreamImage::whole(on_vis_grid(sensor_frame(fd, stage)?, w, h, through)?));
        }
        Stream::Fused(p) | Stream::SensorFused(p) | Stream::InSequence(p) => p,
        Stream::Loop(p) => FuseConfig { skip: SkipPolicy::Window(window), ..p },
    };
    let tir = match stream {
        Stream::SensorFused(_) => sensor_frame(fd, SensorStage::Chain)?,
        _ => &fd.tir,
    };
    // An offset rig's frame registered onto the visible grid; an aligned one as it is (the
    // core rescales it).
    let registered = through.map(|_| on_vis_grid(tir, w, h, through)).transpose()?;
    let tir = registered.as_ref().unwrap_or(tir);
    let mut out = Gray::<u8>::new(w, h);
    let mut scratch = CoreScratch::new(p.scratch_pixels((w, h), (tir.width, tir.height))?);
    let (vis, tir, mut scratch) = (fd.vis.view()?, tir.view()?, scratch.view_mut());
    let report = match stream {
        Stream::InSequence(_) => {
            fusion_nostd::fuse_in_sequence(vis, tir, out.view_mut()?, &mut scratch, p, sequence)?
        }
        _ => fusion_nostd::fuse(vis, tir, out.view_mut()?, &mut scratch, p)?,
    };
    // The window whose pixels are the method's output: the ROI for a crop (the background value
    // is written outside it), the computed window otherwise.
    let win = if report.skip.taken.contains(Skips::CROP) { report.skip.roi } else { report.skip.computed };
    let (mut inside, mut total) = (0usize, 0usize);
    for (k, _) in fd.either_mask.iter().enumerate().filter(|(_, m)| **m) {
        total += 1;
        inside += usize::from(win.contains(k % w, k / w));
    }
    let coverage = if total == 0 { 1.0 } else { inside as f64 / total as f64 };
    let valid = Region { x0: win.x0 as u32, y0: win.y0 as u32, x1: win.x1 as u32, y1: win.y1 as u32 };
    Ok(StreamImage { image: out, valid, coverage, window_frac: win.area() as f64 / (w * h) as f64 })
}

/// Per-frame state the next frame's pairwise matching needs: features with their 3D points.
struct Tracked {
    features: Vec<Feature>,
    /// Camera-frame 3D point of each feature (from the rendered depth), when it sits on the target.
    points: Vec<Option<DVec3>>,
}

/// The relative pose between two camera poses given as (attitude camera → target, position).
fn relative(a: (DQuat, DVec3), b: (DQuat, DVec3)) -> RelativePose {
    RelativePose::between(
        render_host::glam::DMat3::from_quat(a.0),
        a.1,
        render_host::glam::DMat3::from_quat(b.0),
        b.1,
    )
}

/// The filter started on the first frame's true state perturbed by [`INIT_ATT_ERR_DEG`],
/// [`INIT_POS_ERR_FRAC`], [`INIT_RATE_ERR_DEG_S`] and [`INIT_VEL_ERR_FRAC_S`] in directions
/// drawn from `seed` (the same for every source of a run): the hand-over from acquisition,
/// which is out of scope. The true rate and velocity (of `centre`, the target model's
/// reference point, in the camera frame) are the first two frames' differences.
fn initial_filter(first: &FrameData, second: &FrameData, centre: DVec3, seed: u64) -> PoseFilter {
    let mut rng = SplitMix64::new(mix64(seed ^ 0x1A17_0000));
    let (q0, p0) = true_pose(&first.camera);
    let (q1, p1) = true_pose(&second.camera);
    let dt = (second.time_s - first.time_s).max(1e-9);
    let range = first.range_m;
    let (att, pos) = (INIT_ATT_ERR_DEG.to_radians(), INIT_POS_ERR_FRAC * range);
    let (rate, vel) = (INIT_RATE_ERR_DEG_S.to_radians(), INIT_VEL_ERR_FRAC_S * range);
    let params = FilterParams { initial_rate_sd: rate, initial_velocity_sd: vel, ..FilterParams::default() };
    let mut f = PoseFilter::new(
        q0 * DQuat::from_scaled_axis(unit_vector(&mut rng) * att),
        p0 + unit_vector(&mut rng) * pos,
        centre,
        (att, pos),
        params,
    );
    f.rate = rotation_vector(q0.inverse() * q1) / dt + unit_vector(&mut rng) * rate;
    let (t0, t1) = (relative_position(q0, p0, centre), relative_position(q1, p1, centre));
    f.target_velocity = (t1 - t0) / dt + unit_vector(&mut rng) * vel;
    f
}

/// Fills the filter's measures of `row` against the frame's truth; `centre` is the target
/// model's reference point (target frame).
fn score_filter(row: &mut FrameResult, filter: &PoseFilter, fd: &FrameData, centre: DVec3) {
    let (q, p) = true_pose(&fd.camera);
    let (ea, ep) = filter.error(q, p);
    let (a3, p3) = filter.three_sigma();
    row.att_err_deg = ea.length().to_degrees();
    row.pos_err_pct = 100.0 * ep.length() / fd.range_m;
    let rel = relative_position(filter.attitude, filter.position(), centre) - relative_position(q, p, centre);
    row.rel_pos_err_pct = 100.0 * rel.length() / fd.range_m;
    row.att_3sigma_deg = a3.to_degrees();
    row.pos_3sigma_pct = 100.0 * p3 / fd.range_m;
    row.nees = filter.nees(q, p);
    row.available = row.att_err_deg <= AVAILABLE_ATT_DEG && row.pos_err_pct <= AVAILABLE_POS_PCT;
    row.available_rel = row.att_err_deg <= AVAILABLE_ATT_DEG && row.rel_pos_err_pct <= AVAILABLE_POS_PCT;
}

/// Fills the frame-to-frame measures of `row` from two consecutive measured poses.
fn score_pair(
    row: &mut FrameResult,
    prev: Option<&PoseMeasurement>,
    cur: Option<&PoseMeasurement>,
    truth: &RelativePose,
) {
    match (prev, cur) {
        (Some(a), Some(b)) => {
            let rel = relative((a.attitude, a.position), (b.attitude, b.position));
            row.rot_err_deg = rel.rotation_error_deg(truth);
            row.trans_dir_err_deg = rel.translation_direction_error_deg(truth);
        }
        _ => row.lost = true,
    }
}

/// Marks, on the first frame of each run of unavailable frames, how many frames navigation
/// took to come back (to the end of the sequence when it never did).
fn mark_reacquisition(rows: &mut [FrameResult]) {
    let n = rows.len();
    let mut i = 0;
    while i < n {
        if rows[i].available {
            i += 1;
            continue;
        }
        let start = i;
        while i < n && !rows[i].available {
            i += 1;
        }
        rows[start].reacquire_frames = (i - start) as f64;
    }
}

/// Normalised image coordinates of the centre of pixel `(x, y)`.
fn pixel_centre(cam: &Camera, x: u32, y: u32) -> DVec2 {
    normalised(cam, f64::from(x) + 0.5, f64::from(y) + 0.5)
}

/// What one source carries from frame to frame.
struct StreamState {
    filter: PoseFilter,
    tracker: ModelTracker,
    /// The BRIEF test pattern of the pairwise front end.
    pairs: Vec<imageproc::binary_descriptors::brief::TestPair>,
    prev_pairwise: Option<Tracked>,
    /// The previous frame's measured pose (the frame-to-frame measures).
    prev_measurement: Option<PoseMeasurement>,
    /// Offset rigs: the range the registration last used — the filter's, held while the
    /// filter predicts the target behind the camera or closer than [`MIN_REGISTRATION_RANGE_M`].
    registration_range: f64,
    /// A sequence-mode stream's carried weights.
    sequence: Sequence,
}

/// The registration keeps its last range when the filter predicts the target nearer than this,
/// m (behind the camera when it has diverged).
pub const MIN_REGISTRATION_RANGE_M: f64 = 0.5;

/// Everything a source's run over a sequence reads.
struct SequenceRun<'a> {
    name: &'a str,
    seed: u64,
    data: &'a [FrameData],
    depths: &'a [Vec<Option<f32>>],
    model: TargetModel<'a>,
    edges: &'a crate::edges::ModelEdges,
    /// The offset rig the sequence was rendered through, if any.
    rig: Option<&'a Rig>,
    /// How its thermal frames reach the visible grid.
    registration: Registration,
}

impl SequenceRun<'_> {
    /// The true relative pose from frame `i − 1` to frame `i`.
    fn truth_pair(&self, i: usize) -> RelativePose {
        relative(true_pose(&self.data[i - 1].camera), true_pose(&self.data[i].camera))
    }

    /// One source over the whole sequence, frames in order.
    fn source(&self, source: &str, stream: &Stream) -> Result<Vec<FrameResult>> {
        let mut rows = Vec::with_capacity(self.data.len());
        let mut st = StreamState {
            filter: initial_filter(&self.data[0], &self.data[1], self.model.centre(), self.seed),
            tracker: ModelTracker::new(TrackerParams::default(), mix64(self.seed ^ 0x7EAC)),
            pairs: test_pairs(),
            prev_pairwise: None,
            prev_measurement: None,
            registration_range: 0.0,
            sequence: Sequence::default(),
        };
        // The registration's first range: the initial filter's.
        let first = camera_at(&self.data[0].camera, st.filter.attitude, st.filter.position());
        st.registration_range = self.model.centre_in_camera(&first).z;
        if matches!(stream, Stream::ZeroMotion) {
            // No motion: the estimate stays where it started.
            st.filter.rate = DVec3::ZERO;
            st.filter.target_velocity = DVec3::ZERO;
        }
        for (i, fd) in self.data.iter().enumerate() {
            let mut row = FrameResult::new(self.name, self.seed, i, fd.phase, source);
            if i > 0 {
                st.filter.predict(fd.time_s - self.data[i - 1].time_s);
            }
            match stream {
                Stream::ZeroMotion => {
                    if i > 0 {
                        row.rot_err_deg =
                            RelativePose { rotation: DQuat::IDENTITY, translation: DVec3::ZERO }
                                .rotation_error_deg(&self.truth_pair(i));
                    }
                }
                Stream::Oracle => {
                    if let Some(m) = self.oracle_frame(&mut row, i) {
                        st.filter.update(&m);
                    }
                }
                _ => self
                    .image_frame(&mut row, i, stream, &mut st)
                    .with_context(|| format!("{} frame {i} {source}", self.name))?,
            }
            score_filter(&mut row, &st.filter, fd, self.model.centre());
            rows.push(row);
        }
        mark_reacquisition(&mut rows);
        Ok(rows)
    }

    /// The oracle on frame `i`: frame to frame, frame i − 1's surface points seen in frame i;
    /// the pose, this frame's surface points in the target frame. Returns the pose measurement.
    fn oracle_frame(&self, row: &mut FrameResult, i: usize) -> Option<PoseMeasurement> {
        let cam = &self.data[i].camera;
        let f = f64::from(cam.focal_px);
        let mut rng = SplitMix64::new(mix64(self.seed ^ (i as u64) << 20 ^ 0x0AC1E));
        if i > 0 {
            let prev = &self.data[i - 1].camera;
            let pts = surface_points(prev, &self.depths[i - 1]);
            let truth = self.truth_pair(i);
            let (q1, p1) = true_pose(prev);
            let to_target = |x: DVec3| render_host::glam::DMat3::from_quat(q1) * x + p1;
            let (p3, p2) = observe(&pts, &truth, f, ORACLE_NOISE_PX, &mut rng, |x| {
                self.model.visible(cam, to_target(x))
            });
            if let Some((_, Some(refined))) = estimate(&p3, &p2, f, i as u64) {
                row.rot_err_deg = refined.pose.rotation_error_deg(&truth);
                row.trans_dir_err_deg = refined.pose.translation_direction_error_deg(&truth);
            } else {
                row.lost = true;
            }
        }
        let (q, p) = true_pose(cam);
        let rot = render_host::glam::DMat3::from_quat(q);
        let pts: Vec<DVec3> = surface_points(cam, &self.depths[i]).into_iter().map(|x| rot * x + p).collect();
        let (p3, p2) = observe(&pts, &target_to_camera(cam), f, ORACLE_NOISE_PX, &mut rng, |_| true);
        row.tracks = p3.len();
        estimate(&p3, &p2, f, (i as u64) ^ 0x5EED).and_then(|(found, refined)| {
            row.inliers = found.inliers;
            refined.map(|r| r.measurement())
        })
    }

    /// An image stream on frame `i`: the pairwise measures, then the model-based front end's
    /// pose into the filter, the outline's position, new features at the updated estimate, and
    /// the frame-to-frame pose between this frame's and the previous frame's measurements.
    fn image_frame(
        &self,
        row: &mut FrameResult,
        i: usize,
        stream: &Stream,
        st: &mut StreamState,
    ) -> Result<()> {
        let fd = &self.data[i];
        let cam = &fd.camera;
        // Closed loop: the box this frame's prediction puts the target in.
        let window = match stream {
            Stream::Loop(_) => predicted_box(&self.model, &st.filter, cam),
            _ => Rect::default(),
        };
        let predicted = camera_at(cam, st.filter.attitude, st.filter.position());
        // An offset rig: the thermal frame registered at the range this frame's prediction
        // (or the truth) puts the target centre at, along the VIS axis.
        let through = match (self.rig, self.registration) {
            (Some(rig), Registration::Filter) => {
                let range = self.model.centre_in_camera(&predicted).z;
                if range.is_finite() && range >= MIN_REGISTRATION_RANGE_M {
                    st.registration_range = range;
                }
                Some((rig, st.registration_range))
            }
            (Some(rig), Registration::Truth) => Some((rig, self.model.centre_in_camera(cam).z)),
            _ => None,
        };
        if self.rig.is_some()
            && !matches!(stream, Stream::Vis)
            && let Some((median, p95)) = misregistration(cam, &fd.tir_camera, &self.depths[i], through)
        {
            row.misregistration_px = median;
            row.misregistration_p95_px = p95;
        }
        let StreamImage { image: img, valid, coverage, window_frac } =
            stream_image(stream, fd, window, through, &mut st.sequence)?;
        row.target_coverage = coverage;
        row.window_frac = window_frac;
        row.cnr = cnr(&img.data, &fd.vis_mask, &fd.ring_mask);
        let gray =
            GrayImage::from_raw(img.width as u32, img.height as u32, img.data).context("image size")?;
        st.prev_pairwise = Some(self.pairwise(row, &gray, &st.pairs, st.prev_pairwise.as_ref(), i));
        let smoothed = smooth(&gray);
        let fe = st.tracker.track(&smoothed, valid, &predicted, &self.model, i as u64);
        row.tracks = fe.tracked;
        row.inliers = fe.inliers;
        // The tracks' pose is scored frame to frame, not fed to the filter: its 3D points come
        // from the model at the estimate, so it measures motion, not pose, and as a pose it
        // pulls the filter along its drift (BENCHMARKS.md, "The model's edges").
        let m = fe.pose.map(|r| r.measurement());
        // The absolute cues: the model's edges where the target is large enough to fit them,
        // its outline where it is not.
        // (Nothing has updated the filter since `predicted`.)
        if !self.edge_update(&smoothed, valid, &predicted, &mut st.filter) {
            self.outline_update(&smoothed, valid, &predicted, &mut st.filter);
        }
        let estimate = camera_at(cam, st.filter.attitude, st.filter.position());
        st.tracker.replenish(&smoothed, valid, &estimate, &self.model);
        if i > 0 {
            score_pair(row, st.prev_measurement.as_ref(), m.as_ref(), &self.truth_pair(i));
        }
        st.prev_measurement = m;
        Ok(())
    }

    /// The model's edges fitted around the prediction `estimate` ([`crate::edges::fit`]) into
    /// the filter, when the target is predicted at least [`crate::edges::MIN_TARGET_PX`] wide
    /// and the fit lies inside the filter's gate. Whether the filter took it.
    fn edge_update(
        &self,
        smoothed: &GrayImage,
        valid: Region,
        estimate: &Camera,
        filter: &mut PoseFilter,
    ) -> bool {
        let big_enough = self
            .model
            .image_box(estimate, 0.0)
            .is_some_and(|(x0, y0, x1, y1)| (x1 - x0).max(y1 - y0) >= crate::edges::MIN_TARGET_PX);
        if !big_enough {
            return false;
        }
        let c = filter.pose_covariance();
        let range = filter.position().length().max(1e-3);
        let sigma_att = (c[(0, 0)] + c[(1, 1)] + c[(2, 2)]).max(0.0).sqrt();
        let sigma_pos = (c[(3, 3)] + c[(4, 4)] + c[(5, 5)]).max(0.0).sqrt();
        let sigma_px = f64::from(estimate.focal_px) * (sigma_att + sigma_pos / range);
        crate::edges::fit(
            smoothed,
            valid,
            estimate,
            &self.model,
            self.edges,
            (filter.attitude, filter.position()),
            sigma_px,
        )
        .is_some_and(|fit| filter.update_if_consistent(&fit.measurement))
    }

    /// The outline against the model's at the estimate ([`crate::silhouette`]): the relative
    /// position.
    /// `valid`: the region holding the scene ([`StreamImage::valid`]).
    fn outline_update(
        &self,
        smoothed: &GrayImage,
        valid: Region,
        estimate: &Camera,
        filter: &mut PoseFilter,
    ) {
        if let Some(bbox) = self.model.image_box(estimate, 0.3)
            && let Some(seen) = segment(smoothed, bbox, valid)
        {
            let step = ((bbox.2 - bbox.0).max(bbox.3 - bbox.1) / 96).max(1);
            if let Some(at) = self.model.silhouette(estimate, bbox, step)
                && let Some((t, r)) = centre_measurement(&seen, &at, estimate, &self.model)
            {
                filter.update_relative(t, &r);
            }
        }
    }

    /// Today's pairwise front end on one frame: FAST-9 + BRIEF, matched against the previous
    /// frame, PnP against its rendered depth. Returns this frame's features for the next.
    fn pairwise(
        &self,
        row: &mut FrameResult,
        gray: &GrayImage,
        pairs: &[imageproc::binary_descriptors::brief::TestPair],
        prev: Option<&Tracked>,
        i: usize,
    ) -> Tracked {
        let fd = &self.data[i];
        let w = gray.width() as usize;
        let corners = detect(gray, Some(&fd.feature_mask));
        let features = describe(gray, &corners, pairs);
        let cam = &fd.camera;
        let points = features
            .iter()
            .map(|f| {
                self.depths[i][f.y as usize * w + f.x as usize]
                    .map(|d| pixel_centre(cam, f.x, f.y).extend(1.0).normalize() * f64::from(d))
            })
            .collect();
        row.target_features = corners.len();
        if let Some(p) = prev {
            let matches = match_features(&p.features, &features);
            row.pairwise_tracks = matches.len();
            let (mut x3, mut x2) = (Vec::new(), Vec::new());
            for &(a, b) in &matches {
                if let Some(x) = p.points[a] {
                    x3.push(x);
                    x2.push(pixel_centre(cam, features[b].x, features[b].y));
                }
            }
            let truth = self.truth_pair(i);
            match pnp_ransac(&x3, &x2, f64::from(cam.focal_px), i as u64) {
                Some(r) if r.inliers >= MIN_INLIERS => {
                    row.pairwise_inliers = r.inliers;
                    row.pairwise_rot_err_deg = r.pose.rotation_error_deg(&truth);
                    row.pairwise_trans_dir_err_deg = r.pose.translation_direction_error_deg(&truth);
                }
                Some(r) => {
                    row.pairwise_inliers = r.inliers;
                    row.pairwise_lost = true;
                }
                None => row.pairwise_lost = true,
            }
        }
        Tracked { features, points }
    }
}

/// Runs the benchmark over one sequence folder: every source, every frame (or the first
/// `frames`). Frames are processed in order per source; sources run in parallel. The
/// sequence's noise seed (its manifest's) also seeds the filter's initialisation and the
/// oracle's noise.
///
/// `only`: the stream names to run (all when `None`; an unknown name is an error; the
/// baselines always run); `clean`: the noiseless renders instead of the noisy ones;
/// `registration`: how a sequence rendered through an offset rig (`fusion render --rig`) puts
/// its thermal frames on the visible grid (ignored on an aligned pair). The cameras are the
/// rig's, lens distortion included.
pub fn run_sequence(
    dir: &Path,
    frames: Option<usize>,
    only: Option<&[String]>,
    clean: bool,
    registration: Registration,
) -> Result<Vec<FrameResult>> {
    let m = read_manifest(dir)?;
    let rig = m.rig.as_ref().map(|r| fusion_io::rig::read(&dir.join(r))).transpose()?;
    let n = frames.unwrap_or(m.frames.len()).min(m.frames.len());
    if n < 2 {
        anyhow::bail!("{}: a sequence needs at least 2 frames, it has {n}", dir.display());
    }
    check_cameras(dir, &m, n)?;
    // The model of the target the sequence was rendered with.
    let scene = m.config.target.scene()?.with_surface_detail(m.config.surface_seed);
    let name = m.config.name.as_str().to_string();
    let mut all = selected(only)?;
    let has_raw = m.nuc.is_some() && m.frames.iter().take(n).all(|f| f.files.tir_raw.is_some());
    if !has_raw {
        if let (Some(_), Some((name, _))) = (only, all.iter().find(|(_, s)| s.needs_raw())) {
            anyhow::bail!(
                "{}: source '{name}' needs the thermal camera's raw counts; render the sequence with --raw-tir",
                dir.display()
            );
        }
        all.retain(|(_, s)| !s.needs_raw());
    }
    // Depth per frame, shared by the sources.
    let mut data: Vec<FrameData> =
        (0..n).into_par_iter().map(|i| load_frame(dir, &m, i, clean, rig.as_ref())).collect::<Result<_>>()?;
    if has_raw && all.iter().any(|(_, s)| s.needs_raw()) {
        for (fd, frames) in data.iter_mut().zip(sensor_frames(dir, &m, n)?) {
            fd.sensor = Some(frames);
        }
    }
    let depths: Vec<Vec<Option<f32>>> =
        data.par_iter().map(|fd| render_host::truth::depth(&scene, &fd.camera)).collect();
    let edges = crate::edges::ModelEdges::new(&scene);
    let run = SequenceRun {
        name: &name,
        seed: m.config.seed,
        data: &data,
        depths: &depths,
        model: TargetModel::new(&scene),
        edges: &edges,
        rig: rig.as_ref(),
        registration,
    };
    let results: Vec<Result<Vec<FrameResult>>> =
        all.par_iter().map(|(source, stream)| run.source(source, stream)).collect();
    let mut out = Vec::new();
    for r in results {
        out.extend(r?);
    }
    Ok(out)
}

/// The phase name of a whole sequence in the summaries.
pub const PHASE_ALL: &str = "all";

/// The `navbench.json` document (of one seed; [`crate::seeds::aggregate`] merges seeds).
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Per stream, per phase, over all sequences.
    pub sources: BTreeMap<String, BTreeMap<String, PhaseSummary>>,
    /// The same per sequence.
    pub by_sequence: BTreeMap<String, BTreeMap<String, BTreeMap<String, PhaseSummary>>>,
    /// Per skip stream (keyed by its method, `-skip` dropped) and closed-loop stream (keyed by
    /// its name, `…-loop`): the share of the target pixels inside the window the method's output
    /// is kept on, and the window's share of the frame.
    pub skip: BTreeMap<String, SkipSummary>,
    /// The same per sequence.
    pub skip_by_sequence: BTreeMap<String, BTreeMap<String, SkipSummary>>,
}

/// The skip block of `navbench.json`.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SkipSummary {
    /// Smallest fraction of the target pixels (both cameras' masks) inside the window.
    pub target_coverage_min: f64,
    /// Mean fraction of the target pixels inside the window.
    pub target_coverage_mean: f64,
    /// Mean share of the frame the window covers.
    pub window_frac_mean: f64,
}

/// Summarises per stream and phase (all sequences, and each), and the skip block.
pub fn summary(rows: &[FrameResult]) -> Summary {
    let mut groups: BTreeMap<(String, String, String), Vec<&FrameResult>> = BTreeMap::new();
    let mut all: BTreeMap<(String, String), Vec<&FrameResult>> = BTreeMap::new();
    for r in rows {
        for phase in [r.phase.as_str(), PHASE_ALL] {
            groups.entry((r.sequence.clone(), r.source.clone(), phase.to_string())).or_default().push(r);
            all.entry((r.source.clone(), phase.to_string())).or_default().push(r);
        }
    }
    let mut sources: BTreeMap<String, BTreeMap<String, PhaseSummary>> = BTreeMap::new();
    for ((src, phase), v) in &all {
        sources.entry(src.clone()).or_default().insert(phase.clone(), summarise(v));
    }
    let mut by_sequence: BTreeMap<String, BTreeMap<String, BTreeMap<String, PhaseSummary>>> = BTreeMap::new();
    for ((seq, src, phase), v) in &groups {
        by_sequence
            .entry(seq.clone())
            .or_default()
            .entry(src.clone())
            .or_default()
            .insert(phase.clone(), summarise(v));
    }
    let mut skip = BTreeMap::new();
    let mut skip_by_sequence: BTreeMap<String, BTreeMap<String, SkipSummary>> = BTreeMap::new();
    for src in sources.keys().filter(|s| s.ends_with("-skip") || s.ends_with("-loop")) {
        let key = src.strip_suffix("-skip").unwrap_or(src).to_string();
        let v: Vec<&FrameResult> = rows.iter().filter(|r| &r.source == src).collect();
        skip.insert(key.clone(), skip_summary(&v));
        for seq in by_sequence.keys() {
            let of_seq: Vec<&FrameResult> = v.iter().copied().filter(|r| &r.sequence == seq).collect();
            if !of_seq.is_empty() {
                skip_by_sequence.entry(seq.clone()).or_default().insert(key.clone(), skip_summary(&of_seq));
            }
        }
    }
    Summary { sources, by_sequence, skip, skip_by_sequence }
}

/// The skip block's figures over some frames of one stream.
fn skip_summary(v: &[&FrameResult]) -> SkipSummary {
    let n = v.len().max(1) as f64;
    SkipSummary {
        target_coverage_min: v.iter().map(|r| r.target_coverage).fold(1.0f64, f64::min),
        target_coverage_mean: v.iter().map(|r| r.target_coverage).sum::<f64>() / n,
        window_frac_mean: v.iter().map(|r| r.window_frac).sum::<f64>() / n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cnr_of_a_hand_made_case() {
        // Target 100 on a ring of 10 ± 2 (values 8 and 12): |100 − 10| / 2 = 45.
        let img = [100u8, 100, 8, 12, 8, 12];
        let mask = [true, true, false, false, false, false];
        let ring = [false, false, true, true, true, true];
        assert!((cnr(&img, &mask, &ring) - 45.0).abs() < 1e-12);
        // A flat ring: σ floored at 0.5.
        assert!((cnr(&[20, 10, 10], &[true, false, false], &[false, true, true]) - 20.0).abs() < 1e-12);
    }

    #[test]
    fn phase_summary_counts_pairs_and_skips_lost_errors() {
        let row = |frame, lost, err: f64, tracks, inliers| FrameResult {
            cnr: 4.0,
            target_features: 10,
            tracks,
            inliers,
            rot_err_deg: err,
            trans_dir_err_deg: err,
            lost,
            att_err_deg: 1.0 + frame as f64,
            pos_err_pct: 1.0,
            available: frame < 2,
            ..FrameResult::new("s", 1, frame, Phase::Light, "vis")
        };
        let rows = [
            row(0, false, f64::NAN, 0, 0),
            row(1, false, 0.2, 10, 5),
            row(2, true, f64::NAN, 4, 2),
            row(3, false, 0.4, 10, 10),
        ];
        let s = summarise(&rows.iter().collect::<Vec<_>>());
        assert_eq!(s.frames, 4);
        assert!((s.lost_frac - 1.0 / 3.0).abs() < 1e-12);
        assert!((s.rot_err_deg_median.unwrap() - 0.3).abs() < 1e-12);
        assert!((s.inlier_ratio - (0.5 + 0.5 + 1.0) / 3.0).abs() < 1e-12);
        assert!((s.tracks - 8.0).abs() < 1e-12);
        // Filter measures: RMS of 1, 2, 3, 4 degrees; available on frames 0 and 1.
        assert!((s.att_rms_deg - (30.0f64 / 4.0).sqrt()).abs() < 1e-12);
        assert!((s.availability - 0.5).abs() < 1e-12);
    }

    #[test]
    fn reacquisition_counts_frames_to_the_next_available_one() {
        let mut rows: Vec<FrameResult> = [true, false, false, true, false]
            .iter()
            .enumerate()
            .map(|(i, &a)| FrameResult { available: a, ..FrameResult::new("s", 1, i, Phase::Light, "vis") })
            .collect();
        mark_reacquisition(&mut rows);
        let r: Vec<f64> = rows.iter().map(|r| r.reacquire_frames).collect();
        assert!(r[0].is_nan() && r[2].is_nan() && r[3].is_nan());
        assert_eq!((r[1], r[4]), (2.0, 1.0));
    }
}
