//! The C interface against the Rust core it wraps: the same bytes, reports and errors, and the
//! refusals the C side adds (NULL, alignment, overlap, unknown enum values).

use crate::*;
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, SkipPolicy};
use fusion_nostd::{AdaptiveParams, AdfParams, FrameMut, FrameRef, IfevipParams, TsifsdParams, Variant};
use std::vec;
use std::vec::Vec;

/// A deterministic test frame: a bright rectangle (the "target") on a dark, slightly noisy
/// background, with texture.
fn frame(w: usize, h: usize, seed: u32) -> Vec<u8> {
    let mut s = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
    (0..w * h)
        .map(|i| {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let (x, y) = (i % w, i / w);
            let inside = x > w / 4 && x < 3 * w / 4 && y > h / 3 && y < 2 * h / 3;
            let base = if inside { 150 + ((x * 7 + y * 3) % 60) as u32 } else { 8 };
            (base + s % 9) as u8
        })
        .collect()
}

/// A frame copied into rows `stride` apart (padding filled with 0xEE).
fn strided(px: &[u8], w: usize, h: usize, stride: usize) -> Vec<u8> {
    let mut out = vec![0xEE; (h - 1) * stride + w];
    for y in 0..h {
        out[y * stride..y * stride + w].copy_from_slice(&px[y * w..(y + 1) * w]);
    }
    out
}

fn image(px: &[u8], w: usize, h: usize, stride: usize) -> FusionImage {
    FusionImage { data: px.as_ptr(), width: w, height: h, stride }
}

fn image_mut(px: &mut [u8], w: usize, h: usize, stride: usize) -> FusionImageMut {
    FusionImageMut { data: px.as_mut_ptr(), width: w, height: h, stride }
}

/// A 4-byte-aligned scratch of at least `bytes`.
fn scratch(bytes: usize) -> Vec<u32> {
    vec![0xDEAD_BEEF; bytes.div_ceil(4)]
}

/// The caller's box of `FUSION_SKIP_WINDOW` in these tests (it runs past a 32 × 24 grid).
const WINDOW: [usize; 4] = [5, 7, 40, 30];

fn config(method: u32, variant: u32, rescale: u32, skip: u32) -> FusionConfig {
    FusionConfig { method, variant, rescale, skip, window: WINDOW }
}

/// The core configuration the same numbers stand for (written out independently of
/// `FusionConfig::pipeline`).
fn core_pipeline(method: u32, variant: u32, rescale: u32, skip: u32) -> FuseConfig {
    let variant = [Variant::Flight, Variant::Classic][variant as usize];
    let method = match method {
        0 => Method::Adf(AdfParams { variant, ..Default::default() }),
        1 => Method::Tsifsd(TsifsdParams { variant, ..Default::default() }),
        2 => Method::Ifevip(IfevipParams { variant, ..Default::default() }),
        _ => Method::Adaptive(AdaptiveParams::default()),
    };
    let rescale = [RescalePolicy::TirUp, RescalePolicy::VisDown, RescalePolicy::None][rescale as usize];
    let [x0, y0, x1, y1] = WINDOW;
    let window = SkipPolicy::Window(fusion_nostd::scene::Rect { x0, y0, x1, y1 });
    let skip = [SkipPolicy::None, SkipPolicy::Roi, SkipPolicy::All, window][skip as usize];
    FuseConfig { rescale, method, skip, ..Default::default() }
}

fn core_fuse(
    vis: &[u8],
    vs: (usize, usize),
    tir: &[u8],
    ts: (usize, usize),
    p: &FuseConfig,
) -> (Vec<u8>, (usize, usize)) {
    let grid = fusion_nostd::pipeline::fusion_grid(vs, ts, p.rescale).unwrap();
    let pixels = p.scratch_pixels(vs, ts).unwrap();
    let (mut a, mut b, mut c, mut band) =
        (vec![0; pixels], vec![0; pixels], vec![0; pixels], vec![0; pixels]);
    let mut s = fusion_nostd::ScratchMut::with_band([&mut a, &mut b, &mut c], &mut band);
    let mut out = vec![0; grid.0 * grid.1];
    fusion_nostd::fuse(
        FrameRef::new(vis, vs.0, vs.1).unwrap(),
        FrameRef::new(tir, ts.0, ts.1).unwrap(),
        FrameMut::new(&mut out, grid.0, grid.1).unwrap(),
        &mut s,
        p,
    )
    .unwrap();
    (out, grid)
}

/// Every method, variant, rescale policy and skip policy through `fusion_fuse` on strided
/// frames: the core's bytes, the padding untouched, the report's grid and guards.
#[test]
fn fuse_gives_the_core_bytes_for_every_configuration() {
    let (vs, ts) = ((64usize, 48usize), (32usize, 24usize));
    let (vis, tir) = (frame(vs.0, vs.1, 1), frame(ts.0, ts.1, 2));
    let (vis_s, tir_s) = (strided(&vis, vs.0, vs.1, 70), strided(&tir, ts.0, ts.1, 33));
    for method in 0..4 {
        for variant in 0..2 {
            for rescale in 0..2 {
                for skip in 0..4 {
                    let cfg = config(method, variant, rescale, skip);
                    let p = core_pipeline(method, variant, rescale, skip);
                    let (expected, grid) = core_fuse(&vis, vs, &tir, ts, &p);
                    let (mut w, mut h, mut bytes) = (0, 0, 0);
                    let mut err = FusionError::of(FusionStatus::Unknown);
                    unsafe {
                        assert_eq!(
                            fusion_output_size(&cfg, vs.0, vs.1, ts.0, ts.1, &mut w, &mut h, &mut err),
                            FusionStatus::Ok
                        );
                        assert_eq!(
                            fusion_scratch_bytes(&cfg, vs.0, vs.1, ts.0, ts.1, &mut bytes, &mut err),
                            FusionStatus::Ok
                        );
                    }
                    assert_eq!((w, h), grid);
                    assert_eq!(bytes, 13 * p.scratch_pixels(vs, ts).unwrap());
                    let stride = w + 5;
                    let mut out = vec![0x77u8; (h - 1) * stride + w];
                    let mut s = scratch(bytes);
                    let mut report = core::mem::MaybeUninit::<FusionReport>::uninit();
                    let status = unsafe {
                        fusion_fuse(
                            &cfg,
                            &image(&vis_s, vs.0, vs.1, 70),
                            &image(&tir_s, ts.0, ts.1, 33),
                            &image_mut(&mut out, w, h, stride),
                            s.as_mut_ptr().cast(),
                            bytes,
                            report.as_mut_ptr(),
                            &mut err,
                        )
                    };
                    assert_eq!(status, FusionStatus::Ok, "{cfg:?}");
                    assert_eq!(err.status, FusionStatus::Ok);
                    let report = unsafe { report.assume_init() };
                    for y in 0..h {
                        assert_eq!(
                            &out[y * stride..y * stride + w],
                            &expected[y * w..(y + 1) * w],
                            "{cfg:?} row {y}"
                        );
                        if y + 1 < h {
                            assert!(
                                out[y * stride + w..(y + 1) * stride].iter().all(|&b| b == 0x77),
                                "padding written"
                            );
                        }
                    }
                    assert_eq!((report.grid_width, report.grid_height), grid);
                    assert_eq!(report.rescaled, 1);
                    assert_eq!(report.strips, 0);
                    if skip == 0 {
                        assert_eq!(report.skip_taken, 0);
                        assert_eq!(report.window, [0, 0, w, h]);
                    }
                    if skip == 3 {
                        // The caller's box (clipped to the grid) is always fused, never declined.
                        assert_eq!(report.skip_declined, 0, "{cfg:?}");
                        assert!(
                            report.skip_taken & 1 != 0 || report.window == [0, 0, w, h],
                            "{cfg:?}: the window was not taken"
                        );
                        let crop = u32::from(method == 0 || method == 2) << 5;
                        assert_eq!(report.skip_taken & 32, crop, "{cfg:?}: crop semantics");
                    }
                }
            }
        }
    }
}

/// Strips: the whole-frame bytes and guards, with the 512 KiB working set and with a small one
/// (many strips), and the strip report.
#[test]
fn strips_give_the_whole_frame_bytes() {
    let (vs, ts) = ((96usize, 80usize), (48usize, 40usize));
    let (vis, tir) = (frame(vs.0, vs.1, 3), frame(ts.0, ts.1, 4));
    for method in 0..4 {
        for variant in 0..2 {
            let cfg = config(method, variant, 0, 0);
            let (expected, (w, h)) = core_fuse(&vis, vs, &tir, ts, &core_pipeline(method, variant, 0, 0));
            for (bytes, max_rows) in
                [(FUSION_STRIP_SCRATCH_BYTES, usize::MAX), (FUSION_STRIP_SCRATCH_BYTES, 7)]
            {
                let mut out = vec![0u8; w * h];
                let mut s = scratch(bytes);
                let mut report = core::mem::MaybeUninit::<FusionReport>::uninit();
                let status = unsafe {
                    fusion_fuse_strips(
                        &cfg,
                        &image(&vis, vs.0, vs.1, vs.0),
                        &image(&tir, ts.0, ts.1, ts.0),
                        &image_mut(&mut out, w, h, w),
                        s.as_mut_ptr().cast(),
                        bytes,
                        max_rows,
                        report.as_mut_ptr(),
                        core::ptr::null_mut(),
                    )
                };
                assert_eq!(status, FusionStatus::Ok, "{cfg:?}");
                assert_eq!(out, expected, "{cfg:?} max_rows {max_rows}");
                let report = unsafe { report.assume_init() };
                assert!(report.strips >= 1 && report.working_set_bytes <= bytes);
                if max_rows == 7 {
                    assert!(report.strips > 1 && report.strip_rows <= 7, "{report:?}");
                }
            }
        }
    }
}

fn fuse_status(
    cfg: &FusionConfig,
    vis: &FusionImage,
    tir: &FusionImage,
    out: &FusionImageMut,
    scratch: *mut core::ffi::c_void,
    bytes: usize,
) -> FusionError {
    let mut err = FusionError::of(FusionStatus::Unknown);
    let status = unsafe { fusion_fuse(cfg, vis, tir, out, scratch, bytes, core::ptr::null_mut(), &mut err) };
    assert_eq!(status, err.status);
    err
}

fn name(e: &FusionError) -> std::string::String {
    let bytes: Vec<u8> = e.name.iter().take_while(|&&c| c != 0).map(|&c| c as u8).collect();
    std::string::String::from_utf8(bytes).unwrap()
}

/// Every refusal of `fusion_fuse`, each before the output is touched.
#[test]
fn bad_calls_are_refused_with_their_code_and_nothing_written() {
    let (w, h) = (32usize, 32usize);
    let (vis, tir) = (frame(w, h, 5), frame(w / 2, h / 2, 6));
    let cfg = fusion_config_default();
    let bytes = 13 * w * h;
    let mut s = scratch(bytes + 8);
    let sp: *mut core::ffi::c_void = s.as_mut_ptr().cast();
    let mut out = vec![0x5Au8; w * h];
    let vi = image(&vis, w, h, w);
    let ti = image(&tir, w / 2, h / 2, w / 2);
    let oi = image_mut(&mut out, w, h, w);
    let null = core::ptr::null_mut();

    let e = |cfg: &FusionConfig, vi: &FusionImage, ti: &FusionImage, oi: &FusionImageMut, sp, n| {
        fuse_status(cfg, vi, ti, oi, sp, n)
    };
    // NULL configuration, images, image data, scratch.
    let err =
        unsafe { fusion_fuse(core::ptr::null(), &vi, &ti, &oi, sp, bytes, null, core::ptr::null_mut()) };
    assert_eq!(err, FusionStatus::NullPointer);
    let err =
        unsafe { fusion_fuse(&cfg, &vi, core::ptr::null(), &oi, sp, bytes, null, core::ptr::null_mut()) };
    assert_eq!(err, FusionStatus::NullPointer);
    assert_eq!(
        e(&cfg, &FusionImage { data: core::ptr::null(), ..vi }, &ti, &oi, sp, bytes).status,
        FusionStatus::NullPointer
    );
    assert_eq!(e(&cfg, &vi, &ti, &oi, core::ptr::null_mut(), bytes).status, FusionStatus::NullPointer);
    // Sizes and strides.
    assert_eq!(
        e(&cfg, &FusionImage { width: 0, ..vi }, &ti, &oi, sp, bytes).status,
        FusionStatus::ZeroDimension
    );
    let big = e(&cfg, &FusionImage { height: 20_000, ..vi }, &ti, &oi, sp, bytes);
    assert_eq!((big.status, big.values[0]), (FusionStatus::DimensionTooLarge, 20_000));
    let stride = e(&cfg, &FusionImage { stride: 31, ..vi }, &ti, &oi, sp, bytes);
    assert_eq!((stride.status, stride.values[0], stride.values[1]), (FusionStatus::StrideTooSmall, 31, 32));
    let grid = e(&cfg, &vi, &ti, &FusionImageMut { width: 16, ..oi }, sp, bytes);
    assert_eq!((grid.status, grid.values), (FusionStatus::SizeMismatch, [32, 32, 16, 32]));
    let none = config(1, 0, FusionRescale::None as u32, 0);
    assert_eq!(e(&none, &vi, &ti, &oi, sp, bytes).status, FusionStatus::SizeMismatch);
    // Scratch: too small (in bytes), misaligned.
    let small = e(&cfg, &vi, &ti, &oi, sp, bytes - 1);
    assert_eq!(
        (small.status, small.values[0], small.values[1]),
        (FusionStatus::ScratchTooSmall, bytes, bytes - 1)
    );
    let odd = unsafe { sp.cast::<u8>().add(2).cast() };
    assert_eq!(e(&cfg, &vi, &ti, &oi, odd, bytes).status, FusionStatus::Misaligned);
    // Unknown enum values name their field.
    for (bad, field) in [
        (config(9, 0, 0, 0), "method"),
        (config(1, 2, 0, 0), "variant"),
        (config(1, 0, 3, 0), "rescale"),
        (config(1, 0, 0, 7), "skip"),
    ] {
        let err = e(&bad, &vi, &ti, &oi, sp, bytes);
        assert_eq!((err.status, name(&err).as_str()), (FusionStatus::InvalidParameter, field));
    }
    // The output over an input or over the scratch.
    let mut both = frame(w, h, 5);
    let vb = image(&both, w, h, w);
    let ob = image_mut(&mut both, w, h, w);
    assert_eq!(e(&cfg, &vb, &ti, &ob, sp, bytes).status, FusionStatus::Overlap);
    let over_scratch = FusionImageMut { data: sp.cast(), width: w, height: h, stride: w };
    assert_eq!(e(&cfg, &vi, &ti, &over_scratch, sp, bytes).status, FusionStatus::Overlap);
    assert!(out.iter().all(|&b| b == 0x5A), "a refused call wrote the output");
    // Strips refuse skipping and a scratch too small for one strip.
    let mut err = FusionError::of(FusionStatus::Ok);
    let st = unsafe {
        fusion_fuse_strips(
            &config(1, 0, 0, 1),
            &vi,
            &ti,
            &oi,
            sp,
            bytes,
            usize::MAX,
            core::ptr::null_mut(),
            &mut err,
        )
    };
    assert_eq!((st, name(&err).as_str()), (FusionStatus::InvalidParameter, "skip"));
    let st = unsafe {
        fusion_fuse_strips(&cfg, &vi, &ti, &oi, sp, 64, usize::MAX, core::ptr::null_mut(), &mut err)
    };
    assert_eq!(st, FusionStatus::ScratchTooSmall);
    assert!(out.iter().all(|&b| b == 0x5A), "a refused strip call wrote the output");
}

/// The rescalers: the core's bytes for u8 and u16, both filters, with strides; overlap refused.
#[test]
fn rescalers_give_the_core_bytes() {
    let src = frame(40, 30, 7);
    let src16: Vec<u16> =
        src.iter().enumerate().map(|(i, &v)| u16::from(v) * 251 + (i % 13) as u16).collect();
    for (filter, code) in [(fusion_nostd::Filter::Cubic, 0u32), (fusion_nostd::Filter::Area, 1)] {
        for (dw, dh) in [(80usize, 60usize), (20, 15), (33, 47)] {
            let mut expected = vec![0u8; dw * dh];
            fusion_nostd::rescale(
                FrameRef::new(&src, 40, 30).unwrap(),
                FrameMut::new(&mut expected, dw, dh).unwrap(),
                filter,
            )
            .unwrap();
            let mut got = vec![0u8; dw * dh];
            let st = unsafe {
                fusion_rescale_u8(
                    &image(&src, 40, 30, 40),
                    &image_mut(&mut got, dw, dh, dw),
                    code,
                    core::ptr::null_mut(),
                )
            };
            assert_eq!((st, &got), (FusionStatus::Ok, &expected));

            let mut expected16 = vec![0u16; dw * dh];
            fusion_nostd::rescale(
                FrameRef::new(&src16, 40, 30).unwrap(),
                FrameMut::new(&mut expected16, dw, dh).unwrap(),
                filter,
            )
            .unwrap();
            let mut got16 = vec![0u16; dw * dh];
            let st = unsafe {
                fusion_rescale_u16(
                    &FusionImage16 { data: src16.as_ptr(), width: 40, height: 30, stride: 40 },
                    &FusionImageMut16 { data: got16.as_mut_ptr(), width: dw, height: dh, stride: dw },
                    code,
                    core::ptr::null_mut(),
                )
            };
            assert_eq!((st, &got16), (FusionStatus::Ok, &expected16));
        }
    }
    let mut err = FusionError::of(FusionStatus::Ok);
    let mut same = frame(40, 30, 7);
    let st = unsafe {
        fusion_rescale_u8(&image(&same, 40, 30, 40), &image_mut(&mut same, 40, 30, 40), 0, &mut err)
    };
    assert_eq!(st, FusionStatus::Overlap);
    let mut out = vec![0u8; 4];
    let st =
        unsafe { fusion_rescale_u8(&image(&src, 40, 30, 40), &image_mut(&mut out, 2, 2, 2), 5, &mut err) };
    assert_eq!((st, name(&err).as_str()), (FusionStatus::InvalidParameter, "filter"));
}

/// The AGC: the core's bytes and report frame after frame (smoothing carries over in the
/// caller's state), both default parameter sets, and its refusals.
#[test]
fn agc_follows_the_core_over_a_sequence() {
    let (w, h) = (50usize, 30usize);
    let mut state = vec![0xFFFF_FFFFu32; fusion_agc_state_bytes().div_ceil(4)];
    let state_bytes = state.len() * 4;
    let sp: *mut core::ffi::c_void = state.as_mut_ptr().cast();
    for mut params in [fusion_agc_linear(), fusion_agc_plateau(w * h)] {
        params.smoothing = 2;
        let core_params = params.core().unwrap();
        let mut core_state = std::boxed::Box::new(fusion_nostd::Agc::new());
        assert_eq!(unsafe { fusion_agc_init(sp, state_bytes, core::ptr::null_mut()) }, FusionStatus::Ok);
        for f in 0..5u32 {
            let counts: Vec<u16> =
                frame(w, h, f).iter().map(|&v| 2000 + u16::from(v) * (40 + f as u16 * 3)).collect();
            let mut expected = vec![0u8; w * h];
            let r = fusion_nostd::agc_frame(
                &mut core_state,
                FrameRef::new(&counts, w, h).unwrap(),
                FrameMut::new(&mut expected, w, h).unwrap(),
                &core_params,
            )
            .unwrap();
            let mut got = vec![0u8; w * h];
            let mut report = core::mem::MaybeUninit::<FusionAgcReport>::uninit();
            let st = unsafe {
                fusion_agc_frame(
                    sp,
                    state_bytes,
                    &params,
                    &FusionImage16 { data: counts.as_ptr(), width: w, height: h, stride: w },
                    &image_mut(&mut got, w, h, w),
                    report.as_mut_ptr(),
                    core::ptr::null_mut(),
                )
            };
            assert_eq!(st, FusionStatus::Ok);
            assert_eq!(got, expected, "frame {f}");
            let report = unsafe { report.assume_init() };
            assert_eq!(
                (report.pixels, (report.bin_low, report.bin_high), report.clipped_bins),
                (r.pixels, r.bins, r.clipped_bins)
            );
        }
    }
    let counts = [7u16; 4];
    let mut out = vec![0u8; 4];
    let mut err = FusionError::of(FusionStatus::Ok);
    let mut call = |params: &FusionAgcParams,
                    state: *mut core::ffi::c_void,
                    bytes: usize,
                    err: &mut FusionError| unsafe {
        fusion_agc_frame(
            state,
            bytes,
            params,
            &FusionImage16 { data: counts.as_ptr(), width: 2, height: 2, stride: 2 },
            &image_mut(&mut out, 2, 2, 2),
            core::ptr::null_mut(),
            err,
        )
    };
    let bad = FusionAgcParams { out_low: 200, out_high: 100, ..fusion_agc_linear() };
    assert_eq!(call(&bad, sp, state_bytes, &mut err), FusionStatus::InvalidParameter);
    assert_eq!(name(&err), "agc output range");
    let bad = FusionAgcParams { mode: 2, ..fusion_agc_linear() };
    assert_eq!(call(&bad, sp, state_bytes, &mut err), FusionStatus::InvalidParameter);
    assert_eq!(call(&fusion_agc_linear(), sp, state_bytes - 4, &mut err), FusionStatus::ScratchTooSmall);
    let odd = unsafe { sp.cast::<u8>().add(1).cast() };
    assert_eq!(call(&fusion_agc_linear(), odd, state_bytes - 4, &mut err), FusionStatus::Misaligned);
    assert_eq!(unsafe { fusion_agc_init(sp, 16, &mut err) }, FusionStatus::ScratchTooSmall);
}

/// The header's constants are the core's values, and every status has its own text.
#[test]
fn constants_and_texts_match_the_core() {
    use fusion_nostd::Guards as G;
    let pairs = [
        (FUSION_GUARD_ADF_ZERO_COVARIANCE, G::ADF_ZERO_COVARIANCE),
        (FUSION_GUARD_ADF_DEGENERATE_EIGENVECTOR, G::ADF_DEGENERATE_EIGENVECTOR),
        (FUSION_GUARD_ADF_WEIGHT_CLAMPED, G::ADF_WEIGHT_CLAMPED),
        (FUSION_GUARD_TSIFSD_ZERO_SALIENCY, G::TSIFSD_ZERO_SALIENCY),
        (FUSION_GUARD_IFEVIP_ZERO_ENTROPY, G::IFEVIP_ZERO_ENTROPY),
        (FUSION_GUARD_IFEVIP_FEW_PIXELS, G::IFEVIP_FEW_PIXELS),
        (FUSION_GUARD_IFEVIP_ZERO_PEAK, G::IFEVIP_ZERO_PEAK),
        (FUSION_GUARD_OUTPUT_SATURATED, G::OUTPUT_SATURATED),
        (FUSION_GUARD_ADAPTIVE_TIR_ONLY, G::ADAPTIVE_TIR_ONLY),
        (FUSION_GUARD_ADAPTIVE_GLARE, G::ADAPTIVE_GLARE),
        (FUSION_GUARD_ADAPTIVE_ADF, G::ADAPTIVE_ADF),
    ];
    assert_eq!(pairs.len(), G::NAMED.len());
    for (c, g) in pairs {
        assert_eq!(c, g.0);
    }
    assert_eq!(FUSION_STRIP_SCRATCH_BYTES, fusion_nostd::strips::STRIP_SCRATCH_BYTES);
    // The method numbers are the core's `Method::KINDS` positions.
    let kinds = [FusionMethod::Adf, FusionMethod::Tsifsd, FusionMethod::Ifevip, FusionMethod::Adaptive];
    for (kind, m) in fusion_nostd::pipeline::Method::KINDS.iter().zip(kinds) {
        assert_eq!(fusion_nostd::pipeline::Method::KINDS[m as usize], *kind);
    }
    let mut texts = std::collections::BTreeSet::new();
    for code in (0..=12).chain([255]) {
        let status = FusionStatus::from_code(code);
        assert_eq!(status as i32, code);
        let t = unsafe { core::ffi::CStr::from_ptr(fusion_status_text(code)) }.to_str().unwrap();
        assert!(texts.insert(t), "two statuses share the text {t:?}");
    }
    let unknown = unsafe { core::ffi::CStr::from_ptr(fusion_status_text(77)) };
    assert_eq!(unknown, c"unknown error");
    let version = unsafe { core::ffi::CStr::from_ptr(fusion_version()) };
    assert_eq!(version.to_str().unwrap(), env!("CARGO_PKG_VERSION"));
}

/// The thermal front end: the core's bytes for the correction (tables and map), the shutter's
/// offsets and the column filter over a sequence (smoothing in the caller's state), and the
/// refusals with nothing written.
#[test]
fn thermal_front_end_follows_the_core() {
    use fusion_nostd::thermal as t;
    let (w, h) = (37usize, 21usize);
    let n = w * h;
    let gain: Vec<u16> = (0..n).map(|i| 16_000 + (i * 131 % 800) as u16).collect();
    let offset: Vec<i16> = (0..n).map(|i| (i * 71 % 400) as i16 - 200).collect();
    let mut bits = vec![0u8; t::bad_map_bytes(w, h)];
    for i in [5usize, 40, 41, 300, 301, 302, 500] {
        bits[(i / w) * w.div_ceil(8) + (i % w) / 8] |= 1 << (i % w % 8);
    }
    let tables = FusionThermalTables {
        width: w,
        height: h,
        gain: gain.as_ptr(),
        offset: offset.as_ptr(),
        bad_pixels: bits.as_ptr(),
    };
    let core_stages = t::Correction {
        nuc: Some(t::NucTables::new(w, h, &gain, &offset).unwrap()),
        bad: Some(t::BadPixelMap::new(w, h, &bits).unwrap()),
    };
    let raw = |f: u32| -> Vec<u16> { frame(w, h, f).iter().map(|&v| 3000 + u16::from(v) * 20).collect() };
    let img16 = |d: &Vec<u16>| FusionImage16 { data: d.as_ptr(), width: w, height: h, stride: w };
    // Correction.
    let r = raw(1);
    let mut expected = vec![0u16; n];
    t::correct_frame(
        &core_stages,
        None,
        FrameRef::new(&r, w, h).unwrap(),
        FrameMut::new(&mut expected, w, h).unwrap(),
    )
    .unwrap();
    let mut got = vec![0u16; n];
    let out = FusionImageMut16 { data: got.as_mut_ptr(), width: w, height: h, stride: w };
    assert_eq!(
        unsafe { fusion_thermal_correct(&tables, &img16(&r), &out, core::ptr::null_mut()) },
        FusionStatus::Ok
    );
    assert_eq!(got, expected);
    // The shutter.
    let shutter: Vec<u16> = (0..n).map(|i| 5000 + (i * 17 % 90) as u16).collect();
    let mut core_offset = offset.clone();
    t::shutter_update(
        &gain,
        &mut core_offset,
        core_stages.bad.as_ref(),
        FrameRef::new(&shutter, w, h).unwrap(),
    )
    .unwrap();
    let mut c_offset = offset.clone();
    let st = unsafe {
        fusion_thermal_shutter(&tables, c_offset.as_mut_ptr(), &img16(&shutter), core::ptr::null_mut())
    };
    assert_eq!(st, FusionStatus::Ok);
    assert_eq!(c_offset, core_offset);
    // The column filter over three frames with smoothing.
    let params = FusionColumnParams { threshold: 300, radius: 4, smoothing: 1 };
    let core_params = t::ColumnParams { threshold: 300, radius: 4, smoothing: 1 };
    let mut state = vec![0xFFFF_FFFF_FFFF_FFFFu64; fusion_column_state_bytes().div_ceil(8)];
    let (sp, sb): (*mut core::ffi::c_void, usize) = (state.as_mut_ptr().cast(), state.len() * 8);
    assert_eq!(unsafe { fusion_column_init(sp, sb, core::ptr::null_mut()) }, FusionStatus::Ok);
    let mut core_filter = std::boxed::Box::new(t::ColumnFilter::new());
    for f in 0..3 {
        let mut a = raw(f + 10);
        let mut b = a.clone();
        t::column_filter_frame(&mut core_filter, FrameMut::new(&mut a, w, h).unwrap(), &core_params).unwrap();
        let fr = FusionImageMut16 { data: b.as_mut_ptr(), width: w, height: h, stride: w };
        assert_eq!(
            unsafe { fusion_column_frame(sp, sb, &params, &fr, core::ptr::null_mut()) },
            FusionStatus::Ok
        );
        assert_eq!(a, b, "frame {f}");
    }
    // Refusals, nothing written: gain without offsets, a map that loses whole rows, an output
    // over the input, bad column parameters, a short state.
    let mut err = FusionError::of(FusionStatus::Ok);
    let mut keep = vec![7u16; n];
    let out = FusionImageMut16 { data: keep.as_mut_ptr(), width: w, height: h, stride: w };
    let half = FusionThermalTables { offset: core::ptr::null(), ..tables };
    assert_eq!(
        unsafe { fusion_thermal_correct(&half, &img16(&r), &out, &mut err) },
        FusionStatus::InvalidParameter
    );
    let dead = vec![0xFFu8; t::bad_map_bytes(w, h)];
    let dead_tables = FusionThermalTables { bad_pixels: dead.as_ptr(), ..tables };
    assert_eq!(
        unsafe { fusion_thermal_correct(&dead_tables, &img16(&r), &out, &mut err) },
        FusionStatus::InvalidParameter
    );
    assert!(keep.iter().all(|&v| v == 7));
    let mut same = r.clone();
    let over = FusionImageMut16 { data: same.as_mut_ptr(), width: w, height: h, stride: w };
    let inp = FusionImage16 { data: same.as_ptr(), width: w, height: h, stride: w };
    assert_eq!(unsafe { fusion_thermal_correct(&tables, &inp, &over, &mut err) }, FusionStatus::Overlap);
    let bad_params = FusionColumnParams { threshold: 0, ..params };
    let fr = FusionImageMut16 { data: keep.as_mut_ptr(), width: w, height: h, stride: w };
    assert_eq!(
        unsafe { fusion_column_frame(sp, sb, &bad_params, &fr, &mut err) },
        FusionStatus::InvalidParameter
    );
    assert_eq!(unsafe { fusion_column_frame(sp, 16, &params, &fr, &mut err) }, FusionStatus::ScratchTooSmall);
    assert!(keep.iter().all(|&v| v == 7));
    let mut off = offset.clone();
    let short = vec![0u16; w * (h - 1)];
    let short_img = FusionImage16 { data: short.as_ptr(), width: w, height: h - 1, stride: w };
    assert_eq!(
        unsafe { fusion_thermal_shutter(&tables, off.as_mut_ptr(), &short_img, &mut err) },
        FusionStatus::SizeMismatch
    );
    assert_eq!(off, offset);
}

/// A small offset pair: VIS 96², TIR 48², 0.1 m baseline, mild distortion.
fn small_rig() -> FusionRig {
    let cam = |size: usize, f: f32, k1: f32| FusionCamera {
        fx: f,
        fy: f,
        cx: size as f32 / 2.0 - 0.5,
        cy: size as f32 / 2.0 - 0.5,
        dist: [k1, 0.01, 0.0005, -0.0003, 0.0],
        width: size,
        height: size,
    };
    FusionRig {
        vis: cam(96, 180.0, -0.05),
        tir: cam(48, 75.0, -0.12),
        r: [1.0, 0.0, 0.003, 0.0, 1.0, 0.0, -0.003, 0.0, 1.0],
        t: [-0.1, 0.0, 0.0],
    }
}

/// `fusion_register_u8`/`_u16` give the core's `register` bytes (scratch of the size asked
/// for, 8 and 16 bit, linear and cubic, both borders); a short or misaligned scratch, an
/// unknown interpolation, an overlap and a wrong size are refused with the output untouched.
#[test]
fn register_gives_the_core_bytes_and_refuses_bad_calls() {
    use fusion_nostd::registration::{Border, Interpolation, NODE_STEP, RigMap, node_count, register};
    let r = small_rig();
    let bytes = unsafe { fusion_register_scratch_bytes(&r) };
    assert_eq!(bytes, 8 * node_count(96, 96, NODE_STEP) + 6 * 16 * 96);
    let mut scratch = vec![0u32; bytes.div_ceil(4)];
    let tir8 = frame(48, 48, 5);
    let tir16: Vec<u16> = tir8.iter().map(|&v| u16::from(v) * 251).collect();
    let core_rig = super::registration::tests_rig(&r);
    let mut nodes = vec![[0.0f32; 2]; node_count(96, 96, NODE_STEP)];
    let map = RigMap::new(&core_rig, 6.0, NODE_STEP, &mut nodes).unwrap();
    for (interpolation, interp) in [(0u32, Interpolation::Linear), (1, Interpolation::Cubic)] {
        for (border_replicate, border) in [(0u32, Border::Constant(17)), (1, Border::Replicate)] {
            let params = FusionRegisterParams { interpolation, border_replicate, border_value: 17 };
            let (mut xy, mut frac) = (vec![0i16; 2 * 96 * 8], vec![0u16; 96 * 8]);
            let mut want8 = vec![0u8; 96 * 96];
            register(
                FrameRef::new(&tir8, 48, 48).unwrap(),
                &map,
                FrameMut::new(&mut want8, 96, 96).unwrap(),
                interp,
                border,
                &mut xy,
                &mut frac,
            )
            .unwrap();
            let mut got8 = vec![0u8; 96 * 96];
            let input = FusionImage { data: tir8.as_ptr(), width: 48, height: 48, stride: 48 };
            let output = FusionImageMut { data: got8.as_mut_ptr(), width: 96, height: 96, stride: 96 };
            let st = unsafe {
                fusion_register_u8(
                    &r,
                    6.0,
                    &params,
                    &input,
                    &output,
                    scratch.as_mut_ptr().cast(),
                    bytes,
                    core::ptr::null_mut(),
                )
            };
            assert_eq!(st, FusionStatus::Ok);
            assert_eq!(got8, want8);
            let mut want16 = vec![0u16; 96 * 96];
            register(
                FrameRef::new(&tir16, 48, 48).unwrap(),
                &map,
                FrameMut::new(&mut want16, 96, 96).unwrap(),
                interp,
                border,
                &mut xy,
                &mut frac,
            )
            .unwrap();
            let mut got16 = vec![0u16; 96 * 96];
            let input = FusionImage16 { data: tir16.as_ptr(), width: 48, height: 48, stride: 48 };
            let output = FusionImageMut16 { data: got16.as_mut_ptr(), width: 96, height: 96, stride: 96 };
            let st = unsafe {
                fusion_register_u16(
                    &r,
                    6.0,
                    &params,
                    &input,
                    &output,
                    scratch.as_mut_ptr().cast(),
                    bytes,
                    core::ptr::null_mut(),
                )
            };
            assert_eq!(st, FusionStatus::Ok);
            assert_eq!(got16, want16);
        }
    }
    let ok = FusionRegisterParams { interpolation: 0, border_replicate: 0, border_value: 0 };
    let mut out = vec![9u8; 96 * 96];
    let input = FusionImage { data: tir8.as_ptr(), width: 48, height: 48, stride: 48 };
    let output = FusionImageMut { data: out.as_mut_ptr(), width: 96, height: 96, stride: 96 };
    let call = |params: &FusionRegisterParams, scratch: *mut u8, n: usize, output: &FusionImageMut| unsafe {
        fusion_register_u8(&r, 6.0, params, &input, output, scratch, n, core::ptr::null_mut())
    };
    let sp = scratch.as_mut_ptr().cast::<u8>();
    assert_ne!(call(&ok, sp, bytes - 1, &output), FusionStatus::Ok);
    assert_eq!(call(&ok, unsafe { sp.add(1) }, bytes - 4, &output), FusionStatus::Misaligned);
    assert_ne!(call(&FusionRegisterParams { interpolation: 2, ..ok }, sp, bytes, &output), FusionStatus::Ok);
    let small = FusionImageMut { data: out.as_mut_ptr(), width: 95, height: 96, stride: 96 };
    assert_ne!(call(&ok, sp, bytes, &small), FusionStatus::Ok);
    let overlap = FusionImageMut { data: sp, width: 96, height: 96, stride: 96 };
    assert_eq!(call(&ok, sp, bytes, &overlap), FusionStatus::Overlap);
    assert!(out.iter().all(|&v| v == 9));
    let st = unsafe { fusion_register_u8(&r, -1.0, &ok, &input, &output, sp, bytes, core::ptr::null_mut()) };
    assert_ne!(st, FusionStatus::Ok);
    assert!(out.iter().all(|&v| v == 9));
}

/// Sequence mode: over five frames, for every method and variant (skip none and all), whole
/// frame and strips, the core's `fuse_in_sequence` bytes and steps frame by frame (ADF:
/// carried after the first); the state's refusals.
#[test]
fn sequences_follow_the_core() {
    use fusion_nostd::sequence::{Pass, Sequence};
    let (vs, ts) = ((96usize, 80usize), (48usize, 40usize));
    let frames: Vec<_> = (0..5).map(|k| (frame(vs.0, vs.1, 10 + k), frame(ts.0, ts.1, 20 + k))).collect();
    let (w, h) = vs;
    // The README's static state of 1 KiB holds it.
    assert!(fusion_sequence_state_bytes() <= 1024, "{}", fusion_sequence_state_bytes());
    let mut state = vec![0u64; fusion_sequence_state_bytes().div_ceil(8)];
    let state_bytes = state.len() * 8;
    let sp: *mut core::ffi::c_void = state.as_mut_ptr().cast();
    let most = (0..4).map(|m| core_pipeline(m, 0, 0, 0).scratch_pixels(vs, ts).unwrap()).max().unwrap();
    let mut s = scratch(FUSION_STRIP_SCRATCH_BYTES.max(most * 13));
    let sbytes = s.len() * 4;
    for method in 0..4 {
        for variant in 0..2 {
            for (skip, strips) in [(0, false), (2, false), (0, true)] {
                let cfg = config(method, variant, 0, skip);
                let core_cfg = core_pipeline(method, variant, 0, skip);
                let mut core_seq = Sequence::default();
                assert_eq!(
                    unsafe { fusion_sequence_init(sp, state_bytes, 150, 5, core::ptr::null_mut()) },
                    FusionStatus::Ok
                );
                for (k, (vis, tir)) in frames.iter().enumerate() {
                    let pixels = core_cfg.scratch_pixels(vs, ts).unwrap();
                    let (mut a, mut b, mut c, mut band) =
                        (vec![0; pixels], vec![0; pixels], vec![0; pixels], vec![0; pixels]);
                    let mut planes = fusion_nostd::ScratchMut::with_band([&mut a, &mut b, &mut c], &mut band);
                    let mut expected = vec![0u8; w * h];
                    fusion_nostd::fuse_in_sequence(
                        FrameRef::new(vis, vs.0, vs.1).unwrap(),
                        FrameRef::new(tir, ts.0, ts.1).unwrap(),
                        FrameMut::new(&mut expected, w, h).unwrap(),
                        &mut planes,
                        &core_cfg,
                        &mut core_seq,
                    )
                    .unwrap();
                    let want = core_seq.last_step().unwrap();
                    let mut out = vec![0u8; w * h];
                    let mut step = core::mem::MaybeUninit::<FusionSequenceStep>::uninit();
                    let (vi, ti, oi) = (
                        image(vis, vs.0, vs.1, vs.0),
                        image(tir, ts.0, ts.1, ts.0),
                        image_mut(&mut out, w, h, w),
                    );
                    let st = unsafe {
                        if strips {
                            fusion_fuse_strips_in_sequence(
                                sp,
                                state_bytes,
                                &cfg,
                                &vi,
                                &ti,
                                &oi,
                                s.as_mut_ptr().cast(),
                                FUSION_STRIP_SCRATCH_BYTES,
                                23,
                                core::ptr::null_mut(),
                                step.as_mut_ptr(),
                                core::ptr::null_mut(),
                            )
                        } else {
                            fusion_fuse_in_sequence(
                                sp,
                                state_bytes,
                                &cfg,
                                &vi,
                                &ti,
                                &oi,
                                s.as_mut_ptr().cast(),
                                sbytes,
                                core::ptr::null_mut(),
                                step.as_mut_ptr(),
                                core::ptr::null_mut(),
                            )
                        }
                    };
                    assert_eq!(st, FusionStatus::Ok, "{cfg:?} frame {k}");
                    assert_eq!(out, expected, "{cfg:?} strips {strips} frame {k}");
                    let step = unsafe { step.assume_init() };
                    let pass = match want.pass {
                        Pass::Carried => FusionPass::Carried,
                        Pass::Own(_) => FusionPass::Own,
                        Pass::PerFrame => FusionPass::PerFrame,
                    };
                    assert_eq!(step.pass, pass as u32, "{cfg:?} frame {k}");
                    assert_eq!(
                        (step.pixels, step.p_ir_used_q30, step.p_ir_own_q30),
                        (want.pixels, want.p_ir_used_q30, want.p_ir_own_q30)
                    );
                    if method == 0 && skip == 0 {
                        let first = if k == 0 { FusionPass::Own } else { FusionPass::Carried };
                        assert_eq!(step.pass, first as u32, "{cfg:?} frame {k}");
                        assert_eq!(step.restart, if k == 0 { FusionRestart::First as u32 } else { 0 });
                    }
                }
            }
        }
    }
    // Refusals: an uninitialised state, a misaligned or short one, bad parameters.
    let mut err = FusionError::of(FusionStatus::Ok);
    let (vis, tir) = &frames[0];
    let mut out = vec![0u8; w * h];
    let cfg = config(0, 0, 0, 0);
    let mut call = |ptr: *mut core::ffi::c_void, bytes: usize, err: &mut FusionError| unsafe {
        fusion_fuse_in_sequence(
            ptr,
            bytes,
            &cfg,
            &image(vis, vs.0, vs.1, vs.0),
            &image(tir, ts.0, ts.1, ts.0),
            &image_mut(&mut out, w, h, w),
            s.as_mut_ptr().cast(),
            sbytes,
            core::ptr::null_mut(),
            core::ptr::null_mut(),
            err,
        )
    };
    let mut fresh = vec![0u64; state.len()];
    assert_eq!(call(fresh.as_mut_ptr().cast(), state_bytes, &mut err), FusionStatus::InvalidParameter);
    assert_eq!(name(&err), "sequence state");
    assert_eq!(call(sp, state_bytes - 8, &mut err), FusionStatus::ScratchTooSmall);
    let odd = unsafe { sp.cast::<u8>().add(4).cast() };
    assert_eq!(call(odd, state_bytes - 8, &mut err), FusionStatus::Misaligned);
    assert_eq!(call(core::ptr::null_mut(), state_bytes, &mut err), FusionStatus::NullPointer);
    let init = |pct: u32, frames: u32, err: &mut FusionError| unsafe {
        fusion_sequence_init(sp, state_bytes, pct, frames, err)
    };
    assert_eq!(init(99, 5, &mut err), FusionStatus::InvalidParameter);
    assert_eq!(name(&err), "size_change_percent");
    assert_eq!(init(150, 9, &mut err), FusionStatus::InvalidParameter);
    assert_eq!(name(&err), "window_frames");
}
