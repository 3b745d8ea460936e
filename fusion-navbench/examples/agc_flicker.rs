//! The thermal AGC on a rendered 16-bit sequence: how much the mean level of the 8-bit thermal
//! frame moves from one frame to the next, with and without the AGC's temporal smoothing.
//!
//! ```sh
//! fusion render --sequence approach --tir16 --out /tmp/seq16
//! cargo run --release -p host-harness --example agc_flicker -- /tmp/seq16
//! ```
//!
//! The renderer's own 8-bit frames (a fixed gain: 150–400 K over 0–255) are the baseline: their
//! level changes only with the scene. Also the target's contrast-to-noise ratio (navbench's
//! definition, `fusion_navbench::bench::cnr`: the TIR target mask against a ring 4–12 px
//! outside it on the 512² grid), mean and worst over the frames. Prints Markdown tables
//! (BENCHMARKS.md, "Thermal AGC").

use anyhow::{Context, Result, bail};
use fusion_io::{ColorPolicy, Gray, GrayInput, load_gray_u8, load_image};
use fusion_navbench::bench::{cnr, ring};
use fusion_nostd::{AgcMode, AgcParams};
use render_host::sequence::read_manifest;
use std::path::PathBuf;

fn mean(img: &Gray<u8>) -> f64 {
    img.data.iter().map(|&v| f64::from(v)).sum::<f64>() / img.data.len() as f64
}

/// The mean level, the mean and largest |Δ| of consecutive levels, and the jitter: the mean
/// |second difference| |L(t+1) − 2 L(t) + L(t−1)|, the part of the change that is not a steady
/// trend (a level that follows the scene smoothly has none).
fn steps(levels: &[f64]) -> [f64; 4] {
    let d: Vec<f64> = levels.windows(2).map(|w| w[1] - w[0]).collect();
    let dd: Vec<f64> = d.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    let avg = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let abs: Vec<f64> = d.iter().map(|v| v.abs()).collect();
    [avg(levels), avg(&abs), abs.iter().copied().fold(0.0, f64::max), avg(&dd)]
}

fn main() -> Result<()> {
    let dir = PathBuf::from(
        std::env::args().nth(1).context("usage: agc_flicker SEQUENCE_DIR (rendered with --tir16)")?,
    );
    let manifest = read_manifest(&dir)?;
    let files: Vec<PathBuf> = manifest
        .frames
        .iter()
        .map(|f| f.files.tir16.as_ref().map(|t| dir.join(t)))
        .collect::<Option<_>>()
        .context("the sequence has no 16-bit thermal frames: render it with --tir16")?;
    let counts: Vec<Gray<u16>> = files
        .iter()
        .map(|p| match load_image(p, ColorPolicy::Refuse)? {
            GrayInput::U16(g) => Ok(g),
            GrayInput::U8(_) => bail!("{} is not 16-bit", p.display()),
        })
        .collect::<Result<_>>()?;
    let fixed: Vec<Gray<u8>> = manifest
        .frames
        .iter()
        .map(|f| load_gray_u8(&dir.join(&f.files.tir), ColorPolicy::Refuse))
        .collect::<Result<_>>()?;
    let masks: Vec<(Vec<bool>, Vec<bool>)> = manifest
        .frames
        .iter()
        .map(|f| {
            let m = load_gray_u8(&dir.join(&f.files.tir_mask), ColorPolicy::Refuse)?;
            let mask: Vec<bool> = m.data.iter().map(|&v| v > 127).collect();
            let r = ring(&mask, m.width, m.height, 4, 12);
            Ok((mask, r))
        })
        .collect::<Result<_>>()?;
    let cnrs = |frames: &[Gray<u8>]| {
        let v: Vec<f64> = frames.iter().zip(&masks).map(|(f, (m, r))| cnr(&f.data, m, r)).collect();
        (v.iter().sum::<f64>() / v.len() as f64, v.iter().copied().fold(f64::INFINITY, f64::min))
    };
    let pixels = counts[0].width * counts[0].height;
    println!(
        "Sequence `{}`, {} frames of {}x{} 16-bit TIR at {} Hz.\n",
        manifest.config.name.as_str(),
        counts.len(),
        counts[0].width,
        counts[0].height,
        manifest.config.frame_rate_hz
    );
    println!(
        "| mapping | smoothing k | target CNR mean | CNR worst | mean level | mean abs step | largest abs step | jitter (mean abs 2nd difference) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let row = |name: &str, k: &str, frames: &[Gray<u8>]| {
        let levels: Vec<f64> = frames.iter().map(mean).collect();
        let [l, m, x, j] = steps(&levels);
        let (c, cw) = cnrs(frames);
        println!("| {name} | {k} | {c:.2} | {cw:.2} | {l:.2} | {m:.3} | {x:.3} | {j:.3} |");
    };
    row("renderer's fixed gain (8-bit frames, scene change only)", "–", &fixed);
    let plateau = |limit| AgcParams { mode: AgcMode::Plateau { limit }, ..AgcParams::plateau(pixels) };
    let configs = [
        ("linear 1–99.9 % (default)", AgcParams::linear(), &[0u8, 2, 3, 4][..]),
        (
            "linear 0.5–99.5 %",
            AgcParams { mode: AgcMode::Linear { low: 50, high: 9_950 }, ..AgcParams::linear() },
            &[0, 3],
        ),
        ("plateau 1 (default for 512²)", AgcParams::plateau(pixels), &[0, 2, 3, 4]),
        ("plateau 16", plateau(16), &[0]),
        ("plateau pixels/64", plateau((pixels / 64) as u32), &[0, 3]),
    ];
    for (name, base, ks) in configs {
        for &k in ks {
            let p = AgcParams { smoothing: k, ..base };
            let mut agc = fusion_engine::agc::fresh();
            let frames = counts
                .iter()
                .map(|c| fusion_engine::agc::map_counts(&mut agc, c, &p))
                .collect::<Result<Vec<_>>>()?;
            row(name, &k.to_string(), &frames);
        }
    }
    Ok(())
}
