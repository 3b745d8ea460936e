//! The pipeline entry (`fusion_nostd::pipeline`): rescale policy + method, against the same
//! steps composed by hand (core rescaler, then the method), and against the f64 references.

use fusion_engine::CoreScratch;
use fusion_engine::methods::{fuse_core, fuse_reference};
use fusion_io::Gray;
use fusion_nostd::methods::{Guards, round_away_sat_u8};
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, fuse, fuse_raw, fusion_grid};
use fusion_nostd::{AdaptiveParams, AdfParams, Error, Filter, IfevipParams, TsifsdParams, Variant, rescale};
use fusion_tests::{assert_same, scene};

fn methods() -> [Method; 7] {
    Method::all()
}

fn run(vis: &Gray<u8>, tir: &Gray<u8>, pipeline: &FuseConfig) -> Result<(Gray<u8>, Guards, bool), Error> {
    let (w, h) = fusion_grid((vis.width, vis.height), (tir.width, tir.height), pipeline.rescale)?;
    let mut out = Gray::new(w, h);
    let need = pipeline.scratch_pixels((vis.width, vis.height), (tir.width, tir.height))?;
    let mut scratch = CoreScratch::new(need);
    let r = fuse(
        vis.view().unwrap(),
        tir.view().unwrap(),
        out.view_mut().unwrap(),
        &mut scratch.view_mut(),
        pipeline,
    )?;
    assert_eq!(r.grid, (w, h));
    Ok((out, r.guards, r.rescaled))
}

fn resized(img: &Gray<u8>, w: usize, h: usize, filter: Filter) -> Gray<u8> {
    let mut out = Gray::new(w, h);
    rescale(img.view().unwrap(), out.view_mut().unwrap(), filter).unwrap();
    out
}

/// TIR up (bicubic onto the VIS grid) and VIS down (area onto the TIR grid) equal the rescale
/// followed by the method on the same-size pair, for every method and variant, at an odd
/// VIS size and a 2:1 ratio. (The adaptive method decides per frame on the input frames,
/// before the rescale: `tests/adaptive.rs` checks it with that decision.)
#[test]
fn policies_equal_rescale_then_fuse() -> Result<(), Error> {
    for (vw, vh) in [(96, 64), (75, 41)] {
        let (tw, th) = (vw / 2 + vw % 2, vh / 2);
        let (vis, tir) = (scene(vw, vh, 1), scene(tw, th, 2));
        for method in methods().into_iter().filter(|m| !matches!(m, Method::Adaptive(_))) {
            let up =
                run(&vis, &tir, &FuseConfig { rescale: RescalePolicy::TirUp, method, ..Default::default() })?;
            let by_hand = run(
                &vis,
                &resized(&tir, vw, vh, Filter::Cubic),
                &FuseConfig { rescale: RescalePolicy::None, method, ..Default::default() },
            )?;
            assert!(up.2 && !by_hand.2, "rescaled flags");
            assert_same(&up.0, &by_hand.0, &format!("tir-up {method:?} {vw}x{vh}"));
            assert_eq!(up.1, by_hand.1);

            let down = run(
                &vis,
                &tir,
                &FuseConfig { rescale: RescalePolicy::VisDown, method, ..Default::default() },
            )?;
            let by_hand = run(
                &resized(&vis, tw, th, Filter::Area),
                &tir,
                &FuseConfig { rescale: RescalePolicy::None, method, ..Default::default() },
            )?;
            assert_eq!((down.0.width, down.0.height), (tw, th));
            assert_same(&down.0, &by_hand.0, &format!("vis-down {method:?} {vw}x{vh}"));
        }
    }
    Ok(())
}

/// The whole pipeline against the f64 pipeline (f64 rescale, u8 cast, f64 method): the study's
/// geometry, VIS 256² + TIR 128² (scaled down 4× from 1024²/512² to keep the test fast).
#[test]
fn core_pipeline_matches_the_reference_pipeline() -> anyhow::Result<()> {
    let (vis, tir) = (scene(256, 256, 11), scene(128, 128, 12));
    for method in methods() {
        for rescale in [RescalePolicy::TirUp, RescalePolicy::VisDown] {
            let p = FuseConfig { rescale, method, ..Default::default() };
            let core = fuse_core(&vis, &tir, &p, false)?;
            let refr = fuse_reference(&vis, &tir, &p)?;
            let max =
                core.image.data.iter().zip(&refr.image.data).map(|(a, b)| a.abs_diff(*b)).max().unwrap_or(0);
            let n = core.image.data.iter().zip(&refr.image.data).filter(|(a, b)| a != b).count();
            println!("{method:?} {rescale:?}: {n} of {} pixels differ, max {max}", core.image.data.len());
            assert!(max <= 2, "{method:?} {rescale:?}: max {max}");
        }
    }
    Ok(())
}

/// The raw entry gives the pre-cast Q16 value whose cast is the u8 output, bit for bit.
#[test]
fn raw_value_casts_to_the_output() -> Result<(), Error> {
    let (vis, tir) = (scene(80, 60, 3), scene(40, 30, 4));
    for method in methods() {
        let p = FuseConfig { rescale: RescalePolicy::TirUp, method, ..Default::default() };
        let (out, _, _) = run(&vis, &tir, &p)?;
        let mut raw = Gray::<i32>::new(80, 60);
        let mut scratch = CoreScratch::new(p.scratch_pixels((80, 60), (40, 30))?);
        let r = fuse_raw(
            vis.view().unwrap(),
            tir.view().unwrap(),
            raw.view_mut().unwrap(),
            &mut scratch.view_mut(),
            &p,
        );
        match method {
            Method::Ifevip(_) | Method::Adaptive(_) => {
                assert_eq!(r, Err(Error::InvalidParameter { name: "method" }))
            }
            _ => {
                r?;
                let cast: Vec<u8> = raw.data.iter().map(|&v| round_away_sat_u8(i64::from(v), 16)).collect();
                assert_eq!(cast, out.data, "{method:?}");
            }
        }
    }
    Ok(())
}

#[test]
fn bad_geometry_is_an_error() {
    let method = Method::default();
    let (vis, tir) = (scene(64, 64, 1), scene(32, 32, 2));
    // policy none with different sizes
    let p = FuseConfig { rescale: RescalePolicy::None, method, ..Default::default() };
    assert!(matches!(run(&vis, &tir, &p), Err(Error::SizeMismatch { .. })));
    // wrong output size
    let p = FuseConfig { rescale: RescalePolicy::TirUp, method, ..Default::default() };
    let mut out = Gray::<u8>::new(32, 32);
    let mut scratch = CoreScratch::new(64 * 64);
    let r =
        fuse(vis.view().unwrap(), tir.view().unwrap(), out.view_mut().unwrap(), &mut scratch.view_mut(), &p);
    assert!(matches!(r, Err(Error::SizeMismatch { .. })), "{r:?}");
    // scratch too small for the band plane
    let mut out = Gray::<u8>::new(64, 64);
    let mut scratch = CoreScratch::new(64 * 63);
    let r =
        fuse(vis.view().unwrap(), tir.view().unwrap(), out.view_mut().unwrap(), &mut scratch.view_mut(), &p);
    assert!(matches!(r, Err(Error::ScratchTooSmall { .. })), "{r:?}");
    // a ratio the 2× kernels do not have still works through the general rescaler
    let tir = scene(30, 17, 2);
    assert!(run(&vis, &tir, &p).is_ok());
}

/// `Method::all` lists each method and variant once with valid default parameters, and its
/// names are the ones navbench's JSON and the CLI use (`<method>-<variant>`, `adaptive`).
#[test]
fn every_method_and_variant_is_listed_once_by_name() {
    let all = Method::all();
    let names: Vec<&str> = all.iter().map(Method::name).collect();
    assert_eq!(
        names,
        [
            "adf-classic",
            "adf-flight",
            "tsifsd-classic",
            "tsifsd-flight",
            "ifevip-classic",
            "ifevip-flight",
            "adaptive"
        ]
    );
    for m in &all {
        m.validate().unwrap();
        assert!(m.name().starts_with(m.kind()));
        assert_eq!(m.variant().is_none(), m.kind() == "adaptive");
        // `named` finds each entry of `all` from its kind and variant.
        assert_eq!(Method::named(m.kind(), m.variant().unwrap_or(Variant::Flight)), Some(*m));
    }
    // `KINDS` in the order of `defaults`, each the flight variant with default parameters.
    assert_eq!(Method::defaults().map(|m| m.kind()), Method::KINDS);
    assert_eq!(
        Method::defaults(),
        [
            Method::Adf(AdfParams::default()),
            Method::Tsifsd(TsifsdParams::default()),
            Method::Ifevip(IfevipParams::default()),
            Method::Adaptive(AdaptiveParams::default()),
        ]
    );
    assert_eq!(Method::named("gff", Variant::Flight), None);
}
