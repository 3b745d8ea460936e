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
//! The study's four other methods (GFF, MGFF, TEPGFL, DRIF; [`fusion_reference::study_methods`]) have no
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

use anyhow::{Context, Result};
use clap::Args;
use fusion_engine::study::{Dataset, NamedMethod, core_methods, fuse_timed, median};
use fusion_io::source_on_grid;
use fusion_io::{Gray, save_gray_u8};
use fusion_metrics::{FusionMetrics, NoiseMetrics, format_psnr, fusion_metrics, noise_metrics};
use fusion_nostd::Filter;
use fusion_nostd::pipeline::{FuseConfig, RescalePolicy};
use fusion_reference::rescale::lanczos3_u8;
use fusion_reference::study_methods::guided_filter::box_mean;
use fusion_reference::study_methods::{HostMethod, fuse_host_u8};
use fusion_report::plot::{Labels, Series, Style, chart};
use fusion_report::sheet::{labelled_sheet, target_square, tile};
use rayon::prelude::*;
use render_host::{
    Camera, DatasetConfig, Illumination, Scene, VisParams, render_dataset, render_vis, trajectory,
};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

mod files;
mod markdown;
mod published;

use files::*;
use markdown::*;
use published::*;

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

/// Which of the study's tables a cell belongs to; `t2`, `t3-light`, … in the CSV files.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Table {
    /// Table 2: TIR upscaled against the native TIR.
    T2,
    /// Table 3: VIS downscaled against the native VIS.
    T3(Illumination),
    /// Table 4: fusion on the VIS grid (TIR upscaled).
    T4(Illumination),
    /// Table 5: fusion on the TIR grid (VIS downscaled).
    T5(Illumination),
    /// Table 6: noise of the fused frame.
    T6(Illumination),
    /// Table 7: run time.
    T7,
}

/// The name of an illumination in the report (`eclipse`, `light`).
fn light_name(ill: Illumination) -> &'static str {
    match ill {
        Illumination::Eclipse => "eclipse",
        Illumination::Light => "light",
    }
}

impl std::fmt::Display for Table {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Table::T2 => write!(f, "t2"),
            Table::T3(i) => write!(f, "t3-{}", light_name(i)),
            Table::T4(i) => write!(f, "t4-{}", light_name(i)),
            Table::T5(i) => write!(f, "t5-{}", light_name(i)),
            Table::T6(i) => write!(f, "t6-{}", light_name(i)),
            Table::T7 => write!(f, "t7"),
        }
    }
}

/// A column of the report's tables, by the name the CSV files give it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Col {
    Ag,
    Mi,
    Fmi,
    Ssim,
    Rmse,
    MseS,
    PsnrS,
    SsimS,
    /// Share of the target's pixels newly at 255.
    Sat,
    /// Fused target level over the sources' mean.
    Level,
    /// Grey levels outside the sources' range near the outline.
    Halo,
    /// Run time on the large grid, s.
    Big,
    /// Run time on the small grid, s.
    Small,
}

impl Col {
    fn name(self) -> &'static str {
        match self {
            Col::Ag => "AG",
            Col::Mi => "MI",
            Col::Fmi => "FMI",
            Col::Ssim => "SSIM",
            Col::Rmse => "RMSE",
            Col::MseS => "MSE_S",
            Col::PsnrS => "PSNR_S",
            Col::SsimS => "SSIM_S",
            Col::Sat => "sat",
            Col::Level => "level",
            Col::Halo => "halo",
            Col::Big => "big",
            Col::Small => "small",
        }
    }
}

/// Per-frame values of the report's cells: `(table, row, column) → values`, keyed by typed
/// table and column (a mistyped key does not compile; rows are method and rescaler names).
/// Stored under the CSV names, so the files list the cells in the same order as before.
#[derive(Debug, Default)]
struct Cells(BTreeMap<(String, String, String), Vec<f64>>);

/// Mean of the finite values (infinite PSNRs are left out and said so by `format`); NaN when
/// there are none.
fn mean_of(values: &[f64]) -> f64 {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
}

/// Median of the values (NaN when there are none).
fn median_of(values: &[f64]) -> f64 {
    if values.is_empty() { f64::NAN } else { median(&mut values.to_vec()) }
}

impl Cells {
    fn push(&mut self, table: Table, row: &str, col: Col, v: f64) {
        self.0.entry((table.to_string(), row.into(), col.name().into())).or_default().push(v);
    }

    fn values(&self, table: Table, row: &str, col: Col) -> &[f64] {
        self.0.get(&(table.to_string(), row.to_string(), col.name().to_string())).map_or(&[], Vec::as_slice)
    }

    fn mean(&self, table: Table, row: &str, col: Col) -> f64 {
        mean_of(self.values(table, row, col))
    }

    fn median(&self, table: Table, row: &str, col: Col) -> f64 {
        median_of(self.values(table, row, col))
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
        Ok(render_vis(&self.scene, &Camera::study(size, pose), &params).to_gray_u8())
    }
}

fn put_fusion(cells: &mut Cells, table: Table, row: &str, m: &FusionMetrics) {
    for (col, v) in
        [(Col::Ag, m.ag), (Col::Mi, m.mi), (Col::Fmi, m.fmi), (Col::Ssim, m.ssim), (Col::Rmse, m.rmse)]
    {
        cells.push(table, row, col, v);
    }
}

fn put_noise(cells: &mut Cells, table: Table, row: &str, n: &NoiseMetrics) {
    for (col, v) in [(Col::MseS, n.mse_s), (Col::PsnrS, n.psnr_s), (Col::SsimS, n.ssim_s)] {
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
    let _folder = fusion_io::output::create_folder(&args.out)?;
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
            put_noise(&mut cells, Table::T2, r, &noise_metrics(&up, &tir1024_c));
        }
        for (ill, illum) in ILLUMINATIONS {
            let vis_n = dataset.image(&format!("vis_{ill}"), f, true)?;
            let vis_c = dataset.image(&format!("vis_{ill}"), f, false)?;
            // Table 3: VIS down against the native noiseless 512².
            let vis512_c = native.render(f, small as u32, illum)?;
            for r in RESCALERS {
                let down = rescale_with(&vis_n, r, small, small)?;
                put_noise(&mut cells, Table::T3(illum), r, &noise_metrics(&down, &vis512_c));
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
                cells.push(Table::T7, name, Col::Big, up.seconds);
                cells.push(Table::T7, name, Col::Small, down.seconds);
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
                cells.push(Table::T7, name, Col::Big, t.elapsed().as_secs_f64());
                let down = if host.different_resolution() {
                    None
                } else {
                    let t = Instant::now();
                    let down =
                        fuse_host_u8(host, &source_on_grid(&vis_n, (small, small), Filter::Area)?, &tir_n)?.0;
                    cells.push(Table::T7, name, Col::Small, t.elapsed().as_secs_f64());
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
                for (table, m) in [(Table::T4 as fn(Illumination) -> Table, Some(up)), (Table::T5, down)] {
                    let Some((metrics, sat, level, halo)) = m else { continue };
                    let t = table(illum);
                    put_fusion(&mut cells, t, name, &metrics);
                    cells.push(t, name, Col::Sat, sat);
                    cells.push(t, name, Col::Level, level);
                    cells.push(t, name, Col::Halo, halo);
                }
                for (row, n) in &noise {
                    let row = if row == "VIS down" { format!("{name}|VIS down") } else { row.clone() };
                    put_noise(&mut cells, Table::T6(illum), &row, n);
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
    let mut columns = vec!["VIS", "TIR up"];
    columns.extend(row_names(&methods));
    let rows: Vec<&str> = ILLUMINATIONS.iter().map(|(name, _)| *name).collect();
    save_gray_u8(&sheet_path, &labelled_sheet(&sheet_rows, 4, &columns, &rows))?;
    let charts = write_charts(&cells, &methods, frames, &args.out)?;
    write_csvs(&cells, &args.out)?;
    let md =
        markdown(&cells, &methods, frames, &dataset, &charts, started.elapsed().as_secs_f64(), (small, big));
    let report = args.out.join("report.md");
    fusion_io::write_bytes(&report, md.as_bytes())?;
    outln!("{md}")?;
    outln!("report: {}", report.display())?;
    Ok(())
}
