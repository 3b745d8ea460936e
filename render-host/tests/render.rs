//! Physics and output checks of the renderer (issue 5, deliverable 7). Images are small
//! (64–256 px) so the suite stays fast; each test states what would make it fail.

use render_host::dataset::{Manifest, noise_stream};
use render_host::glam::Vec3;
use render_host::noise::{NoiseRng, pink_noise, radial_power_spectrum, rng_for};
use render_host::scene::{Material, MeshBuilder};
use render_host::thermal::sunlit_fractions;
use render_host::{
    Band, Camera, DatasetConfig, DnMapping, Image, NoiseParams, Pose, Radiometry, RenderOptions, Scene,
    ThermalParams, TirParams, VisParams, apply_sensor_noise, face_temperatures, render_dataset, render_tir,
    render_vis, steady_state, trajectory,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------------------------------------
// Geometry and rays

/// Rays shot along each bus side's inward normal hit that side, at the distance and on the
/// material the procedural geometry defines.
#[test]
fn ray_hits_the_box_face_where_geometry_says() {
    let sc = Scene::tango().unwrap();
    let [bx, by, bz] = render_host::scene::tango::BUS;
    let [_, _, pt] = render_host::scene::tango::PANEL;
    // (point on the surface, outward normal, material there)
    let cases = [
        (Vec3::new(bx / 2.0, 0.03, 0.02), Vec3::X, Material::MliKapton),
        (Vec3::new(-bx / 2.0, 0.1, -0.04), -Vec3::X, Material::MliKapton),
        (Vec3::new(0.1, by / 2.0, -0.05), Vec3::Y, Material::MliKapton),
        (Vec3::new(-0.2, -by / 2.0, 0.0), -Vec3::Y, Material::WhitePaint),
        (Vec3::new(0.15, 0.1, -bz / 2.0), -Vec3::Z, Material::MliKapton),
        (Vec3::new(0.3, -0.3, bz / 2.0 + pt), Vec3::Z, Material::GaAsCell),
        (Vec3::new(0.0, 0.0, bz / 2.0), -Vec3::Z, Material::WhitePaint), // panel underside
    ];
    for (k, (p, n, material)) in cases.into_iter().enumerate() {
        let origin = p + 5.0 * n;
        // The panel underside over the bus is hidden by the bus; shoot it from the side instead.
        let (origin, dir) = if k == 6 { (Vec3::new(0.0, 0.36, 0.0), Vec3::Z) } else { (origin, -n) };
        let hit = sc.intersect(origin, dir, 0.0).unwrap_or_else(|| panic!("case {k}: no hit"));
        let face = sc.faces[hit.face as usize];
        assert_eq!(face.material, material, "case {k}");
        assert!((face.normal - n).length() < 1e-5, "case {k}: normal {}", face.normal);
        let expected = if k == 6 { Vec3::new(0.0, 0.36, bz / 2.0) } else { p };
        assert!((hit.point - expected).length() < 1e-4, "case {k}: hit at {} not {expected}", hit.point);
    }
    // Just beside the panel's edge: a miss.
    assert!(sc.intersect(Vec3::new(0.0, 0.386, 3.0), -Vec3::Z, 0.0).is_none());
    assert!(sc.intersect(Vec3::new(0.0, 0.380, 3.0), -Vec3::Z, 0.0).is_some());
    // Any-hit respects the segment: the panel top is 2 − 0.17 = 1.83 m below (0, 0, 2).
    assert!(sc.occluded(Vec3::new(0.0, 0.0, 2.0), -Vec3::Z, 0.0, 1.9));
    assert!(!sc.occluded(Vec3::new(0.0, 0.0, 2.0), -Vec3::Z, 0.0, 1.8));

    // Through a camera: the pixel a point projects to sees that point.
    let cam = Camera::study(256, Pose::look_at(Vec3::new(0.0, -6.0, 0.0), Vec3::ZERO, Vec3::Z));
    let p = Vec3::new(0.2, -by / 2.0, -0.05);
    let (u, v) = cam.project(p).unwrap();
    let d = cam.ray_dir(u, v);
    let hit = sc.intersect(cam.pose.position, d, 0.0).unwrap();
    assert!((hit.point - p).length() < 1e-4);
    assert_eq!(sc.faces[hit.face as usize].material, Material::WhitePaint);
    // The radiator is the bus's −y side, 6 − 0.285 m from the camera near the axis.
    let centre = sc.intersect(cam.pose.position, cam.pixel_ray(130, 127), 0.0).unwrap();
    assert!((centre.point.y + by / 2.0).abs() < 1e-5, "{}", centre.point);
    assert!((centre.t - (6.0 - by / 2.0)).abs() < 2e-3, "{}", centre.t);
}

/// OBJ meshes load through `tobj`, take their material from the MTL name and render.
#[test]
fn obj_mesh_loads_and_renders() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("cube.obj");
    std::fs::write(dir.path().join("cube.mtl"), "newmtl radiator_white\nKd 0.9 0.9 0.9\n").unwrap();
    let mut text = String::from("mtllib cube.mtl\no cube\nusemtl radiator_white\n");
    for z in [-1, 1] {
        for y in [-1, 1] {
            for x in [-1, 1] {
                text += &format!("v {x} {y} {z}\n");
            }
        }
    }
    // Vertex index = 1 + (x>0) + 2 (y>0) + 4 (z>0); quads counter-clockwise from outside.
    text += "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
    std::fs::write(&obj, text).unwrap();
    let sc = Scene::from_obj(&obj, Material::MliKapton, 0.25).unwrap();
    assert_eq!(sc.triangles.len(), 12);
    assert!(sc.faces.iter().all(|f| f.material == Material::WhitePaint));
    for (t, &f) in sc.triangles.iter().zip(&sc.triangle_face) {
        let c = Vec3::from(t.v0 + t.v1 + t.v2) / 3.0;
        assert!(c.dot(sc.faces[f as usize].normal) > 0.0, "inward normal");
    }
    assert!((sc.radius - 0.25 * 3f32.sqrt()).abs() < 1e-5);
    let cam = Camera::study(64, Pose::look_at(Vec3::new(2.0, -3.0, 1.0), Vec3::ZERO, Vec3::Z));
    let img = render_vis(
        &sc,
        &cam,
        &VisParams { sun_dir: Vec3::new(1.0, -1.0, 1.0).normalize(), ..VisParams::light() },
    );
    assert!(img.at(32, 32) > 0.3, "the lit cube should be bright at the centre");
    assert_eq!(img.at(0, 0), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Shading: shadows, eclipse, TIR

/// A white-paint plate with internal heat (+x side of a box) faces the sun but sits in the
/// shadow of a screen; seen from the side it is black in VIS and still warm in TIR.
#[test]
fn shadowed_face_is_dark_in_vis_and_warm_in_tir() {
    let build = |screen: bool| {
        let mut m = MeshBuilder::new();
        let mut sides = [None; 6];
        for (i, s) in sides.iter_mut().enumerate() {
            let node = m.new_node();
            *s = Some(if i == 1 {
                (Material::WhitePaint, node, 100.0)
            } else {
                (Material::MliKapton, node, 0.0)
            });
        }
        m.add_box(Vec3::splat(-0.5), Vec3::splat(0.5), sides);
        if screen {
            let node = m.new_node();
            let s = Some((Material::MliKapton, node, 0.0));
            m.add_box(Vec3::new(2.0, -0.7, -0.7), Vec3::new(2.05, 0.7, 0.7), [s; 6]);
        }
        m.build().unwrap()
    };
    let (shaded, open) = (build(true), build(false));
    let plus_x = 1usize; // face index of the +x side (faces are added in side order)
    assert!((shaded.faces[plus_x].normal - Vec3::X).length() < 1e-6);

    // Camera off to the side, looking at the face centre past the screen's edge.
    let cam = Camera::study(64, Pose::look_at(Vec3::new(5.0, -4.0, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::Z));
    // (A pixel off the quad's diagonals, which are shared triangle edges.)
    let (px, py) = (33, 29);
    let hit = shaded.intersect(cam.pose.position, cam.pixel_ray(px, py), 0.0).unwrap();
    assert_eq!(hit.face as usize, plus_x, "the centre pixel must see the +x side, not the screen");

    let vis = VisParams { sun_dir: Vec3::X, earthshine: 0.0, specular: false, ..VisParams::light() };
    let dark = render_vis(&shaded, &cam, &vis);
    let lit = render_vis(&open, &cam, &vis);
    assert_eq!(dark.at(px, py), 0.0, "shadowed face must be black in VIS");
    assert!(lit.at(px, py) > 0.8, "the same face unshadowed: {}", lit.at(px, py));

    let thermal = ThermalParams { sun_dir: Vec3::X, ..ThermalParams::default() };
    assert!(sunlit_fractions(&shaded, Vec3::X, 64)[plus_x] < 0.01);
    assert!(sunlit_fractions(&open, Vec3::X, 64)[plus_x] > 0.99);
    let t_shaded = face_temperatures(&shaded, &steady_state(&shaded, &thermal));
    let t_open = face_temperatures(&open, &steady_state(&open, &thermal));
    let (ts, to) = (t_shaded[plus_x], t_open[plus_x]);
    assert!(ts > 230.0, "shadowed face has no floor: {ts} K");
    assert!(to > ts + 15.0, "sunlight should warm the face: {to} K vs {ts} K");

    let tir = TirParams::default();
    let img = render_tir(&shaded, &cam, &t_shaded, &tir);
    // The face pixel is the emitted radiance at the face temperature, times the cos⁴ fall-off.
    let eps = Material::WhitePaint.props().ir_emittance;
    let cos4 = f64::from(cam.pose.forward().dot(cam.pixel_ray(px, py))).powi(4);
    let expected = tir.value_of_radiance(cos4 * eps * TirParams::blackbody_radiance(f64::from(ts))) as f32;
    assert!((img.at(px, py) - expected).abs() < 1e-3 * expected, "{} vs {expected}", img.at(px, py));
    assert!(img.at(px, py) > 0.05, "warm face should stand out: {}", img.at(px, py));
    assert!(img.at(0, 0) <= 0.0, "space is below T_min");
    // TIR has no shadows: with the same temperatures, the screen changes nothing on the face.
    let img_open = render_tir(&open, &cam, &t_shaded[..open.faces.len()], &tir);
    assert_eq!(img.at(px, py), img_open.at(px, py));
}

fn tango_pose(frame: usize) -> (Scene, Pose) {
    let sc = Scene::tango().unwrap();
    let pose = trajectory(&DatasetConfig::default(), sc.centre)[frame].pose;
    (sc, pose)
}

/// A pixel of an `n × n`-sampled render is the mean of the `n × n` pixels of a render at `n`
/// times the resolution (its sub-pixel centres are their centres, its footprint theirs): the
/// sampled VIS render against the box-filtered large one, surface detail included.
#[test]
fn sub_pixel_samples_average_the_finer_render() {
    let (scene, pose) = tango_pose(3);
    let scene = scene.with_surface_detail(0);
    let (size, n) = (96u32, 4u32);
    let params = VisParams::light();
    let sampled = render_vis(&scene, &Camera::study(size, pose), &VisParams { samples: n, ..params });
    let fine = render_vis(&scene, &Camera::study(size * n, pose), &params);
    let (mut partial, mut covered) = (0, 0);
    for y in 0..size {
        for x in 0..size {
            let block: Vec<f32> = (0..n)
                .flat_map(|j| (0..n).map(move |i| (x * n + i, y * n + j)))
                .map(|(u, v)| fine.at(u, v))
                .collect();
            let mean = block.iter().sum::<f32>() / (n * n) as f32;
            let v = sampled.at(x, y);
            assert!((v - mean).abs() <= 1e-6 * mean.abs().max(1.0), "({x}, {y}): {v} vs {mean}");
            covered += usize::from(v > 0.0);
            partial += usize::from(block.contains(&0.0) && block.iter().any(|&b| b > 0.0));
        }
    }
    // The target is in view, and its outline is anti-aliased (pixels part target, part space).
    assert!(covered > 100 && partial > 20, "{covered} covered, {partial} on the outline");
}

/// In eclipse only the weak earthshine lights the target; without it the frame is all zero.
#[test]
fn eclipse_vis_is_dark() {
    let (sc, pose) = tango_pose(6);
    let cam = Camera::study(128, pose);
    let light = render_vis(&sc, &cam, &VisParams::light());
    let eclipse = render_vis(&sc, &cam, &VisParams::eclipse());
    let lit_px = light.data.iter().filter(|&&v| v > 0.1).count();
    assert!(lit_px > 40, "the sunlit target should be visible: {lit_px} px > 0.1");
    let max = eclipse.data.iter().copied().fold(0.0f32, f32::max);
    // Earthshine × exposure × (albedo + specular lobe ≤ 1).
    let p = VisParams::eclipse();
    assert!(max > 0.0 && max <= p.earthshine * p.exposure, "eclipse max {max}");
    assert!(eclipse.mean() < 0.05 * light.mean(), "{} vs {}", eclipse.mean(), light.mean());
    assert!(eclipse.to_gray8().iter().all(|&v| v <= 10));
    let none = render_vis(&sc, &cam, &VisParams { earthshine: 0.0, ..VisParams::eclipse() });
    assert!(none.data.iter().all(|&v| v == 0.0));
}

/// Radiometric mode: radiance does not depend on range or on the facet's tilt. Study mode: the
/// view-factor weighting falls as 1/S² and with the facet's obliquity, and equals the
/// radiometric value face-on at the reference range.
#[test]
fn radiometric_and_study_modes() {
    let plate = |tilt_deg: f32| {
        let mut m = MeshBuilder::new();
        let (s, c) = tilt_deg.to_radians().sin_cos();
        // A 2 m square facing −y, tilted about z, through the origin but not centred on it (the
        // optical axis must not run along a diagonal, a shared triangle edge).
        let (u, n) = (Vec3::new(c, s, 0.0), Vec3::new(s, -c, 0.0));
        let o = 0.3 * u + 0.2 * Vec3::Z;
        let q = [o - u - Vec3::Z, o + u - Vec3::Z, o + u + Vec3::Z, o - u + Vec3::Z];
        m.add_quad(q, Material::WhitePaint, 0, 0.0);
        let sc = m.build().unwrap();
        assert!((sc.faces[0].normal - n).length() < 1e-5);
        sc
    };
    let temps = [300.0f32];
    let radiance = |tir: &TirParams, sc: &Scene, range: f32| {
        // 33² px: the centre of pixel (16, 16) is on the optical axis.
        let cam = Camera::study(33, Pose::look_at(Vec3::new(0.0, -range, 0.0), Vec3::ZERO, Vec3::Z));
        let v = f64::from(render_tir(sc, &cam, &temps, tir).at(16, 16));
        let (lo, hi) = (TirParams::blackbody_radiance(tir.t_min), TirParams::blackbody_radiance(tir.t_max));
        lo + v * (hi - lo)
    };
    let radiometric = TirParams { dn_mapping: DnMapping::Radiance, ..TirParams::default() };
    let study = TirParams { radiometry: Radiometry::Study, ..radiometric };
    let s_ref = radiometric.study_reference_range as f32;
    let flat = plate(0.0);
    let tilted = plate(60.0);
    let l0 = radiance(&radiometric, &flat, s_ref);
    let rel = |a: f64, b: f64| (a - b).abs() / b;
    assert!(rel(radiance(&radiometric, &flat, 2.0 * s_ref), l0) < 1e-4);
    assert!(rel(radiance(&radiometric, &tilted, s_ref), l0) < 1e-4);
    assert!(rel(radiance(&study, &flat, s_ref), l0) < 1e-3);
    assert!(rel(radiance(&study, &flat, 2.0 * s_ref), l0 / 4.0) < 1e-3);
    assert!(rel(radiance(&study, &tilted, s_ref), l0 / 2.0) < 2e-3);
    // The temperature DN mapping is linear in brightness temperature.
    let t = TirParams { dn_mapping: DnMapping::Temperature, ..radiometric };
    let v = t.value_of_radiance(TirParams::blackbody_radiance(275.0));
    assert!((v - 0.5).abs() < 1e-9);
}

// ---------------------------------------------------------------------------------------------
// Noise

fn variance(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = v.clone().count() as f64;
    let mean = v.clone().sum::<f64>() / n;
    (mean, v.map(|x| (x - mean).powi(2)).sum::<f64>() / n)
}

/// On a flat mid-grey region (no clipping, blur changes nothing) the measured variance is the
/// setting: 0.0022 for VIS, 0.0022 + 0.0022 for TIR (white + 1/f), also after 8-bit DN.
#[test]
fn noise_variance_on_a_flat_region_matches_the_setting() {
    let flat = Image { width: 256, height: 256, data: vec![0.5; 256 * 256] };
    let p = NoiseParams::default();
    assert_eq!(p.awgn_variance, 0.0022);
    let vis = apply_sensor_noise(&flat, &p, Band::Vis, &mut rng_for(7, 1));
    let (mean, var) = variance(vis.data.iter().map(|&v| f64::from(v)));
    assert!((mean - 0.5).abs() < 1e-3, "mean {mean}");
    assert!((var / 0.0022 - 1.0).abs() < 0.03, "VIS variance {var}");
    let (_, var8) = variance(vis.to_gray8().iter().map(|&v| f64::from(v) / 255.0));
    assert!((var8 / 0.0022 - 1.0).abs() < 0.03, "8-bit VIS variance {var8}");

    let tir = apply_sensor_noise(&flat, &p, Band::Tir, &mut rng_for(7, 2));
    let (_, var) = variance(tir.data.iter().map(|&v| f64::from(v)));
    assert!((var / 0.0044 - 1.0).abs() < 0.06, "TIR variance {var}");
    // A different setting is honoured too (the check is not tuned to the default).
    let q = NoiseParams { awgn_variance: 0.01, pink_variance: 0.0, ..p };
    let (_, var) = variance(
        apply_sensor_noise(&flat, &q, Band::Tir, &mut rng_for(7, 3)).data.iter().map(|&v| f64::from(v)),
    );
    assert!((var / 0.01 - 1.0).abs() < 0.03, "variance {var}");
}

/// Least-squares slope of ln P against ln f.
fn loglog_slope(spectrum: &[(f64, f64)]) -> f64 {
    let pts: Vec<(f64, f64)> = spectrum.iter().map(|&(f, p)| (f.ln(), p.ln())).collect();
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    sxy / sxx
}

/// The 1/f field has power ∝ f^(−2α): slope −2 for α = 1 (and −3 for α = 1.5, so the fit is
/// not fixed at −2); white noise is flat; the field is normalised to unit variance.
#[test]
fn pink_noise_spectrum_slope_is_minus_two() {
    let n = 256usize;
    let mut rng: NoiseRng = rng_for(3, 0);
    for (alpha, want) in [(1.0, -2.0), (1.5, -3.0), (0.0, 0.0)] {
        let mut avg = vec![(0.0, 0.0); 0];
        for _ in 0..4 {
            let field = pink_noise(n as u32, n as u32, alpha, &mut rng);
            let (mean, var) = variance(field.iter().map(|&v| f64::from(v)));
            assert!(mean.abs() < 1e-6 && (var - 1.0).abs() < 1e-6);
            let s = radial_power_spectrum(&field, n);
            if avg.is_empty() {
                avg = s;
            } else {
                avg.iter_mut().zip(s).for_each(|(a, b)| a.1 += b.1);
            }
        }
        let band: Vec<(f64, f64)> =
            avg.into_iter().filter(|&(f, _)| f >= 2.0 / n as f64 && f <= 0.45).collect();
        let slope = loglog_slope(&band);
        assert!((slope - want).abs() < 0.1, "alpha {alpha}: slope {slope}, want {want}");
    }
}

// ---------------------------------------------------------------------------------------------
// Datasets

fn files_under(root: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.strip_prefix(root).unwrap().to_path_buf(), std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

fn small_config() -> DatasetConfig {
    DatasetConfig {
        tir_16bit: true,
        tir_eclipse_minutes: Some(30.0),
        contact_sheet_frames: 2,
        ..DatasetConfig::small(3, 64)
    }
}

/// Same seed, same bytes — on one thread and on two; another seed changes only the noisy files.
#[test]
fn two_renders_with_one_seed_are_byte_identical() {
    let cfg = small_config();
    let (a, b, c) =
        (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    pool(1).install(|| render_dataset(&cfg, a.path(), false)).unwrap();
    pool(2).install(|| render_dataset(&cfg, b.path(), false)).unwrap();
    let (fa, fb) = (files_under(a.path()), files_under(b.path()));
    // 6 sets × 3 frames × (clean, noisy) PNGs, + 16-bit for the 4 TIR sets, + manifest + sheet.
    assert_eq!(fa.len(), 6 * 3 * 2 + 4 * 3 * 2 + 2, "{:?}", fa.keys().collect::<Vec<_>>());
    assert_eq!(fa.keys().collect::<Vec<_>>(), fb.keys().collect::<Vec<_>>());
    for (k, v) in &fa {
        assert!(fb[k] == *v, "{} differs between two renders with one seed", k.display());
    }
    render_dataset(&DatasetConfig { seed: cfg.seed + 1, ..cfg.clone() }, c.path(), false).unwrap();
    let fc = files_under(c.path());
    for (k, v) in &fa {
        let name = k.to_string_lossy();
        let noisy = name.contains("noisy");
        if name.ends_with(".png") && !name.contains("contact") {
            assert_eq!(fc[k] == *v, !noisy, "{name}: noisy files follow the seed, clean ones do not");
        }
    }
    assert_ne!(noise_stream("tir32", 0), noise_stream("tir64", 0));
}

/// The manifest records poses, the sun, temperatures, noise, seed and files, and the files it
/// names exist with the stated sizes; 16-bit TIR carries the same picture as 8-bit.
#[test]
fn manifest_and_files() {
    let cfg = small_config();
    let dir = tempfile::tempdir().unwrap();
    let m = render_dataset(&cfg, dir.path(), false).unwrap();
    let text = std::fs::read_to_string(dir.path().join("manifest.json")).unwrap();
    let back: Manifest = serde_json::from_str(&text).unwrap();
    assert_eq!((back.seed, &back.sets, back.frames.len()), (m.seed, &m.sets, m.frames.len()));
    assert_eq!(back.frames[1].files, m.frames[1].files);
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in ["seed", "sun_direction", "temperature_range_k", "node_temperatures_k", "sets", "frames"] {
        assert!(json.get(key).is_some(), "manifest lacks {key}");
    }
    assert_eq!(json["config"]["noise"]["awgn_variance"], 0.0022);
    assert_eq!(json["config"]["noise"]["blur_sigma_px"], 1.0);
    assert_eq!(m.seed, 1);
    assert_eq!(m.temperature_range_k, [150.0, 400.0]);
    let names: Vec<&str> = m.sets.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["vis_light", "vis_eclipse", "tir32", "tir64", "tir32_eclipse", "tir64_eclipse"]);
    let sun = Vec3::from(m.sun_direction);
    assert!((sun.length() - 1.0).abs() < 1e-5);
    // Eclipse cools every node.
    let ecl = m.eclipse_node_temperatures_k.as_ref().unwrap();
    assert!(m.node_temperatures_k.iter().zip(ecl).all(|(a, b)| b <= a));
    assert_eq!(m.frames.len(), 3);
    for f in &m.frames {
        let range = (Vec3::from(f.position_m) - Vec3::from(m.target_centre_m)).length();
        assert!((range - f.range_m).abs() < 1e-4 && (3.99..=7.26).contains(&range), "range {range}");
        for s in &m.sets {
            let ff = &f.files[&s.name];
            let img = image::open(dir.path().join(ff.clean.as_ref().unwrap())).unwrap();
            assert_eq!((img.width(), img.height()), (s.width, s.height));
            assert!(dir.path().join(ff.noisy.as_ref().unwrap()).is_file());
            if s.band == Band::Tir {
                let c8 = img.to_luma8();
                let c16 = image::open(dir.path().join(ff.clean16.as_ref().unwrap())).unwrap().to_luma16();
                assert!(
                    c8.iter().zip(c16.iter()).all(|(&a, &b)| (i32::from(a) - i32::from(b >> 8)).abs() <= 1)
                );
                assert!(c16.iter().any(|&v| v % 256 != 0), "16-bit output must carry more than 8 bits");
            } else {
                assert!(ff.clean16.is_none());
            }
        }
    }
    let sheet = image::open(dir.path().join("contact_sheet.png")).unwrap();
    assert_eq!(m.contact_sheet_columns, [0, 2]);
    assert_eq!(m.contact_sheet_rows.len(), 12);
    // 2 columns x 12 rows of 32-px tiles with 2-px gaps; the column names on top (one 20-px line),
    // the row names (`set/clean`, `set/noisy`) in a band as wide as the longest, 10 px a character.
    let left = m.contact_sheet_rows.iter().map(|r| r.len()).max().unwrap() * 10 + 2;
    assert_eq!((sheet.width(), sheet.height()), (left as u32 + 2 * 34 + 2, 22 + 12 * 34 + 2));
    // The eclipse TIR is cooler than the sunlit one.
    let mean = |rel: &str| {
        let img = image::open(dir.path().join(rel)).unwrap().to_luma8();
        img.iter().map(|&v| f64::from(v)).sum::<f64>() / img.len() as f64
    };
    let f0 = &m.frames[0].files;
    assert!(mean(f0["tir64_eclipse"].clean.as_ref().unwrap()) < mean(f0["tir64"].clean.as_ref().unwrap()));
}

/// With a focal plane, every TIR set also gets raw counts and the shutter's flat fields, and
/// each TIR size its factory calibration (the eclipse sets share their size's); the tables,
/// applied by hand in f64, take a raw frame back to the noisy frame's counts within the
/// calibration's stated error (the raw pattern is tens of times larger); the frame the shutter
/// froze repeats the one before; without a focal plane the manifest is as before.
#[test]
fn raw_thermal_counts_in_the_study_layout() {
    use render_host::focal_plane::FocalPlaneParams;
    let p = FocalPlaneParams { shutter_period_s: 2.0, ..FocalPlaneParams::default() };
    let cfg = DatasetConfig {
        focal_plane: Some(p),
        tir_eclipse_minutes: Some(30.0),
        contact_sheet_thumb: 0,
        ..DatasetConfig::small(4, 64)
    };
    let dir = tempfile::tempdir().unwrap();
    let m = render_dataset(&cfg, dir.path(), false).unwrap();
    let tir: Vec<_> = m.sets.iter().filter(|s| s.band == Band::Tir).collect();
    assert_eq!(tir.len(), 4);
    for s in &tir {
        assert_eq!(s.nuc.as_deref(), Some(format!("calibration/tir{}.nuc", s.width).as_str()), "{}", s.name);
        assert_eq!(
            s.bad_pixels.as_deref(),
            Some(format!("calibration/tir{}_bad_pixels.png", s.width).as_str())
        );
    }
    assert!(m.sets.iter().filter(|s| s.band == Band::Vis).all(|s| s.nuc.is_none()));
    // Shutter every 2 s at 1 Hz: closes at frame 2, freezing it.
    let frozen: Vec<bool> = m.frames.iter().map(|f| f.tir_frozen).collect();
    assert_eq!(frozen, [false, false, true, false]);
    assert_eq!(m.frames[3].fpa_delta_k, Some(3.0 * p.fpa_drift_k_per_s));
    for f in &m.frames {
        for s in &tir {
            let ff = &f.files[&s.name];
            assert_eq!(ff.shutter.is_some(), f.index == 2, "{} frame {}", s.name, f.index);
            assert!(ff.raw.is_some());
        }
        assert!(f.files["vis_light"].raw.is_none());
    }
    let read = |rel: &Option<String>| std::fs::read(dir.path().join(rel.as_ref().unwrap())).unwrap();
    assert_eq!(read(&m.frames[2].files["tir64"].raw), read(&m.frames[1].files["tir64"].raw));
    assert_ne!(read(&m.frames[3].files["tir64"].raw), read(&m.frames[1].files["tir64"].raw));

    let tables = fusion_io::thermal::NucTables::read(&dir.path().join("calibration/tir64.nuc")).unwrap();
    let bad =
        fusion_io::thermal::BadPixels::read(&dir.path().join("calibration/tir64_bad_pixels.png")).unwrap();
    assert_eq!((tables.width, tables.height, bad.width, bad.height), (64, 64, 64, 64));
    let f0 = &m.frames[0].files["tir64"];
    let raw = image::open(dir.path().join(f0.raw.as_ref().unwrap())).unwrap().to_luma16();
    let noisy = image::open(dir.path().join(f0.noisy.as_ref().unwrap())).unwrap().to_luma8();
    let scene_counts = p.responsivity_counts_per_k * (cfg.tir.t_max - cfg.tir.t_min) / 255.0;
    let (mut raw_err, mut nuc_err, mut n) = (0.0, 0.0, 0.0);
    for (i, (&r, &v)) in raw.iter().zip(noisy.iter()).enumerate() {
        if bad.is_bad(i % 64, i / 64) {
            continue;
        }
        let ideal = f64::from(v) * scene_counts;
        let corrected = f64::from(r) * f64::from(tables.gain[i]) / 16_384.0 + f64::from(tables.offset[i]);
        raw_err += (f64::from(r) - ideal).abs();
        nuc_err += (corrected - ideal).abs();
        n += 1.0;
    }
    let (raw_err, nuc_err) = (raw_err / n, nuc_err / n);
    // Left after the tables: the 0.3 K calibration error, NETD and the 8-bit quantisation of
    // the comparison (one level = 39 counts), in counts; the raw frame is off by its pedestal.
    let bound = p.responsivity_counts_per_k * (p.calibration_offset_error_k + p.netd_k) + scene_counts;
    assert!(nuc_err < bound, "mean |error| after the tables {nuc_err:.1} counts, bound {bound:.1}");
    assert!(raw_err > 20.0 * bound, "raw mean |error| {raw_err:.1}");

    let plain = tempfile::tempdir().unwrap();
    let m = render_dataset(
        &DatasetConfig { contact_sheet_thumb: 0, ..DatasetConfig::small(2, 32) },
        plain.path(),
        false,
    )
    .unwrap();
    let text = std::fs::read_to_string(plain.path().join("manifest.json")).unwrap();
    for key in ["focal_plane", "nuc", "bad_pixels", "raw", "shutter", "fpa_delta_k", "tir_frozen"] {
        assert!(!text.contains(&format!("\"{key}\"")), "{key} in a manifest without raw counts");
    }
    assert!(!plain.path().join("calibration").exists() && m.frames[0].fpa_delta_k.is_none());
}

/// Binary-mask centroid in relative image coordinates (0..1).
fn centroid(img: &Image, inside: impl Fn(f32) -> bool) -> (f64, f64, usize) {
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0usize);
    for y in 0..img.height {
        for x in 0..img.width {
            if inside(img.at(x, y)) {
                sx += f64::from(x) + 0.5;
                sy += f64::from(y) + 0.5;
                n += 1;
            }
        }
    }
    (sx / n as f64 / f64::from(img.width), sy / n as f64 / f64::from(img.height), n)
}

/// One pose, three cameras: the 2N² TIR, the N² TIR and the 2N² VIS put the target at the same
/// relative position.
///
/// A binary mask's centroid carries a sampling error of up to half a pixel per edge, so single
/// poses are only checked loosely; over 60 poses (the 20 dataset positions, three aim points
/// each, putting the target off the image centre) the error averages out, while a systematic
/// slip, such as sampling pixel corners instead of centres (which moves the N² image by 0.25 of
/// its pixels relative to the 2N² one), would not. VIS and TIR of one size trace the same rays.
#[test]
fn tir_and_vis_at_both_sizes_align() {
    let mut m = MeshBuilder::new();
    let [bx, by, bz] = render_host::scene::tango::BUS;
    let node = m.new_node();
    m.add_box(
        Vec3::new(-bx, -by, -bz) / 2.0,
        Vec3::new(bx, by, bz) / 2.0,
        [Some((Material::MliKapton, node, 0.0)); 6],
    );
    let bus = m.build().unwrap();
    let tango = Scene::tango().unwrap();
    let cfg = DatasetConfig::default();
    let tir = TirParams::default();
    let background = tir.value_of_radiance(0.0) as f32;
    for (name, scene) in [("bus", &bus), ("tango", &tango)] {
        let temps = face_temperatures(scene, &steady_state(scene, &ThermalParams::default()));
        let (mut sum, mut sum2, mut count) = ([0.0f64; 2], 0.0f64, 0.0f64);
        for tp in trajectory(&cfg, tango.centre) {
            for offset in
                [Vec3::new(0.25, -0.2, 0.15), Vec3::new(-0.3, 0.1, -0.2), Vec3::new(0.05, 0.3, 0.25)]
            {
                // Aim off the target so it sits away from the image centre.
                let pose = Pose::look_at(tp.pose.position, tango.centre + offset, -tp.pose.rotation.y_axis);
                let (small, large) = (Camera::study(64, pose), Camera::study(128, pose));
                let t64 = render_tir(scene, &small, &temps, &tir);
                let t128 = render_tir(scene, &large, &temps, &tir);
                let (ax, ay, an) = centroid(&t64, |v| v > background);
                let (bx, by, bn) = centroid(&t128, |v| v > background);
                assert!(an > 20, "{name}: target too small to test: {an} px");
                let (dx, dy) = ((ax - bx) * 64.0, (ay - by) * 64.0);
                assert!(dx.abs() < 1.0 && dy.abs() < 1.0, "{name}: centroids differ by ({dx}, {dy}) px");
                sum[0] += dx;
                sum[1] += dy;
                sum2 += dx * dx + dy * dy;
                count += 1.0;
                // Light from (near) the camera: nearly every visible face is lit, so the VIS mask
                // is the hit mask but for a few grazing or parallax-shadowed pixels.
                let sun_dir = (pose.position - tango.centre).normalize();
                let vis = VisParams { sun_dir, earthshine: 0.0, ..VisParams::light() };
                let v128 = render_vis(scene, &large, &vis);
                let (cx, cy, cn) = centroid(&v128, |v| v > 0.0);
                let stray = v128.data.iter().zip(&t128.data).filter(|&(&v, &t)| v > 0.0 && t <= background);
                assert_eq!(stray.count(), 0, "{name}: VIS sees the target where TIR does not");
                assert!(bn >= cn && bn - cn <= bn / 20, "{name}: hit pixels TIR {bn} vs VIS {cn}");
                assert!((bx - cx).abs() * 128.0 < 1.0 && (by - cy).abs() * 128.0 < 1.0);
            }
        }
        let (mx, my) = (sum[0] / count, sum[1] / count);
        let rms = (sum2 / count).sqrt();
        eprintln!("{name}: mean centroid offset ({mx:.3}, {my:.3}) px of 64², rms {rms:.3} px");
        assert!(mx.abs() < 0.08 && my.abs() < 0.08, "{name}: systematic offset ({mx}, {my}) px");
        assert!(rms < 0.4, "{name}: rms offset {rms} px");
    }
}

/// The render options drive the dataset: sizes, frames, radiometry and the sheet; bad options
/// are refused before anything is written.
#[test]
fn render_options_render_a_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ds");
    fusion_io::console::set_quiet(true);
    let a = RenderOptions {
        out: out.clone(),
        frames: Some(2),
        vis_size: 48,
        tir_sizes: Some(vec![24, 48]),
        sheet_frames: 0,
        radiometry: Radiometry::Study,
        ..RenderOptions::default()
    };
    let cfg = a.config().unwrap();
    assert_eq!((cfg.frames, cfg.vis_size, cfg.tir_sizes.clone()), (2, 48, vec![24, 48]));
    assert_eq!(cfg.tir.radiometry, Radiometry::Study);
    let summary = render_host::render(&a).unwrap();
    assert!(summary.starts_with("wrote 16 images in 4 sets x 2 frames"), "{summary}");
    let m: Manifest = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m.frames.len(), 2);
    assert_eq!(m.contact_sheet_columns, [0, 1]);
    assert!(out.join("tir24/noisy/frame_001.png").is_file());
    assert!(out.join("vis_eclipse/clean/frame_000.png").is_file());
    let bad = [
        RenderOptions { frames: Some(0), ..a.clone() },
        RenderOptions { t_min: 400.0, t_max: 300.0, ..a.clone() },
        RenderOptions { tir_sizes: Some(vec![0]), ..a.clone() },
        RenderOptions { out: dir.path().join("never"), exposure: f32::NAN, ..a.clone() },
    ];
    for b in &bad {
        assert!(b.config().is_err() && render_host::render(b).is_err(), "{b:?} should be refused");
    }
    assert!(!dir.path().join("never").exists(), "a refused render writes nothing");
}
