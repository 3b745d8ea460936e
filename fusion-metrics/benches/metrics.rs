//! Host timing of the metric suites on real content at 640×480 (one thread).
//!
//! `RAYON_NUM_THREADS=1 cargo bench -p host-harness --bench metrics`. The triple is VIFB's
//! `kettle` pair and its published TSIFSD output, rescaled to 640×480 with the core's bicubic
//! rescaler. The 4096² figures come from `fusion eval` runs (one iteration takes seconds);
//! commands and figures: BENCHMARKS.md, "Metrics".

use criterion::{Criterion, criterion_group, criterion_main};
use fusion_io::testdata;
use fusion_io::{Channels, ColorPolicy, Gray, load_gray_u8};
use fusion_metrics::table::study_metrics;
use fusion_metrics::vifb::vifb_metrics;
use fusion_metrics::{HaghighatFeature, fmi_haghighat};
use std::hint::black_box;
use std::time::Duration;

fn triple(w: usize, h: usize) -> [Gray<u8>; 3] {
    ["kettle_VIS.png", "kettle_IR.png", "kettle_TSIFSD_ref.png"].map(|name| {
        let img = load_gray_u8(&testdata::file(&format!("vifb/{name}")), ColorPolicy::Refuse).unwrap();
        fusion_io::source_on_grid(&img, (w, h), fusion_nostd::Filter::Cubic).unwrap()
    })
}

fn bench(c: &mut Criterion) {
    {
        let (w, h) = (640, 480);
        let [v, i, f] = triple(w, h);
        let ch = |g: &Gray<u8>| Channels::from_gray(g.clone());
        let (cv, ci, cf) = (ch(&v), ch(&i), ch(&f));
        let mut g = c.benchmark_group(format!("metrics_{w}x{h}"));
        g.sample_size(20).measurement_time(Duration::from_secs(10));
        g.bench_function("vifb_13", |b| b.iter(|| vifb_metrics(black_box(&cv), &ci, &cf).unwrap()));
        g.bench_function("fmi_pixel", |b| {
            b.iter(|| fmi_haghighat(black_box(&v), &i, &f, HaghighatFeature::Pixels))
        });
        g.bench_function("study_with_3_fmi", |b| b.iter(|| study_metrics(black_box(&v), &i, &f)));
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
