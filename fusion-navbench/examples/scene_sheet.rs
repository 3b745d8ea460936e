//! What each method makes of a hard scene — the Earth behind the target, the sun in view: a
//! labelled contact sheet of a rendered sequence, one row per illumination phase, the visible
//! frame, the thermal frame on the visible grid and every method of the core with the adaptive
//! fusion.
//!
//! ```sh
//! fusion render --sequence radial --out /tmp/radial
//! cargo run --release -p fusion-navbench --example scene_sheet -- /tmp/radial docs/earth/radial_sheet.png
//! fusion render --sequence approach --sun-phase 172 --glare --frames 12 --out /tmp/glare
//! cargo run --release -p fusion-navbench --example scene_sheet -- /tmp/glare docs/glare/approach_sheet.png whole
//! ```
//!
//! Rows: the last frame in light, the middle frame of the penumbra, the last frame in eclipse
//! (phases the sequence lacks are left out). The crop is the square around both cameras'
//! target masks grown to three times the target's size, so the background around it shows
//! (`whole` as a third argument: the whole frame). Prints per row and column the target's
//! contrast against its background: the mean grey level inside the target mask minus the mean
//! over the background pixels of the crop (the Earth's where the sequence draws it, else every
//! pixel off the target), in grey levels (negative: the target is darker than what is behind
//! it).

use anyhow::{Result, bail};
use fusion_engine::methods::fuse_core;
use fusion_engine::study::{core_methods, grid};
use fusion_io::{ColorPolicy, Gray, load_gray_u8, source_on_grid};
use fusion_nostd::pipeline::{FuseConfig, RescalePolicy};
use fusion_nostd::{AdaptiveParams, Filter, Method};
use fusion_report::sheet::{labelled_sheet, target_square, tile};
use render_host::sequence::{Phase, read_manifest};
use std::path::PathBuf;

/// Mean over the pixels of `img` where `inside` holds, within the crop square.
fn mean_where(img: &Gray<u8>, (x0, y0, side): (usize, usize, usize), inside: impl Fn(usize) -> bool) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for y in y0..y0 + side {
        for x in x0..x0 + side {
            let i = y * img.width + x;
            if inside(i) {
                sum += f64::from(img.data[i]);
                n += 1;
            }
        }
    }
    if n == 0 { f64::NAN } else { sum / n as f64 }
}

fn main() -> Result<()> {
    let mut args = std::env::args_os().skip(1);
    let (Some(dir), Some(out)) = (args.next().map(PathBuf::from), args.next().map(PathBuf::from)) else {
        bail!("usage: scene_sheet SEQUENCE_DIR OUT.png [whole]");
    };
    let whole = match args.next() {
        None => false,
        Some(w) if w == "whole" => true,
        Some(w) => bail!("the third argument is `whole` (the whole frame), not {}", w.to_string_lossy()),
    };
    let m = read_manifest(&dir)?;
    let load = |rel: &str| load_gray_u8(&dir.join(rel), ColorPolicy::Refuse);
    let last = |p: Phase| m.frames.iter().rev().find(|f| f.phase == p);
    let penumbra: Vec<_> = m.frames.iter().filter(|f| f.phase == Phase::Penumbra).collect();
    let rows: Vec<_> = [
        ("light", last(Phase::Light)),
        ("penumbra", penumbra.get(penumbra.len() / 2).copied()),
        ("eclipse", last(Phase::Eclipse)),
    ]
    .into_iter()
    .filter_map(|(name, f)| f.map(|f| (name, f)))
    .collect();
    let mut methods: Vec<(&str, Method)> = core_methods().into_iter().map(|n| (n.name, n.method)).collect();
    methods.push(("adaptive", Method::Adaptive(AdaptiveParams::default())));
    let mut columns = vec!["VIS", "TIR"];
    columns.extend(methods.iter().map(|(n, _)| *n));
    println!(
        "target minus its background, grey levels ({})",
        if whole { "whole frame" } else { "crop of 3x the target" }
    );
    println!("| frame | {} |", columns.join(" | "));
    println!("|---|{}", "---:|".repeat(columns.len()));
    let (mut sheet, mut labels) = (Vec::new(), Vec::new());
    for (name, f) in &rows {
        let (vis, tir) = (load(&f.files.vis)?, load(&f.files.tir)?);
        let g = grid(&vis, &tir, RescalePolicy::TirUp)?;
        let tir_up = source_on_grid(&tir, g, Filter::Cubic)?;
        let target = load(&f.files.vis_mask)?;
        // The background: the Earth where the sequence draws it, else everything off the target.
        let background = match f.files.vis_earth_mask.as_deref() {
            Some(rel) => load(rel)?,
            None => Gray {
                width: target.width,
                height: target.height,
                data: target.data.iter().map(|&t| 255 - t).collect(),
            },
        };
        let tir_target = source_on_grid(&load(&f.files.tir_mask)?, g, Filter::Area)?;
        let square = if whole {
            (0, 0, vis.width.min(vis.height))
        } else {
            target_square(&[&target, &tir_target], 127, 1.0)
        };
        let mut images = vec![vis.clone(), tir_up];
        for (_, method) in &methods {
            let config =
                FuseConfig { rescale: RescalePolicy::TirUp, method: *method, ..FuseConfig::default() };
            images.push(fuse_core(&vis, &tir, &config, false)?.image);
        }
        let contrast: Vec<String> = images
            .iter()
            .map(|img| {
                let t = mean_where(img, square, |i| target.data[i] > 127);
                let e = mean_where(img, square, |i| background.data[i] > 127);
                format!("{:+.1}", t - e)
            })
            .collect();
        println!("| {name} {} ({:.1} m) | {} |", f.index, f.range_m, contrast.join(" | "));
        sheet.push(images.iter().map(|img| tile(img, square, 200)).collect::<Result<Vec<_>>>()?);
        labels.push(format!("{name} {}", f.index));
    }
    let labels: Vec<&str> = labels.iter().map(String::as_str).collect();
    fusion_io::save_gray_u8(&out, &labelled_sheet(&sheet, 4, &columns, &labels))?;
    println!("\nwrote {}", out.display());
    Ok(())
}
