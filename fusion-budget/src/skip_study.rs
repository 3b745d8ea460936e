//! `fusion budget --skip-study DATASET`: exact instruction counts of the whole pipeline (scene
//! analysis + rescale + method, one `pipeline` region around `fusion_nostd::pipeline::fuse`)
//! per rendered frame pair and skip level on the emulated targets, each fused frame checked
//! byte for byte (and the skip report field by field) against the host's `fuse` with the same
//! [`FuseConfig`](fusion_nostd::pipeline::FuseConfig).
//!
//! Runs: every method (flight variants; the adaptive method) with `--skip none|roi|all`. TSIFSD
//! and the adaptive method skip exactly (the ROI bit-identical to the unskipped fusion); ADF and
//! IFEVIP use the crop semantics on noisy frames (IFEVIP on every frame): the ROI is the fusion
//! of the crop, and each row reports its PSNR and largest difference against the unskipped
//! fusion inside the ROI (the quality guard of issue 38). One emulator job per frame pair. ADF,
//! IFEVIP and adaptive runs that fuse the whole frame (skip `none`, or a declined skip) take
//! ~20 s each on QEMU at 1024², so they are emulated on the first `whole_frames` frames of each
//! set and version only (the host still fuses them all).
//!
//! On rendezvous sequences the study also fuses each sequence in sequence mode
//! (`fusion_nostd::sequence`, rows `all+seq`): per sequence and method one job of its frames in
//! order (`skip all`; ADF's weights carried, the skip windows joined over the last frames), each
//! frame checked against the host's `fusion_engine::sequence::SequenceFuser`.

use super::fw::{self, Grid, Job, RunOut, RunSpec, Target};
use anyhow::{Context, Result, bail, ensure};
use fusion_engine::methods::{MethodArg, RescaleArg, SkipArg, VariantArg};
use fusion_engine::skip::{fuse_once, skip_error_in};
use fusion_engine::study::{Dataset, version};
use fusion_io::Gray;
use fusion_io::note;
use fusion_io::{ColorPolicy, load_gray_u8};
use fusion_nostd::pipeline::{FuseReport, Skips};
use fusion_nostd::scene::Rect;
use fusion_report::plot::{Labels, Series, Style, chart};
use render_host::sequence::{SequenceManifest, SequenceName, read_manifest};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Duration;

/// What the study does.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    /// Rendered dataset folder (`fusion render`).
    pub dataset: PathBuf,
    /// TIR set, upscaled onto the VIS grid (`tir512`).
    pub tir: String,
    /// Frames per set and version, from the first.
    pub frames: usize,
    /// Emulate whole-frame ADF/IFEVIP runs on this many frames only.
    pub whole_frames: usize,
    /// Noise versions (`false` clean, `true` noisy).
    pub versions: Vec<bool>,
    /// Target to emulate.
    pub target: Target,
    /// Emulator timeout per job.
    pub timeout: Duration,
    /// Work folder (image, plugin, per-frame job folders).
    pub work: PathBuf,
    /// Where `emulator_<target>.md` and `.csv` go.
    pub report_dir: PathBuf,
}

/// The issues' targets for the mean instructions per 1024² frame pair with skipping (issues 20
/// and 38).
pub fn target_mean(method: MethodArg) -> Option<u64> {
    match method {
        MethodArg::Tsifsd | MethodArg::Adaptive => Some(40_000_000),
        MethodArg::Adf => Some(80_000_000),
        MethodArg::Ifevip => Some(60_000_000),
    }
}

/// The runs of one frame pair: every method at every skip level.
pub fn study_runs() -> Vec<RunSpec> {
    let mut runs = Vec::new();
    for method in [MethodArg::Tsifsd, MethodArg::Adf, MethodArg::Ifevip, MethodArg::Adaptive] {
        for skip in [SkipArg::None, SkipArg::Roi, SkipArg::All] {
            runs.push(RunSpec { skip, ..RunSpec::plain(method, VariantArg::Flight, RescaleArg::TirUp) });
        }
    }
    runs
}

fn skip_key(s: SkipArg) -> &'static str {
    match s {
        SkipArg::None => "none",
        SkipArg::Roi => "roi",
        SkipArg::All => "all",
    }
}

fn decline_text(r: &FuseReport) -> String {
    r.skip.declined.map_or_else(|| "-".to_string(), |d| format!("{d:?}"))
}

/// Differences between the target's run and the host's result for the same pipeline: the fused
/// frame byte for byte, the guards and the skip report (level, skips taken, decline, window).
/// Empty when they agree.
pub fn compare_run(spec: &RunSpec, host: &Gray<u8>, report: &FuseReport, run: &RunOut) -> Vec<String> {
    let mut d = Vec::new();
    match &run.image {
        None => d.push("no fused frame from the target".to_string()),
        Some(img) if (img.width, img.height) != (host.width, host.height) => {
            d.push(format!("size: target {}x{}, host {}x{}", img.width, img.height, host.width, host.height))
        }
        Some(img) => {
            let n = img.data.iter().zip(&host.data).filter(|(a, b)| a != b).count();
            if n != 0 {
                d.push(format!("{n} pixels differ"));
            }
        }
    }
    if run.guards != report.guards.0 {
        d.push(format!("guards: target {:#x}, host {:#x}", run.guards, report.guards.0));
    }
    match &run.skip {
        None => d.push("no skip report from the target".to_string()),
        Some(s) => {
            let c = report.skip.computed;
            let want = [c.x0, c.y0, c.x1, c.y1];
            if s.level != skip_key(spec.skip)
                || s.taken != report.skip.taken.0
                || s.declined != decline_text(report)
                || s.computed != want
            {
                d.push(format!(
                    "skip report: target {s:?}, host taken {:#x} declined {} computed {want:?}",
                    report.skip.taken.0,
                    decline_text(report)
                ));
            }
        }
    }
    d
}

/// One measured (or host-only) run.
#[derive(Debug, Clone)]
pub struct Row {
    /// `vis_light` or `vis_eclipse`.
    pub set: &'static str,
    /// `clean` or `noisy`.
    pub version: &'static str,
    /// Frame index.
    pub frame: usize,
    /// Method.
    pub method: MethodArg,
    /// Skip level.
    pub skip: SkipArg,
    /// Whole-pipeline instructions (`None`: not emulated, see `whole_frames`).
    pub instructions: Option<u64>,
    /// Window the method ran on / frame.
    pub window: f64,
    /// `Skips` bits.
    pub taken: u32,
    /// Decline reason or `-`.
    pub declined: String,
    /// Target output identical to the host (`None`: not emulated).
    pub identical: Option<bool>,
    /// PSNR (dB) against the unskipped fusion inside the ROI (∞: identical).
    pub roi_psnr: f64,
    /// Largest absolute difference against the unskipped fusion inside the ROI.
    pub roi_max_abs: u8,
    /// Fused in sequence mode (`fusion_nostd::sequence`: the set's frames one after another in
    /// one job, ADF's weights carried, the skip windows joined over the last frames).
    pub sequence: bool,
}

/// The skip column of a row: the level, `+seq` in sequence mode.
fn row_skip(r: &Row) -> String {
    format!("{}{}", skip_key(r.skip), if r.sequence { "+seq" } else { "" })
}

fn method_name(m: MethodArg) -> &'static str {
    super::method_key(m)
}

fn csv_text(rows: &[Row]) -> String {
    let mut s = String::from(
        "set,version,frame,method,skip,instructions,window_fraction,taken,declined,identical,roi_psnr_db,roi_max_abs\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{:.5},{},{},{},{:.2},{}",
            r.set,
            r.version,
            r.frame,
            method_name(r.method),
            row_skip(r),
            r.instructions.map_or_else(String::new, |n| n.to_string()),
            r.window,
            r.taken,
            r.declined,
            r.identical.map_or("", |b| if b { "yes" } else { "NO" }),
            r.roi_psnr,
            r.roi_max_abs
        );
    }
    s
}

fn millions(n: f64) -> String {
    format!("{:.1} M", n / 1e6)
}

/// The set name of the pooled rows of [`summary`].
pub const ALL_SETS: &str = "all";

/// The summary table: per (set, version, method, skip), frames emulated, mean and worst
/// instructions, worst / mean, and the targets.
pub fn summary(rows: &[Row]) -> String {
    let mut keys: Vec<(&str, &str, MethodArg, SkipArg, bool)> = Vec::new();
    for r in rows {
        let k = (r.set, r.version, r.method, r.skip, r.sequence);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    // With several sets, the pooled rows (set `all`): the issues' targets are over every frame
    // of every set.
    let sets = rows.iter().map(|r| r.set).fold(Vec::new(), |mut v, s| {
        if !v.contains(&s) {
            v.push(s);
        }
        v
    });
    if sets.len() > 1 {
        let pooled: Vec<_> = keys.iter().map(|&(_, v, m, k, q)| (ALL_SETS, v, m, k, q)).collect();
        for k in pooled {
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
    }
    let mut s = String::from(
        "| set | version | method | skip | frames emulated | mean instr | worst instr | worst/mean | mean window | ROI taken | crop | eclipse plan | declined | target mean | mean ok | worst ≤ 2× mean | ROI PSNR (worst) | ROI max abs | identical to host |\n\
         |---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---|---|---:|---:|---|\n",
    );
    for (set, ver, method, skip, sequence) in keys {
        let group: Vec<&Row> = rows
            .iter()
            .filter(|r| {
                (set == ALL_SETS || r.set == set)
                    && (r.version, r.method, r.skip, r.sequence) == (ver, method, skip, sequence)
            })
            .collect();
        let counts: Vec<f64> = group.iter().filter_map(|r| r.instructions).map(|n| n as f64).collect();
        let windows: Vec<f64> = group.iter().map(|r| r.window).collect();
        let roi_taken = group.iter().filter(|r| r.taken & Skips::ROI.0 != 0).count();
        // The eclipse plan of either method: ADF takes VIS as its constant level, TSIFSD's
        // window follows the TIR target alone.
        let plan = Skips::ECLIPSE_VIS.0 | Skips::ECLIPSE_TIR_TARGET.0;
        let eclipse = group.iter().filter(|r| r.taken & plan != 0).count();
        let mut declined: Vec<&str> =
            group.iter().map(|r| r.declined.as_str()).filter(|d| *d != "-").collect();
        declined.sort_unstable();
        declined.dedup();
        let identical = group.iter().filter(|r| r.identical == Some(true)).count();
        let crop = group.iter().filter(|r| r.taken & Skips::CROP.0 != 0).count();
        let worst_psnr = group.iter().map(|r| r.roi_psnr).fold(f64::INFINITY, f64::min);
        let max_abs = group.iter().map(|r| r.roi_max_abs).max().unwrap_or(0);
        let mean_w = windows.iter().sum::<f64>() / windows.len().max(1) as f64;
        let (mean, worst) = if counts.is_empty() {
            (f64::NAN, f64::NAN)
        } else {
            (counts.iter().sum::<f64>() / counts.len() as f64, counts.iter().copied().fold(0.0, f64::max))
        };
        let t = target_mean(method);
        let (mean_ok, worst_ok) = if counts.is_empty() {
            ("—".to_string(), "—".to_string())
        } else {
            (
                t.map_or("—".to_string(), |t| {
                    if mean <= t as f64 { "yes".into() } else { format!("**no** ({:.1}×)", mean / t as f64) }
                }),
                if worst <= 2.0 * mean { "yes".into() } else { "**no**".into() },
            )
        };
        let _ = writeln!(
            s,
            "| {set} | {ver} | {} | {} | {}/{} | {} | {} | {} | {:.1} % | {roi_taken}/{} | {crop} | {eclipse} | {} | {} | {mean_ok} | {worst_ok} | {} | {max_abs} | {identical}/{} |",
            method_name(method),
            format_args!("{}{}", skip_key(skip), if sequence { "+seq" } else { "" }),
            counts.len(),
            group.len(),
            if counts.is_empty() { "—".into() } else { millions(mean) },
            if counts.is_empty() { "—".into() } else { millions(worst) },
            if counts.is_empty() { "—".into() } else { format!("{:.2}", worst / mean) },
            mean_w * 100.0,
            group.len(),
            if declined.is_empty() { "—".to_string() } else { declined.join(", ") },
            t.map_or("—".to_string(), |t| millions(t as f64)),
            if worst_psnr.is_infinite() {
                "∞ (identical)".to_string()
            } else {
                format!("{worst_psnr:.1} dB")
            },
            counts.len(),
        );
    }
    s
}

fn progress(msg: &str) {
    note!("skip-study: {msg}");
}

/// Where the study's frame pairs come from: a study-layout dataset (`fusion render`: sets
/// `vis_light`, `vis_eclipse`, the first `frames` frames) or a folder of rendezvous sequences
/// (`fusion render --sequence`, or `fusion navbench`'s `data/`: `approach/`, `flyaround/`,
/// `frames` frames spread evenly over each).
enum Source {
    Dataset(Box<Dataset>),
    Sequences(Vec<(&'static str, PathBuf, SequenceManifest)>),
}

impl Source {
    fn open(dir: &std::path::Path) -> Result<Source> {
        if dir.join("manifest.json").is_file() {
            return Ok(Source::Dataset(Box::new(Dataset::open(dir)?)));
        }
        let mut seqs = Vec::new();
        for name in SequenceName::ALL {
            let d = dir.join(name.as_str());
            if d.join("manifest.json").is_file() {
                seqs.push((name.as_str(), d.clone(), read_manifest(&d)?));
            }
        }
        ensure!(
            !seqs.is_empty(),
            "{} holds neither a dataset (manifest.json) nor sequences (approach/, flyaround/)",
            dir.display()
        );
        Ok(Source::Sequences(seqs))
    }

    /// `(set, frame)` of the pairs to study: at most `frames` per set.
    fn pairs(&self, frames: usize) -> Vec<(&'static str, usize)> {
        match self {
            Source::Dataset(ds) => ["vis_light", "vis_eclipse"]
                .into_iter()
                .flat_map(|set| (0..frames.min(ds.frames())).map(move |f| (set, f)))
                .collect(),
            Source::Sequences(seqs) => seqs
                .iter()
                .flat_map(|(name, _, m)| {
                    let n = m.frames.len();
                    let k = frames.clamp(1, n.max(1));
                    (0..k).map(move |i| (*name, i * n / k))
                })
                .collect(),
        }
    }

    fn images(&self, set: &str, frame: usize, noisy: bool, tir_set: &str) -> Result<(Gray<u8>, Gray<u8>)> {
        match self {
            Source::Dataset(ds) => Ok((ds.image(set, frame, noisy)?, ds.image(tir_set, frame, noisy)?)),
            Source::Sequences(seqs) => {
                let (_, dir, m) = seqs.iter().find(|(n, _, _)| *n == set).context("no such sequence")?;
                let f = m.frames.get(frame).context("no such frame")?;
                let (v, t) = if noisy {
                    (Some(&f.files.vis), Some(&f.files.tir))
                } else {
                    (f.files.vis_clean.as_ref(), f.files.tir_clean.as_ref())
                };
                let load = |rel: Option<&String>| -> Result<Gray<u8>> {
                    let rel = rel.context("the sequence has no clean frames")?;
                    load_gray_u8(&dir.join(rel), ColorPolicy::Refuse)
                };
                Ok((load(v)?, load(t)?))
            }
        }
    }
}

/// Runs the study; writes `emulator_<target>.{md,csv}` into `report_dir` after every frame (so
/// a cut run leaves its partial table). Fails when any target run differs from the host.
pub fn run(opts: &StudyOptions) -> Result<Vec<Row>> {
    let src = Source::open(&opts.dataset)?;
    let pairs = src.pairs(opts.frames);
    let frames = opts.frames;
    ensure!(!pairs.is_empty(), "the dataset has no frames");
    std::fs::create_dir_all(&opts.work).with_context(|| format!("cannot create {}", opts.work.display()))?;
    std::fs::create_dir_all(&opts.report_dir)?;
    let target = opts.target;
    let plugin = if target.counts_with_plugin() {
        progress("building the Arm counting plugin");
        Some(fw::build_plugin(&opts.work)?)
    } else {
        None
    };
    progress(&format!("building the {target} image for the 1024² grid"));
    let image = fw::build_image(target, Grid::G1024, &opts.work)?;
    let mut rows = Vec::new();
    let mut diffs = Vec::new();
    let csv_path = opts.report_dir.join(format!("emulator_{target}.csv"));
    let md_path = opts.report_dir.join(format!("emulator_{target}.md"));
    for &noisy in &opts.versions {
        {
            for (k, &(set, frame)) in pairs.iter().enumerate() {
                let (vis, tir) = src.images(set, frame, noisy, &opts.tir)?;
                let grid = (vis.width * vis.height) as f64;
                let mut host = Vec::new();
                let mut runs = Vec::new();
                for spec in study_runs() {
                    let (image, report, _) = fuse_once(&vis, &tir, &spec.pipeline())?;
                    let whole = report.skip.computed == Rect::full(report.grid);
                    let costly = spec.method != MethodArg::Tsifsd && whole;
                    let first = pairs.iter().position(|&(s, _)| s == set).unwrap_or(0);
                    let emulate = !costly || k - first < opts.whole_frames;
                    if emulate {
                        runs.push(spec);
                    }
                    host.push((spec, image, report, emulate));
                }
                let report = if runs.is_empty() {
                    None
                } else {
                    let job = Job {
                        vis: vis.clone(),
                        tir: tir.clone(),
                        runs,
                        tir16: None,
                        frames: Vec::new(),
                        thermal: None,
                        rig: None,
                    };
                    let dir = opts.work.join(format!("{target}-skip-{set}-{}-{frame}", version(noisy)));
                    Some(fw::run_job(target, &image, plugin.as_deref(), &job, &dir, opts.timeout)?)
                };
                let mut outs = report.as_ref().map(|r| r.runs.iter()).into_iter().flatten();
                let mut line = String::new();
                let unskipped = |m: MethodArg| {
                    host.iter().find(|(s, ..)| s.method == m && s.skip == SkipArg::None).map(|h| &h.1)
                };
                let errors: Vec<(f64, u8)> = host
                    .iter()
                    .map(|(spec, image, fused, _)| {
                        unskipped(spec.method).map_or((f64::NAN, 0), |full| {
                            let e = skip_error_in(image, full, fused.skip.roi);
                            (e.psnr, e.max_abs)
                        })
                    })
                    .collect();
                for ((spec, image, fused, emulate), (roi_psnr, roi_max_abs)) in host.into_iter().zip(errors) {
                    let run = if emulate { outs.next() } else { None };
                    let (instructions, identical) = match run {
                        None => (None, None),
                        Some(run) => {
                            let d = compare_run(&spec, &image, &fused, run);
                            let same = d.is_empty();
                            for e in d {
                                diffs.push(format!(
                                    "{set} {} frame {frame} {} skip {}: {e}",
                                    version(noisy),
                                    method_name(spec.method),
                                    skip_key(spec.skip)
                                ));
                            }
                            (Some(run.region("pipeline").context("no pipeline region")?), Some(same))
                        }
                    };
                    let _ = write!(
                        line,
                        " {}/{}={}",
                        method_name(spec.method),
                        skip_key(spec.skip),
                        instructions.map_or("-".to_string(), |n| millions(n as f64))
                    );
                    rows.push(Row {
                        set,
                        version: version(noisy),
                        frame,
                        method: spec.method,
                        skip: spec.skip,
                        instructions,
                        window: fused.skip.computed.area() as f64 / grid,
                        taken: fused.skip.taken.0,
                        declined: decline_text(&fused),
                        identical,
                        roi_psnr,
                        roi_max_abs,
                        sequence: false,
                    });
                }
                let wall = report.as_ref().map_or(0.0, |r| r.wall.as_secs_f64());
                progress(&format!("{set} {} frame {frame} ({wall:.0} s):{line}", version(noisy)));
                let mut batch = fusion_io::Batch::default();
                batch.add_bytes(&csv_path, csv_text(&rows).as_bytes())?;
                batch.add_bytes(&md_path, markdown(opts, frames, &rows).as_bytes())?;
                batch.commit()?;
            }
            // Sequence mode: each sequence's frames one after another in one job per method.
            if let Source::Sequences(_) = &src {
                sequence_runs(opts, &src, &pairs, noisy, (&image, plugin.as_deref()), &mut rows, &mut diffs)?;
                let mut batch = fusion_io::Batch::default();
                batch.add_bytes(&csv_path, csv_text(&rows).as_bytes())?;
                batch.add_bytes(&md_path, markdown(opts, frames, &rows).as_bytes())?;
                batch.commit()?;
            }
        }
    }
    let chart = chart_per_frame(opts, &rows)?;
    if !diffs.is_empty() {
        bail!("target output differs from the host:\n  {}", diffs.join("\n  "));
    }
    progress(&format!("wrote {}, {} and {}", md_path.display(), csv_path.display(), chart.display()));
    Ok(rows)
}

/// The sequence-mode rows of one noise version: per sequence and method, the set's frames in
/// one job (each run its own frame pair, `skip all`, in the job's sequence), compared with the
/// host's `fusion_engine::sequence::SequenceFuser` over the same frames frame by frame.
fn sequence_runs(
    opts: &StudyOptions,
    src: &Source,
    pairs: &[(&'static str, usize)],
    noisy: bool,
    (image, plugin): (&std::path::Path, Option<&std::path::Path>),
    rows: &mut Vec<Row>,
    diffs: &mut Vec<String>,
) -> Result<()> {
    use fusion_engine::sequence::{Form, SequenceFuser};
    let target = opts.target;
    let mut sets: Vec<&'static str> = pairs.iter().map(|p| p.0).collect();
    sets.dedup();
    for set in sets {
        let frames: Vec<usize> = pairs.iter().filter(|p| p.0 == set).map(|p| p.1).collect();
        ensure!(frames.len() <= 128, "{set}: a sequence job holds at most 128 frames, not {}", frames.len());
        let images: Vec<(Gray<u8>, Gray<u8>)> =
            frames.iter().map(|&f| src.images(set, f, noisy, &opts.tir)).collect::<Result<_>>()?;
        for method in [MethodArg::Tsifsd, MethodArg::Adf, MethodArg::Ifevip, MethodArg::Adaptive] {
            let spec = RunSpec {
                skip: SkipArg::All,
                sequence: true,
                own_frames: true,
                ..RunSpec::plain(method, VariantArg::Flight, RescaleArg::TirUp)
            };
            let mut host = SequenceFuser::new(spec.pipeline(), Default::default(), Form::WholeFrame);
            let expected: Vec<_> = images.iter().map(|(v, t)| host.fuse(v, t)).collect::<Result<_>>()?;
            let (vis, tir) = images.first().cloned().context("no frames")?;
            let job = Job {
                vis,
                tir,
                runs: vec![spec; images.len()],
                frames: images.clone(),
                tir16: None,
                thermal: None,
                rig: None,
            };
            let dir =
                opts.work.join(format!("{target}-skip-{set}-{}-seq-{}", version(noisy), method_name(method)));
            let report = fw::run_job(target, image, plugin, &job, &dir, opts.timeout)?;
            let grid = (job.vis.width * job.vis.height) as f64;
            let mut same_frames = 0;
            let unskipped = RunSpec {
                skip: SkipArg::None,
                ..RunSpec::plain(method, VariantArg::Flight, RescaleArg::TirUp)
            };
            for (((&frame, want), run), (v, t)) in frames.iter().zip(&expected).zip(&report.runs).zip(&images)
            {
                let (full, _, _) = fuse_once(v, t, &unskipped.pipeline())?;
                let e = skip_error_in(&want.image, &full, want.report.skip.roi);
                let d = compare_run(&spec, &want.image, &want.report, run);
                let same = d.is_empty();
                same_frames += usize::from(same);
                for e in d {
                    diffs.push(format!(
                        "{set} {} frame {frame} {} all+seq: {e}",
                        version(noisy),
                        method_name(method)
                    ));
                }
                rows.push(Row {
                    set,
                    version: version(noisy),
                    frame,
                    method,
                    skip: SkipArg::All,
                    instructions: Some(run.region("pipeline").context("no pipeline region")?),
                    window: want.report.skip.computed.area() as f64 / grid,
                    taken: want.report.skip.taken.0,
                    declined: decline_text(&want.report),
                    identical: Some(same),
                    roi_psnr: e.psnr,
                    roi_max_abs: e.max_abs,
                    sequence: true,
                });
            }
            progress(&format!(
                "{set} {} {} in sequence: {} frames, {same_frames} identical to the host",
                version(noisy),
                method_name(method),
                frames.len()
            ));
        }
    }
    Ok(())
}

/// Chart `emulator_<target>_frames`: instructions per frame (millions) of every method with
/// skip `all` on the clean frames (the noisy ones when the study ran only those), one series per
/// method with the sets one after the other on the frame axis, and the targets as flat lines.
fn chart_per_frame(opts: &StudyOptions, rows: &[Row]) -> Result<PathBuf> {
    let mut series: Vec<Series> = Vec::new();
    let shown = if rows.iter().any(|r| r.version == "clean") { "clean" } else { "noisy" };
    let sets = rows.iter().map(|r| r.set).fold(Vec::new(), |mut v, s| {
        if !v.contains(&s) {
            v.push(s);
        }
        v
    });
    let per_set = rows.iter().map(|r| r.frame).max().unwrap_or(0) + 1;
    let offset = |set: &str| sets.iter().position(|s| *s == set).unwrap_or(0) * per_set;
    for r in rows.iter().filter(|r| r.version == shown && r.skip == SkipArg::All && !r.sequence) {
        let Some(n) = r.instructions else { continue };
        let name = format!("{} {}", method_name(r.method), skip_key(r.skip));
        let point = ((offset(r.set) + r.frame) as f64, n as f64 / 1e6);
        match series.iter_mut().find(|s| s.name == name) {
            Some(s) => s.points.push(point),
            None => series.push(Series { name, points: vec![point] }),
        }
    }
    let last = (sets.len() * per_set).saturating_sub(1) as f64;
    for (who, m) in
        [("tsifsd, adaptive", MethodArg::Tsifsd), ("ifevip", MethodArg::Ifevip), ("adf", MethodArg::Adf)]
    {
        if let Some(t) = target_mean(m) {
            let y = t as f64 / 1e6;
            series.push(Series { name: format!("target mean {who}"), points: vec![(0.0, y), (last, y)] });
        }
    }
    let title =
        format!("{} instructions per 1024² frame, {shown} renders, with skipping", opts.target.core());
    let names: Vec<&str> = sets.iter().map(|s| s.trim_start_matches("vis_")).collect();
    let x = format!("frame ({}, {per_set} frames each, one after the other)", names.join(" then "));
    chart(
        &opts.report_dir.join(format!("emulator_{}_frames", opts.target)),
        Labels { title: &title, x: &x, y: "million instructions (whole pipeline)" },
        &series,
        Style::Lines,
    )
}

/// The Markdown report: what was run and the summary table.
pub fn markdown(opts: &StudyOptions, frames: usize, rows: &[Row]) -> String {
    let mut s = format!(
        "# Scene skipping on the emulated {} ({}): instructions per frame\n\n\
         Dataset `{}`, {frames} frames per set and version, VIS 1024², {} bicubic-upscaled onto \
         the 1024² grid (`RescalePolicy::TirUp`), flight variants, `SceneParams::default()`. One \
         count per frame = the `pipeline` region around `fusion_nostd::pipeline::fuse` (scene \
         analysis + rescale + method + background fill; includes the marker overhead of a few \
         instructions). Every emulated fused frame was compared byte for byte with the host's \
         `fuse` of the same pipeline, and the skip report (skips taken, decline, window) field \
         by field. Window = pixels the method ran on / frame; crop = frames where a frame-global \
         method (ADF, IFEVIP) fused its crop as a frame of its own (`Skips::CROP`, issue 38's window \
         semantics); eclipse plan = frames where ADF took VIS as its constant level \
         (`Skips::ECLIPSE_VIS`) or the window followed the TIR target alone \
         (`Skips::ECLIPSE_TIR_TARGET`). ROI PSNR / max abs: the skipped output against the same \
         method's unskipped fusion inside the ROI, on the host, every frame (∞: bit-identical). \
         Set `all`: every frame of every set pooled (the issues' targets are over them). {}\n\n",
        opts.target.core(),
        opts.target,
        opts.dataset.display(),
        opts.tir,
        if opts.whole_frames >= frames {
            "Every run was emulated on every frame.".to_string()
        } else {
            format!(
                "ADF, IFEVIP and adaptive runs that fuse the whole frame (skip `none`, or a declined skip) \
                 were emulated on the first {} frame(s) only (\"frames emulated\"); the window, ROI \
                 and decline columns are from the host over all frames.",
                opts.whole_frames
            )
        }
    );
    s.push_str(&summary(rows));
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fw::SkipOut;

    #[test]
    fn skip_levels_round_trip_through_the_job_encoding() -> Result<()> {
        for spec in study_runs() {
            assert_eq!(RunSpec::decode(spec.encode())?, spec);
        }
        let roi = RunSpec {
            skip: SkipArg::Roi,
            ..RunSpec::plain(MethodArg::Adf, VariantArg::Flight, RescaleArg::TirUp)
        };
        assert_eq!(roi.encode(), [0, 1, 0, 1 << 2]);
        let all = RunSpec { skip: SkipArg::All, fault: true, ..roi };
        assert_eq!(all.encode(), [0, 1, 0, (2 << 2) | 2]);
        assert_eq!(RunSpec::decode(all.encode())?, all);
        // Skip level 3, unknown flag bits and a staged skipping run are refused (as by the image).
        assert!(RunSpec::decode([0, 1, 0, 3 << 2]).is_err());
        assert!(RunSpec::decode([0, 1, 0, 1 << 5]).is_err());
        // A strip run round-trips; staged or skipping strip runs are refused.
        let strips =
            RunSpec { strips: true, ..RunSpec::plain(MethodArg::Adf, VariantArg::Flight, RescaleArg::TirUp) };
        assert_eq!(strips.encode(), [0, 1, 0, 1 << 4]);
        assert_eq!(RunSpec::decode(strips.encode())?, strips);
        assert!(RunSpec::decode([0, 1, 0, (1 << 4) | 1]).is_err());
        assert!(RunSpec::decode([0, 1, 0, (1 << 4) | (1 << 2)]).is_err());
        assert!(RunSpec::decode([0, 1, 0, (1 << 2) | 1]).is_err());
        assert_eq!(all.pipeline().skip, fusion_nostd::pipeline::SkipPolicy::All);
        Ok(())
    }

    #[test]
    fn comparison_catches_a_pixel_and_a_skip_report() -> Result<()> {
        let (vis, tir) = crate::synthetic_pair(64, 48);
        let spec = RunSpec {
            skip: SkipArg::Roi,
            ..RunSpec::plain(MethodArg::Tsifsd, VariantArg::Flight, RescaleArg::TirUp)
        };
        let (image, report, _) = fuse_once(&vis, &tir, &spec.pipeline())?;
        let c = report.skip.computed;
        let good = RunOut {
            regions: vec![("pipeline".to_string(), 1)],
            guards: report.guards.0,
            rescaled: true,
            fnv1a: 0,
            size: (image.width, image.height),
            image: Some(image.clone()),
            skip: Some(SkipOut {
                level: "roi".into(),
                taken: report.skip.taken.0,
                declined: decline_text(&report),
                computed: [c.x0, c.y0, c.x1, c.y1],
            }),
            strips: None,
            sequence: None,
        };
        assert!(compare_run(&spec, &image, &report, &good).is_empty());
        let mut bad = good.clone();
        if let Some(img) = bad.image.as_mut() {
            img.data[7] ^= 1;
        }
        assert_eq!(compare_run(&spec, &image, &report, &bad), ["1 pixels differ"]);
        let mut bad = good.clone();
        if let Some(s) = bad.skip.as_mut() {
            s.taken ^= 1;
        }
        assert_eq!(compare_run(&spec, &image, &report, &bad).len(), 1);
        let mut bad = good;
        bad.skip = None;
        assert_eq!(compare_run(&spec, &image, &report, &bad).len(), 1);
        Ok(())
    }

    #[test]
    fn summary_flags_targets() {
        let row = |frame, n| Row {
            set: "vis_light",
            version: "clean",
            frame,
            method: MethodArg::Tsifsd,
            skip: SkipArg::Roi,
            instructions: Some(n),
            window: 0.1,
            taken: 1,
            declined: "-".into(),
            identical: Some(true),
            roi_psnr: if frame == 1 { 31.25 } else { f64::INFINITY },
            roi_max_abs: frame as u8,
            sequence: false,
        };
        let ok = summary(&[row(0, 30_000_000), row(1, 40_000_000)]);
        assert!(ok.contains("| 35.0 M | 40.0 M | 1.14 |") && ok.contains("| yes | yes |"), "{ok}");
        assert!(ok.contains("| 2/2 | 0 | 0 | — |"), "ROI, crop and eclipse-plan counts: {ok}");
        assert!(ok.contains("| 31.2 dB | 1 | 2/2 |"), "the ROI's worst PSNR and max abs: {ok}");
        // Two sets: the pooled row over both.
        let two = summary(&[
            row(0, 30_000_000),
            row(1, 40_000_000),
            Row { set: "vis_eclipse", ..row(2, 50_000_000) },
        ]);
        assert!(two.contains("| all | clean | tsifsd | roi | 3/3 | 40.0 M | 50.0 M | 1.25 |"), "{two}");
        assert!(!ok.contains("| all |"), "one set has no pooled row: {ok}");
        let bad = summary(&[row(0, 10_000_000), row(1, 10_000_000), row(2, 130_000_000)]);
        assert!(bad.contains("**no** (1.2×)") && bad.contains("| **no** | 31.2 dB | 2 | 3/3 |"), "{bad}");
    }
}
