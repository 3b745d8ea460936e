//! The model-edge cue (`fusion_navbench::edges`) on a rendered sequence's frames: the fit
//! started at the true pose (edges alone) and started 1° and 1 % of the range off (with that
//! prior), against the truth.
//!
//! ```sh
//! cargo run --release -p fusion-navbench --example edge_probe -- SEQUENCE_DIR vis|tir [FRAMES]
//! ```

use anyhow::{Context, Result};
use fusion_io::{ColorPolicy, load_gray_u8};
use fusion_navbench::edges::{ModelEdges, fit};
use fusion_navbench::filter::rotation_vector;
use fusion_navbench::model::TargetModel;
use fusion_navbench::tracker::smooth;
use image::GrayImage;
use render_host::Camera;
use render_host::glam::{DQuat, DVec3};
use std::path::PathBuf;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().context("usage: edge_probe DIR vis|tir [FRAMES]")?);
    let band = args.next().unwrap_or_else(|| "vis".into());
    let frames: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(20);
    let m = render_host::sequence::read_manifest(&dir)?;
    let scene = m.config.target.scene()?.with_surface_detail(m.config.surface_seed);
    let model = TargetModel::new(&scene);
    let edges = ModelEdges::new(&scene);
    println!(
        "| frame | range m | truth start: att ° | pos % | σ px | found | 1° off: att ° | pos % | σ px |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for f in m.frames.iter().take(frames) {
        let vis = load_gray_u8(&dir.join(&f.files.vis), ColorPolicy::Refuse)?;
        let img = if band == "tir" {
            let tir = load_gray_u8(&dir.join(&f.files.tir), ColorPolicy::Refuse)?;
            let mut up = fusion_io::Gray::<u8>::new(vis.width, vis.height);
            fusion_nostd::rescale(tir.view()?, up.view_mut()?, fusion_nostd::Filter::Cubic)?;
            up
        } else if band == "vis_clean" {
            load_gray_u8(
                &dir.join(f.files.vis_clean.as_ref().context("no clean frames")?),
                ColorPolicy::Refuse,
            )?
        } else {
            vis
        };
        let gray =
            smooth(&GrayImage::from_raw(img.width as u32, img.height as u32, img.data).context("size")?);
        let cam = Camera::study(m.vis_camera.size, f.pose());
        let q0 = DQuat::from_mat3(&cam.pose.rotation.as_dmat3());
        let p0 = cam.pose.position.as_dvec3();
        let range = f64::from(f.range_m);
        let err = |q: DQuat, p: DVec3| {
            (rotation_vector(q.inverse() * q0).length().to_degrees(), 100.0 * (p - p0).length() / range)
        };
        let whole = fusion_navbench::region::Region::whole(gray.width(), gray.height());
        let a = fit(&gray, whole, &cam, &model, &edges, (q0, p0), 1.0);
        let sa = 1f64.to_radians();
        // 1° about the camera's x axis, the position moved to keep the target centre in view.
        let dq = DQuat::from_scaled_axis(DVec3::X * sa);
        let q1 = q0 * dq;
        let c = render_host::glam::DMat3::from_quat(q0).transpose() * (scene.centre.as_dvec3() - p0);
        let p1 = scene.centre.as_dvec3() - render_host::glam::DMat3::from_quat(q1) * c;
        let b = fit(&gray, whole, &cam, &model, &edges, (q1, p1), f64::from(cam.focal_px) * 2.0 * sa);
        let show = |r: &Option<fusion_navbench::edges::EdgeFit>| match r {
            Some(r) => {
                let (ea, ep) = err(r.measurement.attitude, r.measurement.position);
                format!("{ea:.2} | {ep:.2} | {:.2}", r.sigma_px)
            }
            None => "— | — | —".into(),
        };
        println!(
            "| {} | {:.1} | {} | {} | {} |",
            f.index,
            range,
            show(&a),
            a.as_ref().map_or(0, |r| r.found),
            show(&b)
        );
    }
    Ok(())
}
