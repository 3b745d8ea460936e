//! Registration (`fusion_nostd::registration`): the remap kernel against OpenCV's `remap` on
//! the same fixed-point map (`tests/data/remap/`, made by `scripts/cv2_remap_fixtures.py` with
//! the OpenCV named in its `versions.txt`), and the kernel's own properties.

use fusion_io::npy::read_npy_2d;
use fusion_io::testdata::file;
use fusion_nostd::registration::{Border, FixedMap, Interpolation, RemapSample, TAB_SIZE, remap};
use fusion_nostd::{Error, FrameMut, FrameRef};

fn load(name: &str) -> (usize, usize, Vec<f64>) {
    let g = read_npy_2d(&file(&format!("remap/{name}.npy"))).unwrap();
    (g.width, g.height, g.data)
}

struct Fixture {
    w: usize,
    h: usize,
    xy: Vec<i16>,
    frac: Vec<u16>,
}

fn fixture_map() -> Fixture {
    let (w, h, x) = load("map_x");
    let (_, _, y) = load("map_y");
    let (_, _, f) = load("map_frac");
    let xy = x.iter().zip(&y).flat_map(|(&x, &y)| [x as i16, y as i16]).collect();
    Fixture { w, h, xy, frac: f.iter().map(|&v| v as u16).collect() }
}

/// Our remap of the fixture's source through its map, and OpenCV's result, for one case.
fn case<T: RemapSample + Default>(depth: &str, interp: Interpolation, border: &str) -> (Vec<u32>, Vec<u32>) {
    let m = fixture_map();
    let (sw, sh, src) = load(&format!("src_{depth}"));
    let src: Vec<T> = src.iter().map(|&v| T::put(v as u32)).collect();
    let full = T::MAX;
    let b = match border {
        "constant0" => Border::Constant(0),
        "constant" => Border::Constant((full / 3) as u16),
        _ => Border::Replicate,
    };
    let map = FixedMap::new(m.w, m.h, &m.xy, &m.frac).unwrap();
    let mut out = vec![T::default(); m.w * m.h];
    remap(FrameRef::new(&src, sw, sh).unwrap(), &map, FrameMut::new(&mut out, m.w, m.h).unwrap(), interp, b)
        .unwrap();
    let name = match interp {
        Interpolation::Linear => "linear",
        Interpolation::Cubic => "cubic",
    };
    let (_, _, cv) = load(&format!("out_{depth}_{name}_{border}"));
    (out.iter().map(|v| v.get()).collect(), cv.iter().map(|&v| v as u32).collect())
}

/// Linear interpolation, 8 and 16 bit, constant (0 and a third of full scale) and replicate
/// borders: every pixel equals OpenCV's, inside, across and outside the source's edges.
#[test]
fn linear_remap_is_opencvs_bit_for_bit() {
    for border in ["constant0", "constant", "replicate"] {
        for (ours, cv) in [
            case::<u8>("u8", Interpolation::Linear, border),
            case::<u16>("u16", Interpolation::Linear, border),
        ] {
            let differ = ours.iter().zip(&cv).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "linear, {border}: {differ} of {} pixels differ from OpenCV", ours.len());
        }
    }
}

/// Cubic interpolation, both depths, every border: OpenCV's arithmetic (its `f32` weights and
/// summation order). OpenCV 5's own cubic output is not one function of its inputs: its
/// optimised and plain builds differ on sums that fall within a rounding error of a half
/// (measured: `BENCHMARKS.md`, "Registration"), so here every pixel must be within one level
/// and at most 0.5 % of them may differ at all.
#[test]
fn cubic_remap_matches_opencv_up_to_its_own_rounding_of_ties() {
    for border in ["constant0", "constant", "replicate"] {
        for (depth, (ours, cv)) in [
            ("u8", case::<u8>("u8", Interpolation::Cubic, border)),
            ("u16", case::<u16>("u16", Interpolation::Cubic, border)),
        ] {
            let worst = ours.iter().zip(&cv).map(|(&a, &b)| a.abs_diff(b)).max().unwrap();
            let differ = ours.iter().zip(&cv).filter(|(a, b)| a != b).count();
            assert!(worst <= 1, "cubic {depth} {border}: off by {worst}");
            assert!(differ * 200 <= ours.len(), "cubic {depth} {border}: {differ} of {} differ", ours.len());
        }
    }
}

/// Hand-computed: at the map's integer positions linear and cubic return the source pixel;
/// half way between two pixels linear gives their mean rounded half up (Q15) or half to even
/// (16 bit, `f32`); a position entirely outside takes the constant, replicate the edge.
#[test]
fn hand_computed_positions() {
    let src8: Vec<u8> = (0..36).map(|i| (i * 7) as u8).collect();
    let src16: Vec<u16> = (0..36).map(|i| (i * 1001) as u16 + 1).collect();
    let run8 = |xy: &[i16], frac: &[u16], interp, border| {
        let map = FixedMap::new(xy.len() / 2, 1, xy, frac).unwrap();
        let mut out = vec![0u8; xy.len() / 2];
        remap(
            FrameRef::new(&src8, 6, 6).unwrap(),
            &map,
            FrameMut::new(&mut out, xy.len() / 2, 1).unwrap(),
            interp,
            border,
        )
        .unwrap();
        out
    };
    let half_x = (TAB_SIZE / 2) as u16;
    for interp in [Interpolation::Linear, Interpolation::Cubic] {
        assert_eq!(run8(&[2, 3, 4, 1], &[0, 0], interp, Border::Replicate), [src8[20], src8[10]]);
    }
    // (2.5, 3): the mean of 7·20 = 140 and 7·21 = 147 is 143.5 → 144.
    assert_eq!(run8(&[2, 3], &[half_x], Interpolation::Linear, Border::Replicate), [144]);
    // Far outside: the constant; replicate: the corner.
    assert_eq!(run8(&[-9, -9, 40, 2], &[0, 0], Interpolation::Linear, Border::Constant(77)), [77, 77]);
    assert_eq!(run8(&[-9, -9], &[0], Interpolation::Cubic, Border::Replicate), [src8[0]]);
    // A constant above 255 saturates for 8-bit frames.
    assert_eq!(run8(&[-9, -9], &[0], Interpolation::Linear, Border::Constant(300)), [255]);
    // 16 bit: (1.5, 0) between 1002 and 2003 → 1502.5 → 1502 (half to even).
    let (xy, frac) = ([1i16, 0], [half_x]);
    let map = FixedMap::new(1, 1, &xy, &frac).unwrap();
    let mut out = [0u16; 1];
    remap(
        FrameRef::new(&src16, 6, 6).unwrap(),
        &map,
        FrameMut::new(&mut out, 1, 1).unwrap(),
        Interpolation::Linear,
        Border::Replicate,
    )
    .unwrap();
    assert_eq!(out, [1502]);
}

/// Maps of the wrong length or an output of another size are refused, nothing written.
#[test]
fn bad_maps_are_refused() {
    let xy = [0i16; 8];
    let frac = [0u16; 4];
    assert!(matches!(FixedMap::new(2, 2, &xy[..6], &frac), Err(Error::BufferTooSmall { .. })));
    assert!(matches!(FixedMap::new(2, 2, &xy, &frac[..3]), Err(Error::BufferTooSmall { .. })));
    assert!(matches!(FixedMap::new(0, 2, &xy, &frac), Err(Error::ZeroDimension)));
    let map = FixedMap::new(2, 2, &xy, &frac).unwrap();
    let src = [5u8; 4];
    let mut out = [9u8; 6];
    let r = remap(
        FrameRef::new(&src, 2, 2).unwrap(),
        &map,
        FrameMut::new(&mut out, 3, 2).unwrap(),
        Interpolation::Linear,
        Border::Replicate,
    );
    assert!(matches!(r, Err(Error::SizeMismatch { .. })));
    assert_eq!(out, [9; 6]);
}

/// A visible pixel and OpenCV's thermal position for it.
type Position = ((usize, usize), (f64, f64));

/// OpenCV's positions on the fixture grid (`tests/data/rig/<name>.npy`, shape (33, 33, 2)): the
/// grid's visible pixels and the thermal position of each.
fn opencv_positions(name: &str) -> Vec<Position> {
    let path = file(&format!("rig/{name}.npy"));
    let bytes = std::fs::read(&path).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    assert_eq!(npy.shape(), &[33, 33, 2]);
    let v: Vec<f64> = npy.into_vec().unwrap();
    let grid = |i: usize| (i * 32).min(1023);
    (0..33 * 33).map(|k| ((grid(k % 33), grid(k / 33)), (v[2 * k], v[2 * k + 1]))).collect()
}

/// The largest distance, px, between our positions and OpenCV's.
fn worst(ours: impl Fn(usize, usize) -> (f32, f32), cv: &[Position]) -> f64 {
    cv.iter()
        .map(|&((u, v), (x, y))| {
            let (a, b) = ours(u, v);
            (f64::from(a) - x).hypot(f64::from(b) - y)
        })
        .fold(0.0, f64::max)
}

/// The rig read from OpenCV's own YAML and JSON is the same; the thermal position of every
/// visible pixel on the plane at 5 and 20 m agrees with OpenCV's `undistortPoints` +
/// `projectPoints` within 0.001 px exactly evaluated and 0.005 px through the node grid (16-px
/// cells; measured 7·10⁻⁵ and 6.5·10⁻⁴ px, `--nocapture` prints them); with an ideal visible
/// lens, with `initUndistortRectifyMap` and the plane homography likewise; the fixed-point map
/// is the grid's position in 1/32 px within 1/64 + 2·10⁻⁴ px (its integer steps across a cell).
#[test]
fn the_rig_map_agrees_with_opencv() {
    use fusion_nostd::registration::{NODE_STEP, RigMap, node_count};
    let rig = fusion_io::rig::read(&file("rig/offset_rig.yml")).unwrap();
    assert_eq!(rig, fusion_io::rig::read(&file("rig/offset_rig.json")).unwrap());
    let ideal = fusion_nostd::registration::Rig {
        vis: fusion_nostd::registration::Camera { dist: [0.0; 5], ..rig.vis },
        ..rig
    };
    let mut nodes = vec![[0.0f32; 2]; node_count(1024, 1024, NODE_STEP)];
    for range in [5u32, 20] {
        let r = range as f32;
        for (rig, name, exact_bound) in [(rig, "positions", 0.001), (ideal, "undistorted", 0.001)] {
            let cv = opencv_positions(&format!("{name}_{range}m"));
            let exact = worst(|u, v| rig.tir_position(u as f32, v as f32, r).unwrap(), &cv);
            let map = RigMap::new(&rig, r, NODE_STEP, &mut nodes).unwrap();
            let grid = worst(|u, v| map.position(u, v), &cv);
            eprintln!("{name} {range} m: exact {exact:.5} px, node grid {grid:.5} px");
            assert!(exact < exact_bound, "{name} at {range} m: {exact} px from OpenCV");
            assert!(grid < 0.005, "{name} at {range} m: the node grid {grid} px from OpenCV");
            // The fixed-point map of two rows is the position rounded to 1/32.
            let (mut xy, mut frac) = (vec![0i16; 2 * 2 * 1024], vec![0u16; 2 * 1024]);
            map.rows(511, &mut xy, &mut frac).unwrap();
            for (i, (p, &f)) in xy.chunks(2).zip(&frac).enumerate() {
                let (x, y) = map.position(i % 1024, 511 + i / 1024);
                let fx = f32::from(p[0]) + f32::from(f % 32) / 32.0;
                let fy = f32::from(p[1]) + f32::from(f / 32) / 32.0;
                assert!(
                    (fx - x).abs() <= 1.0 / 64.0 + 2e-4 && (fy - y).abs() <= 1.0 / 64.0 + 2e-4,
                    "{fx} {x} {fy} {y}"
                );
            }
        }
    }
}

/// Bad rigs and ranges are refused with nothing computed; rig files that are not calibrations
/// are refused in one line naming what is wrong.
#[test]
fn bad_rigs_are_refused() {
    use fusion_nostd::registration::{NODE_STEP, RigMap};
    let rig = fusion_io::rig::read(&file("rig/offset_rig.json")).unwrap();
    let mut nodes = vec![[7.0f32; 2]; 10];
    assert!(matches!(RigMap::new(&rig, 5.0, NODE_STEP, &mut nodes), Err(Error::BufferTooSmall { .. })));
    let mut nodes = vec![[7.0f32; 2]; 5000];
    for range in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert!(RigMap::new(&rig, range, NODE_STEP, &mut nodes).is_err(), "range {range}");
    }
    assert!(RigMap::new(&rig, 5.0, 0, &mut nodes).is_err());
    let nan = fusion_nostd::registration::Rig { t: [f32::NAN, 0.0, 0.0], ..rig };
    assert!(RigMap::new(&nan, 5.0, NODE_STEP, &mut nodes).is_err());
    assert!(nodes.iter().all(|n| *n == [7.0, 7.0]), "nothing computed");
    let text = fusion_io::rig::example_json();
    for (from, to, says) in [
        ("\"R\"", "\"Q\"", "no `R`"),
        (
            "\"dt\": \"d\",\n        \"data\": [ -0.2",
            "\"dt\": \"d\",\n        \"data\": [ 0.0, -0.2",
            "`T` does not have 3 values",
        ),
        ("1910.8100134752654, 0.0, 511.5", "1910.8100134752654, 3.0, 511.5", "skewed"),
        ("[ 1024, 1024 ]", "[ 1024, 0 ]", "height 0"),
        ("0.99997410764584338", "1.5", "not a rotation"),
    ] {
        assert!(text.contains(from), "{from}");
        let e = fusion_io::rig::from_text(&text.replacen(from, to, 1)).unwrap_err();
        let msg = format!("{e:#}");
        assert!(msg.contains(says) && !msg.contains('\n'), "{says}: {msg}");
    }
    assert!(fusion_io::rig::from_text("%YAML:1.0\n---\nR: [1, 2]\n").is_err());
    assert!(fusion_io::rig::from_text("{ not json").is_err());
}

/// `register` strip by strip gives the bytes of one `remap` through the whole frame's map, for
/// strips of 1, 7 and 64 rows, both depths and interpolations; sizes that do not match the rig
/// and scratch without a whole row are refused with nothing written.
#[test]
fn register_in_strips_is_remap_through_the_whole_map() {
    use fusion_nostd::registration::{NODE_STEP, RigMap, node_count, register};
    let mut rig = fusion_io::rig::read(&file("rig/offset_rig.json")).unwrap();
    // A small pair keeps the test fast: the same lenses and pose, scaled images.
    rig.vis = fusion_nostd::registration::Camera {
        fx: rig.vis.fx / 8.0,
        fy: rig.vis.fy / 8.0,
        cx: 63.5,
        cy: 63.5,
        width: 128,
        height: 128,
        ..rig.vis
    };
    rig.tir = fusion_nostd::registration::Camera {
        fx: rig.tir.fx / 8.0,
        fy: rig.tir.fy / 8.0,
        cx: 31.5,
        cy: 31.5,
        width: 64,
        height: 64,
        ..rig.tir
    };
    let mut nodes = vec![[0.0f32; 2]; node_count(128, 128, NODE_STEP)];
    let map = RigMap::new(&rig, 6.0, NODE_STEP, &mut nodes).unwrap();
    let src8: Vec<u8> = (0..64 * 64).map(|i| ((i * 37 + i / 64 * 11) % 251) as u8).collect();
    let src16: Vec<u16> =
        src8.iter().enumerate().map(|(i, &v)| u16::from(v) * 250 + (i % 97) as u16).collect();
    let (mut xy, mut frac) = (vec![0i16; 2 * 128 * 128], vec![0u16; 128 * 128]);
    map.rows(0, &mut xy, &mut frac).unwrap();
    let whole = FixedMap::new(128, 128, &xy, &frac).unwrap();
    for interp in [Interpolation::Linear, Interpolation::Cubic] {
        let border = Border::Constant(0);
        let mut want8 = vec![0u8; 128 * 128];
        remap(
            FrameRef::new(&src8, 64, 64).unwrap(),
            &whole,
            FrameMut::new(&mut want8, 128, 128).unwrap(),
            interp,
            border,
        )
        .unwrap();
        let mut want16 = vec![0u16; 128 * 128];
        remap(
            FrameRef::new(&src16, 64, 64).unwrap(),
            &whole,
            FrameMut::new(&mut want16, 128, 128).unwrap(),
            interp,
            border,
        )
        .unwrap();
        assert!(
            want8.iter().filter(|&&v| v != 0).count() > 128 * 128 / 2,
            "the thermal frame covers the grid"
        );
        for rows in [1usize, 7, 64] {
            let (mut sxy, mut sfrac) = (vec![0i16; 2 * rows * 128], vec![0u16; rows * 128]);
            let mut got8 = vec![0u8; 128 * 128];
            let src = FrameRef::new(&src8, 64, 64).unwrap();
            register(
                src,
                &map,
                FrameMut::new(&mut got8, 128, 128).unwrap(),
                interp,
                border,
                &mut sxy,
                &mut sfrac,
            )
            .unwrap();
            assert_eq!(got8, want8, "{interp:?}, strips of {rows}");
            let mut got16 = vec![0u16; 128 * 128];
            let src = FrameRef::new(&src16, 64, 64).unwrap();
            register(
                src,
                &map,
                FrameMut::new(&mut got16, 128, 128).unwrap(),
                interp,
                border,
                &mut sxy,
                &mut sfrac,
            )
            .unwrap();
            assert_eq!(got16, want16, "{interp:?} 16-bit, strips of {rows}");
        }
    }
    let mut out = vec![9u8; 128 * 128];
    let (mut sxy, mut sfrac) = (vec![0i16; 2 * 127], vec![0u16; 127]);
    let src = FrameRef::new(&src8, 64, 64).unwrap();
    let r = register(
        src,
        &map,
        FrameMut::new(&mut out, 128, 128).unwrap(),
        Interpolation::Linear,
        Border::Replicate,
        &mut sxy,
        &mut sfrac,
    );
    assert!(r.is_err(), "less than a row of scratch");
    let wrong = FrameRef::new(&src8[..32 * 64], 64, 32).unwrap();
    let (mut sxy, mut sfrac) = (vec![0i16; 2 * 128], vec![0u16; 128]);
    let r = register(
        wrong,
        &map,
        FrameMut::new(&mut out, 128, 128).unwrap(),
        Interpolation::Linear,
        Border::Replicate,
        &mut sxy,
        &mut sfrac,
    );
    assert!(matches!(r, Err(Error::SizeMismatch { .. })));
    assert!(out.iter().all(|&v| v == 9));
}

/// The default offset rig scaled to 128² / 64² (same lenses, pose and fields of view).
fn small_offset_rig() -> fusion_nostd::registration::Rig {
    render_host::rig::scaled(&render_host::rig::offset_rig().unwrap(), 128, 64)
}

/// Rendered ground truth: a sequence through the (scaled) offset rig, whose thermal target
/// mask, registered onto the visible grid at the frame's range, lands on the visible mask
/// (centroid within 0.5 px, overlap ≥ 0.75 at this small size — the mask's edge pixels) while the aligned-camera assumption (a 2× rescale)
/// misses it by pixels; and the renderer's thermal camera sees each plane point where the
/// core's rig map says (the two compose the rig's pose independently).
#[test]
fn a_rendered_offset_rig_is_registered_onto_the_visible_grid() {
    use render_host::sequence::{SequenceConfig, SequenceName, render_sequence};
    let rig = small_offset_rig();
    let cfg = SequenceConfig {
        frames: 3,
        vis_size: 128,
        tir_size: 64,
        rig: Some(rig),
        write_clean: false,
        vis: render_host::vis::VisParams { samples: 1, ..render_host::vis::VisParams::light() },
        tir: render_host::tir::TirParams { samples: 1, ..render_host::tir::TirParams::default() },
        ..SequenceConfig::new(SequenceName::Approach)
    };
    let dir = tempfile::tempdir().unwrap();
    let m = render_sequence(&cfg, dir.path(), false).unwrap();
    assert_eq!(m.rig.as_deref(), Some("calibration/rig.json"));
    assert_eq!(fusion_io::rig::read(&dir.path().join("calibration/rig.json")).unwrap(), rig);
    let mask =
        |rel: &str| fusion_io::load_gray_u8(&dir.path().join(rel), fusion_io::ColorPolicy::Refuse).unwrap();
    let centroid = |g: &fusion_io::Gray<u8>| {
        let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
        for (i, &v) in g.data.iter().enumerate() {
            if v > 127 {
                (sx, sy, n) = (sx + (i % g.width) as f64, sy + (i / g.width) as f64, n + 1.0);
            }
        }
        (sx / n, sy / n, n)
    };
    let overlap = |a: &fusion_io::Gray<u8>, b: &fusion_io::Gray<u8>| {
        let both = a.data.iter().zip(&b.data).filter(|(x, y)| **x > 127 && **y > 127).count();
        let any = a.data.iter().zip(&b.data).filter(|(x, y)| **x > 127 || **y > 127).count();
        both as f64 / any.max(1) as f64
    };
    for f in m.frames.iter().skip(1) {
        let vis = mask(&f.files.vis_mask);
        let tir = mask(&f.files.tir_mask);
        let registered = fusion_engine::registration::register(
            &tir,
            &rig,
            f64::from(f.range_m),
            Interpolation::Linear,
            Border::Constant(0),
        )
        .unwrap();
        let mut rescaled = fusion_io::Gray::<u8>::new(128, 128);
        fusion_nostd::rescale(tir.view().unwrap(), rescaled.view_mut().unwrap(), fusion_nostd::Filter::Cubic)
            .unwrap();
        let (v, r, s) = (centroid(&vis), centroid(&registered), centroid(&rescaled));
        let off = |a: (f64, f64, f64)| (a.0 - v.0).hypot(a.1 - v.1);
        assert!(v.2 > 50.0, "frame {}: the target is seen", f.index);
        let (o_r, o_s) = (overlap(&vis, &registered), overlap(&vis, &rescaled));
        eprintln!(
            "frame {}: registered {:.2} px off, overlap {o_r:.3}; rescaled {:.2} px, {o_s:.3}",
            f.index,
            off(r),
            off(s)
        );
        assert!(
            off(r) < 0.5 && o_r >= 0.75,
            "frame {}: registered {:.2} px off, overlap {o_r:.3}",
            f.index,
            off(r)
        );
        assert!(
            off(s) > 3.0 * off(r).max(0.3) && o_s < o_r - 0.2,
            "frame {}: the rescale {:.2} px off, overlap {o_s:.3}",
            f.index,
            off(s)
        );
    }
    // The renderer's cameras against the core's map: a visible pixel's plane point seen by the
    // thermal camera where the map puts it.
    let pose = render_host::camera::Pose::look_at(
        render_host::glam::Vec3::new(0.3, -6.0, 0.2),
        render_host::glam::Vec3::ZERO,
        render_host::glam::Vec3::Z,
    );
    let (vc, tc) = render_host::rig::cameras(&rig, pose).unwrap();
    for (u, v) in [(10.0f32, 20.0f32), (64.0, 64.0), (120.0, 5.0)] {
        let d = vc.ray_dir(u + 0.5, v + 0.5);
        let depth = 7.0;
        let p = pose.position + d * (depth / d.dot(pose.forward()));
        let (x, y) = tc.project(p).unwrap();
        let (mx, my) = rig.tir_position(u, v, depth).unwrap();
        assert!(
            (x - 0.5 - mx).abs() < 2e-3 && (y - 0.5 - my).abs() < 2e-3,
            "({u}, {v}): {x} {y} vs {mx} {my}"
        );
    }
}
