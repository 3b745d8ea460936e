//! Host timing of the core's u8 rescalers at the study's sizes (single thread).
//!
//! `cargo bench -p host-harness --bench rescale`; `scripts/bench_rescale.sh` runs this and
//! the OpenCV baseline in one go and prints the ratios for BENCHMARKS.md.

use criterion::{Criterion, criterion_group, criterion_main};
use fusion_nostd::{Filter, FrameMut, FrameRef, rescale};
use std::hint::black_box;

fn frame(w: usize, h: usize) -> Vec<u8> {
    // A smooth scene with texture, not constant (constant frames could flatter the kernels).
    (0..w * h).map(|i| ((i % w) * 7 + (i / w) * 13 + (i * 2654435761) % 31) as u8).collect()
}

fn bench(c: &mut Criterion) {
    let tir = frame(512, 512);
    let vis = frame(1024, 1024);
    let mut big = vec![0u8; 1024 * 1024];
    let mut small = vec![0u8; 512 * 512];
    let mut g = c.benchmark_group("rescale_u8");
    g.bench_function("cubic_512_to_1024", |b| {
        b.iter(|| {
            let src = FrameRef::new(black_box(&tir), 512, 512).unwrap();
            rescale(src, FrameMut::new(&mut big, 1024, 1024).unwrap(), Filter::Cubic).unwrap();
        })
    });
    g.bench_function("area_1024_to_512", |b| {
        b.iter(|| {
            let src = FrameRef::new(black_box(&vis), 1024, 1024).unwrap();
            rescale(src, FrameMut::new(&mut small, 512, 512).unwrap(), Filter::Area).unwrap();
        })
    });
    g.bench_function("cubic_1024_to_512", |b| {
        b.iter(|| {
            let src = FrameRef::new(black_box(&vis), 1024, 1024).unwrap();
            rescale(src, FrameMut::new(&mut small, 512, 512).unwrap(), Filter::Cubic).unwrap();
        })
    });
    g.bench_function("area_512_to_1024", |b| {
        b.iter(|| {
            let src = FrameRef::new(black_box(&tir), 512, 512).unwrap();
            rescale(src, FrameMut::new(&mut big, 1024, 1024).unwrap(), Filter::Area).unwrap();
        })
    });
    g.bench_function("memcpy_1024", |b| b.iter(|| big.copy_from_slice(black_box(&vis))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
