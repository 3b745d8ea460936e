//! Host timing of ADF and TSIFSD (single thread): the integer core in both variants and the
//! f64 references, at 512² and 1024².
//!
//! `cargo bench -p host-harness --bench fuse_adf_tsifsd` (all), or filter, e.g.
//! `cargo bench -p host-harness --bench fuse_adf_tsifsd -- core/` for the core only.

use criterion::{Criterion, criterion_group, criterion_main};
use fusion_engine::CoreScratch;
use fusion_engine::study::bench_frame as frame;
use fusion_io::Gray;
use fusion_nostd::methods::Variant;
use fusion_nostd::methods::adf::{AdfParams, fuse_adf};
use fusion_nostd::methods::tsifsd::{TsifsdParams, fuse_tsifsd};
use fusion_nostd::{FrameMut, FrameRef};
use fusion_reference as reference;
use std::hint::black_box;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("fuse_adf_tsifsd");
    g.sample_size(20).measurement_time(Duration::from_secs(4)).warm_up_time(Duration::from_secs(1));
    for n in [512usize, 1024] {
        let (vis, tir) = (frame(n, 3), frame(n, 11));
        let mut out = vec![0u8; n * n];
        let mut scratch = CoreScratch::new(n * n);
        for variant in [Variant::Classic, Variant::Flight] {
            let adf = AdfParams { variant, ..AdfParams::default() };
            let tsifsd = TsifsdParams { variant, ..TsifsdParams::default() };
            g.bench_function(format!("core/adf/{variant:?}/{n}"), |b| {
                b.iter(|| {
                    let v = FrameRef::new(black_box(&vis), n, n).unwrap();
                    let t = FrameRef::new(black_box(&tir), n, n).unwrap();
                    fuse_adf(v, t, FrameMut::new(&mut out, n, n).unwrap(), &adf, &mut scratch.view_mut())
                        .unwrap()
                })
            });
            g.bench_function(format!("core/tsifsd/{variant:?}/{n}"), |b| {
                b.iter(|| {
                    let v = FrameRef::new(black_box(&vis), n, n).unwrap();
                    let t = FrameRef::new(black_box(&tir), n, n).unwrap();
                    fuse_tsifsd(
                        v,
                        t,
                        FrameMut::new(&mut out, n, n).unwrap(),
                        &tsifsd,
                        &mut scratch.view_mut(),
                    )
                    .unwrap()
                })
            });
        }
    }
    g.finish();

    // The f64 references are ~100× slower: fewer samples.
    let mut g = c.benchmark_group("fuse_adf_tsifsd");
    g.sample_size(10).measurement_time(Duration::from_secs(5)).warm_up_time(Duration::from_millis(500));
    for n in [512usize, 1024] {
        let to_f64 = |d: Vec<u8>| Gray { width: n, height: n, data: d.into_iter().map(f64::from).collect() };
        let (vis, tir) = (to_f64(frame(n, 3)), to_f64(frame(n, 11)));
        for variant in [Variant::Classic, Variant::Flight] {
            let adf = AdfParams { variant, ..AdfParams::default() };
            let tsifsd = TsifsdParams { variant, ..TsifsdParams::default() };
            g.bench_function(format!("reference/adf/{variant:?}/{n}"), |b| {
                b.iter(|| reference::adf::fuse_adf(black_box(&vis), black_box(&tir), &adf))
            });
            g.bench_function(format!("reference/tsifsd/{variant:?}/{n}"), |b| {
                b.iter(|| reference::tsifsd::fuse_tsifsd(black_box(&vis), black_box(&tir), &tsifsd))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
