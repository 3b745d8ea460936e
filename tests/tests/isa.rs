//! Issue 23 item 1: every SIMD form of the host kernels gives the portable code's bytes. The
//! process-wide switch `fusion_nostd::cpu::limit_isa` caps the kernels at the portable code,
//! then at AVX2, then lets them take the best the CPU has (AVX-512 where there is one); every
//! method and variant, every rescale policy, the scene-skipping plans, strips and the
//! rescalers on their own run under each cap on the same rendered and synthetic frames, and
//! the outputs, reports and guards must be identical. On AArch64 (CI runs this test under
//! `qemu-aarch64`, built for `aarch64-unknown-linux-gnu`) the same comparison checks the NEON
//! forms. The Armv7E-M forms are checked against the host by `fusion budget` (byte-identical
//! outputs under QEMU).

use std::sync::Mutex;

use anyhow::Result;
use fusion_engine::skip::fuse_once;
use fusion_engine::strips::{HostStripScratch, fuse_strips_once};
use fusion_engine::study::Dataset;
use fusion_io::Gray;
use fusion_nostd::cpu::{Isa, isa, limit_isa};
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, SkipPolicy};
use fusion_nostd::{Filter, rescale};
use fusion_tests::scene;
use render_host::{DatasetConfig, render_dataset};

/// The tests here change the process-wide cap: one at a time.
static CAP: Mutex<()> = Mutex::new(());

/// The sets this CPU runs, each with the cap that selects it.
fn available() -> Vec<Isa> {
    let mut sets = Vec::new();
    for cap in Isa::ALL {
        limit_isa(cap);
        if isa() == cap {
            sets.push(cap);
        }
    }
    limit_isa(Isa::Avx512);
    sets
}

/// Everything the kernels compute for one frame pair, as bytes and reports.
fn outputs(vis: &Gray<u8>, tir: &Gray<u8>) -> Result<Vec<String>> {
    let mut all = Vec::new();
    let mut strips = HostStripScratch::default();
    for method in Method::all() {
        for rescale in [RescalePolicy::TirUp, RescalePolicy::VisDown] {
            for skip in [SkipPolicy::None, SkipPolicy::Roi, SkipPolicy::All] {
                let p = FuseConfig { method, rescale, skip, ..FuseConfig::default() };
                let (fused, report, _) = fuse_once(vis, tir, &p)?;
                all.push(format!("{}/{rescale:?}/{skip:?}: {:?} {report:?}", method.name(), fused.data));
            }
        }
        // Strips on the VIS grid (a grid far shorter than IFEVIP's quadtree grid needs more
        // than the 512 KiB, see `fusion_nostd::strips`).
        let p = FuseConfig { method, ..FuseConfig::default() };
        let (fused, report, layout, _) = fuse_strips_once(vis, tir, &p, 40, &mut strips)?;
        all.push(format!("{} strips: {:?} {report:?} {layout:?}", method.name(), fused.data));
    }
    for filter in [Filter::Cubic, Filter::Area] {
        for (src, size) in [(tir, (vis.width, vis.height)), (vis, (tir.width, tir.height)), (vis, (97, 61))] {
            let mut dst = Gray::<u8>::new(size.0, size.1);
            rescale(src.view()?, dst.view_mut()?, filter)?;
            all.push(format!("rescale {filter:?} to {size:?}: {:?}", dst.data));
            let f = Gray::<f32> {
                width: src.width,
                height: src.height,
                data: src.data.iter().map(|&v| f32::from(v) * 0.37 - 9.0).collect(),
            };
            let mut dst = Gray::<f32>::new(size.0, size.1);
            rescale(f.view()?, dst.view_mut()?, filter)?;
            all.push(format!(
                "rescale f32 {filter:?} to {size:?}: {:?}",
                dst.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
            ));
        }
    }
    Ok(all)
}

#[test]
fn every_simd_form_gives_the_portable_bytes() -> Result<()> {
    let _one = CAP.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir()?;
    let cfg = DatasetConfig { tir_sizes: vec![128], ..DatasetConfig::small(2, 256) };
    render_dataset(&cfg, dir.path(), false)?;
    let ds = Dataset::open(dir.path())?;
    let mut pairs = vec![("synthetic 2×".to_string(), scene(302, 200, 3), scene(151, 100, 4))];
    for (set, noisy) in [("vis_light", true), ("vis_eclipse", true), ("vis_light", false)] {
        pairs.push((format!("{set} noisy {noisy}"), ds.image(set, 1, noisy)?, ds.image("tir128", 1, noisy)?));
    }
    let sets = available();
    eprintln!("instruction sets on this CPU: {:?}", sets.iter().map(|s| s.name()).collect::<Vec<_>>());
    // Not a vacuous pass: a CPU with AVX2 compares at least the AVX2 forms with the portable code.
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        assert!(sets.len() >= 2 && sets.contains(&Isa::Avx2), "the cap did not select AVX2: {sets:?}");
    }
    // And on AArch64 (under `qemu-aarch64` in CI) the NEON forms.
    #[cfg(target_arch = "aarch64")]
    assert_eq!(sets, [Isa::Portable, Isa::Neon], "the cap did not select NEON");
    for (name, vis, tir) in &pairs {
        limit_isa(Isa::Portable);
        let portable = outputs(vis, tir);
        for &set in sets.iter().filter(|&&s| s != Isa::Portable) {
            limit_isa(set);
            let simd = outputs(vis, tir);
            limit_isa(Isa::Avx512);
            let (portable, simd) = (portable.as_ref().map_err(|e| anyhow::anyhow!("{e}"))?, simd?);
            assert_eq!(portable.len(), simd.len());
            for (a, b) in portable.iter().zip(&simd) {
                assert!(
                    a == b,
                    "{name}, {}: {} differs from the portable code",
                    &a[..a.find(':').unwrap_or(0)],
                    set.name()
                );
            }
        }
        limit_isa(Isa::Avx512);
    }
    Ok(())
}

/// The cap is what the kernels read: capped at the portable code no SIMD set is reported, and
/// lifting the cap gives back the best set (the same as the first call).
#[test]
fn the_cap_selects_the_instruction_set() {
    let _one = CAP.lock().unwrap_or_else(|e| e.into_inner());
    limit_isa(Isa::Avx512);
    let best = isa();
    limit_isa(Isa::Portable);
    assert_eq!(isa(), Isa::Portable);
    // AVX2 and NEON are one level: either caps AVX-512 at AVX2 and leaves NEON on.
    for level_one in [Isa::Avx2, Isa::Neon] {
        limit_isa(level_one);
        assert_eq!(isa(), if best == Isa::Avx512 { Isa::Avx2 } else { best });
    }
    limit_isa(Isa::Avx512);
    assert_eq!(isa(), best);
    #[cfg(target_arch = "x86_64")]
    assert_eq!([Isa::Avx2, Isa::Avx512].contains(&best), std::arch::is_x86_feature_detected!("avx2"));
    #[cfg(target_arch = "aarch64")]
    assert_eq!(best, Isa::Neon);
}
