//! Figures over several seeds: every summary figure as its mean and spread, and verdicts that
//! are only stated outside that spread.
//!
//! A navigation figure from one seed is an anecdote: the sensor noise, the filter's
//! initialisation and the oracle's noise all change with the seed, and so do the medians and
//! shares of a 120-frame sequence. `fusion navbench --seeds 1,2,3` runs each seed; here each
//! [`PhaseSummary`] figure becomes a [`Stat`] (mean and sample standard deviation over the
//! seeds that have it), and [`verdict`] says "better" or "worse" only when two means differ by
//! more than the larger of their spreads.

use crate::bench::{PhaseSummary, SkipSummary, Summary};
use serde::Serialize;
use serde::ser::{SerializeMap, Serializer};
use std::collections::BTreeMap;

/// One figure over seeds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stat {
    /// Mean over the seeds that have the figure.
    pub mean: f64,
    /// Sample standard deviation over them (0 for one seed).
    pub sd: f64,
    /// How many seeds had it.
    pub n: usize,
}

impl Stat {
    /// The mean and sample standard deviation of `values` (`None` when empty).
    pub fn of(values: &[f64]) -> Option<Stat> {
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let sd = if n > 1 {
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        Some(Stat { mean, sd, n })
    }
}

/// One seed: the plain number; several: `{"mean": x, "sd": x}`.
impl Serialize for Stat {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.n <= 1 {
            return s.serialize_f64(self.mean);
        }
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("mean", &self.mean)?;
        m.serialize_entry("sd", &self.sd)?;
        m.end()
    }
}

/// A phase's figures by name (the [`PhaseSummary`] field names); `None` where no seed has it.
pub type Figures = BTreeMap<String, Option<Stat>>;

/// `navbench.json` over seeds: the [`Summary`] shape with every figure a [`Stat`].
#[derive(Clone, Debug, Serialize)]
pub struct SeedSummary {
    /// The seeds, in run order.
    pub seeds: Vec<u64>,
    /// Per source, per phase, over all sequences.
    pub sources: BTreeMap<String, BTreeMap<String, Figures>>,
    /// The same per sequence.
    pub by_sequence: BTreeMap<String, BTreeMap<String, BTreeMap<String, Figures>>>,
    /// Per skip method: the skip block's figures.
    pub skip: BTreeMap<String, Figures>,
    /// The same per sequence.
    pub skip_by_sequence: BTreeMap<String, BTreeMap<String, Figures>>,
}

fn figures_of<T: Serialize>(v: &T) -> BTreeMap<String, Option<f64>> {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::Object(m)) => m.into_iter().map(|(k, v)| (k, v.as_f64())).collect(),
        _ => BTreeMap::new(),
    }
}

fn merge<T: Serialize>(items: &[&T]) -> Figures {
    let per: Vec<BTreeMap<String, Option<f64>>> = items.iter().map(|i| figures_of(*i)).collect();
    let mut keys: Vec<String> = per.iter().flat_map(|m| m.keys().cloned()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .map(|k| {
            let vals: Vec<f64> = per.iter().filter_map(|m| m.get(&k).copied().flatten()).collect();
            (k, Stat::of(&vals))
        })
        .collect()
}

/// Merges the per-seed summaries (in seed order) into one.
pub fn aggregate(seeds: &[u64], per_seed: &[Summary]) -> SeedSummary {
    let mut sources: BTreeMap<String, BTreeMap<String, Vec<&PhaseSummary>>> = BTreeMap::new();
    let mut by_sequence: BTreeMap<String, BTreeMap<String, BTreeMap<String, Vec<&PhaseSummary>>>> =
        BTreeMap::new();
    let mut skip: BTreeMap<String, Vec<&SkipSummary>> = BTreeMap::new();
    let mut skip_by_sequence: BTreeMap<String, BTreeMap<String, Vec<&SkipSummary>>> = BTreeMap::new();
    for s in per_seed {
        for (seq, methods) in &s.skip_by_sequence {
            for (m, v) in methods {
                skip_by_sequence.entry(seq.clone()).or_default().entry(m.clone()).or_default().push(v);
            }
        }
        for (src, phases) in &s.sources {
            for (ph, v) in phases {
                sources.entry(src.clone()).or_default().entry(ph.clone()).or_default().push(v);
            }
        }
        for (seq, srcs) in &s.by_sequence {
            for (src, phases) in srcs {
                for (ph, v) in phases {
                    by_sequence
                        .entry(seq.clone())
                        .or_default()
                        .entry(src.clone())
                        .or_default()
                        .entry(ph.clone())
                        .or_default()
                        .push(v);
                }
            }
        }
        for (m, v) in &s.skip {
            skip.entry(m.clone()).or_default().push(v);
        }
    }
    let phases = |m: BTreeMap<String, Vec<&PhaseSummary>>| -> BTreeMap<String, Figures> {
        m.into_iter().map(|(ph, v)| (ph, merge(&v))).collect()
    };
    SeedSummary {
        seeds: seeds.to_vec(),
        sources: sources.into_iter().map(|(k, v)| (k, phases(v))).collect(),
        by_sequence: by_sequence
            .into_iter()
            .map(|(seq, srcs)| (seq, srcs.into_iter().map(|(k, v)| (k, phases(v))).collect()))
            .collect(),
        skip: skip.into_iter().map(|(k, v)| (k, merge(&v))).collect(),
        skip_by_sequence: skip_by_sequence
            .into_iter()
            .map(|(seq, m)| (seq, m.into_iter().map(|(k, v)| (k, merge(&v))).collect()))
            .collect(),
    }
}

/// How one figure of a stream compares with another's over the seeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Better by more than the spread.
    Better,
    /// Worse by more than the spread.
    Worse,
    /// The means differ by no more than the larger spread: no verdict.
    WithinSpread,
    /// Fewer than two seeds on either side: no spread to judge against, no verdict.
    OneSeed,
}

impl Verdict {
    /// The word navbench.md uses.
    pub fn word(self) -> &'static str {
        match self {
            Verdict::Better => "better",
            Verdict::Worse => "worse",
            Verdict::WithinSpread => "within the seed spread",
            Verdict::OneSeed => "one seed: no verdict",
        }
    }
}

/// `a` against `b`: better or worse only when the means differ by more than the larger of the
/// two standard deviations over seeds (and both come from at least two seeds).
pub fn verdict(a: Stat, b: Stat, higher_is_better: bool) -> Verdict {
    if a.n < 2 || b.n < 2 {
        return Verdict::OneSeed;
    }
    let d = a.mean - b.mean;
    if d.abs() <= a.sd.max(b.sd) {
        return Verdict::WithinSpread;
    }
    if (d > 0.0) == higher_is_better { Verdict::Better } else { Verdict::Worse }
}

/// One figure of a skipped stream that moved more than the guard allows.
#[derive(Clone, Debug, PartialEq)]
pub struct Moved {
    /// `phase.figure`, e.g. `light.availability`.
    pub figure: String,
    /// Skipped mean − unskipped mean.
    pub delta: f64,
    /// What the guard allows: the larger spread over seeds, or 1 % of the unskipped mean.
    pub allowed: f64,
}

/// The skip guard of one skipped stream (issue 38): its figures against its unskipped
/// stream's, phase by phase.
#[derive(Clone, Debug, PartialEq)]
pub struct GuardRow {
    /// The skipped stream (`…-skip`, or `…-loop` for the closed loop).
    pub skipped: String,
    /// Its unskipped stream.
    pub unskipped: String,
    /// Figures compared (phase × figure, both streams have them).
    pub figures: usize,
    /// Those that moved by more than the guard allows, the largest move (by `|delta| /
    /// allowed`) first.
    pub moved: Vec<Moved>,
}

/// The stream a guarded stream is judged against: `<stream>-skip` and `<stream>-loop` against
/// `<stream>`; a sequence-mode stream against the same stream fused per frame
/// (`adf-flight-seq` against `adf-flight`, `adf-flight-seq-skip` against `adf-flight-skip`).
fn twin(name: &str) -> Option<String> {
    if name.contains("-seq") {
        return Some(name.replacen("-seq", "", 1));
    }
    name.strip_suffix("-skip").or_else(|| name.strip_suffix("-loop")).map(str::to_string)
}

/// The guard of issue 38 over the whole summary: every `<stream>-skip` and `<stream>-loop`
/// against `<stream>`, every sequence-mode stream against its per-frame twin, over all
/// sequences. A figure may move by at most the larger of the two streams' standard deviations
/// over the seeds, or by 1 % of the twin's mean where that is larger.
pub fn skip_guard(s: &SeedSummary) -> Vec<GuardRow> {
    let mut out = Vec::new();
    for (name, phases) in &s.sources {
        let Some(base) = twin(name) else { continue };
        let Some(base_phases) = s.sources.get(&base) else { continue };
        let mut row =
            GuardRow { skipped: name.clone(), unskipped: base.clone(), figures: 0, moved: Vec::new() };
        for (phase, figs) in phases {
            let Some(base_figs) = base_phases.get(phase) else { continue };
            for (key, stat) in figs {
                let (Some(a), Some(Some(b))) = (stat, base_figs.get(key)) else { continue };
                if !a.mean.is_finite() || !b.mean.is_finite() {
                    continue;
                }
                row.figures += 1;
                let delta = a.mean - b.mean;
                let allowed = a.sd.max(b.sd).max(0.01 * b.mean.abs());
                if delta.abs() > allowed {
                    row.moved.push(Moved { figure: format!("{phase}.{key}"), delta, allowed });
                }
            }
        }
        row.moved.sort_by(|x, y| {
            (y.delta.abs() / y.allowed.max(1e-300)).total_cmp(&(x.delta.abs() / x.allowed.max(1e-300)))
        });
        out.push(row);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A figure that moves by more than both the spread and 1 % is listed; one inside the
    /// spread, or inside 1 % of the mean, is not; streams without an unskipped twin are skipped.
    #[test]
    fn the_skip_guard_lists_only_moves_beyond_the_spread() {
        let stat = |values: &[f64]| Stat::of(values);
        let figs = |a: Option<Stat>, b: Option<Stat>, c: Option<Stat>| -> Figures {
            [("availability".to_string(), a), ("cnr".to_string(), b), ("nees".to_string(), c)]
                .into_iter()
                .collect()
        };
        let phases =
            |f: Figures| -> BTreeMap<String, Figures> { [("all".to_string(), f)].into_iter().collect() };
        let mut sources = BTreeMap::new();
        // availability: 0.50 ± 0.01 vs 0.60 ± 0.01 (moved); cnr: within the spread; nees: 100.0
        // vs 100.5, sd 0 (inside 1 %).
        sources.insert(
            "x".to_string(),
            phases(figs(stat(&[0.49, 0.50, 0.51]), stat(&[4.0, 5.0, 6.0]), stat(&[100.0, 100.0]))),
        );
        sources.insert(
            "x-skip".to_string(),
            phases(figs(stat(&[0.59, 0.60, 0.61]), stat(&[4.5, 5.5, 6.5]), stat(&[100.5, 100.5]))),
        );
        sources.insert("y-loop".to_string(), phases(figs(stat(&[1.0, 1.0]), None, None)));
        let s = SeedSummary {
            seeds: vec![1, 2, 3],
            sources,
            by_sequence: BTreeMap::new(),
            skip: BTreeMap::new(),
            skip_by_sequence: BTreeMap::new(),
        };
        let g = skip_guard(&s);
        assert_eq!(g.len(), 1, "{g:?}");
        assert_eq!((g[0].skipped.as_str(), g[0].unskipped.as_str(), g[0].figures), ("x-skip", "x", 3));
        assert_eq!(g[0].moved.len(), 1, "{g:?}");
        assert_eq!(g[0].moved[0].figure, "all.availability");
        assert!((g[0].moved[0].delta - 0.1).abs() < 1e-12 && (g[0].moved[0].allowed - 0.01).abs() < 1e-12);
        // Sequence-mode streams against their per-frame twins.
        assert_eq!(twin("adf-flight-seq").as_deref(), Some("adf-flight"));
        assert_eq!(twin("adf-flight-seq-skip").as_deref(), Some("adf-flight-skip"));
        assert_eq!(twin("adaptive-loop").as_deref(), Some("adaptive"));
        assert_eq!(twin("adf-flight"), None);
    }

    #[test]
    fn stat_is_mean_and_sample_sd_and_serialises_by_seed_count() {
        let s = Stat::of(&[1.0, 2.0, 3.0]).unwrap();
        assert_eq!((s.mean, s.sd, s.n), (2.0, 1.0, 3));
        assert_eq!(serde_json::to_string(&s).unwrap(), r#"{"mean":2.0,"sd":1.0}"#);
        assert_eq!(serde_json::to_string(&Stat::of(&[0.5]).unwrap()).unwrap(), "0.5");
        assert!(Stat::of(&[]).is_none());
    }

    /// A difference inside the spread gets no verdict, one outside it does, one seed none.
    #[test]
    fn verdicts_only_outside_the_spread() {
        let a = Stat { mean: 1.0, sd: 0.2, n: 3 };
        let b = Stat { mean: 1.15, sd: 0.1, n: 3 };
        assert_eq!(verdict(a, b, false), Verdict::WithinSpread);
        let c = Stat { mean: 1.5, sd: 0.1, n: 3 };
        assert_eq!(verdict(a, c, false), Verdict::Better);
        assert_eq!(verdict(c, a, false), Verdict::Worse);
        assert_eq!(verdict(c, a, true), Verdict::Better);
        assert_eq!(verdict(Stat { n: 1, ..a }, c, false), Verdict::OneSeed);
    }
}
