//! Firmware image that runs the `fusion-nostd` pipeline on an emulated Cortex-M7
//! (`thumbv7em-none-eabihf`, QEMU `mps2-an500`) or RV32 (`riscv32imac-unknown-none-elf`,
//! QEMU `virt`). See `fw/README.md`.
//!
//! Inputs come in and results go out through semihosting file I/O, relative to QEMU's working
//! directory:
//! * `job.bin` — frame sizes and the list of runs (layout in [`job`]); without it the image
//!   runs a small built-in self-test and exits.
//! * `vis.gray`, `tir.gray` — the input frames, row-major 8-bit.
//! * `out<i>.gray` — the fused frame of run `i` (written by the image).
//!
//! Each run fuses the pair with one method through the pipeline entry
//! ([`fusion_nostd::pipeline::fuse`]); with its `stages` flag it first runs the method's public
//! stage functions one by one, each inside a measured region, and checks that the staged
//! result equals the pipeline's. Regions are bracketed by the marker functions
//! [`fw_region_begin`] / [`fw_region_end`]: on RV32 the image reads `minstret` around them, on
//! Arm the TCG plugin `fw/plugin/insn_count.c` counts between them.
//!
//! Lines on the console start with `@fw `; a fault or an error exits QEMU with status 1.
#![no_std]
#![no_main]
// The reduced `rescale-only` image leaves the job I/O and most buffers unused.
#![cfg_attr(feature = "rescale-only", allow(dead_code))]

mod arch;
#[cfg(not(feature = "rescale-only"))]
mod job;
#[cfg(not(feature = "rescale-only"))]
mod runner;
mod semihosting;

use core::fmt::Write;
use semihosting::Console;

/// Static buffer sizes of the image: the default image fuses on grids up to 1024²; with the
/// `grid512` feature the image is sized for the 512² grid (VIS 1024² downscaled to the
/// 512² TIR grid).
#[cfg(not(feature = "grid512"))]
mod sizes {
    /// VIS input buffer, bytes.
    pub const VIS: usize = 1024 * 1024;
    /// TIR input buffer, bytes.
    pub const TIR: usize = 1024 * 1024;
    /// Output frame (the fusion grid), bytes.
    pub const OUT: usize = 1024 * 1024;
    /// Work planes for the grid.
    pub type Scratch = fusion_nostd::Scratch1024;
    /// Printed in the report.
    pub const NAME: &str = "grid1024";
}
#[cfg(feature = "grid512")]
mod sizes {
    pub const VIS: usize = 1024 * 1024;
    pub const TIR: usize = 512 * 512;
    pub const OUT: usize = 512 * 512;
    pub type Scratch = fusion_nostd::Scratch512;
    pub const NAME: &str = "grid512";
}

#[unsafe(link_section = ".bigram")]
static mut VIS: [u8; sizes::VIS] = [0; sizes::VIS];
#[unsafe(link_section = ".bigram")]
static mut TIR: [u8; sizes::TIR] = [0; sizes::TIR];
#[unsafe(link_section = ".bigram")]
static mut OUT: [u8; sizes::OUT] = [0; sizes::OUT];
/// 16-bit TIR counts of an AGC run (`tir16.gray`), in RAM (`.bss`): `.bigram` is full.
static mut TIR16: [u16; sizes::TIR] = [0; sizes::TIR];
/// The AGC state of an AGC run (112 KiB, `.bss`).
static mut AGC: fusion_nostd::Agc = fusion_nostd::Agc::new();
/// A thermal front-end run's tables, map and frames (the 512² image only: 2.1 MiB of `.bss`
/// at 512², more than the 1024² image's RAM has beside its 2 MiB of counts).
#[cfg(not(feature = "rescale-only"))]
pub(crate) mod thermal_buffers {
    /// Pixels of the largest thermal frame a front-end run takes.
    #[cfg(feature = "grid512")]
    pub const PX: usize = super::sizes::TIR;
    #[cfg(not(feature = "grid512"))]
    pub const PX: usize = 0;
    /// NUC gains (Q2.14) then offsets (`i16` bits), as read from `nuc.bin`.
    pub static mut NUC: [u16; 2 * PX] = [0; 2 * PX];
    /// The one-bit map (`bad.bin`).
    pub static mut BAD: [u8; PX / 8 + 2048] = [0; PX / 8 + 2048];
    /// The corrected frame after each stage.
    pub static mut STAGE_A: [u16; PX] = [0; PX];
    pub static mut STAGE_B: [u16; PX] = [0; PX];
    /// The column filter's state (28 KiB), carried from frame to frame.
    pub static mut COLUMN: fusion_nostd::thermal::ColumnFilter = fusion_nostd::thermal::ColumnFilter::new();
    /// The column filter's parameters (`column.bin`, read by the job's first thermal run).
    pub static mut COLUMN_PARAMS: fusion_nostd::thermal::ColumnParams =
        fusion_nostd::thermal::ColumnParams { threshold: 0, radius: 0, smoothing: 0 };
}
/// A registration run's node grid and strip map (`fusion_nostd::registration`): 33 KiB of
/// nodes for a 1024² visible grid, 16 rows of map (96 KiB).
#[cfg(not(feature = "rescale-only"))]
pub(crate) mod registration_buffers {
    use fusion_nostd::registration::{NODE_STEP, node_count};
    /// Visible rows per strip.
    pub const STRIP_ROWS: usize = 16;
    /// Widest visible frame.
    pub const WIDTH: usize = 1024;
    /// Nodes of the largest visible frame.
    pub const NODES: usize = node_count(WIDTH, WIDTH, NODE_STEP);
    pub static mut NODE_GRID: [[f32; 2]; NODES] = [[0.0; 2]; NODES];
    pub static mut XY: [i16; 2 * STRIP_ROWS * WIDTH] = [0; 2 * STRIP_ROWS * WIDTH];
    pub static mut FRAC: [u16; STRIP_ROWS * WIDTH] = [0; STRIP_ROWS * WIDTH];
}
#[unsafe(link_section = ".bigram")]
static mut SCRATCH: sizes::Scratch = sizes::Scratch::new();
/// The strip pipeline's whole working set (512 KiB), in the processor's RAM (`.bss`), not in
/// the big frame memory: the design point of `fusion_nostd::strips`.
static mut STRIP_SCRATCH: fusion_nostd::strips::StripScratch512K =
    fusion_nostd::strips::StripScratch512K::new();

/// Written by the marker functions so that they have distinct bodies (identical functions
/// could be merged into one address) and a visible side effect.
static mut MARK_BEGIN: u32 = 0;
static mut MARK_END: u32 = 0;

/// Start of a measured region (the Arm plugin finds this symbol in the ELF).
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn fw_region_begin(seq: u32) {
    // SAFETY: single-threaded; a plain store.
    unsafe { core::ptr::write_volatile(core::ptr::addr_of_mut!(MARK_BEGIN), seq) }
}

/// End of a measured region (the Arm plugin finds this symbol in the ELF).
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn fw_region_end(seq: u32) {
    // SAFETY: single-threaded; a plain store.
    unsafe { core::ptr::write_volatile(core::ptr::addr_of_mut!(MARK_END), seq) }
}

#[macro_export]
macro_rules! say {
    ($con:expr, $($arg:tt)*) => {{
        let _ = writeln!($con, $($arg)*);
    }};
}

/// The console plus the region counter.
pub struct Meter {
    /// The console.
    pub con: Console,
    seq: u32,
}

impl Meter {
    /// Runs `f` inside a measured region and reports it as `@fw region <seq> <label> <count>`
    /// (`-` for the count on Arm, where the plugin supplies it in the same order).
    pub fn region<R>(&mut self, label: &str, f: impl FnOnce() -> R) -> R {
        let seq = self.seq;
        self.seq += 1;
        let c0 = arch::instret();
        fw_region_begin(seq);
        let r = f();
        fw_region_end(seq);
        let c1 = arch::instret();
        match (c0, c1) {
            (Some(a), Some(b)) => say!(self.con, "@fw region {seq} {label} {}", b.wrapping_sub(a)),
            _ => say!(self.con, "@fw region {seq} {label} -"),
        }
        r
    }
}

/// FNV-1a over the bytes.
pub fn fnv1a(data: &[u8]) -> u32 {
    data.iter().fold(0x811c_9dc5u32, |h, &b| (h ^ u32::from(b)).wrapping_mul(0x0100_0193))
}

const STACK_PAINT: u32 = 0x5EED_F00D;

unsafe extern "C" {
    static mut _stack_end: u32;
    static mut _stack_start: u32;
}

/// Fills the unused stack (from its lowest address to just below the current frame) with a
/// pattern, so that [`stack_used`] can find the high-water mark.
fn paint_stack() {
    let lo = core::ptr::addr_of_mut!(_stack_end) as usize;
    let limit = arch::sp().saturating_sub(256);
    let mut p = (lo + 3) & !3;
    while p < limit {
        // SAFETY: [lo, sp − 256) is stack memory below every live frame.
        unsafe { core::ptr::write_volatile(p as *mut u32, STACK_PAINT) };
        p += 4;
    }
}

/// Bytes of stack used since [`paint_stack`] (the deepest word overwritten).
fn stack_used() -> usize {
    let lo = (core::ptr::addr_of_mut!(_stack_end) as usize + 3) & !3;
    let top = core::ptr::addr_of_mut!(_stack_start) as usize;
    let mut p = lo;
    // SAFETY: reads of stack memory below the live frames.
    while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == STACK_PAINT {
        p += 4;
    }
    top - p
}

/// Called by the start-up code of either target.
pub fn main() -> ! {
    paint_stack();
    let mut m = Meter { con: Console::open(), seq: 0 };
    say!(m.con, "@fw start {} {}", arch::NAME, sizes::NAME);
    #[cfg(any(feature = "panic-check", feature = "exercise"))]
    exercise_entry_points();
    #[cfg(not(feature = "rescale-only"))]
    let result = match semihosting::open("job.bin", semihosting::Mode::ReadBinary) {
        Ok(h) => {
            semihosting::close(h);
            runner::run_job(&mut m)
        }
        Err(_) => runner::self_test(&mut m),
    };
    #[cfg(feature = "rescale-only")]
    let result = rescale_smoke(&mut m);
    let ok = match result {
        Ok(()) => true,
        Err(e) => {
            say!(m.con, "@fw error {e}");
            false
        }
    };
    say!(m.con, "@fw stack {}", stack_used());
    say!(m.con, "@fw done {}", if ok { "ok" } else { "failed" });
    semihosting::exit(ok)
}

/// The `rescale-only` image: upscales a 512² TIR pattern to 1024² with the bicubic rescaler
/// and prints a checksum (the scope of the CI panic-check gate until the fusion methods are
/// panic-free, see README.md).
#[cfg(feature = "rescale-only")]
fn rescale_smoke(m: &mut Meter) -> Result<(), fusion_nostd::Error> {
    use fusion_nostd::{Filter, FrameMut, FrameRef, rescale};
    // SAFETY: single-threaded firmware; these are the only references to the frames.
    let (tir, out) = unsafe { (&mut *core::ptr::addr_of_mut!(TIR), &mut *core::ptr::addr_of_mut!(OUT)) };
    let tir = tir.get_mut(..512 * 512).unwrap_or(&mut []);
    let out = out.get_mut(..1024 * 1024).unwrap_or(&mut []);
    for (i, p) in tir.iter_mut().enumerate() {
        *p = (i.wrapping_mul(2_654_435_761) >> 13) as u8;
    }
    let src = FrameRef::new(&tir[..], 512, 512)?;
    m.region("rescale", || rescale(src, FrameMut::new(&mut *out, 1024, 1024)?, Filter::Cubic))?;
    say!(m.con, "@fw smoke cubic 512->1024 fnv1a {:08x}", fnv1a(out));
    Ok(())
}

/// A fault or trap: report it and make QEMU exit with status 1.
pub fn fault(what: &str, pc: usize, cause: usize) -> ! {
    let mut con = Console::open();
    say!(con, "@fw fault {} pc 0x{:08x} cause 0x{:x}", what, pc, cause);
    semihosting::exit(false)
}

/// Calls every public entry point with sizes, parameters and data the optimiser cannot see,
/// so the `panic-check` link covers all their code paths, not just the ones the demo reaches.
#[cfg(any(feature = "panic-check", feature = "exercise"))]
fn exercise_entry_points() {
    use core::hint::black_box;
    use fusion_nostd::{Filter, FrameMut, FrameRef, rescale};
    static mut U8_IN: [u8; 4096] = [0; 4096];
    static mut U8_IN2: [u8; 4096] = [0; 4096];
    static mut U8_OUT: [u8; 4096] = [0; 4096];
    static mut U16_IN: [u16; 1024] = [0; 1024];
    static mut U16_OUT: [u16; 1024] = [0; 1024];
    static mut F32_IN: [f32; 1024] = [0.0; 1024];
    static mut F32_OUT: [f32; 1024] = [0.0; 1024];
    static mut I32_OUT: [i32; 4096] = [0; 4096];
    static mut PLANES: [[i32; 4096]; 3] = [[0; 4096]; 3];
    static mut BAND: [u8; 4096] = [0; 4096];
    // SAFETY: single-threaded; the only references to these buffers.
    let (a, a2, b, c, d, e, f, raw, planes, band) = unsafe {
        (
            &*core::ptr::addr_of!(U8_IN),
            &*core::ptr::addr_of!(U8_IN2),
            &mut *core::ptr::addr_of_mut!(U8_OUT),
            &*core::ptr::addr_of!(U16_IN),
            &mut *core::ptr::addr_of_mut!(U16_OUT),
            &*core::ptr::addr_of!(F32_IN),
            &mut *core::ptr::addr_of_mut!(F32_OUT),
            &mut *core::ptr::addr_of_mut!(I32_OUT),
            &mut *core::ptr::addr_of_mut!(PLANES),
            &mut *core::ptr::addr_of_mut!(BAND),
        )
    };
    let dims =
        || (black_box(7usize), black_box(9usize), black_box(13usize), black_box(4usize), black_box(8usize));
    let (sw, sh, dw, dh, stride) = dims();
    for filter in [Filter::Cubic, Filter::Area] {
        let filter = black_box(filter);
        if let (Ok(s), Ok(o)) = (FrameRef::with_stride(a, sw, sh, stride), FrameMut::new(&mut *b, dw, dh)) {
            let _ = black_box(rescale(s, o, filter));
        }
        if let (Ok(s), Ok(o)) = (FrameRef::new(c, sw, sh), FrameMut::new(&mut *d, dw, dh)) {
            let _ = black_box(rescale(s, o, filter));
        }
        if let (Ok(s), Ok(o)) = (FrameRef::new(e, sw, sh), FrameMut::new(&mut *f, dw, dh)) {
            let _ = black_box(rescale(s, o, filter));
        }
    }
    // The thermal AGC: the frame entry and the row entries, both modes, parameters unseen.
    #[cfg(not(feature = "rescale-only"))]
    {
        use fusion_nostd::{AgcMode, AgcParams, agc_frame};
        // SAFETY: single-threaded; the only reference to the runner's AGC state while this runs.
        let agc = unsafe { &mut *core::ptr::addr_of_mut!(crate::AGC) };
        for mode in
            [AgcMode::Plateau { limit: black_box(3) }, AgcMode::Linear { low: black_box(100), high: 9_990 }]
        {
            let p =
                black_box(AgcParams { mode, out_low: black_box(0), out_high: 255, smoothing: black_box(3) });
            if let (Ok(s), Ok(o)) = (FrameRef::with_stride(c, sw, sh, stride), FrameMut::new(&mut *b, sw, sh))
            {
                let _ = black_box(agc_frame(agc, s, o, &p));
            }
            let n = black_box(37usize);
            let _ = black_box(agc.accumulate(c.get(..n).unwrap_or(&[])));
            let _ = black_box(agc.update(&p));
            let _ = black_box(agc.apply(c.get(..n).unwrap_or(&[]), b.get_mut(..n).unwrap_or(&mut [])));
        }
        agc.reset();
    }
    // The thermal front end: tables, map, the frame, strip and row entries, the shutter and
    // the column filter, sizes and parameters unseen.
    #[cfg(not(feature = "rescale-only"))]
    {
        use fusion_nostd::thermal::{
            BadPixelMap, ColumnParams, Correction, NucTables, correct_frame, correct_row, correct_strip,
            nuc_frame, shutter_update,
        };
        static mut OFFSETS: [i16; 1024] = [0; 1024];
        static mut BITS: [u8; 1024] = [0; 1024];
        // SAFETY: single-threaded; the only references to these statics while this runs.
        let (offsets, bits, filter) = unsafe {
            (
                &mut *core::ptr::addr_of_mut!(OFFSETS),
                &*core::ptr::addr_of!(BITS),
                &mut *core::ptr::addr_of_mut!(crate::thermal_buffers::COLUMN),
            )
        };
        let n = sw * sh;
        let gain = c.get(..n).unwrap_or(&[]);
        if let Ok(frame) = FrameRef::new(c, sw, sh) {
            let _ = black_box(shutter_update(gain, offsets.get_mut(..n).unwrap_or(&mut []), None, frame));
        }
        let bad = BadPixelMap::new(sw, sh, bits.get(..sw.div_ceil(8) * sh).unwrap_or(&[])).ok();
        let nuc = NucTables::new(sw, sh, gain, offsets.get(..n).unwrap_or(&[])).ok();
        if let (Some(t), Ok(s), Ok(o)) = (nuc, FrameRef::new(c, sw, sh), FrameMut::new(&mut *d, sw, sh)) {
            let _ = black_box(nuc_frame(&t, s, o));
        }
        let stages = black_box(Correction { nuc, bad });
        let p = black_box(ColumnParams {
            threshold: black_box(40),
            radius: black_box(16),
            smoothing: black_box(2),
        });
        if let (Ok(s), Ok(o)) = (FrameRef::new(c, sw, sh), FrameMut::new(&mut *d, sw, sh)) {
            let _ = black_box(correct_frame(&stages, Some((&mut *filter, &p)), s, o));
        }
        if let (Ok(s), Ok(o)) = (FrameRef::new(c, sw, sh), FrameMut::new(&mut *d, sw, black_box(1))) {
            let _ = black_box(correct_strip(&stages, s, black_box(1), o));
        }
        let (r0, r1, r2) = (
            c.get(..sw).unwrap_or(&[]),
            c.get(sw..2 * sw).unwrap_or(&[]),
            c.get(2 * sw..3 * sw).unwrap_or(&[]),
        );
        let _ = black_box(correct_row(
            &stages,
            sh,
            black_box(1),
            Some(r0),
            r1,
            Some(r2),
            d.get_mut(..sw).unwrap_or(&mut []),
        ));
        let _ = black_box(filter.accumulate(r1, &p));
        let _ = black_box(filter.update(&p));
        let _ = black_box(filter.apply(r1, d.get_mut(..sw).unwrap_or(&mut [])));
        filter.reset();
    }
    // Registration: the rig map, the strip registration and the remap, both depths, both
    // interpolations and borders, rig and sizes unseen.
    #[cfg(not(feature = "rescale-only"))]
    {
        use fusion_nostd::registration::{
            Border, Camera, FixedMap, Interpolation, Rig, RigMap, register, remap,
        };
        static mut NODES: [[f32; 2]; 64] = [[0.0; 2]; 64];
        static mut XY: [i16; 512] = [0; 512];
        static mut FRAC: [u16; 256] = [0; 256];
        // SAFETY: single-threaded; the only references to these statics while this runs.
        let (nodes, xy, frac) = unsafe {
            (
                &mut *core::ptr::addr_of_mut!(NODES),
                &mut *core::ptr::addr_of_mut!(XY),
                &mut *core::ptr::addr_of_mut!(FRAC),
            )
        };
        let cam = |w: usize, h: usize| Camera {
            fx: black_box(20.0),
            fy: black_box(21.0),
            cx: black_box(3.5),
            cy: black_box(4.0),
            dist: black_box([-0.1, 0.01, 0.001, 0.0, 0.0]),
            width: w,
            height: h,
        };
        let rig = black_box(Rig {
            vis: cam(dw, dh),
            tir: cam(sw, sh),
            r: black_box([[1.0, 0.0, 0.0]; 3]),
            t: [0.1; 3],
        });
        for interp in [Interpolation::Linear, Interpolation::Cubic] {
            let interp = black_box(interp);
            for border in [Border::Constant(black_box(9)), Border::Replicate] {
                let border = black_box(border);
                if let Ok(map) = RigMap::new(&rig, black_box(5.0), black_box(4), &mut *nodes) {
                    if let (Ok(s), Ok(o)) = (FrameRef::new(a, sw, sh), FrameMut::new(&mut *b, dw, dh)) {
                        let _ = black_box(register(s, &map, o, interp, border, &mut *xy, &mut *frac));
                    }
                    if let (Ok(s), Ok(o)) = (FrameRef::new(c, sw, sh), FrameMut::new(&mut *d, dw, dh)) {
                        let _ = black_box(register(s, &map, o, interp, border, &mut *xy, &mut *frac));
                    }
                }
                let n = dw * dh;
                if let Ok(map) =
                    FixedMap::new(dw, dh, xy.get(..2 * n).unwrap_or(&[]), frac.get(..n).unwrap_or(&[]))
                {
                    if let (Ok(s), Ok(o)) = (FrameRef::new(a, sw, sh), FrameMut::new(&mut *b, dw, dh)) {
                        let _ = black_box(remap(s, &map, o, interp, border));
                    }
                }
            }
        }
    }
    // The pipeline entry (and the pre-cast entry) with every method and rescale policy.
    #[cfg(not(feature = "rescale-only"))]
    {
        use fusion_nostd::ScratchMut;
        use fusion_nostd::stages::fuse_raw;
        use fusion_nostd::{FuseConfig, Method, RescalePolicy, fuse};
        let methods = Method::defaults();
        let policies = [RescalePolicy::TirUp, RescalePolicy::VisDown, RescalePolicy::None];
        let (vw, vh, tw, th, ow, oh) =
            (black_box(40usize), black_box(30usize), black_box(20usize), black_box(15usize), dw, dh);
        for method in methods {
            for policy in policies {
                let pipeline = black_box(FuseConfig {
                    rescale: policy,
                    method: black_box(method),
                    ..Default::default()
                });
                let [p0, p1, p2] = &mut *planes;
                let mut scratch = ScratchMut::with_band([p0, p1, p2], &mut *band);
                if let (Ok(v), Ok(t), Ok(o)) =
                    (FrameRef::new(a, vw, vh), FrameRef::new(a2, tw, th), FrameMut::new(&mut *b, ow, oh))
                {
                    let _ = black_box(fuse(v, t, o, &mut scratch, &pipeline));
                }
                if let (Ok(v), Ok(t), Ok(o)) =
                    (FrameRef::new(a, vw, vh), FrameRef::new(a2, tw, th), FrameMut::new(&mut *raw, ow, oh))
                {
                    let _ = black_box(fuse_raw(v, t, o, &mut scratch, &pipeline));
                }
                // The strip pipeline, in the strip scratch's words and band (cut short too).
                if let (Ok(v), Ok(t), Ok(o)) =
                    (FrameRef::new(a, vw, vh), FrameRef::new(a2, tw, th), FrameMut::new(&mut *b, ow, oh))
                {
                    let [p0, _, _] = &mut *planes;
                    let (words, band_len) = (black_box(p0.len()), black_box(band.len()));
                    let mut strip = fusion_nostd::strips::StripScratchMut::from_slices(
                        p0.get_mut(..words).unwrap_or(&mut []),
                        band.get_mut(..band_len).unwrap_or(&mut []),
                    );
                    let _ = black_box(fusion_nostd::strips::fuse_strips(
                        v,
                        t,
                        o,
                        &mut strip,
                        &pipeline,
                        black_box(7),
                    ));
                }
                let _ = black_box(pipeline.scratch_pixels((vw, vh), (tw, th)));
            }
        }
        // Each method's own entries (u8 and pre-cast), strided views, work planes without a band
        // plane, and the public stage functions the firmware runner measures.
        {
            use fusion_nostd::methods::{adf, ifevip, tsifsd};
            use fusion_nostd::stages::box_sum_u8;
            use fusion_nostd::stages::fuse_method;
            use fusion_nostd::{AdfParams, IfevipParams, TsifsdParams};
            let variant = black_box(fusion_nostd::Variant::Classic);
            let (adf_p, ts_p, ife_p) = black_box((
                AdfParams { variant, ..AdfParams::default() },
                TsifsdParams { variant, ..TsifsdParams::default() },
                IfevipParams { variant, ..IfevipParams::default() },
            ));
            let (w, h, s) = (black_box(11usize), black_box(7usize), black_box(13usize));
            let [p0, p1, p2] = &mut *planes;
            let mut scratch = ScratchMut::from_slices([&mut p0[..], &mut p1[..], &mut p2[..]]);
            if let (Ok(v), Ok(t)) = (FrameRef::with_stride(a, w, h, s), FrameRef::with_stride(a2, w, h, s)) {
                if let Ok(o) = FrameMut::with_stride(&mut *b, w, h, s) {
                    let _ = black_box(adf::fuse_adf(v, t, o, &adf_p, &mut scratch));
                }
                if let Ok(o) = FrameMut::with_stride(&mut *raw, w, h, s) {
                    let _ = black_box(adf::fuse_adf_raw(v, t, o, &adf_p, &mut scratch));
                }
                if let Ok(o) = FrameMut::with_stride(&mut *b, w, h, s) {
                    let _ = black_box(tsifsd::fuse_tsifsd(v, t, o, &ts_p, &mut scratch));
                }
                if let Ok(o) = FrameMut::with_stride(&mut *raw, w, h, s) {
                    let _ = black_box(tsifsd::fuse_tsifsd_raw(v, t, o, &ts_p, &mut scratch));
                }
                if let Ok(o) = FrameMut::with_stride(&mut *b, w, h, s) {
                    let _ = black_box(ifevip::fuse_ifevip(v, t, o, &ife_p, &mut scratch));
                }
                if let Ok(o) = FrameMut::with_stride(&mut *b, w, h, s) {
                    let _ = black_box(fuse_method(v, t, o, &black_box(Method::Tsifsd(ts_p)), &mut scratch));
                }
                let _ = black_box(ifevip::background(t, &ife_p, &mut scratch));
                let _ = black_box(ifevip::scratch_pixels(w, h, &ife_p));
                if let Ok([x, y, _]) = scratch.planes(w * h) {
                    let b = adf::Band::Frame(v);
                    let _ = black_box(adf::diffuse_pair(b, b, (w, h), &adf_p, x, y));
                    let _ = black_box(box_sum_u8(v, black_box(17), ts_p.mean_border(), x, y));
                }
                if let Ok(strip) = v.sub_rows(black_box(1), black_box(5)) {
                    let _ = black_box(strip.get(black_box(3), black_box(2)));
                }
            }
            if let (Ok(src), Ok(dst)) = (FrameRef::new(a, sw, sh), FrameMut::new(&mut *b, dw, dh)) {
                fusion_nostd::rescalers::rescale_general_u8(src, dst, black_box(Filter::Cubic));
            }
        }
    }
    #[cfg(feature = "rescale-only")]
    let _ = (a2, raw, planes, band);
}

#[cfg(not(feature = "panic-check"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    let mut con = Console::open();
    say!(con, "@fw panic");
    semihosting::exit(false)
}

/// With `--features panic-check` any panic path the optimiser could not remove from the linked
/// image calls this undefined symbol, so the link fails: a build that links has no panic path.
#[cfg(feature = "panic-check")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    unsafe extern "C" {
        fn fusion_core_has_a_reachable_panic_path() -> !;
    }
    // SAFETY: never defined; only reached if a panic path survives optimisation (link error).
    unsafe { fusion_core_has_a_reachable_panic_path() }
}
