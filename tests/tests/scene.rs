//! Scene skipping (`SkipPolicy::Roi`/`All`): the pixels of the reported ROI are bit-identical
//! to the unskipped run for every method and variant, on rendered and synthetic frames; the
//! error outside is measured; real scenes (VIFB) make the analysis decline; a black VIS is an
//! eclipse; bad input is still an `Err`.

use anyhow::Result;
use fusion_engine::skip::{first_difference_in, fuse_crop, fuse_once, skip_error};
use fusion_engine::study::Dataset;
use fusion_io::{Gray, vifb_pairs};
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, SkipPolicy, Skips};
use fusion_nostd::scene::{Decline, Illumination, Rect, SceneParams, analyze};
use fusion_nostd::{AdaptiveParams, AdfParams, Error, Guards, IfevipParams, TsifsdParams};
use render_host::{DatasetConfig, render_dataset};

/// Every method and variant (ADF, TSIFSD, IFEVIP classic and flight; the adaptive method).
fn methods() -> Vec<(&'static str, Method)> {
    Method::all().into_iter().map(|m| (m.name(), m)).collect()
}

fn pipeline(method: Method, rescale: RescalePolicy, skip: SkipPolicy) -> FuseConfig {
    FuseConfig { rescale, method, skip, ..FuseConfig::default() }
}

/// What one comparison found.
struct Outcome {
    /// The method the frame ran (the adaptive method's large-target frames are ADF's).
    ran: Method,
    taken: Skips,
    roi: Rect,
    computed: Rect,
    psnr: f64,
    declined: Option<Decline>,
}

/// Fuses with `skip` and without; asserts the ROI (and, when the report says so, the whole
/// frame) is bit-identical and the computed window covers the ROI.
fn check(
    name: &str,
    vis: &Gray<u8>,
    tir: &Gray<u8>,
    method: Method,
    rescale: RescalePolicy,
    skip: SkipPolicy,
) -> Result<Outcome> {
    let (full, full_report, _) = fuse_once(vis, tir, &pipeline(method, rescale, SkipPolicy::None))?;
    let (got, report, _) = fuse_once(vis, tir, &pipeline(method, rescale, skip))?;
    let s = report.skip;
    let adf = Guards::ADAPTIVE_ADF;
    assert_eq!(report.guards.contains(adf), full_report.guards.contains(adf), "{name}: one decision");
    let ran = match method {
        Method::Adaptive(p) if report.guards.contains(adf) => Method::Adf(p.adf),
        m => m,
    };
    let method = ran;
    assert!(s.computed.covers(&s.roi), "{name}: computed {:?} does not cover roi {:?}", s.computed, s.roi);
    let grid = Rect::full(report.grid);
    assert!(grid.covers(&s.computed), "{name}: window {:?} outside the grid", s.computed);
    if s.taken.contains(Skips::CROP) {
        // Frame-global methods: the ROI is the fusion of the crop, not of the whole frame.
        assert!(method.frame_global(), "{name}: crop semantics for a local method");
        let reference = fuse_crop(vis, tir, &pipeline(method, rescale, skip), s.computed)?;
        assert_eq!(
            first_difference_in(&got, &reference, s.roi),
            None,
            "{name} {skip:?}: ROI {:?} is not the fusion of the crop {:?}",
            s.roi,
            s.computed
        );
        assert!(!s.exact_outside, "{name}: a crop cannot be exact outside");
    } else if !s.taken.contains(Skips::ECLIPSE_VIS) {
        assert_eq!(first_difference_in(&got, &full, s.roi), None, "{name} {skip:?}: ROI {:?} differs", s.roi);
        if s.exact_outside {
            assert_eq!(got.data, full.data, "{name} {skip:?}: report claims exact outside the ROI");
        }
    }
    if s.declined.is_some() {
        assert_eq!(got.data, full.data, "{name}: declined but the output changed");
        assert_eq!(report.guards, full_report.guards);
    }
    if s.roi == grid && !s.taken.contains(Skips::ECLIPSE_VIS) {
        assert_eq!(report.guards, full_report.guards, "{name}: guards of an unskipped frame");
    }
    let e = skip_error(&got, &full);
    if let Some(bg) = s.background {
        // Outside the window every pixel is the background value (outside the ROI for the
        // frame-global methods).
        let written = if method.frame_global() { s.roi } else { s.computed };
        for (i, &v) in got.data.iter().enumerate() {
            let (x, y) = (i % got.width, i / got.width);
            if !written.contains(x, y) {
                assert_eq!(v, bg, "{name}: ({x}, {y}) outside the window is not the background");
            }
        }
    }
    println!(
        "{name:>40} {skip:?}: roi {:?} computed {}/{} px, taken {:?}, declined {:?}, max abs {}, psnr {:.1} dB",
        (s.roi.x0, s.roi.y0, s.roi.x1, s.roi.y1),
        s.computed.area(),
        grid.area(),
        s.taken,
        s.declined,
        e.max_abs,
        e.psnr
    );
    Ok(Outcome { ran, taken: s.taken, roi: s.roi, computed: s.computed, psnr: e.psnr, declined: s.declined })
}

/// A dark frame with a textured bright target and optional ±1..2 noise (deterministic).
fn synthetic(w: usize, h: usize, target: Rect, level: u8, noise: u32, seed: u32) -> Gray<u8> {
    let mut g = Gray::new(w, h);
    let mut s = seed.wrapping_mul(2654435761).wrapping_add(1);
    for y in 0..h {
        for x in 0..w {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let n = if noise == 0 { 0 } else { (s % (2 * noise + 1)) as i32 - noise as i32 };
            let v = if target.contains(x, y) {
                level as i32 + ((x * 7 + y * 3) % 40) as i32 + if (x / 4 + y / 4) % 2 == 0 { 30 } else { 0 }
            } else {
                3
            };
            g.data[y * w + x] = (v + n).clamp(0, 255) as u8;
        }
    }
    g
}

#[test]
fn synthetic_frames_roi_is_bit_identical_for_every_method() -> Result<()> {
    let vis_t = Rect { x0: 70, y0: 60, x1: 110, y1: 100 };
    let tir_t = Rect { x0: 36, y0: 31, x1: 54, y1: 49 };
    let mut took_roi = 0;
    for noise in [0, 1] {
        let vis = synthetic(192, 160, vis_t, 90, noise, 1);
        let tir = synthetic(96, 80, tir_t, 120, noise, 2);
        let tir_same = synthetic(192, 160, vis_t, 120, noise, 3);
        for (name, method) in methods() {
            for skip in [SkipPolicy::Roi, SkipPolicy::All] {
                for (label, v, t, rescale) in [
                    ("tir-up", &vis, &tir, RescalePolicy::TirUp),
                    ("vis-down", &vis, &tir, RescalePolicy::VisDown),
                    ("same-grid", &vis, &tir_same, RescalePolicy::None),
                ] {
                    let o = check(
                        &format!("synthetic noise {noise} {label} {name}"),
                        v,
                        t,
                        method,
                        rescale,
                        skip,
                    )?;
                    if o.taken.contains(Skips::ROI) {
                        took_roi += 1;
                        // The target itself is always inside the exact ROI.
                        let grid_target = if rescale == RescalePolicy::VisDown {
                            Rect { x0: 35, y0: 30, x1: 55, y1: 50 }
                        } else {
                            vis_t
                        };
                        assert!(
                            o.roi.covers(&grid_target),
                            "{name} {label}: roi {:?} misses the target",
                            o.roi
                        );
                        assert!(
                            o.computed.area() < v.width * v.height,
                            "{name}: ROI skip on the whole frame"
                        );
                    }
                    if matches!(method, Method::Ifevip(_)) {
                        assert!(
                            o.taken.contains(Skips::CROP) || o.declined == Some(Decline::RoiTooLarge),
                            "{name} {label}: IFEVIP skips its crop (or finds it too large)"
                        );
                    }
                    if matches!(method, Method::Adf(_)) && noise > 0 {
                        // Noise everywhere: the covariance is not reproducible from a window.
                        assert_eq!(o.declined, Some(Decline::GlobalStatistic), "{name} noisy");
                    }
                }
            }
        }
    }
    assert!(took_roi >= 12, "only {took_roi} runs took the ROI skip");
    Ok(())
}

fn render_small() -> Result<(tempfile::TempDir, Dataset)> {
    let dir = tempfile::tempdir()?;
    let cfg = DatasetConfig { tir_sizes: vec![128], ..DatasetConfig::small(3, 256) };
    render_dataset(&cfg, dir.path(), false)?;
    let ds = Dataset::open(dir.path())?;
    Ok((dir, ds))
}

#[test]
fn rendered_frames_roi_is_bit_identical_for_every_method() -> Result<()> {
    let (_dir, ds) = render_small()?;
    let (mut roi_runs, mut worst_psnr) = (0, f64::INFINITY);
    for frame in 0..ds.frames() {
        for noisy in [false, true] {
            let tir = ds.image("tir128", frame, noisy)?;
            for set in ["vis_light", "vis_eclipse"] {
                let vis = ds.image(set, frame, noisy)?;
                let scene =
                    analyze(vis.view()?, tir.view()?, (vis.width, vis.height), &SceneParams::default())?;
                if noisy {
                    // The rendered sensor noise (σ ≈ 12–18 levels on black) is above
                    // max_noise_spread: both bands are analysed in block means, whose noise is
                    // below it, so the frame is not declined.
                    assert!(scene.vis_blocks.is_some() && scene.tir_blocks.is_some(), "frame {frame}");
                    assert_eq!(scene.decline, None, "frame {frame}: {scene:?}");
                } else if set == "vis_light" {
                    assert_eq!(
                        scene.decline, None,
                        "frame {frame}: rendered space background must not decline"
                    );
                    assert!(scene.target.is_some(), "frame {frame}: no target found");
                }
                for (name, method) in methods() {
                    for skip in [SkipPolicy::Roi, SkipPolicy::All] {
                        let o = check(
                            &format!("{set} {frame} {} {name}", fusion_engine::study::version(noisy)),
                            &vis,
                            &tir,
                            method,
                            RescalePolicy::TirUp,
                            skip,
                        )?;
                        if o.taken.contains(Skips::ROI) {
                            roi_runs += 1;
                        }
                        if !o.taken.contains(Skips::ECLIPSE_VIS) {
                            worst_psnr = worst_psnr.min(o.psnr);
                        }
                    }
                }
            }
        }
    }
    println!("ROI runs {roi_runs}, worst skip PSNR {worst_psnr:.1} dB");
    assert!(roi_runs > 0);
    Ok(())
}

#[test]
fn vifb_pairs_decline_and_stay_identical() -> Result<()> {
    let mut pairs = 0;
    for (name, vis, tir) in vifb_pairs(&fusion_io::testdata::vifb_dir())? {
        let scene = analyze(vis.view()?, tir.view()?, (vis.width, vis.height), &SceneParams::default())?;
        assert!(scene.decline.is_some(), "{name}: the analysis must decline a real scene: {scene:?}");
        for (m, method) in methods() {
            let o =
                check(&format!("vifb {name} {m}"), &vis, &tir, method, RescalePolicy::None, SkipPolicy::All)?;
            assert!(o.declined.is_some() && o.psnr.is_infinite(), "{name} {m}");
        }
        pairs += 1;
    }
    assert!(pairs >= 4, "found {pairs} VIFB pairs");
    Ok(())
}

#[test]
fn black_vis_is_an_eclipse_and_adf_skips_its_side() -> Result<()> {
    let vis = Gray { width: 128, height: 128, data: vec![0u8; 128 * 128] };
    let mut tir = synthetic(64, 64, Rect { x0: 20, y0: 24, x1: 40, y1: 44 }, 100, 0, 5);
    tir.data.iter_mut().for_each(|p| *p = p.saturating_sub(3)); // background exactly 0
    let scene = analyze(vis.view()?, tir.view()?, (128, 128), &SceneParams::default())?;
    assert_eq!(scene.illumination, Illumination::Eclipse);
    assert_eq!(scene.vis.signal, None);
    let adf = Method::Adf(AdfParams::default());
    let (got, report, _) = fuse_once(&vis, &tir, &pipeline(adf, RescalePolicy::TirUp, SkipPolicy::All))?;
    assert!(report.skip.taken.contains(Skips::ECLIPSE_VIS | Skips::ROI), "{:?}", report.skip);
    // VIS is exactly its level 0 here, so the eclipse plan must reproduce the unskipped ADF.
    let (full, _, _) = fuse_once(&vis, &tir, &pipeline(adf, RescalePolicy::TirUp, SkipPolicy::None))?;
    assert_eq!(got.data, full.data);
    // A lit VIS of the same scene is not an eclipse.
    let lit = synthetic(128, 128, Rect { x0: 40, y0: 48, x1: 80, y1: 88 }, 60, 0, 6);
    let scene = analyze(lit.view()?, tir.view()?, (128, 128), &SceneParams::default())?;
    assert_eq!(scene.illumination, Illumination::Light);
    Ok(())
}

#[test]
fn bad_input_is_still_an_error() -> Result<()> {
    let vis = synthetic(64, 64, Rect { x0: 20, y0: 20, x1: 40, y1: 40 }, 80, 0, 7);
    let tir = synthetic(32, 32, Rect { x0: 10, y0: 10, x1: 20, y1: 20 }, 80, 0, 8);
    let mut scratch = fusion_engine::CoreScratch::new(64 * 64);
    for skip in [SkipPolicy::Roi, SkipPolicy::All] {
        let p = pipeline(Method::default(), RescalePolicy::TirUp, skip);
        let mut small = Gray::<u8>::new(32, 32);
        let r = fusion_nostd::pipeline::fuse(
            vis.view()?,
            tir.view()?,
            small.view_mut()?,
            &mut scratch.view_mut(),
            &p,
        );
        assert_eq!(r.err(), Some(Error::SizeMismatch { expected: (64, 64), got: (32, 32) }));
        let mut out = Gray::<u8>::new(64, 64);
        let mut tiny = fusion_engine::CoreScratch::new(16);
        let r =
            fusion_nostd::pipeline::fuse(vis.view()?, tir.view()?, out.view_mut()?, &mut tiny.view_mut(), &p);
        assert!(matches!(r, Err(Error::ScratchTooSmall { .. })), "{r:?}");
        // One pixel short of a full run is an error whatever the plan: here same-size frames
        // whose small target window would fit the scratch.
        let target = Rect { x0: 70, y0: 70, x1: 90, y1: 90 };
        let (vis160, tir160) =
            (synthetic(160, 160, target, 80, 0, 9), synthetic(160, 160, target, 90, 0, 10));
        let same = FuseConfig { rescale: RescalePolicy::None, ..p };
        let mut out160 = Gray::<u8>::new(160, 160);
        let n = 160 * 160;
        let mut short = fusion_engine::CoreScratch::new(n - 1);
        let r = fusion_nostd::pipeline::fuse(
            vis160.view()?,
            tir160.view()?,
            out160.view_mut()?,
            &mut short.view_mut(),
            &same,
        );
        assert_eq!(r.err(), Some(Error::ScratchTooSmall { needed: n, capacity: n - 1 }));
        let mut enough = fusion_engine::CoreScratch::new(n);
        let r = fusion_nostd::pipeline::fuse(
            vis160.view()?,
            tir160.view()?,
            out160.view_mut()?,
            &mut enough.view_mut(),
            &same,
        )?;
        assert!(
            r.skip.declined.is_none() && r.skip.computed.area() < n / 4,
            "the window plan ran: {:?}",
            r.skip
        );
        let bad = pipeline(
            Method::Tsifsd(TsifsdParams { mean_size: 4, ..TsifsdParams::default() }),
            RescalePolicy::TirUp,
            skip,
        );
        let r = fusion_nostd::pipeline::fuse(
            vis.view()?,
            tir.view()?,
            out.view_mut()?,
            &mut scratch.view_mut(),
            &bad,
        );
        assert_eq!(r.err(), Some(Error::InvalidParameter { name: "mean_size" }));
        let bad = FuseConfig { scene: SceneParams { min_delta: 0, ..SceneParams::default() }, ..p };
        let r = fusion_nostd::pipeline::fuse(
            vis.view()?,
            tir.view()?,
            out.view_mut()?,
            &mut scratch.view_mut(),
            &bad,
        );
        assert_eq!(r.err(), Some(Error::InvalidParameter { name: "min_delta" }));
        let none = FuseConfig { rescale: RescalePolicy::None, ..p };
        let r = fusion_nostd::pipeline::fuse(
            vis.view()?,
            tir.view()?,
            out.view_mut()?,
            &mut scratch.view_mut(),
            &none,
        );
        assert!(matches!(r, Err(Error::SizeMismatch { .. })));
    }
    Ok(())
}

/// Noisy rendezvous frames (the study's sensor model, every sequence, light, penumbra and
/// eclipse): against black space the analysis does not decline, the TSIFSD and adaptive windows hold every target
/// pixel of both cameras' ground-truth masks, their ROI is bit-identical to the unskipped
/// fusion (`check`), and ADF and IFEVIP (frame-global) hold every target pixel in the ROI
/// their crop's fusion is kept on; with the Earth behind the target (`radial`) it declines and
/// the whole frame is fused.
#[test]
fn noisy_sequence_windows_hold_every_target_pixel() -> Result<()> {
    use render_host::sequence::{SequenceConfig, SequenceName, read_manifest, render_sequence};
    let dir = tempfile::tempdir()?;
    let (mut checked, mut declined) = (0, 0);
    for name in SequenceName::ALL {
        let cfg = SequenceConfig { frames: 8, vis_size: 512, tir_size: 256, ..SequenceConfig::new(name) };
        let d = dir.path().join(name.as_str());
        render_sequence(&cfg, &d, false)?;
        let m = read_manifest(&d)?;
        for f in &m.frames {
            let load = |rel: &str| fusion_io::load_gray_u8(&d.join(rel), fusion_io::ColorPolicy::Refuse);
            let (vis, tir) = (load(&f.files.vis)?, load(&f.files.tir)?);
            let (vm, tm) = (load(&f.files.vis_mask)?, load(&f.files.tir_mask)?);
            let label = format!("{} frame {} ({:?})", name.as_str(), f.index, f.phase);
            for (mname, method) in [
                ("tsifsd", Method::Tsifsd(TsifsdParams::default())),
                ("adaptive", Method::Adaptive(AdaptiveParams::default())),
                ("adf", Method::Adf(AdfParams::default())),
                ("ifevip", Method::Ifevip(IfevipParams::default())),
            ] {
                for skip in [SkipPolicy::Roi, SkipPolicy::All] {
                    let o =
                        check(&format!("{label} {mname}"), &vis, &tir, method, RescalePolicy::TirUp, skip)?;
                    if f.files.vis_earth_mask.is_some() {
                        // The Earth behind the target: "the target is what is not dark" fails,
                        // so the analysis must decline and the whole frame be fused.
                        assert!(o.declined.is_some(), "{label} {mname} {skip:?}: a window against the Earth");
                        assert_eq!(o.computed.area(), vis.width * vis.height, "{label} {mname} {skip:?}");
                        declined += 1;
                        continue;
                    }
                    assert_eq!(o.declined, None, "{label} {mname} {skip:?}");
                    // The frame-global methods keep their crop's output on the ROI only.
                    let w = if o.ran.frame_global() {
                        assert!(o.taken.contains(Skips::CROP), "{label} {mname}: no crop");
                        o.roi
                    } else {
                        o.computed
                    };
                    for y in 0..vis.height {
                        for x in 0..vis.width {
                            let target = vm.at(x, y) > 127
                                || tm.at(x * tm.width / vis.width, y * tm.height / vis.height) > 127;
                            assert!(
                                !target || w.contains(x, y),
                                "{label} {mname} {skip:?}: target pixel ({x}, {y}) outside {w:?}"
                            );
                        }
                    }
                    assert!(
                        w.area() < vis.width * vis.height,
                        "{label} {mname}: the window is the whole frame"
                    );
                    checked += 1;
                }
            }
        }
    }
    assert_eq!((checked, declined), (2 * 8 * 4 * 2, 8 * 4 * 2));
    Ok(())
}

/// The caller's window ([`SkipPolicy::Window`], e.g. the navigation filter's predicted box),
/// on rendered noisy frames (both rescale directions) and on real pairs (VIFB, which the
/// analysis declines): the local methods are bit-identical to the unskipped fusion on the ROI,
/// the frame-global ones give the fusion of the crop there (`check`); the ROI holds the whole
/// box; a box off the frame gives the background everywhere.
#[test]
fn caller_windows_follow_the_same_semantics() -> Result<()> {
    let (_dir, ds) = render_small()?;
    let mut runs = 0;
    let mut cases: Vec<(String, Gray<u8>, Gray<u8>, RescalePolicy)> = Vec::new();
    for frame in [0, ds.frames() - 1] {
        let (vis, tir) = (ds.image("vis_light", frame, true)?, ds.image("tir128", frame, true)?);
        for rescale in [RescalePolicy::TirUp, RescalePolicy::VisDown] {
            cases.push((format!("rendered noisy {frame} {rescale:?}"), vis.clone(), tir.clone(), rescale));
        }
    }
    for (name, vis, tir) in vifb_pairs(&fusion_io::testdata::vifb_dir())?.into_iter().take(2) {
        cases.push((format!("vifb {name}"), vis, tir, RescalePolicy::None));
    }
    for (label, vis, tir, rescale) in &cases {
        let grid =
            fusion_nostd::pipeline::fusion_grid((vis.width, vis.height), (tir.width, tir.height), *rescale)?;
        let (w, h) = grid;
        let boxes = [
            Rect { x0: w / 4 + 1, y0: h / 3, x1: 3 * w / 4, y1: 2 * h / 3 + 1 },
            Rect { x0: 0, y0: h / 2, x1: w / 5, y1: 2 * h },
        ];
        for (name, method) in methods() {
            for b in boxes {
                let o = check(
                    &format!("{label} {name} box {b:?}"),
                    vis,
                    tir,
                    method,
                    *rescale,
                    SkipPolicy::Window(b),
                )?;
                assert_eq!(o.declined, None, "{label} {name}: the caller's window is never declined");
                let want = b.intersect(Rect::full(grid));
                assert!(o.roi.covers(&want), "{label} {name}: roi {:?} misses the box {want:?}", o.roi);
                if o.ran.frame_global() {
                    assert_eq!(o.roi, want, "{label} {name}: the crop's output is kept on the box");
                }
                runs += 1;
            }
            let off = SkipPolicy::Window(Rect { x0: w + 3, y0: 0, x1: w + 40, y1: h });
            let (got, report, _) = fuse_once(vis, tir, &pipeline(method, *rescale, off))?;
            let bg = report.skip.background.expect("an empty window writes the background");
            assert!(got.data.iter().all(|&v| v == bg), "{label} {name}: off-frame box");
            assert!(report.skip.roi.is_empty());
        }
    }
    assert_eq!(runs, cases.len() * methods().len() * 2);
    Ok(())
}
