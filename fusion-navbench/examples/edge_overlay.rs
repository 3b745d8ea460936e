//! The model's creases over a frame at the true pose: green where the image has the crease's
//! step within the support tolerance (`fusion_navbench::edges::support`), red where not.
//!
//! ```sh
//! cargo run --release -p fusion-navbench --example edge_overlay -- SEQUENCE_DIR vis|tir FRAME OUT.png
//! ```

use anyhow::{Context, Result};
use fusion_io::{ColorPolicy, load_gray_u8};
use fusion_navbench::edges::{BORDER_PX, ModelEdges, SUPPORT_RANGE_PX, supported};
use fusion_navbench::model::TargetModel;
use fusion_navbench::tracker::smooth;
use image::{GrayImage, Rgb, RgbImage};
use render_host::Camera;
use std::path::PathBuf;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: edge_overlay DIR vis|tir FRAME OUT.png";
    let dir = PathBuf::from(args.next().context(usage)?);
    let band = args.next().context(usage)?;
    let k: usize = args.next().context(usage)?.parse()?;
    let out = PathBuf::from(args.next().context(usage)?);
    let m = render_host::sequence::read_manifest(&dir)?;
    let scene = m.config.target.scene()?.with_surface_detail(m.config.surface_seed);
    let model = TargetModel::new(&scene);
    let edges = ModelEdges::new(&scene);
    let f = m.frames.get(k).context("no such frame")?;
    let vis = load_gray_u8(&dir.join(&f.files.vis), ColorPolicy::Refuse)?;
    let img = if band == "tir" {
        let tir = load_gray_u8(&dir.join(&f.files.tir), ColorPolicy::Refuse)?;
        let mut up = fusion_io::Gray::<u8>::new(vis.width, vis.height);
        fusion_nostd::rescale(tir.view()?, up.view_mut()?, fusion_nostd::Filter::Cubic)?;
        up
    } else {
        vis
    };
    let gray = smooth(&GrayImage::from_raw(img.width as u32, img.height as u32, img.data).context("size")?);
    let cam = Camera::study(m.vis_camera.size, f.pose());
    let (x0, y0, x1, y1) = model.image_box(&cam, 0.3).context("target not in view")?;
    let s = 3u32;
    let (w, h) = (x1 - x0, y1 - y0);
    let mut canvas = RgbImage::new(w * s, h * s);
    for y in 0..h * s {
        for x in 0..w * s {
            let v = gray.get_pixel(x0 + x / s, y0 + y / s)[0];
            canvas.put_pixel(x, y, Rgb([v, v, v]));
        }
    }
    let samples = edges.samples(&cam, &model, SUPPORT_RANGE_PX + BORDER_PX);
    let mut near = 0;
    for e in &samples {
        let ok = supported(&gray, e);
        near += usize::from(ok);
        let colour = if ok { Rgb([0, 255, 0]) } else { Rgb([255, 0, 0]) };
        let (u, v) = ((e.image.x - f64::from(x0)) * f64::from(s), (e.image.y - f64::from(y0)) * f64::from(s));
        for d in -2i32..=2 {
            for (du, dv) in [(d, 0), (0, d)] {
                let (px, py) = (u as i32 + du, v as i32 + dv);
                if px >= 0 && py >= 0 && (px as u32) < w * s && (py as u32) < h * s {
                    canvas.put_pixel(px as u32, py as u32, colour);
                }
            }
        }
    }
    canvas.save(&out)?;
    println!("frame {k} {band}: {near} of {} samples supported -> {}", samples.len(), out.display());
    Ok(())
}
