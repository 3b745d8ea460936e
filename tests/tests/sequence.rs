//! Sequence mode (`fusion_nostd::sequence`): ADF's KL weights carried from frame k − 1 to
//! frame k, so a frame is fused in one pass over its strips.
//!
//! Checked on a rendered noisy fly-around (light, terminator and eclipse): the whole-frame and
//! the strip forms give the same bytes, guards and steps frame by frame for both variants and
//! both rescale directions; the pass each frame takes follows the rule recomputed here from the
//! scene analysis; a carried frame is the `f64` reference ADF fused with the previous frame's
//! weight (within the core's documented 1 level), and uses exactly the weight the previous
//! frame measured; a frame with its own weights is the per-frame fusion's bytes; strips take
//! one pass on a carried frame; restarts on a change of size, parameters or illumination; a
//! failed call leaves the sequence as it was; scene skipping carries a crop's weights.

use anyhow::Result;
use fusion_engine::sequence::{Form, SequenceFuser};
use fusion_engine::skip::fuse_once;
use fusion_io::Gray;
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, SkipPolicy, fuse_in_sequence, fusion_grid};
use fusion_nostd::scene::{Illumination, analyze};
use fusion_nostd::sequence::{Pass, Restart, Sequence, SequenceParams};
use fusion_nostd::{AdfParams, Filter, Variant, rescale};
use render_host::sequence::{SequenceConfig, SequenceName, read_manifest, render_sequence};

/// A noisy fly-around of `frames` frames at 256² VIS, 128² TIR: (VIS, TIR) per frame.
fn flyaround(frames: usize) -> Result<Vec<(Gray<u8>, Gray<u8>)>> {
    let dir = tempfile::tempdir()?;
    let cfg = SequenceConfig {
        frames,
        vis_size: 256,
        tir_size: 128,
        ..SequenceConfig::new(SequenceName::Flyaround)
    };
    render_sequence(&cfg, dir.path(), false)?;
    let m = read_manifest(dir.path())?;
    let load = |rel: &str| fusion_io::load_gray_u8(&dir.path().join(rel), fusion_io::ColorPolicy::Refuse);
    m.frames.iter().map(|f| Ok((load(&f.files.vis)?, load(&f.files.tir)?))).collect()
}

fn adf(variant: Variant) -> Method {
    Method::Adf(AdfParams { variant, ..AdfParams::default() })
}

fn config(method: Method, rescale: RescalePolicy) -> FuseConfig {
    FuseConfig { method, rescale, ..FuseConfig::default() }
}

/// A band brought onto the grid as the pipeline does (VIS down by area, TIR up by bicubic).
fn on_grid(band: &Gray<u8>, grid: (usize, usize), filter: Filter) -> Result<Gray<u8>> {
    if (band.width, band.height) == grid {
        return Ok(band.clone());
    }
    let mut g = Gray::new(grid.0, grid.1);
    rescale(band.view()?, g.view_mut()?, filter)?;
    Ok(g)
}

#[test]
fn whole_frame_and_strips_agree_and_follow_the_rule() -> Result<()> {
    let frames = flyaround(20)?;
    let mut carried_frames = 0;
    let mut classes = Vec::new();
    for variant in [Variant::Flight, Variant::Classic] {
        for rescale in [RescalePolicy::TirUp, RescalePolicy::VisDown] {
            let cfg = config(adf(variant), rescale);
            let params = SequenceParams::default();
            let mut whole = SequenceFuser::new(cfg, params, Form::WholeFrame);
            let mut tall = SequenceFuser::new(cfg, params, Form::Strips { max_rows: usize::MAX });
            let mut short = SequenceFuser::new(cfg, params, Form::Strips { max_rows: 37 });
            let mut previous: Option<(Illumination, i64)> = None;
            for (k, (vis, tir)) in frames.iter().enumerate() {
                let label = format!("{variant:?} {rescale:?} frame {k}");
                let a = whole.fuse(vis, tir)?;
                for s in [&mut tall, &mut short] {
                    let b = s.fuse(vis, tir)?;
                    assert_eq!(a.image.data, b.image.data, "{label}: strips differ from the whole frame");
                    assert_eq!(a.report.guards, b.report.guards, "{label}");
                    assert_eq!(a.step, b.step, "{label}");
                    // One pass over the strips exactly when the weights were carried.
                    let passes = b.strips.map(|r| r.passes);
                    assert_eq!(passes, Some(if a.step.pass == Pass::Carried { 1 } else { 2 }), "{label}");
                }
                // The rule, from the scene analysis of the input frames.
                let grid = fusion_grid((vis.width, vis.height), (tir.width, tir.height), rescale)?;
                let class = analyze(vis.view()?, tir.view()?, grid, &cfg.scene)?.illumination;
                let expected = match previous {
                    None => Pass::Own(Restart::First),
                    Some((c, _)) if c != class => Pass::Own(Restart::Illumination),
                    Some(_) => Pass::Carried,
                };
                assert_eq!(a.step.pass, expected, "{label}");
                assert_eq!(a.step.illumination, Some(class), "{label}");
                assert_eq!(a.step.pixels, grid.0 * grid.1, "{label}");
                let (single, single_report, _) = fuse_once(vis, tir, &cfg)?;
                // The frame's own weight is the per-frame fusion's: the step says so, and a
                // frame fused with it is the per-frame fusion's bytes.
                match a.step.pass {
                    Pass::Carried => {
                        carried_frames += 1;
                        assert_eq!(a.step.p_ir_used_q30, previous.map(|p| p.1).unwrap_or(-1), "{label}");
                        if a.step.p_ir_used_q30 == a.step.p_ir_own_q30 {
                            assert_eq!(a.image.data, single.data, "{label}");
                        }
                    }
                    _ => {
                        assert_eq!(a.step.p_ir_used_q30, a.step.p_ir_own_q30, "{label}");
                        assert_eq!(
                            a.image.data, single.data,
                            "{label}: own weights, not the per-frame bytes"
                        );
                        assert_eq!(a.report.guards, single_report.guards, "{label}");
                    }
                }
                previous = Some((class, a.step.p_ir_own_q30));
                if variant == Variant::Flight && rescale == RescalePolicy::TirUp {
                    classes.push(class);
                }
            }
        }
    }
    // The fly-around passes through the eclipse: both carried frames and restarts occur.
    assert!(
        classes.contains(&Illumination::Light) && classes.contains(&Illumination::Eclipse),
        "{classes:?}"
    );
    assert!(carried_frames >= 4 * 10, "only {carried_frames} carried frames");
    Ok(())
}

/// A carried frame against the `f64` reference: the reference's diffusion of the frame's own
/// bands, fused with the previous frame's weight (`F = ½A_IR + ½A_VIS + p·D_IR + (1 − p)·D_VIS`),
/// within the core's documented error (1 level after the 8-bit cast); the frame's own weight
/// against the reference's KL weight of the frame.
#[test]
fn a_carried_frame_is_the_reference_with_the_previous_weight() -> Result<()> {
    let frames = flyaround(6)?;
    let params = AdfParams::default();
    let cfg = config(Method::Adf(params), RescalePolicy::TirUp);
    let mut seq = SequenceFuser::new(cfg, SequenceParams::default(), Form::Strips { max_rows: usize::MAX });
    let mut checked = 0;
    for (k, (vis, tir)) in frames.iter().enumerate() {
        let f = seq.fuse(vis, tir)?;
        let grid = (vis.width, vis.height);
        let tir_g = on_grid(tir, grid, Filter::Cubic)?;
        let (v, t) = (fusion_reference::to_f64(vis), fusion_reference::to_f64(&tir_g));
        let (a_vis, a_ir) =
            (fusion_reference::adf::diffuse(&v, &params), fusion_reference::adf::diffuse(&t, &params));
        let d_ir: Vec<f64> = t.data.iter().zip(&a_ir.data).map(|(i, a)| i - a).collect();
        let d_vis: Vec<f64> = v.data.iter().zip(&a_vis.data).map(|(i, a)| i - a).collect();
        let (p_ref, _) = fusion_reference::adf::kl_weights(&d_ir, &d_vis, params.variant);
        let p_own = f.step.p_ir_own_q30 as f64 / f64::from(1u32 << 30);
        assert!(
            (p_own - p_ref).abs() < 1e-3,
            "frame {k}: own weight {p_own} against the reference's {p_ref}"
        );
        let p = f.step.p_ir_used_q30 as f64 / f64::from(1u32 << 30);
        let mut worst = 0.0f64;
        for i in 0..d_ir.len() {
            let r = 0.5 * (a_ir.data[i] + a_vis.data[i]) + p * d_ir[i] + (1.0 - p) * d_vis[i];
            worst =
                worst.max((f64::from(fusion_reference::matlab_uint8(r)) - f64::from(f.image.data[i])).abs());
        }
        assert!(worst <= 1.0, "frame {k} ({:?}): {worst} levels from the reference", f.step.pass);
        if f.step.pass == Pass::Carried {
            checked += 1;
        }
    }
    assert!(checked >= 3, "only {checked} carried frames");
    Ok(())
}

#[test]
fn the_carry_restarts_on_size_parameters_and_illumination() -> Result<()> {
    let frames = flyaround(1)?;
    let (vis, tir) = &frames[0];
    let crop = |g: &Gray<u8>, side: usize| Gray {
        width: side,
        height: side,
        data: (0..side * side).map(|i| g.data[(i / side) * g.width + i % side]).collect(),
    };
    // Same-size crops: no rescale.
    let tir_g = on_grid(tir, (vis.width, vis.height), Filter::Cubic)?;
    let cfg = config(adf(Variant::Flight), RescalePolicy::None);
    let mut s = SequenceFuser::new(cfg, SequenceParams::default(), Form::WholeFrame);
    let step = |s: &mut SequenceFuser, side: usize| -> Result<Pass> {
        Ok(s.fuse(&crop(vis, side), &crop(&tir_g, side))?.step.pass)
    };
    assert_eq!(step(&mut s, 160)?, Pass::Own(Restart::First));
    // 192² / 160² = 1.44 ≤ 1.5: carried; 240² / 192² = 1.5625: restart; 200²/240² = 1.44 back.
    assert_eq!(step(&mut s, 192)?, Pass::Carried);
    assert_eq!(step(&mut s, 240)?, Pass::Own(Restart::Size));
    assert_eq!(step(&mut s, 200)?, Pass::Carried);
    // A tighter rule.
    let mut tight = SequenceFuser::new(
        cfg,
        SequenceParams { size_change_percent: 110, ..SequenceParams::default() },
        Form::WholeFrame,
    );
    assert_eq!(step(&mut tight, 200)?, Pass::Own(Restart::First));
    assert_eq!(step(&mut tight, 208)?, Pass::Carried); // 1.0816
    assert_eq!(step(&mut tight, 220)?, Pass::Own(Restart::Size)); // 1.1187
    // Other parameters.
    let other = config(Method::Adf(AdfParams { iterations: 5, ..AdfParams::default() }), RescalePolicy::None);
    let mut s2 = SequenceFuser::new(cfg, SequenceParams::default(), Form::WholeFrame);
    let mut seq = Sequence::default();
    let mut scratch = fusion_engine::CoreScratch::new(200 * 200);
    let mut out = Gray::new(200, 200);
    let (v, t) = (crop(vis, 200), crop(&tir_g, 200));
    for (c, want) in [
        (&cfg, Pass::Own(Restart::First)),
        (&cfg, Pass::Carried),
        (&other, Pass::Own(Restart::Method)),
        (&other, Pass::Carried),
    ] {
        fuse_in_sequence(v.view()?, t.view()?, out.view_mut()?, &mut scratch.view_mut(), c, &mut seq)?;
        assert_eq!(seq.last_step().map(|s| s.pass), Some(want));
    }
    // A method that carries nothing drops the carry.
    let tsifsd = config(Method::Tsifsd(Default::default()), RescalePolicy::None);
    fuse_in_sequence(v.view()?, t.view()?, out.view_mut()?, &mut scratch.view_mut(), &tsifsd, &mut seq)?;
    assert_eq!(seq.last_step().map(|s| s.pass), Some(Pass::PerFrame));
    let (single, _, _) = fuse_once(&v, &t, &tsifsd)?;
    assert_eq!(out.data, single.data, "a method that carries nothing is fused per frame");
    fuse_in_sequence(v.view()?, t.view()?, out.view_mut()?, &mut scratch.view_mut(), &cfg, &mut seq)?;
    assert_eq!(seq.last_step().map(|s| s.pass), Some(Pass::Own(Restart::First)));
    // Illumination: a black VIS frame is an eclipse.
    assert_eq!(s2.fuse(&v, &t)?.step.pass, Pass::Own(Restart::First));
    let black = Gray { width: 200, height: 200, data: vec![0u8; 200 * 200] };
    let e = s2.fuse(&black, &t)?;
    assert_eq!(
        (e.step.pass, e.step.illumination),
        (Pass::Own(Restart::Illumination), Some(Illumination::Eclipse))
    );
    assert_eq!(s2.fuse(&black, &t)?.step.pass, Pass::Carried);
    assert_eq!(s2.fuse(&v, &t)?.step.pass, Pass::Own(Restart::Illumination));
    // Bad sequence parameters are an error.
    let mut bad = Sequence::new(SequenceParams { size_change_percent: 99, ..SequenceParams::default() });
    let r = fuse_in_sequence(v.view()?, t.view()?, out.view_mut()?, &mut scratch.view_mut(), &cfg, &mut bad);
    assert!(matches!(r, Err(fusion_nostd::Error::InvalidParameter { name: "size_change_percent" })), "{r:?}");
    Ok(())
}

#[test]
fn a_failed_frame_leaves_the_sequence_as_it_was() -> Result<()> {
    // Three frames in light (the fly-around's first of twenty).
    let mut frames = flyaround(20)?;
    frames.truncate(3);
    let cfg = config(adf(Variant::Flight), RescalePolicy::TirUp);
    let run = |fail: bool| -> Result<Vec<(Vec<u8>, Pass)>> {
        let mut seq = Sequence::default();
        let mut scratch = fusion_engine::CoreScratch::new(256 * 256);
        let mut got = Vec::new();
        for (k, (vis, tir)) in frames.iter().enumerate() {
            if fail && k == 1 {
                // A wrong output size: an error, the carry kept.
                let mut wrong = Gray::new(100, 100);
                let r = fuse_in_sequence(
                    vis.view()?,
                    tir.view()?,
                    wrong.view_mut()?,
                    &mut scratch.view_mut(),
                    &cfg,
                    &mut seq,
                );
                assert!(r.is_err());
                assert_eq!(seq.last_step(), None);
            }
            let mut out = Gray::new(256, 256);
            fuse_in_sequence(
                vis.view()?,
                tir.view()?,
                out.view_mut()?,
                &mut scratch.view_mut(),
                &cfg,
                &mut seq,
            )?;
            got.push((out.data, seq.last_step().map(|s| s.pass).unwrap_or(Pass::PerFrame)));
        }
        Ok(got)
    };
    let (clean, failed) = (run(false)?, run(true)?);
    assert_eq!(clean, failed);
    assert_eq!(clean[1].1, Pass::Carried);
    Ok(())
}

/// With scene skipping (the crop semantics of ADF on noisy frames) the crop's weights are
/// carried: each step counts the crop's pixels, uses the previous crop's weight, and a frame
/// with its own weights is the skipped per-frame fusion's bytes; outside the ROI the output is
/// the per-frame one's (the background value).
#[test]
fn skipping_carries_the_crops_weights() -> Result<()> {
    let frames = flyaround(12)?;
    let cfg = FuseConfig { skip: SkipPolicy::All, ..config(adf(Variant::Flight), RescalePolicy::TirUp) };
    // The frame's own windows (the windows over the sequence: the next test).
    let params = SequenceParams { window_frames: 0, ..SequenceParams::default() };
    let mut s = SequenceFuser::new(cfg, params, Form::WholeFrame);
    let mut previous_own = None;
    let mut carried = 0;
    for (k, (vis, tir)) in frames.iter().enumerate() {
        let f = s.fuse(vis, tir)?;
        let (single, report, _) = fuse_once(vis, tir, &cfg)?;
        assert_eq!(f.report.skip, report.skip, "frame {k}");
        if f.step.pass == Pass::PerFrame {
            assert_eq!(f.image.data, single.data, "frame {k}");
            continue;
        }
        assert_eq!(f.step.pixels, report.skip.computed.area(), "frame {k}: the crop's pixels");
        let roi = report.skip.roi;
        for y in 0..single.height {
            for x in 0..single.width {
                if !roi.contains(x, y) {
                    assert_eq!(f.image.at(x, y), single.at(x, y), "frame {k} ({x}, {y}) outside the ROI");
                }
            }
        }
        match f.step.pass {
            Pass::Carried => {
                carried += 1;
                assert_eq!(Some(f.step.p_ir_used_q30), previous_own, "frame {k}");
            }
            _ => assert_eq!(f.image.data, single.data, "frame {k}: own weights"),
        }
        previous_own = Some(f.step.p_ir_own_q30);
    }
    assert!(carried >= 4, "only {carried} carried crops");
    Ok(())
}

/// The skip windows of a sequence: with `window_frames` = N, the target boxes the plan uses are
/// the scene analysis's own joined with those of the N frames before (recomputed here from
/// `analyze` frame by frame), for ADF's crop (its ROI is the joined box) and TSIFSD's exact
/// window; with N = 0 a sequence skips as `fuse` does, byte for byte.
#[test]
fn skip_windows_join_the_last_frames_boxes() -> Result<()> {
    use fusion_nostd::pipeline::Skips;
    use fusion_nostd::scene::Rect;
    let frames = flyaround(20)?;
    let join = |a: Option<Rect>, b: Option<Rect>| match (a, b) {
        (Some(a), Some(b)) => Some(a.union(b)),
        (a, b) => a.or(b),
    };
    for n in [0u8, 1, 5] {
        let params = SequenceParams { window_frames: n, ..SequenceParams::default() };
        for method in [adf(Variant::Flight), Method::Tsifsd(Default::default())] {
            let cfg = FuseConfig { skip: SkipPolicy::All, ..config(method, RescalePolicy::TirUp) };
            let mut s = SequenceFuser::new(cfg, params, Form::WholeFrame);
            let mut own: Vec<(Option<Rect>, Option<Rect>)> = Vec::new();
            let mut crops = 0;
            for (k, (vis, tir)) in frames.iter().enumerate() {
                let f = s.fuse(vis, tir)?;
                let scene = analyze(vis.view()?, tir.view()?, (vis.width, vis.height), &cfg.scene)?;
                own.push((scene.target, scene.target_tir));
                let recent = &own[k.saturating_sub(usize::from(n))..];
                let target = recent.iter().fold(None, |a, b| join(a, b.0));
                let target_tir = recent.iter().fold(None, |a, b| join(a, b.1));
                let eclipse = scene.illumination == Illumination::Eclipse;
                let expected = if eclipse { target_tir } else { target };
                let label = format!("window_frames {n} {} frame {k}", method.name());
                if f.report.skip.taken.contains(Skips::CROP) {
                    assert_eq!(Some(f.report.skip.roi), expected, "{label}");
                    crops += 1;
                } else if let (Method::Tsifsd(_), Some(t)) = (method, expected) {
                    assert!(f.report.skip.computed.covers(&t), "{label}: {:?} {t:?}", f.report.skip.computed);
                }
                if n == 0 && method.name().starts_with("tsifsd") {
                    assert_eq!(f.image.data, fuse_once(vis, tir, &cfg)?.0.data, "{label}");
                }
            }
            if matches!(method, Method::Adf(_)) {
                assert!(crops >= 10, "window_frames {n}: {crops} crops");
            }
        }
    }
    Ok(())
}
