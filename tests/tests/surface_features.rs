//! The rendered target gives a feature tracker something to hold on to (issue 20, item 1): with
//! the procedural surface detail, the navigation front end's detector
//! (`fusion_navbench::features::detect`) finds several times more corners on the target than
//! on the flat-shaded target of the same views: at least 3× in VIS, 2× in TIR in light and in
//! eclipse.

use fusion_navbench::features::{detect, grow_mask};
use render_host::dataset::trajectory;
use render_host::truth::target_mask;
use render_host::{
    Camera, DatasetConfig, Scene, ThermalParams, eclipse_transient, face_temperatures, render_tir,
    render_vis, steady_state,
};

#[test]
fn surface_detail_multiplies_the_features_on_the_target() {
    let cfg = DatasetConfig::default();
    let flat = Scene::tango().unwrap();
    let detailed = Scene::tango().unwrap().with_surface_detail(cfg.surface_seed);
    let thermal = ThermalParams { sun_dir: cfg.vis.sun_dir.normalize(), ..cfg.thermal };
    let node_t = steady_state(&flat, &thermal);
    let light_t = face_temperatures(&flat, &node_t);
    let eclipse_t = face_temperatures(&flat, &eclipse_transient(&flat, &thermal, &node_t, 1800.0));
    let traj = trajectory(&cfg, flat.centre);
    // (band, counts flat, counts detailed) over three views.
    let mut counts = [[0usize; 2]; 3];
    for i in [2, 8, 16] {
        for (k, scene) in [&flat, &detailed].into_iter().enumerate() {
            let vis_cam = Camera::study(1024, traj[i].pose);
            let tir_cam = Camera::study(512, traj[i].pose);
            let count = |img: &render_host::Image, cam: &Camera| {
                let mask = grow_mask(&target_mask(scene, cam), cam.width as usize, cam.height as usize, 3);
                let mut img = img.clone();
                img.clip();
                detect(&img.to_gray8(), Some(&mask)).len()
            };
            counts[0][k] += count(&render_vis(scene, &vis_cam, &cfg.vis), &vis_cam);
            counts[1][k] += count(&render_tir(scene, &tir_cam, &light_t, &cfg.tir), &tir_cam);
            counts[2][k] += count(&render_tir(scene, &tir_cam, &eclipse_t, &cfg.tir), &tir_cam);
        }
    }
    println!(
        "corners on the target, flat → detailed: VIS {:?}, TIR light {:?}, TIR eclipse {:?}",
        counts[0], counts[1], counts[2]
    );
    assert!(counts[0][1] >= 3 * counts[0][0], "VIS: {:?}", counts[0]);
    assert!(counts[1][1] >= 2 * counts[1][0], "TIR light: {:?}", counts[1]);
    assert!(counts[2][1] >= 2 * counts[2][0], "TIR eclipse: {:?}", counts[2]);
}
