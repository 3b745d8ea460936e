//! `fusion navbench`: does a fused stream help relative navigation? Every image stream of a
//! rendezvous sequence — VIS, TIR upscaled, each core method and variant, with and without
//! scene skipping — through one feature-based front end, measured against the rendered
//! ground truth, per illumination phase.
//!
//! Per frame and stream:
//! * **CNR**: `|μ_target − μ_ring| / σ_ring`, the target mask (VIS grid) against a background
//!   ring 8–24 px outside it (σ floored at 0.5 grey levels).
//! * **target features**: corners of [`super::features::detect`] inside the target mask grown
//!   by 3 px.
//! * per frame pair (k − 1, k): **tracks** (mutual-best BRIEF matches, [`super::track`]), the
//!   **inlier ratio** of PnP-RANSAC against frame k − 1's rendered depth ([`super::pose`]),
//!   the **rotation error** and **translation-direction error** of that relative pose against
//!   the truth, and **lost** when no pose with [`super::pose::MIN_INLIERS`] inliers exists.
//!
//! A pair counts in the phase of its second frame. Medians of the errors are over the pairs
//! that were not lost.

use super::features::{detect, grow_mask};
use super::pose::{MIN_INLIERS, RelativePose, pnp_ransac};
use super::track::{Feature, describe, match_features, test_pairs};
use anyhow::{Context, Result};
use fusion_engine::CoreScratch;
use fusion_io::{ColorPolicy, Gray, load_gray_u8};
use fusion_nostd::pipeline::SkipPolicy;
use fusion_nostd::{AdaptiveParams, Filter, FuseConfig, Method, RescalePolicy};
use image::GrayImage;
use rayon::prelude::*;
use render_host::glam::{DVec2, DVec3};
use render_host::sequence::{Phase, SequenceManifest, read_manifest};
use render_host::{Camera, Scene};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// One image stream judged by the benchmark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stream {
    /// The visible camera alone.
    Vis,
    /// The thermal camera alone, upscaled to the VIS grid with the core's bicubic.
    Tir,
    /// A core fusion (TIR upscaled with bicubic, as in flight).
    Fused(FuseConfig),
}

/// The streams of the benchmark with their names: `vis`, `tir`, `adaptive`, `adaptive-skip`,
/// `<method>-<variant>`,
/// `<method>-<variant>-skip` (scene skipping with the eclipse plan, [`SkipPolicy::All`]).
pub fn streams() -> Vec<(String, Stream)> {
    let mut out = vec![("vis".to_string(), Stream::Vis), ("tir".to_string(), Stream::Tir)];
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

/// The streams named in `only` (every stream when `None`), in [`streams`] order.
pub fn selected(only: Option<&[String]>) -> Result<Vec<(String, Stream)>> {
    let all = streams();
    let Some(only) = only else { return Ok(all) };
    if let Some(bad) = only.iter().find(|n| !all.iter().any(|(s, _)| s == *n)) {
        let names: Vec<&str> = all.iter().map(|(s, _)| s.as_str()).collect();
        anyhow::bail!("unknown source '{bad}'; the sources are {}", names.join(", "));
    }
    Ok(all.into_iter().filter(|(s, _)| only.contains(s)).collect())
}

/// What one stream gave on one frame.
#[derive(Debug, Clone, Serialize)]
pub struct FrameResult {
    /// Sequence name.
    pub sequence: String,
    /// Frame index.
    pub frame: usize,
    /// Illumination phase.
    pub phase: Phase,
    /// Stream name.
    pub source: String,
    /// Target contrast-to-noise ratio.
    pub cnr: f64,
    /// Corners on the target.
    pub target_features: usize,
    /// Matches with the previous frame (0 on the first frame).
    pub tracks: usize,
    /// PnP-RANSAC inliers among them.
    pub inliers: usize,
    /// Rotation error of the frame-to-frame pose, degrees (NaN when lost or first).
    pub rot_err_deg: f64,
    /// Translation-direction error, degrees (NaN when lost or first).
    pub trans_dir_err_deg: f64,
    /// Tracking lost on this frame pair (false on the first frame).
    pub lost: bool,
    /// Skip streams: fraction of the target pixels of both cameras' masks inside the window
    /// the method computed (1 for the others).
    pub target_coverage: f64,
    /// Skip streams: the computed window's share of the frame (1 for the others).
    pub window_frac: f64,
}

/// Summary of one stream in one phase (the `navbench.json` shape).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PhaseSummary {
    /// Mean CNR over the phase's frames.
    pub cnr: f64,
    /// Mean target features per frame.
    pub target_features: f64,
    /// Mean tracks per frame pair.
    pub tracks: f64,
    /// Mean inlier ratio (inliers / tracks; 0 where there were no tracks).
    pub inlier_ratio: f64,
    /// Median rotation error over the pairs not lost, degrees (`null` when all were lost).
    pub rot_err_deg_median: Option<f64>,
    /// Median translation-direction error over the pairs not lost, degrees.
    pub trans_dir_err_deg_median: Option<f64>,
    /// Fraction of the phase's frame pairs on which tracking was lost.
    pub lost_frac: f64,
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

/// Summarises the results of one stream in one phase.
pub fn summarise(rows: &[&FrameResult]) -> PhaseSummary {
    let pairs: Vec<&&FrameResult> = rows.iter().filter(|r| r.frame > 0).collect();
    let n = rows.len().max(1) as f64;
    let np = pairs.len().max(1) as f64;
    PhaseSummary {
        cnr: rows.iter().map(|r| r.cnr).sum::<f64>() / n,
        target_features: rows.iter().map(|r| r.target_features as f64).sum::<f64>() / n,
        tracks: pairs.iter().map(|r| r.tracks as f64).sum::<f64>() / np,
        inlier_ratio: pairs
            .iter()
            .map(|r| if r.tracks > 0 { r.inliers as f64 / r.tracks as f64 } else { 0.0 })
            .sum::<f64>()
            / np,
        rot_err_deg_median: median(pairs.iter().filter(|r| !r.lost).map(|r| r.rot_err_deg).collect()),
        trans_dir_err_deg_median: median(
            pairs.iter().filter(|r| !r.lost).map(|r| r.trans_dir_err_deg).collect(),
        ),
        lost_frac: pairs.iter().filter(|r| r.lost).count() as f64 / np,
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
    /// The VIS target mask (CNR's target).
    vis_mask: Vec<bool>,
    /// The VIS mask grown by 3 px: where features count as on the target.
    feature_mask: Vec<bool>,
    /// The CNR background ring, 8–24 px outside the VIS mask.
    ring_mask: Vec<bool>,
    /// Target pixels of either camera (TIR mask mapped to the VIS grid): the skip coverage.
    either_mask: Vec<bool>,
    camera: Camera,
    phase: Phase,
}

fn load_frame(dir: &Path, m: &SequenceManifest, i: usize, clean: bool) -> Result<FrameData> {
    let f = &m.frames[i];
    let pick = |noisy: &String, clean_file: &Option<String>| -> Result<std::path::PathBuf> {
        if !clean {
            return Ok(dir.join(noisy));
        }
        let rel = clean_file.as_ref().context("the sequence was rendered without clean frames")?;
        Ok(dir.join(rel))
    };
    let vis = load_gray_u8(&pick(&f.files.vis, &f.files.vis_clean)?, ColorPolicy::Refuse)?;
    let tir = load_gray_u8(&pick(&f.files.tir, &f.files.tir_clean)?, ColorPolicy::Refuse)?;
    let vis_mask: Vec<bool> = load_gray_u8(&dir.join(&f.files.vis_mask), ColorPolicy::Refuse)?
        .data
        .iter()
        .map(|&v| v > 127)
        .collect();
    let tir_mask = load_gray_u8(&dir.join(&f.files.tir_mask), ColorPolicy::Refuse)?;
    let (w, h) = (vis.width, vis.height);
    let (sx, sy) = (tir_mask.width as f64 / w as f64, tir_mask.height as f64 / h as f64);
    let either_mask = (0..w * h)
        .map(|k| {
            let (x, y) = ((k % w) as f64 * sx, (k / w) as f64 * sy);
            vis_mask[k]
                || tir_mask.at((x as usize).min(tir_mask.width - 1), (y as usize).min(tir_mask.height - 1))
                    > 127
        })
        .collect();
    Ok(FrameData {
        feature_mask: grow_mask(&vis_mask, w, h, 3),
        ring_mask: ring(&vis_mask, w, h, 8, 24),
        either_mask,
        vis,
        tir,
        vis_mask,
        camera: Camera::study(m.vis_camera.size, f.pose()),
        phase: f.phase,
    })
}

/// Normalised image coordinates `((x + ½ − cx)/f, (y + ½ − cy)/f)` of pixel `(x, y)`'s centre.
fn normalised(cam: &Camera, x: u32, y: u32) -> DVec2 {
    let f = f64::from(cam.focal_px);
    DVec2::new((f64::from(x) + 0.5 - f64::from(cam.cx)) / f, (f64::from(y) + 0.5 - f64::from(cam.cy)) / f)
}

/// The stream's image of one frame (VIS grid) and, for skip streams, (coverage, window share).
fn stream_image(stream: &Stream, fd: &FrameData) -> Result<(Gray<u8>, f64, f64)> {
    let (w, h) = (fd.vis.width, fd.vis.height);
    match stream {
        Stream::Vis => Ok((fd.vis.clone(), 1.0, 1.0)),
        Stream::Tir => {
            let mut up = Gray::<u8>::new(w, h);
            fusion_nostd::rescale(fd.tir.view()?, up.view_mut()?, Filter::Cubic)?;
            Ok((up, 1.0, 1.0))
        }
        Stream::Fused(p) => {
            let mut out = Gray::<u8>::new(w, h);
            let mut scratch = CoreScratch::new(p.scratch_pixels((w, h), (fd.tir.width, fd.tir.height))?);
            let report = fusion_nostd::fuse(
                fd.vis.view()?,
                fd.tir.view()?,
                out.view_mut()?,
                &mut scratch.view_mut(),
                p,
            )?;
            let win = report.skip.computed;
            let (mut inside, mut total) = (0usize, 0usize);
            for (k, _) in fd.either_mask.iter().enumerate().filter(|(_, m)| **m) {
                total += 1;
                inside += usize::from(win.contains(k % w, k / w));
            }
            let coverage = if total == 0 { 1.0 } else { inside as f64 / total as f64 };
            let frac = ((win.x1 - win.x0) * (win.y1 - win.y0)) as f64 / (w * h) as f64;
            Ok((out, coverage, frac))
        }
    }
}

/// Per-frame state the next frame's tracking needs: features with their 3D points.
struct Tracked {
    features: Vec<Feature>,
    /// Camera-frame 3D point of each feature (from the rendered depth), when it sits on the target.
    points: Vec<Option<DVec3>>,
}

/// Runs the benchmark over one sequence folder: every stream, every frame (or the first
/// `frames`). Frames are processed in order per stream; streams run in parallel.
///
/// `only`: the stream names to run (all when `None`; an unknown name is an error); `clean`:
/// the noiseless renders instead of the noisy ones.
pub fn run_sequence(
    dir: &Path,
    frames: Option<usize>,
    only: Option<&[String]>,
    clean: bool,
) -> Result<Vec<FrameResult>> {
    let m = read_manifest(dir)?;
    let n = frames.unwrap_or(m.frames.len()).min(m.frames.len());
    let scene = Scene::tango()?.with_surface_detail(m.config.surface_seed);
    let name = m.config.name.as_str().to_string();
    let pairs = test_pairs();
    let all = selected(only)?;
    // Depth per frame, shared by the streams.
    let data: Vec<FrameData> =
        (0..n).into_par_iter().map(|i| load_frame(dir, &m, i, clean)).collect::<Result<_>>()?;
    let depths: Vec<Vec<Option<f32>>> =
        data.par_iter().map(|fd| render_host::truth::depth(&scene, &fd.camera)).collect();
    let results: Vec<Result<Vec<FrameResult>>> = all
        .par_iter()
        .map(|(source, stream)| {
            let mut rows = Vec::with_capacity(n);
            let mut prev: Option<Tracked> = None;
            for (i, fd) in data.iter().enumerate() {
                let (img, target_coverage, window_frac) =
                    stream_image(stream, fd).with_context(|| format!("{name} frame {i} {source}"))?;
                let (w, h) = (img.width, img.height);
                let gray = GrayImage::from_raw(w as u32, h as u32, img.data.clone()).context("image size")?;
                let corners = detect(&gray, Some(&fd.feature_mask));
                let features = describe(&gray, &corners, &pairs);
                let cam = &fd.camera;
                let points = features
                    .iter()
                    .map(|f| {
                        depths[i][f.y as usize * w + f.x as usize]
                            .map(|d| normalised(cam, f.x, f.y).extend(1.0).normalize() * f64::from(d))
                    })
                    .collect();
                let mut row = FrameResult {
                    sequence: name.clone(),
                    frame: i,
                    phase: fd.phase,
                    source: source.clone(),
                    cnr: cnr(&img.data, &fd.vis_mask, &fd.ring_mask),
                    target_features: corners.len(),
                    tracks: 0,
                    inliers: 0,
                    rot_err_deg: f64::NAN,
                    trans_dir_err_deg: f64::NAN,
                    lost: false,
                    target_coverage,
                    window_frac,
                };
                if let Some(p) = &prev {
                    let matches = match_features(&p.features, &features);
                    row.tracks = matches.len();
                    let (mut x3, mut x2) = (Vec::new(), Vec::new());
                    for &(a, b) in &matches {
                        if let Some(x) = p.points[a] {
                            x3.push(x);
                            x2.push(normalised(cam, features[b].x, features[b].y));
                        }
                    }
                    let prev_cam = &data[i - 1].camera;
                    let truth = RelativePose::between(
                        prev_cam.pose.rotation.as_dmat3(),
                        prev_cam.pose.position.as_dvec3(),
                        cam.pose.rotation.as_dmat3(),
                        cam.pose.position.as_dvec3(),
                    );
                    match pnp_ransac(&x3, &x2, f64::from(cam.focal_px), i as u64) {
                        Some(r) if r.inliers >= MIN_INLIERS => {
                            row.inliers = r.inliers;
                            row.rot_err_deg = r.pose.rotation_error_deg(&truth);
                            row.trans_dir_err_deg = r.pose.translation_direction_error_deg(&truth);
                        }
                        Some(r) => {
                            row.inliers = r.inliers;
                            row.lost = true;
                        }
                        None => row.lost = true,
                    }
                }
                rows.push(row);
                prev = Some(Tracked { features, points });
            }
            Ok(rows)
        })
        .collect();
    let mut out = Vec::new();
    for r in results {
        out.extend(r?);
    }
    Ok(out)
}

/// The `navbench.json` document.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Per stream, per phase, over all sequences.
    pub sources: BTreeMap<String, BTreeMap<String, PhaseSummary>>,
    /// The same per sequence.
    pub by_sequence: BTreeMap<String, BTreeMap<String, BTreeMap<String, PhaseSummary>>>,
    /// Per skip stream: the smallest share of the target pixels inside the computed window and
    /// the mean window share of the frame.
    pub skip: BTreeMap<String, SkipSummary>,
}

/// The skip block of `navbench.json`.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SkipSummary {
    /// Smallest fraction of the target pixels (both cameras' masks) inside the window.
    pub target_coverage_min: f64,
    /// Mean share of the frame the window covers.
    pub window_frac_mean: f64,
}

/// Summarises per stream and phase (all sequences, and each), and the skip block.
pub fn summary(rows: &[FrameResult]) -> Summary {
    let mut groups: BTreeMap<(String, String, String), Vec<&FrameResult>> = BTreeMap::new();
    let mut all: BTreeMap<(String, String), Vec<&FrameResult>> = BTreeMap::new();
    for r in rows {
        groups
            .entry((r.sequence.clone(), r.source.clone(), r.phase.as_str().to_string()))
            .or_default()
            .push(r);
        all.entry((r.source.clone(), r.phase.as_str().to_string())).or_default().push(r);
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
    for src in sources.keys().filter(|s| s.ends_with("-skip")) {
        let v: Vec<&FrameResult> = rows.iter().filter(|r| &r.source == src).collect();
        let min = v.iter().map(|r| r.target_coverage).fold(1.0f64, f64::min);
        let mean = v.iter().map(|r| r.window_frac).sum::<f64>() / v.len().max(1) as f64;
        skip.insert(
            src.trim_end_matches("-skip").to_string(),
            SkipSummary { target_coverage_min: min, window_frac_mean: mean },
        );
    }
    Summary { sources, by_sequence, skip }
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
            sequence: "s".into(),
            frame,
            phase: Phase::Light,
            source: "vis".into(),
            cnr: 4.0,
            target_features: 10,
            tracks,
            inliers,
            rot_err_deg: err,
            trans_dir_err_deg: err,
            lost,
            target_coverage: 1.0,
            window_frac: 1.0,
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
    }
}
