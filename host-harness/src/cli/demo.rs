//! `fusion demo`: the whole main job on the built-in default scene, in one command.
//!
//! 1. Renders a short dataset of the procedural Tango-like target (VIS 1024² in light and in
//!    eclipse, TIR 512², with sensor noise) into `OUT/dataset/`.
//! 2. Fuses every frame with every core method (TIR upscaled to the VIS grid with bicubic, as
//!    the flight pipeline does) and writes `OUT/fused/<illumination>/<method>/frame_NNN.png`.
//! 3. Writes `OUT/contact_sheet.png` (per illumination one row: VIS, TIR upscaled, then each
//!    method, cropped to the target) and `OUT/summary.md` / `OUT/summary.csv`: per method and
//!    illumination the median core time and the mean fusion metrics.
//! 4. Navigation, as `fusion navbench` judges it, in short: navbench's 120-frame fly-around
//!    through the eclipse (VIS 1024², TIR 512², 2 × 2 sub-pixel samples where navbench renders
//!    4 × 4, `OUT/flyaround/`), VIS, TIR and the adaptive fusion through
//!    the model-based front end and the filter beside the two baselines;
//!    `OUT/navigation_attitude_error.png` (the filter's attitude error and 3σ per frame) and the
//!    availability of each in `summary.md`.

use anyhow::Result;
use clap::Args;
use fusion_engine::study::{Dataset, core_methods, fuse_timed, grid};
use fusion_io::save_gray_u8;
use fusion_io::source_on_grid;
use fusion_metrics::{average_gradient, mutual_information, rmse, ssim};
use fusion_nostd::pipeline::{FuseConfig, RescalePolicy};
use fusion_nostd::{Filter, Guards};
use fusion_report::sheet::{labelled_sheet, target_square, tile};
use render_host::{DatasetConfig, render_dataset};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `fusion demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output folder (created; its `dataset/` is reused when it already holds a manifest).
    #[arg(long, default_value = "fusion-demo")]
    pub out: PathBuf,
    /// Frames to render and fuse.
    #[arg(long, default_value_t = 4)]
    pub frames: usize,
    /// Timing repeats per fusion (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
}

/// One row of the summary: a method under one illumination, averaged over the frames.
#[derive(Debug, Clone, Default)]
struct Row {
    ms: Vec<f64>,
    ag: f64,
    mi: f64,
    rmse: f64,
    ssim: f64,
    guards: Guards,
}

/// Runs `fusion demo`.
pub fn run(args: &DemoArgs) -> Result<()> {
    let started = Instant::now();
    let _folder = fusion_io::output::create_folder(&args.out)?;
    let data_dir = args.out.join("dataset");
    let dataset = match Dataset::open(&data_dir) {
        Ok(d) if d.frames() >= args.frames => {
            outln!("reusing the dataset in {}", data_dir.display())?;
            d
        }
        _ => {
            let cfg = DatasetConfig {
                frames: args.frames.max(1),
                tir_sizes: vec![512],
                ..DatasetConfig::default()
            };
            outln!("rendering {} frames (VIS 1024² light + eclipse, TIR 512²) …", cfg.frames)?;
            let t = Instant::now();
            render_dataset(&cfg, &data_dir, true)?;
            outln!("  rendered in {:.1} s → {}", t.elapsed().as_secs_f64(), data_dir.display())?;
            Dataset::open(&data_dir)?
        }
    };

    // The published methods and the adaptive fusion for navigation (no published counterpart,
    // so not among the study's methods).
    let mut methods = core_methods();
    methods.push(fusion_engine::study::NamedMethod {
        name: "adaptive",
        method: fusion_nostd::Method::Adaptive(fusion_nostd::AdaptiveParams::default()),
    });
    let illuminations = ["light", "eclipse"];
    let frames = args.frames.min(dataset.frames()).max(1);
    let mut rows: Vec<Vec<Row>> = vec![vec![Row::default(); methods.len()]; illuminations.len()];
    let mut sheet_rows = Vec::new();
    outln!(
        "fusing {frames} frames × {} illuminations × {} methods with the core …",
        illuminations.len(),
        methods.len()
    )?;
    for (ii, ill) in illuminations.iter().enumerate() {
        for f in 0..frames {
            let vis = dataset.image(&format!("vis_{ill}"), f, true)?;
            let tir = dataset.image("tir512", f, true)?;
            let g = grid(&vis, &tir, RescalePolicy::TirUp)?;
            let tir_up = source_on_grid(&tir, g, Filter::Cubic)?;
            let mut fused_all = Vec::new();
            for (mi, m) in methods.iter().enumerate() {
                let pipeline =
                    FuseConfig { rescale: RescalePolicy::TirUp, method: m.method, ..Default::default() };
                let r = fuse_timed(&vis, &tir, &pipeline, args.repeats)?;
                let path = args.out.join("fused").join(ill).join(m.name).join(format!("frame_{f:03}.png"));
                std::fs::create_dir_all(path.parent().unwrap_or(&args.out))?;
                save_gray_u8(&path, &r.fused)?;
                let n = frames as f64;
                let row = &mut rows[ii][mi];
                row.ms.push(r.seconds * 1e3);
                row.ag += average_gradient(&r.fused) / n;
                row.mi += (mutual_information(&vis, &r.fused) + mutual_information(&tir_up, &r.fused)) / n;
                row.ssim += (ssim(&vis, &r.fused) + ssim(&tir_up, &r.fused)) / n;
                row.rmse += (rmse(&vis, &r.fused) + rmse(&tir_up, &r.fused)) / (2.0 * n);
                row.guards |= r.guards;
                fused_all.push(r.fused);
            }
            if f == 0 {
                let mut images = vec![&vis, &tir_up];
                images.extend(fused_all.iter());
                // Crop to the target, found on the noiseless renders (space is exactly black there).
                let clean_vis = dataset.image("vis_light", f, false)?;
                let clean_tir = source_on_grid(&dataset.image("tir512", f, false)?, g, Filter::Cubic)?;
                let square = target_square(&[&clean_vis, &clean_tir], 4, 0.15);
                let tiles: Result<Vec<_>> = images.iter().map(|img| tile(img, square, 256)).collect();
                sheet_rows.push(tiles?);
            }
        }
    }
    let mut columns = vec!["VIS", "TIR up"];
    columns.extend(methods.iter().map(|m| m.name));
    let sheet = labelled_sheet(&sheet_rows, 4, &columns, &illuminations);
    let sheet_path = args.out.join("contact_sheet.png");
    save_gray_u8(&sheet_path, &sheet)?;

    let mut md = String::new();
    let _ = writeln!(
        md,
        "# fusion demo\n\n{frames} frames of the default scene (VIS 1024², TIR 512² upscaled to 1024² with \
         bicubic), noisy inputs, fused by the no_std core on the host (one thread). Time: median over \
         frames of the per-frame median of {} runs. Metrics: the study's suite (`fusion eval \
         --suite study`, docs/metrics.md: AG of F; MI in bits and SSIM summed over F against VIS and \
         against the upscaled TIR; RMSE their mean), averaged over the frames; `fusion eval` adds FMI \
         and, with `--suite vifb`, VIFB's 13. Guards: the guards any frame fired, by name \
         (`fusion_nostd::Guards::NAMED`; the CSV has the bit set).\n\nContact sheet columns: VIS, TIR (upscaled), {}; rows: {}.\n",
        args.repeats.max(1),
        methods.iter().map(|m| m.name).collect::<Vec<_>>().join(", "),
        illuminations.join(", ")
    );
    let _ = writeln!(md, "| illumination | method | time ms | AG | MI | SSIM | RMSE | guards |");
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
    let mut csv = String::from("illumination,method,time_ms,ag,mi,ssim,rmse,guards\n");
    for (ii, ill) in illuminations.iter().enumerate() {
        for (mi, m) in methods.iter().enumerate() {
            let row = &mut rows[ii][mi];
            let ms = fusion_engine::study::median(&mut row.ms);
            let _ = writeln!(
                md,
                "| {ill} | {} | {ms:.1} | {:.3} | {:.3} | {:.3} | {:.3} | {} |",
                m.name, row.ag, row.mi, row.ssim, row.rmse, row.guards
            );
            let _ = writeln!(
                csv,
                "{ill},{},{ms:.3},{:.5},{:.5},{:.5},{:.5},{}",
                m.name, row.ag, row.mi, row.ssim, row.rmse, row.guards.0
            );
        }
    }
    let nav = navigation(&args.out)?;
    let _ = writeln!(md, "{}", nav.markdown);
    let mut summary = fusion_io::Batch::default();
    summary.add_bytes(&args.out.join("summary.md"), md.as_bytes())?;
    summary.add_bytes(&args.out.join("summary.csv"), csv.as_bytes())?;
    summary.commit()?;
    outln!("\n{md}")?;
    outln!("fused images: {}", args.out.join("fused").display())?;
    outln!("contact sheet: {}", sheet_path.display())?;
    outln!("navigation chart: {}", nav.chart.display())?;
    outln!("summary: {}", args.out.join("summary.md").display())?;
    outln!("done in {:.1} s", started.elapsed().as_secs_f64())?;
    Ok(())
}

/// What the demo's navigation part wrote.
struct Navigation {
    chart: PathBuf,
    markdown: String,
}

/// Step 4: a short fly-around through the eclipse, VIS, TIR and the adaptive fusion through
/// `fusion navbench`'s chain (one seed), the attitude chart and the availability per source.
fn navigation(out: &std::path::Path) -> Result<Navigation> {
    use fusion_navbench::bench::{PHASE_ALL, run_sequence, summary};
    use render_host::sequence::{SequenceConfig, SequenceName, render_sequence};
    let dir = out.join("flyaround");
    // Navbench's frames at 2 × 2 sub-pixel samples instead of 4 × 4: a quarter of the rays,
    // so the demo stays within a minute (the sequence at full size: the target is large enough
    // for the model's edges, and the adaptive method fuses it by ADF).
    let base = SequenceConfig::new(SequenceName::Flyaround);
    let cfg = SequenceConfig {
        frames: 120,
        vis_size: 1024,
        tir_size: 512,
        vis: render_host::vis::VisParams { samples: 2, ..base.vis },
        tir: render_host::tir::TirParams { samples: 2, ..base.tir },
        ..base
    };
    if !dir.join("manifest.json").is_file() {
        outln!("rendering a {}-frame fly-around through the eclipse (VIS 1024², TIR 512²) …", cfg.frames)?;
        // Whole or absent: an interrupted render leaves no half-written sequence.
        fusion_io::output::in_new_folder(&dir, |d| render_sequence(&cfg, d, false))?;
    }
    let only = ["vis".to_string(), "tir".to_string(), "adaptive".to_string()];
    outln!("navigating it with VIS, TIR and the adaptive fusion (and the two baselines) …")?;
    let rows =
        run_sequence(&dir, None, Some(&only), false, fusion_navbench::registration::Registration::Filter)?;
    let seq: Vec<&fusion_navbench::bench::FrameResult> = rows.iter().collect();
    let chart = super::navbench::error_chart(
        &out.join("navigation_attitude_error"),
        "fly-around (120 frames): filter attitude error and its 3σ (thin)",
        "attitude error, degrees (log)",
        &seq,
        &|r| (r.att_err_deg, r.att_3sigma_deg),
    )?;
    let s = summary(&rows);
    let mut md = String::from(
        "## Navigation (as `fusion navbench` judges it, one seed)\n\nA 120-frame fly-around through the eclipse (VIS 1024², TIR 512²); \
         each source through the model-based front end and the filter. Available: share of the frames with \
         attitude error ≤ 2° and position error ≤ 2 % of range; by the relative position: the same with the \
         target's position in the camera's frame (the line of sight guidance steers on) in place of the \
         camera's in the target's. Chart: `navigation_attitude_error.png`.\n\n\
         | source | available | available (relative position) | attitude RMS ° |\n|---|---|---|---|\n",
    );
    for src in ["zero-motion", "oracle", "vis", "tir", "adaptive"] {
        if let Some(x) = s.sources.get(src).and_then(|p| p.get(PHASE_ALL)) {
            let _ = writeln!(
                md,
                "| {src} | {:.3} | {:.3} | {:.3} |",
                x.availability, x.availability_rel, x.att_rms_deg
            );
        }
    }
    Ok(Navigation { chart, markdown: md })
}
