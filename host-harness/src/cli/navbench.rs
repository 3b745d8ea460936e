//! `fusion navbench`: every image stream of the rendezvous sequences, and the two baselines,
//! through the navigation chain (model-based front end, filter) against the rendered ground
//! truth, over several seeds (`fusion_navbench::bench`, `fusion_navbench::seeds`).

use anyhow::{Result, bail};
use clap::Args;
use fusion_io::write_bytes;
use fusion_navbench::bench::{FrameResult, PHASE_ALL, run_sequence, selected, summary};
use fusion_navbench::registration::Registration;
use fusion_navbench::seeds::{Figures, SeedSummary, Stat, Verdict, aggregate, verdict};
use fusion_report::plot::{Labels, Series, Style, chart_bounded, chart_shaded, name_identical};
use render_host::sequence::{Phase, SequenceConfig, SequenceName, read_manifest, render_sequence};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `fusion navbench`.
#[derive(Debug, Clone, Args)]
pub struct NavbenchArgs {
    /// Output folder: navbench.md, navbench.json, per_frame.csv, charts.
    #[arg(long)]
    pub out: PathBuf,
    /// Folder holding the sequences (`seed-N/approach/`, `seed-N/flyaround/`, each with its
    /// manifest.json); missing ones are rendered there [default: OUT/data].
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Noise seeds, comma-separated: each is rendered and run; every summary figure becomes
    /// its mean and spread over them.
    #[arg(long, value_delimiter = ',', value_name = "SEEDS", default_value = "1,2,3")]
    pub seeds: Vec<u64>,
    /// Frames per sequence (rendered, and used) [default: 120].
    #[arg(long)]
    pub frames: Option<usize>,
    /// VIS size of sequences rendered here (TIR is half).
    #[arg(long, default_value_t = 1024, value_name = "PX")]
    pub vis_size: u32,
    /// Only these sources, comma-separated (e.g. `vis,tir,adaptive`) [default: all but the
    /// sequence-mode ones, see --sequence-mode]; the baselines `zero-motion` and `oracle`
    /// always run.
    #[arg(long, value_delimiter = ',', value_name = "NAMES")]
    pub sources: Option<Vec<String>>,
    /// Also run the sequence-mode sources (as `fusion fuse --sequence-mode`): ADF with the KL
    /// weights of the stream's previous frame (`adf-flight-seq`, `adf-classic-seq`,
    /// `adf-flight-seq-skip`) and every method skipping with the windows joined over the last
    /// frames (`tsifsd-flight-seq-skip`, `ifevip-flight-seq-skip`, `adaptive-seq-skip`); they
    /// run only when asked, here or by name in --sources.
    #[arg(long)]
    pub sequence_mode: bool,
    /// Use the noiseless renders instead of the noisy ones (e.g. the skip windows on clean
    /// frames).
    #[arg(long)]
    pub clean: bool,
    /// Render missing sequences with the thermal camera's raw counts too (`fusion render
    /// --raw-tir`), which adds the raw-sensor sources `tir-raw`, `tir-nuc`, `tir-chain` and
    /// `adaptive-chain` (run on every sequence that has them).
    #[arg(long)]
    pub raw_tir: bool,
    /// Render missing sequences through an offset camera pair (`fusion render --rig`): `offset`
    /// (the built-in rig) or an OpenCV stereo calibration file. Sequences already rendered
    /// through a rig are judged through theirs whatever this says.
    #[arg(long, value_name = "offset|FILE")]
    pub rig: Option<PathBuf>,
    /// How the thermal frames of a sequence rendered through an offset rig reach the visible
    /// grid: `filter` (registered at the range the stream's own filter predicts, as on board),
    /// `truth` (at the true range) or `none` (rescaled as if the cameras were aligned).
    #[arg(long, default_value = "filter", value_name = "filter|truth|none", value_parser = Registration::parse)]
    pub registration: Registration,
    /// Only these sequences, comma-separated: `NAME[+earth][@DEG]`, NAME one of `approach`,
    /// `flyaround`, `radial` (the Earth behind the target), `+earth` the Earth behind an
    /// `approach` or `flyaround` (500 km), `@DEG` the sun phase angle at the first frame
    /// (`fusion render --sun-phase`); the spec names the sequence's folder and its rows
    /// [default: approach, flyaround, radial, radial@10 — black space, and the Earth at two
    /// phase angles: radial's own 68° (night side, into the shadow) and 10° (daylight)].
    #[arg(long, value_delimiter = ',', value_parser = SequenceSpec::parse, value_name = "SPECS")]
    pub sequences: Option<Vec<SequenceSpec>>,
    /// The target of sequences rendered here: `tango` or `boxwing` (`fusion render --target`)
    /// [default: tango]; given, sequences already rendered with another target are refused.
    /// Each sequence is judged against the model of the target it was rendered with.
    #[arg(long, value_enum, value_name = "NAME")]
    pub target: Option<render_host::scene::Target>,
}

/// One sequence of a run: a named trajectory, with the Earth behind it or not, at its own sun
/// or at a sun phase angle.
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceSpec {
    /// The trajectory.
    pub name: SequenceName,
    /// The Earth behind an `approach` or `flyaround` (`radial` always has it).
    pub earth: bool,
    /// The sun phase angle at the first frame, degrees (0–180).
    pub sun_phase_deg: Option<f64>,
}

impl SequenceSpec {
    /// The default run: black space, and the Earth at two sun phase angles.
    pub fn defaults() -> Vec<SequenceSpec> {
        let plain = |name| SequenceSpec { name, earth: false, sun_phase_deg: None };
        vec![
            plain(SequenceName::Approach),
            plain(SequenceName::Flyaround),
            plain(SequenceName::Radial),
            SequenceSpec { sun_phase_deg: Some(10.0), ..plain(SequenceName::Radial) },
        ]
    }

    /// Parses `NAME[+earth][@DEG]`.
    pub fn parse(text: &str) -> Result<SequenceSpec, String> {
        let (rest, phase) = match text.split_once('@') {
            Some((r, p)) => {
                let deg: f64 = p.parse().map_err(|_| format!("'{p}' is not a sun phase angle in degrees"))?;
                if !(0.0..=180.0).contains(&deg) {
                    return Err(format!("sun phase {deg}° is outside 0–180°"));
                }
                (r, Some(deg))
            }
            None => (text, None),
        };
        let (name, earth) = match rest.strip_suffix("+earth") {
            Some(n) => (n, true),
            None => (rest, false),
        };
        let name = SequenceName::ALL.into_iter().find(|n| n.as_str() == name).ok_or_else(|| {
            format!("unknown sequence '{name}' (approach, flyaround, radial; NAME[+earth][@DEG])")
        })?;
        if earth && name == SequenceName::Radial {
            return Err("radial always has the Earth behind the target: drop '+earth'".into());
        }
        Ok(SequenceSpec { name, earth, sun_phase_deg: phase })
    }

    /// The spec as written (`radial@10`): the sequence's folder and the rows' `sequence`.
    pub fn label(&self) -> String {
        let mut s = self.name.as_str().to_string();
        if self.earth {
            s.push_str("+earth");
        }
        if let Some(p) = self.sun_phase_deg {
            let _ = write!(s, "@{p}");
        }
        s
    }

    /// Whether the Earth is behind the target.
    pub fn has_earth(&self) -> bool {
        self.earth || self.name == SequenceName::Radial
    }
}

/// The phases in table order, then the whole sequence.
const PHASES: [&str; 4] = ["light", "penumbra", "eclipse", PHASE_ALL];

/// The sources the charts and the answer show, when run (`adf-flight-seq` only with
/// `--sequence-mode`).
const SHOWN: [&str; 7] = ["zero-motion", "oracle", "vis", "tir", "adaptive", "adf-flight", "adf-flight-seq"];

/// Runs `fusion navbench`.
pub fn run(args: &NavbenchArgs) -> Result<()> {
    if args.frames == Some(0) || args.frames == Some(1) {
        bail!("--frames must be at least 2 (tracking needs frame pairs)");
    }
    let max = fusion_navbench::bench::MAX_CAMERA_SIZE;
    if args.vis_size < 64 || args.vis_size > max || !args.vis_size.is_multiple_of(2) {
        bail!("--vis-size must be even, at least 64 and at most {max}");
    }
    // What a run of freshly rendered sequences holds (existing ones are checked when read).
    let px = u64::from(args.vis_size).pow(2) * args.frames.unwrap_or(120) as u64;
    fusion_io::memory::check(
        &format!("--vis-size {}", args.vis_size),
        "judging",
        fusion_io::memory::estimate(px, fusion_navbench::bench::BYTES_PER_PIXEL_FRAME),
    )?;
    let mut seen = std::collections::BTreeSet::new();
    let seeds: Vec<u64> = args.seeds.iter().copied().filter(|s| seen.insert(*s)).collect();
    if seeds.is_empty() {
        bail!("--seeds needs at least one seed");
    }
    let rig = args.rig.as_deref().map(render_host::rig::from_arg).transpose()?;
    if let Some(r) = &rig
        && (r.vis.width != r.vis.height || r.tir.width != r.tir.height)
    {
        bail!("--rig: the sequences render square images, the rig's cameras are not square");
    }
    // --sequence-mode: the sources asked for (or the default ones) and ADF in sequence mode.
    let with_sequence: Option<Vec<String>> = args.sequence_mode.then(|| {
        let names = match &args.sources {
            Some(s) => s.clone(),
            None => selected(None).map(|v| v.into_iter().map(|(n, _)| n).collect()).unwrap_or_default(),
        };
        let seq = fusion_navbench::bench::SEQUENCE_SOURCES.iter().map(|s| s.to_string());
        names.into_iter().chain(seq).collect()
    });
    let only = with_sequence.as_deref().or(args.sources.as_deref());
    let streams = selected(only)?.len();
    let start = Instant::now();
    let data = args.data.clone().unwrap_or_else(|| args.out.join("data"));
    let _folder = fusion_io::output::create_folder(&args.out)?;
    let mut rows: Vec<FrameResult> = Vec::new();
    let mut per_seed = Vec::new();
    let specs = args.sequences.clone().unwrap_or_else(SequenceSpec::defaults);
    let labels: Vec<String> = specs.iter().map(SequenceSpec::label).collect();
    if let Some(l) = labels.iter().enumerate().find_map(|(i, l)| labels[..i].contains(l).then_some(l)) {
        bail!("--sequences names '{l}' twice");
    }
    let earth: Vec<String> = specs.iter().filter(|s| s.has_earth()).map(SequenceSpec::label).collect();
    // Which target each sequence shows (`sequence: target`), for the report.
    let mut targets: Vec<String> = Vec::new();
    for &seed in &seeds {
        let mut seed_rows = Vec::new();
        for spec in &specs {
            let (name, label) = (spec.name, spec.label());
            let dir = data.join(format!("seed-{seed}")).join(&label);
            let target = if dir.join("manifest.json").is_file() {
                let m = read_manifest(&dir)?;
                if m.config.seed != seed {
                    bail!("{}: rendered with seed {}, not {seed}", dir.display(), m.config.seed);
                }
                if m.config.name != name
                    || m.config.earth.is_some() != spec.has_earth()
                    || m.config.sun_phase_deg != spec.sun_phase_deg
                {
                    bail!(
                        "{}: rendered as another sequence than '{label}' (its trajectory, Earth or sun phase differ)",
                        dir.display()
                    );
                }
                if let Some(t) = args.target
                    && m.config.target != t
                {
                    bail!(
                        "{}: rendered with the target {}, not {} (--target)",
                        dir.display(),
                        m.config.target.as_str(),
                        t.as_str()
                    );
                }
                // Existing data is used as it is: say where it differs from what was asked.
                if let Some(f) = args.frames
                    && m.frames.len() < f
                {
                    note!(
                        "navbench: {} has {} frames, fewer than --frames {f}: using {}",
                        dir.display(),
                        m.frames.len(),
                        m.frames.len()
                    );
                }
                let samples = render_host::sequence::SEQUENCE_SAMPLES;
                if m.vis_camera.size != args.vis_size || m.config.vis.samples != samples {
                    note!(
                        "navbench: {} was rendered at {} px with {}² samples per pixel (a new render: {} px, {samples}²); using it as it is",
                        dir.display(),
                        m.vis_camera.size,
                        m.config.vis.samples,
                        args.vis_size
                    );
                }
                m.config.target
            } else {
                let (vis_size, tir_size) = match &rig {
                    Some(r) => (r.vis.width as u32, r.tir.width as u32),
                    None => (args.vis_size, args.vis_size / 2),
                };
                let base = SequenceConfig::new(name);
                let cfg = SequenceConfig {
                    frames: args.frames.unwrap_or(120),
                    vis_size,
                    tir_size,
                    seed,
                    target: args.target.unwrap_or_default(),
                    focal_plane: args.raw_tir.then(render_host::focal_plane::FocalPlaneParams::default),
                    rig,
                    // The sequence's own Earth (`radial`) or the one asked for, seeded as
                    // `fusion render` seeds it.
                    earth: render_host::sequence::sequence_earth(
                        name,
                        spec.earth.then_some(render_host::earth::DEFAULT_ALTITUDE_M),
                        seed,
                        base.surface_seed,
                    ),
                    sun_phase_deg: spec.sun_phase_deg,
                    ..base
                };
                note!("rendering {label} seed {seed} ({} frames) into {}", cfg.frames, dir.display());
                // Whole or absent: an interrupted render leaves no half-written sequence.
                fusion_io::output::in_new_folder(&dir, |d| render_sequence(&cfg, d, false))?.config.target
            };
            targets.push(format!("`{label}`: {}", target.as_str()));
            let mut seq = run_sequence(&dir, args.frames, only, args.clean, args.registration)?;
            for r in &mut seq {
                r.sequence.clone_from(&label);
            }
            note!(
                "navbench: {label} seed {seed} ({} frames, {streams} sources, {:.0} s so far)",
                seq.len() / streams.max(1),
                start.elapsed().as_secs_f64()
            );
            seed_rows.extend(seq);
        }
        per_seed.push(summary(&seed_rows));
        rows.extend(seed_rows);
    }
    let s = aggregate(&seeds, &per_seed);
    write_text(&args.out.join("navbench.json"), &serde_json::to_string_pretty(&s)?)?;
    write_text(&args.out.join("per_frame.csv"), &csv(&rows))?;
    let charts = charts(&args.out, &rows, seeds[0], &labels)?;
    targets.sort();
    targets.dedup();
    let targets = targets.join(", ");
    write_text(
        &args.out.join("navbench.md"),
        &markdown(&s, &charts, start.elapsed().as_secs_f64(), &targets, &earth),
    )?;
    outln!(
        "navbench: {} frame results, {} sources, {} seeds -> {} ({:.0} s)",
        rows.len(),
        s.sources.len(),
        seeds.len(),
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
        "sequence,seed,frame,phase,source,cnr,target_features,tracks,inliers,rot_err_deg,trans_dir_err_deg,lost,\
att_err_deg,pos_err_pct,att_3sigma_deg,pos_3sigma_pct,nees,available,reacquire_frames,\
pairwise_tracks,pairwise_inliers,pairwise_rot_err_deg,pairwise_trans_dir_err_deg,pairwise_lost,target_coverage,window_frac,\
misregistration_px,misregistration_p95_px,rel_pos_err_pct,available_rel\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.sequence,
            r.seed,
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
            r.att_err_deg,
            r.pos_err_pct,
            r.att_3sigma_deg,
            r.pos_3sigma_pct,
            r.nees,
            r.available,
            r.reacquire_frames,
            r.pairwise_tracks,
            r.pairwise_inliers,
            r.pairwise_rot_err_deg,
            r.pairwise_trans_dir_err_deg,
            r.pairwise_lost,
            r.target_coverage,
            r.window_frac,
            r.misregistration_px,
            r.misregistration_p95_px,
            r.rel_pos_err_pct,
            r.available_rel
        );
    }
    s
}

/// Per sequence (the first seed): the filter's attitude and position errors against the frame
/// with their 3σ bounds (thin lines), penumbra and eclipse shaded, for the baselines, the two
/// cameras, the adaptive fusion and ADF (flight); and the features on the target.
fn charts(out: &Path, rows: &[FrameResult], seed: u64, labels: &[String]) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for name in labels {
        let seq: Vec<&FrameResult> = rows.iter().filter(|r| &r.sequence == name && r.seed == seed).collect();
        if seq.is_empty() {
            continue;
        }
        let mut shaded = Vec::new();
        for r in seq.iter().filter(|r| r.source == "zero-motion" && r.phase != Phase::Light) {
            shaded.push((r.frame as f64 - 0.5, r.frame as f64 + 0.5));
        }
        let shown: Vec<&str> = SHOWN.iter().copied().filter(|s| seq.iter().any(|r| r.source == *s)).collect();
        let series = |f: &dyn Fn(&FrameResult) -> f64| -> Vec<Series> {
            shown
                .iter()
                .map(|src| Series {
                    name: (*src).to_string(),
                    points: seq.iter().filter(|r| r.source == *src).map(|r| (r.frame as f64, f(r))).collect(),
                })
                .collect()
        };
        written.push(error_chart(
            &out.join(format!("{name}_attitude_error")),
            &format!("{name}, seed {seed}: filter attitude error and its 3σ (thin)"),
            "attitude error, degrees (log)",
            &seq,
            &|r| (r.att_err_deg, r.att_3sigma_deg),
        )?);
        written.push(error_chart(
            &out.join(format!("{name}_position_error")),
            &format!("{name}, seed {seed}: filter position error and its 3σ (thin)"),
            "position error, % of range (log)",
            &seq,
            &|r| (r.pos_err_pct, r.pos_3sigma_pct),
        )?);
        let image_streams: Vec<Series> = series(&|r| r.target_features as f64)
            .into_iter()
            .filter(|s| !["zero-motion", "oracle"].contains(&s.name.as_str()))
            .collect();
        written.push(chart_shaded(
            &out.join(format!("{name}_features")),
            Labels {
                title: &format!("{name}, seed {seed}: features on the target (grey: penumbra and eclipse)"),
                x: "frame",
                y: "FAST corners on the target",
            },
            &image_streams,
            Style::Lines,
            &shaded,
        )?);
    }
    Ok(written)
}

/// One sequence's filter error against the frame (log y) with its 3σ as a thin line, for the
/// sources of [`SHOWN`] that ran (the zero-motion baseline's growing bound is left out),
/// penumbra and eclipse shaded. `value` gives (error, 3σ) of a row.
pub fn error_chart(
    stem: &Path,
    title: &str,
    y: &str,
    seq: &[&FrameResult],
    value: &dyn Fn(&FrameResult) -> (f64, f64),
) -> Result<PathBuf> {
    let mut shaded = Vec::new();
    for r in seq.iter().filter(|r| r.source == "zero-motion" && r.phase != Phase::Light) {
        shaded.push((r.frame as f64 - 0.5, r.frame as f64 + 0.5));
    }
    let shown: Vec<&str> = SHOWN.iter().copied().filter(|s| seq.iter().any(|r| r.source == *s)).collect();
    let series = |pick: &dyn Fn(&FrameResult) -> f64| -> Vec<Series> {
        shown
            .iter()
            .map(|src| Series {
                name: (*src).to_string(),
                points: seq.iter().filter(|r| r.source == *src).map(|r| (r.frame as f64, pick(r))).collect(),
            })
            .collect()
    };
    let mut bounds = series(&|r| value(r).1);
    if let Some(b) = bounds.first_mut().filter(|b| b.name == "zero-motion") {
        b.points.clear();
    }
    // A line drawn exactly over an earlier one (the adaptive method's large-target frames are
    // ADF's) says so in the legend.
    let mut lines = series(&|r| value(r).0);
    name_identical(&mut lines);
    chart_bounded(
        stem,
        Labels { title: &format!("{title} (grey: penumbra and eclipse)"), x: "frame", y },
        &lines,
        &bounds,
        Style::LinesLogY,
        &shaded,
    )
}

/// Issue 39's targets on the sequences with the Earth behind the target: per phase, the
/// adaptive stream never worse than the better camera (means over seeds), and the skip
/// streams' windows (the scene analysis's, from brightness) covering every target pixel.
fn earth_targets(md: &mut String, s: &SeedSummary, earth: &[String]) {
    let present: Vec<&String> = earth.iter().filter(|l| s.by_sequence.contains_key(*l)).collect();
    if present.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "## Targets with the Earth behind the target\n\n\
         Per phase, the adaptive stream against the better single camera (the never-worse rule: mean \
         availability ≥ the camera's and mean attitude RMS ≤ 1.05 × its; better or worse only when the \
         means differ by more than the larger spread over the seeds); the skip streams' windows (the \
         scene analysis's, found from brightness; the `-loop` streams take the filter's predicted box \
         instead) against every target pixel.\n\n\
         | sequence | phase | better camera: availability | adaptive: availability | never worse | adaptive's availability against it |\n\
         |---|---|---|---|---|---|"
    );
    for label in &present {
        let Some(srcs) = s.by_sequence.get(*label) else { continue };
        for phase in PHASES {
            let (Some((cam, cf)), Some(a)) =
                (better_camera(srcs, phase), srcs.get("adaptive").and_then(|p| p.get(phase)))
            else {
                continue;
            };
            let v = match (stat(a, "availability"), stat(cf, "availability")) {
                (Some(x), Some(c)) => verdict(x, c, true).word(),
                _ => Verdict::OneSeed.word(),
            };
            let _ = writeln!(
                md,
                "| {label} | {phase} | {cam} {} | {} | {} | {v} |",
                cell(cf, "availability", 3),
                cell(a, "availability", 3),
                if never_worse(a, cf) { "yes" } else { "no" }
            );
        }
    }
    let _ = writeln!(
        md,
        "\n| sequence | skip stream | target coverage (each seed's minimum over frames, mean over seeds) | 100 % on every frame |\n\
         |---|---|---|---|"
    );
    for label in &present {
        let Some(methods) = s.skip_by_sequence.get(*label) else { continue };
        for (m, k) in methods.iter().filter(|(m, _)| !m.ends_with("-loop")) {
            let min = k.get("target_coverage_min").copied().flatten().map(|x| x.mean);
            let _ = writeln!(
                md,
                "| {label} | {m} | {} | {} |",
                min.map_or("—".into(), |x| format!("{x:.4}")),
                if min == Some(1.0) { "yes" } else { "no" }
            );
        }
    }
    let _ = writeln!(md);
}

/// `mean ± sd` (the mean alone for one seed), `—` when missing.
fn cell(f: &Figures, key: &str, digits: usize) -> String {
    match f.get(key).copied().flatten() {
        Some(Stat { mean, sd, n }) if n > 1 => format!("{mean:.digits$} ± {sd:.digits$}"),
        Some(Stat { mean, .. }) => format!("{mean:.digits$}"),
        None => "—".to_string(),
    }
}

fn stat(f: &Figures, key: &str) -> Option<Stat> {
    f.get(key).copied().flatten()
}

/// The better single camera in a phase: higher availability, then the lower RMS attitude
/// error (means over seeds).
fn better_camera<'a>(
    phases: &'a std::collections::BTreeMap<String, std::collections::BTreeMap<String, Figures>>,
    phase: &str,
) -> Option<(&'static str, &'a Figures)> {
    let get = |s: &str| phases.get(s).and_then(|p| p.get(phase));
    let (vis, tir) = (get("vis")?, get("tir")?);
    let key = |f: &Figures| {
        (
            -stat(f, "availability").map_or(0.0, |s| s.mean),
            stat(f, "att_rms_deg").map_or(f64::INFINITY, |s| s.mean),
        )
    };
    Some(if key(vis) <= key(tir) { ("vis", vis) } else { ("tir", tir) })
}

/// The never-worse rule on the filter's measures (means over seeds): availability at least
/// the better camera's, RMS attitude error at most 1.05 × its.
fn never_worse(x: &Figures, cam: &Figures) -> bool {
    let m = |f: &Figures, k: &str| stat(f, k).map(|s| s.mean);
    match (m(x, "availability"), m(cam, "availability"), m(x, "att_rms_deg"), m(cam, "att_rms_deg")) {
        (Some(a), Some(ac), Some(r), Some(rc)) => a >= ac && r <= 1.05 * rc,
        _ => false,
    }
}

fn markdown(s: &SeedSummary, charts: &[PathBuf], seconds: f64, targets: &str, earth: &[String]) -> String {
    let mut md = String::new();
    let seeds: Vec<String> = s.seeds.iter().map(u64::to_string).collect();
    let _ = writeln!(md, "# Navigation benchmark\n");
    let _ = writeln!(
        md,
        "Every source through one navigation chain on the rendezvous sequences (`approach`: 50 m → 5 m \
in light, target tumbling; `flyaround`: a circumnavigation at 8 m through an eclipse; `radial`: \
30 m → 5 m from above with the Earth behind the target, into its shadow), targets {targets}, noisy frames, \
seeds {} (each figure: mean ± sample standard deviation over the seeds). Generated by `fusion \
navbench` in {seconds:.0} s.\n\n\
* **Front end** (model-based): Shi–Tomasi corners tracked over frames by pyramidal Lucas–Kanade with \
a forward–backward check (`optical-flow-lk`), their 3D points from the target model at the \
estimated pose, PnP-RANSAC (SQPnP) + Levenberg–Marquardt. *f2f rot*: the rotation error of the \
relative pose between two consecutive measured poses; *lost*: pairs without it.\n\
* **Absolute cues**: the model's creases searched along their normals around the prediction and \
the pose fitted to them (Gauss–Newton, Tukey weights) where the target is predicted ≥ 96 px wide; \
the outline's position elsewhere; both read only the part of a frame that holds the scene (a skipped \
fusion's window).\n\
* **Filter**: an MEKF on the relative attitude (constant rate) and the target's centre in the \
camera's frame (constant velocity there: the chaser points at the target), fed by the absolute cues (not by the tracks' pose, which drifts with the estimate its points come \
from), started on the first frame's truth perturbed by 1° and 1 % of the range. *available*: share of \
frames with attitude error ≤ 2° and position error ≤ 2 % of range (the position is the camera's in \
the target's frame, so an attitude error about the target's centre counts in it too: 1° is 1.75 % \
of range); *relative position*: the target's centre in the camera's frame, the line of sight \
guidance steers on, which that error leaves unchanged; *available (relative)*: attitude ≤ 2° and \
relative position ≤ 2 %; *NEES*: 6 when consistent; *re-acq.*: mean frames from a loss to the \
next available frame.\n\
* **Baselines**: `zero-motion` (no motion; its filter never gets a measurement), `oracle` \
(ground-truth correspondences with 0.3 px noise through the same estimator and filter).\n\
* **Pairwise** (the previous judge, kept beside): FAST-9 + BRIEF matched frame to frame, PnP \
against the previous frame's rendered depth.\n\
* A verdict (better / worse) is stated only where two means differ by more than the larger of \
their spreads over the seeds.\n",
        seeds.join(", ")
    );
    // The answer: the whole sequence.
    let _ = writeln!(md, "## The answer: navigation over each whole sequence\n");
    for (seq, srcs) in &s.by_sequence {
        let _ = writeln!(
            md,
            "**{seq}**\n\n| source | available | attitude RMS ° | position RMS % of range | available (relative) | relative position RMS % | NEES | re-acq. frames |\n|---|---|---|---|---|---|---|---|"
        );
        for (src, phases) in srcs {
            let Some(x) = phases.get(PHASE_ALL) else { continue };
            let _ = writeln!(
                md,
                "| {src} | {} | {} | {} | {} | {} | {} | {} |",
                cell(x, "availability", 3),
                cell(x, "att_rms_deg", 3),
                cell(x, "pos_rms_pct", 3),
                cell(x, "availability_rel", 3),
                cell(x, "rel_pos_rms_pct", 3),
                cell(x, "nees", 1),
                cell(x, "reacquire_frames", 1)
            );
        }
        let _ = writeln!(md);
    }
    // Targets of issue 37.
    let _ = writeln!(md, "## Targets\n\n| target | measured (mean over seeds) | holds |\n|---|---|---|");
    let light =
        |seq: &str, src: &str| s.by_sequence.get(seq).and_then(|x| x.get(src)).and_then(|p| p.get("light"));
    let mean = |f: Option<&Figures>, k: &str| f.and_then(|f| stat(f, k)).map(|x| x.mean);
    for (seq, cam_factor, oracle_factor) in [("flyaround", 0.25, 0.1), ("approach", 0.5, 0.2)] {
        let Some(zero) = mean(light(seq, "zero-motion"), "rot_err_deg_median") else { continue };
        let phases = s.by_sequence.get(seq);
        let best = phases.and_then(|p| better_camera(p, "light"));
        if let Some((cam, f)) = best {
            let r = mean(Some(f), "rot_err_deg_median");
            let lost = mean(Some(f), "lost_frac").unwrap_or(1.0);
            let _ = writeln!(
                md,
                "| {seq}, light: better camera ({cam}) f2f rotation ≤ {cam_factor} × zero-motion ({zero:.3}°) | {} | {} |",
                r.map_or("—".into(), |r| format!("{r:.3}° = {:.2} ×", r / zero)),
                if r.is_some_and(|r| r <= cam_factor * zero) { "yes" } else { "no" }
            );
            let _ = writeln!(
                md,
                "| {seq}, light: better camera ({cam}) lost pairs ≤ 5 % | {:.1} % | {} |",
                100.0 * lost,
                if lost <= 0.05 { "yes" } else { "no" }
            );
        }
        let o = mean(light(seq, "oracle"), "rot_err_deg_median");
        let _ = writeln!(
            md,
            "| {seq}, light: oracle f2f rotation ≤ {oracle_factor} × zero-motion | {} | {} |",
            o.map_or("—".into(), |o| format!("{o:.3}° = {:.3} ×", o / zero)),
            if o.is_some_and(|o| o <= oracle_factor * zero) { "yes" } else { "no" }
        );
    }
    if let Some(fly) = s.by_sequence.get("flyaround") {
        let av =
            |src: &str| fly.get(src).and_then(|p| p.get(PHASE_ALL)).and_then(|f| stat(f, "availability"));
        if let (Some(a), Some(v), Some(t)) = (av("adaptive"), av("vis"), av("tir")) {
            let _ = writeln!(
                md,
                "| flyaround, whole: adaptive availability ≥ 95 % and above both cameras (vis {:.1} %, tir {:.1} %) | {:.1} % | {} |",
                100.0 * v.mean,
                100.0 * t.mean,
                100.0 * a.mean,
                if a.mean >= 0.95 && a.mean > v.mean && a.mean > t.mean { "yes" } else { "no" }
            );
        }
    }
    let _ = writeln!(md);
    earth_targets(&mut md, s, earth);
    // Per sequence and phase.
    for (seq, srcs) in &s.by_sequence {
        for phase in PHASES {
            if !srcs.values().any(|p| p.contains_key(phase)) {
                continue;
            }
            let _ = writeln!(md, "## {seq}: {phase}\n");
            let _ = writeln!(
                md,
                "| source | available | att. RMS ° | pos. RMS % | NEES | f2f rot ° (median) | lost | tracks | inlier ratio | CNR | pairwise rot ° | pairwise lost |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
            );
            for (src, phases) in srcs {
                let Some(x) = phases.get(phase) else { continue };
                let _ = writeln!(
                    md,
                    "| {src} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    cell(x, "availability", 3),
                    cell(x, "att_rms_deg", 3),
                    cell(x, "pos_rms_pct", 3),
                    cell(x, "nees", 1),
                    cell(x, "rot_err_deg_median", 3),
                    cell(x, "lost_frac", 3),
                    cell(x, "tracks", 0),
                    cell(x, "inlier_ratio", 2),
                    cell(x, "cnr", 2),
                    cell(x, "pairwise_rot_err_deg_median", 3),
                    cell(x, "pairwise_lost_frac", 3),
                );
            }
            let _ = writeln!(md);
            if let Some((cam, cf)) = better_camera(srcs, phase) {
                let mut lines = Vec::new();
                for (src, phases) in srcs {
                    if ["vis", "tir", "zero-motion", "oracle"].contains(&src.as_str()) {
                        continue;
                    }
                    let Some(x) = phases.get(phase) else { continue };
                    let judge = |k: &str, higher: bool| match (stat(x, k), stat(cf, k)) {
                        (Some(a), Some(b)) => verdict(a, b, higher),
                        _ => Verdict::OneSeed,
                    };
                    lines.push(format!(
                        "| {src} | {} | {} | {} | {} |",
                        judge("availability", true).word(),
                        judge("att_rms_deg", false).word(),
                        judge("rot_err_deg_median", false).word(),
                        if never_worse(x, cf) { "yes" } else { "no" }
                    ));
                }
                let _ = writeln!(
                    md,
                    "The better single camera in {seq} {phase} is **{cam}**. Each fused stream against it:\n\n\
| stream | availability | attitude RMS | f2f rotation | never worse (mean availability ≥, mean att. RMS ≤ 1.05 ×) |\n|---|---|---|---|---|\n{}\n",
                    lines.join("\n")
                );
            }
        }
    }
    if !s.skip.is_empty() {
        let _ = writeln!(
            md,
            "## Scene skipping and the closed loop\n\n`<method>`: the skip stream (the analysis's window); \
             `<method>-loop`: the closed loop (the window is the box the stream's own filter predicts, \
             `SkipPolicy::Window`). Coverage: the share of the target pixels (both cameras' masks) inside \
             the window the method's output is kept on.\n\n\
             | sequence | method | target coverage (min) | target coverage (mean) | window share of the frame (mean) |\n|---|---|---|---|---|"
        );
        let all = [("all".to_string(), &s.skip)];
        let rows = all
            .iter()
            .map(|(q, m)| (q.as_str(), *m))
            .chain(s.skip_by_sequence.iter().map(|(q, m)| (q.as_str(), m)));
        for (seq, methods) in rows {
            for (m, k) in methods {
                let _ = writeln!(
                    md,
                    "| {seq} | {m} | {} | {} | {} |",
                    cell(k, "target_coverage_min", 4),
                    cell(k, "target_coverage_mean", 4),
                    cell(k, "window_frac_mean", 4)
                );
            }
        }
        let _ = writeln!(md);
    }
    let guard = fusion_navbench::seeds::skip_guard(s);
    if !guard.is_empty() {
        let _ = writeln!(
            md,
            "## What skipping changes in navigation\n\nEvery figure of every phase (all sequences) of a \
             skipped or closed-loop stream against its whole-frame stream, and of a sequence-mode stream \
             against the same stream fused per frame: a figure *moved* when the means \
             differ by more than the larger spread over the seeds and by more than 1 % of the whole-frame \
             mean (the guard of issue 38).\n\n\
             | stream | against | figures | moved | largest moves (phase.figure: change, allowed) |\n|---|---|---|---|---|"
        );
        for g in &guard {
            let worst: Vec<String> = g
                .moved
                .iter()
                .take(3)
                .map(|m| format!("{}: {:+.4} ({:.4})", m.figure, m.delta, m.allowed))
                .collect();
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} |",
                g.skipped,
                g.unskipped,
                g.figures,
                g.moved.len(),
                if worst.is_empty() { "—".to_string() } else { worst.join("; ") }
            );
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sequence_spec_reads_back_as_written_and_refuses_what_it_cannot_be() {
        for text in ["approach", "flyaround+earth", "radial@10", "approach+earth@172.5", "radial@0"] {
            let spec = SequenceSpec::parse(text).unwrap();
            assert_eq!(spec.label(), text);
            assert_eq!(SequenceSpec::parse(&spec.label()).unwrap(), spec);
        }
        let r = SequenceSpec::parse("radial@10").unwrap();
        assert_eq!(
            (r.name, r.earth, r.sun_phase_deg, r.has_earth()),
            (SequenceName::Radial, false, Some(10.0), true)
        );
        let a = SequenceSpec::parse("approach").unwrap();
        assert!(!a.has_earth() && a.sun_phase_deg.is_none());
        assert!(SequenceSpec::parse("flyaround+earth").unwrap().has_earth());
        for bad in
            ["radial+earth", "orbit", "approach@181", "approach@-1", "approach@ten", "approach@", "+earth"]
        {
            assert!(SequenceSpec::parse(bad).is_err(), "{bad}");
        }
        // The default run: black space, and the Earth behind the target at two sun phase angles.
        let d = SequenceSpec::defaults();
        let earth: Vec<String> = d.iter().filter(|s| s.has_earth()).map(SequenceSpec::label).collect();
        assert_eq!(earth, ["radial", "radial@10"]);
        assert!(d.iter().any(|s| s.name == SequenceName::Approach && !s.has_earth()));
        assert!(d.iter().any(|s| s.name == SequenceName::Flyaround && !s.has_earth()));
    }
}
