//! How sparse is the target inside its bounding box? For a rendered dataset (`fusion render`),
//! per frame: the pixels that differ at all from their band's background (VIS 1024² in light,
//! TIR 512² bicubic-upscaled onto it), grown by ADF's halo N = 10 row by row (Chebyshev), and
//! then three areas as fractions of the frame, averaged over the frames:
//!
//! * the box window of today's ROI plan: the bounding box of that region grown by N;
//! * band tiles: per band of S rows the region's column extent, each band's window grown by N
//!   on every side (what a tile plan with halos would compute), for S = 8, 16, 32, 64;
//! * the region itself (a lower bound: an irregular-region diffusion would compute only this).
//!
//! `cargo run --release -p host-harness --example roi_sparsity -- DATASET_DIR`

use anyhow::{Context, Result};
use fusion_engine::study::Dataset;
use fusion_io::Gray;
use fusion_nostd::{Filter, rescale};

/// The most frequent value (the background level of a dark frame).
fn mode(g: &Gray<u8>) -> u8 {
    let mut h = [0usize; 256];
    for &v in &g.data {
        h[usize::from(v)] += 1;
    }
    (0..=255u8).max_by_key(|&i| h[usize::from(i)]).unwrap_or(0)
}

fn main() -> Result<()> {
    let dir = std::env::args().nth(1).context("usage: roi_sparsity DATASET_DIR")?;
    let ds = Dataset::open(std::path::Path::new(&dir))?;
    let n = 10usize;
    let bands = [8usize, 16, 32, 64];
    let (mut box_area, mut region_area, mut tile_area) = (0usize, 0usize, [0usize; 4]);
    let (mut frames, mut pixels) = (0usize, 0usize);
    for f in 0..ds.frames() {
        let vis = ds.image("vis_light", f, false)?;
        let tir = ds.image("tir512", f, false)?;
        let (w, h) = (vis.width, vis.height);
        let mut up = Gray::new(w, h);
        rescale(tir.view()?, up.view_mut()?, Filter::Cubic)?;
        let (bv, bt) = (mode(&vis), mode(&up));
        // Column extent of the varying pixels per row, then grown by N rows and N columns.
        let mut rows: Vec<Option<(usize, usize)>> = vec![None; h];
        for (y, r) in rows.iter_mut().enumerate() {
            for x in 0..w {
                if vis.data[y * w + x] != bv || up.data[y * w + x] != bt {
                    let e = r.get_or_insert((x, x + 1));
                    *e = (e.0.min(x), e.1.max(x + 1));
                }
            }
        }
        let mut region: Vec<Option<(usize, usize)>> = vec![None; h];
        for (y, r) in region.iter_mut().enumerate() {
            for &(a, b) in rows[y.saturating_sub(n)..(y + n + 1).min(h)].iter().flatten() {
                let (a, b) = (a.saturating_sub(n), (b + n).min(w));
                let e = r.get_or_insert((a, b));
                *e = (e.0.min(a), e.1.max(b));
            }
        }
        let ys: Vec<usize> = (0..h).filter(|&y| region[y].is_some()).collect();
        let (Some(&y0), Some(&y1)) = (ys.first(), ys.last()) else { continue };
        frames += 1;
        pixels += w * h;
        let extents = ys.iter().filter_map(|&y| region[y]);
        let x0 = extents.clone().map(|e| e.0).min().unwrap_or(0);
        let x1 = extents.clone().map(|e| e.1).max().unwrap_or(0);
        region_area += extents.map(|(a, b)| b - a).sum::<usize>();
        box_area += ((x1 + n).min(w) - x0.saturating_sub(n)) * ((y1 + 1 + n).min(h) - y0.saturating_sub(n));
        for (k, &s) in bands.iter().enumerate() {
            for b0 in (0..h).step_by(s) {
                let b1 = (b0 + s).min(h);
                let ext =
                    region[b0..b1].iter().flatten().fold(None, |acc: Option<(usize, usize)>, &(a, b)| {
                        Some(acc.map_or((a, b), |(c, d)| (c.min(a), d.max(b))))
                    });
                if let Some((a, b)) = ext {
                    tile_area[k] +=
                        ((b + n).min(w) - a.saturating_sub(n)) * ((b1 + n).min(h) - b0.saturating_sub(n));
                }
            }
        }
    }
    let pct = |a: usize| a as f64 / pixels.max(1) as f64 * 100.0;
    println!("{frames} frames with a target (vis_light, tir512 upscaled), N = {n}");
    println!("box window (today's ROI plan): {:.2} % of the frame", pct(box_area));
    for (k, s) in bands.iter().enumerate() {
        println!("band tiles of {s} rows with halos: {:.2} %", pct(tile_area[k]));
    }
    println!("the region itself (lower bound): {:.2} %", pct(region_area));
    Ok(())
}
