//! `fusion skip-study`: what scene skipping saves and costs over a rendered dataset — per
//! method and skip level, host time, window (ROI + halo) fraction and the error against the
//! unskipped result; a Markdown table, a CSV and a chart.

use anyhow::{Result, bail};
use clap::Args;
use fusion_engine::skip::{fuse_once, skip_error};
use fusion_engine::study::{Dataset, core_methods, version};
use fusion_io::Gray;
use fusion_io::source_on_grid;
use fusion_nostd::Filter;
use fusion_nostd::pipeline::{FuseConfig, RescalePolicy, SkipPolicy, Skips};
use fusion_nostd::scene::Rect;
use fusion_nostd::scene::{SceneParams, analyze};
use fusion_report::plot::{Labels, Series, Style, chart};
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

/// Per (set, method): the background-rule bounds `(best constant, input mean)` in dB of the
/// declined noisy frames.
type Bounds<'a> = Vec<((&'a str, &'a str), Vec<(f64, f64)>)>;

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

/// The whole-frame PSNR (dB) of `full` against itself with every pixel outside `window` replaced
/// by `fill(i)` — what a background rule `fill` would cost.
fn background_rule_psnr(full: &Gray<u8>, window: Rect, fill: impl Fn(usize) -> f64) -> f64 {
    let mut se = 0.0;
    for (i, &v) in full.data.iter().enumerate() {
        if !window.contains(i % full.width, i / full.width) {
            let d = f64::from(v) - fill(i);
            se += d * d;
        }
    }
    let mse = se / full.data.len().max(1) as f64;
    if mse == 0.0 { f64::INFINITY } else { 10.0 * (255.0 * 255.0 / mse).log10() }
}

/// What the best background rules would cost on a frame the analysis declined, with the window
/// the ROI plan took on the clean version of the same frame: `(best constant, mean of the two
/// inputs)` as whole-frame PSNR against the unskipped result, in dB. The best constant is the
/// mean of the fused background itself (an oracle no cheap rule beats with a constant).
fn declined_bounds(full: &Gray<u8>, window: Rect, vis: &Gray<u8>, tir_up: &Gray<u8>) -> (f64, f64) {
    let outside: Vec<f64> = full
        .data
        .iter()
        .enumerate()
        .filter(|(i, _)| !window.contains(i % full.width, i / full.width))
        .map(|(_, &v)| f64::from(v))
        .collect();
    let level = mean(&outside).round();
    let best_constant = background_rule_psnr(full, window, |_| level);
    let average = background_rule_psnr(full, window, |i| {
        let (a, b) = (vis.data.get(i).copied().unwrap_or(0), tir_up.data.get(i).copied().unwrap_or(0));
        ((f64::from(a) + f64::from(b)) / 2.0).round()
    });
    (best_constant, average)
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
    let _folder = fusion_io::output::create_folder(&args.out)?;
    let levels = [("none", SkipPolicy::None), ("roi", SkipPolicy::Roi), ("all", SkipPolicy::All)];
    let mut csv = String::from(
        "set,version,frame,method,skip,seconds,window_fraction,roi_fraction,max_abs,psnr_db,taken,declined,illumination,vis_bg,vis_spread_q8,tir_bg,tir_spread_q8,declined_best_constant_psnr_db,declined_input_mean_psnr_db\n",
    );
    // The ROI windows the clean frames got, for the bounds on their declined noisy versions:
    // (set, frame, method) → window.
    let mut clean_windows: Vec<((&str, usize, &str), Rect)> = Vec::new();
    // (set, method) → the bounds over the declined noisy frames.
    let mut bounds: Bounds<'_> = Vec::new();
    // (set, version, method, level) → accumulator
    let mut acc: Vec<(Key<'_>, Acc)> = Vec::new();
    for set in ["vis_light", "vis_eclipse"] {
        for &noisy in &versions {
            for frame in 0..frames {
                let vis = ds.image(set, frame, noisy)?;
                let tir = ds.image(&args.tir, frame, noisy)?;
                let tir_up = source_on_grid(&tir, (vis.width, vis.height), Filter::Cubic)?;
                let scene =
                    analyze(vis.view()?, tir.view()?, (vis.width, vis.height), &SceneParams::default())?;
                for m in core_methods() {
                    let mut full = None;
                    for (lname, level) in levels {
                        let p = FuseConfig {
                            rescale: RescalePolicy::TirUp,
                            method: m.method,
                            skip: level,
                            ..FuseConfig::default()
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
                        if !noisy && lname == "roi" && report.skip.taken.contains(Skips::ROI) {
                            clean_windows.push(((set, frame, m.name), report.skip.computed));
                        }
                        let clean = clean_windows.iter().find(|(k, _)| *k == (set, frame, m.name));
                        let bound = match (&full, clean) {
                            (Some(f), Some((_, win))) if noisy && lname == "roi" && !declined.is_empty() => {
                                let b = declined_bounds(f, *win, &vis, &tir_up);
                                match bounds.iter_mut().find(|(k, _)| *k == (set, m.name)) {
                                    Some((_, v)) => v.push(b),
                                    None => bounds.push(((set, m.name), vec![b])),
                                }
                                format!("{:.2},{:.2}", b.0, b.1)
                            }
                            _ => ",".to_string(),
                        };
                        writeln!(
                            csv,
                            "{set},{},{frame},{},{lname},{best:.6},{window:.5},{roi:.5},{},{:.2},{},{declined},{:?},{},{},{},{},{bound}",
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
    if !bounds.is_empty() {
        md.push_str(
            "\nDeclined noisy frames: what a background rule would have cost, with the ROI window the \
             clean version of the same frame got (whole-frame PSNR against the unskipped noisy result; \
             the bound is 50 dB). *Best constant* fills the background with the fused background's \
             own mean, the best any constant can do; *input mean* fills it with `(VIS + TIR)/2`.\n\n\
             | set | method | frames | best constant: mean / best dB | input mean: mean / best dB |\n\
             |---|---|---:|---:|---:|\n",
        );
        for ((set, method), v) in &bounds {
            let (c, a): (Vec<f64>, Vec<f64>) = v.iter().copied().unzip();
            writeln!(
                md,
                "| {set} | {method} | {} | {:.1} / {:.1} | {:.1} / {:.1} |",
                v.len(),
                mean(&c),
                max(&c),
                mean(&a),
                max(&a)
            )?;
        }
    }
    let mut batch = fusion_io::Batch::default();
    batch.add_bytes(&args.out.join("skip_study.md"), md.as_bytes())?;
    batch.add_bytes(&args.out.join("skip_study.csv"), csv.as_bytes())?;
    batch.commit()?;
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
    out!("{md}")?;
    outln!(
        "\nwrote {}, {}, {}",
        args.out.join("skip_study.md").display(),
        args.out.join("skip_study.csv").display(),
        path.display()
    )?;
    Ok(())
}
