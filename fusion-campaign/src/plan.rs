//! The cases of a campaign, each with a stable id.
//!
//! A case is one sequence rendered and judged: a trajectory, a sun phase angle, the Earth or not,
//! a target, glare or not, a replica number, and the campaign's frames, size and streams. Its id
//! is the first 16 hexadecimal digits of the SHA-256 of its parameters and the campaign seed
//! (written as canonical JSON), so the same parameters give the same id in any order, on any
//! machine and in any later version; its sensor seed is drawn from the id the same way. A
//! uniform axis is drawn from the campaign seed and the case's other parameters, so a rerun of
//! the file draws the same values.

use crate::file::{CampaignFile, NumberAxis};
use anyhow::{Result, bail};
use render_host::scene::Target;
use render_host::sequence::SequenceName;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// One case of a campaign.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Case {
    /// The stable id (16 hexadecimal digits).
    pub id: String,
    /// Its place in the plan (the order the file lists its axes in).
    pub index: usize,
    /// The sensor noise seed (and the judge's: the filter's start, the oracle's noise).
    pub seed: u64,
    /// The trajectory.
    pub trajectory: SequenceName,
    /// The sun phase angle at the first frame, degrees (`None`: the sequence's own sun).
    pub sun_phase_deg: Option<f64>,
    /// The Earth's altitude behind the target, km (`None`: black space; `radial` always has its
    /// own Earth).
    pub earth_km: Option<f64>,
    /// The target.
    pub target: Target,
    /// The sun's glare in the visible camera.
    pub glare: bool,
    /// The replica (0-based) of its grid point.
    pub replica: u32,
    /// Frames of the sequence.
    pub frames: usize,
    /// VIS size, px (TIR is half).
    pub vis_size: u32,
    /// The streams judged (the baselines always are).
    pub sources: Vec<String>,
    /// The phases whose rows are kept.
    pub phases: Vec<String>,
}

/// What the id hashes: every parameter of a case but the id, index and seed, and the campaign
/// seed. Field order is fixed here, so the JSON is canonical.
#[derive(Serialize)]
struct IdKey<'a> {
    campaign_seed: u64,
    trajectory: &'a str,
    sun_phase_deg: Option<f64>,
    earth_km: Option<f64>,
    target: &'a str,
    glare: bool,
    replica: u32,
    frames: usize,
    vis_size: u32,
    sources: &'a [String],
    phases: &'a [String],
}

fn sha256(parts: &[&[u8]]) -> [u8; 32] {
    let mut h = Sha256::new();
    for p in parts {
        h.update(p);
    }
    h.finalize().into()
}

fn hex16(d: &[u8; 32]) -> String {
    d[..8].iter().map(|b| format!("{b:02x}")).collect()
}

/// A draw in [0, 1) from a hash: its first 53 bits.
fn unit(d: &[u8; 32]) -> f64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(&d[..8]);
    (u64::from_be_bytes(b) >> 11) as f64 / (1u64 << 53) as f64
}

/// The sensor seed of a case: 31 bits of the hash of its id (positive in every integer type).
pub fn seed_of(id: &str) -> u64 {
    let d = sha256(&[b"seed:", id.as_bytes()]);
    u64::from(u32::from_be_bytes([d[0], d[1], d[2], d[3]]) >> 1)
}

/// The values of a numeric axis at one grid point (`None`: drawn per case).
fn values(axis: &NumberAxis) -> Vec<Option<f64>> {
    match axis {
        NumberAxis::List(v) => v.iter().map(|&x| Some(x)).collect(),
        NumberAxis::Steps { from, to, steps } => {
            (0..*steps).map(|i| Some(from + (to - from) * i as f64 / (*steps - 1) as f64)).collect()
        }
        NumberAxis::Uniform { .. } => vec![None],
    }
}

/// Every case of a campaign, in the plan's order: trajectory, target, Earth, sun phase, glare,
/// replica (the last varies fastest).
pub fn plan(file: &CampaignFile) -> Result<Vec<Case>> {
    let a = &file.axes;
    let phases: Vec<Option<f64>> = a.sun_phase.as_ref().map_or(vec![None], values);
    let grid = a.trajectory.len() * a.target.len() * a.earth.len() * phases.len() * a.glare.len();
    let n = grid.saturating_mul(file.replicas as usize);
    if n > crate::file::MAX_CASES {
        bail!("the campaign plans {n} cases, more than {}", crate::file::MAX_CASES);
    }
    let sources = file.source_names()?;
    let mut cases = Vec::with_capacity(n);
    for &trajectory in &a.trajectory {
        for &target in &a.target {
            for earth in &a.earth {
                for &phase in &phases {
                    for &glare in &a.glare {
                        for replica in 0..file.replicas {
                            let mut key = IdKey {
                                campaign_seed: file.seed,
                                trajectory: trajectory.as_str(),
                                sun_phase_deg: phase,
                                earth_km: earth.km(),
                                target: target.as_str(),
                                glare,
                                replica,
                                frames: file.frames,
                                vis_size: file.vis_size,
                                sources: &sources,
                                phases: &file.record.phases,
                            };
                            if let (None, Some(NumberAxis::Uniform { uniform: [lo, hi] })) =
                                (phase, &a.sun_phase)
                            {
                                let d = sha256(&[b"sun_phase:", serde_json::to_string(&key)?.as_bytes()]);
                                key.sun_phase_deg = Some(lo + (hi - lo) * unit(&d));
                            }
                            let id = hex16(&sha256(&[serde_json::to_string(&key)?.as_bytes()]));
                            cases.push(Case {
                                seed: seed_of(&id),
                                index: cases.len(),
                                id,
                                trajectory,
                                sun_phase_deg: key.sun_phase_deg,
                                earth_km: key.earth_km,
                                target,
                                glare,
                                replica,
                                frames: file.frames,
                                vis_size: file.vis_size,
                                sources: sources.clone(),
                                phases: file.record.phases.clone(),
                            });
                        }
                    }
                }
            }
        }
    }
    let mut ids: Vec<&str> = cases.iter().map(|c| c.id.as_str()).collect();
    ids.sort_unstable();
    if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
        bail!("two cases share the id {} (a repeated axis value?)", w[0]);
    }
    Ok(cases)
}

/// The plan's fingerprint: the SHA-256 (hex, 16 digits) of the campaign's name and its cases'
/// ids in order. A run records it; a changed file that plans other cases has another.
pub fn fingerprint(name: &str, cases: &[Case]) -> String {
    let mut h = Sha256::new();
    h.update(name.as_bytes());
    for c in cases {
        h.update(b"\n");
        h.update(c.id.as_bytes());
    }
    hex16(&h.finalize().into())
}

/// The plan as a table, as `fusion campaign plan` and `vistir-campaign plan` print it: a header
/// line with the name, case count, fingerprint and streams, then one tab-separated line per case.
pub fn table(name: &str, cases: &[Case]) -> String {
    fn num(v: Option<f64>, none: &str) -> String {
        v.map_or(none.to_string(), |x| {
            format!("{x:.6}").trim_end_matches('0').trim_end_matches('.').to_string()
        })
    }
    let mut out = format!(
        "# campaign {name}: {} cases, plan {}, streams {}\nid\ttrajectory\ttarget\tearth_km\tsun_phase_deg\tglare\treplica\tseed\n",
        cases.len(),
        fingerprint(name, cases),
        cases.first().map(|c| c.sources.join(",")).unwrap_or_default()
    );
    for c in cases {
        out += &format!(
            "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\n",
            c.id,
            c.trajectory.as_str(),
            c.target.as_str(),
            num(c.earth_km, "-"),
            num(c.sun_phase_deg, "own"),
            c.glare,
            c.replica,
            c.seed
        );
    }
    out
}
