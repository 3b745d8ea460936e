//! The adaptive fusion (`fusion_nostd::methods::adaptive`): the integer core against the f64
//! reference written from the rule, the thermal frame passed through bit for bit when VIS has
//! no signal (eclipse), clipped VIS replaced by TIR (glare), the target never darkened by a
//! black band, a large target's frame fused by ADF (whole frame, strips, skipping), and the
//! pipeline's decision taken from the input frames.

use anyhow::Result;
use fusion_engine::CoreScratch;
use fusion_engine::methods::{fuse_core, fuse_reference};
use fusion_engine::study::Dataset;
use fusion_io::Gray;
use fusion_nostd::methods::adaptive::{AdaptiveParams, Decision, decide_frame};
use fusion_nostd::methods::adf::AdfParams;
use fusion_nostd::pipeline::{
    FuseConfig, Method, RescalePolicy, SkipPolicy, adaptive_decision, fuse_method_decided,
};
use fusion_nostd::scene::{SceneParams, analyze};
use fusion_nostd::strips::{StripScratchMut, fuse_strips};
use fusion_nostd::{Filter, Guards, rescale};
use render_host::{DatasetConfig, render_dataset};

fn adaptive() -> FuseConfig {
    FuseConfig {
        rescale: RescalePolicy::TirUp,
        method: Method::Adaptive(AdaptiveParams::default()),
        ..FuseConfig::default()
    }
}

fn upscaled(tir: &Gray<u8>, w: usize, h: usize) -> Gray<u8> {
    let mut up = Gray::new(w, h);
    rescale(tir.view().unwrap(), up.view_mut().unwrap(), Filter::Cubic).unwrap();
    up
}

/// Core against the f64 reference: equal, except by one level on a rounding tie.
fn assert_matches_reference(vis: &Gray<u8>, tir: &Gray<u8>, label: &str) -> Result<()> {
    assert_matches_reference_with(vis, tir, &adaptive(), label)
}

/// [`assert_matches_reference`] with the configuration `p`.
fn assert_matches_reference_with(vis: &Gray<u8>, tir: &Gray<u8>, p: &FuseConfig, label: &str) -> Result<()> {
    let core = fuse_core(vis, tir, p, false)?;
    let reference = fuse_reference(vis, tir, p)?;
    let raw = reference.raw.expect("the reference's value before the cast");
    for (i, (&a, &b)) in core.image.data.iter().zip(&reference.image.data).enumerate() {
        // The core is exact up to its one rounding: it may differ only where the reference's
        // value sits on a rounding tie (x.5) that its f64 sums resolve the other way.
        let tie = (raw.data[i] - raw.data[i].floor() - 0.5).abs() < 1e-6;
        assert!(
            a == b || (tie && a.abs_diff(b) == 1),
            "{label}: pixel {i}: core {a}, reference {b} ({})",
            raw.data[i]
        );
    }
    Ok(())
}

fn render_small() -> Result<(tempfile::TempDir, Dataset)> {
    let dir = tempfile::tempdir()?;
    let cfg = DatasetConfig { tir_sizes: vec![64], ..DatasetConfig::small(2, 128) };
    render_dataset(&cfg, dir.path(), false)?;
    let ds = Dataset::open(dir.path())?;
    Ok((dir, ds))
}

#[test]
fn core_matches_the_reference_on_rendered_and_synthetic_frames() -> Result<()> {
    let (_dir, ds) = render_small()?;
    for frame in 0..ds.frames() {
        for noisy in [false, true] {
            let vis = ds.image("vis_light", frame, noisy)?;
            let tir = ds.image("tir64", frame, noisy)?;
            assert_matches_reference(&vis, &tir, &format!("frame {frame} noisy {noisy}"))?;
        }
    }
    // Synthetic: a textured lit block, a warm block, a clipped patch (glare), odd sizes.
    let (w, h) = (75, 53);
    let vis = Gray {
        width: w,
        height: h,
        data: (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (40..60).contains(&x) && (10..25).contains(&y) {
                    255
                } else if (10..40).contains(&x) && (25..40).contains(&y) {
                    (90 + (x * 7 + y * 13) % 60) as u8
                } else {
                    ((i.wrapping_mul(2_654_435_761) >> 13) % 24) as u8
                }
            })
            .collect(),
    };
    let tir = Gray {
        width: w,
        height: h,
        data: (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (30..70).contains(&x) && (5..40).contains(&y) { (120 + (x + 2 * y) % 40) as u8 } else { 6 }
            })
            .collect(),
    };
    let core = fuse_core(&vis, &tir, &adaptive(), false)?;
    assert!(core.guards.contains(Guards::ADAPTIVE_GLARE), "the clipped patch is glare: {:?}", core.guards);
    assert_matches_reference(&vis, &tir, "synthetic")
}

/// Eclipse: VIS is black sensor noise, the analysis finds no signal, and the output is the
/// upscaled thermal frame, bit for bit.
#[test]
fn eclipse_passes_the_thermal_frame_through() -> Result<()> {
    let (_dir, ds) = render_small()?;
    for frame in 0..ds.frames() {
        let vis = ds.image("vis_eclipse", frame, true)?;
        let tir = ds.image("tir64", frame, true)?;
        let grid = (vis.width, vis.height);
        let d = decide_frame(
            vis.view()?,
            tir.view()?,
            grid,
            &SceneParams::default(),
            &AdaptiveParams::default(),
        )?;
        assert_eq!(d, Decision::TirOnly, "frame {frame}");
        let fused = fuse_core(&vis, &tir, &adaptive(), false)?;
        assert!(fused.guards.contains(Guards::ADAPTIVE_TIR_ONLY));
        assert_eq!(fused.image.data, upscaled(&tir, vis.width, vis.height).data, "frame {frame}");
    }
    Ok(())
}

/// A lit VIS background is not "no signal": a structured background (tiles of 20, 60 and 90
/// grey levels: median 20, upper quartile 60, so the 6σ threshold lies above 255 and no pixel
/// is "signal") is blended, while the same frame with the structure taken away (a dark,
/// uniform VIS) still passes the thermal frame through. On the VIFB pairs — daylight scenes —
/// the thermal frame is never passed through, and where the rule blends, the output is not
/// the thermal frame.
#[test]
fn a_lit_background_is_not_an_eclipse() -> Result<()> {
    let (w, h) = (128, 128);
    let mut vis = Gray::<u8>::new(w, h);
    let tir = large_target_pair(w, h, 30).1;
    for y in 0..h {
        for x in 0..w {
            // Tiles of 32 px: half at 20, a quarter at 60, a quarter at 90.
            let t = (x / 32 + 4 * (y / 32)) % 4;
            vis.data[y * w + x] = [20, 20, 60, 90][t];
        }
    }
    let grid = (w, h);
    let (sp, ap) = (SceneParams::default(), AdaptiveParams::blend_only());
    let scene = analyze(vis.view()?, tir.view()?, grid, &sp)?;
    assert!(scene.vis.threshold > 255 && scene.vis.signal_samples == 0, "{:?}", scene.vis);
    assert!(scene.vis_background_lit);
    assert!(matches!(decide_frame(vis.view()?, tir.view()?, grid, &sp, &ap)?, Decision::Blend { .. }));
    let dark = Gray::<u8>::new(w, h);
    assert!(!analyze(dark.view()?, tir.view()?, grid, &sp)?.vis_background_lit);
    assert_eq!(decide_frame(dark.view()?, tir.view()?, grid, &sp, &ap)?, Decision::TirOnly);
    let dir = fusion_io::testdata::vifb_dir();
    for name in ["fight", "kettle", "manWalking", "peopleshadow"] {
        let load = |band: &str| {
            fusion_io::load_gray_u8(&dir.join(format!("{name}_{band}.png")), fusion_io::ColorPolicy::Refuse)
        };
        let (vis, tir) = (load("VIS")?, load("IR")?);
        let scene = analyze(vis.view()?, tir.view()?, (vis.width, vis.height), &sp)?;
        assert!(scene.vis_background_lit, "{name}");
        let fused = fuse_core(&vis, &tir, &adaptive(), false)?;
        assert!(!fused.guards.contains(Guards::ADAPTIVE_TIR_ONLY), "{name}: {:?}", fused.guards);
        assert_ne!(fused.image.data, tir.data, "{name}");
        // The blend against its f64 reference (an ADF frame is ADF's, within a level of its own).
        if !fused.guards.contains(Guards::ADAPTIVE_ADF) {
            assert_matches_reference(&vis, &tir, name)?;
        }
    }
    Ok(())
}

/// Glare: where VIS is clipped at 255 (smoothed VIS at 255) the output is the TIR pixel. (The
/// clipped part stays below a quarter of the frame: the analysis reads the noise from the
/// upper quartile and assumes a mostly empty sky.)
#[test]
fn clipped_vis_gives_way_to_tir() -> Result<()> {
    let (w, h) = (64, 48);
    let noise = |i: usize| ((i.wrapping_mul(2_654_435_761) >> 13) % 24) as u8;
    let vis = Gray {
        width: w,
        height: h,
        data: (0..w * h).map(|i| if i % w < 10 { 255 } else { noise(i) }).collect(),
    };
    let tir =
        Gray { width: w, height: h, data: (0..w * h).map(|i| ((i % w) * 3 + (i / w) * 2) as u8).collect() };
    let fused = fuse_core(&vis, &tir, &adaptive(), false)?;
    assert!(fused.guards.contains(Guards::ADAPTIVE_GLARE), "{:?}", fused.guards);
    for y in 0..h {
        for x in 0..9 {
            assert_eq!(fused.image.at(x, y), tir.at(x, y), "({x}, {y})");
        }
    }
    Ok(())
}

/// The target is never darkened by a black band: its mean in the adaptive output is at least
/// 95 % of the brighter band's (ADF and TSIFSD halve it in eclipse; here the thermal frame passes
/// through there, and in light the brighter band's base carries it).
#[test]
fn the_target_is_not_darker_than_in_the_brighter_band() -> Result<()> {
    let (_dir, ds) = render_small()?;
    for set in ["vis_light", "vis_eclipse"] {
        for frame in 0..ds.frames() {
            let vis = ds.image(set, frame, true)?;
            let tir = upscaled(&ds.image("tir64", frame, true)?, vis.width, vis.height);
            let (vc, tc) =
                (ds.image(set, frame, false)?, upscaled(&ds.image("tir64", frame, false)?, 128, 128));
            let mask: Vec<bool> = vc.data.iter().zip(&tc.data).map(|(&v, &t)| v > 20 || t > 20).collect();
            let fused = fuse_core(&vis, &tir, &adaptive(), false)?;
            let mean = |img: &Gray<u8>| {
                let s: f64 =
                    img.data.iter().zip(&mask).filter(|(_, m)| **m).map(|(&v, _)| f64::from(v)).sum();
                s / mask.iter().filter(|m| **m).count().max(1) as f64
            };
            let (mv, mt, mf) = (mean(&vis), mean(&tir), mean(&fused.image));
            assert!(mf >= 0.95 * mv.max(mt), "{set} frame {frame}: fused {mf:.1}, VIS {mv:.1}, TIR {mt:.1}");
        }
    }
    Ok(())
}

/// The pipeline decides from the input frames before the rescale: TIR up equals the rescale
/// by hand followed by the method with that decision, bit for bit.
#[test]
fn the_pipeline_decides_on_the_input_frames() -> Result<()> {
    let (_dir, ds) = render_small()?;
    let p = adaptive();
    for set in ["vis_light", "vis_eclipse"] {
        let (vis, tir) = (ds.image(set, 0, true)?, ds.image("tir64", 0, true)?);
        let piped = fuse_core(&vis, &tir, &p, false)?;
        let decision = adaptive_decision(vis.view()?, tir.view()?, &p)?;
        assert!(decision.is_some());
        let up = upscaled(&tir, vis.width, vis.height);
        let mut out = Gray::new(vis.width, vis.height);
        let mut scratch = CoreScratch::new(vis.width * vis.height);
        let guards = fuse_method_decided(
            vis.view()?,
            up.view()?,
            out.view_mut()?,
            &p.method,
            &mut scratch.view_mut(),
            decision,
        )?;
        assert_eq!(out.data, piped.image.data, "{set}");
        assert_eq!(guards, piped.guards, "{set}");
    }
    Ok(())
}

/// A pair with a large target on a mostly empty sky (the analysis reads the noise from the
/// upper quartile): a `side`-pixel textured block, lit on its left half, on black sensor noise
/// (VIS `w × h`) and warm all over with its own texture (TIR at half size).
fn large_target_pair(w: usize, h: usize, side: usize) -> (Gray<u8>, Gray<u8>) {
    let noise = |i: usize, k: usize| ((i.wrapping_mul(2_654_435_761).wrapping_add(k) >> 13) % 12) as u8;
    let band = |w: usize, h: usize, side: usize, k: usize, px: &dyn Fn(usize, usize, bool) -> u8| Gray {
        width: w,
        height: h,
        data: (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let inside =
                    (w - side) / 2 <= x && x < (w + side) / 2 && (h - side) / 2 <= y && y < (h + side) / 2;
                px(x, y, inside).saturating_add(noise(i, k))
            })
            .collect(),
    };
    let vis = band(w, h, side, 1, &|x, y, inside| {
        if inside && x < w / 2 { 60 + ((x * 7 + y * 13) % 90) as u8 } else { 0 }
    });
    let tir = band(w / 2, h / 2, side / 2, 2, &|x, y, inside| {
        if inside { 110 + ((x * 5 + y * 3) % 50) as u8 } else { 20 }
    });
    (vis, tir)
}

/// A large target (its box's longer side ≥ `adf_from_px` on the grid): the frame is ADF's
/// (`AdaptiveParams::adf`), bit for bit, whole frame, in strips and skipping, with the
/// `ADAPTIVE_ADF` guard beside ADF's own; one pixel over the box's side it is the blend again,
/// which matches its f64 reference; the f64 reference of an ADF frame is ADF's.
#[test]
fn a_large_target_is_fused_by_adf() -> Result<()> {
    let (vis, tir) = large_target_pair(448, 400, 180);
    let grid = (vis.width, vis.height);
    let scene = analyze(vis.view()?, tir.view()?, grid, &SceneParams::default())?;
    let side = scene.target.map_or(0, |r| r.width().max(r.height()));
    assert!(side >= 160, "the target box's side {side}");
    let adaptive_at = |from: usize| FuseConfig {
        method: Method::Adaptive(AdaptiveParams { adf_from_px: from as u16, ..AdaptiveParams::default() }),
        ..adaptive()
    };
    let adf = FuseConfig { method: Method::Adf(AdfParams::default()), ..adaptive() };
    let (a, b) = (fuse_core(&vis, &tir, &adaptive(), false)?, fuse_core(&vis, &tir, &adf, false)?);
    assert_eq!(a.image.data, b.image.data, "the default threshold ({side} px box)");
    assert_eq!(a.guards, b.guards.with(Guards::ADAPTIVE_ADF));
    let at = fuse_core(&vis, &tir, &adaptive_at(side), false)?;
    assert_eq!(at.image.data, b.image.data, "at the box's side");
    for p in [adaptive_at(side + 1), adaptive_at(0)] {
        let blend = fuse_core(&vis, &tir, &p, false)?;
        assert!(!blend.guards.contains(Guards::ADAPTIVE_ADF), "{:?}", blend.guards);
        assert_ne!(blend.image.data, b.image.data, "the blend is not ADF");
        assert_matches_reference_with(&vis, &tir, &p, "the blend of a large target")?;
    }
    let (ra, rb) = (fuse_reference(&vis, &tir, &adaptive())?, fuse_reference(&vis, &tir, &adf)?);
    assert_eq!(ra.raw.expect("raw").data, rb.raw.expect("raw").data, "the f64 reference");
    // Strips: ADF's strip form (two passes), the same bytes and guards as the whole frame.
    let (mut work, mut band) = (vec![0i32; 1 << 16], vec![0u8; 1 << 18]);
    let mut out = Gray::new(grid.0, grid.1);
    let (fused, strips) = fuse_strips(
        vis.view()?,
        tir.view()?,
        out.view_mut()?,
        &mut StripScratchMut::from_slices(&mut work, &mut band),
        &adaptive(),
        64,
    )?;
    assert_eq!(out.data, a.image.data, "strips");
    assert_eq!(fused.guards, a.guards);
    assert_eq!(strips.passes, 2, "ADF's covariance pass, then its output");
    // Skipping: ADF's plan and bytes.
    for skip in [SkipPolicy::Roi, SkipPolicy::All] {
        let sa = fuse_core(&vis, &tir, &FuseConfig { skip, ..adaptive() }, false)?;
        let sb = fuse_core(&vis, &tir, &FuseConfig { skip, ..adf }, false)?;
        assert_eq!(sa.image.data, sb.image.data, "{skip:?}");
        assert_eq!(sa.guards, sb.guards.with(Guards::ADAPTIVE_ADF), "{skip:?}");
    }
    Ok(())
}

/// On a dark, noisy pair (the analysis takes the box from its block means and grows it by its
/// margin) the decision follows the target's size: a 100 px target keeps the blend, a 220 px
/// target takes ADF, a pair with no target keeps the blend.
#[test]
fn the_decision_follows_the_target_box_on_noisy_frames() -> Result<()> {
    // A frame `n` px square: background 20 ± 3 levels of noise, a centred square target at 180.
    let frame = |n: usize, target: usize| {
        let mut g = Gray::<u8>::new(n, n);
        let mut rng = render_host::noise::SplitMix64::new((n * 31 + target) as u64);
        let (a, b) = ((n - target) / 2, (n + target) / 2);
        for y in 0..n {
            for x in 0..n {
                let noise = (rng.next_u64() % 7) as i32 - 3;
                let level = if target > 0 && (a..b).contains(&x) && (a..b).contains(&y) { 180 } else { 20 };
                g.data[y * n + x] = (level + noise) as u8;
            }
        }
        g
    };
    for (target, adf) in [(100, false), (220, true), (0, false)] {
        let (vis, tir) = (frame(512, target), frame(256, target / 2));
        let d = decide_frame(
            vis.view()?,
            tir.view()?,
            (512, 512),
            &SceneParams::default(),
            &AdaptiveParams::default(),
        )?;
        assert_eq!(d == Decision::Adf, adf, "target {target} px: {d:?}");
    }
    Ok(())
}

/// The glare case in rendered data (`render_host::glare`): the approach with the sun 5° off
/// the optical axis (`--sun-phase 175 --glare`) puts the solar disc in the visible frame —
/// saturated where the camera's projection of the sun falls, its column bloomed farther than
/// the halo reaches along its row — and the adaptive fusion's glare guard fires there, as it
/// does not on the same frame rendered without glare.
#[test]
fn a_sequence_with_the_sun_in_view_gives_the_adaptive_rule_its_glare_case() -> Result<()> {
    use render_host::sequence::{
        SequenceConfig, SequenceName, camera_pose, cameras, read_manifest, render_sequence, state,
    };
    let dir = tempfile::tempdir()?;
    let base = SequenceConfig {
        frames: 2,
        vis_size: 256,
        tir_size: 128,
        sun_phase_deg: Some(175.0),
        ..SequenceConfig::new(SequenceName::Approach)
    };
    let with = SequenceConfig { glare: Some(render_host::glare::GlareParams::default()), ..base.clone() };
    let mut guards = Vec::new();
    for (name, cfg) in [("plain", &base), ("glare", &with)] {
        let d = dir.path().join(name);
        render_sequence(cfg, &d, false)?;
        let m = read_manifest(&d)?;
        let f = &m.frames[0];
        let load = |rel: &str| fusion_io::load_gray_u8(&d.join(rel), fusion_io::ColorPolicy::Refuse);
        let (vis, tir) = (load(&f.files.vis)?, load(&f.files.tir)?);
        if name == "glare" {
            let off = f.sun_off_axis_deg.expect("the glare's ground truth");
            assert!((off - 5.0).abs() < 0.5, "sun {off}° off the axis");
            // Where the sun projects, the frame is saturated; its column stays saturated
            // farther from it than its row does (blooming).
            let scene = render_host::scene::Scene::tango()?;
            let st = state(cfg, 0);
            let pose = camera_pose(&st, &scene);
            let (cam, _) = cameras(cfg, pose)?;
            let sun_body = st.attitude.inverse() * st.sun;
            let (u, v) = cam.project(pose.position + sun_body * 1e4).expect("the sun in front");
            let (sx, sy) = (u as usize, v as usize);
            // On the noiseless frame, where the full well reads 255 exactly.
            let clean = load(f.files.vis_clean.as_deref().expect("clean frames"))?;
            assert_eq!(clean.data[sy * clean.width + sx], 255, "the sun at ({sx}, {sy})");
            let run = |step: &dyn Fn(usize) -> Option<(usize, usize)>| {
                (1..)
                    .take_while(|&k| step(k).is_some_and(|(x, y)| clean.data[y * clean.width + x] == 255))
                    .count()
            };
            let up = run(&|k| sy.checked_sub(k).map(|y| (sx, y)));
            let left = run(&|k| sx.checked_sub(k).map(|x| (x, sy)));
            assert!(up > left + 3, "column run {up} px, row run {left} px: no blooming");
            assert!(f.vis_saturated_pixels.unwrap_or(0) > 30);
        } else {
            assert_eq!(f.sun_off_axis_deg, None);
        }
        let fused = fuse_core(&vis, &tir, &adaptive(), false)?;
        guards.push(fused.guards.contains(Guards::ADAPTIVE_GLARE));
    }
    assert_eq!(guards, vec![false, true], "the glare guard without and with the sun's glare");
    Ok(())
}
