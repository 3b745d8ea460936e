//! One frame of tracking at the true pose, per frame pair of a rendered sequence: corners
//! detected in frame k inside the model's box, back-projected onto the model at the true pose,
//! tracked into frame k + STEP by pyramidal Lucas–Kanade (seeded at the true projection) and by
//! the model-warped template (`fusion_navbench::warp`, started from the Lucas–Kanade position
//! and from the true projection); printed: the median and 90th percentile of each one's
//! distance to the true projection, px, and how many were tracked.
//! `cargo run --release -p fusion-navbench --example warp_probe -- DIR [vis|vis_clean] [STEP]`

use fusion_io::{ColorPolicy, load_gray_u8};
use fusion_navbench::model::TargetModel;
use fusion_navbench::tracker::smooth;
use fusion_navbench::warp::{GradientImage, Template};
use optical_flow_lk::{DetectorContext, Grid, TrackParams, TrackStatus, build_pyramid, calc_optical_flow_fb};
use render_host::Camera;
use render_host::sequence::read_manifest;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let dir = std::path::PathBuf::from(args.get(1).map_or("data/flyaround", String::as_str));
    let band = args.get(2).map_or("vis", String::as_str);
    let step: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let m = read_manifest(&dir)?;
    let scene = m.config.target.scene()?.with_surface_detail(m.config.surface_seed);
    let model = TargetModel::new(&scene);
    let mut detector = DetectorContext::new();
    let load = |i: usize| -> anyhow::Result<image::GrayImage> {
        let f = &m.frames[i];
        let file = match band {
            "vis_clean" => f.files.vis_clean.as_ref().ok_or_else(|| anyhow::anyhow!("no clean frames"))?,
            _ => &f.files.vis,
        };
        let img = load_gray_u8(&dir.join(file), ColorPolicy::Refuse)?;
        let gray = image::GrayImage::from_raw(img.width as u32, img.height as u32, img.data)
            .ok_or_else(|| anyhow::anyhow!("size"))?;
        Ok(smooth(&gray))
    };
    let size = m.vis_camera.size;
    let params = TrackParams { window_size: 21, max_iterations: 30, min_eigen_threshold: 2.0 };
    let summary = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let at = |q: usize| v.get(q).copied().unwrap_or(f64::NAN);
        format!("{:.3} / {:.3} ({n})", at(n / 2), at(n * 9 / 10))
    };
    println!("frame  corners  LK median / p90 (n)  warped from LK  warped from truth");
    for k in (0..m.frames.len().saturating_sub(step)).step_by(3) {
        let (a, b) = (load(k)?, load(k + step)?);
        let ca = Camera::study(size, m.frames[k].pose());
        let cb = Camera::study(size, m.frames[k + step].pose());
        let Some((x0, y0, x1, y1)) = model.image_box(&ca, 0.1) else { continue };
        let crop = image::imageops::crop_imm(&a, x0, y0, x1 - x0, y1 - y0).to_image();
        let corners =
            detector.detect_grid(&crop, Grid { cols: 8, rows: 8, max_per_cell: 18 }, 0.02, 6, &[]).to_vec();
        let (mut from, mut truth, mut templates) = (Vec::new(), Vec::new(), Vec::new());
        for c in corners {
            let (x, y) = (c.x + x0, c.y + y0);
            let Some(hit) = model.back_project(&ca, f64::from(x) + 0.5, f64::from(y) + 0.5) else { continue };
            let Some(t) = Template::cut(&a, &ca, &model, (x, y), hit.point, (hit.face, hit.normal)) else {
                continue;
            };
            let Some((u, v)) = cb.project(hit.point.as_vec3()) else { continue };
            from.push((x as f32, y as f32));
            truth.push((u - 0.5, v - 0.5));
            templates.push(t);
        }
        let results = calc_optical_flow_fb(
            &build_pyramid(&a, 4),
            &build_pyramid(&b, 4),
            &from,
            Some(&truth),
            params,
            1.0,
        );
        let gradients = GradientImage::new(&b);
        let (mut lk, mut from_lk, mut from_truth) = (Vec::new(), Vec::new(), Vec::new());
        for ((r, t), &p) in results.iter().zip(&templates).zip(&truth) {
            if r.status != TrackStatus::Tracked {
                continue;
            }
            let d = |q: (f32, f32)| f64::from((q.0 - p.0).hypot(q.1 - p.1));
            lk.push(d(r.pos));
            from_lk.extend(t.refine(&gradients, &cb, r.pos).map(d));
            from_truth.extend(t.refine(&gradients, &cb, p).map(d));
        }
        println!("{k:5}  {:7}  {}  {}  {}", from.len(), summary(lk), summary(from_lk), summary(from_truth));
    }
    Ok(())
}
