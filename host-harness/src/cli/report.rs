//! `fusion report`: the study's Tables 2–7 on our renders, with plots and the conclusions our
//! numbers confirm or refute.
//!
//! Over a rendered dataset (rendered first when the folder has no manifest):
//! * **Table 2** — TIR 512 → 1024 (noisy input) with area, bicubic (core) and Lanczos-3 (host)
//!   against the TIR rendered natively at 1024² without noise: MSE_S, PSNR_S, SSIM_S.
//! * **Table 3** — VIS 1024 → 512 (noisy) with the same three, against VIS rendered natively at
//!   512² without noise, eclipse and light.
//! * **Tables 4/5** — fusion metrics (AG, MI, FMI, SSIM, RMSE; 1:2) of each method with TIR
//!   upscaled (1024² grid) and with VIS downscaled (512² grid), noisy inputs, eclipse and light;
//!   plus the fraction of output pixels newly saturated at 255 (IFEVIP's in-light problem).
//! * **Table 6** — noise metrics (1:1) of each method's fused noisy frame against the same
//!   method's fusion of the noiseless same-resolution pair (VIS 1024² + TIR 1024²), for three
//!   inputs: VIS down (compared with the reference area-downscaled to 512²), TIR up, same res.
//! * **Table 7** — median core time per method on both grids (one thread).
//!
//! The study's four other methods (GFF, MGFF, TEPGFL, DRIF; [`crate::study_methods`]) have no
//! core path: they run on the host in f64, one thread, and are timed that way (once per frame).
//! DRIF fuses VIS 1024² with TIR 512² as they are and outputs on the VIS grid: it has a row in
//! Table 4 (compared with the same sources as the others), none in Table 5, and one Table 6 row
//! ("different res") against its fusion of the noiseless same-resolution pair. Tables 4/5 also
//! give the target's brightness relative to the sources and a halo measure, so that the study's
//! qualitative findings (GFF darkens with TIR upscaling, TEPGFL halos, DRIF textureless and slow)
//! can be checked with numbers.
//!
//! Everything goes to `OUT/`: `report.md` (our tables beside the study's numbers and the
//! conclusions), one CSV per table, per-frame CSV and charts, and a contact sheet.

use crate::io::{Gray, save_gray_u8};
use crate::metrics::{FusionMetrics, NoiseMetrics, format_psnr, fusion_metrics, noise_metrics};
use crate::plot::{Labels, Series, Style, chart};
use crate::reference::rescale::lanczos3_u8;
use crate::study::{
    Dataset, NamedMethod, contact_sheet, core_methods, fuse_timed, median, source_on_grid, target_square,
    tile,
};
use crate::study_methods::guided_filter::box_mean;
use crate::study_methods::{HostMethod, fuse_host_u8};
use anyhow::{Context, Result};
use clap::Args;
use fusion_nostd::Filter;
use fusion_nostd::pipeline::{FuseConfig, RescalePolicy};
use rayon::prelude::*;
use render_host::{
    Camera, DatasetConfig, Illumination, Scene, VisParams, render_dataset, render_vis, trajectory,
};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `fusion report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Dataset folder (from `fusion render`); rendered here with the study's layout when it
    /// holds no `manifest.json`.
    #[arg(long)]
    pub data: PathBuf,
    /// Output folder for the report, CSVs and plots.
    #[arg(long)]
    pub out: PathBuf,
    /// Use only the first N frames (default: all).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Frames to render when the dataset folder is empty.
    #[arg(long, default_value_t = 20)]
    pub render_frames: usize,
    /// Timing repeats per fusion (median).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
}

/// Per-frame values of one table cell: `(table, row, column) → values`.
#[derive(Debug, Default)]
struct Cells(BTreeMap<(String, String, String), Vec<f64>>);

impl Cells {
    fn push(&mut self, table: &str, row: &str, col: &str, v: f64) {
        self.0.entry((table.into(), row.into(), col.into())).or_default().push(v);
    }

    fn values(&self, table: &str, row: &str, col: &str) -> &[f64] {
        self.0.get(&(table.to_string(), row.to_string(), col.to_string())).map_or(&[], Vec::as_slice)
    }

    /// Mean of the finite values (infinite PSNRs are left out and said so by `format`).
    fn mean(&self, table: &str, row: &str, col: &str) -> f64 {
        let v: Vec<f64> = self.values(table, row, col).iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
    }

    /// Median of the values (NaN when there are none).
    fn median(&self, table: &str, row: &str, col: &str) -> f64 {
        let v = self.values(table, row, col);
        if v.is_empty() { f64::NAN } else { median(&mut v.to_vec()) }
    }
}

const ILLUMINATIONS: [(&str, Illumination); 2] =
    [("eclipse", Illumination::Eclipse), ("light", Illumination::Light)];
const RESCALERS: [&str; 3] = ["area", "bicubic", "lanczos3"];

/// Rescales with one of the three compared filters (area and bicubic: the core, OpenCV
/// conventions; Lanczos-3: host f64, MATLAB conventions).
fn rescale_with(img: &Gray<u8>, name: &str, w: usize, h: usize) -> Result<Gray<u8>> {
    match name {
        "area" => source_on_grid(img, (w, h), Filter::Area),
        "bicubic" => source_on_grid(img, (w, h), Filter::Cubic),
        _ => Ok(lanczos3_u8(img, w, h)),
    }
}

fn to_gray(img: &render_host::Image) -> Gray<u8> {
    let g = img.to_gray8();
    Gray { width: g.width() as usize, height: g.height() as usize, data: g.into_raw() }
}

/// The natively rendered noiseless VIS frames at another size (Table 3's ground truth),
/// rendered with the dataset's own configuration.
struct NativeVis {
    cfg: DatasetConfig,
    scene: Scene,
    poses: Vec<render_host::Pose>,
}

impl NativeVis {
    fn new(cfg: &DatasetConfig) -> Result<Self> {
        let scene = cfg.scene()?;
        let poses = trajectory(cfg, scene.centre).iter().map(|t| t.pose).collect();
        Ok(Self { cfg: cfg.clone(), scene, poses })
    }

    fn render(&self, frame: usize, size: u32, ill: Illumination) -> Result<Gray<u8>> {
        let pose = *self.poses.get(frame).context("frame outside the trajectory")?;
        let sun = self.cfg.vis.sun_dir.normalize();
        let params = VisParams { sun_dir: sun, ..self.cfg.vis }.with_illumination(ill);
        Ok(to_gray(&render_vis(&self.scene, &Camera::study(size, pose), &params)))
    }
}

fn put_fusion(cells: &mut Cells, table: &str, row: &str, m: &FusionMetrics) {
    for (col, v) in [("AG", m.ag), ("MI", m.mi), ("FMI", m.fmi), ("SSIM", m.ssim), ("RMSE", m.rmse)] {
        cells.push(table, row, col, v);
    }
}

fn put_noise(cells: &mut Cells, table: &str, row: &str, n: &NoiseMetrics) {
    for (col, v) in [("MSE_S", n.mse_s), ("PSNR_S", n.psnr_s), ("SSIM_S", n.ssim_s)] {
        cells.push(table, row, col, v);
    }
}

/// The target and the band around its outline on one grid, from the noiseless sources.
struct TargetZone {
    /// Pixels where either noiseless source is above [`TARGET_LEVEL`].
    target: Vec<bool>,
    /// Pixels within [`HALO_RADIUS`] px of the target's outline (either side): their window
    /// holds both target and background pixels.
    band: Vec<bool>,
}

/// Grey level above which a noiseless source pixel belongs to the target.
const TARGET_LEVEL: u8 = 10;
/// Half-width of the band around the outline where halos are measured, px.
const HALO_RADIUS: usize = 8;

impl TargetZone {
    fn new(vis_clean: &Gray<u8>, tir_clean: &Gray<u8>) -> Self {
        let target: Vec<bool> =
            vis_clean.data.iter().zip(&tir_clean.data).map(|(&v, &t)| v.max(t) > TARGET_LEVEL).collect();
        let frac = box_mean(
            &Gray {
                width: vis_clean.width,
                height: vis_clean.height,
                data: target.iter().map(|&t| f64::from(u8::from(t))).collect(),
            },
            HALO_RADIUS,
        );
        let band = frac.data.iter().map(|&f| f > 1e-9 && f < 1.0 - 1e-9).collect();
        Self { target, band }
    }
}

/// Mean of `fused` over the target divided by the mean of `½(vis + tir)` there (NaN without a
/// target): below 1 the fusion is darker than the sources' average on the target.
fn target_level(zone: &TargetZone, vis: &Gray<u8>, tir: &Gray<u8>, fused: &Gray<u8>) -> f64 {
    let (mut f, mut s) = (0.0, 0.0);
    for (i, _) in zone.target.iter().enumerate().filter(|(_, t)| **t) {
        f += f64::from(fused.data[i]);
        s += 0.5 * (f64::from(vis.data[i]) + f64::from(tir.data[i]));
    }
    if s > 0.0 { f / s } else { f64::NAN }
}

/// Halo measure: the mean distance (grey levels) by which `fused` leaves the range
/// `[min(vis, tir), max(vis, tir)]` of its two sources, over the band around the target's
/// outline. A fusion that only mixes its sources scores 0; over- and undershoots next to edges
/// (halos, ringing) raise it.
fn halo(zone: &TargetZone, vis: &Gray<u8>, tir: &Gray<u8>, fused: &Gray<u8>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (i, _) in zone.band.iter().enumerate().filter(|(_, b)| **b) {
        let (v, t, f) = (vis.data[i], tir.data[i], fused.data[i]);
        let (lo, hi) = (v.min(t), v.max(t));
        sum += f64::from(f.saturating_sub(hi)) + f64::from(lo.saturating_sub(f));
        n += 1;
    }
    if n > 0 { sum / n as f64 } else { f64::NAN }
}

/// Every row name of Tables 4–7: the core's methods, then the host-only ones.
fn row_names(methods: &[NamedMethod]) -> Vec<&'static str> {
    methods.iter().map(|m| m.name).chain(HostMethod::ALL.iter().map(|h| h.name())).collect()
}

/// The Table 6 row of a method's noise with TIR upscaled (DRIF: at different resolutions).
fn tir_up_row(name: &str) -> String {
    if name == HostMethod::Drif.name() { format!("{name}|different res") } else { format!("{name}|TIR up") }
}

/// One method's fusions of a frame pair: TIR up (DRIF: different res), VIS down, the noisy
/// same-res pair, the noiseless same-res reference and that reference area-downscaled.
struct Run {
    name: &'static str,
    up: Gray<u8>,
    down: Option<Gray<u8>>,
    same: Option<Gray<u8>>,
    reference: Gray<u8>,
    ref_down: Option<Gray<u8>>,
}

/// Fraction of pixels at 255 in `fused` that are below 255 in `vis`.
fn newly_saturated(vis: &Gray<u8>, fused: &Gray<u8>) -> f64 {
    let n = fused.data.iter().zip(&vis.data).filter(|&(&f, &v)| f == 255 && v < 255).count();
    n as f64 / fused.data.len().max(1) as f64
}

/// Runs `fusion report`.
pub fn run(args: &ReportArgs) -> Result<()> {
    let started = Instant::now();
    let dataset = match Dataset::open(&args.data) {
        Ok(d) => d,
        Err(_) => {
            let cfg = DatasetConfig { frames: args.render_frames.max(1), ..DatasetConfig::default() };
            outln!(
                "no dataset in {}: rendering the study's layout ({} frames) …",
                args.data.display(),
                cfg.frames
            )?;
            render_dataset(&cfg, &args.data, true)?;
            Dataset::open(&args.data)?
        }
    };
    let has = |set: &str| dataset.manifest.sets.iter().any(|s| s.name == set);
    // The study's geometry scaled to the dataset: VIS V², TIR (V/2)², native TIR V².
    let big = dataset.manifest.config.vis_size as usize;
    let small = big / 2;
    let (tir_small, tir_big) = (format!("tir{small}"), format!("tir{big}"));
    for set in ["vis_light", "vis_eclipse", &tir_small, &tir_big] {
        anyhow::ensure!(has(set), "the dataset has no {set} set (render it with --tir-sizes {small},{big})");
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let frames = args.frames.unwrap_or(usize::MAX).min(dataset.frames());
    let native = NativeVis::new(&dataset.manifest.config)?;
    let methods = core_methods();
    let mut cells = Cells::default();
    let mut sheet_rows = Vec::new();
    let sheet_frame = frames / 2;

    for f in 0..frames {
        let t_frame = Instant::now();
        let tir_n = dataset.image(&tir_small, f, true)?;
        let tir1024_n = dataset.image(&tir_big, f, true)?;
        let tir1024_c = dataset.image(&tir_big, f, false)?;
        let tir_c = dataset.image(&tir_small, f, false)?;
        // Table 2: TIR up against the native noiseless 1024².
        for r in RESCALERS {
            let up = rescale_with(&tir_n, r, big, big)?;
            put_noise(&mut cells, "t2", r, &noise_metrics(&up, &tir1024_c));
        }
        for (ill, illum) in ILLUMINATIONS {
            let vis_n = dataset.image(&format!("vis_{ill}"), f, true)?;
            let vis_c = dataset.image(&format!("vis_{ill}"), f, false)?;
            // Table 3: VIS down against the native noiseless 512².
            let vis512_c = native.render(f, small as u32, illum)?;
            for r in RESCALERS {
                let down = rescale_with(&vis_n, r, small, small)?;
                put_noise(&mut cells, &format!("t3-{ill}"), r, &noise_metrics(&down, &vis512_c));
            }
            let tir_up = source_on_grid(&tir_n, (big, big), Filter::Cubic)?;
            let vis_down = source_on_grid(&vis_n, (small, small), Filter::Area)?;
            // Target zones for the level and halo measures, from the noiseless sources.
            let clean_tir_up = source_on_grid(&tir_c, (big, big), Filter::Cubic)?;
            let zone_big = TargetZone::new(&vis_c, &clean_tir_up);
            let zone_small = TargetZone::new(&source_on_grid(&vis_c, (small, small), Filter::Area)?, &tir_c);
            // Fusions one after the other (timed), then their metrics in parallel.
            let mut runs = Vec::new();
            for m in &methods {
                let NamedMethod { name, method } = *m;
                let up = fuse_timed(
                    &vis_n,
                    &tir_n,
                    &FuseConfig { rescale: RescalePolicy::TirUp, method, ..Default::default() },
                    args.repeats,
                )?;
                let down = fuse_timed(
                    &vis_n,
                    &tir_n,
                    &FuseConfig { rescale: RescalePolicy::VisDown, method, ..Default::default() },
                    args.repeats,
                )?;
                let none = FuseConfig { rescale: RescalePolicy::None, method, ..Default::default() };
                let same = fuse_timed(&vis_n, &tir1024_n, &none, 1)?;
                let reference = fuse_timed(&vis_c, &tir1024_c, &none, 1)?;
                let ref_down = source_on_grid(&reference.fused, (small, small), Filter::Area)?;
                cells.push("t7", name, "big", up.seconds);
                cells.push("t7", name, "small", down.seconds);
                runs.push(Run {
                    name,
                    up: up.fused,
                    down: Some(down.fused),
                    same: Some(same.fused),
                    reference: reference.fused,
                    ref_down: Some(ref_down),
                });
            }
            // The host-only methods (f64): the timed fusions one at a time (rescale included),
            // then the untimed ones (noisy same-res, noiseless reference) in parallel.
            let mut host_runs = Vec::new();
            for host in HostMethod::ALL {
                let name = host.name();
                let t = Instant::now();
                let up = if host.different_resolution() {
                    fuse_host_u8(host, &vis_n, &tir_n)?.0
                } else {
                    fuse_host_u8(host, &vis_n, &source_on_grid(&tir_n, (big, big), Filter::Cubic)?)?.0
                };
                cells.push("t7", name, "big", t.elapsed().as_secs_f64());
                let down = if host.different_resolution() {
                    None
                } else {
                    let t = Instant::now();
                    let down =
                        fuse_host_u8(host, &source_on_grid(&vis_n, (small, small), Filter::Area)?, &tir_n)?.0;
                    cells.push("t7", name, "small", t.elapsed().as_secs_f64());
                    Some(down)
                };
                host_runs.push((host, up, down));
            }
            let untimed = HostMethod::ALL
                .par_iter()
                .map(|&host| -> Result<_> {
                    let reference = fuse_host_u8(host, &vis_c, &tir1024_c)?.0;
                    let same = if host.different_resolution() {
                        None
                    } else {
                        Some(fuse_host_u8(host, &vis_n, &tir1024_n)?.0)
                    };
                    Ok((reference, same))
                })
                .collect::<Result<Vec<_>>>()?;
            for ((host, up, down), (reference, same)) in host_runs.into_iter().zip(untimed) {
                let ref_down = if down.is_some() {
                    Some(source_on_grid(&reference, (small, small), Filter::Area)?)
                } else {
                    None
                };
                runs.push(Run { name: host.name(), up, down, same, reference, ref_down });
            }
            let measured: Vec<_> = runs
                .par_iter()
                .map(|r| {
                    let up = (
                        fusion_metrics(&vis_n, &tir_up, &r.up),
                        newly_saturated(&vis_n, &r.up),
                        target_level(&zone_big, &vis_n, &tir_up, &r.up),
                        halo(&zone_big, &vis_n, &tir_up, &r.up),
                    );
                    let down = r.down.as_ref().map(|d| {
                        (
                            fusion_metrics(&vis_down, &tir_n, d),
                            newly_saturated(&vis_down, d),
                            target_level(&zone_small, &vis_down, &tir_n, d),
                            halo(&zone_small, &vis_down, &tir_n, d),
                        )
                    });
                    let mut noise = Vec::new();
                    if let (Some(d), Some(rd)) = (&r.down, &r.ref_down) {
                        noise.push(("VIS down".to_string(), noise_metrics(d, rd)));
                    }
                    noise.push((tir_up_row(r.name), noise_metrics(&r.up, &r.reference)));
                    if let Some(same) = &r.same {
                        noise.push((format!("{}|same res", r.name), noise_metrics(same, &r.reference)));
                    }
                    (up, down, noise)
                })
                .collect();
            let mut sheet_fused = Vec::new();
            for (run, (up, down, noise)) in runs.into_iter().zip(measured) {
                let name = run.name;
                for (table, m) in [("t4", Some(up)), ("t5", down)] {
                    let Some((metrics, sat, level, halo)) = m else { continue };
                    let t = format!("{table}-{ill}");
                    put_fusion(&mut cells, &t, name, &metrics);
                    cells.push(&t, name, "sat", sat);
                    cells.push(&t, name, "level", level);
                    cells.push(&t, name, "halo", halo);
                }
                for (row, n) in &noise {
                    let row = if row == "VIS down" { format!("{name}|VIS down") } else { row.clone() };
                    put_noise(&mut cells, &format!("t6-{ill}"), &row, n);
                }
                if f == sheet_frame {
                    sheet_fused.push(run.up);
                }
            }
            if f == sheet_frame {
                let square =
                    target_square(&[&vis_c, &clean_tir_up, &dataset.image("vis_light", f, false)?], 4, 0.15);
                let mut row = vec![tile(&vis_n, square, 256)?, tile(&tir_up, square, 256)?];
                for fused in &sheet_fused {
                    row.push(tile(fused, square, 256)?);
                }
                sheet_rows.push(row);
            }
        }
        outln!("frame {}/{frames} in {:.1} s", f + 1, t_frame.elapsed().as_secs_f64())?;
    }

    let sheet_path = args.out.join("contact_sheet.png");
    save_gray_u8(&sheet_path, &contact_sheet(&sheet_rows, 4))?;
    let charts = write_charts(&cells, &methods, frames, &args.out)?;
    write_csvs(&cells, &args.out)?;
    let md =
        markdown(&cells, &methods, frames, &dataset, &charts, started.elapsed().as_secs_f64(), (small, big));
    let report = args.out.join("report.md");
    crate::io::write_bytes(&report, md.as_bytes())?;
    outln!("{md}")?;
    outln!("report: {}", report.display())?;
    Ok(())
}

/// One CSV with every per-frame value: `table,row,column,frame,value`.
fn write_csvs(cells: &Cells, out: &Path) -> Result<()> {
    let mut per_frame = String::from("table,row,column,frame,value\n");
    let mut means = String::from("table,row,column,mean,median,frames\n");
    for ((t, r, c), v) in &cells.0 {
        for (i, x) in v.iter().enumerate() {
            let _ = writeln!(per_frame, "{t},{r},{c},{i},{x}");
        }
        let _ = writeln!(means, "{t},{r},{c},{},{},{}", cells.mean(t, r, c), cells.median(t, r, c), v.len());
    }
    let mut tables = crate::io::Batch::default();
    tables.add_bytes(&out.join("per_frame.csv"), per_frame.as_bytes())?;
    tables.add_bytes(&out.join("tables.csv"), means.as_bytes())?;
    tables.commit()?;
    Ok(())
}

/// Per-frame metric curves (as the study's figures 10 and 12): for each illumination, the
/// 1:2 metrics with TIR upscaled and the noise PSNR_S, one line per method (core and host;
/// DRIF at different resolutions).
fn write_charts(cells: &Cells, methods: &[NamedMethod], frames: usize, out: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for (ill, _) in ILLUMINATIONS {
        for (table, col, what) in [
            ("t4", "AG", "AG, TIR upscaled"),
            ("t4", "MI", "MI, TIR upscaled"),
            ("t4", "FMI", "FMI, TIR upscaled"),
            ("t4", "SSIM", "SSIM, TIR upscaled"),
            ("t6", "PSNR_S", "PSNR_S (noisy vs noiseless fusion), TIR upscaled"),
        ] {
            let series: Vec<Series> = row_names(methods)
                .into_iter()
                .map(|name| {
                    let row = if table == "t6" { tir_up_row(name) } else { name.to_string() };
                    let v = cells.values(&format!("{table}-{ill}"), &row, col);
                    Series {
                        name: name.into(),
                        points: v.iter().enumerate().map(|(i, &y)| (i as f64, y)).collect(),
                    }
                })
                .collect();
            let title = format!("{what}, {ill}, per frame ({frames} frames)");
            let stem = out.join(format!("frames_{}_{ill}", col.to_lowercase()));
            written.push(chart(&stem, Labels { title: &title, x: "frame", y: col }, &series, Style::Lines)?);
        }
    }
    Ok(written)
}

fn fmt(v: f64, digits: usize) -> String {
    if v.is_nan() { "–".into() } else { format!("{v:.digits$}") }
}

/// The study's numbers (shared/reference/study-results.md) for the rows we have.
fn study_t2(r: &str) -> (f64, f64, f64) {
    match r {
        "area" => (0.0065, 22.13, 0.48),
        "bicubic" => (0.0063, 22.29, 0.49),
        _ => (0.0063, 22.24, 0.48),
    }
}

fn study_t3(r: &str, ill: &str) -> (f64, f64, f64) {
    match (r, ill) {
        ("area", "eclipse") => (0.00075, 31.34, 0.57),
        ("bicubic", "eclipse") => (0.00094, 30.34, 0.54),
        ("lanczos3", "eclipse") => (0.00104, 29.87, 0.51),
        ("area", _) => (0.0022, 27.19, 0.56),
        ("bicubic", _) => (0.0024, 26.70, 0.53),
        _ => (0.0025, 26.48, 0.50),
    }
}

/// Study rows of Tables 4 and 5 (eclipse only; TSIFSD classic and flight share the TSIFSD row).
fn study_t45(table: &str, method: &str) -> Option<[f64; 5]> {
    let up = table == "t4";
    Some(match (method.split('-').next()?, up) {
        ("adf", true) => [14.66, 0.98, 0.848, 1.96, 12.31],
        ("adf", false) => [14.56, 1.232, 0.867, 0.976, 12.04],
        ("tsifsd", true) => [13.10, 0.84, 0.835, 1.95, 11.97],
        ("tsifsd", false) => [10.89, 0.842, 0.893, 1.076, 11.7],
        ("ifevip", true) => [20.35, 1.50, 0.818, 1.26, 15.52],
        ("ifevip", false) => [16.67, 1.91, 0.906, 1.03, 14.72],
        ("gff", true) => [15.35, 1.52, 0.878, 1.94, 11.76],
        ("gff", false) => [15.39, 1.51, 0.927, 1.00, 11.62],
        ("mgff", true) => [16.13, 1.01, 0.837, 1.94, 12.14],
        ("mgff", false) => [13.74, 1.05, 0.900, 1.160, 11.90],
        ("tepgfl", true) => [14.97, 0.94, 0.784, 1.12, 18.63],
        ("tepgfl", false) => [12.94, 0.873, 0.831, 0.437, 17.6],
        _ => return None,
    })
}

/// Study PSNR_S of Table 6: (eclipse, light).
fn study_t6_psnr(method: &str, input: &str) -> Option<(f64, f64)> {
    Some(match (method.split('-').next()?, input) {
        ("adf", "VIS down") => (25.58, 24.35),
        ("adf", "TIR up") => (29.20, 29.12),
        ("adf", "same res") => (29.36, 29.32),
        ("tsifsd", "VIS down") => (25.69, 24.50),
        ("tsifsd", "TIR up") => (29.97, 29.85),
        ("tsifsd", "same res") => (30.44, 30.26),
        ("ifevip", "VIS down") => (21.21, 20.00),
        ("ifevip", "TIR up") => (26.10, 26.06),
        ("ifevip", "same res") => (25.86, 25.84),
        ("gff", "VIS down") => (22.22, 22.82),
        ("gff", "TIR up") => (24.91, 26.67),
        ("gff", "same res") => (28.56, 29.13),
        ("mgff", "VIS down") => (24.96, 23.89),
        ("mgff", "TIR up") => (28.84, 28.73),
        ("mgff", "same res") => (28.58, 28.45),
        ("tepgfl", "VIS down") => (21.14, 21.81),
        ("tepgfl", "TIR up") => (23.97, 26.21),
        ("tepgfl", "same res") => (24.64, 26.55),
        ("drif", "different res") => (27.12, 26.30),
        _ => return None,
    })
}

fn study_t7(method: &str) -> Option<(f64, f64)> {
    Some(match method.split('-').next()? {
        "adf" => (0.012, 0.045),
        "tsifsd" => (0.013, 0.056),
        "ifevip" => (0.024, 0.094),
        "gff" => (0.153, 0.549),
        "mgff" => (0.136, 0.536),
        "tepgfl" => (0.241, 1.040),
        // "~6 s (different resolution)": VIS 1024² with TIR 512², output on the 1024² grid
        "drif" => (f64::NAN, 6.0),
        _ => return None,
    })
}

fn best<'a>(items: impl Iterator<Item = (&'a str, f64)>) -> &'a str {
    items.filter(|(_, v)| v.is_finite()).max_by(|a, b| a.1.total_cmp(&b.1)).map_or("–", |(n, _)| n)
}

fn verdict(ok: bool) -> &'static str {
    if ok { "**confirmed**" } else { "**not confirmed**" }
}

fn markdown(
    cells: &Cells,
    methods: &[NamedMethod],
    frames: usize,
    dataset: &Dataset,
    charts: &[PathBuf],
    seconds: f64,
    (small, big): (usize, usize),
) -> String {
    let mut md = String::new();
    let cfg = &dataset.manifest.config;
    let _ = writeln!(
        md,
        "# The study's tables on our renders\n\n{frames} frames of `{}` (seed {}, VIS {big}², TIR {small}² and {big}², \
         noise: blur σ = {} px, white σ² = {}, TIR also 1/f σ² = {}), means over the frames (PSNR: frames with a finite \
         value). Our scene is not the study's, so absolute values differ; the orderings are what we compare. \
         \"study\" columns: Advances in Space Research 2023 (shared/reference/study-results.md). Fusion runs \
         through the no_std core (flight variants unless named `-classic`), except the study's other four \
         methods (gff, mgff, tepgfl, drif), which have no core path and run on the host in f64 \
         (`host_harness::study_methods`); metrics in f64, the study's suite (`fusion eval --suite study`; \
         every variant in docs/metrics.md). FMI variant: the Fast-FMI model on Sobel gradient magnitudes, \
         3×3 windows, mean of VIS–F and TIR–F (Haghighat's `fmi.m` variants: `fusion eval`). Generated by `fusion report` in {seconds:.0} s.\n",
        dataset.dir.display(),
        dataset.manifest.seed,
        cfg.noise.blur_sigma_px,
        cfg.noise.awgn_variance,
        cfg.noise.pink_variance,
    );

    // Table 2
    let _ = writeln!(md, "## Table 2 — TIR {small} → {big} against the native noiseless {big}² TIR\n");
    let _ = writeln!(
        md,
        "| method | MSE_S | PSNR_S dB | SSIM_S | study MSE_S | study PSNR_S | study SSIM_S |\n|---|---|---|---|---|---|---|"
    );
    for r in RESCALERS {
        let (a, b, c) = study_t2(r);
        let _ = writeln!(
            md,
            "| {r} | {} | {} | {} | {a} | {b} | {c} |",
            fmt(cells.mean("t2", r, "MSE_S"), 5),
            fmt(cells.mean("t2", r, "PSNR_S"), 2),
            fmt(cells.mean("t2", r, "SSIM_S"), 3)
        );
    }
    // Table 3
    let _ = writeln!(md, "\n## Table 3 — VIS {big} → {small} against the native noiseless {small}² VIS\n");
    let _ = writeln!(
        md,
        "| method | illumination | MSE_S | PSNR_S dB | SSIM_S | study MSE_S | study PSNR_S | study SSIM_S |\n|---|---|---|---|---|---|---|---|"
    );
    for (ill, _) in ILLUMINATIONS {
        for r in RESCALERS {
            let t = format!("t3-{ill}");
            let (a, b, c) = study_t3(r, ill);
            let _ = writeln!(
                md,
                "| {r} | {ill} | {} | {} | {} | {a} | {b} | {c} |",
                fmt(cells.mean(&t, r, "MSE_S"), 5),
                fmt(cells.mean(&t, r, "PSNR_S"), 2),
                fmt(cells.mean(&t, r, "SSIM_S"), 3)
            );
        }
    }
    let names = row_names(methods);
    let drif = HostMethod::Drif.name();
    // Tables 4, 5
    for (table, what) in [
        ("t4", format!("Table 4 — VIS + TIR upscaled ({big}² grid)")),
        ("t5", format!("Table 5 — VIS downscaled + TIR ({small}² grid)")),
    ] {
        let _ = writeln!(md, "\n## {what}\n");
        let _ = writeln!(
            md,
            "\"target level\": mean of the fused image over the target divided by the mean of ½(VIS + TIR) there (< 1: \
             darker than the sources' average); \"halo\": mean grey levels by which the fused image leaves the range \
             [min, max] of its two sources within {HALO_RADIUS} px of the target's outline (target: a noiseless \
             source above {TARGET_LEVEL}).{}\n",
            if table == "t4" {
                " drif fuses VIS with the TIR frame at its own size (no upscale) and outputs on this grid; it is \
                 compared with the same sources as the others."
            } else {
                " drif has no row here: it fuses at the VIS resolution by design."
            }
        );
        let _ = writeln!(
            md,
            "| method | illumination | AG | MI | FMI | SSIM | RMSE | newly 255 % | target level | halo | study (eclipse) AG / MI / FMI / SSIM / RMSE |\n|---|---|---|---|---|---|---|---|---|---|---|"
        );
        for (ill, _) in ILLUMINATIONS {
            let t = format!("{table}-{ill}");
            for &name in &names {
                if table == "t5" && name == drif {
                    continue;
                }
                let study = match (ill, study_t45(table, name)) {
                    ("eclipse", Some(s)) => s.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(" / "),
                    _ => String::new(),
                };
                let _ = writeln!(
                    md,
                    "| {name} | {ill} | {} | {} | {} | {} | {} | {} | {} | {} | {study} |",
                    fmt(cells.mean(&t, name, "AG"), 2),
                    fmt(cells.mean(&t, name, "MI"), 3),
                    fmt(cells.mean(&t, name, "FMI"), 3),
                    fmt(cells.mean(&t, name, "SSIM"), 3),
                    fmt(cells.mean(&t, name, "RMSE"), 2),
                    fmt(100.0 * cells.mean(&t, name, "sat"), 3),
                    fmt(cells.mean(&t, name, "level"), 3),
                    fmt(cells.mean(&t, name, "halo"), 2),
                );
            }
        }
    }
    // Table 6
    let _ = writeln!(
        md,
        "\n## Table 6 — noise: fused noisy frame against the fused noiseless same-resolution pair\n"
    );
    let _ = writeln!(
        md,
        "drif \"different res\": VIS {big}² with TIR {small}² (noisy) against drif's fusion of the noiseless \
         {big}²/{big}² pair.\n"
    );
    let _ = writeln!(
        md,
        "| method | input | MSE_S ecl | MSE_S light | PSNR_S ecl | PSNR_S light | SSIM_S ecl | SSIM_S light | study PSNR_S ecl / light |\n|---|---|---|---|---|---|---|---|---|"
    );
    for &name in &names {
        let inputs: &[&str] =
            if name == drif { &["different res"] } else { &["VIS down", "TIR up", "same res"] };
        for &input in inputs {
            let row = format!("{name}|{input}");
            let v = |ill: &str, col: &str| cells.mean(&format!("t6-{ill}"), &row, col);
            let study = study_t6_psnr(name, input).map_or(String::new(), |(e, l)| format!("{e} / {l}"));
            let _ = writeln!(
                md,
                "| {name} | {input} | {} | {} | {} | {} | {} | {} | {study} |",
                fmt(v("eclipse", "MSE_S"), 5),
                fmt(v("light", "MSE_S"), 5),
                format_psnr(v("eclipse", "PSNR_S")),
                format_psnr(v("light", "PSNR_S")),
                fmt(v("eclipse", "SSIM_S"), 3),
                fmt(v("light", "SSIM_S"), 3),
            );
        }
    }
    // Table 7
    let _ = writeln!(md, "\n## Table 7 — run time per frame pair (median over frames and illuminations)\n");
    let _ = writeln!(
        md,
        "Core methods: the no_std fixed-point core on the host, one thread, rescale included, median of the \
         repeats. gff, mgff, tepgfl, drif have no core path: they are timed with their f64 host implementation, \
         one thread, one run per frame, rescale included (drif: no rescale, VIS {big}² with TIR {small}², output \
         {big}²; it has no {small}² time). The study's figures are MATLAB on an i7-8750H.\n"
    );
    let _ = writeln!(
        md,
        "| method | engine | VIS down ({small}²) ms | TIR up ({big}²) ms | study 512² ms | study 1024² ms |\n|---|---|---|---|---|---|"
    );
    for &name in &names {
        let (a, b) = study_t7(name).map_or((f64::NAN, f64::NAN), |(a, b)| (a * 1e3, b * 1e3));
        let engine = if methods.iter().any(|m| m.name == name) { "core (fixed point)" } else { "host f64" };
        let _ = writeln!(
            md,
            "| {name} | {engine} | {} | {} | {} | {} |",
            fmt(1e3 * cells.median("t7", name, "small"), 1),
            fmt(1e3 * cells.median("t7", name, "big"), 1),
            fmt(a, 0),
            fmt(b, 0)
        );
    }

    // Conclusions
    let _ = writeln!(md, "\n## The study's conclusions against our numbers\n");
    let up_best = best(RESCALERS.iter().map(|&r| (r, cells.mean("t2", r, "PSNR_S"))));
    let _ = writeln!(
        md,
        "1. *Bicubic is the best of the three for upscaling TIR* (Table 2): best PSNR_S here is {up_best} — {}.",
        verdict(up_best == "bicubic")
    );
    for (ill, _) in ILLUMINATIONS {
        let t = format!("t3-{ill}");
        let down_best = best(RESCALERS.iter().map(|&r| (r, cells.mean(&t, r, "PSNR_S"))));
        let _ = writeln!(
            md,
            "1. *Area is the best for downscaling VIS* ({ill}, Table 3): best PSNR_S here is {down_best} — {}.",
            verdict(down_best == "area")
        );
    }
    // Mean of a cell over both illuminations.
    let both = |table: &str, row: &str, col: &str| {
        (cells.mean(&format!("{table}-eclipse"), row, col) + cells.mean(&format!("{table}-light"), row, col))
            / 2.0
    };
    for &name in names.iter().filter(|&&n| n != drif) {
        let (up, down) = (
            both("t6", &format!("{name}|TIR up"), "PSNR_S"),
            both("t6", &format!("{name}|VIS down"), "PSNR_S"),
        );
        let _ = writeln!(
            md,
            "1. *Upscaling TIR beats downscaling VIS for noise* ({name}, Table 6): PSNR_S {} dB (TIR up) vs {} dB (VIS down) — {}.",
            fmt(up, 2),
            fmt(down, 2),
            verdict(up > down)
        );
    }
    let sat = |name: &str, ill: &str| cells.mean(&format!("t4-{ill}"), name, "sat");
    let ifevip_light = sat("ifevip", "light");
    let others_light = names.iter().filter(|&&n| n != "ifevip").map(|&n| sat(n, "light")).fold(0.0, f64::max);
    let _ = writeln!(
        md,
        "1. *IFEVIP saturates the target in light*: {} % of its pixels newly at 255 in light ({} % in eclipse), at most {} % for the other seven methods — {}.",
        fmt(100.0 * ifevip_light, 3),
        fmt(100.0 * sat("ifevip", "eclipse"), 3),
        fmt(100.0 * others_light, 3),
        verdict(ifevip_light > others_light && ifevip_light > 0.0)
    );
    let noise_rank = best(names.iter().map(|&n| (n, both("t6", &tir_up_row(n), "PSNR_S"))));
    let _ = writeln!(
        md,
        "1. *TSIFSD or ADF is the method to fly (TIR up)*: the most noise-robust of the eight methods here (PSNR_S, TIR up; drif at different res) is {noise_rank} — {}.",
        verdict(noise_rank.starts_with("tsifsd") || noise_rank == "adf")
    );
    let fastest = best(methods.iter().map(|m| (m.name, -cells.median("t7", m.name, "big"))));
    let _ = writeln!(
        md,
        "1. *TSIFSD and ADF are the fast ones*: the fastest core method at {big}² here is {fastest} (the study: ADF, then TSIFSD) — {}.",
        verdict(fastest.starts_with("tsifsd") || fastest == "adf")
    );
    // GFF darkens with TIR upscaling: its target level with TIR up, against its own with VIS down
    // and against the sources' average (1).
    let gff = HostMethod::Gff.name();
    let (gff_up, gff_down) = (both("t4", gff, "level"), both("t5", gff, "level"));
    let others_up: Vec<f64> = names
        .iter()
        .filter(|&&n| n != gff)
        .map(|&n| both("t4", n, "level"))
        .filter(|v| v.is_finite())
        .collect();
    let (lo, hi) =
        others_up.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let _ = writeln!(
        md,
        "1. *GFF darkens with TIR upscaling*: GFF's target level is {} with TIR up against {} with VIS down (1 = the \
         sources' average; the other methods with TIR up: {}–{}) — {}.",
        fmt(gff_up, 3),
        fmt(gff_down, 3),
        fmt(lo, 3),
        fmt(hi, 3),
        verdict(gff_up < gff_down && gff_up < 1.0)
    );
    // TEPGFL halos: the largest halo measure of the eight methods (TIR up).
    let tepgfl = HostMethod::Tepgfl.name();
    let halo_rank = best(names.iter().map(|&n| (n, both("t4", n, "halo"))));
    let _ = writeln!(
        md,
        "1. *TEPGFL halos*: halo measure around the target (TIR up) {} grey levels for tepgfl; the largest of the \
         eight is {halo_rank} ({}); median of the others {} — {}.",
        fmt(both("t4", tepgfl, "halo"), 2),
        fmt(both("t4", halo_rank, "halo"), 2),
        fmt(
            median(
                &mut names
                    .iter()
                    .filter(|&&n| n != tepgfl)
                    .map(|&n| both("t4", n, "halo"))
                    .collect::<Vec<_>>()
            ),
            2
        ),
        verdict(halo_rank == tepgfl)
    );
    // DRIF textureless (lowest AG of the eight, Table 4) and slow (the longest run time).
    let ag_low = best(names.iter().map(|&n| (n, -both("t4", n, "AG"))));
    let _ = writeln!(
        md,
        "1. *DRIF is textureless*: AG (Table 4, both illuminations) {} for drif; the lowest of the eight is {ag_low} \
         ({}); the highest {} — {}.",
        fmt(both("t4", drif, "AG"), 2),
        fmt(both("t4", ag_low, "AG"), 2),
        fmt(names.iter().map(|&n| both("t4", n, "AG")).filter(|v| v.is_finite()).fold(f64::NAN, f64::max), 2),
        verdict(ag_low == drif)
    );
    let slowest = best(names.iter().map(|&n| (n, cells.median("t7", n, "big"))));
    let second = names
        .iter()
        .filter(|&&n| n != drif)
        .map(|&n| cells.median("t7", n, "big"))
        .filter(|v| v.is_finite())
        .fold(f64::NAN, f64::max);
    let _ = writeln!(
        md,
        "1. *DRIF is slow*: drif takes {} ms per frame pair at {big}² (f64, one thread; the study: ~6 s), the slowest \
         of the others {} ms; the slowest of the eight is {slowest} — {}.",
        fmt(1e3 * cells.median("t7", drif, "big"), 0),
        fmt(1e3 * second, 0),
        verdict(slowest == drif)
    );
    let _ = writeln!(
        md,
        "\n## Figures\n\n![contact sheet](contact_sheet.png)\n\nContact sheet (frame {}): rows eclipse, light; columns VIS (noisy), TIR upscaled, then {} (TIR up; drif at different res), cropped to the target.\n",
        frames / 2,
        names.join(", ")
    );
    for c in charts {
        if let Some(name) = c.file_name().and_then(|n| n.to_str()) {
            let _ = writeln!(md, "![{name}]({name})\n");
        }
    }
    md
}
