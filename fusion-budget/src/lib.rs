//! # fusion-budget
//!
//! Firmware budgets (`fusion budget`): exact instruction counts of the core on the emulated flight targets, the
//! committed budget table, bit-exactness against the host, and the static memory of the image.
//!
//! The firmware (`fw/`) runs under QEMU: on RV32 it reads `minstret` (exact with
//! `-icount shift=0,sleep=off`), on Arm the TCG plugin `fw/plugin/insn_count.c` counts the
//! instructions between the marker functions. A staged run calls the public stage functions of a
//! method one by one inside measured regions, then the method itself; the method's remainder is
//! its count minus its stages. The whole-pipeline region is a separate call of
//! [`fusion_nostd::pipeline::fuse`] — the figure the budgets and the issue's targets are about.

//! The committed budget table (`fw/budgets.toml`) holds the instructions per pixel each
//! target, grid, method and stage may take; a typo in it is an error, not a dropped budget:
//!
//! ```
//! use fusion_budget::table::Table;
//!
//! let table = Table::parse("[arm.1024.tsifsd]\npipeline = 372.0  # instr/px\n")?;
//! assert_eq!(table.get("arm.1024.tsifsd.pipeline"), Some(372.0));
//! assert!(Table::parse("[arm.1024.tsifsd]\npipeline = fast\n").is_err());
//! # Ok::<(), anyhow::Error>(())
//! ```

mod checks;
mod elf;
pub mod fw;
mod inputs;
mod memory;
mod report;
pub mod skip_study;
mod stages;
pub mod table;

pub use checks::*;
pub use inputs::*;
pub use memory::*;
pub use report::*;
pub use stages::*;

use anyhow::{Context, Result, bail, ensure};
use elf::Elf;
use fusion_engine::methods::{MethodArg, RescaleArg, SkipArg, VariantArg, fuse_core, method_for};
use fusion_io::note;
use fusion_io::{ColorPolicy, Gray, load_gray_u8};
use fusion_nostd::pipeline::FuseConfig;
use fusion_nostd::registration::Interpolation;
use fw::{FwReport, Grid, Job, RunOut, RunSpec, Target};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Duration;
use table::Table;

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
    /// The thermal AGC's `agc` regions and the thermal front end's stages.
    pub agc: Vec<TirMeasured>,
}

/// What a per-TIR-pixel count measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TirStage {
    /// The thermal AGC alone, this mapping.
    Agc(fw::AgcKind),
    /// One stage of the thermal front end's run (`shutter`, `nuc`, `bad_pixels`, `column`, `agc`).
    Thermal(&'static str),
    /// Registration onto the visible grid, per visible pixel: the rig's node grid (`rig_map`)
    /// or the strips (`linear`, `cubic`).
    Registration(&'static str),
}

impl TirStage {
    /// The thermal front end's regions, in order.
    pub const THERMAL: [&'static str; 5] = ["shutter", "nuc", "bad_pixels", "column", "agc"];

    /// The budget table (`agc` or `thermal`).
    pub fn table(self) -> &'static str {
        match self {
            TirStage::Agc(_) => "agc",
            TirStage::Thermal(_) => "thermal",
            TirStage::Registration(_) => "registration",
        }
    }

    /// The entry's name in its table.
    pub fn name(self) -> &'static str {
        match self {
            TirStage::Agc(k) => k.name(),
            TirStage::Thermal(s) | TirStage::Registration(s) => s,
        }
    }
}

/// The range of the budget job's registration runs, metres.
pub const REGISTRATION_RANGE_M: f32 = 8.0;

/// One thermal-band region's count: an AGC run, a stage of a thermal front-end run, or a
/// registration's (per visible pixel: `size` is then the visible frame's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TirMeasured {
    /// Target.
    pub target: Target,
    /// What was measured.
    pub stage: TirStage,
    /// Instructions of the region (marker overhead included).
    pub count: u64,
    /// TIR frame size.
    pub size: (usize, usize),
}

impl TirMeasured {
    /// Instructions per TIR pixel.
    pub fn per_px(&self) -> f64 {
        self.count as f64 / (self.size.0 * self.size.1) as f64
    }

    /// Budget-table key: `<target>.<TIR side>.agc.<mapping>` or
    /// `<target>.<TIR side>.thermal.<stage>`.
    pub fn key(&self) -> String {
        format!("{}.{}.{}.{}", self.target, self.size.0, self.stage.table(), self.stage.name())
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

/// Compares every run of `report` with the host's result for the same job; returns how many
/// runs were identical, and describes the first difference in `diffs`.
fn compare_with_host(job: &Job, report: &FwReport, diffs: &mut Vec<String>, what: &str) -> Result<usize> {
    let mut same = 0;
    let thermal = job.thermal.as_ref().map(inputs::thermal_host).transpose()?.unwrap_or_default();
    let mut thermal = thermal.iter().enumerate();
    for (spec, run) in job.runs.iter().zip(&report.runs) {
        if spec.thermal {
            let (k, host) = thermal.next().context("a thermal run without its frame")?;
            let fw = run.image.as_ref().context("no image")?;
            if host == fw {
                same += 1;
            } else {
                let differ = host.data.iter().zip(&fw.data).filter(|(a, b)| a != b).count();
                diffs.push(format!("{what}: thermal front end, frame {k}: {differ} pixels differ"));
            }
            continue;
        }
        if let Some(interp) = spec.registration {
            let (rig, range) = job.rig.as_ref().context("a registration run without its rig")?;
            let host = fusion_engine::registration::register(
                &job.tir,
                rig,
                f64::from(*range),
                interp,
                fusion_nostd::registration::Border::Constant(0),
            )?;
            let fw = run.image.as_ref().context("no image")?;
            if host == *fw {
                same += 1;
            } else {
                let differ = host.data.iter().zip(&fw.data).filter(|(a, b)| a != b).count();
                diffs.push(format!("{what}: registration {interp:?}: {differ} pixels differ"));
            }
            continue;
        }
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
            // Both variants; the adaptive method's classic run is its blend alone (the job's
            // variant 0), so both of its paths are compared on every pair.
            for variant in [VariantArg::Flight, VariantArg::Classic] {
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
            frames: Vec::new(),
            thermal: None,
            rig: None,
        },
    )];
    let (vis, tir) = synthetic_pair(301, 233);
    jobs.push((
        format!("synthetic {}x{}/{}x{}", vis.width, vis.height, tir.width, tir.height),
        Job {
            vis,
            tir,
            runs: all(&[RescaleArg::TirUp, RescaleArg::VisDown]),
            tir16: None,
            frames: Vec::new(),
            thermal: None,
            rig: None,
        },
    ));
    for (name, vis, tir) in fusion_io::vifb_pairs(&opts.vifb)? {
        jobs.push((
            format!("VIFB {name} {}x{}", vis.width, vis.height),
            Job {
                vis,
                tir,
                runs: all(&[RescaleArg::None]),
                frames: Vec::new(),
                tir16: None,
                thermal: None,
                rig: None,
            },
        ));
    }
    Ok(jobs)
}

/// Runs each `(folder, job)` of `jobs` on `image`, as many at a time as the host has cores (one
/// emulator is one thread; the counts are exact either way, only the wall times grow), and
/// returns the reports in the order of `jobs`.
fn run_jobs(
    target: Target,
    image: &std::path::Path,
    plugin: Option<&std::path::Path>,
    jobs: &[(&std::path::Path, &Job)],
    timeout: std::time::Duration,
) -> Result<Vec<FwReport>> {
    let at_once = std::thread::available_parallelism().map_or(1, |n| n.get()).max(1);
    let mut reports = Vec::with_capacity(jobs.len());
    for batch in jobs.chunks(at_once) {
        let done: Vec<_> = std::thread::scope(|s| {
            let running: Vec<_> = batch
                .iter()
                .map(|&(dir, job)| s.spawn(move || fw::run_job(target, image, plugin, job, dir, timeout)))
                .collect();
            running.into_iter().map(|r| r.join()).collect()
        });
        for r in done {
            reports.push(r.map_err(|_| anyhow::anyhow!("an emulator thread panicked"))??);
        }
    }
    Ok(reports)
}

/// Builds, runs and measures (see [`Options`]). Returns the outcome; errors on a build or run
/// failure, on counts that differ between repeats, or on output that differs from the host.
pub fn run(opts: &Options) -> Result<Outcome> {
    std::fs::create_dir_all(&opts.out).with_context(|| format!("cannot create {}", opts.out.display()))?;
    let timeout = opts.timeout;
    let plugin = if opts.targets.iter().any(|t| t.counts_with_plugin()) {
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
            // ADF's sequence mode in strips: the pair twice in the job's sequence, the first with
            // its own weights (two passes), the second with the first's carried (one pass; its
            // own weights, so the per-frame fusion's bytes).
            let sequence = opts.methods.iter().filter(|&&m| m == MethodArg::Adf).flat_map(|&method| {
                let run = RunSpec {
                    strips: true,
                    sequence: true,
                    ..RunSpec::plain(method, VariantArg::Flight, grid.policy())
                };
                [run, run]
            });
            // The whole pipeline with scene skipping (`--skip all`) on the budget pair: the
            // analysis and the window (the crop semantics for ADF and IFEVIP; issue 38).
            let skipping = opts.methods.iter().map(|&method| RunSpec {
                skip: SkipArg::All,
                ..RunSpec::plain(method, VariantArg::Flight, grid.policy())
            });
            // TSIFSD classic, whole frame and in strips (its circular window wraps around the
            // frame; no budget entry: the targets are the flight variant's).
            let classic = opts.methods.iter().filter(|&&m| m == MethodArg::Tsifsd).flat_map(|&method| {
                let whole = RunSpec::plain(method, VariantArg::Classic, grid.policy());
                [whole, RunSpec { strips: true, ..whole }]
            });
            // The adaptive method's blend alone (its variant 0 in the job): what a frame with a
            // small target costs, beside the budget pair's large target fused by ADF.
            let blend = opts
                .methods
                .iter()
                .filter(|&&m| m == MethodArg::Adaptive)
                .map(|&method| RunSpec::plain(method, VariantArg::Classic, grid.policy()));
            // The thermal AGC on the pair's TIR frame as 14-bit counts (the TIR frame is 512² on
            // both grids: measured once, in the 512² job).
            let agc = fw::AgcKind::ALL.into_iter().filter(|_| grid == Grid::G512).map(RunSpec::agc);
            // The thermal front end on the same TIR frame as a short raw video of the renderer's
            // focal plane with a shutter closure (`inputs::raw_thermal`), a run per frame, in the
            // 512² job (its tables need that image's RAM).
            let raw = (grid == Grid::G512).then(|| inputs::raw_thermal(&pair.1)).transpose()?;
            let thermal: Vec<RunSpec> = raw.iter().flat_map(inputs::thermal_runs).collect();
            // Registration of the pair's TIR frame onto its 1024² VIS grid through the default
            // offset rig at 8 m, linear and cubic, in the 1024² job (its output is 1024²).
            let rig = (grid == Grid::G1024)
                .then(|| render_host::rig::offset_rig().map(|r| (r, REGISTRATION_RANGE_M)))
                .transpose()?;
            let registration = [Interpolation::Linear, Interpolation::Cubic]
                .into_iter()
                .filter(|_| rig.is_some())
                .map(RunSpec::registration);
            let job = Job {
                vis: pair.0.clone(),
                tir: pair.1.clone(),
                runs: staged
                    .chain(strips)
                    .chain(sequence)
                    .chain(skipping)
                    .chain(classic)
                    .chain(blend)
                    .chain(agc)
                    .chain(thermal)
                    .chain(registration)
                    .collect(),
                tir16: (grid == Grid::G512).then(|| counts_of(&pair.1)),
                frames: Vec::new(),
                thermal: raw,
                rig,
            };
            let reps = opts.repeat.max(1);
            progress(&format!("{target} {}²: budget runs 1–{reps} (in parallel, one per core)", grid.side()));
            let dirs: Vec<_> = (0..reps)
                .map(|rep| opts.out.join(format!("{target}-{}-budget-{rep}", grid.side())))
                .collect();
            let jobs: Vec<_> = dirs.iter().map(|d| (d.as_path(), &job)).collect();
            let mut first: Option<FwReport> = None;
            for (rep, report) in
                run_jobs(target, &image, plugin.as_deref(), &jobs, timeout)?.into_iter().enumerate()
            {
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
                    "{target}: budget pair, {}² grid, flight (whole frame, strips, ADF's sequence mode in strips, skipping), TSIFSD classic (whole frame and strips), the adaptive blend alone{}",
                    grid.side(),
                    if job.tir16.is_some() {
                        ", thermal AGC (plateau, linear), thermal front end"
                    } else if job.rig.is_some() {
                        ", registration (linear, cubic)"
                    } else {
                        ""
                    }
                ),
                job.runs.len(),
                same,
            ));
            out.stacks.push((target, grid, report.stack_bytes));
            out.overheads.push((target, grid, report.overhead));
            let mut classic_whole = None;
            let mut thermal_runs = Vec::new();
            let size = (job.tir.width, job.tir.height);
            for (spec, run) in job.runs.iter().zip(&report.runs) {
                if let Some(kind) = spec.agc {
                    let count = run.region("agc").context("no agc region in an AGC run")?;
                    out.agc.push(TirMeasured { target, stage: TirStage::Agc(kind), count, size });
                    continue;
                }
                if spec.thermal {
                    thermal_runs.push(run);
                    continue;
                }
                if let Some(interp) = spec.registration {
                    let vis_size = (job.vis.width, job.vis.height);
                    if interp == Interpolation::Linear {
                        let count =
                            run.region("rig_map").context("no rig_map region in a registration run")?;
                        out.agc.push(TirMeasured {
                            target,
                            stage: TirStage::Registration("rig_map"),
                            count,
                            size: vis_size,
                        });
                    }
                    let count = run.region("register").context("no register region in a registration run")?;
                    let name = if interp == Interpolation::Cubic { "cubic" } else { "linear" };
                    out.agc.push(TirMeasured {
                        target,
                        stage: TirStage::Registration(name),
                        count,
                        size: vis_size,
                    });
                    continue;
                }
                if spec.variant == VariantArg::Classic && spec.method == MethodArg::Adaptive {
                    let count = run.region("pipeline").context("no pipeline region in a blend run")?;
                    let m = out
                        .measured
                        .iter_mut()
                        .find(|m| m.target == target && m.grid == grid && m.method == spec.method)
                        .context("a blend run without its staged run")?;
                    m.stages.push(Stage {
                        key: "blend",
                        what: "whole pipeline, the blend alone (a small target's frame: `AdaptiveParams::blend_only`)",
                        count,
                    });
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
                if spec.sequence {
                    let pass = run.sequence.as_deref().context("no sequence line in a sequence run")?;
                    if pass == "own-first" {
                        continue;
                    }
                    ensure!(pass == "carried", "{target}: the second sequence run was not carried: {pass}");
                    let count = run.region("pipeline").context("no pipeline region in a sequence run")?;
                    let strips = run.strips.context("no strip report")?;
                    ensure!(
                        strips.passes == 1,
                        "{target}: a carried strip run took {} passes",
                        strips.passes
                    );
                    let m = out
                        .measured
                        .iter_mut()
                        .find(|m| m.target == target && m.grid == grid && m.method == spec.method)
                        .context("a sequence run without its staged run")?;
                    m.stages.push(Stage {
                        key: "strips_sequence",
                        what: "whole pipeline in strips in a sequence, weights carried from the previous frame (one pass)",
                        count,
                    });
                    let whole = m.pipeline();
                    out.strips.push(StripRun {
                        target,
                        grid,
                        label: format!("{} sequence (carried)", method_key(spec.method)),
                        report: strips,
                        count,
                        whole,
                    });
                    continue;
                }
                if spec.skip != SkipArg::None {
                    let count = run.region("pipeline").context("no pipeline region in a skip run")?;
                    let m = out
                        .measured
                        .iter_mut()
                        .find(|m| m.target == target && m.grid == grid && m.method == spec.method)
                        .context("a skip run without its staged run")?;
                    m.stages.push(Stage {
                        key: "skip",
                        what: "whole pipeline with scene skipping (`all`) on the budget pair: analysis, window (crop for ADF, IFEVIP), background",
                        count,
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
            // Per stage, the most any frame of the thermal sequence took (the shutter stage: on
            // the frames that had one).
            if !thermal_runs.is_empty() {
                for stage in TirStage::THERMAL {
                    let count = thermal_runs
                        .iter()
                        .filter_map(|run| run.region(stage))
                        .max()
                        .with_context(|| format!("no {stage} region in the thermal runs"))?;
                    out.agc.push(TirMeasured { target, stage: TirStage::Thermal(stage), count, size });
                }
            }
        }
        if opts.exactness {
            let image = out
                .images
                .iter()
                .find(|(t, g, _)| *t == target && *g == Grid::G1024)
                .map(|(_, _, p)| p.clone())
                .context("no 1024² image")?;
            let jobs = exactness_jobs(opts, &pair)?;
            let runs: usize = jobs.iter().map(|(_, job)| job.runs.len()).sum();
            progress(&format!(
                "{target}: bit-exactness, {} jobs ({runs} runs, in parallel, one per core)",
                jobs.len()
            ));
            let dirs: Vec<_> =
                (0..jobs.len()).map(|i| opts.out.join(format!("{target}-exact-{i}"))).collect();
            let both: Vec<_> = dirs.iter().zip(&jobs).map(|(d, (_, job))| (d.as_path(), job)).collect();
            let reports = run_jobs(target, &image, plugin.as_deref(), &both, timeout)?;
            for ((what, job), report) in jobs.iter().zip(reports) {
                out.wall.push((target, format!("exactness: {what}"), report.wall.as_secs_f64()));
                let same = compare_with_host(job, &report, &mut diffs, &format!("{target} {what}"))?;
                out.exact.push((
                    format!(
                        "{target}: {what}, 4 methods × 2 variants (adaptive: its policy and its blend alone)"
                    ),
                    job.runs.len(),
                    same,
                ));
            }
        }
    }
    if !diffs.is_empty() {
        bail!("target output differs from the host:\n  {}", diffs.join("\n  "));
    }
    Ok(out)
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
            sequence: None,
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
        let agc = [TirMeasured {
            target: Target::Arm,
            stage: TirStage::Agc(fw::AgcKind::Linear),
            count: 10 * 512 * 512,
            size: (512, 512),
        }];
        let old = Table::parse("[goal.arm.1024]\ntsifsd = 120\nadf = 500\n")?;
        let text = budget_table_text(&m, &agc, &old);
        let t = Table::parse(&text)?;
        assert!(check(&m, &agc, &t).passed());
        assert_eq!(t.get("arm.512.tsifsd.pipeline"), Some(125.5));
        assert_eq!(t.get("arm.512.agc.linear"), Some(10.2));
        let over = [TirMeasured { count: 11 * 512 * 512, ..agc[0] }];
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
