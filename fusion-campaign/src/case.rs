//! One case run: its sequence rendered into a scratch folder, every stream judged by the
//! navigation judge (`fusion_navbench::bench::run_sequence`), one row per stream and phase.

use crate::plan::Case;
use anyhow::{Context, Result};
use fusion_navbench::bench::{PhaseSummary, run_sequence, summary};
use fusion_navbench::registration::Registration;
use render_host::sequence::{SequenceConfig, render_sequence, sequence_earth};
use serde::Serialize;
use std::path::Path;

/// One row of a case's table: the case's parameters, a stream, a phase, the judge's figures
/// there (`fusion navbench`'s per-phase summary, the same keys as `navbench.json`).
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// The case id.
    pub case_id: String,
    /// The case's place in the plan.
    pub case_index: usize,
    /// The trajectory.
    pub trajectory: String,
    /// The sun phase angle at the first frame, degrees (`None`: the sequence's own sun).
    pub sun_phase_deg: Option<f64>,
    /// Whether the Earth is behind the target.
    pub earth: bool,
    /// The Earth's altitude, km (`None`: black space).
    pub earth_km: Option<f64>,
    /// The target.
    pub target: String,
    /// Glare in the visible camera.
    pub glare: bool,
    /// The replica of the grid point.
    pub replica: u32,
    /// The sensor seed.
    pub seed: u64,
    /// The stream (or baseline).
    pub source: String,
    /// The phase (`all`: the whole sequence).
    pub phase: String,
    /// The judge's figures.
    #[serde(flatten)]
    pub figures: PhaseSummary,
}

/// The sequence a case renders. The thermal camera's raw counts and factory calibration are
/// rendered too (`fusion render --raw-tir`) when a stream of the case reads them (`tir-raw`,
/// `tir-nuc`, `tir-chain`, `adaptive-chain`: navbench's defaults name them); the other
/// frames are the same either way.
pub fn sequence_config(case: &Case) -> SequenceConfig {
    let base = SequenceConfig::new(case.trajectory);
    let raw = fusion_navbench::bench::streams()
        .iter()
        .any(|(name, stream)| stream.needs_raw() && case.sources.contains(name));
    SequenceConfig {
        frames: case.frames,
        vis_size: case.vis_size,
        tir_size: case.vis_size / 2,
        seed: case.seed,
        target: case.target,
        write_clean: false,
        earth: sequence_earth(
            case.trajectory,
            case.earth_km.map(|km| km * 1000.0),
            case.seed,
            base.surface_seed,
        ),
        sun_phase_deg: case.sun_phase_deg,
        glare: case.glare.then(render_host::glare::GlareParams::default),
        focal_plane: raw.then(render_host::focal_plane::FocalPlaneParams::default),
        ..base
    }
}

/// Renders the case's sequence into a folder under `scratch` (removed on return, whatever
/// happens), judges every stream of the case, and returns its rows: per stream, per phase kept,
/// in the order stream, phase.
pub fn run(case: &Case, scratch: &Path) -> Result<Vec<Row>> {
    let dir = tempfile::Builder::new()
        .prefix(&format!("case-{}-", case.id))
        .tempdir_in(scratch)
        .with_context(|| format!("cannot make a scratch folder in {}", scratch.display()))?;
    let cfg = sequence_config(case);
    render_sequence(&cfg, dir.path(), false).with_context(|| format!("case {}: rendering", case.id))?;
    let frames = run_sequence(dir.path(), None, Some(&case.sources), false, Registration::default())
        .with_context(|| format!("case {}: judging", case.id))?;
    let s = summary(&frames);
    let mut rows = Vec::new();
    for (source, phases) in s.by_sequence.get(case.trajectory.as_str()).into_iter().flatten() {
        for phase in &case.phases {
            if let Some(figures) = phases.get(phase) {
                rows.push(Row {
                    case_id: case.id.clone(),
                    case_index: case.index,
                    trajectory: case.trajectory.as_str().to_string(),
                    sun_phase_deg: case.sun_phase_deg,
                    earth: cfg.earth.is_some(),
                    earth_km: cfg.earth.map(|e| e.altitude_m / 1000.0),
                    target: case.target.as_str().to_string(),
                    glare: case.glare,
                    replica: case.replica,
                    seed: case.seed,
                    source: source.clone(),
                    phase: phase.clone(),
                    figures: figures.clone(),
                });
            }
        }
    }
    Ok(rows)
}
