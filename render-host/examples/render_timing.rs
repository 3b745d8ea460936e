//! Measures the two speed targets of the crate (run with `--release`): one 1024² VIS frame with
//! shadows on one core, and the full 20-frame dataset on all cores; plus the cost of each stage.
//!
//! ```sh
//! cargo run --release -p render-host --example render_timing [-- OUT_DIR [RUNS]]
//! ```
//!
//! Per-frame figures run on a one-thread rayon pool (the same as `RAYON_NUM_THREADS=1`) over the
//! 20 dataset poses; the dataset runs `RUNS` times (default 3) on the global pool, whose size
//! follows `RAYON_NUM_THREADS` (default: one thread per core). All figures are medians.

use render_host::image::Image;
use render_host::noise::rng_for;
use render_host::{
    Band, Camera, DatasetConfig, Scene, TirParams, VisParams, apply_sensor_noise, face_temperatures,
    render_dataset, render_tir, render_vis, steady_state, trajectory,
};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// Runs `f` once per item and returns the median time in ms.
fn time_each<T>(items: &[T], mut f: impl FnMut(&T)) -> f64 {
    median(
        items
            .iter()
            .map(|x| {
                let t = Instant::now();
                f(x);
                1e3 * t.elapsed().as_secs_f64()
            })
            .collect(),
    )
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let out = args.next().map_or_else(|| std::env::temp_dir().join("render-host-timing"), Into::into);
    let runs: usize = args.next().map_or(Ok(3), |s| s.parse())?;
    let cfg = DatasetConfig::default();
    let scene = Scene::tango()?;
    let poses: Vec<_> = trajectory(&cfg, scene.centre).iter().map(|t| t.pose).collect();
    let temps = face_temperatures(&scene, &steady_state(&scene, &cfg.thermal));
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    one.install(|| {
        let bb = std::hint::black_box::<Image>;
        let light = VisParams::light();
        let vis = time_each(&poses, |p| drop(bb(render_vis(&scene, &Camera::study(1024, *p), &light))));
        let ecl = VisParams::eclipse();
        let vis_e = time_each(&poses, |p| drop(bb(render_vis(&scene, &Camera::study(1024, *p), &ecl))));
        let tir = TirParams::default();
        let t512 = time_each(&poses, |p| drop(bb(render_tir(&scene, &Camera::study(512, *p), &temps, &tir))));
        let t1024 =
            time_each(&poses, |p| drop(bb(render_tir(&scene, &Camera::study(1024, *p), &temps, &tir))));
        println!("one core, median over {} poses:", poses.len());
        println!("  VIS 1024² in light (primary + shadow rays): {vis:.1} ms");
        println!("  VIS 1024² in eclipse (earthshine rays):     {vis_e:.1} ms");
        println!("  TIR 512²:                                   {t512:.1} ms");
        println!("  TIR 1024²:                                  {t1024:.1} ms");
        let img = render_vis(&scene, &Camera::study(1024, poses[6]), &light);
        let small = render_tir(&scene, &Camera::study(512, poses[6]), &temps, &tir);
        let seeds: Vec<u64> = (0..5).collect();
        let n = cfg.noise;
        let nv =
            time_each(&seeds, |&s| drop(bb(apply_sensor_noise(&img, &n, Band::Vis, &mut rng_for(s, 0)))));
        let nt =
            time_each(&seeds, |&s| drop(bb(apply_sensor_noise(&img, &n, Band::Tir, &mut rng_for(s, 0)))));
        let nt5 =
            time_each(&seeds, |&s| drop(bb(apply_sensor_noise(&small, &n, Band::Tir, &mut rng_for(s, 0)))));
        let png = time_each(&seeds, |_| {
            let mut buf = std::io::Cursor::new(Vec::new());
            img.to_gray8().write_to(&mut buf, image::ImageFormat::Png).ok();
            drop(std::hint::black_box(buf));
        });
        println!("  sensor noise VIS 1024² (blur + AWGN):       {nv:.1} ms");
        println!("  sensor noise TIR 1024² (+ 1/f by FFT):      {nt:.1} ms");
        println!("  sensor noise TIR 512²:                      {nt5:.1} ms");
        println!("  8-bit PNG encode of a 1024² frame:          {png:.1} ms");
    });

    let threads = rayon::current_num_threads();
    let mut times = Vec::new();
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let m = render_dataset(&cfg, &out, false)?;
        times.push(t.elapsed().as_secs_f64());
        assert_eq!(m.frames.len(), cfg.frames);
    }
    let all: Vec<String> = times.iter().map(|t| format!("{t:.2}")).collect();
    println!(
        "{threads} threads: dataset of 4 sets x {} frames (clean + noisy PNGs, manifest, contact sheet): \
         median {:.2} s over {} runs [{}] -> {}",
        cfg.frames,
        median(times.clone()),
        times.len(),
        all.join(", "),
        out.display()
    );
    Ok(())
}
