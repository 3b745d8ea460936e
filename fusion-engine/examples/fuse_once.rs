//! Runs one fusion of a synthetic pair on the core, for instruction counting under callgrind.
//!
//! ```sh
//! cargo build --release -p host-harness --example fuse_once
//! valgrind --tool=callgrind --toggle-collect=fuse_once::fuse_region \
//!     target/release/examples/fuse_once adf classic 1024
//! ```
//!
//! Arguments: `adf|tsifsd|ifevip`, `classic|flight`, the side `n` (frames are `n × n`),
//! optionally `--repeat R` (fuse R times; prints the minimum and median time per fusion) and `--write DIR` (also write the synthetic pair as
//! `DIR/synth<n>_VIS.png`, `DIR/synth<n>_IR.png`, and raw 8-bit `.gray` twins for the firmware),
//! or `--pair VIS.png TIR.png` (a real pair instead of the synthetic one: the TIR frame is
//! bicubic-rescaled onto the VIS grid first, outside the timing, and `n` is ignored), and
//! `--strips` (fuse in strips, `fusion_nostd::strips`, in the 512 KiB strip scratch: the pair
//! is on one grid, so the count is the method's strip overhead without band rescales). Only [`fuse_region`] does the fusion, so
//! `--toggle-collect` on it counts the fusion alone (frame synthesis excluded). The frames are
//! the ones of the criterion benches (`benches/fuse_adf_tsifsd.rs`).

use anyhow::{Context, Result, bail};
use fusion_engine::CoreScratch;
use fusion_engine::strips::HostStripScratch;
use fusion_engine::study::bench_frame as frame;
use fusion_io::{ColorPolicy, Gray, load_gray_u8, save_gray_u8};
use fusion_nostd::methods::Variant;
use fusion_nostd::methods::adf::AdfParams;
use fusion_nostd::methods::ifevip::{IfevipParams, scratch_pixels};
use fusion_nostd::methods::tsifsd::TsifsdParams;
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, fuse_method};
use fusion_nostd::rescalers::{Filter, rescale};
use fusion_nostd::strips::fuse_strips;
use fusion_nostd::{FrameMut, FrameRef, Guards};
use std::hint::black_box;
use std::path::PathBuf;

/// The measured region: one fusion (whole frame, or in strips in the 512 KiB strip scratch
/// when `strips` is given: the same pair on one grid, so no band is rescaled).
#[inline(never)]
fn fuse_region(
    vis: &[u8],
    tir: &[u8],
    out: &mut [u8],
    n: usize,
    method: &Method,
    scratch: &mut CoreScratch,
    strips: Option<&mut HostStripScratch>,
) -> Guards {
    let run = || -> Result<Guards> {
        let v = FrameRef::new(black_box(vis), n, n)?;
        let t = FrameRef::new(black_box(tir), n, n)?;
        let o = FrameMut::new(out, n, n)?;
        Ok(match strips {
            Some(s) => {
                let p = FuseConfig { method: *method, rescale: RescalePolicy::None, ..FuseConfig::default() };
                fuse_strips(v, t, o, &mut s.view_mut(), &p, usize::MAX)?.0.guards
            }
            None => fuse_method(v, t, o, method, &mut scratch.view_mut())?,
        })
    };
    run().unwrap_or(Guards(u32::MAX))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(method), Some(variant), Some(n)) = (args.first(), args.get(1), args.get(2)) else {
        bail!("usage: fuse_once adf|tsifsd|ifevip classic|flight N [--repeat R] [--write DIR]");
    };
    let variant = match variant.as_str() {
        "classic" => Variant::Classic,
        "flight" => Variant::Flight,
        v => bail!("unknown variant {v}"),
    };
    let n: usize = n.parse().context("N")?;
    let method = match method.as_str() {
        "adf" => Method::Adf(AdfParams { variant, ..AdfParams::default() }),
        "tsifsd" => Method::Tsifsd(TsifsdParams { variant, ..TsifsdParams::default() }),
        "ifevip" => Method::Ifevip(IfevipParams { variant, ..IfevipParams::default() }),
        m => bail!("unknown method {m}"),
    };
    let mut repeat = 1usize;
    let mut write: Option<PathBuf> = None;
    let mut pair: Option<(PathBuf, PathBuf)> = None;
    let mut strips: Option<HostStripScratch> = None;
    let mut rest = args.iter().skip(3);
    while let Some(a) = rest.next() {
        match a.as_str() {
            "--repeat" => repeat = rest.next().context("--repeat R")?.parse()?,
            "--strips" => strips = Some(HostStripScratch::default()),
            "--write" => write = Some(PathBuf::from(rest.next().context("--write DIR")?)),
            "--pair" => {
                let vis = PathBuf::from(rest.next().context("--pair VIS TIR")?);
                pair = Some((vis, PathBuf::from(rest.next().context("--pair VIS TIR")?)));
            }
            other => bail!("unknown argument {other}"),
        }
    }
    let (n, vis, tir) = match &pair {
        None => (n, frame(n, 3), frame(n, 11)),
        Some((v, t)) => {
            let vis = load_gray_u8(v, ColorPolicy::Bt601)?;
            let tir = load_gray_u8(t, ColorPolicy::Bt601)?;
            if vis.width != vis.height {
                bail!("--pair wants a square VIS frame, got {}x{}", vis.width, vis.height);
            }
            let mut up = Gray::new(vis.width, vis.height);
            rescale(tir.view()?, up.view_mut()?, Filter::Cubic)?;
            (vis.width, vis.data, up.data)
        }
    };
    if let Some(dir) = write {
        for (name, data) in [("VIS", &vis), ("IR", &tir)] {
            let img = Gray { width: n, height: n, data: data.clone() };
            save_gray_u8(&dir.join(format!("synth{n}_{name}.png")), &img)?;
            std::fs::write(dir.join(format!("synth{n}_{name}.gray")), data)?;
        }
    }
    let pixels = match &method {
        Method::Ifevip(p) => scratch_pixels(n, n, p).max(n * n),
        _ => n * n,
    };
    let mut scratch = CoreScratch::new(pixels);
    let mut out = vec![0u8; n * n];
    let mut guards = Guards::NONE;
    let mut times = Vec::with_capacity(repeat);
    for _ in 0..repeat {
        let start = std::time::Instant::now();
        guards = fuse_region(&vis, &tir, &mut out, n, &method, &mut scratch, strips.as_mut());
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let checksum = out.iter().fold(0u64, |h, &v| h.wrapping_mul(1_000_003).wrapping_add(u64::from(v)));
    println!("guards {:#x} checksum {checksum:016x}", guards.0);
    // Minimum and median per fusion: on a shared machine the minimum is the steadiest figure.
    if let (Some(min), Some(median)) = (times.first(), times.get(times.len() / 2)) {
        println!("ms per fusion over {repeat} runs: min {min:.3} median {median:.3}");
    }
    Ok(())
}
