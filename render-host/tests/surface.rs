//! The procedural surface detail (`render_host::surface`): anti-aliased, deterministic, in both
//! bands, and off by default in `Scene::tango()`.

use render_host::glam::Vec3;
use render_host::scene::{Material, tango};
use render_host::{Camera, Pose, Scene, TirParams, VisParams, render_tir, render_vis};

/// Seen through a footprint of many cells, the solar panel's texture averages to the
/// area-weighted mean of cells, substrate gaps and bus bars (hand-computed from the layout:
/// gaps cover 1 − (1 − 1.5/42)(1 − 1.5/72) = 5.57 %, bars 1.2/42 of the rest = 2.70 %), and the
/// per-cell scatter fades out: no Moiré on a far target.
#[test]
fn far_away_the_cells_average_to_their_area_weighted_albedo() {
    let scene = Scene::tango().unwrap().with_surface_detail(3);
    let detail = scene.detail.as_ref().unwrap();
    let top = scene.faces.iter().position(|f| f.material == Material::GaAsCell).unwrap() as u32;
    let z = tango::BUS[2] / 2.0 + tango::PANEL[2];
    let gap = 1.0 - (1.0 - 1.5 / 42.0) * (1.0 - 1.5 / 72.0);
    let bar = 1.2 / 42.0 * (1.0 - gap);
    let expected = (1.0 - gap - bar) * 0.08 + gap * 0.45 + bar * 0.70;
    for k in 0..50 {
        let p = Vec3::new(-0.3 + 0.012 * k as f32, 0.2 - 0.007 * k as f32, z);
        let s = detail.at(&scene.faces, top, p, 1.0, 330.0);
        assert!((s.albedo - expected).abs() < 0.002, "point {k}: albedo {} not {expected}", s.albedo);
        // Up close the same points see one of the three surfaces exactly.
        let near = detail.at(&scene.faces, top, p, 1e-5, 330.0).albedo;
        assert!(near < 0.1 || (near - 0.45).abs() < 1e-3 || (near - 0.70).abs() < 1e-3, "{near}");
    }
}

/// Renders are a function of the surface seed: the same seed gives the same bytes, another
/// seed another surface; `Scene::tango()` without detail renders as before (flat faces: one
/// value per face in a face-on view).
#[test]
fn detail_is_seeded_and_off_by_default() {
    let pose = Pose::look_at(Vec3::new(0.0, 0.0, 2.5), Vec3::new(0.0, 0.0, 0.17), Vec3::Y);
    let cam = Camera::study(96, pose);
    // Lambertian only: a flat face under the sun is then exactly one value.
    let vis = VisParams { specular: false, ..VisParams::light() };
    let a = render_vis(&Scene::tango().unwrap().with_surface_detail(1), &cam, &vis);
    let b = render_vis(&Scene::tango().unwrap().with_surface_detail(1), &cam, &vis);
    let c = render_vis(&Scene::tango().unwrap().with_surface_detail(2), &cam, &vis);
    assert_eq!(a.data, b.data);
    assert_ne!(a.data, c.data);
    let flat = render_vis(&Scene::tango().unwrap(), &cam, &vis);
    let centre: Vec<f32> =
        (40..56).flat_map(|y| (40..56).map(move |x| (x, y))).map(|(x, y)| flat.at(x, y)).collect();
    assert!(centre.iter().all(|&v| v == centre[0] && v > 0.0), "flat panel is one value");
    let textured: Vec<f32> =
        (40..56).flat_map(|y| (40..56).map(move |x| (x, y))).map(|(x, y)| a.at(x, y)).collect();
    let spread =
        textured.iter().cloned().fold(f32::MIN, f32::max) - textured.iter().cloned().fold(f32::MAX, f32::min);
    assert!(spread > 0.05, "the detailed panel has structure: spread {spread}");
}

/// In TIR the detail is temperature and emittance structure inside a face, in light and in
/// eclipse: a face of one node temperature renders with a spread of several kelvins of
/// brightness temperature (4× the flat face's cos⁴ fall-off over the window), above the bus
/// temperature and after cooling below it.
#[test]
fn thermal_structure_inside_a_face_in_light_and_in_eclipse() {
    let scene = Scene::tango().unwrap().with_surface_detail(0);
    let flat = Scene::tango().unwrap();
    // Face-on to the +x MLI side.
    let pose = Pose::look_at(Vec3::new(1.5, 0.0, 0.0), Vec3::ZERO, Vec3::Z);
    let cam = Camera::study(128, pose);
    let tir = TirParams::default();
    for node_t in [320.0f32, 200.0] {
        let temps = vec![node_t; scene.faces.len()];
        let img = render_tir(&scene, &cam, &temps, &tir);
        let base = render_tir(&flat, &cam, &temps, &tir);
        let (x, y) = (64u32, 64u32);
        let window: Vec<f32> = (y - 15..y + 15)
            .flat_map(|yy| (x - 30..x + 30).map(move |xx| (xx, yy)))
            .map(|(a, b)| img.at(a, b))
            .collect();
        let lo = window.iter().cloned().fold(f32::MAX, f32::min);
        let hi = window.iter().cloned().fold(f32::MIN, f32::max);
        // 250 K over [0, 1]: 0.02 is 5 K of brightness temperature.
        assert!(hi - lo > 0.02, "T = {node_t}: spread {}", hi - lo);
        let flat_window: Vec<f32> = (y - 15..y + 15)
            .flat_map(|yy| (x - 30..x + 30).map(move |xx| (xx, yy)))
            .map(|(a, b)| base.at(a, b))
            .collect();
        // The flat face varies only by the cos⁴ fall-off across the window.
        let flat_spread = flat_window.iter().cloned().fold(f32::MIN, f32::max)
            - flat_window.iter().cloned().fold(f32::MAX, f32::min);
        assert!(hi - lo > 4.0 * flat_spread, "T = {node_t}: detail {} against cos⁴ {flat_spread}", hi - lo);
    }
}

/// With detail, a face mirrors the Earth's infrared glow where its (relief-tilted) normal
/// reflects the view ray into the Earth's disc: the +x blanket seen face-on from +x is warmer
/// when the Earth is behind the camera than when it is behind the target (by more than 0.02 of
/// the 150–400 K range, 5 K); flat faces mirror nothing (the renders before the detail).
#[test]
fn detailed_faces_mirror_the_earth_in_tir() {
    let scene = Scene::tango().unwrap().with_surface_detail(0);
    let flat = Scene::tango().unwrap();
    let cam = Camera::study(128, Pose::look_at(Vec3::new(1.5, 0.0, 0.0), Vec3::ZERO, Vec3::Z));
    let temps = vec![280.0f32; scene.faces.len()];
    let mean = |s: &Scene, earth: Vec3| {
        let img = render_tir(s, &cam, &temps, &TirParams { earth_dir: earth, ..TirParams::default() });
        (49..79)
            .flat_map(|y| (34..94).map(move |x| (x, y)))
            .map(|(x, y)| f64::from(img.at(x, y)))
            .sum::<f64>()
            / 1800.0
    };
    let (facing, behind) = (mean(&scene, Vec3::X), mean(&scene, -Vec3::X));
    assert!(facing > behind + 0.02, "Earth in view of the mirror: {facing} against {behind}");
    assert_eq!(mean(&flat, Vec3::X), mean(&flat, -Vec3::X));
}
