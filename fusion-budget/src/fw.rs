//! Building the firmware image and the Arm counting plugin, writing a job, running QEMU and
//! reading back what the image reported (protocol: `fw/src/main.rs`, `fw/src/job.rs`).

use super::elf::Elf;
use anyhow::{Context, Result, bail, ensure};
use fusion_engine::methods::{MethodArg, RescaleArg, SkipArg, VariantArg};
use fusion_io::Gray;
use fusion_nostd::registration::{Interpolation, Rig};
use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The emulated flight targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Target {
    /// Cortex-M7, `thumbv7em-none-eabihf`, QEMU `mps2-an500`.
    Arm,
    /// RV32IMAC, `riscv32imac-unknown-none-elf`, QEMU `virt`.
    Riscv,
    /// Cortex-A53 (AArch64 with NEON), `aarch64-unknown-none`, QEMU `virt -cpu cortex-a53`: the
    /// application processor class of on-board vision processing (Zynq UltraScale+ and the like).
    A53,
}

impl Target {
    /// Every target.
    pub const ALL: [Target; 3] = [Target::Arm, Target::Riscv, Target::A53];

    /// Rust target triple.
    pub fn triple(self) -> &'static str {
        match self {
            Target::Arm => "thumbv7em-none-eabihf",
            Target::Riscv => "riscv32imac-unknown-none-elf",
            Target::A53 => "aarch64-unknown-none",
        }
    }

    /// Short name (also the first key of the budget table).
    pub fn name(self) -> &'static str {
        match self {
            Target::Arm => "arm",
            Target::Riscv => "riscv",
            Target::A53 => "a53",
        }
    }

    /// Core the estimate is for, as printed.
    pub fn core(self) -> &'static str {
        match self {
            Target::Arm => "Cortex-M7",
            Target::Riscv => "RV32 in-order",
            Target::A53 => "Cortex-A53",
        }
    }

    /// Stated cycles-per-instruction range used to turn counts into cycle estimates (QEMU has
    /// no timing model): Cortex-M7 dual-issue 1.0–1.3, a simple in-order RV32 about 1.5, the
    /// dual-issue in-order Cortex-A53 1.0–1.5 (its NEON pipe issues one 128-bit operation a
    /// cycle; loads that miss its 32 KiB L1 and the external memory raise the CPI).
    pub fn cpi(self) -> (f64, f64) {
        match self {
            Target::Arm => (1.0, 1.3),
            Target::Riscv => (1.5, 1.5),
            Target::A53 => (1.0, 1.5),
        }
    }

    /// The stated clock of the estimates: 400 MHz for the microcontrollers (a Cortex-M7 at its
    /// usual rating), 1.2 GHz for the Cortex-A53 (Zynq UltraScale+ APU class).
    pub fn clock_hz(self) -> f64 {
        match self {
            Target::Arm | Target::Riscv => 400e6,
            Target::A53 => 1.2e9,
        }
    }

    /// Whether instructions are counted by the TCG plugin between the marker functions (Arm and
    /// AArch64) rather than read by the guest (`minstret` on RV32).
    pub fn counts_with_plugin(self) -> bool {
        matches!(self, Target::Arm | Target::A53)
    }

    /// The QEMU command line before the image (`-kernel` follows).
    fn qemu(self) -> (&'static str, &'static [&'static str]) {
        match self {
            Target::Arm => ("qemu-system-arm", &["-machine", "mps2-an500", "-cpu", "cortex-m7"]),
            Target::Riscv => (
                "qemu-system-riscv32",
                &["-machine", "virt", "-bios", "none", "-m", "64M", "-icount", "shift=0,sleep=off"],
            ),
            Target::A53 => ("qemu-system-aarch64", &["-machine", "virt", "-cpu", "cortex-a53", "-m", "128M"]),
        }
    }

    /// The linker map that defines the target's memory regions.
    pub fn linker_map(self) -> PathBuf {
        match self {
            Target::Arm => fw_dir().join("../memory.x"),
            Target::Riscv => fw_dir().join("riscv-virt.ld"),
            Target::A53 => fw_dir().join("aarch64-virt.ld"),
        }
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which static buffer sizes the image is built with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Grid {
    /// 512² fusion grid (VIS 1024² area-downscaled onto the 512² TIR grid): feature `grid512`.
    G512,
    /// 1024² fusion grid (TIR 512² bicubic-upscaled onto the 1024² VIS grid): the default.
    G1024,
}

impl Grid {
    /// Side of the fusion grid.
    pub fn side(self) -> usize {
        match self {
            Grid::G512 => 512,
            Grid::G1024 => 1024,
        }
    }

    /// How the budget pair (VIS 1024², TIR 512²) reaches this grid.
    pub fn policy(self) -> RescaleArg {
        match self {
            Grid::G512 => RescaleArg::VisDown,
            Grid::G1024 => RescaleArg::TirUp,
        }
    }
}

/// The firmware sources (`fw/` beside this crate).
pub fn fw_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fw")
}

/// Builds the image for `target` and `grid` (release) and copies it to
/// `out/fusion-fw-<target>-<side>.elf` (every feature set writes the same cargo output path).
pub fn build_image(target: Target, grid: Grid, out: &Path) -> Result<PathBuf> {
    let fw = fw_dir();
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cmd.current_dir(&fw)
        .args(["build", "--release", "--quiet", "--target", target.triple(), "--target-dir"])
        .arg(fw.join("target"));
    if grid == Grid::G512 {
        cmd.args(["--features", "grid512"]);
    }
    let status = cmd.status().context("cannot run cargo to build the firmware")?;
    ensure!(status.success(), "firmware build failed for {target} ({}²)", grid.side());
    let built = fw.join("target").join(target.triple()).join("release/fusion-fw");
    let dst = out.join(format!("fusion-fw-{target}-{}.elf", grid.side()));
    fs::copy(&built, &dst).with_context(|| format!("cannot copy {}", built.display()))?;
    Ok(dst)
}

/// Builds the Arm instruction-counting plugin (`fw/plugin/insn_count.c`) with the host C
/// compiler (`$CC`, default `gcc`) into `out/libinsn_count.so`.
pub fn build_plugin(out: &Path) -> Result<PathBuf> {
    let src = fw_dir().join("plugin/insn_count.c");
    let dst = out.join("libinsn_count.so");
    let cc = std::env::var_os("CC").unwrap_or_else(|| "gcc".into());
    let status = Command::new(&cc)
        .args(["-shared", "-fPIC", "-O2", "-Wall", "-Wextra", "-Werror", "-o"])
        .arg(&dst)
        .arg(&src)
        .status()
        .with_context(|| format!("cannot run the C compiler {cc:?} for the QEMU plugin"))?;
    ensure!(status.success(), "building {} failed", src.display());
    Ok(dst)
}

/// The thermal AGC's two mappings, as an AGC run of a job measures them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AgcKind {
    /// `AgcParams::plateau(pixels)`.
    Plateau,
    /// `AgcParams::linear()`.
    Linear,
}

impl AgcKind {
    /// Both, in table order.
    pub const ALL: [AgcKind; 2] = [AgcKind::Plateau, AgcKind::Linear];

    /// Name (the budget key's stage).
    pub fn name(self) -> &'static str {
        match self {
            AgcKind::Plateau => "plateau",
            AgcKind::Linear => "linear",
        }
    }

    /// The core parameters the image uses for a frame of `pixels`.
    pub fn params(self, pixels: usize) -> fusion_nostd::AgcParams {
        match self {
            AgcKind::Plateau => fusion_nostd::AgcParams::plateau(pixels),
            AgcKind::Linear => fusion_nostd::AgcParams::linear(),
        }
    }
}

/// One run of a job: a method on the job's pair (or, with `agc`, the thermal AGC on the job's
/// 16-bit TIR frame; the other fields are then unused).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunSpec {
    /// Fusion method.
    pub method: MethodArg,
    /// Variant.
    pub variant: VariantArg,
    /// Rescale policy.
    pub policy: RescaleArg,
    /// Scene skip level (the scene thresholds are `SceneParams::default()` on both sides).
    pub skip: SkipArg,
    /// Measure the stages too (the staged run repeats the work).
    pub stages: bool,
    /// Make the image raise a fault instead (tests that a fault ends the run with status 1).
    pub fault: bool,
    /// Fuse strip by strip in the image's 512 KiB strip scratch (`fusion_nostd::strips`); the
    /// output must equal the host's whole-frame `fuse`.
    pub strips: bool,
    /// An AGC run instead of a fusion.
    pub agc: Option<AgcKind>,
    /// A thermal front-end run instead of a fusion (`fw/src/job.rs`, method 5): one frame of
    /// the job's raw sequence ([`ThermalInputs`]).
    pub thermal: bool,
    /// A thermal run whose frame comes with a shutter frame (its flag bit 5).
    pub shutter: bool,
    /// A registration run instead of a fusion (`fw/src/job.rs`, method 6): the job's thermal
    /// frame onto its visible grid through [`Job::rig`], with this interpolation.
    pub registration: Option<Interpolation>,
    /// Fuse in the job's sequence (`fusion_nostd::sequence`, flag bit 6): the runs with this
    /// flag share one sequence, in order; on the job's one pair a run after the first takes
    /// the first's weights, which are its own, so the output is the per-frame fusion's.
    pub sequence: bool,
    /// Fuse the run's own frame pair ([`Job::frames`], flag bit 7) instead of the job's.
    pub own_frames: bool,
}

impl RunSpec {
    /// A whole-pipeline run (no stages, no fault, no skipping).
    pub fn plain(method: MethodArg, variant: VariantArg, policy: RescaleArg) -> Self {
        RunSpec {
            method,
            variant,
            policy,
            skip: SkipArg::None,
            stages: false,
            fault: false,
            strips: false,
            agc: None,
            thermal: false,
            shutter: false,
            registration: None,
            sequence: false,
            own_frames: false,
        }
    }

    /// A registration run of the job's thermal frame ([`Job::rig`]).
    pub fn registration(interpolation: Interpolation) -> Self {
        RunSpec {
            registration: Some(interpolation),
            ..RunSpec::plain(MethodArg::Tsifsd, VariantArg::Flight, RescaleArg::None)
        }
    }

    /// A thermal front-end run on the next frame of the job's raw sequence ([`Job::thermal`]),
    /// re-levelled from its shutter frame first with `shutter`.
    pub fn thermal(shutter: bool) -> Self {
        RunSpec {
            thermal: true,
            shutter,
            ..RunSpec::plain(MethodArg::Tsifsd, VariantArg::Flight, RescaleArg::None)
        }
    }

    /// An AGC run on the job's 16-bit TIR frame.
    pub fn agc(kind: AgcKind) -> Self {
        RunSpec {
            agc: Some(kind),
            ..RunSpec::plain(MethodArg::Tsifsd, VariantArg::Classic, RescaleArg::None)
        }
    }

    /// The core configuration the image builds for this run (`fw/src/job.rs`), for the host's
    /// comparison run.
    pub fn pipeline(&self) -> fusion_nostd::pipeline::FuseConfig {
        fusion_nostd::pipeline::FuseConfig {
            rescale: self.policy.into(),
            method: fusion_nostd::pipeline::Method::for_job(
                crate::stages::method_key(self.method),
                self.variant.into(),
            )
            .unwrap_or_default(),
            skip: self.skip.into(),
            scene: fusion_nostd::scene::SceneParams::default(),
        }
    }

    /// The four bytes of this run in `job.bin`.
    pub fn encode(&self) -> [u8; 4] {
        if let Some(kind) = self.agc {
            return [4, u8::from(kind == AgcKind::Linear), 2, u8::from(self.fault) << 1];
        }
        if self.thermal {
            return [5, 1, 2, (u8::from(self.fault) << 1) | (u8::from(self.shutter) << 5)];
        }
        if let Some(i) = self.registration {
            return [6, u8::from(i == Interpolation::Cubic), 2, u8::from(self.fault) << 1];
        }
        let method = match self.method {
            MethodArg::Adf => 0,
            MethodArg::Tsifsd => 1,
            MethodArg::Ifevip => 2,
            MethodArg::Adaptive => 3,
        };
        let variant = match self.variant {
            VariantArg::Classic => 0,
            VariantArg::Flight => 1,
        };
        let policy = match self.policy {
            RescaleArg::TirUp => 0,
            RescaleArg::VisDown => 1,
            RescaleArg::None => 2,
        };
        let skip = match self.skip {
            SkipArg::None => 0u8,
            SkipArg::Roi => 1,
            SkipArg::All => 2,
        };
        let flags = u8::from(self.stages)
            | (u8::from(self.fault) << 1)
            | (skip << 2)
            | (u8::from(self.strips) << 4)
            | (u8::from(self.sequence) << 6)
            | (u8::from(self.own_frames) << 7);
        [method, variant, policy, flags]
    }

    /// The inverse of [`RunSpec::encode`], with the image's checks (`fw/src/job.rs`).
    pub fn decode([method, variant, policy, flags]: [u8; 4]) -> Result<Self> {
        if method == 4 {
            ensure!(
                policy == 2 && flags & !2 == 0,
                "an AGC run takes policy 2 and no flag but the fault bit"
            );
            let kind = match variant {
                0 => AgcKind::Plateau,
                1 => AgcKind::Linear,
                _ => bail!("bad AGC mapping {variant}"),
            };
            return Ok(RunSpec { fault: flags & 2 != 0, ..RunSpec::agc(kind) });
        }
        if method == 5 {
            ensure!(
                variant == 1 && policy == 2 && flags & !0x22 == 0,
                "a thermal front-end run takes variant 1, policy 2 and no flag but the fault and shutter bits"
            );
            return Ok(RunSpec { fault: flags & 2 != 0, ..RunSpec::thermal(flags & 0x20 != 0) });
        }
        if method == 6 {
            ensure!(
                policy == 2 && flags & !2 == 0,
                "a registration run takes policy 2 and no flag but the fault bit"
            );
            let interp = match variant {
                0 => Interpolation::Linear,
                1 => Interpolation::Cubic,
                _ => bail!("bad registration interpolation {variant}"),
            };
            return Ok(RunSpec { fault: flags & 2 != 0, ..RunSpec::registration(interp) });
        }
        let method = match method {
            0 => MethodArg::Adf,
            1 => MethodArg::Tsifsd,
            2 => MethodArg::Ifevip,
            3 => MethodArg::Adaptive,
            _ => bail!("bad method {method}"),
        };
        let variant = match variant {
            0 => VariantArg::Classic,
            1 => VariantArg::Flight,
            _ => bail!("bad variant {variant}"),
        };
        let policy = match policy {
            0 => RescaleArg::TirUp,
            1 => RescaleArg::VisDown,
            2 => RescaleArg::None,
            _ => bail!("bad rescale policy {policy}"),
        };
        let skip = match (flags >> 2) & 3 {
            0 => SkipArg::None,
            1 => SkipArg::Roi,
            2 => SkipArg::All,
            s => bail!("bad skip level {s}"),
        };
        ensure!(flags & 0x20 == 0, "unknown flags {flags:#x}");
        let (stages, fault, strips) = (flags & 1 != 0, flags & 2 != 0, flags & 0x10 != 0);
        let sequence = flags & 0x40 != 0;
        ensure!(!(stages && sequence), "a sequence run cannot be staged");
        ensure!(!(stages && skip != SkipArg::None), "a staged run cannot skip");
        ensure!(!(strips && (stages || skip != SkipArg::None)), "a strip run cannot be staged or skip");
        Ok(RunSpec {
            method,
            variant,
            policy,
            skip,
            stages,
            fault,
            strips,
            agc: None,
            thermal: false,
            shutter: false,
            registration: None,
            sequence,
            own_frames: flags & 0x80 != 0,
        })
    }
}

/// What the image reported about a run's scene skipping (`@fw skip` line).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkipOut {
    /// Skip level as printed (`none`, `roi`, `all`).
    pub level: String,
    /// `Skips` bits taken.
    pub taken: u32,
    /// Why the skip was declined (`-`: it was not).
    pub declined: String,
    /// The window the method ran on: x0, y0, x1, y1.
    pub computed: [usize; 4],
}

/// A job: one VIS/TIR pair and the runs on it.
#[derive(Debug, Clone)]
pub struct Job {
    /// Visible frame.
    pub vis: Gray<u8>,
    /// Thermal frame.
    pub tir: Gray<u8>,
    /// Runs, in order (at most 128).
    pub runs: Vec<RunSpec>,
    /// The frame pairs of the runs with [`RunSpec::own_frames`], in order (the job's sizes),
    /// written as `vis<i>.gray` and `tir<i>.gray` for run `i`.
    pub frames: Vec<(Gray<u8>, Gray<u8>)>,
    /// 16-bit TIR counts of the AGC and thermal runs (the TIR size), written as `tir16.gray`.
    pub tir16: Option<Gray<u16>>,
    /// The thermal front-end runs' raw sequence, tables, map and column parameters.
    pub thermal: Option<ThermalInputs>,
    /// The registration runs' rig (its cameras of the job's sizes) and range, metres, written
    /// as `rig.bin`.
    pub rig: Option<(Rig, f32)>,
}

/// One frame of a thermal sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct ThermalFrame {
    /// Raw counts of the TIR size, written as `raw<i>.gray` for run `i`.
    pub raw: Gray<u16>,
    /// A flat field's raw counts (the TIR size) the shutter took before this frame, written as
    /// `shutter<i>.gray`: the offsets are re-levelled from it first.
    pub shutter: Option<Gray<u16>>,
}

/// What the thermal front-end runs read: a raw sequence, the k-th thermal run of the job
/// correcting `frames[k]` with the state (re-levelled offsets, column estimate) the runs before
/// left, and the calibration, written as `nuc.bin`, `bad.bin` and `column.bin`.
#[derive(Debug, Clone)]
pub struct ThermalInputs {
    /// The frames, in order.
    pub frames: Vec<ThermalFrame>,
    /// NUC tables of the TIR size.
    pub nuc: fusion_io::thermal::NucTables,
    /// Bad-pixel map of the TIR size.
    pub bad: fusion_io::thermal::BadPixels,
    /// Column filter parameters.
    pub column: fusion_nostd::thermal::ColumnParams,
}

impl Job {
    /// The `job.bin` bytes.
    pub fn encode(&self) -> Result<Vec<u8>> {
        ensure!((1..=128).contains(&self.runs.len()), "a job has 1 to 128 runs");
        let sizes = ((self.vis.width, self.vis.height), (self.tir.width, self.tir.height));
        ensure!(
            self.runs.iter().filter(|r| r.own_frames).count() == self.frames.len()
                && self.frames.iter().all(|(v, t)| ((v.width, v.height), (t.width, t.height)) == sizes),
            "runs with their own frames need a frame pair each, of the job's sizes"
        );
        let tir_size = (self.tir.width, self.tir.height);
        ensure!(
            self.runs.iter().all(|r| r.agc.is_none())
                || self.tir16.as_ref().is_some_and(|t| (t.width, t.height) == tir_size),
            "AGC runs need 16-bit TIR counts of the TIR size"
        );
        let thermal: Vec<bool> = self.runs.iter().filter(|r| r.thermal).map(|r| r.shutter).collect();
        ensure!(
            thermal.is_empty()
                || self.thermal.as_ref().is_some_and(|t| {
                    t.frames.iter().map(|f| f.shutter.is_some()).eq(thermal.iter().copied())
                        && t.frames.iter().all(|f| {
                            (f.raw.width, f.raw.height) == tir_size
                                && f.shutter.as_ref().is_none_or(|s| (s.width, s.height) == tir_size)
                        })
                        && (t.nuc.width, t.nuc.height) == tir_size
                        && (t.bad.width, t.bad.height) == tir_size
                }),
            "thermal runs need a raw frame each (with a shutter frame where the run has its bit), NUC tables and a bad-pixel map, of the TIR size"
        );
        ensure!(
            self.runs.iter().all(|r| r.registration.is_none())
                || self.rig.as_ref().is_some_and(|(rig, _)| {
                    (rig.vis.width, rig.vis.height) == (self.vis.width, self.vis.height)
                        && (rig.tir.width, rig.tir.height) == tir_size
                }),
            "registration runs need a rig whose cameras are the job's sizes"
        );
        let mut b = b"FWJ1".to_vec();
        for v in [self.vis.width, self.vis.height, self.tir.width, self.tir.height, self.runs.len()] {
            b.extend_from_slice(&u32::try_from(v)?.to_le_bytes());
        }
        for r in &self.runs {
            b.extend_from_slice(&r.encode());
        }
        Ok(b)
    }
}

/// `rig.bin`: 32 little-endian `f32` — per camera `fx, fy, cx, cy, k1, k2, p1, p2, k3`, then
/// `R` row-major, `T`, the range and a zero (`fw/src/job.rs`).
pub fn rig_bytes(rig: &Rig, range: f32) -> Vec<u8> {
    let cam = |c: &fusion_nostd::registration::Camera| {
        let [k1, k2, p1, p2, k3] = c.dist;
        [c.fx, c.fy, c.cx, c.cy, k1, k2, p1, p2, k3]
    };
    let mut v: Vec<f32> = cam(&rig.vis).into_iter().chain(cam(&rig.tir)).collect();
    v.extend(rig.r.iter().flatten());
    v.extend(rig.t);
    v.extend([range, 0.0]);
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// What one run reported.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOut {
    /// Measured regions in order: label and instruction count.
    pub regions: Vec<(String, u64)>,
    /// Guard bits of the pipeline's report.
    pub guards: u32,
    /// Whether a band was rescaled.
    pub rescaled: bool,
    /// FNV-1a of the fused frame, as computed on the target.
    pub fnv1a: u32,
    /// Fused frame size.
    pub size: (usize, usize),
    /// The fused frame, read back from the file the image wrote.
    pub image: Option<Gray<u8>>,
    /// The scene-skip report (images before the skip level print none).
    pub skip: Option<SkipOut>,
    /// The strip report of a strip run (`@fw strips` line).
    pub strips: Option<fusion_nostd::strips::StripReport>,
    /// How a sequence run was fused (`@fw sequence` line: `carried`, `own-first`, …).
    pub sequence: Option<String>,
}

impl RunOut {
    /// Count of the region with this label.
    pub fn region(&self, label: &str) -> Option<u64> {
        self.regions.iter().find(|(l, _)| l == label).map(|&(_, c)| c)
    }
}

/// Everything one emulator run reported.
#[derive(Debug, Clone, PartialEq)]
pub struct FwReport {
    /// Instructions of an empty region (marker overhead, included in every region count).
    pub overhead: u64,
    /// One entry per run of the job.
    pub runs: Vec<RunOut>,
    /// Stack high-water mark, bytes.
    pub stack_bytes: u64,
    /// Wall time of the emulator process.
    pub wall: Duration,
}

fn parse_hex(s: &str) -> Result<u32> {
    Ok(u32::from_str_radix(s.trim_start_matches("0x"), 16)?)
}

/// Reads the image's console lines (and, on Arm, the plugin's `insn_count` lines, which
/// supply the region counts in the same order).
pub fn parse_report(console: &str, plugin_log: Option<&str>) -> Result<FwReport> {
    let plugin_counts: Option<Vec<u64>> = plugin_log.map(|log| {
        log.lines()
            .filter_map(|l| l.strip_prefix("insn_count "))
            .filter(|l| !l.starts_with("total") && !l.starts_with("error"))
            .filter_map(|l| l.split_whitespace().nth(1)?.parse().ok())
            .collect()
    });
    if let Some(log) = plugin_log
        && let Some(line) = log.lines().find(|l| l.starts_with("insn_count error"))
    {
        bail!("counting plugin: {line}");
    }
    let mut overhead = None;
    let mut runs: Vec<RunOut> = Vec::new();
    let mut stack_bytes = None;
    let mut done = false;
    let mut seq = 0usize;
    for line in console.lines() {
        let Some(rest) = line.strip_prefix("@fw ") else { continue };
        let f: Vec<&str> = rest.split_whitespace().collect();
        match f.as_slice() {
            ["region", n, label, count] => {
                ensure!(n.parse::<usize>()? == seq, "region numbers out of order: {line}");
                let count = match (&plugin_counts, *count) {
                    (Some(pc), "-") => {
                        *pc.get(seq).with_context(|| format!("plugin has no count for {line}"))?
                    }
                    (None, c) => c.parse().with_context(|| format!("no count in {line}"))?,
                    (Some(_), _) => bail!("unexpected count from the guest on Arm: {line}"),
                };
                seq += 1;
                if *label == "overhead" && runs.is_empty() {
                    overhead = Some(count);
                } else {
                    runs.last_mut()
                        .with_context(|| format!("region outside a run: {line}"))?
                        .regions
                        .push((label.to_string(), count));
                }
            }
            ["run", i, _method, _variant, _policy, size] => {
                ensure!(i.parse::<usize>()? == runs.len(), "runs out of order: {line}");
                let (w, h) = size.split_once('x').context("bad run size")?;
                runs.push(RunOut {
                    regions: Vec::new(),
                    guards: 0,
                    rescaled: false,
                    fnv1a: 0,
                    size: (w.parse()?, h.parse()?),
                    image: None,
                    skip: None,
                    strips: None,
                    sequence: None,
                });
            }
            ["result", i, "guards", g, "rescaled", r, "fnv1a", sum, "file", _] => {
                let run = runs.get_mut(i.parse::<usize>()?).context("result for an unknown run")?;
                run.guards = parse_hex(g)?;
                run.rescaled = *r == "1";
                run.fnv1a = parse_hex(sum)?;
            }
            ["skip", i, "level", level, "taken", taken, "declined", declined, "computed", x0, y0, x1, y1] => {
                let run = runs.get_mut(i.parse::<usize>()?).context("skip report for an unknown run")?;
                run.skip = Some(SkipOut {
                    level: level.to_string(),
                    taken: parse_hex(taken)?,
                    declined: declined.to_string(),
                    computed: [x0.parse()?, y0.parse()?, x1.parse()?, y1.parse()?],
                });
            }
            [
                "strips",
                i,
                "count",
                count,
                "rows",
                rows,
                "halo",
                halo,
                "passes",
                passes,
                "method_rows",
                method_rows,
                "band_rows",
                band_rows,
                "work_words",
                words,
                "band_bytes",
                band_bytes,
            ] => {
                let run = runs.get_mut(i.parse::<usize>()?).context("strip report for an unknown run")?;
                run.strips = Some(fusion_nostd::strips::StripReport {
                    strips: count.parse()?,
                    strip_rows: rows.parse()?,
                    halo_rows: halo.parse()?,
                    passes: passes.parse()?,
                    method_rows: method_rows.parse()?,
                    band_rows: band_rows.parse()?,
                    work_words: words.parse()?,
                    band_bytes: band_bytes.parse()?,
                });
            }
            ["sequence", i, "pass", pass] => {
                let run = runs.get_mut(i.parse::<usize>()?).context("sequence line for an unknown run")?;
                run.sequence = Some(pass.to_string());
            }
            ["stack", n] => stack_bytes = Some(n.parse()?),
            ["done", "ok"] => done = true,
            ["error", ..] | ["fault", ..] | ["panic", ..] | ["done", ..] => bail!("firmware: {rest}"),
            _ => {}
        }
    }
    ensure!(done, "the firmware did not finish (no `@fw done ok` line)");
    if let Some(pc) = &plugin_counts {
        ensure!(pc.len() == seq, "plugin counted {} regions, the firmware reported {seq}", pc.len());
    }
    Ok(FwReport {
        overhead: overhead.context("no overhead region")?,
        runs,
        stack_bytes: stack_bytes.context("no stack line")?,
        wall: Duration::ZERO,
    })
}

/// What a finished emulator process left behind.
struct Finished {
    status: std::process::ExitStatus,
    console: String,
    plugin_log: Option<String>,
    wall: Duration,
}

/// Writes `job` into a fresh folder `dir` and runs `image` there under QEMU (console and plugin
/// logs stay there); kills the emulator after `timeout`.
fn emulate(
    target: Target,
    image: &Path,
    plugin: Option<&Path>,
    job: &Job,
    dir: &Path,
    timeout: Duration,
) -> Result<Finished> {
    if dir.exists() {
        fs::remove_dir_all(dir).with_context(|| format!("cannot clear {}", dir.display()))?;
    }
    fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    // The job's three files for the emulator, through the one write path. (The emulator's own
    // console and log files below are its streams, captured where it runs.)
    let mut files = fusion_io::Batch::default();
    files.add_bytes(&dir.join("job.bin"), &job.encode()?)?;
    files.add_bytes(&dir.join("vis.gray"), &job.vis.data)?;
    files.add_bytes(&dir.join("tir.gray"), &job.tir.data)?;
    if let Some(t) = &job.tir16 {
        let bytes: Vec<u8> = t.data.iter().flat_map(|v| v.to_le_bytes()).collect();
        files.add_bytes(&dir.join("tir16.gray"), &bytes)?;
    }
    let own = job.runs.iter().enumerate().filter(|(_, r)| r.own_frames).map(|(i, _)| i);
    for (i, (v, t)) in own.zip(&job.frames) {
        files.add_bytes(&dir.join(format!("vis{i}.gray")), &v.data)?;
        files.add_bytes(&dir.join(format!("tir{i}.gray")), &t.data)?;
    }
    if let Some(t) = &job.thermal {
        let runs = job.runs.iter().enumerate().filter(|(_, r)| r.thermal).map(|(i, _)| i);
        for (i, frame) in runs.zip(&t.frames) {
            for (name, counts) in [("raw", Some(&frame.raw)), ("shutter", frame.shutter.as_ref())] {
                if let Some(counts) = counts {
                    let bytes: Vec<u8> = counts.data.iter().flat_map(|v| v.to_le_bytes()).collect();
                    files.add_bytes(&dir.join(format!("{name}{i}.gray")), &bytes)?;
                }
            }
        }
        // The table file without its 16-byte header: gains, then offsets.
        files.add_bytes(&dir.join("nuc.bin"), t.nuc.to_bytes().get(16..).unwrap_or(&[]))?;
        files.add_bytes(&dir.join("bad.bin"), &t.bad.bits)?;
        let c = &t.column;
        let cfg: Vec<u8> = [u32::from(c.threshold), u32::from(c.radius), u32::from(c.smoothing)]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        files.add_bytes(&dir.join("column.bin"), &cfg)?;
    }
    if let Some((rig, range)) = &job.rig {
        files.add_bytes(&dir.join("rig.bin"), &rig_bytes(rig, *range))?;
    }
    files.commit()?;
    let (qemu, machine) = target.qemu();
    let mut cmd = Command::new(qemu);
    cmd.current_dir(dir)
        .args(machine)
        .args(["-nographic", "-semihosting-config", "enable=on,target=native", "-kernel"])
        .arg(image);
    if target.counts_with_plugin() {
        let plugin = plugin.with_context(|| format!("the {target} run needs the counting plugin"))?;
        let elf = Elf::read(image)?;
        let sym = |n: &str| elf.symbol(n).with_context(|| format!("{n} not found in {}", image.display()));
        let (begin, end) = (sym("fw_region_begin")?, sym("fw_region_end")?);
        cmd.arg("-plugin").arg(format!("{},begin={begin:#x},end={end:#x}", plugin.display())).args([
            "-d",
            "plugin",
            "-D",
            "plugin.log",
        ]);
    }
    let console_path = dir.join("console.txt");
    cmd.stdin(Stdio::null())
        .stdout(fs::File::create(&console_path)?)
        .stderr(fs::File::create(dir.join("stderr.txt"))?);
    let start = Instant::now();
    let mut child = cmd.spawn().with_context(|| format!("cannot start {qemu} (is QEMU installed?)"))?;
    let status = loop {
        if let Some(s) = child.try_wait()? {
            break s;
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            bail!("{qemu} timed out after {} s (logs in {})", timeout.as_secs(), dir.display());
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let wall = start.elapsed();
    let console = fs::read_to_string(&console_path)?;
    let plugin_log =
        target.counts_with_plugin().then(|| fs::read_to_string(dir.join("plugin.log")).unwrap_or_default());
    Ok(Finished { status, console, plugin_log, wall })
}

/// Runs `job` on `image` in a fresh folder `dir` (inputs, outputs, console and plugin logs stay
/// there) and reads back the report and the fused frames. `plugin` is required on Arm. The
/// emulator is killed after `timeout`.
pub fn run_job(
    target: Target,
    image: &Path,
    plugin: Option<&Path>,
    job: &Job,
    dir: &Path,
    timeout: Duration,
) -> Result<FwReport> {
    let done = emulate(target, image, plugin, job, dir, timeout)?;
    let mut report = parse_report(&done.console, done.plugin_log.as_deref())
        .with_context(|| format!("{target} run in {}", dir.display()))?;
    ensure!(done.status.success(), "QEMU exited with {} (logs in {})", done.status, dir.display());
    ensure!(
        report.runs.len() == job.runs.len(),
        "the firmware reported {} of {} runs",
        report.runs.len(),
        job.runs.len()
    );
    for (i, run) in report.runs.iter_mut().enumerate() {
        let data = fs::read(dir.join(format!("out{i}.gray")))?;
        let (w, h) = run.size;
        ensure!(data.len() == w * h, "out{i}.gray has {} bytes, expected {}", data.len(), w * h);
        run.image = Some(Gray { width: w, height: h, data });
    }
    report.wall = done.wall;
    Ok(report)
}

/// Runs a job whose first run raises a fault and checks that the image reported it and QEMU
/// exited with a failure status (the contract for faults and panics on the flight targets).
pub fn check_fault_exit(
    target: Target,
    image: &Path,
    plugin: Option<&Path>,
    dir: &Path,
    timeout: Duration,
) -> Result<()> {
    let spec =
        RunSpec { fault: true, ..RunSpec::plain(MethodArg::Tsifsd, VariantArg::Flight, RescaleArg::None) };
    let job = Job {
        vis: Gray::new(8, 8),
        tir: Gray::new(8, 8),
        runs: vec![spec],
        tir16: None,
        frames: Vec::new(),
        thermal: None,
        rig: None,
    };
    let done = emulate(target, image, plugin, &job, dir, timeout)?;
    ensure!(
        !done.status.success(),
        "{target}: a fault ended the emulation with status 0 (logs in {})",
        dir.display()
    );
    ensure!(
        done.console.lines().any(|l| l.starts_with("@fw fault ")),
        "{target}: the fault handler did not report (logs in {})",
        dir.display()
    );
    ensure!(
        parse_report(&done.console, done.plugin_log.as_deref()).is_err(),
        "a fault must not parse as a finished run"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const CONSOLE: &str = "noise from the serial port\n\
        @fw start arm grid1024\n\
        @fw job 4x4 2x2 runs 1\n\
        @fw region 0 overhead -\n\
        @fw run 0 tsifsd flight tir-up 4x4\n\
        @fw region 1 rescale -\n\
        @fw region 2 pipeline -\n\
        @fw result 0 guards 0x88 rescaled 1 fnv1a 61d855a2 file out0.gray\n\
        @fw stack 11968\n\
        @fw done ok\n";

    #[test]
    fn merges_plugin_counts_in_order() -> Result<()> {
        let log = "insn_count 0 8\ninsn_count 1 100\ninsn_count 2 250\ninsn_count total 999 regions 3 open 0 errors 0\n";
        let r = parse_report(CONSOLE, Some(log))?;
        assert_eq!(r.overhead, 8);
        assert_eq!(r.runs.len(), 1);
        assert_eq!(r.runs[0].regions, vec![("rescale".to_string(), 100), ("pipeline".to_string(), 250)]);
        assert_eq!((r.runs[0].guards, r.runs[0].rescaled, r.runs[0].fnv1a), (0x88, true, 0x61d8_55a2));
        assert_eq!(r.runs[0].region("pipeline"), Some(250));
        assert_eq!(r.stack_bytes, 11968);
        Ok(())
    }

    #[test]
    fn guest_counts_on_riscv() -> Result<()> {
        let c = CONSOLE
            .replace("overhead -", "overhead 16")
            .replace("rescale -", "rescale 7")
            .replace("pipeline -", "pipeline 9");
        let r = parse_report(&c, None)?;
        assert_eq!((r.overhead, r.runs[0].regions[1].1), (16, 9));
        Ok(())
    }

    #[test]
    fn failures_are_errors() {
        // Plugin and firmware disagree on the number of regions.
        assert!(parse_report(CONSOLE, Some("insn_count 0 8\ninsn_count 1 100\n")).is_err());
        // A fault line, or no final `done ok`.
        let fault = CONSOLE.replace("@fw done ok", "@fw fault HardFault pc 0x00001234 cause 0x0");
        assert!(parse_report(&fault, Some("insn_count 0 8\ninsn_count 1 1\ninsn_count 2 2\n")).is_err());
        let cut = CONSOLE.replace("@fw done ok\n", "");
        assert!(parse_report(&cut, Some("insn_count 0 8\ninsn_count 1 1\ninsn_count 2 2\n")).is_err());
        // A count missing on RISC-V.
        assert!(parse_report(CONSOLE, None).is_err());
    }

    #[test]
    fn job_encoding_matches_the_firmware_layout() -> Result<()> {
        let job = Job {
            vis: Gray::new(6, 4),
            tir: Gray::new(3, 2),
            runs: vec![RunSpec {
                method: MethodArg::Ifevip,
                variant: VariantArg::Classic,
                policy: RescaleArg::VisDown,
                skip: SkipArg::None,
                stages: true,
                fault: true,
                strips: false,
                agc: None,
                thermal: false,
                shutter: false,
                registration: None,
                sequence: false,
                own_frames: false,
            }],
            tir16: None,
            frames: Vec::new(),
            thermal: None,
            rig: None,
        };
        let b = job.encode()?;
        assert_eq!(&b[..4], b"FWJ1");
        assert_eq!(b.len(), 24 + 4);
        assert_eq!(&b[4..8], &6u32.to_le_bytes());
        assert_eq!(&b[16..20], &2u32.to_le_bytes());
        assert_eq!(&b[20..24], &1u32.to_le_bytes());
        assert_eq!(&b[24..], &[2, 0, 1, 3]);
        // A strip run in the job's sequence: flag bits 4 and 6, and back.
        let seq = RunSpec {
            strips: true,
            sequence: true,
            ..RunSpec::plain(MethodArg::Adf, VariantArg::Flight, RescaleArg::TirUp)
        };
        assert_eq!(seq.encode(), [0, 1, 0, 0x50]);
        assert_eq!(RunSpec::decode(seq.encode())?, seq);
        assert!(RunSpec::decode([0, 1, 0, 0x41]).is_err(), "a staged sequence run");
        // A run with its own frame pair (bit 7): the job carries one pair per such run.
        let own = RunSpec { own_frames: true, ..seq };
        assert_eq!(own.encode(), [0, 1, 0, 0xd0]);
        assert_eq!(RunSpec::decode(own.encode())?, own);
        let pair = (Gray::new(6, 4), Gray::new(3, 2));
        let framed = Job { runs: vec![own, own], frames: vec![pair.clone(), pair.clone()], ..job.clone() };
        assert!(framed.encode().is_ok());
        assert!(Job { frames: vec![pair], ..framed.clone() }.encode().is_err(), "a run without its pair");
        let wrong = (Gray::new(4, 4), Gray::new(3, 2));
        assert!(
            Job { frames: vec![wrong.clone(), wrong], ..framed }.encode().is_err(),
            "a pair of another size"
        );
        let empty = Job { runs: Vec::new(), ..job.clone() };
        assert!(empty.encode().is_err());
        // AGC runs: method 4, the mapping in the variant byte, policy 2; they need the counts.
        for (kind, byte) in [(AgcKind::Plateau, 0), (AgcKind::Linear, 1)] {
            let spec = RunSpec::agc(kind);
            assert_eq!(spec.encode(), [4, byte, 2, 0]);
            assert_eq!(RunSpec::decode(spec.encode())?, spec);
            let fault = RunSpec { fault: true, ..spec };
            assert_eq!(RunSpec::decode(fault.encode())?, fault);
        }
        assert!(RunSpec::decode([4, 0, 0, 0]).is_err());
        assert!(RunSpec::decode([4, 0, 2, 1]).is_err());
        let agc = Job { runs: vec![RunSpec::agc(AgcKind::Linear)], ..job.clone() };
        assert!(agc.encode().is_err(), "no counts");
        let agc = Job { tir16: Some(Gray::new(3, 2)), ..agc };
        assert_eq!(&agc.encode()?[24..], &[4, 1, 2, 0]);
        // The thermal front end: method 5, variant 1, policy 2, the shutter bit 5; a frame of
        // the TIR size per thermal run, a shutter frame where its run has the bit.
        let spec = RunSpec::thermal(false);
        assert_eq!(spec.encode(), [5, 1, 2, 0]);
        assert_eq!(RunSpec::thermal(true).encode(), [5, 1, 2, 0x20]);
        for s in [spec, RunSpec::thermal(true), RunSpec { fault: true, ..RunSpec::thermal(true) }] {
            assert_eq!(RunSpec::decode(s.encode())?, s);
        }
        for bad in [[5, 0, 2, 0], [5, 1, 0, 0], [5, 1, 2, 1], [5, 1, 2, 0x40], [7, 1, 2, 0], [1, 1, 2, 0x20]]
        {
            assert!(RunSpec::decode(bad).is_err(), "{bad:?}");
        }
        let thermal = Job { runs: vec![spec, RunSpec::thermal(true)], ..job.clone() };
        assert!(thermal.encode().is_err(), "no inputs");
        let (w, h) = (job.tir.width, job.tir.height);
        let frame =
            |shutter: bool| ThermalFrame { raw: Gray::new(w, h), shutter: shutter.then(|| Gray::new(w, h)) };
        let inputs = ThermalInputs {
            frames: vec![frame(false), frame(true)],
            nuc: fusion_io::thermal::NucTables {
                width: w,
                height: h,
                gain: vec![0; w * h],
                offset: vec![0; w * h],
            },
            bad: fusion_io::thermal::BadPixels::from_mask(w, h, &vec![false; w * h]),
            column: fusion_nostd::thermal::ColumnParams { threshold: 9, radius: 4, smoothing: 0 },
        };
        let wrong = ThermalInputs {
            frames: vec![frame(false), ThermalFrame { raw: Gray::new(w + 1, h), shutter: None }],
            ..inputs.clone()
        };
        assert!(Job { thermal: Some(wrong), ..thermal.clone() }.encode().is_err(), "raw of another size");
        let unmatched = ThermalInputs { frames: vec![frame(false), frame(false)], ..inputs.clone() };
        assert!(
            Job { thermal: Some(unmatched), ..thermal.clone() }.encode().is_err(),
            "a shutter run without its frame"
        );
        let short = ThermalInputs { frames: vec![frame(false)], ..inputs.clone() };
        assert!(Job { thermal: Some(short), ..thermal.clone() }.encode().is_err(), "a run without its frame");
        // Registration: method 6, variant 0 linear / 1 cubic, policy 2; a rig of the job's sizes.
        for (i, v) in [(Interpolation::Linear, 0u8), (Interpolation::Cubic, 1)] {
            let spec = RunSpec::registration(i);
            assert_eq!(spec.encode(), [6, v, 2, 0]);
            assert_eq!(RunSpec::decode(spec.encode())?, spec);
        }
        assert!(RunSpec::decode([6, 2, 2, 0]).is_err() && RunSpec::decode([6, 0, 1, 0]).is_err());
        let reg = Job { runs: vec![RunSpec::registration(Interpolation::Linear)], ..job.clone() };
        assert!(reg.encode().is_err(), "no rig");
        let mut rig = render_host::rig::offset_rig()?;
        (rig.vis.width, rig.vis.height, rig.tir.width, rig.tir.height) =
            (job.vis.width, job.vis.height, w, h);
        assert!(Job { rig: Some((rig, 8.0)), ..reg }.encode().is_ok());
        let bytes = rig_bytes(&rig, 8.0);
        assert_eq!(bytes.len(), 128);
        assert_eq!(f32::from_le_bytes(bytes[120..124].try_into()?), 8.0);
        assert_eq!(&Job { thermal: Some(inputs), ..thermal }.encode()?[24..], &[5, 1, 2, 0, 5, 1, 2, 0x20]);
        Ok(())
    }
}
