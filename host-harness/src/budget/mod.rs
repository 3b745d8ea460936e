//! Firmware budgets: exact instruction counts of the core on the emulated flight targets, the
//! committed budget table, bit-exactness against the host, and the static memory of the image.
//!
//! The firmware (`fw/`) runs under QEMU: on RV32 it reads `minstret` (exact with
//! `-icount shift=0,sleep=off`), on Arm the TCG plugin `fw/plugin/insn_count.c` counts the
//! instructions between the marker functions. A staged run calls the public stage functions of a
//! method one by one inside measured regions, then the method itself; the method's remainder is
//! its count minus its stages. The whole-pipeline region is a separate call of
//! [`fusion_nostd::pipeline::fuse`] — the figure the budgets and the targets are about.

pub mod elf;
pub mod fw;
pub mod skip_study;
pub mod table;

use crate::io::{ColorPolicy, Gray, load_gray_u8};
use crate::methods::{MethodArg, RescaleArg, VariantArg, fuse_core, method_for};
use anyhow::{Context, Result, bail, ensure};
use elf::Elf;
use fusion_nostd::pipeline::FuseConfig;
use fw::{FwReport, Grid, Job, RunOut, RunSpec, Target};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Duration;
use table::Table;

/// Clock rate of the frame-rate estimates.
pub const CLOCK_HZ: f64 = 400e6;

/// The method's name as a budget key.
pub fn method_key(m: MethodArg) -> &'static str {
    match m {
        MethodArg::Adf => "adf",
        MethodArg::Tsifsd => "tsifsd",
        MethodArg::Ifevip => "ifevip",
        MethodArg::Adaptive => "adaptive",
    }
}

/// The measured stages of a method, in order: `(budget key, firmware region, what it is)`.
fn method_stages(m: MethodArg) -> &'static [(&'static str, &'static str, &'static str)] {
    match m {
        MethodArg::Adf => {
            &[("diffuse", "adf.diffuse", "anisotropic diffusion of VIS and TIR together (10 iterations)")]
        }
        // The flight kernel is one pass; its stages cannot be measured apart.
        MethodArg::Tsifsd => &[],
        MethodArg::Ifevip => &[(
            "background",
            "ifevip.background",
            "IR background: resize, quadtree, erosion, Bézier, smoothing",
        )],
        // One pass after the analysis; the analysis is inside the method's region.
        MethodArg::Adaptive => &[],
    }
}

/// The remainder stage of a method: its count minus the measured stages.
fn remainder_stage(m: MethodArg) -> (&'static str, &'static str) {
    match m {
        MethodArg::Adf => ("kl_reconstruct", "KL covariance, weights and reconstruction"),
        MethodArg::Tsifsd => (
            "saliency_reconstruct",
            "one pass: 35×35 window sums of IR − VIS, Scharr saliency, weights, reconstruction",
        ),
        MethodArg::Ifevip => ("features_reconstruct", "entropy, IR features, peak, reconstruction"),
        MethodArg::Adaptive => (
            "analysis_blend",
            "scene analysis of the input frames (the decision), then one pass: box means, VIS binomial, blend",
        ),
    }
}

fn method_region(m: MethodArg) -> &'static str {
    match m {
        MethodArg::Adf => "adf.fuse",
        MethodArg::Tsifsd => "tsifsd.fuse",
        MethodArg::Ifevip => "ifevip.fuse",
        MethodArg::Adaptive => "adaptive.fuse",
    }
}

/// Whether the method runs in strips ([`fusion_nostd::strips`]: every method, both variants).
pub fn has_strips(m: MethodArg) -> bool {
    matches!(m, MethodArg::Adf | MethodArg::Tsifsd | MethodArg::Ifevip | MethodArg::Adaptive)
}

/// One row of the stage table.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    /// Budget key (`rescale`, `diffuse`, …, `method`, `pipeline`).
    pub key: &'static str,
    /// What it covers.
    pub what: &'static str,
    /// Instructions (marker overhead included, a few per region).
    pub count: u64,
}

/// Splits a staged run's regions into the table rows: rescale (when the grid needed one), the
/// method's stages, its remainder, the method in total and the whole pipeline.
pub fn stages_of(method: MethodArg, run: &RunOut) -> Result<Vec<Stage>> {
    let mut rows = Vec::new();
    if let Some(c) = run.region("rescale") {
        rows.push(Stage { key: "rescale", what: "rescale onto the fusion grid", count: c });
    }
    let total =
        run.region(method_region(method)).with_context(|| format!("no {} region", method_region(method)))?;
    let mut sum = 0u64;
    for &(key, region, what) in method_stages(method) {
        let c = run.region(region).with_context(|| format!("no {region} region"))?;
        sum += c;
        rows.push(Stage { key, what, count: c });
    }
    let (key, what) = remainder_stage(method);
    let rest = total
        .checked_sub(sum)
        .with_context(|| format!("{} counts fewer instructions than its stages", method_key(method)))?;
    rows.push(Stage { key, what, count: rest });
    rows.push(Stage { key: "method", what: "the method in total (stages + remainder)", count: total });
    let pipeline = run.region("pipeline").context("no pipeline region")?;
    rows.push(Stage { key: "pipeline", what: "whole pipeline entry: rescale + method", count: pipeline });
    Ok(rows)
}

/// Measurements of one method on one target and grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// Target.
    pub target: Target,
    /// Grid.
    pub grid: Grid,
    /// Method.
    pub method: MethodArg,
    /// Stage rows.
    pub stages: Vec<Stage>,
}

impl Measured {
    /// Output pixels (the fusion grid).
    pub fn pixels(&self) -> u64 {
        (self.grid.side() * self.grid.side()) as u64
    }

    /// Instructions per output pixel of a stage.
    pub fn per_px(&self, s: &Stage) -> f64 {
        s.count as f64 / self.pixels() as f64
    }

    /// The whole-pipeline count.
    pub fn pipeline(&self) -> u64 {
        self.stages.iter().find(|s| s.key == "pipeline").map_or(0, |s| s.count)
    }

    /// Budget-table key of a stage.
    pub fn key(&self, stage: &str) -> String {
        format!("{}.{}.{}.{}", self.target, self.grid.side(), method_key(self.method), stage)
    }
}

/// The outcome of checking measurements against the table.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Check {
    /// Keys over budget, with measured and budget instr/px.
    pub over: Vec<(String, f64, f64)>,
    /// Keys with no budget entry.
    pub missing: Vec<String>,
    /// Keys more than 10 % under budget (time to tighten).
    pub slack: Vec<(String, f64, f64)>,
    /// Keys checked.
    pub checked: usize,
}

impl Check {
    /// No entry over budget and none missing.
    pub fn passed(&self) -> bool {
        self.over.is_empty() && self.missing.is_empty()
    }
}

/// Checks every measured stage (and AGC run) against `budgets`.
pub fn check(measured: &[Measured], agc: &[AgcMeasured], budgets: &Table) -> Check {
    let mut c = Check::default();
    let entries = measured
        .iter()
        .flat_map(|m| m.stages.iter().map(move |s| (m.key(s.key), m.per_px(s))))
        .chain(agc.iter().map(|a| (a.key(), a.per_px())));
    for (key, got) in entries {
        c.checked += 1;
        match budgets.get(&key) {
            None => c.missing.push(key),
            Some(b) if got > b => c.over.push((key, got, b)),
            Some(b) if got < b / 1.10 => c.slack.push((key, got, b)),
            Some(_) => {}
        }
    }
    c
}

/// A budget table (TOML text) for these measurements: measured + 2 %, rounded up to 0.1
/// instr/px; `goals` lines are copied from `old`.
pub fn budget_table_text(measured: &[Measured], agc: &[AgcMeasured], old: &Table) -> String {
    let mut s = String::from(
        "# Instruction budgets of the fusion core on the emulated flight targets, in instructions per\n\
         # output pixel of the fusion grid (exact counts / W·H), checked by `fusion budget`.\n\
         # Written by `fusion budget --write-budgets` as measured + 2 %, rounded up to 0.1; tighten\n\
         # them as the code gets faster, never loosen them without saying why in the commit.\n\
         # Keys: [<target>.<grid side>.<method>] then one line per stage (see fw/README.md).\n",
    );
    for m in measured {
        let _ = writeln!(s, "\n[{}.{}.{}]", m.target, m.grid.side(), method_key(m.method));
        for st in &m.stages {
            let _ = writeln!(s, "{} = {}", st.key, table::budget_for(m.per_px(st), 0.02, 0.1));
        }
    }
    let mut header = String::new();
    for a in agc {
        let table = format!("{}.{}.agc", a.target, a.size.0);
        if table != header {
            let _ = writeln!(
                s,
                "\n# The thermal AGC (fusion_nostd::agc) on a {}x{} 14-bit TIR frame, per TIR pixel.\n[{table}]",
                a.size.0, a.size.1
            );
            header = table;
        }
        let _ = writeln!(s, "{} = {}", a.kind.name(), table::budget_for(a.per_px(), 0.02, 0.1));
    }
    let goals: Vec<_> = old.iter().filter(|(k, _)| k.starts_with("goal.")).collect();
    if !goals.is_empty() {
        s.push_str("\n# The issue's targets for the whole pipeline (reported, not enforced).\n");
        let mut header = String::new();
        for (k, v) in goals {
            let (table, key) = k.rsplit_once('.').unwrap_or((k, ""));
            if table != header {
                let _ = writeln!(s, "[{table}]");
                header = table.to_string();
            }
            let _ = writeln!(s, "{key} = {v}");
        }
    }
    s
}

/// The committed budget pair: a rendered Tango-like target in light (VIS 1024², TIR 512², noisy),
/// see `fw/README.md`.
pub fn budget_pair() -> Result<(Gray<u8>, Gray<u8>)> {
    let dir = fw::fw_dir().join("data");
    let vis = load_gray_u8(&dir.join("tango_vis_light_1024.png"), ColorPolicy::Refuse)?;
    let tir = load_gray_u8(&dir.join("tango_tir_512.png"), ColorPolicy::Refuse)?;
    ensure!(
        (vis.width, vis.height, tir.width, tir.height) == (1024, 1024, 512, 512),
        "budget pair has the wrong size"
    );
    Ok((vis, tir))
}

/// A synthetic pair at sizes that are not a factor of two apart (VIS `w×h`, TIR about half),
/// with black background, a gradient "bus", a saturated glint, stripes and hashed noise, so the
/// general rescale path and the saturation guards are exercised.
pub fn synthetic_pair(w: usize, h: usize) -> (Gray<u8>, Gray<u8>) {
    let hash = |x: usize, y: usize, s: u32| {
        let mut v = (x as u32).wrapping_mul(0x9E37_79B1) ^ (y as u32).wrapping_mul(0x85EB_CA77) ^ s;
        v ^= v >> 15;
        v = v.wrapping_mul(0x2C1B_3C6D);
        v ^= v >> 12;
        v
    };
    let mut vis = Gray::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (x * 1000 / w, y * 1000 / h);
            let noise = (hash(x, y, 1) % 9) as i32 - 4;
            let base: i32 = if (300..700).contains(&u) && (350..650).contains(&v) {
                if (550..600).contains(&u) && (400..430).contains(&v) {
                    255
                } else {
                    60 + (u as i32 - 300) / 3
                }
            } else if (100..900).contains(&u) && (480..520).contains(&v) {
                if (u / 40) % 2 == 0 { 30 } else { 140 }
            } else {
                2
            };
            vis.data[y * w + x] = (base + noise).clamp(0, 255) as u8;
        }
    }
    let (tw, th) = (w.div_ceil(2) + 1, h.div_ceil(2) - 1);
    let mut tir = Gray::new(tw, th);
    for y in 0..th {
        for x in 0..tw {
            let (u, v) = (x * 1000 / tw, y * 1000 / th);
            let noise = (hash(x, y, 2) % 7) as i32 - 3;
            let base: i32 = if (300..700).contains(&u) && (350..650).contains(&v) {
                170 + ((u + v) / 50) as i32
            } else if (100..900).contains(&u) && (480..520).contains(&v) {
                230
            } else {
                12
            };
            tir.data[y * tw + x] = (base + noise).clamp(0, 255) as u8;
        }
    }
    (vis, tir)
}

/// What `fusion budget` does.
#[derive(Debug, Clone)]
pub struct Options {
    /// Targets to measure.
    pub targets: Vec<Target>,
    /// Fusion grids to measure.
    pub grids: Vec<Grid>,
    /// Methods to measure.
    pub methods: Vec<MethodArg>,
    /// Runs of each budget job (counts must agree exactly).
    pub repeat: usize,
    /// Also check bit-exactness on the VIFB pairs, the synthetic pair and the classic variants.
    pub exactness: bool,
    /// VIFB folder.
    pub vifb: PathBuf,
    /// Budget table.
    pub budgets: PathBuf,
    /// Write a fresh table from the measurements here.
    pub write_budgets: Option<PathBuf>,
    /// Emulator timeout per run.
    pub timeout: Duration,
    /// Work folder (images, jobs, logs, report).
    pub out: PathBuf,
}

/// Results of a budget run.
#[derive(Debug, Clone, Default)]
pub struct Outcome {
    /// Per target, grid and method.
    pub measured: Vec<Measured>,
    /// `(target, grid, stack high-water bytes)`.
    pub stacks: Vec<(Target, Grid, u64)>,
    /// `(target, grid, marker overhead)`.
    pub overheads: Vec<(Target, Grid, u64)>,
    /// `(what, runs compared, runs identical)` of the bit-exactness checks.
    pub exact: Vec<(String, usize, usize)>,
    /// Built images: `(target, grid, path)`.
    pub images: Vec<(Target, Grid, PathBuf)>,
    /// Emulator wall time, seconds, per `(target, what)`.
    pub wall: Vec<(Target, String, f64)>,
    /// Targets on which a deliberate fault was checked to end the run with status 1.
    pub fault_exit: Vec<Target>,
    /// The strip runs, each beside its whole-frame run.
    pub strips: Vec<StripRun>,
    /// The thermal AGC's `agc` regions.
    pub agc: Vec<AgcMeasured>,
}

/// One AGC run's count.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AgcMeasured {
    /// Target.
    pub target: Target,
    /// Mapping.
    pub kind: fw::AgcKind,
    /// Instructions of the `agc` region (marker overhead included).
    pub count: u64,
    /// TIR frame size.
    pub size: (usize, usize),
}

impl AgcMeasured {
    /// Instructions per TIR pixel.
    pub fn per_px(&self) -> f64 {
        self.count as f64 / (self.size.0 * self.size.1) as f64
    }

    /// Budget-table key: `<target>.<TIR side>.agc.<mapping>`.
    pub fn key(&self) -> String {
        format!("{}.{}.agc.{}", self.target, self.size.0, self.kind.name())
    }
}

/// One strip run of the budget job and the whole-frame run of the same pipeline.
#[derive(Debug, Clone)]
pub struct StripRun {
    /// Target.
    pub target: Target,
    /// Grid.
    pub grid: Grid,
    /// Method and variant, as the table shows them.
    pub label: String,
    /// The core's strip report.
    pub report: fusion_nostd::strips::StripReport,
    /// Instructions of the strip run (its `pipeline` region).
    pub count: u64,
    /// Instructions of the whole-frame run.
    pub whole: u64,
}

/// The host's AGC of `counts` with a fresh state, as an AGC run of the image computes it.
pub fn agc_host(counts: &Gray<u16>, kind: fw::AgcKind) -> Result<Gray<u8>> {
    crate::agc::map_counts(&mut crate::agc::fresh(), counts, &kind.params(counts.data.len()))
}

/// The budget pair's TIR frame as 14-bit counts, the input of the AGC runs: each 8-bit level
/// times 64 plus a deterministic 6-bit dither (the AGC's cost does not depend on the values
/// beyond the histogram's spread).
pub fn counts_of(tir: &Gray<u8>) -> Gray<u16> {
    let data = tir
        .data
        .iter()
        .enumerate()
        .map(|(i, &v)| (u16::from(v) << 6) | ((i as u32).wrapping_mul(2_654_435_761) >> 26) as u16)
        .collect();
    Gray { width: tir.width, height: tir.height, data }
}

/// Compares every run of `report` with the host's result for the same job; returns how many
/// runs were identical, and describes the first difference in `diffs`.
fn compare_with_host(job: &Job, report: &FwReport, diffs: &mut Vec<String>, what: &str) -> Result<usize> {
    let mut same = 0;
    for (spec, run) in job.runs.iter().zip(&report.runs) {
        if let Some(kind) = spec.agc {
            let counts = job.tir16.as_ref().context("an AGC run without counts")?;
            let host = agc_host(counts, kind)?;
            let fw = run.image.as_ref().context("no image")?;
            if host == *fw {
                same += 1;
            } else {
                let differ = host.data.iter().zip(&fw.data).filter(|(a, b)| a != b).count();
                diffs.push(format!("{what}: agc {}: {differ} pixels differ", kind.name()));
            }
            continue;
        }
        let host = fuse_core(&job.vis, &job.tir, &spec.pipeline(), false)?;
        let fw = run.image.as_ref().context("no image")?;
        let differ = host.image.data.iter().zip(&fw.data).filter(|(a, b)| a != b).count();
        if (host.image.width, host.image.height) == (fw.width, fw.height)
            && differ == 0
            && host.guards.0 == run.guards
        {
            same += 1;
        } else {
            diffs.push(format!(
                "{what}: {} {:?} {:?}: {differ} pixels differ (host {}x{}, target {}x{}), guards host {:#x} target {:#x}",
                method_key(spec.method),
                spec.variant,
                spec.policy,
                host.image.width,
                host.image.height,
                fw.width,
                fw.height,
                host.guards.0,
                run.guards
            ));
        }
    }
    Ok(same)
}

fn progress(msg: &str) {
    note!("budget: {msg}");
}

/// The exactness jobs (run on the 1024² image): the budget pair with every method in both
/// variants and both rescale policies, the synthetic pair likewise, and each VIFB pair at its
/// own size (no rescale).
fn exactness_jobs(opts: &Options, pair: &(Gray<u8>, Gray<u8>)) -> Result<Vec<(String, Job)>> {
    let all = |policies: &[RescaleArg]| {
        let mut runs = Vec::new();
        for &method in &[MethodArg::Adf, MethodArg::Tsifsd, MethodArg::Ifevip, MethodArg::Adaptive] {
            // The adaptive method has no variants.
            let variants: &[VariantArg] = if method == MethodArg::Adaptive {
                &[VariantArg::Flight]
            } else {
                &[VariantArg::Flight, VariantArg::Classic]
            };
            for &variant in variants {
                for &policy in policies {
                    runs.push(RunSpec::plain(method, variant, policy));
                }
            }
        }
        runs
    };
    let mut jobs = vec![(
        "rendered 1024²/512²".to_string(),
        Job {
            vis: pair.0.clone(),
            tir: pair.1.clone(),
            runs: all(&[RescaleArg::TirUp, RescaleArg::VisDown]),
            tir16: None,
        },
    )];
    let (vis, tir) = synthetic_pair(301, 233);
    jobs.push((
        format!("synthetic {}x{}/{}x{}", vis.width, vis.height, tir.width, tir.height),
        Job { vis, tir, runs: all(&[RescaleArg::TirUp, RescaleArg::VisDown]), tir16: None },
    ));
    for (name, vis, tir) in crate::io::vifb_pairs(&opts.vifb)? {
        jobs.push((
            format!("VIFB {name} {}x{}", vis.width, vis.height),
            Job { vis, tir, runs: all(&[RescaleArg::None]), tir16: None },
        ));
    }
    Ok(jobs)
}

/// Builds, runs and measures (see [`Options`]). Returns the outcome; errors on a build or run
/// failure, on counts that differ between repeats, or on output that differs from the host.
pub fn run(opts: &Options) -> Result<Outcome> {
    std::fs::create_dir_all(&opts.out).with_context(|| format!("cannot create {}", opts.out.display()))?;
    let timeout = opts.timeout;
    let plugin = if opts.targets.contains(&Target::Arm) {
        progress("building the Arm counting plugin");
        Some(fw::build_plugin(&opts.out)?)
    } else {
        None
    };
    let pair = budget_pair()?;
    let mut out = Outcome::default();
    let mut diffs = Vec::new();
    let mut grids = opts.grids.clone();
    if opts.exactness && !grids.contains(&Grid::G1024) {
        grids.push(Grid::G1024);
    }
    for &target in &opts.targets {
        for &grid in &grids {
            progress(&format!("building the {target} image for the {}² grid", grid.side()));
            let image = fw::build_image(target, grid, &opts.out)?;
            out.images.push((target, grid, image.clone()));
            if grid == Grid::G1024 {
                progress(&format!("{target}: a fault must end the emulation with status 1"));
                let dir = opts.out.join(format!("{target}-fault"));
                fw::check_fault_exit(target, &image, plugin.as_deref(), &dir, timeout)?;
                out.fault_exit.push(target);
            }
            if !opts.grids.contains(&grid) || opts.methods.is_empty() {
                continue;
            }
            // The staged run of every method, then the strip run of each method that has one
            // (the same pipeline strip by strip in the 512 KiB strip scratch).
            let staged = opts.methods.iter().map(|&method| RunSpec {
                stages: true,
                ..RunSpec::plain(method, VariantArg::Flight, grid.policy())
            });
            let strips = opts.methods.iter().filter(|&&m| has_strips(m)).map(|&method| RunSpec {
                strips: true,
                ..RunSpec::plain(method, VariantArg::Flight, grid.policy())
            });
            // TSIFSD classic, whole frame and in strips (its circular window wraps around the
            // frame; no budget entry: the targets are the flight variant's).
            let classic = opts.methods.iter().filter(|&&m| m == MethodArg::Tsifsd).flat_map(|&method| {
                let whole = RunSpec::plain(method, VariantArg::Classic, grid.policy());
                [whole, RunSpec { strips: true, ..whole }]
            });
            // The thermal AGC on the pair's TIR frame as 14-bit counts (the TIR frame is 512² on
            // both grids: measured once, in the 512² job).
            let agc = fw::AgcKind::ALL.into_iter().filter(|_| grid == Grid::G512).map(RunSpec::agc);
            let job = Job {
                vis: pair.0.clone(),
                tir: pair.1.clone(),
                runs: staged.chain(strips).chain(classic).chain(agc).collect(),
                tir16: (grid == Grid::G512).then(|| counts_of(&pair.1)),
            };
            let mut first: Option<FwReport> = None;
            for rep in 0..opts.repeat.max(1) {
                progress(&format!(
                    "{target} {}²: budget run {}/{}",
                    grid.side(),
                    rep + 1,
                    opts.repeat.max(1)
                ));
                let dir = opts.out.join(format!("{target}-{}-budget-{rep}", grid.side()));
                let report = fw::run_job(target, &image, plugin.as_deref(), &job, &dir, timeout)?;
                out.wall.push((target, format!("{}² budget job", grid.side()), report.wall.as_secs_f64()));
                match &first {
                    None => first = Some(report),
                    Some(f) => {
                        for (a, b) in f.runs.iter().zip(&report.runs) {
                            ensure!(
                                a.regions == b.regions && a.fnv1a == b.fnv1a,
                                "{target} {}²: run {} differs from run 1: {:?} vs {:?}",
                                grid.side(),
                                rep + 1,
                                a.regions,
                                b.regions
                            );
                        }
                        ensure!(
                            f.overhead == report.overhead,
                            "{target}: marker overhead differs between runs"
                        );
                    }
                }
            }
            let report = first.context("no budget run")?;
            let same = compare_with_host(
                &job,
                &report,
                &mut diffs,
                &format!("{target} {}² budget pair", grid.side()),
            )?;
            out.exact.push((
                format!(
                    "{target}: budget pair, {}² grid, flight (whole frame and strips), TSIFSD classic (whole frame and strips){}",
                    grid.side(),
                    if job.tir16.is_some() { ", thermal AGC (plateau, linear)" } else { "" }
                ),
                job.runs.len(),
                same,
            ));
            out.stacks.push((target, grid, report.stack_bytes));
            out.overheads.push((target, grid, report.overhead));
            let mut classic_whole = None;
            for (spec, run) in job.runs.iter().zip(&report.runs) {
                if let Some(kind) = spec.agc {
                    let count = run.region("agc").context("no agc region in an AGC run")?;
                    out.agc.push(AgcMeasured { target, kind, count, size: (job.tir.width, job.tir.height) });
                    continue;
                }
                if spec.variant == VariantArg::Classic {
                    let count = run.region("pipeline").context("no pipeline region in a classic run")?;
                    if !spec.strips {
                        classic_whole = Some(count);
                        continue;
                    }
                    out.strips.push(StripRun {
                        target,
                        grid,
                        label: format!("{} classic", method_key(spec.method)),
                        report: run.strips.context("no strip report")?,
                        count,
                        whole: classic_whole.context("a classic strip run without its whole-frame run")?,
                    });
                    continue;
                }
                if !spec.strips {
                    out.measured.push(Measured {
                        target,
                        grid,
                        method: spec.method,
                        stages: stages_of(spec.method, run)?,
                    });
                    continue;
                }
                let count = run.region("pipeline").context("no pipeline region in a strip run")?;
                let strips = run.strips.context("no strip report")?;
                let m = out
                    .measured
                    .iter_mut()
                    .find(|m| m.target == target && m.grid == grid && m.method == spec.method)
                    .context("a strip run without its staged run")?;
                m.stages.push(Stage {
                    key: "strips",
                    what: "whole pipeline in strips (512 KiB working set, bit-identical)",
                    count,
                });
                let whole = m.pipeline();
                out.strips.push(StripRun {
                    target,
                    grid,
                    label: method_key(spec.method).to_string(),
                    report: strips,
                    count,
                    whole,
                });
            }
        }
        if opts.exactness {
            let image = out
                .images
                .iter()
                .find(|(t, g, _)| *t == target && *g == Grid::G1024)
                .map(|(_, _, p)| p.clone())
                .context("no 1024² image")?;
            for (i, (what, job)) in exactness_jobs(opts, &pair)?.into_iter().enumerate() {
                progress(&format!("{target}: bit-exactness, {what} ({} runs)", job.runs.len()));
                let dir = opts.out.join(format!("{target}-exact-{i}"));
                let report = fw::run_job(target, &image, plugin.as_deref(), &job, &dir, timeout)?;
                out.wall.push((target, format!("exactness: {what}"), report.wall.as_secs_f64()));
                let same = compare_with_host(&job, &report, &mut diffs, &format!("{target} {what}"))?;
                out.exact.push((format!("{target}: {what}, 3 methods × 2 variants"), job.runs.len(), same));
            }
        }
    }
    if !diffs.is_empty() {
        bail!("target output differs from the host:\n  {}", diffs.join("\n  "));
    }
    Ok(out)
}

fn parse_size(s: &str) -> Option<u64> {
    let s = s.trim();
    let (num, mul) = if let Some(n) = s.strip_suffix(['K', 'k']) {
        (n, 1024)
    } else if let Some(n) = s.strip_suffix(['M', 'm']) {
        (n, 1024 * 1024)
    } else {
        (s, 1)
    };
    let v = if let Some(h) = num.strip_prefix("0x").or_else(|| num.strip_prefix("0X")) {
        u64::from_str_radix(h, 16).ok()?
    } else {
        num.parse().ok()?
    };
    Some(v * mul)
}

/// The `MEMORY { NAME : ORIGIN = …, LENGTH = … }` regions of a linker map.
pub fn memory_regions(map: &str) -> Vec<(String, u64, u64)> {
    let mut out = Vec::new();
    for line in map.lines() {
        let line = line.split("/*").next().unwrap_or("");
        let Some((name, rest)) = line.split_once(':') else { continue };
        let (mut origin, mut length) = (None, None);
        for part in rest.split(',') {
            if let Some((k, v)) = part.split_once('=') {
                match k.trim() {
                    "ORIGIN" | "org" | "o" => origin = parse_size(v),
                    "LENGTH" | "len" | "l" => length = parse_size(v),
                    _ => {}
                }
            }
        }
        if let (Some(o), Some(l)) = (origin, length) {
            out.push((name.trim().to_string(), o, l));
        }
    }
    out
}

fn mib(bytes: u64) -> String {
    if bytes >= 1 << 20 {
        format!("{:.2} MiB", bytes as f64 / f64::from(1 << 20))
    } else if bytes >= 1024 {
        format!("{:.1} KiB", bytes as f64 / 1024.0)
    } else {
        format!("{bytes} B")
    }
}

/// Markdown memory report of the built images: per memory region of the target, the static
/// sections placed there; plus what each method needs at each grid according to the core.
pub fn memory_report(out: &Outcome) -> Result<String> {
    let mut s = String::new();
    s.push_str("| target | image | region | size | static use | of which | stack (measured) |\n");
    s.push_str("|---|---|---|---|---|---|---|\n");
    for (target, grid, path) in &out.images {
        let elf = Elf::read(path)?;
        let map = std::fs::read_to_string(target.linker_map())?;
        let stack = out.stacks.iter().find(|(t, g, _)| t == target && g == grid).map(|&(_, _, b)| b);
        for (name, origin, length) in memory_regions(&map) {
            let inside: Vec<_> =
                elf.alloc_sections().filter(|sec| sec.addr >= origin && sec.addr < origin + length).collect();
            let used: u64 = inside.iter().map(|sec| sec.size).sum();
            let mut parts: Vec<String> =
                inside.iter().map(|sec| format!("{} {}", sec.name, mib(sec.size))).collect();
            // `.data` also has a load copy in flash on Arm.
            if name == "FLASH" {
                for sec in elf.alloc_sections().filter(|x| x.name == ".data") {
                    parts.push(format!(".data load copy {}", mib(sec.size)));
                }
            }
            let stack_cell = match (name.as_str(), stack) {
                ("RAM", Some(b)) => mib(b),
                _ => String::new(),
            };
            let _ = writeln!(
                s,
                "| {target} | {}² | {name} | {} | {} ({:.1} %) | {} | {stack_cell} |",
                grid.side(),
                mib(length),
                mib(used),
                100.0 * used as f64 / length as f64,
                parts.join(", "),
            );
        }
    }
    s.push_str("\nWhat the core needs per method (`FuseConfig::scratch_pixels`: three `i32` planes + the `u8` band plane, plus the frames VIS in, TIR in, fused out):\n\n");
    s.push_str("| grid | method | scratch | frames | total |\n|---|---|---|---|---|\n");
    for grid in [Grid::G512, Grid::G1024] {
        for m in [MethodArg::Adf, MethodArg::Tsifsd, MethodArg::Ifevip, MethodArg::Adaptive] {
            let pipeline = FuseConfig {
                rescale: grid.policy().into(),
                method: method_for(m, VariantArg::Flight),
                ..Default::default()
            };
            let px = pipeline.scratch_pixels((1024, 1024), (512, 512))? as u64;
            let scratch = px * (3 * 4 + 1);
            let side = grid.side() as u64;
            let frames = 1024 * 1024 + 512 * 512 + side * side;
            let _ = writeln!(
                s,
                "| {side}² | {} | {} | {} | {} |",
                method_key(m),
                mib(scratch),
                mib(frames),
                mib(scratch + frames)
            );
        }
    }
    Ok(s)
}

/// Markdown tables of the measurements, the budget check and the estimates.
pub fn report(out: &Outcome, budgets: &Table, chk: &Check) -> String {
    let mut s = String::new();
    let mut groups: Vec<(Target, Grid)> = out.measured.iter().map(|m| (m.target, m.grid)).collect();
    groups.dedup();
    for (target, grid) in groups {
        let overhead = out.overheads.iter().find(|(t, g, _)| *t == target && *g == grid).map_or(0, |o| o.2);
        let _ = writeln!(
            s,
            "\n### {} ({target}), {}² grid — {}\n",
            target.core(),
            grid.side(),
            match grid {
                Grid::G512 => "VIS 1024² area-downscaled, fused with TIR 512²",
                Grid::G1024 => "TIR 512² bicubic-upscaled, fused with VIS 1024²",
            }
        );
        s.push_str("| method | stage | instructions | instr/px | budget | |\n|---|---|---:|---:|---:|---|\n");
        for m in out.measured.iter().filter(|m| m.target == target && m.grid == grid) {
            for st in &m.stages {
                let b = budgets.get(&m.key(st.key));
                let verdict = match b {
                    None => "no budget",
                    Some(b) if m.per_px(st) > b => "**over**",
                    Some(_) => "ok",
                };
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {:.2} | {} | {verdict} |",
                    method_key(m.method),
                    st.key,
                    st.count,
                    m.per_px(st),
                    b.map_or_else(|| "—".to_string(), |b| format!("{b}")),
                );
            }
        }
        let _ = writeln!(
            s,
            "\nEvery region includes the marker overhead of {overhead} instructions (an empty region)."
        );
    }
    if !out.agc.is_empty() {
        s.push_str(
            "\n### Thermal AGC (`fusion_nostd::agc_frame`, the budget pair's TIR as 14-bit counts)\n\n\
             | target | mapping | TIR | instructions | instr/px | budget | time at 400 MHz (CPI range) | |\n\
             |---|---|---|---:|---:|---:|---|---|\n",
        );
        for a in &out.agc {
            let b = budgets.get(&a.key());
            let verdict = match b {
                None => "no budget",
                Some(b) if a.per_px() > b => "**over**",
                Some(_) => "ok",
            };
            let (lo, hi) = a.target.cpi();
            let ms = |cpi: f64| format!("{:.2}", a.count as f64 * cpi / CLOCK_HZ * 1e3);
            let _ = writeln!(
                s,
                "| {} | {} | {}x{} | {} | {:.2} | {} | {}–{} ms | {verdict} |",
                a.target,
                a.kind.name(),
                a.size.0,
                a.size.1,
                a.count,
                a.per_px(),
                b.map_or_else(|| "—".to_string(), |b| format!("{b}")),
                ms(lo),
                ms(hi),
            );
        }
    }
    s.push_str("\n### Whole pipeline: estimates at 400 MHz\n\n");
    s.push_str("| target | grid | method | instr/px | instructions | CPI | cycles | time/frame | frames/s | goal (instr/px) |\n");
    s.push_str("|---|---|---|---:|---:|---|---:|---:|---:|---|\n");
    for m in &out.measured {
        let n = m.pipeline() as f64;
        let (lo, hi) = m.target.cpi();
        let per_px = n / m.pixels() as f64;
        let goal = budgets.get(&format!("goal.{}.{}.{}", m.target, m.grid.side(), method_key(m.method)));
        let goal_cell = match goal {
            None => "—".to_string(),
            Some(g) if per_px <= g => format!("{g}: met"),
            Some(g) => format!("{g}: **not met** ({:.1}×)", per_px / g),
        };
        let range =
            |f: &dyn Fn(f64) -> String| if lo == hi { f(lo) } else { format!("{}–{}", f(lo), f(hi)) };
        let _ = writeln!(
            s,
            "| {} | {}² | {} | {:.1} | {} | {} | {} | {} | {} | {goal_cell} |",
            m.target,
            m.grid.side(),
            method_key(m.method),
            per_px,
            m.pipeline(),
            range(&|c| format!("{c:.1}")),
            range(&|c| format!("{:.0} M", n * c / 1e6)),
            range(&|c| format!("{:.0} ms", n * c / CLOCK_HZ * 1e3)),
            // Frame rate falls as CPI rises: high CPI first.
            if lo == hi {
                format!("{:.2}", CLOCK_HZ / (n * lo))
            } else {
                format!("{:.2}–{:.2}", CLOCK_HZ / (n * hi), CLOCK_HZ / (n * lo))
            },
        );
    }
    if !out.strips.is_empty() {
        s.push_str(&strip_table(out));
    }
    if !out.exact.is_empty() {
        s.push_str("\n### Bit-exactness against the host\n\n| runs | identical |\n|---|---|\n");
        for (what, n, same) in &out.exact {
            let _ = writeln!(s, "| {what} | {same}/{n} |");
        }
    }
    for t in &out.fault_exit {
        let _ = writeln!(
            s,
            "\n{t}: a deliberate fault (undefined instruction) was reported and ended QEMU with status 1."
        );
    }
    let _ = writeln!(
        s,
        "\nBudget check: {} entries, {} over, {} without a budget, {} more than 10 % under budget.",
        chk.checked,
        chk.over.len(),
        chk.missing.len(),
        chk.slack.len()
    );
    s
}

/// The strip runs next to the whole-frame runs: strips, halos, the rows and instructions the
/// halos add, and the working set (method words + band window) against the 512 KiB scratch.
fn strip_table(out: &Outcome) -> String {
    let mut s = String::from(
        "\n### Strip processing: 512 KiB working set besides the frames (`fusion_nostd::strips`)\n\n\
         | target | grid | method | strips × rows | halo | passes | method rows / grid rows | band rows | \
         working set (work + band) | instructions, strips | whole frame | strips / whole |\n\
         |---|---|---|---|---:|---:|---:|---:|---|---:|---:|---:|\n",
    );
    for StripRun { target, grid, label, report: r, count: strips, whole } in &out.strips {
        let side = grid.side();
        let _ = writeln!(
            s,
            "| {target} | {side}² | {label} | {} × {} | {} | {} | {:.3} | {} | {:.1} + {:.1} = {:.1} KiB | {strips} | {whole} | {:.3} |",
            r.strips,
            r.strip_rows,
            r.halo_rows,
            r.passes,
            r.method_rows as f64 / side as f64,
            r.band_rows,
            (r.work_words * 4) as f64 / 1024.0,
            r.band_bytes as f64 / 1024.0,
            r.working_set_bytes() as f64 / 1024.0,
            *strips as f64 / (*whole).max(1) as f64,
        );
    }
    s.push_str(
        "\nEach strip run's output is compared with the host's whole-frame `fuse` (the bit-exactness table).\n",
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_with(regions: &[(&str, u64)]) -> RunOut {
        RunOut {
            regions: regions.iter().map(|&(l, c)| (l.to_string(), c)).collect(),
            guards: 0,
            rescaled: true,
            fnv1a: 0,
            size: (4, 4),
            image: None,
            skip: None,
            strips: None,
        }
    }

    #[test]
    fn stages_and_remainder() -> Result<()> {
        let run = run_with(&[("rescale", 10), ("adf.diffuse", 201), ("adf.fuse", 260), ("pipeline", 272)]);
        let rows = stages_of(MethodArg::Adf, &run)?;
        let got: Vec<_> = rows.iter().map(|r| (r.key, r.count)).collect();
        assert_eq!(
            got,
            [("rescale", 10), ("diffuse", 201), ("kl_reconstruct", 59), ("method", 260), ("pipeline", 272)]
        );
        // A method region smaller than its stages is an error, as is a missing region.
        assert!(
            stages_of(MethodArg::Adf, &run_with(&[("adf.diffuse", 10), ("adf.fuse", 6), ("pipeline", 7)]))
                .is_err()
        );
        assert!(stages_of(MethodArg::Tsifsd, &run).is_err());
        Ok(())
    }

    fn measured(per_px_pipeline: u64) -> Measured {
        let px = 512 * 512;
        Measured {
            target: Target::Arm,
            grid: Grid::G512,
            method: MethodArg::Tsifsd,
            stages: vec![
                Stage { key: "method", what: "", count: 90 * px },
                Stage { key: "pipeline", what: "", count: per_px_pipeline * px },
            ],
        }
    }

    #[test]
    fn budget_check_flags_over_missing_and_slack() -> Result<()> {
        let t = Table::parse("[arm.512.tsifsd]\npipeline = 100\nmethod = 100\n")?;
        let c = check(&[measured(100)], &[], &t);
        assert!(c.passed());
        assert_eq!(c.checked, 2);
        assert_eq!(c.slack.len(), 1, "method at 90 of 100 is 10 % under: {:?}", c.slack);
        let c = check(&[measured(101)], &[], &t);
        assert!(!c.passed());
        assert_eq!(c.over[0].0, "arm.512.tsifsd.pipeline");
        let c = check(&[measured(100)], &[], &Table::parse("[arm.512.tsifsd]\npipeline = 100\n")?);
        assert_eq!(c.missing, ["arm.512.tsifsd.method"]);
        assert!(!c.passed());
        Ok(())
    }

    #[test]
    fn written_table_reads_back_and_passes() -> Result<()> {
        let m = [measured(123)];
        let agc = [AgcMeasured {
            target: Target::Arm,
            kind: fw::AgcKind::Linear,
            count: 10 * 512 * 512,
            size: (512, 512),
        }];
        let old = Table::parse("[goal.arm.1024]\ntsifsd = 120\nadf = 500\n")?;
        let text = budget_table_text(&m, &agc, &old);
        let t = Table::parse(&text)?;
        assert!(check(&m, &agc, &t).passed());
        assert_eq!(t.get("arm.512.tsifsd.pipeline"), Some(125.5));
        assert_eq!(t.get("arm.512.agc.linear"), Some(10.2));
        let over = [AgcMeasured { count: 11 * 512 * 512, ..agc[0] }];
        assert_eq!(check(&m, &over, &t).over[0].0, "arm.512.agc.linear");
        assert_eq!(t.get("goal.arm.1024.tsifsd"), Some(120.0));
        assert_eq!(t.get("goal.arm.1024.adf"), Some(500.0));
        Ok(())
    }

    #[test]
    fn linker_map_regions() {
        let map = "MEMORY\n{\n  FLASH  : ORIGIN = 0x00000000, LENGTH = 4M\n  RAM : ORIGIN = 0x20000000, LENGTH = 512K /* c */\n}\n\
                   SECTIONS { .bigram (NOLOAD) : ALIGN(8) { } > BIGRAM }";
        assert_eq!(
            memory_regions(map),
            [("FLASH".to_string(), 0, 4 << 20), ("RAM".to_string(), 0x2000_0000, 512 << 10)]
        );
    }

    #[test]
    fn synthetic_pair_is_deterministic_and_not_twofold() {
        let (v, t) = synthetic_pair(301, 233);
        let (v2, t2) = synthetic_pair(301, 233);
        assert_eq!((v.data == v2.data, t.data == t2.data), (true, true));
        assert_eq!((t.width, t.height), (152, 116));
        assert!(v.data.contains(&255), "has a saturated glint");
        assert!(v.data.iter().filter(|&&p| p < 8).count() > v.data.len() / 2, "mostly dark background");
    }
}
