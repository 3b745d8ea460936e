//! `fusion navbench`: every image stream of the rendezvous sequences through one feature-based
//! navigation front end, against the rendered ground truth (`fusion_navbench::bench`).

use anyhow::{Result, bail};
use clap::Args;
use fusion_io::write_bytes;
use fusion_navbench::bench::{FrameResult, PhaseSummary, Summary, run_sequence, selected, summary};
use fusion_report::plot::{Labels, Series, Style, chart_shaded};
use render_host::sequence::{Phase, SequenceConfig, SequenceName, render_sequence};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `fusion navbench`.
#[derive(Debug, Clone, Args)]
pub struct NavbenchArgs {
    /// Output folder: navbench.md, navbench.json, per_frame.csv, charts.
    #[arg(long)]
    pub out: PathBuf,
    /// Folder holding the sequences (`approach/`, `flyaround/`, each with its manifest.json);
    /// missing ones are rendered there [default: OUT/data].
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Frames per sequence (rendered, and used) [default: 120].
    #[arg(long)]
    pub frames: Option<usize>,
    /// VIS size of sequences rendered here (TIR is half) [default: 1024].
    #[arg(long, default_value_t = 1024, value_name = "PX")]
    pub vis_size: u32,
    /// Only these sources, comma-separated (e.g. `vis,tir,adaptive`) [default: all].
    #[arg(long, value_delimiter = ',', value_name = "NAMES")]
    pub sources: Option<Vec<String>>,
    /// Use the noiseless renders instead of the noisy ones (e.g. the skip windows on clean
    /// frames).
    #[arg(long)]
    pub clean: bool,
}

/// The phases in table order.
const PHASES: [Phase; 3] = [Phase::Light, Phase::Penumbra, Phase::Eclipse];

/// Runs `fusion navbench`.
pub fn run(args: &NavbenchArgs) -> Result<()> {
    if args.frames == Some(0) || args.frames == Some(1) {
        bail!("--frames must be at least 2 (tracking needs frame pairs)");
    }
    if args.vis_size < 64 || !args.vis_size.is_multiple_of(2) {
        bail!("--vis-size must be even and at least 64");
    }
    let only = args.sources.as_deref();
    let streams = selected(only)?.len();
    let start = Instant::now();
    let data = args.data.clone().unwrap_or_else(|| args.out.join("data"));
    std::fs::create_dir_all(&args.out)?;
    let mut rows: Vec<FrameResult> = Vec::new();
    for name in SequenceName::ALL {
        let dir = data.join(name.as_str());
        if !dir.join("manifest.json").is_file() {
            let cfg = SequenceConfig {
                frames: args.frames.unwrap_or(120),
                vis_size: args.vis_size,
                tir_size: args.vis_size / 2,
                ..SequenceConfig::new(name)
            };
            note!("rendering {} ({} frames) into {}", name.as_str(), cfg.frames, dir.display());
            render_sequence(&cfg, &dir, false)?;
        }
        let seq = run_sequence(&dir, args.frames, only, args.clean)?;
        note!("navbench: {} ({} frames, {streams} streams)", name.as_str(), seq.len() / streams.max(1));
        rows.extend(seq);
    }
    let s = summary(&rows);
    write_text(&args.out.join("navbench.json"), &serde_json::to_string_pretty(&s)?)?;
    write_text(&args.out.join("per_frame.csv"), &csv(&rows))?;
    let charts = charts(&args.out, &rows)?;
    write_text(&args.out.join("navbench.md"), &markdown(&s, &charts, start.elapsed().as_secs_f64()))?;
    outln!(
        "navbench: {} frame results, {} streams -> {} ({:.0} s)",
        rows.len(),
        s.sources.len(),
        args.out.display(),
        start.elapsed().as_secs_f64()
    )?;
    Ok(())
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    write_bytes(path, text.as_bytes())
}

fn csv(rows: &[FrameResult]) -> String {
    let mut s = String::from(
        "sequence,frame,phase,source,cnr,target_features,tracks,inliers,rot_err_deg,trans_dir_err_deg,lost,target_coverage,window_frac\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.sequence,
            r.frame,
            r.phase.as_str(),
            r.source,
            r.cnr,
            r.target_features,
            r.tracks,
            r.inliers,
            r.rot_err_deg,
            r.trans_dir_err_deg,
            r.lost,
            r.target_coverage,
            r.window_frac
        );
    }
    s
}

/// Per sequence: rotation error (points: lost pairs have none) and target features (lines)
/// against the frame, penumbra and eclipse shaded, for vis, tir and the flight variants.
fn charts(out: &Path, rows: &[FrameResult]) -> Result<Vec<PathBuf>> {
    let shown = ["vis", "tir", "adf-flight", "tsifsd-flight", "ifevip-flight"];
    let mut written = Vec::new();
    for name in SequenceName::ALL {
        let seq: Vec<&FrameResult> = rows.iter().filter(|r| r.sequence == name.as_str()).collect();
        if seq.is_empty() {
            continue;
        }
        // Shade the frames not in light (penumbra and eclipse), from the vis rows.
        let mut shaded = Vec::new();
        for r in seq.iter().filter(|r| r.source == "vis" && r.phase != Phase::Light) {
            shaded.push((r.frame as f64 - 0.5, r.frame as f64 + 0.5));
        }
        let series = |f: &dyn Fn(&FrameResult) -> f64| -> Vec<Series> {
            shown
                .iter()
                .map(|src| Series {
                    name: (*src).to_string(),
                    points: seq.iter().filter(|r| r.source == *src).map(|r| (r.frame as f64, f(r))).collect(),
                })
                .collect()
        };
        let stem = out.join(format!("{}_rotation_error", name.as_str()));
        written.push(chart_shaded(
            &stem,
            Labels {
                title: &format!(
                    "{}: frame-to-frame rotation error (grey: penumbra and eclipse)",
                    name.as_str()
                ),
                x: "frame",
                y: "rotation error, degrees",
            },
            &series(&|r| r.rot_err_deg),
            Style::Points,
            &shaded,
        )?);
        let stem = out.join(format!("{}_features", name.as_str()));
        written.push(chart_shaded(
            &stem,
            Labels {
                title: &format!("{}: features on the target (grey: penumbra and eclipse)", name.as_str()),
                x: "frame",
                y: "FAST corners on the target",
            },
            &series(&|r| r.target_features as f64),
            Style::Lines,
            &shaded,
        )?);
    }
    Ok(written)
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or("—".to_string(), |x| format!("{x:.3}"))
}

/// Whether stream `s` is at least as good as the better single camera `best` (never-worse rule
/// of issue 20: rotation error ≤ 1.05×, lost fraction ≤, CNR ≥ 0.95×), and better on any
/// measure.
fn judge(s: &PhaseSummary, vis: &PhaseSummary, tir: &PhaseSummary) -> (bool, Vec<&'static str>) {
    let best_rot = [vis.rot_err_deg_median, tir.rot_err_deg_median].into_iter().flatten().reduce(f64::min);
    let best_lost = vis.lost_frac.min(tir.lost_frac);
    let best_cnr = vis.cnr.max(tir.cnr);
    let rot_ok = match (s.rot_err_deg_median, best_rot) {
        (Some(r), Some(b)) => r <= 1.05 * b,
        (None, Some(_)) => false,
        (_, None) => true,
    };
    let never_worse = rot_ok && s.lost_frac <= best_lost && s.cnr >= 0.95 * best_cnr;
    let mut better = Vec::new();
    if let (Some(r), Some(b)) = (s.rot_err_deg_median, best_rot)
        && r < b
    {
        better.push("rotation error");
    }
    if s.lost_frac < best_lost {
        better.push("tracking kept");
    }
    if s.cnr > best_cnr {
        better.push("CNR");
    }
    if s.target_features > vis.target_features.max(tir.target_features) {
        better.push("features");
    }
    (never_worse, better)
}

/// Whether VIS is the better single camera in a phase: fewer pairs lost, then the smaller
/// rotation error, then the higher CNR.
fn better_single_camera(vis: &PhaseSummary, tir: &PhaseSummary) -> bool {
    let rot = |s: &PhaseSummary| s.rot_err_deg_median.unwrap_or(f64::INFINITY);
    (vis.lost_frac, rot(vis), -vis.cnr) <= (tir.lost_frac, rot(tir), -tir.cnr)
}

fn markdown(s: &Summary, charts: &[PathBuf], seconds: f64) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# Navigation benchmark\n");
    let _ = writeln!(
        md,
        "Every stream of the rendezvous sequences (`approach`: 50 m → 5 m in light, target tumbling; \
`flyaround`: a circumnavigation at 8 m through an eclipse) through one front end: FAST-9 on the \
target after σ = 1.5 px smoothing, BRIEF-256 matches frame to frame (mutual best, 48 px window), \
PnP-RANSAC (SQPnP) against the previous frame's rendered depth. Noisy frames (the study's sensor \
model). A pair counts in the phase of its second frame; error medians are over the pairs not lost. \
Generated by `fusion navbench` in {seconds:.0} s.\n"
    );
    for phase in PHASES {
        let p = phase.as_str();
        if !s.sources.values().any(|v| v.contains_key(p)) {
            continue;
        }
        let _ = writeln!(md, "## {p}\n");
        let _ = writeln!(
            md,
            "| stream | CNR | features | tracks | inlier ratio | rotation error ° (median) | translation dir. error ° (median) | lost | never worse than the better camera | better on |"
        );
        let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|");
        let (vis, tir) =
            (s.sources.get("vis").and_then(|v| v.get(p)), s.sources.get("tir").and_then(|v| v.get(p)));
        for (name, phases) in &s.sources {
            let Some(x) = phases.get(p) else { continue };
            let verdict = match (vis, tir) {
                (Some(v), Some(t)) if name != "vis" && name != "tir" => {
                    let (ok, better) = judge(x, v, t);
                    (if ok { "yes" } else { "no" }.to_string(), better.join(", "))
                }
                _ => ("—".to_string(), String::new()),
            };
            let _ = writeln!(
                md,
                "| {name} | {:.2} | {:.1} | {:.1} | {:.3} | {} | {} | {:.3} | {} | {} |",
                x.cnr,
                x.target_features,
                x.tracks,
                x.inlier_ratio,
                fmt_opt(x.rot_err_deg_median),
                fmt_opt(x.trans_dir_err_deg_median),
                x.lost_frac,
                verdict.0,
                verdict.1
            );
        }
        let _ = writeln!(md);
        // In words.
        if let (Some(v), Some(t)) = (vis, tir) {
            let mut helps = Vec::new();
            let mut hurts = Vec::new();
            for (name, phases) in &s.sources {
                if name == "vis" || name == "tir" {
                    continue;
                }
                if let Some(x) = phases.get(p) {
                    let (ok, better) = judge(x, v, t);
                    if ok && !better.is_empty() {
                        helps.push(format!("{name} ({})", better.join(", ")));
                    } else if !ok {
                        hurts.push(name.clone());
                    }
                }
            }
            let better_cam = if better_single_camera(v, t) { "vis" } else { "tir" };
            let _ = writeln!(
                md,
                "In {p}, the better single camera is **{better_cam}**. Streams never worse than it and better on some measure: {}. Streams worse than it on some measure: {}.\n",
                if helps.is_empty() { "none".to_string() } else { helps.join("; ") },
                if hurts.is_empty() { "none".to_string() } else { hurts.join(", ") }
            );
        }
    }
    if !s.skip.is_empty() {
        let _ = writeln!(
            md,
            "## Scene skipping\n\n| method | target coverage (min) | window share of the frame (mean) |\n|---|---|---|"
        );
        for (m, k) in &s.skip {
            let _ = writeln!(md, "| {m} | {:.4} | {:.4} |", k.target_coverage_min, k.window_frac_mean);
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(md, "## Charts\n");
    for c in charts {
        if let Some(n) = c.file_name() {
            let _ = writeln!(md, "![{}]({})", n.to_string_lossy(), n.to_string_lossy());
        }
    }
    md
}
