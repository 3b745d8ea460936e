//! Probes the model-based front end on a rendered sequence with the true pose as its estimate:
//! per frame the tracks carried, the PnP inliers, the features added, and the pose's error.
//! `cargo run --release -p fusion-navbench --example tracker_probe -- DIR [vis|tir|vis_clean|tir_clean] [FRAMES]`;
//! `… -- render-lambertian DIR` renders the default fly-around without VIS's specular lobe.

use fusion_io::{ColorPolicy, load_gray_u8};
use fusion_navbench::model::TargetModel;
use fusion_navbench::tracker::{ModelTracker, TrackerParams, smooth};
use render_host::Camera;
use render_host::glam::DQuat;
use render_host::sequence::read_manifest;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    // `tracker_probe render-lambertian DIR`: the default fly-around without the VIS specular
    // lobe, to tell the tracker's limits from the scene's view-dependent look.
    if args.get(1).map(String::as_str) == Some("render-lambertian") {
        use render_host::sequence::{SequenceConfig, SequenceName, render_sequence};
        let mut cfg = SequenceConfig::new(SequenceName::Flyaround);
        cfg.vis.specular = false;
        let dir = std::path::PathBuf::from(args.get(2).map_or("flyaround-lambertian", String::as_str));
        render_sequence(&cfg, &dir, false)?;
        println!("rendered {} without the specular lobe", dir.display());
        return Ok(());
    }
    let dir = std::path::PathBuf::from(args.get(1).map_or("data/flyaround", String::as_str));
    let band = args.get(2).map_or("vis", String::as_str);
    let m = read_manifest(&dir)?;
    let n = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(m.frames.len()).min(m.frames.len());
    let scene = m.config.target.scene()?.with_surface_detail(m.config.surface_seed);
    let model = TargetModel::new(&scene);
    let mut tracker = ModelTracker::new(TrackerParams::default(), 1);
    // Residuals by track age: 0–29 frames, the last bin 30 and older.
    let mut by_age: Vec<Vec<f64>> = vec![Vec::new(); 31];
    for (i, f) in m.frames.iter().take(n).enumerate() {
        let file = match band {
            "vis" => &f.files.vis,
            "vis_clean" => f.files.vis_clean.as_ref().unwrap(),
            "tir_clean" => f.files.tir_clean.as_ref().unwrap(),
            _ => &f.files.tir,
        };
        let img = load_gray_u8(&dir.join(file), ColorPolicy::Refuse)?;
        let size = m.vis_camera.size;
        let img = if img.width as u32 != size {
            let mut up = fusion_io::Gray::<u8>::new(size as usize, size as usize);
            fusion_nostd::rescale(img.view()?, up.view_mut()?, fusion_nostd::Filter::Cubic)?;
            up
        } else {
            img
        };
        let gray = image::GrayImage::from_raw(img.width as u32, img.height as u32, img.data).unwrap();
        let cam = Camera::study(size, f.pose());
        let s = smooth(&gray);
        let whole = fusion_navbench::region::Region::whole(s.width(), s.height());
        let fe = tracker.track(&s, whole, &cam, &model, i as u64);
        let err = fe.pose.map(|r| {
            let m = r.measurement();
            let c = m.covariance;
            println!(
                "    claimed 1σ: attitude {:.2}° {:.2}° {:.2}°, position {:.3} {:.3} {:.3} m, rms {:.2} px",
                c[(0, 0)].sqrt().to_degrees(),
                c[(1, 1)].sqrt().to_degrees(),
                c[(2, 2)].sqrt().to_degrees(),
                c[(3, 3)].sqrt(),
                c[(4, 4)].sqrt(),
                c[(5, 5)].sqrt(),
                r.rms_px
            );
            let q = DQuat::from_mat3(&cam.pose.rotation.as_dmat3());
            (
                (m.attitude.inverse() * q).to_axis_angle().1.to_degrees(),
                (m.position - cam.pose.position.as_dvec3()).length(),
            )
        });
        let mut res: Vec<f64> = tracker
            .tracks()
            .iter()
            .filter_map(|t| {
                let (u, v) = cam.project(t.point.as_vec3())?;
                let r = (f64::from(u - 0.5 - t.pos.0).powi(2) + f64::from(v - 0.5 - t.pos.1).powi(2)).sqrt();
                let last = by_age.len() - 1;
                by_age[t.age.min(last)].push(r);
                Some(r)
            })
            .collect();
        res.sort_by(f64::total_cmp);
        let med = res.get(res.len() / 2).copied().unwrap_or(f64::NAN);
        let p90 = res.get(res.len() * 9 / 10).copied().unwrap_or(f64::NAN);
        println!("    true-pose residual of kept tracks: median {med:.2} px, p90 {p90:.2} px");
        if let Some(bbox) = model.image_box(&cam, 0.3)
            && let Some(seen) = fusion_navbench::silhouette::segment(&s, bbox, whole)
            && let Some(at) = model.silhouette(&cam, bbox, 1)
        {
            let Some((t, _)) = fusion_navbench::silhouette::centre_measurement(&seen, &at, &cam, &model)
            else {
                continue;
            };
            let d = t - model.centre_in_camera(&cam);
            println!(
                "    outline at the true pose: area {:.0} vs model {:.0}, centroid ({:.1}, {:.1}) vs ({:.1}, {:.1}), position error {:.3} m of range {:.1}",
                seen.area,
                at.area,
                seen.cx,
                seen.cy,
                at.cx,
                at.cy,
                d.length(),
                f.range_m
            );
        }
        let added = tracker.replenish(&s, whole, &cam, &model);
        println!(
            "{i:3} {:?} tracked {:4} inliers {:4} added {:4} err {:?} box {:?}",
            f.phase,
            fe.tracked,
            fe.inliers,
            added,
            err,
            model.image_box(&cam, 0.1)
        );
    }
    println!("true-pose residual by track age (frames since anchored): median, p90, count");
    for (age, r) in by_age.iter_mut().enumerate() {
        r.sort_by(f64::total_cmp);
        if let (Some(m), Some(p)) = (r.get(r.len() / 2), r.get(r.len() * 9 / 10)) {
            println!("  age {age:2}: {m:.3} px, {p:.3} px, {}", r.len());
        }
    }
    Ok(())
}
