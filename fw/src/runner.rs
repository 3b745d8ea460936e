//! The job runner: reads `job.bin` and the frames, runs the pipeline (and, per run, its stages
//! in measured regions), writes the fused frames; or, without a job, a small self-test.

use crate::semihosting;
use crate::{AGC, Meter, OUT, SCRATCH, STRIP_SCRATCH, TIR, TIR16, VIS, fnv1a, job, say, sizes};
use core::fmt::Write;
use fusion_nostd::methods::adf::{Band, diffuse_pair};
use fusion_nostd::methods::ifevip::background;
use fusion_nostd::sequence::{Pass, Restart};
use fusion_nostd::stages::{adaptive_decision, fuse_method_decided};
use fusion_nostd::{
    AgcParams, Decline, Filter, FrameMut, FrameRef, FuseConfig, FuseReport, Guards, Method, RescalePolicy,
    ScratchMut, Sequence, agc_frame, fuse, fuse_in_sequence, fuse_strips, fuse_strips_in_sequence,
    fusion_grid, rescale,
};

/// What can stop a job.
pub enum FwError {
    /// A semihosting file operation on the named file failed.
    Io(semihosting::IoError, &'static str),
    /// The core returned an error.
    Core(fusion_nostd::Error),
    /// `job.bin` is malformed or does not fit the image.
    Job(&'static str),
    /// The staged run and the pipeline entry gave different frames.
    StagedMismatch,
}

impl core::fmt::Display for FwError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FwError::Io(e, file) => write!(f, "semihosting {e:?} on {file}"),
            FwError::Core(e) => write!(f, "core error: {e}"),
            FwError::Job(msg) => write!(f, "job: {msg}"),
            FwError::StagedMismatch => write!(f, "the staged run and the pipeline differ"),
        }
    }
}

impl From<fusion_nostd::Error> for FwError {
    fn from(e: fusion_nostd::Error) -> Self {
        FwError::Core(e)
    }
}

/// The staged run: the rescale and the method's public stage functions in measured regions,
/// then the method itself (which repeats the stages: the host subtracts them to get the
/// remainder). Writes the fused frame to `out`.
fn staged(
    m: &mut Meter,
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: &mut [u8],
    scratch: &mut ScratchMut<'_>,
    pipeline: &FuseConfig,
    tag: &str,
) -> Result<Guards, FwError> {
    let (w, h) = fusion_grid(vis.size(), tir.size(), pipeline.rescale)?;
    let n = w * h;
    let same = vis.size() == tir.size();
    let (band, mut planes) = scratch.split_band(if same { 0 } else { n })?;
    let out = FrameMut::new(out, w, h)?;
    if !same {
        let (src, filter) = match pipeline.rescale {
            RescalePolicy::TirUp => (tir, Filter::Cubic),
            RescalePolicy::VisDown | RescalePolicy::None => (vis, Filter::Area),
        };
        let dst = FrameMut::new(&mut *band, w, h)?;
        m.region("rescale", || rescale(src, dst, filter))?;
    }
    let band = FrameRef::new(band, w, h);
    let (vg, tg) = match (same, pipeline.rescale) {
        (true, _) => (vis, tir),
        (false, RescalePolicy::TirUp) => (vis, band?),
        (false, _) => (band?, tir),
    };
    match &pipeline.method {
        Method::Adf(p) => {
            let [a, _, work] = planes.planes(n)?;
            let (vb, tb) = (Band::Frame(vg), Band::Frame(tg));
            m.region("adf.diffuse", || diffuse_pair(vb, tb, (w, h), p, a, work))?;
        }
        // TSIFSD's flight kernel is one pass (window sums of IR − VIS, Scharr saliency, weights
        // and reconstruction together): no public stage to measure apart.
        Method::Tsifsd(_) => {}
        Method::Ifevip(p) => {
            m.region("ifevip.background", || background(tg, p, &mut planes))?;
        }
        Method::Adaptive(_) => {}
    }
    // The adaptive method decides on the input frames (the scene analysis), as the pipeline;
    // its region holds that analysis and the blend.
    let method = &pipeline.method;
    let guards = m.region(tag, || {
        let decision = adaptive_decision(vis, tir, pipeline)?;
        fuse_method_decided(vg, tg, out, method, &mut planes, decision)
    })?;
    Ok(guards)
}

pub fn run_job(m: &mut Meter) -> Result<(), FwError> {
    // SAFETY: single-threaded; these are the only references to the buffers.
    let (vis_buf, tir_buf, out_buf, scratch, strip_scratch) = unsafe {
        (
            &mut *core::ptr::addr_of_mut!(VIS),
            &mut *core::ptr::addr_of_mut!(TIR),
            &mut *core::ptr::addr_of_mut!(OUT),
            &mut *core::ptr::addr_of_mut!(SCRATCH),
            &mut *core::ptr::addr_of_mut!(STRIP_SCRATCH),
        )
    };
    let mut raw = [0u8; job::MAX_LEN];
    let len = semihosting::read_file("job.bin", &mut raw).map_err(|e| FwError::Io(e, "job.bin"))?;
    let job = job::Job::parse(raw.get(..len).unwrap_or(&[])).map_err(FwError::Job)?;
    let (vw, vh) = job.vis;
    let (tw, th) = job.tir;
    let vis_px = vw.checked_mul(vh).filter(|&n| n <= sizes::VIS).ok_or(FwError::Job("VIS too large"))?;
    let tir_px = tw.checked_mul(th).filter(|&n| n <= sizes::TIR).ok_or(FwError::Job("TIR too large"))?;
    let vis_slice = vis_buf.get_mut(..vis_px).ok_or(FwError::Job("VIS too large"))?;
    let tir_slice = tir_buf.get_mut(..tir_px).ok_or(FwError::Job("TIR too large"))?;
    if semihosting::read_file("vis.gray", vis_slice).map_err(|e| FwError::Io(e, "vis.gray"))? != vis_px {
        return Err(FwError::Job("vis.gray has the wrong length"));
    }
    if semihosting::read_file("tir.gray", tir_slice).map_err(|e| FwError::Io(e, "tir.gray"))? != tir_px {
        return Err(FwError::Job("tir.gray has the wrong length"));
    }
    // The 16-bit counts, read only when a run needs them.
    // SAFETY: single-threaded; the only references to these statics.
    let (tir16_buf, agc) =
        unsafe { (&mut *core::ptr::addr_of_mut!(TIR16), &mut *core::ptr::addr_of_mut!(AGC)) };
    let counts = tir16_buf.get_mut(..tir_px).ok_or(FwError::Job("TIR too large"))?;
    if job.runs().any(|r| r.agc().is_some()) {
        // SAFETY: a `u16` slice viewed as its bytes (alignment 1 ≤ 2, length doubled); both
        // targets are little-endian, the file's byte order.
        let bytes =
            unsafe { core::slice::from_raw_parts_mut(counts.as_mut_ptr().cast::<u8>(), counts.len() * 2) };
        if semihosting::read_file("tir16.gray", bytes).map_err(|e| FwError::Io(e, "tir16.gray"))?
            != 2 * tir_px
        {
            return Err(FwError::Job("tir16.gray has the wrong length"));
        }
    }
    let counts = FrameRef::new(&counts[..], tw, th)?;
    say!(m.con, "@fw job {}x{} {}x{} runs {}", vw, vh, tw, th, job.runs().len());
    m.region("overhead", || core::hint::black_box(()));

    let mut thermal_started = false;
    // The job's one sequence (the runs with the sequence bit, in order).
    let mut sequence = Sequence::default();
    for (i, run) in job.runs().enumerate() {
        if run.own_frames {
            // A frame of a sequence: this run's own pair.
            let mut name = [0u8; 16];
            let file = job::file_name(b"vis", i, &mut name);
            if semihosting::read_file(file, vis_slice).map_err(|e| FwError::Io(e, "vis<i>.gray"))? != vis_px {
                return Err(FwError::Job("vis<i>.gray has the wrong length"));
            }
            let file = job::file_name(b"tir", i, &mut name);
            if semihosting::read_file(file, tir_slice).map_err(|e| FwError::Io(e, "tir<i>.gray"))? != tir_px {
                return Err(FwError::Job("tir<i>.gray has the wrong length"));
            }
        }
        let vis = FrameRef::new(&vis_slice[..], vw, vh)?;
        let tir = FrameRef::new(&tir_slice[..], tw, th)?;
        if run.thermal() {
            let out = out_buf.get_mut(..tir_px).ok_or(FwError::Job("output too large for the image"))?;
            say!(m.con, "@fw run {} thermal chain none {}x{}", i, tw, th);
            if run.fault {
                crate::arch::undefined_instruction();
            }
            thermal_run(m, i, (tw, th), (!thermal_started, run.shutter), agc, out)?;
            thermal_started = true;
            let sum = fnv1a(out);
            let mut file_name = [0u8; 16];
            let file = job::out_name(i, &mut file_name);
            semihosting::write_file(file, out).map_err(|e| FwError::Io(e, "out<i>.gray"))?;
            say!(m.con, "@fw result {} guards 0x00 rescaled 0 fnv1a {:08x} file {}", i, sum, file);
            continue;
        }
        if let Some(cubic) = run.registration() {
            let (vw, vh) = job.vis;
            let out = out_buf.get_mut(..vw * vh).ok_or(FwError::Job("output too large for the image"))?;
            say!(
                m.con,
                "@fw run {} register {} none {}x{}",
                i,
                if cubic { "cubic" } else { "linear" },
                vw,
                vh
            );
            if run.fault {
                crate::arch::undefined_instruction();
            }
            registration_run(m, (vw, vh), tir, cubic, out)?;
            let sum = fnv1a(out);
            let mut file_name = [0u8; 16];
            let file = job::out_name(i, &mut file_name);
            semihosting::write_file(file, out).map_err(|e| FwError::Io(e, "out<i>.gray"))?;
            say!(m.con, "@fw result {} guards 0x00 rescaled 0 fnv1a {:08x} file {}", i, sum, file);
            continue;
        }
        if let Some(linear) = run.agc() {
            let out = out_buf.get_mut(..tir_px).ok_or(FwError::Job("output too large for the image"))?;
            let name = if linear { "linear" } else { "plateau" };
            say!(m.con, "@fw run {} agc {} none {}x{}", i, name, tw, th);
            if run.fault {
                crate::arch::undefined_instruction();
            }
            let params = if linear { AgcParams::linear() } else { AgcParams::plateau(tir_px) };
            agc.reset();
            let out_frame = FrameMut::new(&mut *out, tw, th)?;
            m.region("agc", || agc_frame(agc, counts, out_frame, &params))?;
            let sum = fnv1a(out);
            let mut file_name = [0u8; 16];
            let file = job::out_name(i, &mut file_name);
            semihosting::write_file(file, out).map_err(|e| FwError::Io(e, "out<i>.gray"))?;
            say!(m.con, "@fw result {} guards 0x00 rescaled 0 fnv1a {:08x} file {}", i, sum, file);
            continue;
        }
        let pipeline = run.pipeline();
        let (w, h) = fusion_grid(vis.size(), tir.size(), pipeline.rescale)?;
        let out = out_buf.get_mut(..w * h).ok_or(FwError::Job("output too large for the image"))?;
        say!(
            m.con,
            "@fw run {} {} {} {} {}x{}",
            i,
            run.method_name(),
            run.variant_name(),
            run.policy_name(),
            w,
            h
        );
        if run.fault {
            crate::arch::undefined_instruction();
        }
        let mut staged_sum = None;
        if run.stages {
            let tag = run.method_tag();
            staged(m, vis, tir, out, &mut scratch.view_mut(), &pipeline, tag)?;
            staged_sum = Some(fnv1a(out));
            out.fill(0);
        }
        let report: FuseReport = if run.strips {
            let out_frame = FrameMut::new(&mut *out, w, h)?;
            let mut sv = strip_scratch.view_mut();
            let (report, s) = if run.sequence {
                m.region("pipeline", || {
                    fuse_strips_in_sequence(
                        vis,
                        tir,
                        out_frame,
                        &mut sv,
                        &pipeline,
                        usize::MAX,
                        &mut sequence,
                    )
                })?
            } else {
                m.region("pipeline", || fuse_strips(vis, tir, out_frame, &mut sv, &pipeline, usize::MAX))?
            };
            say!(
                m.con,
                "@fw strips {} count {} rows {} halo {} passes {} method_rows {} band_rows {} work_words {} band_bytes {}",
                i,
                s.strips,
                s.strip_rows,
                s.halo_rows,
                s.passes,
                s.method_rows,
                s.band_rows,
                s.work_words,
                s.band_bytes
            );
            report
        } else {
            let out_frame = FrameMut::new(&mut *out, w, h)?;
            let mut sv = scratch.view_mut();
            if run.sequence {
                m.region("pipeline", || {
                    fuse_in_sequence(vis, tir, out_frame, &mut sv, &pipeline, &mut sequence)
                })?
            } else {
                m.region("pipeline", || fuse(vis, tir, out_frame, &mut sv, &pipeline))?
            }
        };
        if run.sequence {
            let pass = match sequence.last_step().map(|s| s.pass) {
                Some(Pass::Carried) => "carried",
                Some(Pass::Own(Restart::First)) => "own-first",
                Some(Pass::Own(Restart::Illumination)) => "own-illumination",
                Some(Pass::Own(Restart::Size)) => "own-size",
                Some(Pass::Own(Restart::Method)) => "own-method",
                Some(Pass::PerFrame) | None => "per-frame",
            };
            say!(m.con, "@fw sequence {} pass {}", i, pass);
        }
        let sum = fnv1a(out);
        if staged_sum.is_some_and(|s| s != sum) {
            return Err(FwError::StagedMismatch);
        }
        let mut name = [0u8; 16];
        let file = job::out_name(i, &mut name);
        semihosting::write_file(file, out).map_err(|e| FwError::Io(e, "out<i>.gray"))?;
        say!(
            m.con,
            "@fw result {} guards 0x{:02x} rescaled {} fnv1a {:08x} file {}",
            i,
            report.guards.0,
            u8::from(report.rescaled),
            sum,
            file
        );
        let skip = &report.skip;
        let c = skip.computed;
        say!(
            m.con,
            "@fw skip {} level {} taken 0x{:02x} declined {} computed {} {} {} {}",
            i,
            run.skip_name(),
            skip.taken.0,
            decline_name(skip.declined),
            c.x0,
            c.y0,
            c.x1,
            c.y1
        );
    }
    Ok(())
}

/// How a declined skip is printed (`-`: not declined).
fn decline_name(d: Option<Decline>) -> &'static str {
    match d {
        None => "-",
        Some(Decline::BackgroundNotDark) => "BackgroundNotDark",
        Some(Decline::TooNoisy) => "TooNoisy",
        Some(Decline::RoiTooLarge) => "RoiTooLarge",
        Some(Decline::GlobalStatistic) => "GlobalStatistic",
    }
}

/// No `job.bin`: fuse a small synthetic pair (256² VIS, 128² TIR upscaled) with every method
/// and print the checksums, so a bare `qemu … -kernel fusion-fw` run checks the image works.
pub fn self_test(m: &mut Meter) -> Result<(), FwError> {
    // SAFETY: single-threaded; these are the only references to the buffers.
    let (vis_buf, tir_buf, out_buf, scratch) = unsafe {
        (
            &mut *core::ptr::addr_of_mut!(VIS),
            &mut *core::ptr::addr_of_mut!(TIR),
            &mut *core::ptr::addr_of_mut!(OUT),
            &mut *core::ptr::addr_of_mut!(SCRATCH),
        )
    };
    let (vis_px, tir_px, out_px) = (256 * 256, 128 * 128, 256 * 256);
    let (Some(vis), Some(tir), Some(out)) =
        (vis_buf.get_mut(..vis_px), tir_buf.get_mut(..tir_px), out_buf.get_mut(..out_px))
    else {
        return Err(FwError::Job("self-test frames do not fit"));
    };
    for (i, p) in vis.iter_mut().enumerate() {
        let (x, y) = (i % 256, i / 256);
        *p = if (64..192).contains(&x) && (96..160).contains(&y) { (x + y) as u8 } else { 3 };
    }
    for (i, p) in tir.iter_mut().enumerate() {
        *p = (i.wrapping_mul(2_654_435_761) >> 13) as u8 / 4 + 60;
    }
    let (vis, tir) = (FrameRef::new(&vis[..], 256, 256)?, FrameRef::new(&tir[..], 128, 128)?);
    for method in Method::defaults() {
        let pipeline = FuseConfig { rescale: RescalePolicy::TirUp, method, ..Default::default() };
        let report = fuse(vis, tir, FrameMut::new(&mut *out, 256, 256)?, &mut scratch.view_mut(), &pipeline)?;
        say!(
            m.con,
            "@fw selftest {} guards 0x{:02x} fnv1a {:08x}",
            method.kind(),
            report.guards.0,
            fnv1a(out)
        );
    }
    Ok(())
}

/// A registration run (`job.rs`): the rig of `rig.bin` at its range, the node grid in region
/// `rig_map`, then the thermal frame onto the visible grid strip by strip in region `register`.
#[cfg(not(feature = "rescale-only"))]
// Not inlined: inlined into `run_job`, the registration's counts followed that function's other
// code (adding the own-frame reads moved the Cortex-A53 cubic remap from 161 to 198 instructions
// per pixel); kept apart they measure the core alone.
#[inline(never)]
fn registration_run(
    m: &mut Meter,
    (vw, vh): (usize, usize),
    tir: FrameRef<'_, u8>,
    cubic: bool,
    out: &mut [u8],
) -> Result<(), FwError> {
    use crate::registration_buffers as rb;
    use fusion_nostd::registration::{Border, Camera, Interpolation, NODE_STEP, Rig, RigMap, register};
    let mut bytes = [0u8; 128];
    if semihosting::read_file("rig.bin", &mut bytes).map_err(|e| FwError::Io(e, "rig.bin"))? != 128 {
        return Err(FwError::Job("rig.bin has the wrong length"));
    }
    let mut v = [0.0f32; 32];
    for (o, w) in v.iter_mut().zip(bytes.chunks_exact(4)) {
        if let [a, b, c, d] = *w {
            *o = f32::from_le_bytes([a, b, c, d]);
        }
    }
    let camera = |k: usize, (width, height): (usize, usize)| Camera {
        fx: v.get(k).copied().unwrap_or(0.0),
        fy: v.get(k + 1).copied().unwrap_or(0.0),
        cx: v.get(k + 2).copied().unwrap_or(0.0),
        cy: v.get(k + 3).copied().unwrap_or(0.0),
        dist: [4, 5, 6, 7, 8].map(|j| v.get(k + j).copied().unwrap_or(0.0)),
        width,
        height,
    };
    let at = |k: usize| v.get(k).copied().unwrap_or(0.0);
    let rig = Rig {
        vis: camera(0, (vw, vh)),
        tir: camera(9, tir.size()),
        r: [[at(18), at(19), at(20)], [at(21), at(22), at(23)], [at(24), at(25), at(26)]],
        t: [at(27), at(28), at(29)],
    };
    let range = at(30);
    // SAFETY: single-threaded; the only references to these statics.
    let (nodes, xy, frac) = unsafe {
        (
            &mut *core::ptr::addr_of_mut!(rb::NODE_GRID),
            &mut *core::ptr::addr_of_mut!(rb::XY),
            &mut *core::ptr::addr_of_mut!(rb::FRAC),
        )
    };
    if vw > rb::WIDTH {
        return Err(FwError::Job("a registration run takes a visible frame up to 1024 wide"));
    }
    let map = m.region("rig_map", move || RigMap::new(&rig, range, NODE_STEP, &mut nodes[..]))?;
    let xy = xy.get_mut(..2 * rb::STRIP_ROWS * vw).ok_or(FwError::Job("strip map"))?;
    let frac = frac.get_mut(..rb::STRIP_ROWS * vw).ok_or(FwError::Job("strip map"))?;
    let interp = if cubic { Interpolation::Cubic } else { Interpolation::Linear };
    let o = FrameMut::new(out, vw, vh)?;
    m.region("register", || register(tir, &map, o, interp, Border::Constant(0), xy, frac))?;
    Ok(())
}

/// `u16` words viewed as their bytes (both targets are little-endian, the files' byte order).
fn words_as_bytes(words: &mut [u16]) -> &mut [u8] {
    // SAFETY: alignment 1 ≤ 2, the length doubled; `u8` has no invalid values.
    unsafe { core::slice::from_raw_parts_mut(words.as_mut_ptr().cast::<u8>(), words.len() * 2) }
}

/// A thermal front-end run (`job.rs`), run `i` of the job: on the job's first (`first`) the
/// tables, map and column parameters are read and the filter starts afresh; with `shutter` the
/// offsets are re-levelled from `shutter<i>.gray`; then the raw counts of `raw<i>.gray` (the TIR
/// size) go through the tables, the bad-pixel map and the column filter, each stage in its own
/// region, then the linear AGC into `out`.
fn thermal_run(
    m: &mut Meter,
    i: usize,
    (tw, th): (usize, usize),
    (first, shutter): (bool, bool),
    agc: &mut fusion_nostd::Agc,
    out: &mut [u8],
) -> Result<(), FwError> {
    use crate::thermal_buffers as tb;
    use fusion_nostd::thermal::{
        BadPixelMap, ColumnParams, Correction, NucTables, bad_map_bytes, column_filter_frame, correct_frame,
        nuc_frame, shutter_update,
    };
    let px = tw * th;
    if px > tb::PX {
        return Err(FwError::Job("a thermal front-end run needs the 512x512 image (feature grid512)"));
    }
    // SAFETY: single-threaded; the only references to these statics.
    let (nuc, bad, a, b, column, column_params) = unsafe {
        (
            &mut *core::ptr::addr_of_mut!(tb::NUC),
            &mut *core::ptr::addr_of_mut!(tb::BAD),
            &mut *core::ptr::addr_of_mut!(tb::STAGE_A),
            &mut *core::ptr::addr_of_mut!(tb::STAGE_B),
            &mut *core::ptr::addr_of_mut!(tb::COLUMN),
            &mut *core::ptr::addr_of_mut!(tb::COLUMN_PARAMS),
        )
    };
    let nuc = nuc.get_mut(..2 * px).ok_or(FwError::Job("TIR too large"))?;
    let bad = bad.get_mut(..bad_map_bytes(tw, th)).ok_or(FwError::Job("TIR too large"))?;
    if first {
        if semihosting::read_file("nuc.bin", words_as_bytes(nuc)).map_err(|e| FwError::Io(e, "nuc.bin"))?
            != 4 * px
        {
            return Err(FwError::Job("nuc.bin has the wrong length"));
        }
        if semihosting::read_file("bad.bin", bad).map_err(|e| FwError::Io(e, "bad.bin"))? != bad.len() {
            return Err(FwError::Job("bad.bin has the wrong length"));
        }
        let mut cfg = [0u8; 12];
        if semihosting::read_file("column.bin", &mut cfg).map_err(|e| FwError::Io(e, "column.bin"))? != 12 {
            return Err(FwError::Job("column.bin has the wrong length"));
        }
        let field =
            |k: usize| cfg.get(4 * k..4 * k + 4).map_or(0, |w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
        *column_params = ColumnParams {
            threshold: u16::try_from(field(0)).map_err(|_| FwError::Job("column.bin: threshold"))?,
            radius: u16::try_from(field(1)).map_err(|_| FwError::Job("column.bin: radius"))?,
            smoothing: u8::try_from(field(2)).map_err(|_| FwError::Job("column.bin: smoothing"))?,
        };
        column.reset();
    }
    let params = *column_params;
    let (gain, offset) = nuc.split_at_mut(px);
    // SAFETY: `i16` and `u16` have the same size and alignment; the offsets are their bits.
    let offset = unsafe { core::slice::from_raw_parts_mut(offset.as_mut_ptr().cast::<i16>(), offset.len()) };
    let map = BadPixelMap::new(tw, th, bad)?;
    let a = a.get_mut(..px).ok_or(FwError::Job("TIR too large"))?;
    let b = b.get_mut(..px).ok_or(FwError::Job("TIR too large"))?;
    let mut name = [0u8; 16];
    if shutter {
        // The shutter's flat field (in the first stage buffer until the tables need it)
        // re-levels the offsets in place.
        let file = job::file_name(b"shutter", i, &mut name);
        if semihosting::read_file(file, words_as_bytes(a)).map_err(|e| FwError::Io(e, "shutter<i>.gray"))?
            != 2 * px
        {
            return Err(FwError::Job("shutter<i>.gray has the wrong length"));
        }
        let flat = FrameRef::new(&a[..], tw, th)?;
        m.region("shutter", || shutter_update(gain, &mut *offset, Some(&map), flat))?;
    }
    let tables = NucTables::new(tw, th, gain, offset)?;
    // The raw counts in the second stage buffer: the tables read them into the first, the
    // bad-pixel stage writes over them.
    let file = job::file_name(b"raw", i, &mut name);
    if semihosting::read_file(file, words_as_bytes(b)).map_err(|e| FwError::Io(e, "raw<i>.gray"))? != 2 * px {
        return Err(FwError::Job("raw<i>.gray has the wrong length"));
    }
    let raw = FrameRef::new(&b[..], tw, th)?;
    let fa = FrameMut::new(&mut *a, tw, th)?;
    m.region("nuc", || nuc_frame(&tables, raw, fa))?;
    let fb = FrameMut::new(&mut *b, tw, th)?;
    let stages = Correction { nuc: None, bad: Some(map) };
    let fa = FrameRef::new(&a[..], tw, th)?;
    m.region("bad_pixels", || correct_frame(&stages, None, fa, fb))?;
    let fb = FrameMut::new(&mut *b, tw, th)?;
    m.region("column", || column_filter_frame(column, fb, &params))?;
    agc.reset();
    let fb = FrameRef::new(&b[..], tw, th)?;
    let out_frame = FrameMut::new(out, tw, th)?;
    m.region("agc", || agc_frame(agc, fb, out_frame, &fusion_nostd::AgcParams::linear()))?;
    Ok(())
}
