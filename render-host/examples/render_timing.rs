//! Measures the two speed targets of the crate (run with `--release`):
//! one 1024² VIS frame with shadows on one core, and the full 20-frame dataset on all cores.
//!
//! ```sh
//! cargo run --release -p render-host --example render_timing [-- OUT_DIR]
//! ```

use render_host::{
    Camera, DatasetConfig, Scene, TirParams, VisParams, face_temperatures, render_dataset, render_tir,
    render_vis, steady_state, trajectory,
};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let cfg = DatasetConfig::default();
    let scene = Scene::tango()?;
    let traj = trajectory(&cfg, scene.centre);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let temps = face_temperatures(&scene, &steady_state(&scene, &cfg.thermal));
    let (mut vis, mut tir) = (Vec::new(), Vec::new());
    one.install(|| {
        for tp in &traj {
            let t = Instant::now();
            std::hint::black_box(render_vis(&scene, &Camera::study(1024, tp.pose), &VisParams::light()));
            vis.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            std::hint::black_box(render_tir(
                &scene,
                &Camera::study(512, tp.pose),
                &temps,
                &TirParams::default(),
            ));
            tir.push(t.elapsed().as_secs_f64());
        }
    });
    println!(
        "one core: VIS 1024² in light (shadows): median {:.1} ms, max {:.1} ms over {} poses",
        1e3 * median(vis.clone()),
        1e3 * vis.iter().cloned().fold(0.0, f64::max),
        vis.len()
    );
    println!("one core: TIR 512²: median {:.1} ms", 1e3 * median(tir));

    let out = match std::env::args().nth(1) {
        Some(p) => std::path::PathBuf::from(p),
        None => std::env::temp_dir().join("render-host-timing"),
    };
    let threads = rayon::current_num_threads();
    let t = Instant::now();
    let m = render_dataset(&cfg, &out, false)?;
    println!(
        "{threads} threads: dataset of {} sets x {} frames (clean + noisy PNGs, manifest, contact sheet) in {:.2} s -> {}",
        m.sets.len(),
        m.frames.len(),
        t.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}
