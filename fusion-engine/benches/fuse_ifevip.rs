//! Host timing of IFEVIP (single thread): the integer core in both variants and the f64
//! reference, at 512² and 1024². The study's MATLAB figures on an i7-8750H: 24 ms (512²),
//! 94 ms (1024²).
//!
//! `cargo bench -p host-harness --bench fuse_ifevip` (all), or filter, e.g.
//! `cargo bench -p host-harness --bench fuse_ifevip -- core/` for the core only.

use criterion::{Criterion, criterion_group, criterion_main};
use fusion_engine::CoreScratch;
use fusion_engine::study::bench_frame as frame;
use fusion_io::Gray;
use fusion_nostd::methods::Variant;
use fusion_nostd::methods::ifevip::{IfevipParams, fuse_ifevip, scratch_pixels};
use fusion_nostd::{FrameMut, FrameRef};
use fusion_reference as reference;
use std::hint::black_box;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("fuse_ifevip");
    g.sample_size(20).measurement_time(Duration::from_secs(4)).warm_up_time(Duration::from_secs(1));
    for n in [512usize, 1024] {
        let (vis, tir) = (frame(n, 3), frame(n, 11));
        let mut out = vec![0u8; n * n];
        for variant in [Variant::Classic, Variant::Flight] {
            let params = IfevipParams { variant, ..IfevipParams::default() };
            let mut scratch = CoreScratch::new(scratch_pixels(n, n, &params));
            g.bench_function(format!("core/{variant:?}/{n}"), |b| {
                b.iter(|| {
                    let v = FrameRef::new(black_box(&vis), n, n).unwrap();
                    let t = FrameRef::new(black_box(&tir), n, n).unwrap();
                    fuse_ifevip(
                        v,
                        t,
                        FrameMut::new(&mut out, n, n).unwrap(),
                        &params,
                        &mut scratch.view_mut(),
                    )
                    .unwrap()
                })
            });
        }
    }
    g.finish();

    let mut g = c.benchmark_group("fuse_ifevip");
    g.sample_size(10).measurement_time(Duration::from_secs(5)).warm_up_time(Duration::from_millis(500));
    for n in [512usize, 1024] {
        let to_f64 = |d: Vec<u8>| Gray { width: n, height: n, data: d.into_iter().map(f64::from).collect() };
        let (vis, tir) = (to_f64(frame(n, 3)), to_f64(frame(n, 11)));
        let params = IfevipParams { variant: Variant::Classic, ..IfevipParams::default() };
        g.bench_function(format!("reference/Classic/{n}"), |b| {
            b.iter(|| reference::ifevip::fuse_ifevip(black_box(&vis), black_box(&tir), &params))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
