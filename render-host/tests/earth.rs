//! The Earth behind the target (`render_host::earth`): its disc where the geometry puts it, its
//! radiance in both bands where the formulas say, and nothing changed without it.

use glam::{DQuat, Vec3};
use render_host::camera::{Camera, Pose};
use render_host::earth::{ATMOSPHERE_K, EarthHit, EarthParams, EarthView, TAU_IR, slant_depth};
use render_host::scene::Scene;
use render_host::tir::TirParams;
use render_host::truth::{earth_mask, target_mask};
use render_host::{VisParams, render_tir, render_tir_over, render_vis, render_vis_over};

/// The Tango target at the origin, the camera 30 m out along +x looking past it sideways (the
/// Earth below, along −z, so the limb crosses the frame).
fn setup(size: u32) -> (Scene, Camera, EarthView) {
    let scene = Scene::tango().unwrap();
    let eye = scene.centre + Vec3::new(30.0, 0.0, 0.0);
    // Looking back at the target and 18° down: the Earth's disc (68° radius about −z, its limb
    // 22° below the horizon) covers the lower part of the frame, space the upper.
    let look = eye + Vec3::new(-1.0, 0.0, -(18f32.to_radians().tan()));
    let camera = Camera::study(size, Pose::look_at(eye, look, Vec3::Z));
    let earth = EarthView::new(&EarthParams::default(), scene.centre, Vec3::NEG_Z, DQuat::IDENTITY, Vec3::Z);
    (scene, camera, earth)
}

#[test]
fn the_earth_mask_is_the_disc_the_angular_radius_gives() {
    let (scene, camera, earth) = setup(96);
    let target = target_mask(&scene, &camera);
    let mask = earth_mask(&camera, &earth, &target);
    let c = EarthParams::default().cos_angular_radius();
    let (mut earth_px, mut checked) = (0, 0);
    for y in 0..camera.height {
        for x in 0..camera.width {
            let k = (y * camera.width + x) as usize;
            // A pixel sees the Earth where its ray is within the angular radius of the nadir
            // (the camera's 30 m offset moves the disc by 30 m / 6871 km: nothing at this size).
            let d = camera.pixel_ray(x, y);
            let cos_nadir = f64::from(-d.z);
            assert!(!(mask[k] && target[k]), "pixel ({x}, {y}) is both the target and the Earth");
            if (cos_nadir - c).abs() < 1e-3 || target[k] {
                continue;
            }
            checked += 1;
            assert_eq!(mask[k], cos_nadir > c, "pixel ({x}, {y}): cos from nadir {cos_nadir}, limb at {c}");
            earth_px += usize::from(mask[k]);
        }
    }
    assert!(
        earth_px > 96 * 20 && earth_px < checked - 96 * 20,
        "the limb crosses the frame: {earth_px} of {checked}"
    );
}

#[test]
fn the_background_is_the_earth_radiance_and_the_target_is_unchanged() {
    let (scene, camera, earth) = setup(64);
    let vis_params = VisParams::light();
    let black = render_vis(&scene, &camera, &vis_params);
    let with = render_vis_over(&scene, &camera, &vis_params, Some(&earth));
    let same_as_black = render_vis_over(&scene, &camera, &vis_params, None);
    assert_eq!(black.data, same_as_black.data, "no Earth: the same bytes as before");
    let target = target_mask(&scene, &camera);
    let tir_params = TirParams::default();
    let temps = vec![280.0f32; scene.faces.len()];
    let tir_black = render_tir(&scene, &camera, &temps, &tir_params);
    let tir_with = render_tir_over(&scene, &camera, &temps, &tir_params, Some(&earth));
    let axis = camera.pose.forward();
    let mut background = 0;
    for y in 0..camera.height {
        for x in 0..camera.width {
            let k = (y * camera.width + x) as usize;
            if target[k] {
                assert_eq!(with.data[k], black.data[k]);
                assert_eq!(tir_with.data[k], tir_black.data[k]);
                continue;
            }
            let d = camera.pixel_ray(x, y);
            match earth.hit(camera.pose.position, d) {
                Some(hit) => {
                    background += 1;
                    let v = vis_params.exposure * earth.vis_radiance(&hit) as f32;
                    assert!((with.data[k] - v).abs() <= 1e-6 * v.max(1.0), "VIS ({x}, {y})");
                    let l = f64::from(axis.dot(d)).max(0.0).powi(4) * earth.tir_radiance(&hit);
                    let t = tir_params.value_of_radiance(l) as f32;
                    assert!((tir_with.data[k] - t).abs() <= 1e-6, "TIR ({x}, {y})");
                }
                None => {
                    assert_eq!(with.data[k], 0.0);
                    assert_eq!(tir_with.data[k], tir_black.data[k]);
                }
            }
        }
    }
    assert!(background > 500, "{background} background pixels see the Earth");
}

#[test]
fn the_limb_glows_in_the_cold_atmosphere_as_the_slab_formula_says() {
    // A grazing ray 16 km above the surface: radiance B(T_atm)(1 − e^{−τ}) with the grazing
    // depth τ₀ √(2πR/H) e^{−h/H} — by hand: √(2π · 6371 km / 8 km) = 70.74, e^{−2} = 0.1353,
    // so τ = 0.1 · 70.74 · 0.1353 = 0.957 and 1 − e^{−τ} = 0.616.
    let earth = EarthView::new(&EarthParams::default(), Vec3::ZERO, Vec3::NEG_Z, DQuat::IDENTITY, Vec3::Z);
    let r = render_host::earth::EARTH_RADIUS_M + render_host::earth::DEFAULT_ALTITUDE_M;
    let grazing = (render_host::earth::EARTH_RADIUS_M + 16_000.0) / r;
    // sin of the angle from the nadir = the closest approach / the distance to the centre.
    let d = Vec3::new(grazing as f32, 0.0, -((1.0 - grazing * grazing).sqrt() as f32));
    let hit = earth.hit(Vec3::ZERO, d).expect("the ray grazes the atmosphere");
    let EarthHit::Limb { height_m, .. } = hit else { panic!("{hit:?}") };
    assert!((height_m - 16_000.0).abs() < 50.0, "{height_m}");
    let by_hand = TirParams::blackbody_radiance(ATMOSPHERE_K) * 0.616;
    assert!((earth.tir_radiance(&hit) / by_hand - 1.0).abs() < 0.01);
    assert!((slant_depth(TAU_IR, 16_000.0) - 0.957).abs() < 0.002);
}

#[test]
fn earthshine_from_a_sunlit_earth_below_is_its_albedo_times_the_view_factor() {
    // Sun overhead, surface facing the Earth: the irradiance is bounded by the darkest and the
    // brightest albedo times the view factor (R/(R+h))² (a uniform Lambertian disc), and the night
    // side gives nothing.
    let day = EarthView::new(&EarthParams::default(), Vec3::ZERO, Vec3::NEG_Z, DQuat::IDENTITY, Vec3::Z);
    let night =
        EarthView::new(&EarthParams::default(), Vec3::ZERO, Vec3::NEG_Z, DQuat::IDENTITY, Vec3::NEG_Z);
    let f = (render_host::earth::EARTH_RADIUS_M
        / (render_host::earth::EARTH_RADIUS_M + render_host::earth::DEFAULT_ALTITUDE_M))
        .powi(2);
    let e = day.earthshine(Vec3::NEG_Z);
    assert!(e > 0.03 * f && e < 0.8 * f, "earthshine {e}, view factor {f}");
    assert!(night.earthshine(Vec3::NEG_Z) < 0.01 * e, "night side {}", night.earthshine(Vec3::NEG_Z));
}

#[test]
fn a_sequence_with_the_earth_is_deterministic_and_carries_its_masks() {
    use render_host::RenderOptions;
    use render_host::sequence::{SequenceName, read_manifest};
    let dir = tempfile::tempdir().unwrap();
    let options = |out: &str| RenderOptions {
        out: dir.path().join(out),
        sequence: Some(SequenceName::Approach),
        frames: Some(2),
        vis_size: 64,
        samples: Some(2),
        earth_km: Some(500.0),
        ..RenderOptions::default()
    };
    render_host::render(&options("a")).unwrap();
    render_host::render(&options("b")).unwrap();
    let m = read_manifest(&dir.path().join("a")).unwrap();
    assert_eq!(m.config.earth.map(|e| e.altitude_m), Some(500_000.0));
    for f in &m.frames {
        for (image, mask, target) in [
            (&f.files.vis_clean, &f.files.vis_earth_mask, &f.files.vis_mask),
            (&f.files.tir_clean, &f.files.tir_earth_mask, &f.files.tir_mask),
        ] {
            let load = |rel: &str| image::open(dir.path().join("a").join(rel)).unwrap().to_luma8();
            let (img, earth, target) =
                (load(image.as_ref().unwrap()), load(mask.as_ref().unwrap()), load(target));
            let earth_px = earth.pixels().filter(|p| p.0[0] == 255).count();
            assert!(earth_px > img.len() / 2, "the approach looks down at the Earth: {earth_px} px");
            for ((e, t), v) in earth.pixels().zip(target.pixels()).zip(img.pixels()) {
                assert!(!(e.0[0] == 255 && t.0[0] == 255), "a pixel is both the Earth and the target");
                if t.0[0] == 0 && e.0[0] == 0 {
                    assert_eq!(v.0[0], 0, "space stays black");
                }
            }
        }
    }
    // The same options, the same bytes.
    for rel in ["manifest.json", "vis/frame_001.png", "tir/frame_001.png", "vis_earth_mask/frame_001.png"] {
        assert_eq!(
            std::fs::read(dir.path().join("a").join(rel)).unwrap(),
            std::fs::read(dir.path().join("b").join(rel)).unwrap(),
            "{rel}"
        );
    }
}
