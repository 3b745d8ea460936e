//! Shows the difference between the two TIR radiometric modes on the dataset's nearest and
//! farthest poses: mean and maximum 8-bit DN over the target's pixels, per material.
//!
//! ```sh
//! cargo run --release -p render-host --example radiometry_modes
//! ```

use render_host::scene::Material;
use render_host::{
    Camera, DatasetConfig, Radiometry, Scene, TirParams, face_temperatures, render_tir, steady_state,
    trajectory,
};

fn main() -> anyhow::Result<()> {
    let cfg = DatasetConfig::default();
    let scene = Scene::tango()?;
    let temps = face_temperatures(&scene, &steady_state(&scene, &cfg.thermal));
    let traj = trajectory(&cfg, scene.centre);
    let range = |i: usize| (traj[i].pose.position - scene.centre).length();
    let near = (0..traj.len()).min_by(|&a, &b| range(a).total_cmp(&range(b))).unwrap_or(0);
    let far = (0..traj.len()).max_by(|&a, &b| range(a).total_cmp(&range(b))).unwrap_or(0);
    println!("| frame | range | mode | material | pixels | mean DN | max DN |");
    println!("|---|---|---|---|---|---|---|");
    for i in [near, far] {
        let cam = Camera::study(512, traj[i].pose);
        for mode in [Radiometry::Radiometric, Radiometry::Study] {
            let tir = TirParams { radiometry: mode, ..cfg.tir };
            let img = render_tir(&scene, &cam, &temps, &tir).to_gray8();
            for m in Material::ALL {
                let mut dn = Vec::new();
                for y in 0..512 {
                    for x in 0..512 {
                        let hit = scene.intersect(cam.pose.position, cam.pixel_ray(x, y), 0.0);
                        if hit.is_some_and(|h| scene.faces[h.face as usize].material == m) {
                            dn.push(f64::from(img.get_pixel(x, y).0[0]));
                        }
                    }
                }
                if dn.is_empty() {
                    continue;
                }
                let mean = dn.iter().sum::<f64>() / dn.len() as f64;
                let max = dn.iter().copied().fold(0.0, f64::max);
                println!(
                    "| {i} | {:.2} m | {mode:?} | {m:?} | {} | {mean:.1} | {max:.0} |",
                    range(i),
                    dn.len()
                );
            }
        }
    }
    Ok(())
}
