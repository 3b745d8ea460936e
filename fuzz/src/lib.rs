//! Fuzz harness of the `fusion-nostd` core: one function per target, each decoding an
//! arbitrary byte string into a call of a public entry point (sizes, strides, buffer lengths,
//! parameters, policies, methods, scratch and pixels) and checking what the core returned.
//!
//! The same functions run under `cargo fuzz` (the targets in `fuzz_targets/`) and on stable
//! Rust in the workspace test `tests/tests/fuzz_replay.rs`, which includes this file as a
//! module and replays the committed corpus and regression inputs. This file therefore uses only
//! `std` and `fusion_nostd`, and has no crate-level attributes.
//!
//! Every input injects at most one fault (a zero side, a stride below the width, a buffer one
//! element short, a wrong output size, scratch one pixel short, different sizes under policy
//! `None`, one parameter out of range), so the expected `Err` is known exactly; an input
//! without a fault must give `Ok`. Besides "no panic", each call checks:
//! * the expected error variant, and that a refused call wrote nothing;
//! * nothing outside the output view is written (stride gaps, buffer tail);
//! * determinism: a second run with differently dirty scratch gives the same bytes and report;
//! * the pipeline's pre-cast value (ADF, TSIFSD) casts to its 8-bit output;
//! * the u8 rescaler (2× kernels included) equals the u16 one on the same samples, saturated;
//! * the f32 rescaler refuses exactly NaN/±∞ ([`Error::NonFinite`]) and magnitudes above
//!   [`F32_MAX_MAGNITUDE`] ([`Error::ValueOutOfRange`]), gives finite output otherwise, and on
//!   integer samples stays within 1.5 levels (cubic) / 0.5 levels (area) of the u16 rescaler.

use fusion_nostd::rescalers::{F32_MAX_MAGNITUDE, rescale_general_u8};
use fusion_nostd::stages::{fuse_raw, round_away_sat_u8};
use fusion_nostd::strips::{STRIP_BAND_BYTES, STRIP_WORK_WORDS, StripScratchMut, fuse_strips};
use fusion_nostd::{
    AdfParams, Error, Filter, FrameMut, FrameRef, IfevipParams, ScratchMut, TsifsdParams, Variant, rescale,
};
use fusion_nostd::{FuseConfig, Method, RescalePolicy, fuse};

/// Largest side of a fuzzed fusion input (keeps one execution in the millisecond range).
pub const MAX_FUSE_SIDE: usize = 48;
/// Largest side of a fuzzed rescale source.
pub const MAX_RESCALE_SRC: usize = 40;
/// Largest side of a fuzzed rescale destination.
pub const MAX_RESCALE_DST: usize = 80;

/// Reads the fuzz input front to back; past its end every read gives zeros.
pub struct Bytes<'a> {
    data: &'a [u8],
}

impl<'a> Bytes<'a> {
    /// A reader over `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Self { data }
    }

    /// The next byte (0 past the end).
    pub fn u8(&mut self) -> u8 {
        match self.data.split_first() {
            Some((&b, rest)) => {
                self.data = rest;
                b
            }
            None => 0,
        }
    }

    /// The next two bytes, little endian.
    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }

    /// The next four bytes, little endian.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }

    /// Whatever is left.
    pub fn rest(&self) -> &'a [u8] {
        self.data
    }
}

/// The one fault an input injects into a frame view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ViewFault {
    None,
    ZeroWidth,
    ZeroHeight,
    StrideTooSmall,
    BufferShort,
}

/// Geometry of one view: size, stride, buffer length.
#[derive(Debug, Clone, Copy)]
struct Geometry {
    width: usize,
    height: usize,
    stride: usize,
    len: usize,
}

impl Geometry {
    /// A view of `width × height` with a stride padding of `pad` and `tail` spare elements,
    /// with `fault` applied (a fault that cannot apply to this size leaves it valid).
    fn new(width: usize, height: usize, pad: usize, tail: usize, fault: ViewFault) -> (Self, ViewFault) {
        let stride = width + pad;
        let len = (height - 1) * stride + width + tail;
        let g = Geometry { width, height, stride, len };
        match fault {
            ViewFault::None => (g, fault),
            ViewFault::ZeroWidth => (Geometry { width: 0, ..g }, fault),
            ViewFault::ZeroHeight => (Geometry { height: 0, ..g }, fault),
            ViewFault::StrideTooSmall if width > 1 => (Geometry { stride: width - 1, ..g }, fault),
            ViewFault::BufferShort => (Geometry { len: (height - 1) * stride + width - 1, ..g }, fault),
            ViewFault::StrideTooSmall => (g, ViewFault::None),
        }
    }

    /// The error building a view of this geometry must give.
    fn expected(&self, fault: ViewFault) -> Option<Error> {
        match fault {
            ViewFault::None => None,
            ViewFault::ZeroWidth | ViewFault::ZeroHeight => Some(Error::ZeroDimension),
            ViewFault::StrideTooSmall => {
                Some(Error::StrideTooSmall { stride: self.stride, width: self.width })
            }
            ViewFault::BufferShort => Some(Error::BufferTooSmall { needed: self.len + 1, got: self.len }),
        }
    }

    /// Whether `i` (an index into the buffer) is a pixel of the view.
    fn is_pixel(&self, i: usize) -> bool {
        self.stride > 0 && i / self.stride < self.height && i % self.stride < self.width
    }
}

fn view_fault(sel: u8) -> ViewFault {
    match sel {
        0 => ViewFault::ZeroWidth,
        1 => ViewFault::ZeroHeight,
        2 => ViewFault::StrideTooSmall,
        3 => ViewFault::BufferShort,
        _ => ViewFault::None,
    }
}

/// Fills `buf` with pixels from `src` by pattern `mode` (raw bytes cycled, constant,
/// max-contrast checkerboard, black with hot pixels, ramp).
fn fill_u8(buf: &mut [u8], width: usize, mode: u8, src: &[u8]) {
    let at = |i: usize| if src.is_empty() { 0 } else { src[i % src.len()] };
    for (i, p) in buf.iter_mut().enumerate() {
        let (x, y) = (i % width.max(1), i / width.max(1));
        *p = match mode % 6 {
            0 | 1 => at(i),
            2 => at(0),
            3 => {
                if (x + y) % 2 == 0 {
                    255
                } else {
                    0
                }
            }
            4 => {
                if at(i) > 250 {
                    255
                } else {
                    0
                }
            }
            _ => (x * 7 + y * 3 + usize::from(at(0))) as u8,
        };
    }
}

/// One dirty-scratch pattern per seed.
fn dirt(seed: u8, i: usize) -> i32 {
    match seed % 4 {
        0 => 0,
        1 => -1,
        2 => i32::MIN + (i as i32 & 0xFF),
        _ => (i as i32).wrapping_mul(0x9E37_79B9u32 as i32) ^ i32::from(seed),
    }
}

/// Caller-owned scratch on the heap: three planes and the band plane, `capacity` each.
struct HeapScratch {
    planes: [Vec<i32>; 3],
    band: Vec<u8>,
}

impl HeapScratch {
    fn new(capacity: usize, seed: u8) -> Self {
        let plane = |k: usize| (0..capacity).map(|i| dirt(seed.wrapping_add(k as u8), i)).collect();
        Self {
            planes: [plane(0), plane(1), plane(2)],
            band: (0..capacity).map(|i| (i as u8) ^ seed).collect(),
        }
    }

    fn view(&mut self) -> ScratchMut<'_> {
        let [a, b, c] = &mut self.planes;
        ScratchMut::with_band([a, b, c], &mut self.band)
    }
}

/// The fault a fusion input injects (beyond the view faults).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum FuseFault {
    None,
    View(usize),
    OutputSize,
    ScratchShort,
    MismatchNone,
    Parameter,
}

fn variant(b: u8) -> Variant {
    if b & 1 == 0 { Variant::Flight } else { Variant::Classic }
}

/// A valid method from the input, or (with `bad_param`) one with exactly one field out of range,
/// and the name of that field.
fn method(b: &mut Bytes<'_>, bad_param: bool) -> (Method, Option<&'static str>) {
    let sel = b.u8();
    let v = variant(sel >> 4);
    let which = b.u8();
    match sel % 3 {
        0 => {
            let mut p = AdfParams {
                variant: v,
                iterations: 1 + u16::from(b.u8() % 16),
                dt_milli: 1 + b.u16() % 250,
                kappa: 1 + b.u16() % 255,
            };
            let name = bad_param.then(|| match which % 3 {
                0 => {
                    p.iterations = if which & 8 == 0 { 0 } else { 1001 };
                    "iterations"
                }
                1 => {
                    p.dt_milli = if which & 8 == 0 { 0 } else { 251 + b.u16() % 1000 };
                    "dt_milli"
                }
                _ => {
                    p.kappa = if which & 8 == 0 { 0 } else { 256 + b.u16() % 1000 };
                    "kappa"
                }
            });
            (Method::Adf(p), name)
        }
        1 => {
            let mut p = TsifsdParams { variant: v, mean_size: 1 + 2 * u16::from(b.u8() % 32) };
            let name = bad_param.then(|| {
                p.mean_size = match which % 3 {
                    0 => 0,
                    1 => 2 + 2 * u16::from(b.u8() % 40),
                    _ => 65 + 2 * u16::from(b.u8()),
                };
                "mean_size"
            });
            (Method::Tsifsd(p), name)
        }
        _ => {
            let norm = match b.u8() % 16 {
                0..=3 => 8u16,
                4..=7 => 16,
                8..=10 => 32,
                11..=12 => 64,
                13 => 128,
                14 => 256,
                _ => 512,
            };
            let levels = norm.trailing_zeros().min(4); // norm / min ≤ 16
            let min = (norm >> (u32::from(b.u8()) % (levels + 1))).max(4);
            let mut p = IfevipParams {
                variant: v,
                quad_norm_dim: norm,
                quad_min_dim: min,
                split_threshold: b.u8(),
                erode_size: 1 + b.u16() % 256,
                gauss_size: 1 + 2 * (b.u8() % 16),
                top_ppm: 1 + b.u32() % 1_000_000,
                gain_cap_percent: 1 + b.u8() % 100,
            };
            let name = bad_param.then(|| match which % 7 {
                0 => {
                    p.quad_norm_dim = [0, 4, 7, 2048, 500][usize::from(which >> 3) % 5];
                    "quad_norm_dim"
                }
                1 => {
                    // Not a power of two, below 4, above the grid, or more than 16 cells a side.
                    p.quad_min_dim = [0, 2, 3, norm * 2, norm / 32][usize::from(which >> 3) % 5];
                    "quad_min_dim"
                }
                2 => {
                    p.erode_size = if which & 8 == 0 { 0 } else { 257 };
                    "erode_size"
                }
                3 => {
                    p.gauss_size = [0, 2, 33, 255][usize::from(which >> 3) % 4];
                    "gauss_size"
                }
                4 => {
                    p.top_ppm = if which & 8 == 0 { 0 } else { 1_000_001 };
                    "top_ppm"
                }
                _ => {
                    p.gain_cap_percent = if which & 8 == 0 { 0 } else { 101 };
                    "gain_cap_percent"
                }
            });
            (Method::Ifevip(p), name)
        }
    }
}

/// Runs `fuse` (or `fuse_raw` into `raw`) on fresh copies of the output buffers.
struct FuseRun {
    result: Result<fusion_nostd::FuseReport, Error>,
    out: Vec<u8>,
}

/// Fuzz target `pipeline`: [`fusion_nostd::pipeline::fuse`] and [`fuse_raw`] with arbitrary
/// sizes (1..=48 per side; VIS = TIR, VIS 2× TIR, TIR 2× VIS or unrelated), strides, buffer
/// lengths, rescale policies, methods, variants, parameters, scratch sizes and pixels.
pub fn pipeline(data: &[u8]) {
    let mut b = Bytes::new(data);
    let fault = match b.u8() {
        0..=159 => FuseFault::None,
        160..=183 => FuseFault::View(usize::from(b.u8() % 3)),
        184..=199 => FuseFault::OutputSize,
        200..=215 => FuseFault::ScratchShort,
        216..=231 => FuseFault::MismatchNone,
        _ => FuseFault::Parameter,
    };
    let policy = match b.u8() % 3 {
        0 => RescalePolicy::TirUp,
        1 => RescalePolicy::VisDown,
        _ => RescalePolicy::None,
    };
    let (method, bad_param) = method(&mut b, fault == FuseFault::Parameter);
    let vw = 1 + usize::from(b.u8()) % MAX_FUSE_SIDE;
    let vh = 1 + usize::from(b.u8()) % MAX_FUSE_SIDE;
    let (tw, th) = match (policy, b.u8() % 4) {
        (RescalePolicy::None, _) => (vw, vh),
        (_, 0) => (vw, vh),
        (_, 1) => (vw.div_ceil(2), vh.div_ceil(2)),
        (_, 2) => ((2 * vw).min(MAX_FUSE_SIDE), (2 * vh).min(MAX_FUSE_SIDE)),
        _ => (1 + usize::from(b.u8()) % MAX_FUSE_SIDE, 1 + usize::from(b.u8()) % MAX_FUSE_SIDE),
    };
    let (tw, th) = match fault {
        FuseFault::MismatchNone if policy == RescalePolicy::None => (tw + 1, th),
        _ => (tw, th),
    };
    let fault = match fault {
        FuseFault::MismatchNone if policy != RescalePolicy::None => FuseFault::None,
        f => f,
    };
    let grid = if policy == RescalePolicy::VisDown { (tw, th) } else { (vw, vh) };
    let out_size = if fault == FuseFault::OutputSize { (grid.0 + 1, grid.1) } else { grid };

    // Views: VIS, TIR, output (one of them may carry the view fault).
    let vf =
        |k: usize, sel: u8| if fault == FuseFault::View(k) { view_fault(sel % 4) } else { ViewFault::None };
    let (sel_v, sel_t, sel_o) = (b.u8(), b.u8(), b.u8());
    let (gv, fv) = Geometry::new(vw, vh, usize::from(b.u8() % 5), usize::from(b.u8() % 3), vf(0, sel_v));
    let (gt, ft) = Geometry::new(tw, th, usize::from(b.u8() % 5), usize::from(b.u8() % 3), vf(1, sel_t));
    let (go, fo) =
        Geometry::new(out_size.0, out_size.1, usize::from(b.u8() % 5), usize::from(b.u8() % 3), vf(2, sel_o));
    let (mode_v, mode_t, seed) = (b.u8(), b.u8(), b.u8());
    let scratch_extra = usize::from(b.u8() % 8);
    let pixels = b.rest();
    let half = pixels.len() / 2;
    let mut vis = vec![0u8; gv.len];
    let mut tir = vec![0u8; gt.len];
    fill_u8(&mut vis, gv.stride, mode_v, pixels.get(..half).unwrap_or(&[]));
    fill_u8(&mut tir, gt.stride, mode_t, pixels.get(half..).unwrap_or(&[]));

    let v = FrameRef::with_stride(&vis, gv.width, gv.height, gv.stride);
    let t = FrameRef::with_stride(&tir, gt.width, gt.height, gt.stride);
    let (v, t) = match (v, t) {
        (Ok(v), Ok(t)) => {
            assert!(fv == ViewFault::None && ft == ViewFault::None, "a faulty view was accepted");
            (v, t)
        }
        (v, t) => {
            assert_eq!(v.err(), gv.expected(fv), "VIS view {gv:?}");
            assert_eq!(t.err(), gt.expected(ft), "TIR view {gt:?}");
            return;
        }
    };
    let fault = match fault {
        // A view fault that could not apply (a stride below a width of 1) leaves a valid input.
        FuseFault::View(_) if fo == ViewFault::None => FuseFault::None,
        f => f,
    };
    if fo != ViewFault::None {
        let mut out = vec![0u8; go.len];
        let r = FrameMut::with_stride(&mut out, go.width, go.height, go.stride);
        assert_eq!(r.err(), go.expected(fo), "output view {go:?}");
        return;
    }

    let p = FuseConfig { rescale: policy, method, ..Default::default() };
    let needed = p.scratch_pixels(v.size(), t.size());
    let needed = match (needed, fault) {
        (Ok(n), _) => n,
        (Err(e), FuseFault::MismatchNone) => {
            assert!(matches!(e, Error::SizeMismatch { .. }), "{e:?}");
            1
        }
        (Err(e), _) => panic!("scratch_pixels refused valid sizes: {e:?}"),
    };
    let capacity = if fault == FuseFault::ScratchShort { needed - 1 } else { needed + scratch_extra };

    let run = |seed: u8| -> FuseRun {
        let mut scratch = HeapScratch::new(capacity, seed);
        let mut out: Vec<u8> = (0..go.len).map(|i| (i as u8).wrapping_mul(31) ^ seed).collect();
        let before = out.clone();
        let result = match FrameMut::with_stride(&mut out, go.width, go.height, go.stride) {
            Ok(o) => fuse(v, t, o, &mut scratch.view(), &p),
            Err(e) => panic!("valid output view refused: {e:?}"),
        };
        for (i, (a, z)) in out.iter().zip(&before).enumerate() {
            if result.is_err() {
                // A refused call may have written a partial result into the view (documented),
                // never outside it.
                if !go.is_pixel(i) {
                    assert_eq!(a, z, "refused call wrote outside the view at {i}");
                }
            } else if !go.is_pixel(i) {
                assert_eq!(a, z, "wrote outside the output view at {i}");
            }
        }
        FuseRun { result, out }
    };
    let first = run(seed);
    let expected_err = match fault {
        FuseFault::None => None,
        FuseFault::View(_) => unreachable!("view faults return early"),
        FuseFault::OutputSize => Some(Error::SizeMismatch { expected: grid, got: out_size }),
        FuseFault::ScratchShort => None, // checked below (which plane runs out depends on the path)
        FuseFault::MismatchNone => Some(Error::SizeMismatch { expected: (vw, vh), got: (tw, th) }),
        FuseFault::Parameter => bad_param.map(|name| Error::InvalidParameter { name }),
    };
    match (&first.result, fault) {
        (Err(Error::ScratchTooSmall { needed: n, capacity: c }), FuseFault::ScratchShort) => {
            assert!(*c < *n && *c <= capacity, "ScratchTooSmall {{ needed: {n}, capacity: {c} }}");
            return;
        }
        (r, FuseFault::ScratchShort) => panic!("scratch one pixel short ({capacity} < {needed}) gave {r:?}"),
        (Err(e), _) => {
            assert_eq!(Some(*e), expected_err, "fault {fault:?}, {p:?}, vis {gv:?}, tir {gt:?}, out {go:?}");
            return;
        }
        (Ok(report), _) => {
            assert_eq!(expected_err, None, "fault {fault:?} not detected, {p:?}");
            assert_eq!(report.grid, grid);
            assert_eq!(report.rescaled, (vw, vh) != (tw, th));
        }
    }
    // Determinism: other dirty scratch, same bytes and report.
    let second = run(seed.wrapping_add(1));
    assert_eq!(first.result, second.result, "report differs between runs");
    assert!(
        pixels_of(&go, &first.out) == pixels_of(&go, &second.out),
        "output differs between runs (scratch dependence), {p:?}, vis {gv:?}, tir {gt:?}, out {go:?}, seed {seed}"
    );

    // The pre-cast value casts to the output (ADF, TSIFSD); IFEVIP has none.
    let mut raw: Vec<i32> = vec![0x1234_5678; go.len];
    let mut scratch = HeapScratch::new(capacity, seed ^ 0x55);
    let r = match FrameMut::with_stride(&mut raw, go.width, go.height, go.stride) {
        Ok(o) => fuse_raw(v, t, o, &mut scratch.view(), &p),
        Err(e) => panic!("valid raw view refused: {e:?}"),
    };
    match method {
        Method::Ifevip(_) => assert_eq!(r.err(), Some(Error::InvalidParameter { name: "method" })),
        _ => {
            assert!(r.is_ok(), "fuse_raw failed where fuse succeeded: {r:?}");
            for (i, (&q, &o)) in raw.iter().zip(&first.out).enumerate() {
                if go.is_pixel(i) {
                    assert_eq!(round_away_sat_u8(i64::from(q), 16), o, "raw cast at {i}, {p:?}");
                } else {
                    assert_eq!(q, 0x1234_5678, "fuse_raw wrote outside the view at {i}");
                }
            }
        }
    }

    // The strip pipeline (dirty strip scratch, a strip height from the input): the same bytes
    // and report where it runs, a documented refusal where it does not, never a write outside
    // the view.
    let max_rows = match seed % 4 {
        0 => usize::MAX,
        _ => 1 + usize::from(seed) % 40,
    };
    let mut work: Vec<i32> = (0..STRIP_WORK_WORDS).map(|i| dirt(seed, i)).collect();
    let mut band: Vec<u8> = (0..STRIP_BAND_BYTES).map(|i| dirt(seed, i) as u8).collect();
    let mut out: Vec<u8> = (0..go.len).map(|i| (i as u8) ^ 0x3C).collect();
    let before = out.clone();
    let r = match FrameMut::with_stride(&mut out, go.width, go.height, go.stride) {
        Ok(o) => fuse_strips(v, t, o, &mut StripScratchMut::from_slices(&mut work, &mut band), &p, max_rows),
        Err(e) => panic!("valid output view refused: {e:?}"),
    };
    let two_x = |a: (usize, usize), b: (usize, usize)| a == (2 * b.0, 2 * b.1);
    let (src, filter_up) = match policy {
        RescalePolicy::TirUp => ((tw, th), true),
        _ => ((vw, vh), false),
    };
    let ratio_ok = (vw, vh) == (tw, th) || if filter_up { two_x(grid, src) } else { two_x(src, grid) };
    match (&r, method) {
        (Err(e), _) if !ratio_ok => assert_eq!(*e, Error::UnsupportedRatio, "{p:?} vis {gv:?} tir {gt:?}"),
        // Many iterations (ADF), a wide mean (TSIFSD) or a short grid under a large quadtree
        // grid (IFEVIP) can outgrow the 512 KiB scratch.
        (Err(Error::ScratchTooSmall { needed, capacity }), _) => assert!(needed > capacity),
        (Err(e), _) => panic!("strips refused a supported pipeline: {e:?}, {p:?}, vis {gv:?}, tir {gt:?}"),
        (Ok((report, _)), _) => {
            assert_eq!(Ok(*report), first.result, "strip report, {p:?}");
            assert!(
                pixels_of(&go, &out) == pixels_of(&go, &first.out),
                "strips differ from the whole frame, {p:?}, vis {gv:?}, tir {gt:?}, rows {max_rows}"
            );
        }
    }
    for (i, (a, z)) in out.iter().zip(&before).enumerate() {
        if !go.is_pixel(i) || r.is_err() {
            assert_eq!(a, z, "strips wrote outside the view (or before refusing) at {i}");
        }
    }
}

/// A decoded rescale call: source and destination geometry, filter, fault.
struct RescaleCase<'a> {
    src: Geometry,
    dst: Geometry,
    fault_src: ViewFault,
    fault_dst: ViewFault,
    filter: Filter,
    mode: u8,
    pixels: &'a [u8],
}

fn rescale_case(data: &[u8]) -> RescaleCase<'_> {
    let mut b = Bytes::new(data);
    let fault = b.u8();
    let filter = if b.u8() & 1 == 0 { Filter::Cubic } else { Filter::Area };
    let sw = 1 + usize::from(b.u8()) % MAX_RESCALE_SRC;
    let sh = 1 + usize::from(b.u8()) % MAX_RESCALE_SRC;
    let (dw, dh) = match b.u8() % 4 {
        0 => (2 * sw, 2 * sh),
        1 => (sw.div_ceil(2), sh.div_ceil(2)),
        2 => (sw, sh),
        _ => (1 + usize::from(b.u8()) % MAX_RESCALE_DST, 1 + usize::from(b.u8()) % MAX_RESCALE_DST),
    };
    let (fs, fd) = match fault {
        0..=15 => (view_fault(fault % 4), ViewFault::None),
        16..=31 => (ViewFault::None, view_fault(fault % 4)),
        _ => (ViewFault::None, ViewFault::None),
    };
    let (src, fault_src) = Geometry::new(sw, sh, usize::from(b.u8() % 5), usize::from(b.u8() % 3), fs);
    let (dst, fault_dst) = Geometry::new(dw, dh, usize::from(b.u8() % 5), usize::from(b.u8() % 3), fd);
    let mode = b.u8();
    RescaleCase { src, dst, fault_src, fault_dst, filter, mode, pixels: b.rest() }
}

/// Rescales `src` (geometry `g`) into a fresh destination prefilled with `fill`; `None` when a
/// view was refused (after checking the expected error).
fn rescale_into<T: fusion_nostd::Sample + PartialEq + std::fmt::Debug>(
    c: &RescaleCase<'_>,
    src: &[T],
    fill: T,
) -> Option<(Result<(), Error>, Vec<T>)> {
    let s = FrameRef::with_stride(src, c.src.width, c.src.height, c.src.stride);
    let mut out = vec![fill; c.dst.len];
    let d = FrameMut::with_stride(&mut out, c.dst.width, c.dst.height, c.dst.stride);
    let (s, d) = match (s, d) {
        (Ok(s), Ok(d)) => {
            assert!(c.fault_src == ViewFault::None && c.fault_dst == ViewFault::None, "faulty view accepted");
            (s, d)
        }
        (s, d) => {
            assert_eq!(s.err(), c.src.expected(c.fault_src), "source view {:?}", c.src);
            assert_eq!(d.err(), c.dst.expected(c.fault_dst), "destination view {:?}", c.dst);
            return None;
        }
    };
    let r = rescale(s, d, c.filter);
    for (i, v) in out.iter().enumerate() {
        if !c.dst.is_pixel(i) || r.is_err() {
            assert_eq!(*v, fill, "rescale wrote outside the destination view (or on error) at {i}");
        }
    }
    Some((r, out))
}

/// The destination pixels (row-major, packed) of a strided buffer.
fn pixels_of<T: Copy>(g: &Geometry, buf: &[T]) -> Vec<T> {
    (0..g.height).flat_map(|y| (0..g.width).map(move |x| buf[y * g.stride + x])).collect()
}

/// Fuzz target `rescale_u8`: the u8 rescaler (2× kernels and the general path) with arbitrary
/// sizes, strides, buffer lengths, filter and pixels; checked against the exact general path
/// and the u16 rescaler.
pub fn rescale_u8(data: &[u8]) {
    let c = rescale_case(data);
    let mut src = vec![0u8; c.src.len];
    fill_u8(&mut src, c.src.stride, c.mode, c.pixels);
    let Some((r, out)) = rescale_into(&c, &src, 0xA5u8) else { return };
    assert_eq!(r, Ok(()), "u8 rescale refused valid views");
    let Some((_, again)) = rescale_into(&c, &src, 0xA5u8) else { return };
    assert!(out == again, "u8 rescale not deterministic");
    let got = pixels_of(&c.dst, &out);
    // The exact general path (the 2× kernels must equal it bit for bit).
    let mut general = vec![0u8; got.len()];
    match (
        FrameRef::with_stride(&src, c.src.width, c.src.height, c.src.stride),
        FrameMut::new(&mut general, c.dst.width, c.dst.height),
    ) {
        (Ok(s), Ok(d)) => rescale_general_u8(s, d, c.filter),
        (s, d) => panic!("valid views refused: {:?} {:?}", s.err(), d.err()),
    }
    assert!(
        got == general,
        "u8 rescale differs from the general path: {:?} {:?} -> {:?}",
        c.filter,
        c.src,
        c.dst
    );
    // The u16 rescaler on the same samples, saturated to 255.
    let src16: Vec<u16> = src.iter().map(|&v| u16::from(v)).collect();
    let Some((Ok(()), out16)) = rescale_into(&c, &src16, 0xA5A5u16) else { panic!("u16 rescale failed") };
    let got16 = pixels_of(&c.dst, &out16);
    for (i, (&a, &w)) in got.iter().zip(&got16).enumerate() {
        assert_eq!(u16::from(a), w.min(255), "u8 vs u16 at {i}: {:?} {:?} -> {:?}", c.filter, c.src, c.dst);
    }
}

/// Fuzz target `rescale_u16`: the u16 rescaler with arbitrary 16-bit samples (full range,
/// constant, checkerboard 0/65535, hot pixels, ramp), sizes, strides and filter.
pub fn rescale_u16(data: &[u8]) {
    let c = rescale_case(data);
    let at = |i: usize| {
        let k = 2 * i % c.pixels.len().max(1);
        u16::from_le_bytes([c.pixels.get(k).copied().unwrap_or(0), c.pixels.get(k + 1).copied().unwrap_or(0)])
    };
    let src: Vec<u16> = (0..c.src.len)
        .map(|i| {
            let (x, y) = (i % c.src.stride, i / c.src.stride);
            match c.mode % 5 {
                0 | 1 => at(i),
                2 => at(0),
                3 => [0, u16::MAX][(x + y) % 2],
                _ => (x as u16).wrapping_mul(977).wrapping_add((y as u16).wrapping_mul(3121)),
            }
        })
        .collect();
    let Some((r, out)) = rescale_into(&c, &src, 0x5A5Au16) else { return };
    assert_eq!(r, Ok(()), "u16 rescale refused valid views");
    let Some((_, again)) = rescale_into(&c, &src, 0x5A5Au16) else { return };
    assert!(out == again, "u16 rescale not deterministic");
    // Area never leaves the input's range (its weights are non-negative and sum to one).
    if c.filter == Filter::Area {
        let s = pixels_of(&c.src, &src);
        let (lo, hi) = (s.iter().min().copied().unwrap_or(0), s.iter().max().copied().unwrap_or(0));
        assert!(pixels_of(&c.dst, &out).iter().all(|&v| (lo..=hi).contains(&v)), "area left [{lo}, {hi}]");
    }
}

/// Fuzz target `rescale_f32`: the f32 rescaler with arbitrary bit patterns (NaN, ±∞, denormals,
/// huge values) or integer samples, sizes, strides and filter.
pub fn rescale_f32(data: &[u8]) {
    let c = rescale_case(data);
    let raw_bits = !c.mode.is_multiple_of(3);
    let at = |i: usize| {
        let n = c.pixels.len().max(1);
        let byte = |k: usize| c.pixels.get((4 * i + k) % n).copied().unwrap_or(0);
        f32::from_bits(u32::from_le_bytes([byte(0), byte(1), byte(2), byte(3)]))
    };
    let src: Vec<f32> = (0..c.src.len)
        .map(|i| {
            if raw_bits {
                at(i)
            } else {
                f32::from(c.pixels.get(i % c.pixels.len().max(1)).copied().unwrap_or(0))
            }
        })
        .collect();
    let Some((r, out)) = rescale_into(&c, &src, -1234.5f32) else { return };
    let s = pixels_of(&c.src, &src);
    let want = if s.iter().any(|v| !v.is_finite()) {
        Err(Error::NonFinite)
    } else if s.iter().any(|v| v.abs() > F32_MAX_MAGNITUDE) {
        Err(Error::ValueOutOfRange)
    } else {
        Ok(())
    };
    assert_eq!(r, want, "f32 rescale result");
    if r.is_err() {
        return;
    }
    let got = pixels_of(&c.dst, &out);
    assert!(got.iter().all(|v| v.is_finite()), "finite input gave non-finite output");
    let Some((_, again)) = rescale_into(&c, &src, -1234.5f32) else { return };
    assert!(out.iter().zip(&again).all(|(a, b)| a.to_bits() == b.to_bits()), "f32 rescale not deterministic");
    if !raw_bits {
        // Integer samples 0..=255: within the integer path's rounding of the exact value.
        let src16: Vec<u16> = src.iter().map(|&v| v as u16).collect();
        let Some((Ok(()), out16)) = rescale_into(&c, &src16, 0u16) else { panic!("u16 rescale failed") };
        let tol = if c.filter == Filter::Cubic { 1.5 } else { 0.5 } + 1e-3;
        for (i, (&f, &w)) in got.iter().zip(&pixels_of(&c.dst, &out16)).enumerate() {
            let f = f64::from(f).max(0.0);
            assert!(
                (f - f64::from(w)).abs() <= tol,
                "f32 {f} vs u16 {w} at {i}: {:?} {:?} -> {:?}",
                c.filter,
                c.src,
                c.dst
            );
        }
    }
}
