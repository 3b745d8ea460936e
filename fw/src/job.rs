//! `job.bin`: what the host asks the image to do (all integers little-endian `u32`).
//!
//! ```text
//! offset  field
//!  0      magic "FWJ1"
//!  4      VIS width, VIS height
//! 12      TIR width, TIR height
//! 20      number of runs n (1..=MAX_RUNS)
//! 24      n × 4 bytes: method (0 ADF, 1 TSIFSD, 2 IFEVIP, 3 adaptive; 4 the thermal AGC;
//!         5 the thermal front end; 6 registration),
//!         variant (0 classic, 1 flight; adaptive: 0 the blend alone, `AdaptiveParams::blend_only`,
//!         1 the default policy; AGC: 0 plateau, 1 linear),
//!         rescale policy (0 TIR up, 1 VIS down, 2 none), flags (bit 0: measure the stages;
//!         bit 1: raise a fault instead, to test that a fault ends the emulation with status 1;
//!         bits 2–3: scene skip level, 0 none, 1 ROI, 2 all; bit 4: fuse in strips
//!         (`fusion_nostd::strips::fuse_strips`, the 512 KiB strip scratch, tallest strips;
//!         not with bits 0 or 2–3); bit 5: thermal front-end runs only, see below;
//!         bit 6: fuse in the job's sequence (`fusion_nostd::sequence`: the runs with this bit
//!         share one `Sequence`, in order, so a run after another of the same ADF parameters
//!         and illumination class takes the previous run's weights — one pass in strips; not
//!         with bit 0); bit 7: the run's own frame pair — run `i` reads `vis<i>.gray` and
//!         `tir<i>.gray` (the job's sizes) instead of the job's pair, so a job can fuse a
//!         sequence of frames (methods 0–3 only))
//! ```
//! An AGC run (method 4) maps `tir16.gray` (the TIR size, `u16` little-endian counts) to 8 bits
//! with `fusion_nostd::agc_frame` (`AgcParams::plateau(pixels)` or `AgcParams::linear()`, a
//! fresh state) in one `agc` region and writes that frame; its policy byte must be 2 and its
//! flags 0 or the fault bit.
//! A thermal front-end run (method 5, variant 1, policy 2, flags 0 or the fault and shutter
//! bits) corrects one frame of a sequence: run `i` reads `raw<i>.gray` (raw counts, the TIR
//! size, `u16` little-endian) and, with the shutter bit (5), first re-levels the offsets from
//! `shutter<i>.gray` (a flat field's raw counts, region `shutter`). The job's first thermal run
//! reads `nuc.bin` (the TIR size of `u16` Q2.14 gains, then of `i16` offsets), `bad.bin` (the
//! one-bit map, `⌈width/8⌉` bytes a row) and `column.bin` (`u32` threshold, radius, smoothing)
//! and starts the column filter afresh; later thermal runs carry the re-levelled offsets and
//! the filter's state on, as a camera's video does. Stage by stage in the regions `nuc`,
//! `bad_pixels`, `column` (`fusion_nostd::thermal`, the filter's temporal estimate) and `agc`
//! (`AgcParams::linear()`, a fresh state each frame); each run writes its 8-bit frame.
//! A registration run (method 6, variant 0 linear or 1 cubic, policy 2, flags 0 or the fault
//! bit) warps `tir.gray` onto the visible grid (`fusion_nostd::registration`): `rig.bin` holds
//! 32 `f32` — per camera (VIS, then TIR) `fx, fy, cx, cy, k1, k2, p1, p2, k3`, then `R`
//! (row-major), `T` and the range in metres — the cameras' sizes are the job's VIS and TIR
//! sizes; the node grid every 16 px in region `rig_map`, the strips (16 rows of map, then the
//! remap; constant 0 outside) in region `register`; it writes the VIS-size frame.
//! Method parameters are the core's defaults for the variant, the scene analysis thresholds
//! `SceneParams::default()` (the host builds the same [`FuseConfig`] for its comparison run).

use fusion_nostd::Variant;
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, SkipPolicy};

/// Most runs in one job.
pub const MAX_RUNS: usize = 128;
/// Longest `job.bin`.
pub const MAX_LEN: usize = 24 + 4 * MAX_RUNS;

/// One run of a job.
#[derive(Clone, Copy)]
pub struct Run {
    method: u8,
    variant: Variant,
    policy: RescalePolicy,
    skip: SkipPolicy,
    /// Measure the stages before the whole pipeline.
    pub stages: bool,
    /// Raise a fault (an undefined instruction) instead of running.
    pub fault: bool,
    /// Fuse strip by strip in the strip scratch.
    pub strips: bool,
    /// A thermal front-end run: re-level the offsets from `shutter<i>.gray` first.
    pub shutter: bool,
    /// Fuse in the job's sequence (carried weights).
    pub sequence: bool,
    /// Fuse the run's own frame pair (`vis<i>.gray`, `tir<i>.gray`).
    pub own_frames: bool,
}

/// A parsed job.
pub struct Job {
    /// VIS width, height.
    pub vis: (usize, usize),
    /// TIR width, height.
    pub tir: (usize, usize),
    runs: [Option<Run>; MAX_RUNS],
    n: usize,
}

fn word(bytes: &[u8], at: usize) -> Result<usize, &'static str> {
    match bytes.get(at..at + 4) {
        Some(&[a, b, c, d]) => Ok(u32::from_le_bytes([a, b, c, d]) as usize),
        _ => Err("job.bin is truncated"),
    }
}

impl Job {
    /// Parses and checks a job.
    pub fn parse(bytes: &[u8]) -> Result<Job, &'static str> {
        if bytes.get(..4) != Some(b"FWJ1".as_slice()) {
            return Err("job.bin: bad magic");
        }
        let vis = (word(bytes, 4)?, word(bytes, 8)?);
        let tir = (word(bytes, 12)?, word(bytes, 16)?);
        let n = word(bytes, 20)?;
        if n == 0 || n > MAX_RUNS {
            return Err("job.bin: bad number of runs");
        }
        let mut runs = [None; MAX_RUNS];
        for (i, slot) in runs.iter_mut().take(n).enumerate() {
            let Some(&[method, variant, policy, flags]) = bytes.get(24 + 4 * i..28 + 4 * i) else {
                return Err("job.bin is truncated");
            };
            let variant = match variant {
                0 => Variant::Classic,
                1 => Variant::Flight,
                _ => return Err("job.bin: bad variant"),
            };
            let policy = match policy {
                0 => RescalePolicy::TirUp,
                1 => RescalePolicy::VisDown,
                2 => RescalePolicy::None,
                _ => return Err("job.bin: bad rescale policy"),
            };
            if method > 6 {
                return Err("job.bin: bad method");
            }
            if method == 6 && (policy != RescalePolicy::None || flags & !2 != 0) {
                return Err("job.bin: a registration run takes policy 2 and no flag but the fault bit");
            }
            if method == 5
                && (policy != RescalePolicy::None || flags & !0x22 != 0 || variant != Variant::Flight)
            {
                return Err(
                    "job.bin: a thermal front-end run takes variant 1, policy 2 and no flag but the fault and shutter bits",
                );
            }
            if method == 4 && (policy != RescalePolicy::None || flags & !2 != 0) {
                return Err("job.bin: an AGC run takes policy 2 and no flag but the fault bit");
            }
            let skip = match (flags >> 2) & 3 {
                0 => SkipPolicy::None,
                1 => SkipPolicy::Roi,
                2 => SkipPolicy::All,
                _ => return Err("job.bin: bad skip level"),
            };
            if (flags & 0x20 != 0 && method != 5) || (flags & 0xc0 != 0 && method > 3) {
                return Err("job.bin: unknown flags");
            }
            let sequence = flags & 0x40 != 0;
            if sequence && flags & 1 != 0 {
                return Err("job.bin: a sequence run cannot be staged");
            }
            if flags & 1 != 0 && skip != SkipPolicy::None {
                return Err("job.bin: a staged run cannot skip");
            }
            let strips = flags & 0x10 != 0;
            if strips && (flags & 1 != 0 || skip != SkipPolicy::None) {
                return Err("job.bin: a strip run cannot be staged or skip");
            }
            *slot = Some(Run {
                method,
                variant,
                policy,
                skip,
                stages: flags & 1 != 0,
                fault: flags & 2 != 0,
                strips,
                shutter: flags & 0x20 != 0,
                sequence,
                own_frames: flags & 0x80 != 0,
            });
        }
        Ok(Job { vis, tir, runs, n })
    }

    /// The runs, in order.
    pub fn runs(&self) -> impl ExactSizeIterator<Item = Run> + '_ {
        self.runs.iter().take(self.n).map(|r| r.unwrap_or(Run::EMPTY))
    }
}

impl Run {
    const EMPTY: Run = Run {
        method: 1,
        variant: Variant::Flight,
        policy: RescalePolicy::None,
        skip: SkipPolicy::None,
        stages: false,
        fault: false,
        strips: false,
        shutter: false,
        sequence: false,
        own_frames: false,
    };

    /// The core configuration of this run.
    pub fn pipeline(&self) -> FuseConfig {
        // `method` numbers the core's `Method::KINDS` (TSIFSD for a number past them).
        let kind = Method::KINDS.get(usize::from(self.method)).copied().unwrap_or("tsifsd");
        let method = Method::for_job(kind, self.variant).unwrap_or_default();
        FuseConfig { rescale: self.policy, method, skip: self.skip, ..Default::default() }
    }

    /// An AGC run: `Some(true)` for the linear stretch, `Some(false)` for plateau equalisation.
    pub fn agc(&self) -> Option<bool> {
        (self.method == 4).then_some(self.variant == Variant::Flight)
    }

    /// A thermal front-end run.
    pub fn thermal(&self) -> bool {
        self.method == 5
    }

    /// A registration run: `Some(true)` cubic, `Some(false)` linear.
    pub fn registration(&self) -> Option<bool> {
        (self.method == 6).then_some(self.variant == Variant::Flight)
    }

    /// Skip level as printed.
    pub fn skip_name(&self) -> &'static str {
        match self.skip {
            SkipPolicy::None => "none",
            SkipPolicy::Roi => "roi",
            SkipPolicy::All => "all",
            SkipPolicy::Window(_) => "window",
        }
    }

    /// Method name as printed.
    pub fn method_name(&self) -> &'static str {
        self.pipeline().method.kind()
    }

    /// Region label of the method's own call in a staged run (`adf.fuse`, …).
    pub fn method_tag(&self) -> &'static str {
        match self.method {
            0 => "adf.fuse",
            2 => "ifevip.fuse",
            3 => "adaptive.fuse",
            _ => "tsifsd.fuse",
        }
    }

    /// Variant name as printed.
    pub fn variant_name(&self) -> &'static str {
        match self.variant {
            Variant::Classic => "classic",
            Variant::Flight => "flight",
        }
    }

    /// Rescale policy as printed.
    pub fn policy_name(&self) -> &'static str {
        match self.policy {
            RescalePolicy::TirUp => "tir-up",
            RescalePolicy::VisDown => "vis-down",
            RescalePolicy::None => "none",
        }
    }
}

/// `out<i>.gray` written into `buf`.
pub fn out_name(i: usize, buf: &mut [u8; 16]) -> &str {
    file_name(b"out", i, buf)
}

/// `<stem><i>.gray` written into `buf` (`shutter127.gray`, the longest a job names, is 15
/// bytes).
pub fn file_name<'a>(stem: &[u8], i: usize, buf: &'a mut [u8; 16]) -> &'a str {
    let mut digits = [0u8; 10];
    let mut n = i;
    let mut k = 0;
    loop {
        if let Some(d) = digits.get_mut(k) {
            *d = b'0' + (n % 10) as u8;
        }
        k += 1;
        n /= 10;
        if n == 0 || k >= digits.len() {
            break;
        }
    }
    let mut len = 0;
    for &b in stem.iter().chain(digits.iter().take(k).rev()).chain(b".gray".iter()) {
        if let Some(slot) = buf.get_mut(len) {
            *slot = b;
            len += 1;
        }
    }
    core::str::from_utf8(buf.get(..len).unwrap_or(&[])).unwrap_or("out.gray")
}
