//! Host timing of the metric suites on real content at 640×480 (one thread).
//!
//! `RAYON_NUM_THREADS=1 cargo bench -p fusion-metrics --bench metrics`. The triple is VIFB's
//! `kettle` pair and its published TSIFSD output, rescaled to 640×480 with the core's bicubic
//! rescaler; VIFB's 13 also in colour (VIS planes VIS, IR, VIS; fused planes ADF, TSIFSD,
//! IFEVIP) and, with `VIFB_4096=1` in the environment, on the grey triple at 4096² (ten
//! iterations of seconds each). The same inputs as `examples/vifb_time.rs`; commands and
//! figures: BENCHMARKS.md, "Metrics".

use criterion::{Criterion, criterion_group, criterion_main};
use fusion_io::testdata;
use fusion_io::{Channels, ColorPolicy, Gray, load_gray_u8};
use fusion_metrics::table::study_metrics;
use fusion_metrics::vifb::vifb_metrics;
use fusion_metrics::{HaghighatFeature, fmi_haghighat};
use std::hint::black_box;
use std::time::Duration;

fn kettle(name: &str, w: usize, h: usize) -> Gray<u8> {
    let img = load_gray_u8(&testdata::file(&format!("vifb/kettle_{name}.png")), ColorPolicy::Refuse).unwrap();
    fusion_io::source_on_grid(&img, (w, h), fusion_nostd::Filter::Cubic).unwrap()
}

fn triple(w: usize, h: usize) -> [Gray<u8>; 3] {
    ["VIS", "IR", "TSIFSD_ref"].map(|name| kettle(name, w, h))
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
        let colour = |names: [&str; 3]| Channels {
            width: w,
            height: h,
            planes: names.map(|n| kettle(n, w, h).data).to_vec(),
        };
        let cv3 = colour(["VIS", "IR", "VIS"]);
        let cf3 = colour(["ADF_ref", "TSIFSD_ref", "IFEVIP_ref"]);
        g.bench_function("vifb_13_colour", |b| b.iter(|| vifb_metrics(black_box(&cv3), &ci, &cf3).unwrap()));
        g.bench_function("fmi_pixel", |b| {
            b.iter(|| fmi_haghighat(black_box(&v), &i, &f, HaghighatFeature::Pixels))
        });
        g.bench_function("study_with_3_fmi", |b| b.iter(|| study_metrics(black_box(&v), &i, &f)));
        g.finish();
    }
    if std::env::var_os("VIFB_4096").is_some() {
        let (w, h) = (4096, 4096);
        let [v, i, f] = triple(w, h).map(Channels::from_gray);
        let mut g = c.benchmark_group(format!("metrics_{w}x{h}"));
        g.sample_size(10).measurement_time(Duration::from_secs(60));
        g.bench_function("vifb_13", |b| b.iter(|| vifb_metrics(black_box(&v), &i, &f).unwrap()));
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
