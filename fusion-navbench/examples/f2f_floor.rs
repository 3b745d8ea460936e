//! The frame-to-frame floor of the model-based front end: what its estimator gives when fed
//! *perfect* tracks, as few as a stream keeps.
//!
//! The front end scores a frame pair by the relative pose between two absolute PnP poses
//! (each frame's tracks against their 3D points on the model). Here the tracks are exact: `N`
//! target surface points (the model hit through pixels drawn at random inside the target's
//! box at the true pose of frame k − 1, visible in both frames), projected with each frame's
//! true pose and perturbed by `σ` px of white noise, through the same PnP-RANSAC and
//! Levenberg–Marquardt (`fusion_navbench::pose::estimate`). The median rotation error of the
//! pairs, per `N` and `σ`, over a sequence's frames in light, is the best a front end with
//! that many tracks at that noise can score; compare with the streams' errors binned by their
//! inliers (`per_frame.csv`).
//!
//! `cargo run --release -p fusion-navbench --example f2f_floor -- DIR [N,N,…] [σ,σ,…] [DRAWS]`
//! (`DIR`: a rendered sequence, e.g. `OUT/data/seed-1/flyaround` of `fusion navbench`).

use fusion_navbench::baseline::{observe, target_to_camera};
use fusion_navbench::model::TargetModel;
use fusion_navbench::pose::{RelativePose, estimate};
use render_host::Camera;
use render_host::glam::{DMat3, DQuat};
use render_host::noise::{SplitMix64, mix64};
use render_host::sequence::{Phase, read_manifest};

fn list<T: std::str::FromStr>(arg: Option<&String>, default: &str) -> Vec<T> {
    arg.map_or(default, String::as_str).split(',').filter_map(|s| s.trim().parse().ok()).collect()
}

/// A uniform deviate in `[lo, hi)`.
fn uniform(rng: &mut SplitMix64, lo: u32, hi: u32) -> f64 {
    f64::from(lo) + (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * f64::from(hi - lo)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let dir = std::path::PathBuf::from(args.get(1).map_or("data/flyaround", String::as_str));
    let counts: Vec<usize> = list(args.get(2), "8,12,16,20,30,45,70,100,150");
    let sigmas: Vec<f64> = list(args.get(3), "0.3,0.5,1.0");
    let draws: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(5);
    let m = read_manifest(&dir)?;
    let scene = m.config.target.scene()?.with_surface_detail(m.config.surface_seed);
    let model = TargetModel::new(&scene);
    let size = m.vis_camera.size;
    let cams: Vec<Camera> = m.frames.iter().map(|f| Camera::study(size, f.pose())).collect();
    let f = f64::from(cams[0].focal_px);
    println!(
        "{} ({} frames, {size}²): median frame-to-frame rotation error, °, of the light pairs",
        dir.display(),
        cams.len()
    );
    print!("{:>6}", "N");
    for s in &sigmas {
        print!(" {:>14}", format!("σ {s} px"));
    }
    println!("   (pairs estimated)");
    for &n in &counts {
        print!("{n:>6}");
        for &sigma in &sigmas {
            let mut errors = Vec::new();
            for k in 1..cams.len() {
                if m.frames[k].phase != Phase::Light {
                    continue;
                }
                let (a, b) = (&cams[k - 1], &cams[k]);
                let Some((x0, y0, x1, y1)) = model.image_box(a, 0.0) else { continue };
                for d in 0..draws {
                    let mut rng = SplitMix64::new(mix64((k as u64) << 32 ^ (d as u64) << 8 ^ n as u64));
                    // N surface points seen in both frames.
                    let mut points = Vec::new();
                    for _ in 0..(n * 200) {
                        if points.len() == n {
                            break;
                        }
                        let (u, v) = (uniform(&mut rng, x0, x1), uniform(&mut rng, y0, y1));
                        if let Some(hit) = model.back_project(a, u, v)
                            && model.visible(b, hit.point)
                        {
                            points.push(hit.point);
                        }
                    }
                    if points.len() < n {
                        continue;
                    }
                    // Each frame's absolute pose from its exact, noisy tracks, as a stream's.
                    let mut measure = |cam: &Camera, salt: u64| {
                        let (p3, p2) = observe(&points, &target_to_camera(cam), f, sigma, &mut rng, |_| true);
                        estimate(&p3, &p2, f, salt).and_then(|(_, refined)| refined).map(|r| r.measurement())
                    };
                    let (Some(p), Some(q)) = (measure(a, 2 * k as u64), measure(b, 2 * k as u64 + 1)) else {
                        continue;
                    };
                    let to_mat = |q: DQuat| DMat3::from_quat(q);
                    let measured =
                        RelativePose::between(to_mat(p.attitude), p.position, to_mat(q.attitude), q.position);
                    let truth = RelativePose::between(
                        a.pose.rotation.as_dmat3(),
                        a.pose.position.as_dvec3(),
                        b.pose.rotation.as_dmat3(),
                        b.pose.position.as_dvec3(),
                    );
                    errors.push(measured.rotation_error_deg(&truth));
                }
            }
            errors.sort_by(f64::total_cmp);
            let med = errors.get(errors.len() / 2).copied().unwrap_or(f64::NAN);
            print!(" {:>14}", format!("{med:.3} ({})", errors.len()));
        }
        println!();
    }
    Ok(())
}
