//! The `fusion` command-line tool: one verb per module.

use clap::{Parser, Subcommand};

pub mod agc;
pub mod bench;
pub mod budget;
pub mod campaign;
pub mod demo;
pub mod eval;
pub mod fuse;
pub mod navbench;
pub mod register;
pub mod render;
pub mod report;
pub mod rescale;
pub mod skip_study;
pub mod stress;

/// VIS/TIR image fusion for spacecraft proximity navigation: host tools.
#[derive(Debug, Parser)]
#[command(name = "fusion", version, about)]
pub struct Cli {
    /// No notes on standard error (progress bars, warnings, guards); errors are still printed.
    #[arg(long, global = true)]
    pub quiet: bool,
    /// Refuse runs whose estimated peak memory exceeds this (bytes, or K/M/G/T) [default: 8G].
    #[arg(long, global = true, value_name = "SIZE", value_parser = fusion_io::memory::parse_size)]
    pub max_memory: Option<u64>,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The verbs of the tool.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// The main job on the built-in default scene: render, fuse with every method, contact sheet, table.
    Demo(demo::DemoArgs),
    /// Run time against error per method, engine, frame size and knob, with a Pareto chart.
    Bench(bench::BenchArgs),
    /// The study's Tables 2–7 on a rendered dataset, with plots and conclusions.
    Report(report::ReportArgs),
    /// Rescale a grey image (PNG, JPEG, TIFF, PGM; 8- or 16-bit) with the core's bicubic or area
    /// rescaler.
    Rescale(rescale::RescaleArgs),
    /// Warp a thermal image of an offset camera pair onto the visible grid at a range (the rig
    /// from OpenCV's stereo calibration, YAML or JSON): what `fuse --rig --range` fuses.
    Register(register::RegisterArgs),
    /// Fuse a VIS/TIR pair or two folders of pairs: ADF, TSIFSD, IFEVIP, adaptive (core or f64
    /// reference); GFF, MGFF, TEPGFL, DRIF (the study's host-only methods, f64). PNG, JPEG, TIFF;
    /// colour kept, 14/16-bit thermal through the core's AGC.
    Fuse(fuse::FuseArgs),
    /// Render a dataset of aligned VIS/TIR pairs of a spacecraft target (ray traced).
    Render(render::RenderArgs),
    /// Fusion metrics of a fused image (or three folders): the study's suite, VIFB's 13 (exactly
    /// as its code), or both; noise metrics with --ref.
    Eval(eval::EvalArgs),
    /// Instruction budgets on the emulated Cortex-M7 and RV32 (QEMU): counts per stage and
    /// method, cycle and frame-rate estimates, memory, bit-exactness against the host.
    Budget(budget::BudgetArgs),
    /// Every method and engine over adversarial frames (zeros, saturation, checkerboards, hot
    /// pixels, noise, …): NaN in the reference, error against it, guards, determinism.
    Stress(stress::StressArgs),
    /// Scene skipping over a rendered dataset: host time, window fraction and the error each
    /// skip level adds against the unskipped result (table, CSV, chart).
    SkipStudy(skip_study::SkipStudyArgs),
    /// Does fusion help navigation? Every stream (VIS, TIR, each method and variant, with and
    /// without skipping) of the rendezvous sequences through a feature-based front end, per
    /// illumination phase, against the rendered ground truth.
    Navbench(navbench::NavbenchArgs),
    /// Monte Carlo campaigns of the navigation judge: `plan FILE` lists the cases with their
    /// stable ids (runs: `vistir-campaign run`, the Python package on Dask).
    Campaign(campaign::CampaignArgs),
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    if let Some(limit) = cli.max_memory {
        fusion_io::memory::set_limit(limit);
    }
    match cli.command {
        Command::Demo(args) => demo::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Report(args) => report::run(&args),
        Command::Rescale(args) => rescale::run(&args),
        Command::Register(args) => register::run(&args),
        Command::Eval(args) => eval::run(&args),
        Command::Budget(args) => budget::run(&args),
        Command::Stress(args) => stress::run(&args),
        Command::Fuse(args) => fuse::run(&args),
        Command::SkipStudy(args) => skip_study::run(&args),
        Command::Render(args) => {
            // Every camera's frames are in flight: the VIS size and each TIR size count.
            let tir_sizes = render_host::RenderOptions {
                vis_size: args.vis_size,
                tir_sizes: args.tir_sizes.clone(),
                ..Default::default()
            }
            .tir_sizes_or_default();
            let px = std::iter::once(args.vis_size)
                .chain(tir_sizes.iter().copied())
                .fold(0u64, |sum, s| sum.saturating_add(u64::from(s).saturating_mul(u64::from(s))));
            let bytes = fusion_io::memory::estimate(px, fusion_io::memory::per_pixel::RENDER);
            let sizes = tir_sizes.iter().map(u32::to_string).collect::<Vec<_>>().join(",");
            fusion_io::memory::check(
                &format!("--vis-size {} --tir-sizes {sizes}", args.vis_size),
                "rendering",
                bytes,
            )?;
            render::run(&args)
        }
        Command::Navbench(args) => navbench::run(&args),
        Command::Campaign(args) => campaign::run(&args),
    }
}
