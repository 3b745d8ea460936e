//! `fusion budget`: build the firmware, run it on the emulated Cortex-M7 and RV32, print
//! instructions per pixel per stage and method, cycle and frame-rate estimates, the memory
//! report, check the committed budget table and bit-exactness against the host.

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use fusion_budget::fw::{Grid, Target};
use fusion_budget::table::Table;
use fusion_budget::{self as budget, Options};
use fusion_engine::methods::MethodArg;
use std::path::PathBuf;
use std::time::Duration;

/// Targets on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TargetArg {
    /// Cortex-M7 (QEMU mps2-an500), counted by the TCG plugin.
    Arm,
    /// RV32IMAC (QEMU virt), counted by minstret.
    Riscv,
    /// Cortex-A53 (QEMU virt, AArch64 with NEON), counted by the TCG plugin.
    A53,
    /// Every target.
    All,
}

/// Fusion grid sizes on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SizeArg {
    /// 512² grid: VIS 1024² area-downscaled onto the TIR 512² grid.
    #[value(name = "512")]
    S512,
    /// 1024² grid: TIR 512² bicubic-upscaled onto the VIS 1024² grid.
    #[value(name = "1024")]
    S1024,
    /// Both.
    All,
}

/// Arguments of `fusion budget`.
#[derive(Debug, Args)]
pub struct BudgetArgs {
    /// Target(s) to measure.
    #[arg(long, value_enum, default_value_t = TargetArg::All)]
    pub target: TargetArg,
    /// Fusion grid(s) to measure.
    #[arg(long, value_enum, default_value_t = SizeArg::All)]
    pub size: SizeArg,
    /// Methods to measure (comma-separated) [default: all four].
    #[arg(long, value_enum, value_delimiter = ',')]
    pub methods: Vec<MethodArg>,
    /// Runs of each budget job; the counts of all runs must be identical.
    #[arg(long, default_value_t = 2)]
    pub repeat: usize,
    /// Skip the bit-exactness jobs (VIFB pairs, synthetic pair, classic variants).
    #[arg(long)]
    pub no_exact: bool,
    /// Folder with the VIFB pairs (`*_VIS.png`, `*_IR.png`) [default: the repository's tests/data/vifb].
    #[arg(long)]
    pub vifb: Option<PathBuf>,
    /// Budget table to check against.
    #[arg(long, default_value_os_t = budget::fw::fw_dir().join("budgets.toml"))]
    pub budgets: PathBuf,
    /// Do not fail when a count exceeds its budget (still reported).
    #[arg(long)]
    pub no_check: bool,
    /// Write a budget table from this run's counts (measured + 2 %) to this file.
    #[arg(long, value_name = "FILE")]
    pub write_budgets: Option<PathBuf>,
    /// Timeout of each emulator run, seconds.
    #[arg(long, default_value_t = 900)]
    pub timeout: u64,
    /// Instead of the budgets: scene skipping over this rendered dataset (`fusion render`) —
    /// whole-pipeline instructions per frame pair and skip level (TSIFSD and ADF at none, roi,
    /// all; IFEVIP at all), each fused frame checked against the host. One target (`--target
    /// arm` or `riscv`); writes `emulator_<target>.{md,csv}` into `--study-out`. DATASET is a
    /// study-layout dataset (`fusion render`) or a folder of rendezvous sequences (`approach/`,
    /// `flyaround/`: `fusion navbench`'s `data/`).
    #[arg(long, value_name = "DATASET")]
    pub skip_study: Option<PathBuf>,
    /// Skip study: frames per set and version (a dataset: the first; sequences: spread evenly).
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Skip study: emulate ADF/IFEVIP runs that fuse the whole frame (~20 s each at 1024² on
    /// QEMU) on this many frames only [default: all].
    #[arg(long)]
    pub whole_frames: Option<usize>,
    /// Skip study: noise versions, clean, noisy or both.
    #[arg(long, default_value = "both")]
    pub versions: String,
    /// Skip study: TIR set of the dataset (upscaled onto the VIS grid).
    #[arg(long, default_value = "tir512")]
    pub tir: String,
    /// Skip study: folder for `emulator_<target>.{md,csv}`.
    #[arg(long, default_value = "docs/skip-study")]
    pub study_out: PathBuf,
    /// Work folder: images, jobs, console and plugin logs, `report.md`.
    #[arg(long, default_value_os_t = budget::fw::fw_dir().join("target/budget"))]
    pub out: PathBuf,
}

/// `fusion budget --skip-study DATASET`.
fn run_skip_study(args: &BudgetArgs, dataset: &std::path::Path) -> Result<()> {
    let target = match args.target {
        TargetArg::Arm => Target::Arm,
        TargetArg::Riscv => Target::Riscv,
        TargetArg::A53 => Target::A53,
        TargetArg::All => bail!("--skip-study measures one target: pass --target arm, riscv or a53"),
    };
    let versions = match args.versions.as_str() {
        "clean" => vec![false],
        "noisy" => vec![true],
        "both" => vec![false, true],
        v => bail!("--versions must be clean, noisy or both, not {v}"),
    };
    let opts = budget::skip_study::StudyOptions {
        dataset: dataset.to_path_buf(),
        tir: args.tir.clone(),
        frames: args.frames,
        whole_frames: args.whole_frames.unwrap_or(usize::MAX),
        versions,
        target,
        timeout: Duration::from_secs(args.timeout),
        work: args.out.clone(),
        report_dir: args.study_out.clone(),
    };
    let rows = budget::skip_study::run(&opts)?;
    let frames = args.frames.min(rows.iter().map(|r| r.frame + 1).max().unwrap_or(0));
    outln!("{}", budget::skip_study::markdown(&opts, frames, &rows))?;
    Ok(())
}

/// Runs `fusion budget`.
pub fn run(args: &BudgetArgs) -> Result<()> {
    if let Some(dataset) = &args.skip_study {
        return run_skip_study(args, dataset);
    }
    let targets = match args.target {
        TargetArg::Arm => vec![Target::Arm],
        TargetArg::Riscv => vec![Target::Riscv],
        TargetArg::A53 => vec![Target::A53],
        TargetArg::All => Target::ALL.to_vec(),
    };
    let grids = match args.size {
        SizeArg::S512 => vec![Grid::G512],
        SizeArg::S1024 => vec![Grid::G1024],
        SizeArg::All => vec![Grid::G512, Grid::G1024],
    };
    let methods = if args.methods.is_empty() {
        vec![MethodArg::Adf, MethodArg::Tsifsd, MethodArg::Ifevip, MethodArg::Adaptive]
    } else {
        args.methods.clone()
    };
    let budgets_text = std::fs::read_to_string(&args.budgets)
        .with_context(|| format!("cannot read the budget table {}", args.budgets.display()))?;
    let budgets = Table::parse(&budgets_text).with_context(|| format!("in {}", args.budgets.display()))?;
    let opts = Options {
        targets,
        grids,
        methods,
        repeat: args.repeat.max(1),
        exactness: !args.no_exact,
        vifb: args.vifb.clone().unwrap_or_else(|| fusion_io::testdata::dir().join("vifb")),
        budgets: args.budgets.clone(),
        write_budgets: args.write_budgets.clone(),
        timeout: Duration::from_secs(args.timeout),
        out: args.out.clone(),
    };
    let outcome = budget::run(&opts)?;
    let chk = budget::check(&outcome.measured, &outcome.agc, &budgets);
    let mut text = budget::report(&outcome, &budgets, &chk);
    text.push_str("\n### Static memory of the images\n\n");
    text.push_str(&budget::memory_report(&outcome)?);
    text.push_str("\n### Emulator wall time\n\n| target | job | seconds |\n|---|---|---:|\n");
    for (t, what, secs) in &outcome.wall {
        text.push_str(&format!("| {t} | {what} | {secs:.1} |\n"));
    }
    outln!("{text}")?;
    let report_path = opts.out.join("report.md");
    let mut batch = fusion_io::Batch::default();
    batch.add_bytes(&report_path, text.as_bytes())?;
    if let Some(path) = &opts.write_budgets {
        batch.add_bytes(
            path,
            budget::budget_table_text(&outcome.measured, &outcome.agc, &budgets).as_bytes(),
        )?;
    }
    batch.commit()?;
    note!("budget: report written to {}", report_path.display());
    if let Some(path) = &opts.write_budgets {
        note!("budget: wrote a budget table from these counts to {}", path.display());
    }
    for (key, got, b) in &chk.slack {
        note!("budget: note: {key} is {got:.2} instr/px, more than 10 % under its budget {b}: tighten it");
    }
    if !chk.passed() && !args.no_check {
        let mut msg = String::new();
        for (key, got, b) in &chk.over {
            msg.push_str(&format!("\n  {key}: {got:.2} instr/px > budget {b}"));
        }
        for key in &chk.missing {
            msg.push_str(&format!("\n  {key}: no budget in {}", opts.budgets.display()));
        }
        bail!("instruction budgets exceeded or missing:{msg}");
    }
    Ok(())
}
