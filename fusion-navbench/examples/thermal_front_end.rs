//! The thermal front end (`fusion_nostd::thermal`) measured: the fixed-pattern noise left on a
//! flat field at each stage, and the stages side by side on a rendered raw sequence.
//!
//! ```sh
//! fusion render --sequence flyaround --raw-tir --out /tmp/raw-fly
//! cargo run --release -p fusion-navbench --example thermal_front_end -- /tmp/raw-fly 39 docs/thermal
//! ```
//!
//! 1. **Flat field** (no files needed): the renderer's default focal plane (512², its own seed)
//!    looking at a uniform 293 K scene, 16 frames averaged so that the temporal noise (NETD)
//!    drops by 4; the spatial standard deviation over the valid pixels in NETD units, and the
//!    column part (the spread of the column means), at the calibration (t = 0) and 39 s later
//!    (the focal plane 2 K warmer, just before the first shutter closure): raw counts, the
//!    factory tables, the tables re-levelled by a shutter frame, the column filter on top.
//! 2. **A rendered frame** (`DIR FRAME`): the renderer's 8-bit TIR (an ideal array), the raw
//!    counts, the factory tables, the whole chain — each through the linear AGC — written side
//!    by side into `OUT/front_end_frame.png`, with the target's contrast-to-noise ratio on the
//!    TIR grid (navbench's definition: the TIR mask against a ring 4–12 px outside it); and
//!    that ratio for every frame of the sequence per stage, `OUT/front_end_cnr.png`.
//!
//! Prints Markdown tables (BENCHMARKS.md, "The thermal camera off the focal plane").

use anyhow::{Context, Result};
use fusion_engine::thermal::{COLUMN_RADIUS, Column, ThermalChain, column_threshold};
use fusion_io::thermal::{BadPixels, NucTables};
use fusion_io::{ColorPolicy, Gray, load_gray_u8};
use fusion_navbench::bench::{cnr, ring, sensor_frames};
use fusion_nostd::thermal::ColumnParams;
use render_host::focal_plane::{FocalPlane, FocalPlaneParams};
use render_host::image::Image;
use render_host::noise::rng_for;
use render_host::sequence::read_manifest;
use std::path::{Path, PathBuf};

/// Spatial σ over the valid pixels and the σ of the column means (same pixels), in counts.
fn spread(frame: &[f64], valid: &[bool], w: usize) -> (f64, f64) {
    let px: Vec<f64> = frame.iter().zip(valid).filter(|(_, v)| **v).map(|(f, _)| *f).collect();
    let sd = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
    };
    let cols: Vec<f64> = (0..w)
        .map(|x| {
            let c: Vec<f64> =
                frame.iter().zip(valid).skip(x).step_by(w).filter(|(_, v)| **v).map(|(f, _)| *f).collect();
            c.iter().sum::<f64>() / c.len().max(1) as f64
        })
        .collect();
    (sd(&px), sd(&cols))
}

fn mean_of(frames: &[Gray<u16>]) -> Vec<f64> {
    let n = frames.len() as f64;
    (0..frames[0].data.len()).map(|i| frames.iter().map(|f| f64::from(f.data[i])).sum::<f64>() / n).collect()
}

fn flat_field() -> Result<()> {
    let p = FocalPlaneParams::default();
    let (w, h) = (512, 512);
    let fp = FocalPlane::new(p, w, h, 250.0);
    let netd_counts = p.netd_k * p.responsivity_counts_per_k;
    let v = Image { width: w as u32, height: h as u32, data: vec![((293.0 - 150.0) / 250.0) as f32; w * h] };
    let valid: Vec<bool> = fp.bad_mask().iter().map(|b| !b).collect();
    let nuc = NucTables { width: w, height: h, gain: fp.nuc_gain.clone(), offset: fp.nuc_offset.clone() };
    let bad = BadPixels::from_mask(w, h, &fp.bad_mask());
    println!("| t (s) | focal plane ΔT (K) | stage | spatial σ (NETD) | column σ (NETD) |");
    println!("|---:|---:|---|---:|---:|");
    for t in [0.0, 39.0] {
        let mut rng = rng_for(11, t as u64);
        let raw: Vec<Gray<u16>> =
            (0..16).map(|_| Gray { width: w, height: h, data: fp.raw(&v, t, &mut rng) }).collect();
        let shutter = Gray { width: w, height: h, data: fp.shutter(150.0, t, &mut rng) };
        let threshold = column_threshold(
            &ThermalChain::new(Some(nuc.clone()), Some(bad.clone()), None)?.correct(&raw[0])?,
        );
        let column = ColumnParams { threshold, radius: COLUMN_RADIUS, smoothing: 0 };
        let stages: Vec<(&str, Option<ThermalChain>, bool)> = vec![
            ("raw counts", None, false),
            ("factory tables", Some(ThermalChain::new(Some(nuc.clone()), None, None)?), false),
            ("tables + shutter", Some(ThermalChain::new(Some(nuc.clone()), None, None)?), true),
            (
                "tables + column filter",
                Some(ThermalChain::new(Some(nuc.clone()), Some(bad.clone()), Some(Column::Params(column)))?),
                false,
            ),
            (
                "tables + shutter + column filter",
                Some(ThermalChain::new(Some(nuc.clone()), Some(bad.clone()), Some(Column::Params(column)))?),
                true,
            ),
        ];
        for (name, chain, use_shutter) in stages {
            let frames: Vec<Gray<u16>> = match chain {
                None => raw.clone(),
                Some(mut c) => {
                    if use_shutter {
                        c.shutter(&shutter)?;
                    }
                    raw.iter().map(|r| c.correct(r)).collect::<Result<_>>()?
                }
            };
            let (s, c) = spread(&mean_of(&frames), &valid, w);
            // 16 frames averaged: the temporal part left is NETD/4 (in the spatial σ).
            println!(
                "| {t:.0} | {:.2} | {name} | {:.2} | {:.2} |",
                fp.fpa_delta_k(t),
                s / netd_counts,
                c / netd_counts
            );
        }
    }
    println!(
        "\n(NETD {:.0} mK = {netd_counts:.1} counts; 16 frames averaged, so a perfectly uniform array would show 0.25 NETD of temporal noise.)\n",
        p.netd_k * 1e3
    );
    Ok(())
}

fn rendered(dir: &Path, frame: usize, out: &Path) -> Result<()> {
    let m = read_manifest(dir)?;
    let f = m.frames.get(frame).context("no such frame")?;
    let sensor = sensor_frames(dir, &m, m.frames.len())?;
    // Every frame's CNR per stage, for the chart.
    let names = ["ideal array", "raw counts", "factory tables", "whole chain"];
    let mut series: Vec<fusion_report::plot::Series> = names
        .iter()
        .map(|n| fusion_report::plot::Series { name: n.to_string(), points: Vec::new() })
        .collect();
    for (k, (fr, stages)) in m.frames.iter().zip(&sensor).enumerate() {
        let ideal = load_gray_u8(&dir.join(&fr.files.tir), ColorPolicy::Refuse)?;
        let mask: Vec<bool> = load_gray_u8(&dir.join(&fr.files.tir_mask), ColorPolicy::Refuse)?
            .data
            .iter()
            .map(|&v| v > 127)
            .collect();
        let bg = ring(&mask, ideal.width, ideal.height, 4, 12);
        for (s, img) in series.iter_mut().zip([&ideal, &stages[0], &stages[1], &stages[2]]) {
            s.points.push((k as f64, cnr(&img.data, &mask, &bg)));
        }
    }
    std::fs::create_dir_all(out)?;
    let shutters: Vec<(f64, f64)> = m
        .frames
        .iter()
        .filter(|f| f.tir_frozen)
        .map(|f| (f.index as f64 - 0.5, f.index as f64 + 0.5))
        .collect();
    let title = format!(
        "{} seed {}: TIR target CNR per frame (shutter closures shaded)",
        m.config.name.as_str(),
        m.config.seed
    );
    let chart = fusion_report::plot::chart_shaded(
        &out.join("front_end_cnr"),
        fusion_report::plot::Labels { title: &title, x: "frame", y: "CNR" },
        &series,
        fusion_report::plot::Style::Lines,
        &shutters,
    )?;
    println!("wrote {}\n", chart.display());
    let [raw, nuc, chain] = sensor.get(frame).context("no frame")?.clone();
    let ideal = load_gray_u8(&dir.join(&f.files.tir), ColorPolicy::Refuse)?;
    let mask: Vec<bool> = load_gray_u8(&dir.join(&f.files.tir_mask), ColorPolicy::Refuse)?
        .data
        .iter()
        .map(|&v| v > 127)
        .collect();
    let (w, h) = (ideal.width, ideal.height);
    let bg = ring(&mask, w, h, 4, 12);
    println!(
        "| {} frame {frame} ({}, ΔT {:.2} K) | CNR |",
        m.config.name.as_str(),
        f.phase.as_str(),
        f.fpa_delta_k.unwrap_or(0.0)
    );
    println!("|---|---:|");
    let panels = [
        ("ideal array (renderer's 8-bit)", &ideal),
        ("raw counts", &raw),
        ("factory tables", &nuc),
        ("whole chain", &chain),
    ];
    for (name, img) in panels {
        println!("| {name} | {:.2} |", cnr(&img.data, &mask, &bg));
    }
    let gap = 8;
    let mut strip = Gray::<u8>::new(4 * w + 3 * gap, h);
    strip.data.fill(255);
    for (k, (_, img)) in panels.iter().enumerate() {
        for y in 0..h {
            let o = y * strip.width + k * (w + gap);
            strip.data[o..o + w].copy_from_slice(&img.data[y * w..(y + 1) * w]);
        }
    }
    fusion_io::save_gray_u8(&out.join("front_end_frame.png"), &strip)?;
    println!("\nwrote {}", out.join("front_end_frame.png").display());
    Ok(())
}

fn main() -> Result<()> {
    flat_field()?;
    let mut args = std::env::args().skip(1);
    if let (Some(dir), Some(frame)) = (args.next(), args.next()) {
        let out = PathBuf::from(args.next().unwrap_or_else(|| ".".to_string()));
        rendered(&PathBuf::from(dir), frame.parse()?, &out)?;
    }
    Ok(())
}
