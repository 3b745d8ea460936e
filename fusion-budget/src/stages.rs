//! The stage tables: each method's measured stages (region, table key, label), its remainder
//! and whole-method regions, and the per-stage counts of a staged run.

#[allow(unused_imports)]
use super::*;

/// The method's name as a budget key.
pub fn method_key(m: MethodArg) -> &'static str {
    match m {
        MethodArg::Adf => "adf",
        MethodArg::Tsifsd => "tsifsd",
        MethodArg::Ifevip => "ifevip",
        MethodArg::Adaptive => "adaptive",
    }
}

/// The measured stages of a method, in order: `(budget key, firmware region, what it is)`.
pub(super) fn method_stages(m: MethodArg) -> &'static [(&'static str, &'static str, &'static str)] {
    match m {
        MethodArg::Adf => {
            &[("diffuse", "adf.diffuse", "anisotropic diffusion of VIS and TIR together (10 iterations)")]
        }
        // The flight kernel is one pass; its stages cannot be measured apart.
        MethodArg::Tsifsd => &[],
        MethodArg::Ifevip => &[(
            "background",
            "ifevip.background",
            "IR background: resize, quadtree, erosion, Bézier, smoothing",
        )],
        // One pass after the analysis; the analysis is inside the method's region.
        MethodArg::Adaptive => &[],
    }
}

/// The remainder stage of a method: its count minus the measured stages.
pub(super) fn remainder_stage(m: MethodArg) -> (&'static str, &'static str) {
    match m {
        MethodArg::Adf => ("kl_reconstruct", "KL covariance, weights and reconstruction"),
        MethodArg::Tsifsd => (
            "saliency_reconstruct",
            "one pass: 35×35 window sums of IR − VIS, Scharr saliency, weights, reconstruction",
        ),
        MethodArg::Ifevip => ("features_reconstruct", "entropy, IR features, peak, reconstruction"),
        MethodArg::Adaptive => (
            "analysis_fusion",
            "scene analysis of both input frames (the decision), then the frame's fusion: on the budget pair's large target, ADF flight",
        ),
    }
}

pub(super) fn method_region(m: MethodArg) -> &'static str {
    match m {
        MethodArg::Adf => "adf.fuse",
        MethodArg::Tsifsd => "tsifsd.fuse",
        MethodArg::Ifevip => "ifevip.fuse",
        MethodArg::Adaptive => "adaptive.fuse",
    }
}

/// Whether the method runs in strips ([`fusion_nostd::strips`]: every method, both variants).
pub fn has_strips(m: MethodArg) -> bool {
    matches!(m, MethodArg::Adf | MethodArg::Tsifsd | MethodArg::Ifevip | MethodArg::Adaptive)
}

/// One row of the stage table.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    /// Budget key (`rescale`, `diffuse`, …, `method`, `pipeline`).
    pub key: &'static str,
    /// What it covers.
    pub what: &'static str,
    /// Instructions (marker overhead included, a few per region).
    pub count: u64,
}

/// Splits a staged run's regions into the table rows: rescale (when the grid needed one), the
/// method's stages, its remainder, the method in total and the whole pipeline.
pub fn stages_of(method: MethodArg, run: &RunOut) -> Result<Vec<Stage>> {
    let mut rows = Vec::new();
    if let Some(c) = run.region("rescale") {
        rows.push(Stage { key: "rescale", what: "rescale onto the fusion grid", count: c });
    }
    let total =
        run.region(method_region(method)).with_context(|| format!("no {} region", method_region(method)))?;
    let mut sum = 0u64;
    for &(key, region, what) in method_stages(method) {
        let c = run.region(region).with_context(|| format!("no {region} region"))?;
        sum += c;
        rows.push(Stage { key, what, count: c });
    }
    let (key, what) = remainder_stage(method);
    let rest = total
        .checked_sub(sum)
        .with_context(|| format!("{} counts fewer instructions than its stages", method_key(method)))?;
    rows.push(Stage { key, what, count: rest });
    rows.push(Stage { key: "method", what: "the method in total (stages + remainder)", count: total });
    let pipeline = run.region("pipeline").context("no pipeline region")?;
    rows.push(Stage { key: "pipeline", what: "whole pipeline entry: rescale + method", count: pipeline });
    Ok(rows)
}
