//! Issue 9, bad input everywhere: every case of the core's input contract gives a specific,
//! documented `Err` (or, where the input is valid however unusual, a correct `Ok`), never a
//! panic. The table of cases and outcomes is in `fusion-nostd`'s crate docs ("Robustness").

use fusion_engine::CoreScratch;
use fusion_io::Gray;
use fusion_nostd::methods::adf::{fuse_adf, fuse_adf_raw};
use fusion_nostd::methods::ifevip::{self, fuse_ifevip};
use fusion_nostd::methods::tsifsd::{fuse_tsifsd, fuse_tsifsd_raw};
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, fuse, fuse_method, fuse_raw};
use fusion_nostd::rescalers::F32_MAX_MAGNITUDE;
use fusion_nostd::{
    AdaptiveParams, AdfParams, Error, Filter, FrameMut, FrameRef, IfevipParams, MAX_DIMENSION, ScratchMut,
    TsifsdParams, Variant, rescale,
};
use fusion_tests::{TestRng, scene};

fn methods() -> [Method; 7] {
    let (c, f) = (Variant::Classic, Variant::Flight);
    [
        Method::Adf(AdfParams { variant: c, ..AdfParams::default() }),
        Method::Adf(AdfParams { variant: f, ..AdfParams::default() }),
        Method::Tsifsd(TsifsdParams { variant: c, ..TsifsdParams::default() }),
        Method::Tsifsd(TsifsdParams { variant: f, ..TsifsdParams::default() }),
        Method::Ifevip(IfevipParams { variant: c, ..IfevipParams::default() }),
        Method::Ifevip(IfevipParams { variant: f, ..IfevipParams::default() }),
        Method::Adaptive(AdaptiveParams::default()),
    ]
}

/// Scratch sized for `pipeline` on these input sizes.
fn scratch_for(p: &FuseConfig, vis: (usize, usize), tir: (usize, usize)) -> CoreScratch {
    CoreScratch::new(p.scratch_pixels(vis, tir).expect("scratch size"))
}

/// Runs the pipeline on packed frames (the grid is the output size given).
fn run(vis: &Gray<u8>, tir: &Gray<u8>, out_size: (usize, usize), p: &FuseConfig) -> Result<Gray<u8>, Error> {
    let pixels = p.scratch_pixels((vis.width, vis.height), (tir.width, tir.height)).unwrap_or(1);
    let mut scratch = CoreScratch::new(pixels);
    let mut out = Gray::new(out_size.0, out_size.1);
    fuse(vis.view().unwrap(), tir.view().unwrap(), out.view_mut().unwrap(), &mut scratch.view_mut(), p)?;
    Ok(out)
}

#[test]
fn views_reject_bad_geometry() {
    let buf = vec![0u8; 64];
    assert_eq!(FrameRef::new(&buf, 0, 4).err(), Some(Error::ZeroDimension));
    assert_eq!(FrameRef::new(&buf, 4, 0).err(), Some(Error::ZeroDimension));
    assert_eq!(FrameRef::new(&buf, 0, 0).err(), Some(Error::ZeroDimension));
    assert_eq!(
        FrameRef::with_stride(&buf, 8, 4, 7).err(),
        Some(Error::StrideTooSmall { stride: 7, width: 8 })
    );
    assert_eq!(
        FrameRef::with_stride(&buf, 8, 4, 0).err(),
        Some(Error::StrideTooSmall { stride: 0, width: 8 })
    );
    assert_eq!(FrameRef::new(&buf, 9, 8).err(), Some(Error::BufferTooSmall { needed: 72, got: 64 }));
    // A stride so large that (height − 1)·stride + width overflows `usize`.
    assert!(matches!(
        FrameRef::with_stride(&buf, 1, 3, usize::MAX / 2 + 1),
        Err(Error::BufferTooSmall { .. })
    ));
    for (w, h) in [(MAX_DIMENSION + 1, 1), (1, MAX_DIMENSION + 1), (usize::MAX, 1), (1, usize::MAX)] {
        let value = w.max(h);
        assert_eq!(FrameRef::new(&buf, w, h).err(), Some(Error::DimensionTooLarge { value }), "{w}x{h}");
    }
    let mut out = vec![0u8; 64];
    assert_eq!(FrameMut::new(&mut out, 0, 1).err(), Some(Error::ZeroDimension));
    assert_eq!(
        FrameMut::with_stride(&mut out, 5, 2, 4).err(),
        Some(Error::StrideTooSmall { stride: 4, width: 5 })
    );
    assert_eq!(FrameMut::new(&mut out, 65, 1).err(), Some(Error::BufferTooSmall { needed: 65, got: 64 }));
    // The last row needs only `width` elements, not a whole stride.
    assert!(FrameRef::with_stride(&buf, 4, 4, 20).is_ok());
    assert!(FrameRef::with_stride(&buf, 5, 4, 20).is_err());
}

/// Every method, called directly and through the pipeline: VIS, TIR and the output must share
/// one size (policy `None`, or a wrong output size for the grid).
#[test]
fn mismatched_sizes_are_size_mismatch() {
    let (a, b) = (scene(24, 16, 1), scene(24, 15, 2));
    for method in methods() {
        let mut scratch = CoreScratch::new(ifevip::scratch_pixels(24, 16, &IfevipParams::default()));
        let mut out = Gray::<u8>::new(24, 16);
        let r = fuse_method(
            a.view().unwrap(),
            b.view().unwrap(),
            out.view_mut().unwrap(),
            &method,
            &mut scratch.view_mut(),
        );
        assert_eq!(r, Err(Error::SizeMismatch { expected: (24, 16), got: (24, 15) }), "{method:?}");
        let mut small = Gray::<u8>::new(23, 16);
        let r = fuse_method(
            a.view().unwrap(),
            a.view().unwrap(),
            small.view_mut().unwrap(),
            &method,
            &mut scratch.view_mut(),
        );
        assert!(matches!(r, Err(Error::SizeMismatch { .. })), "{method:?} {r:?}");

        let none = FuseConfig { rescale: RescalePolicy::None, method, ..Default::default() };
        assert_eq!(
            run(&a, &b, (24, 16), &none),
            Err(Error::SizeMismatch { expected: (24, 16), got: (24, 15) })
        );
        for (policy, wrong) in [(RescalePolicy::TirUp, (12, 8)), (RescalePolicy::VisDown, (24, 16))] {
            let tir = scene(12, 8, 3);
            let p = FuseConfig { rescale: policy, method, ..Default::default() };
            assert!(
                matches!(run(&a, &tir, wrong, &p), Err(Error::SizeMismatch { got, .. }) if got == wrong),
                "{policy:?} {method:?}"
            );
        }
    }
    // The pre-cast entries check the output size as well.
    let mut scratch = CoreScratch::new(24 * 16);
    let mut raw = Gray::<i32>::new(24, 15);
    let p = AdfParams::default();
    let r = fuse_adf_raw(
        a.view().unwrap(),
        a.view().unwrap(),
        raw.view_mut().unwrap(),
        &p,
        &mut scratch.view_mut(),
    );
    assert!(matches!(r, Err(Error::SizeMismatch { .. })), "{r:?}");
    let p = TsifsdParams::default();
    let r = fuse_tsifsd_raw(
        a.view().unwrap(),
        a.view().unwrap(),
        raw.view_mut().unwrap(),
        &p,
        &mut scratch.view_mut(),
    );
    assert!(matches!(r, Err(Error::SizeMismatch { .. })), "{r:?}");
}

/// Scratch one pixel short of what a method needs is `ScratchTooSmall` with the exact numbers;
/// the pipeline also needs the band plane when it rescales.
#[test]
fn scratch_too_small_is_reported_with_the_numbers() {
    let (w, h) = (31, 17);
    let (vis, tir) = (scene(w, h, 1), scene(w, h, 2));
    for method in methods() {
        let p = FuseConfig { rescale: RescalePolicy::None, method, ..Default::default() };
        let needed = p.scratch_pixels((w, h), (w, h)).unwrap();
        let mut scratch = CoreScratch::new(needed - 1);
        let mut out = Gray::<u8>::new(w, h);
        let r = fuse(
            vis.view().unwrap(),
            tir.view().unwrap(),
            out.view_mut().unwrap(),
            &mut scratch.view_mut(),
            &p,
        );
        assert_eq!(r.err(), Some(Error::ScratchTooSmall { needed, capacity: needed - 1 }), "{method:?}");
        // Empty scratch.
        let mut none = ScratchMut::from_slices([&mut [], &mut [], &mut []]);
        let r = fuse(vis.view().unwrap(), tir.view().unwrap(), out.view_mut().unwrap(), &mut none, &p);
        assert_eq!(r.err(), Some(Error::ScratchTooSmall { needed, capacity: 0 }), "{method:?}");
        // Planes of different lengths: the shortest counts.
        let (mut p0, mut p1, mut p2) = (vec![0i32; needed], vec![0i32; needed - 2], vec![0i32; needed + 5]);
        let mut uneven = ScratchMut::from_slices([&mut p0, &mut p1, &mut p2]);
        let r = fuse(vis.view().unwrap(), tir.view().unwrap(), out.view_mut().unwrap(), &mut uneven, &p);
        assert_eq!(r.err(), Some(Error::ScratchTooSmall { needed, capacity: needed - 2 }), "{method:?}");
    }
    // A rescaling pipeline without a band plane (work planes from `from_slices`).
    let small_tir = scene(16, 9, 3);
    let p = FuseConfig { rescale: RescalePolicy::TirUp, method: Method::default(), ..Default::default() };
    let (mut p0, mut p1, mut p2) = (vec![0i32; w * h], vec![0i32; w * h], vec![0i32; w * h]);
    let mut no_band = ScratchMut::from_slices([&mut p0, &mut p1, &mut p2]);
    let mut out = Gray::<u8>::new(w, h);
    let r = fuse(vis.view().unwrap(), small_tir.view().unwrap(), out.view_mut().unwrap(), &mut no_band, &p);
    assert_eq!(r.err(), Some(Error::ScratchTooSmall { needed: w * h, capacity: 0 }));
}

/// Frames over the capacity of the core: a side above `MAX_DIMENSION` cannot even be viewed,
/// and `FuseConfig::scratch_pixels` refuses such sizes instead of overflowing.
#[test]
fn frames_over_the_capacity() {
    for method in methods() {
        let p = FuseConfig { rescale: RescalePolicy::TirUp, method, ..Default::default() };
        for (vis, tir) in [
            ((MAX_DIMENSION + 1, 1), (1, 1)),
            ((1, 1), (1, MAX_DIMENSION + 1)),
            ((usize::MAX, usize::MAX), (1, 1)),
            ((usize::MAX / 2, 1), (1, 1)),
        ] {
            assert!(
                matches!(p.scratch_pixels(vis, tir), Err(Error::DimensionTooLarge { .. })),
                "{method:?} {vis:?} {tir:?}: {:?}",
                p.scratch_pixels(vis, tir)
            );
        }
        assert!(matches!(p.scratch_pixels((0, 5), (1, 1)), Err(Error::ZeroDimension)));
        // The largest frame the core accepts needs a known, finite scratch.
        let big = p.scratch_pixels((MAX_DIMENSION, MAX_DIMENSION), (MAX_DIMENSION / 2, MAX_DIMENSION / 2));
        assert!(big.is_ok_and(|n| n >= MAX_DIMENSION * MAX_DIMENSION), "{method:?}");
    }
}

/// Valid but unusual geometry: one pixel, one row, one column, odd sizes, the widest and the
/// tallest frame the core accepts. Every method and variant fuses them (`Ok`), on packed and on
/// strided views with the same result, and deterministically.
#[test]
fn tiny_odd_wide_and_tall_frames_fuse() {
    let sizes = [
        (1, 1),
        (1, 2),
        (2, 1),
        (2, 2),
        (3, 3),
        (1, 9),
        (9, 1),
        (5, 3),
        (3, 5),
        (37, 23),
        (MAX_DIMENSION, 1),
        (1, MAX_DIMENSION),
        (MAX_DIMENSION, 2),
        (3, MAX_DIMENSION),
    ];
    let mut rng = TestRng::new(9);
    for (w, h) in sizes {
        let (vis, tir) = (rng.image_u8(w, h), rng.image_u8(w, h));
        for method in methods() {
            let p = FuseConfig { rescale: RescalePolicy::None, method, ..Default::default() };
            let packed = run(&vis, &tir, (w, h), &p).unwrap_or_else(|e| panic!("{w}x{h} {method:?}: {e}"));
            assert_eq!(run(&vis, &tir, (w, h), &p).unwrap(), packed, "{w}x{h} {method:?}: deterministic");
            // The same frames in strided buffers (stride = width + 3, garbage in the gaps).
            let stride = w + 3;
            let spread = |g: &Gray<u8>| {
                let mut buf = vec![0xA5u8; stride * h];
                for (y, row) in g.data.chunks(w).enumerate() {
                    buf[y * stride..y * stride + w].copy_from_slice(row);
                }
                buf
            };
            let (vbuf, tbuf) = (spread(&vis), spread(&tir));
            let mut obuf = vec![0x5Au8; stride * h];
            let mut scratch = scratch_for(&p, (w, h), (w, h));
            fuse(
                FrameRef::with_stride(&vbuf, w, h, stride).unwrap(),
                FrameRef::with_stride(&tbuf, w, h, stride).unwrap(),
                FrameMut::with_stride(&mut obuf, w, h, stride).unwrap(),
                &mut scratch.view_mut(),
                &p,
            )
            .unwrap();
            for y in 0..h {
                assert_eq!(
                    &obuf[y * stride..y * stride + w],
                    &packed.data[y * w..(y + 1) * w],
                    "{w}x{h} {method:?}"
                );
                assert!(obuf[y * stride + w..(y + 1) * stride].iter().all(|&v| v == 0x5A), "gap written");
            }
        }
    }
}

/// The pipeline with rescale on odd and degenerate size pairs (not 2:1, one side 1, TIR larger
/// than VIS): every method and both policies give `Ok`.
#[test]
fn rescaling_pipeline_on_odd_size_pairs() {
    let pairs = [
        ((1, 1), (1, 1)),
        ((2, 2), (1, 1)),
        ((1, 1), (2, 2)),
        ((7, 1), (3, 1)),
        ((1, 7), (1, 3)),
        ((33, 21), (17, 11)),
        ((20, 20), (31, 7)),
    ];
    let mut rng = TestRng::new(3);
    for ((vw, vh), (tw, th)) in pairs {
        let (vis, tir) = (rng.image_u8(vw, vh), rng.image_u8(tw, th));
        for method in methods() {
            for (policy, grid) in [(RescalePolicy::TirUp, (vw, vh)), (RescalePolicy::VisDown, (tw, th))] {
                let p = FuseConfig { rescale: policy, method, ..Default::default() };
                let r = run(&vis, &tir, grid, &p);
                assert!(r.is_ok(), "{vw}x{vh} / {tw}x{th} {policy:?} {method:?}: {r:?}");
            }
        }
    }
}

#[test]
fn invalid_parameters_name_the_field() {
    let (vis, tir) = (scene(16, 16, 1), scene(16, 16, 2));
    let adf = AdfParams::default();
    let ts = TsifsdParams::default();
    let ife = IfevipParams::default();
    let cases: Vec<(Method, &str)> = vec![
        (Method::Adf(AdfParams { iterations: 0, ..adf }), "iterations"),
        (Method::Adf(AdfParams { iterations: 1001, ..adf }), "iterations"),
        (Method::Adf(AdfParams { dt_milli: 0, ..adf }), "dt_milli"),
        (Method::Adf(AdfParams { dt_milli: 251, ..adf }), "dt_milli"),
        (Method::Adf(AdfParams { kappa: 0, ..adf }), "kappa"),
        (Method::Adf(AdfParams { kappa: 256, ..adf }), "kappa"),
        (Method::Tsifsd(TsifsdParams { mean_size: 0, ..ts }), "mean_size"),
        (Method::Tsifsd(TsifsdParams { mean_size: 34, ..ts }), "mean_size"),
        (Method::Tsifsd(TsifsdParams { mean_size: 65, ..ts }), "mean_size"),
        (Method::Ifevip(IfevipParams { quad_norm_dim: 500, ..ife }), "quad_norm_dim"),
        (Method::Ifevip(IfevipParams { quad_norm_dim: 2048, ..ife }), "quad_norm_dim"),
        (Method::Ifevip(IfevipParams { quad_min_dim: 2, ..ife }), "quad_min_dim"),
        (Method::Ifevip(IfevipParams { quad_min_dim: 8, ..ife }), "quad_min_dim"),
        (Method::Ifevip(IfevipParams { erode_size: 0, ..ife }), "erode_size"),
        (Method::Ifevip(IfevipParams { gauss_size: 8, ..ife }), "gauss_size"),
        (Method::Ifevip(IfevipParams { top_ppm: 0, ..ife }), "top_ppm"),
        (Method::Ifevip(IfevipParams { gain_cap_percent: 101, ..ife }), "gain_cap_percent"),
    ];
    for (method, name) in cases {
        let p = FuseConfig { rescale: RescalePolicy::None, method, ..Default::default() };
        let mut scratch = CoreScratch::new(ifevip::scratch_pixels(16, 16, &ife));
        let mut out = Gray::<u8>::new(16, 16);
        let r = fuse(
            vis.view().unwrap(),
            tir.view().unwrap(),
            out.view_mut().unwrap(),
            &mut scratch.view_mut(),
            &p,
        );
        assert_eq!(r.err(), Some(Error::InvalidParameter { name }), "{method:?}");
    }
    // IFEVIP has no pre-cast value.
    let p = FuseConfig { rescale: RescalePolicy::None, method: Method::Ifevip(ife), ..Default::default() };
    let mut scratch = CoreScratch::new(ifevip::scratch_pixels(16, 16, &ife));
    let mut raw = Gray::<i32>::new(16, 16);
    let r = fuse_raw(
        vis.view().unwrap(),
        tir.view().unwrap(),
        raw.view_mut().unwrap(),
        &mut scratch.view_mut(),
        &p,
    );
    assert_eq!(r.err(), Some(Error::InvalidParameter { name: "method" }));
}

/// The direct method entries on the smallest frames with the smallest scratch they accept.
#[test]
fn direct_entries_on_one_pixel() {
    let one = [200u8];
    let other = [3u8];
    for variant in [Variant::Classic, Variant::Flight] {
        let mut p = [vec![0i32; 1], vec![0i32; 1], vec![0i32; 1]];
        let [a, b, c] = &mut p;
        let mut s = ScratchMut::from_slices([a, b, c]);
        let mut out = [0u8];
        let (v, t) = (FrameRef::new(&one, 1, 1).unwrap(), FrameRef::new(&other, 1, 1).unwrap());
        let adf = AdfParams { variant, ..AdfParams::default() };
        fuse_adf(v, t, FrameMut::new(&mut out, 1, 1).unwrap(), &adf, &mut s).unwrap();
        let ts = TsifsdParams { variant, ..TsifsdParams::default() };
        fuse_tsifsd(v, t, FrameMut::new(&mut out, 1, 1).unwrap(), &ts, &mut s).unwrap();
        let ife = IfevipParams { variant, ..IfevipParams::default() };
        let r = fuse_ifevip(v, t, FrameMut::new(&mut out, 1, 1).unwrap(), &ife, &mut s);
        let needed = ifevip::scratch_pixels(1, 1, &ife);
        assert_eq!(r, Err(Error::ScratchTooSmall { needed, capacity: 1 }));
    }
}

fn rescale_f32(
    src: &[f32],
    sw: usize,
    sh: usize,
    dw: usize,
    dh: usize,
    filter: Filter,
) -> (Result<(), Error>, Vec<f32>) {
    let mut out = vec![-7.0f32; dw * dh];
    let r = rescale(FrameRef::new(src, sw, sh).unwrap(), FrameMut::new(&mut out, dw, dh).unwrap(), filter);
    (r, out)
}

/// The f32 rescaler: NaN and ±Inf are `NonFinite`; magnitudes above `F32_MAX_MAGNITUDE` (where
/// the filter's overshoot could overflow to ±Inf) are `ValueOutOfRange`; the destination is left
/// untouched on error. Denormals and the largest accepted magnitude give finite output.
#[test]
fn f32_rescale_rejects_non_finite_and_huge_values() {
    let sizes = [(4usize, 4usize, 8usize, 8usize), (8, 8, 4, 4), (5, 3, 7, 2), (4, 4, 4, 4), (1, 1, 3, 3)];
    for filter in [Filter::Cubic, Filter::Area] {
        for (sw, sh, dw, dh) in sizes {
            let n = sw * sh;
            for (bad, want) in [
                (f32::NAN, Error::NonFinite),
                (f32::INFINITY, Error::NonFinite),
                (f32::NEG_INFINITY, Error::NonFinite),
                (-f32::NAN, Error::NonFinite),
                (f32::MAX, Error::ValueOutOfRange),
                (f32::MIN, Error::ValueOutOfRange),
                (F32_MAX_MAGNITUDE * 1.0001, Error::ValueOutOfRange),
            ] {
                let mut src = vec![1.0f32; n];
                src[n - 1] = bad;
                let (r, out) = rescale_f32(&src, sw, sh, dw, dh, filter);
                assert_eq!(r, Err(want), "{filter:?} {sw}x{sh}->{dw}x{dh} {bad}");
                assert!(out.iter().all(|&v| v == -7.0), "dst untouched on error");
            }
            // The extremes that are accepted: the largest magnitude in a max-contrast
            // checkerboard (worst overshoot), denormals, signed zeros.
            let board: Vec<f32> = (0..n)
                .map(|i| if (i % sw + i / sw) % 2 == 0 { F32_MAX_MAGNITUDE } else { -F32_MAX_MAGNITUDE })
                .collect();
            let denormal: Vec<f32> = (0..n)
                .map(|i| if i % 2 == 0 { f32::from_bits(1) } else { -f32::MIN_POSITIVE / 3.0 })
                .collect();
            let zeros: Vec<f32> = (0..n).map(|i| if i % 2 == 0 { 0.0 } else { -0.0 }).collect();
            for src in [board, denormal, zeros] {
                let (r, out) = rescale_f32(&src, sw, sh, dw, dh, filter);
                assert_eq!(r, Ok(()), "{filter:?} {sw}x{sh}->{dw}x{dh}");
                assert!(out.iter().all(|v| v.is_finite()), "{filter:?} {sw}x{sh}->{dw}x{dh}: {out:?}");
            }
        }
    }
}

/// The integer rescalers accept their whole sample range (there is no bit-depth parameter:
/// a u16 frame is full 16-bit) and saturate instead of wrapping.
#[test]
fn integer_rescalers_saturate_at_the_extremes() {
    for filter in [Filter::Cubic, Filter::Area] {
        for (sw, sh, dw, dh) in [(4usize, 4usize, 8usize, 8usize), (8, 8, 4, 4), (5, 3, 9, 7), (6, 6, 1, 1)] {
            let board8: Vec<u8> =
                (0..sw * sh).map(|i| if (i % sw + i / sw) % 2 == 0 { 255 } else { 0 }).collect();
            let mut out8 = vec![0u8; dw * dh];
            rescale(
                FrameRef::new(&board8, sw, sh).unwrap(),
                FrameMut::new(&mut out8, dw, dh).unwrap(),
                filter,
            )
            .unwrap();
            let board16: Vec<u16> = board8.iter().map(|&v| if v == 255 { u16::MAX } else { 0 }).collect();
            let mut out16 = vec![0u16; dw * dh];
            rescale(
                FrameRef::new(&board16, sw, sh).unwrap(),
                FrameMut::new(&mut out16, dw, dh).unwrap(),
                filter,
            )
            .unwrap();
            // Saturation, not wrap-around: where the u8 result is 255 (or 0) the u16 one is the
            // top (or the bottom) of its range too.
            for (a, b) in out8.iter().zip(&out16) {
                if *a == 255 {
                    assert!(*b >= 65535 - 257, "{filter:?}: u8 {a} vs u16 {b}");
                }
                if *a == 0 {
                    assert!(*b <= 257, "{filter:?}: u8 {a} vs u16 {b}");
                }
            }
            let full = vec![u16::MAX; sw * sh];
            rescale(
                FrameRef::new(&full, sw, sh).unwrap(),
                FrameMut::new(&mut out16, dw, dh).unwrap(),
                filter,
            )
            .unwrap();
            assert!(out16.iter().all(|&v| v == u16::MAX), "{filter:?}: constant 65535 stays");
        }
    }
}
