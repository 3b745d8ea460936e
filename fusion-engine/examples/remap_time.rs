//! The core's remap timed on one thread, beside OpenCV's on the same map.
//!
//! ```sh
//! cargo run --release -p fusion-engine --example remap_time -- /tmp/remap-time     # writes the map, times ours
//! python3 scripts/cv2_remap_timing.py /tmp/remap-time                             # times cv2.remap on it
//! ```
//!
//! The map: the default offset rig at 8 m (`fusion_nostd::registration::RigMap::rows` over the
//! whole 1024² visible grid), written raw into `DIR` (`map_xy.i16`, `map_frac.u16`, 1024 × 1024,
//! little-endian) with a 512² 8-bit thermal frame (`tir.u8`, a smooth pattern with edges) and our
//! outputs (`out_linear.u8`, `out_cubic.u8`) so the script can check the bytes too. Prints the
//! median of 50 calls of `remap` (8-bit, linear and cubic, constant 0) and of the map alone.

use anyhow::{Context, Result};
use fusion_io::Gray;
use fusion_nostd::registration::{Border, FixedMap, Interpolation, NODE_STEP, RigMap, node_count, remap};
use std::time::Instant;

fn median_ms(mut f: impl FnMut()) -> f64 {
    for _ in 0..5 {
        f();
    }
    let mut t: Vec<f64> = (0..50)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn main() -> Result<()> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).context("usage: remap_time DIR")?);
    std::fs::create_dir_all(&dir)?;
    let rig = fusion_io::rig::from_text(fusion_io::rig::example_json())?;
    let (w, h) = (rig.vis.width, rig.vis.height);
    let mut nodes = vec![[0.0f32; 2]; node_count(w, h, NODE_STEP)];
    let map = RigMap::new(&rig, 8.0, NODE_STEP, &mut nodes).map_err(|e| anyhow::anyhow!("{e}"))?;
    let (mut xy, mut frac) = (vec![0i16; 2 * w * h], vec![0u16; w * h]);
    let map_ms = median_ms(|| map.rows(0, &mut xy, &mut frac).unwrap_or(()));
    let tir = Gray {
        width: 512,
        height: 512,
        data: (0..512 * 512)
            .map(|i| {
                let (x, y) = ((i % 512) as f64, (i / 512) as f64);
                let v =
                    128.0 + 80.0 * (x / 17.0).sin() * (y / 23.0).cos() + if x > 300.0 { 30.0 } else { 0.0 };
                v.clamp(0.0, 255.0) as u8
            })
            .collect(),
    };
    let fixed = FixedMap::new(w, h, &xy, &frac).map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut out = Gray::<u8>::new(w, h);
    println!("| step (1024² from 512², one thread) | ours, median ms |");
    println!("|---|---:|");
    println!("| map (`RigMap::rows`, whole frame) | {map_ms:.2} |");
    for (name, interp) in [("linear", Interpolation::Linear), ("cubic", Interpolation::Cubic)] {
        let ms = median_ms(|| {
            let _ = remap(tir.view().unwrap(), &fixed, out.view_mut().unwrap(), interp, Border::Constant(0));
        });
        println!("| remap {name} 8-bit | {ms:.2} |");
        std::fs::write(dir.join(format!("out_{name}.u8")), &out.data)?;
    }
    std::fs::write(dir.join("map_xy.i16"), xy.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
    std::fs::write(dir.join("map_frac.u16"), frac.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
    std::fs::write(dir.join("tir.u8"), &tir.data)?;
    Ok(())
}
