//! The campaign file (TOML): the axes and their values or distributions, the replicas (sensor
//! seeds), the streams, the sequence length and size, what to record.
//!
//! ```toml
//! name = "phase-angle"
//! seed = 2026            # the campaign seed: with a case's parameters, its id and its seeds
//! replicas = 5           # cases per point of the grid, each with its own sensor seed
//! frames = 48            # frames per sequence (the whole trajectory, sampled more coarsely)
//! vis_size = 512         # VIS px (TIR is half)
//! sources = ["vis", "tir", "adaptive"]   # streams judged (the baselines always are); default: navbench's
//!
//! [axes]
//! trajectory = ["approach", "flyaround"]       # approach, flyaround, radial
//! sun_phase = { from = 0, to = 180, steps = 7 } # degrees; a list, evenly spaced steps, or { uniform = [lo, hi] }
//! earth = [false, true]                        # black space, the Earth at 500 km, or an altitude in km
//! target = ["tango"]                           # tango, boxwing
//! glare = [false]                              # the sun's glare in the visible camera
//!
//! [record]
//! phases = ["all", "light", "penumbra", "eclipse"]   # the phases whose rows are kept
//! ```
//!
//! Every key but `name`, `seed`, `frames`, `vis_size` and `axes.trajectory` has the default
//! shown in its comment (`sun_phase` absent: each sequence's own sun; `sources` absent: every
//! stream `fusion navbench` runs by default, the raw thermal chain's among them, so the cases
//! then render the thermal camera's raw counts too). Unknown keys, an empty or
//! repeated axis value, a phase outside 0–180° are refused with one line naming the key.

use anyhow::{Context, Result, bail, ensure};
use render_host::scene::Target;
use render_host::sequence::SequenceName;
use serde::Deserialize;
use std::path::Path;

/// The largest number of cases a campaign file may plan.
pub const MAX_CASES: usize = 1_000_000;

/// The phases a sequence's frames fall into, and `all` (the whole sequence).
pub const PHASES: [&str; 4] = ["all", "light", "penumbra", "eclipse"];

/// A numeric axis: values, evenly spaced steps, or a uniform draw per case.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum NumberAxis {
    /// These values.
    List(Vec<f64>),
    /// `steps` values from `from` to `to`, both ends included.
    Steps {
        /// First value.
        from: f64,
        /// Last value.
        to: f64,
        /// How many (≥ 2).
        steps: usize,
    },
    /// Drawn per case, uniform in `[lo, hi]`, from the campaign seed and the case's other
    /// parameters (so a rerun draws the same).
    Uniform {
        /// `[lo, hi]`.
        uniform: [f64; 2],
    },
}

/// One value of the `earth` axis: `false` (black space), `true` (the Earth at the default
/// altitude) or an altitude in km.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum EarthValue {
    /// `false`: black space; `true`: the Earth at the renderer's default altitude.
    Flag(bool),
    /// The Earth at this altitude, km.
    Km(f64),
}

impl EarthValue {
    /// The altitude in km, or `None` for black space.
    pub fn km(self) -> Option<f64> {
        match self {
            EarthValue::Flag(false) => None,
            EarthValue::Flag(true) => Some(render_host::earth::DEFAULT_ALTITUDE_M / 1000.0),
            EarthValue::Km(km) => Some(km),
        }
    }
}

/// The `[axes]` table.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axes {
    /// The trajectories.
    pub trajectory: Vec<SequenceName>,
    /// The sun–target–camera phase angle at the first frame, degrees (absent: each sequence's
    /// own sun).
    pub sun_phase: Option<NumberAxis>,
    /// Black space or the Earth behind the target.
    #[serde(default = "no_earth")]
    pub earth: Vec<EarthValue>,
    /// The targets.
    #[serde(default = "default_target")]
    pub target: Vec<Target>,
    /// The sun's glare in the visible camera.
    #[serde(default = "no_glare")]
    pub glare: Vec<bool>,
}

fn no_earth() -> Vec<EarthValue> {
    vec![EarthValue::Flag(false)]
}
fn default_target() -> Vec<Target> {
    vec![Target::default()]
}
fn no_glare() -> Vec<bool> {
    vec![false]
}
fn one() -> u32 {
    1
}
fn all_phases() -> Vec<String> {
    PHASES.iter().map(|p| p.to_string()).collect()
}

/// The `[record]` table.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Record {
    /// The phases whose rows are kept (of [`PHASES`]).
    #[serde(default = "all_phases")]
    pub phases: Vec<String>,
}

impl Default for Record {
    fn default() -> Self {
        Record { phases: all_phases() }
    }
}

/// A campaign file, read and checked.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CampaignFile {
    /// The campaign's name (letters, digits, `-`, `_`).
    pub name: String,
    /// The campaign seed.
    pub seed: u64,
    /// Cases per point of the grid, each with its own sensor seed.
    #[serde(default = "one")]
    pub replicas: u32,
    /// Frames per sequence.
    pub frames: usize,
    /// VIS image size, px (TIR is half).
    pub vis_size: u32,
    /// The streams judged (navbench's names); `None`: navbench's default streams.
    pub sources: Option<Vec<String>>,
    /// The axes.
    pub axes: Axes,
    /// What to record.
    #[serde(default)]
    pub record: Record,
}

impl CampaignFile {
    /// Parses and checks a campaign file's text (`what` names it in errors).
    pub fn parse(text: &str, what: &str) -> Result<CampaignFile> {
        let file: CampaignFile = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| text[..s.start.min(text.len())].lines().count().max(1));
            let msg = e.message().replace('\n', " ");
            match line {
                Some(l) => anyhow::anyhow!("{what}, line {l}: {msg}"),
                None => anyhow::anyhow!("{what}: {msg}"),
            }
        })?;
        file.check().with_context(|| what.to_string())?;
        Ok(file)
    }

    /// Reads and checks a campaign file.
    pub fn read(path: &Path) -> Result<CampaignFile> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        CampaignFile::parse(&text, &path.display().to_string())
    }

    /// The streams a case judges: the file's, or navbench's defaults.
    pub fn source_names(&self) -> Result<Vec<String>> {
        let all = fusion_navbench::bench::selected(self.sources.as_deref())?;
        Ok(all.into_iter().map(|(n, _)| n).collect())
    }

    fn check(&self) -> Result<()> {
        ensure!(
            !self.name.is_empty()
                && self.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_'),
            "name: letters, digits, '-' and '_' only, not '{}'",
            self.name
        );
        ensure!(self.replicas >= 1, "replicas must be at least 1");
        ensure!(self.frames >= 2, "frames must be at least 2 (tracking needs frame pairs)");
        let max = fusion_navbench::bench::MAX_CAMERA_SIZE;
        ensure!(
            self.vis_size >= 64 && self.vis_size <= max && self.vis_size.is_multiple_of(2),
            "vis_size must be even, at least 64 and at most {max}"
        );
        if let Some(s) = &self.sources {
            ensure!(!s.is_empty(), "sources: name at least one stream (or leave the key out)");
            distinct("sources", s)?;
        }
        self.source_names()?;
        let a = &self.axes;
        nonempty("axes.trajectory", &a.trajectory)?;
        distinct("axes.trajectory", &a.trajectory.iter().map(|t| t.as_str()).collect::<Vec<_>>())?;
        nonempty("axes.earth", &a.earth)?;
        for e in &a.earth {
            if let Some(km) = e.km() {
                ensure!(
                    (100.0..=40_000.0).contains(&km),
                    "axes.earth: an altitude of {km} km is outside 100–40000 km"
                );
            }
        }
        distinct("axes.earth", &a.earth.iter().map(|e| format!("{:?}", e.km())).collect::<Vec<_>>())?;
        nonempty("axes.target", &a.target)?;
        distinct("axes.target", &a.target.iter().map(|t| t.as_str()).collect::<Vec<_>>())?;
        nonempty("axes.glare", &a.glare)?;
        distinct("axes.glare", &a.glare)?;
        if let Some(p) = &a.sun_phase {
            match p {
                NumberAxis::List(v) => {
                    nonempty("axes.sun_phase", v)?;
                    for x in v {
                        in_phase_range(*x)?;
                    }
                    distinct("axes.sun_phase", &v.iter().map(|x| x.to_bits()).collect::<Vec<_>>())?;
                }
                NumberAxis::Steps { from, to, steps } => {
                    ensure!(*steps >= 2, "axes.sun_phase: steps must be at least 2");
                    in_phase_range(*from)?;
                    in_phase_range(*to)?;
                    ensure!(from < to, "axes.sun_phase: from must be below to");
                }
                NumberAxis::Uniform { uniform: [lo, hi] } => {
                    in_phase_range(*lo)?;
                    in_phase_range(*hi)?;
                    ensure!(lo < hi, "axes.sun_phase: uniform = [lo, hi] needs lo < hi");
                }
            }
        }
        nonempty("record.phases", &self.record.phases)?;
        for p in &self.record.phases {
            ensure!(
                PHASES.contains(&p.as_str()),
                "record.phases: unknown phase '{p}'; the phases are {}",
                PHASES.join(", ")
            );
        }
        distinct("record.phases", &self.record.phases)?;
        Ok(())
    }
}

fn in_phase_range(x: f64) -> Result<()> {
    ensure!((0.0..=180.0).contains(&x), "axes.sun_phase: {x}° is outside 0–180°");
    Ok(())
}

fn nonempty<T>(key: &str, v: &[T]) -> Result<()> {
    if v.is_empty() {
        bail!("{key}: give at least one value");
    }
    Ok(())
}

fn distinct<T: PartialEq + std::fmt::Debug>(key: &str, v: &[T]) -> Result<()> {
    for (i, x) in v.iter().enumerate() {
        if v[..i].contains(x) {
            bail!("{key}: the value {x:?} is given twice");
        }
    }
    Ok(())
}
