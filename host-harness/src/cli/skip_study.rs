//! `fusion skip-study`: what scene skipping saves and costs over a rendered dataset — per
//! method and skip level, host time, window (ROI + halo) fraction and the error against the
//! unskipped result; a Markdown table, a CSV and a chart.

use crate::plot::{Labels, Series, Style, chart};
use crate::skip::{fuse_once, skip_error};
use crate::study::{Dataset, core_methods, version};
use anyhow::{Result, bail};
use clap::Args;
use fusion_nostd::pipeline::{Pipeline, RescalePolicy, SkipPolicy, Skips};
use fusion_nostd::scene::{SceneParams, analyze};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `fusion skip-study`.
#[derive(Debug, Args)]
pub struct SkipStudyArgs {
    /// Rendered dataset folder (holds manifest.json; `fusion render`).
    pub dataset: PathBuf,
    /// Output folder for skip_study.md, skip_study.csv and the chart.
    #[arg(long, default_value = "skip-study")]
    pub out: PathBuf,
    /// TIR set (TIR is upscaled onto the VIS grid).
    #[arg(long, default_value = "tir512")]
    pub tir: String,
    /// Frames to use (from the first).
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Noise versions: clean, noisy or both.
    #[arg(long, default_value = "both")]
    pub versions: String,
    /// Timed repeats per fusion (the minimum is kept).
    #[arg(long, default_value_t = 1)]
    pub repeats: usize,
}

/// (set, version, method, skip level).
type Key<'a> = (String, &'a str, &'a str, &'a str);

#[derive(Default)]
struct Acc {
    times: Vec<f64>,
    fractions: Vec<f64>,
    max_abs: u8,
    psnrs: Vec<f64>,
    roi_taken: usize,
    eclipse_taken: usize,
    declined: Vec<String>,
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() { 0.0 } else { v.iter().sum::<f64>() / v.len() as f64 }
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

fn min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

/// Runs the study.
pub fn run(args: &SkipStudyArgs) -> Result<()> {
    let ds = Dataset::open(&args.dataset)?;
    let frames = args.frames.min(ds.frames());
    if frames == 0 {
        bail!("the dataset has no frames");
    }
    let versions: Vec<bool> = match args.versions.as_str() {
        "clean" => vec![false],
        "noisy" => vec![true],
        "both" => vec![false, true],
        v => bail!("--versions must be clean, noisy or both, not {v}"),
    };
    std::fs::create_dir_all(&args.out)?;
    let levels = [("none", SkipPolicy::None), ("roi", SkipPolicy::Roi), ("all", SkipPolicy::All)];
    let mut csv = String::from(
        "set,version,frame,method,skip,seconds,window_fraction,roi_fraction,max_abs,psnr_db,taken,declined,illumination,vis_bg,vis_spread_q8,tir_bg,tir_spread_q8\n",
    );
    // (set, version, method, level) → accumulator
    let mut acc: Vec<(Key<'_>, Acc)> = Vec::new();
    for set in ["vis_light", "vis_eclipse"] {
        for &noisy in &versions {
            for frame in 0..frames {
                let vis = ds.image(set, frame, noisy)?;
                let tir = ds.image(&args.tir, frame, noisy)?;
                let scene =
                    analyze(vis.view()?, tir.view()?, (vis.width, vis.height), &SceneParams::default())?;
                for m in core_methods() {
                    let mut full = None;
                    for (lname, level) in levels {
                        let p = Pipeline {
                            rescale: RescalePolicy::TirUp,
                            method: m.method,
                            skip: level,
                            ..Pipeline::default()
                        };
                        let mut best = f64::INFINITY;
                        let mut last = None;
                        for _ in 0..args.repeats.max(1) {
                            let (img, report, s) = fuse_once(&vis, &tir, &p)?;
                            best = best.min(s);
                            last = Some((img, report));
                        }
                        let Some((img, report)) = last else { continue };
                        let grid = (report.grid.0 * report.grid.1) as f64;
                        let window = report.skip.computed.area() as f64 / grid;
                        let roi = report.skip.roi.area() as f64 / grid;
                        let e = match &full {
                            None => {
                                full = Some(img);
                                skip_error(full.as_ref().unwrap_or(&vis), full.as_ref().unwrap_or(&vis))
                            }
                            Some(f) => skip_error(&img, f),
                        };
                        let declined = report.skip.declined.map(|d| format!("{d:?}")).unwrap_or_default();
                        writeln!(
                            csv,
                            "{set},{},{frame},{},{lname},{best:.6},{window:.5},{roi:.5},{},{:.2},{},{declined},{:?},{},{},{},{}",
                            version(noisy),
                            m.name,
                            e.max_abs,
                            e.psnr,
                            report.skip.taken.0,
                            scene.illumination,
                            scene.vis.background,
                            scene.vis.spread_q8,
                            scene.tir.background,
                            scene.tir.spread_q8
                        )?;
                        let key = (set.to_string(), version(noisy), m.name, lname);
                        let i = match acc.iter().position(|(k, _)| *k == key) {
                            Some(i) => i,
                            None => {
                                acc.push((key, Acc::default()));
                                acc.len() - 1
                            }
                        };
                        let a = &mut acc[i].1;
                        a.times.push(best);
                        a.fractions.push(window);
                        a.max_abs = a.max_abs.max(e.max_abs);
                        a.psnrs.push(e.psnr);
                        a.roi_taken += usize::from(report.skip.taken.contains(Skips::ROI));
                        a.eclipse_taken += usize::from(report.skip.taken.contains(Skips::ECLIPSE_VIS));
                        if !declined.is_empty() && !a.declined.contains(&declined) {
                            a.declined.push(declined);
                        }
                    }
                }
            }
        }
    }
    let mut md = format!(
        "# Scene skipping over `{}` ({frames} frames, {} upscaled onto the VIS grid)\n\n\
         Window = the pixels the method ran on (ROI + halo), as a fraction of the frame. Error = \
         against the unskipped (`--skip none`) result over the whole frame. Host times are single \
         runs (min of {} repeat(s)) on this machine.\n\n\
         | set | version | method | skip | mean ms | worst ms | mean window | worst window | ROI taken | eclipse plan | max abs | worst PSNR dB | declined |\n\
         |---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n",
        args.dataset.display(),
        args.tir,
        args.repeats.max(1)
    );
    for ((set, ver, method, level), a) in &acc {
        let psnr = min(&a.psnrs);
        writeln!(
            md,
            "| {set} | {ver} | {method} | {level} | {:.1} | {:.1} | {:.1} % | {:.1} % | {}/{} | {} | {} | {} | {} |",
            mean(&a.times) * 1e3,
            max(&a.times) * 1e3,
            mean(&a.fractions) * 100.0,
            max(&a.fractions) * 100.0,
            a.roi_taken,
            a.times.len(),
            a.eclipse_taken,
            a.max_abs,
            if psnr.is_infinite() { "∞ (identical)".to_string() } else { format!("{psnr:.1}") },
            a.declined.join(", ")
        )?;
    }
    std::fs::write(args.out.join("skip_study.md"), &md)?;
    std::fs::write(args.out.join("skip_study.csv"), &csv)?;
    // Chart: mean host time per method and skip level, one series per (set, version, level).
    let mut series = Vec::new();
    for ((set, ver, method, level), a) in &acc {
        let name = format!("{set} {ver} {level}");
        let x = core_methods().iter().position(|m| m.name == *method).unwrap_or(0) as f64;
        let point =
            (x + levels.iter().position(|l| l.0 == *level).unwrap_or(0) as f64 * 0.2, mean(&a.times) * 1e3);
        match series.iter_mut().find(|s: &&mut Series| s.name == name) {
            Some(s) => s.points.push(point),
            None => series.push(Series { name, points: vec![point] }),
        }
    }
    let names: Vec<&str> = core_methods().iter().map(|m| m.name).collect();
    let title = format!("mean host ms per frame by method ({}) and skip level", names.join(", "));
    let path = chart(
        &args.out.join("skip_study_time"),
        Labels { title: &title, x: "method index (+0.2 roi, +0.4 all)", y: "ms per frame" },
        &series,
        Style::Lines,
    )?;
    print!("{md}");
    println!(
        "\nwrote {}, {}, {}",
        args.out.join("skip_study.md").display(),
        args.out.join("skip_study.csv").display(),
        path.display()
    );
    Ok(())
}
