//! What sequence mode (`fusion_nostd::sequence`) does to the fused frames of rendered
//! rendezvous sequences: every frame fused per frame and in sequence mode (ADF flight and
//! classic, whole frame; ADF flight with scene skipping `all`), compared pixel by pixel.
//!
//! ```sh
//! cargo run --release -p fusion-engine --example sequence_study -- DATA OUT.md
//! ```
//!
//! `DATA` holds `seed-N/<sequence>/` folders as `fusion navbench` renders them (`--data`). Per
//! configuration, sequence and phase over every seed: the share of frames fused with carried
//! weights (one pass in strips), the PSNR of the sequence-mode frame against the per-frame one
//! (whole frame; with skipping, inside the ROI the output is kept on) — min and median over the
//! frames that differ at all — the largest difference, and the median relative change of the
//! IR weight (`|p_used − p_own| / p_own`).

use anyhow::{Context, Result};
use fusion_engine::sequence::{Form, SequenceFuser};
use fusion_engine::skip::fuse_once;
use fusion_io::{ColorPolicy, load_gray_u8};
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, SkipPolicy};
use fusion_nostd::sequence::{Pass, SequenceParams};
use fusion_nostd::{AdfParams, Variant};
use rayon::prelude::*;
use render_host::sequence::read_manifest;
use std::collections::BTreeMap;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// One frame's comparison.
struct FrameCmp {
    phase: String,
    carried: bool,
    differs: bool,
    psnr_db: f64,
    max_diff: u8,
    weight_change: f64,
}

fn configs() -> Vec<(&'static str, FuseConfig)> {
    let adf = |variant| Method::Adf(AdfParams { variant, ..AdfParams::default() });
    let cfg =
        |method, skip| FuseConfig { method, skip, rescale: RescalePolicy::TirUp, ..FuseConfig::default() };
    vec![
        ("adf-flight", cfg(adf(Variant::Flight), SkipPolicy::None)),
        ("adf-classic", cfg(adf(Variant::Classic), SkipPolicy::None)),
        ("adf-flight, skip all", cfg(adf(Variant::Flight), SkipPolicy::All)),
    ]
}

/// Every frame of one sequence folder, per frame and in sequence mode.
fn study(dir: &Path, config: &FuseConfig) -> Result<Vec<FrameCmp>> {
    let m = read_manifest(dir)?;
    let mut seq = SequenceFuser::new(*config, SequenceParams::default(), Form::WholeFrame);
    let mut out = Vec::new();
    for f in &m.frames {
        let load = |rel: &str| load_gray_u8(&dir.join(rel), ColorPolicy::Refuse);
        let (vis, tir) = (load(&f.files.vis)?, load(&f.files.tir)?);
        let s = seq.fuse(&vis, &tir)?;
        let (alone, report, _) = fuse_once(&vis, &tir, config)?;
        // With skipping, the pixels the method wrote (the ROI of a crop); else the frame.
        let roi = if config.skip == SkipPolicy::None { None } else { Some(report.skip.roi) };
        let (mut sq, mut n, mut max_diff) = (0f64, 0usize, 0u8);
        for (k, (a, b)) in s.image.data.iter().zip(&alone.data).enumerate() {
            if roi.is_some_and(|r| !r.contains(k % vis.width, k / vis.width)) {
                continue;
            }
            let d = a.abs_diff(*b);
            sq += f64::from(d) * f64::from(d);
            n += 1;
            max_diff = max_diff.max(d);
        }
        let mse = sq / n.max(1) as f64;
        let (used, own) = (s.step.p_ir_used_q30 as f64, s.step.p_ir_own_q30 as f64);
        out.push(FrameCmp {
            phase: format!("{:?}", f.phase).to_lowercase(),
            carried: s.step.pass == Pass::Carried,
            differs: max_diff > 0,
            psnr_db: if mse == 0.0 { f64::INFINITY } else { 10.0 * (255.0f64 * 255.0 / mse).log10() },
            max_diff,
            weight_change: if own == 0.0 { 0.0 } else { (used - own).abs() / own.abs() },
        });
    }
    Ok(out)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

fn main() -> Result<()> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let (data, out) = match args.as_slice() {
        [d, o] => (d.clone(), o.clone()),
        _ => anyhow::bail!("usage: sequence_study DATA OUT.md"),
    };
    let mut dirs = Vec::new();
    for seed in std::fs::read_dir(&data).with_context(|| data.display().to_string())? {
        let seed = seed?.path();
        for s in std::fs::read_dir(&seed)? {
            let s = s?.path();
            if s.join("manifest.json").is_file() {
                dirs.push(s);
            }
        }
    }
    dirs.sort();
    let jobs: Vec<(usize, PathBuf)> =
        (0..configs().len()).flat_map(|c| dirs.iter().map(move |d| (c, d.clone()))).collect();
    let results: Vec<(usize, String, Vec<FrameCmp>)> = jobs
        .par_iter()
        .map(|(c, d)| {
            let name = d.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            Ok((*c, name, study(d, &configs()[*c].1).with_context(|| d.display().to_string())?))
        })
        .collect::<Result<_>>()?;
    let mut md = String::from(
        "| configuration | sequence | phase | frames | carried | differ | PSNR min dB | PSNR median dB | largest difference | weight change (median) |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (c, (label, _)) in configs().iter().enumerate() {
        let mut groups: BTreeMap<(String, String), Vec<&FrameCmp>> = BTreeMap::new();
        for (_, seq, frames) in results.iter().filter(|(k, _, _)| *k == c) {
            for f in frames {
                groups.entry((seq.clone(), f.phase.clone())).or_default().push(f);
                groups.entry((seq.clone(), "all".into())).or_default().push(f);
            }
        }
        for ((seq, phase), v) in &groups {
            let differing: Vec<f64> = v.iter().filter(|f| f.differs).map(|f| f.psnr_db).collect();
            let carried = v.iter().filter(|f| f.carried).count();
            let _ = writeln!(
                md,
                "| {label} | {seq} | {phase} | {} | {carried} | {} | {:.1} | {:.1} | {} | {:.3} |",
                v.len(),
                differing.len(),
                differing.iter().copied().fold(f64::INFINITY, f64::min),
                median(differing.clone()),
                v.iter().map(|f| f.max_diff).max().unwrap_or(0),
                median(v.iter().filter(|f| f.carried).map(|f| f.weight_change).collect()),
            );
        }
    }
    std::fs::write(&out, &md).with_context(|| out.display().to_string())?;
    print!("{md}");
    Ok(())
}
