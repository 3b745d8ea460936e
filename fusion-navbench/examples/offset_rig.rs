//! Registration of an offset camera pair measured on rendered ground truth.
//!
//! ```sh
//! fusion render --sequence approach --rig offset --frames 24 --out /tmp/rig-approach
//! cargo run --release -p fusion-navbench --example offset_rig -- /tmp/rig-approach docs/registration
//! ```
//!
//! For every frame of a sequence rendered through an offset rig (`fusion render --rig`), the
//! thermal target mask is put on the visible grid two ways — as if the cameras were aligned
//! (the core's bicubic rescale, today's fusion path) and registered through the rig at the
//! frame's true range (`fusion_engine::registration`, linear) — and compared with the visible
//! target mask: the distance between the masks' centroids (visible pixels) and their overlap
//! (intersection over union). Prints the per-frame table and the medians and 95th
//! percentiles, and writes `OUT/offset_rig.png`: the visible frame and the TSIFSD fusion of a
//! middle frame without and with registration, labelled.

use anyhow::{Context, Result};
use fusion_engine::methods::{MethodArg, VariantArg, fuse_core, method_for};
use fusion_engine::registration::register;
use fusion_io::{ColorPolicy, Gray, load_gray_u8};
use fusion_nostd::pipeline::FuseConfig;
use fusion_nostd::registration::{Border, Interpolation};
use std::path::PathBuf;

fn centroid(g: &Gray<u8>) -> (f64, f64) {
    let (mut sx, mut sy, mut n) = (0.0f64, 0.0f64, 0.0f64);
    for (i, &v) in g.data.iter().enumerate() {
        if v > 127 {
            (sx, sy, n) = (sx + (i % g.width) as f64, sy + (i / g.width) as f64, n + 1.0);
        }
    }
    (sx / n.max(1.0), sy / n.max(1.0))
}

fn iou(a: &Gray<u8>, b: &Gray<u8>) -> f64 {
    let both = a.data.iter().zip(&b.data).filter(|(x, y)| **x > 127 && **y > 127).count();
    let any = a.data.iter().zip(&b.data).filter(|(x, y)| **x > 127 || **y > 127).count();
    both as f64 / any.max(1) as f64
}

fn rescaled(g: &Gray<u8>, w: usize, h: usize) -> Result<Gray<u8>> {
    let mut out = Gray::new(w, h);
    fusion_nostd::rescale(g.view()?, out.view_mut()?, fusion_nostd::Filter::Cubic)?;
    Ok(out)
}

fn quantile(v: &[f64], q: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((s.len() - 1) as f64 * q).round() as usize]
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().context("usage: offset_rig SEQUENCE_DIR [OUT]")?);
    let out = args.next().map(PathBuf::from);
    let m = render_host::sequence::read_manifest(&dir)?;
    let rig_file = m.rig.as_ref().context("the sequence was rendered without --rig")?;
    let rig = fusion_io::rig::read(&dir.join(rig_file))?;
    let load = |rel: &str| load_gray_u8(&dir.join(rel), ColorPolicy::Refuse);
    let (vw, vh) = (rig.vis.width, rig.vis.height);
    println!(
        "| frame | range m | VIS target px | aligned: centroid px | aligned: IoU | registered: centroid px | registered: IoU |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|");
    let (mut off_a, mut off_r, mut iou_a, mut iou_r) = (vec![], vec![], vec![], vec![]);
    for f in &m.frames {
        let vis = load(&f.files.vis_mask)?;
        let n = vis.data.iter().filter(|&&v| v > 127).count();
        if n < 20 {
            continue;
        }
        let tir = load(&f.files.tir_mask)?;
        let reg = register(&tir, &rig, f64::from(f.range_m), Interpolation::Linear, Border::Constant(0))?;
        let up = rescaled(&tir, vw, vh)?;
        let c = centroid(&vis);
        let d = |g: &Gray<u8>| {
            let p = centroid(g);
            (p.0 - c.0).hypot(p.1 - c.1)
        };
        let (da, dr, ia, ir) = (d(&up), d(&reg), iou(&vis, &up), iou(&vis, &reg));
        println!("| {} | {:.1} | {n} | {da:.2} | {ia:.3} | {dr:.2} | {ir:.3} |", f.index, f.range_m);
        off_a.push(da);
        off_r.push(dr);
        iou_a.push(ia);
        iou_r.push(ir);
    }
    anyhow::ensure!(!off_a.is_empty(), "no frame shows the target");
    println!();
    println!("| | centroid offset, median / 95th pct (VIS px) | IoU, median / 5th pct |");
    println!("|---|---|---|");
    for (name, o, i) in [("aligned (rescale)", &off_a, &iou_a), ("registered", &off_r, &iou_r)] {
        println!(
            "| {name} | {:.2} / {:.2} | {:.3} / {:.3} |",
            quantile(o, 0.5),
            quantile(o, 0.95),
            quantile(i, 0.5),
            quantile(i, 0.05)
        );
    }
    if let Some(out) = out {
        std::fs::create_dir_all(&out)?;
        let f = &m.frames[m.frames.len() / 2];
        let vis = load(&f.files.vis)?;
        let tir = load(&f.files.tir)?;
        let config =
            FuseConfig { method: method_for(MethodArg::Tsifsd, VariantArg::Flight), ..FuseConfig::default() };
        let plain = fuse_core(&vis, &tir, &config, false)?.image;
        let reg = register(&tir, &rig, f64::from(f.range_m), Interpolation::Linear, Border::Constant(0))?;
        let registered = fuse_core(&vis, &reg, &config, false)?.image;
        // Crop to the target (the VIS mask's box, grown) so the doubling shows.
        let mask = load(&f.files.vis_mask)?;
        let (mut x0, mut y0, mut x1, mut y1) = (vw, vh, 0, 0);
        for (i, &v) in mask.data.iter().enumerate() {
            if v > 127 {
                let (x, y) = (i % vw, i / vw);
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
        let side = ((x1.saturating_sub(x0)).max(y1.saturating_sub(y0)) * 13 / 10).clamp(64, vw.min(vh));
        let (cx, cy) = ((x0 + x1) / 2, (y0 + y1) / 2);
        let (ox, oy) =
            (cx.saturating_sub(side / 2).min(vw - side), cy.saturating_sub(side / 2).min(vh - side));
        let crop = |g: &Gray<u8>| -> Result<Gray<u8>> {
            let mut c = Gray::new(side, side);
            for y in 0..side {
                c.data[y * side..(y + 1) * side]
                    .copy_from_slice(&g.data[(oy + y) * vw + ox..(oy + y) * vw + ox + side]);
            }
            rescaled(&c, 400, 400)
        };
        let sheet = fusion_report::sheet::labelled_sheet(
            &[vec![crop(&vis)?, crop(&plain)?, crop(&registered)?]],
            4,
            &["VIS", "fused, cameras taken as aligned", "fused, TIR registered"],
            &[&format!("frame {}, {:.1} m", f.index, f.range_m)],
        );
        fusion_io::save_gray_u8(&out.join("offset_rig.png"), &sheet)?;
        println!("\nwrote {}", out.join("offset_rig.png").display());
    }
    Ok(())
}
