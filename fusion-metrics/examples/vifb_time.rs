//! Timing of VIFB's 13 on fixed inputs, for before/after comparisons (BENCHMARKS.md, "Metrics
//! fast (issue 43)"): `vifb_time CASE REPS` prints each run's milliseconds, the median and the 13
//! values in full precision (`{:?}` of `f64` round-trips). CASE is `grey640`, `colour640` or
//! `grey4096`; REPS 0 only prints the values of one run. One thread (the suite uses none).
//!
//! Inputs: VIFB's kettle pair and its published outputs, rescaled with the core's bicubic —
//! grey: (VIS, IR, TSIFSD); colour: VIS planes (VIS, IR, VIS), grey IR, fused planes
//! (ADF, TSIFSD, IFEVIP).

use fusion_io::{Channels, ColorPolicy, Gray, load_gray_u8, testdata};
use fusion_metrics::vifb::vifb_metrics;
use std::time::Instant;

fn kettle(name: &str, w: usize, h: usize) -> Vec<u8> {
    let img: Gray<u8> =
        load_gray_u8(&testdata::file(&format!("vifb/kettle_{name}.png")), ColorPolicy::Refuse).unwrap();
    fusion_io::source_on_grid(&img, (w, h), fusion_nostd::Filter::Cubic).unwrap().data
}

/// The (VIS, IR, fused) triple of a case.
pub fn case(name: &str) -> [Channels; 3] {
    let (w, h) = match name {
        "grey640" | "colour640" => (640, 480),
        "grey4096" => (4096, 4096),
        _ => panic!("unknown case {name}: grey640, colour640 or grey4096"),
    };
    let ch = |planes: Vec<Vec<u8>>| Channels { width: w, height: h, planes };
    let k = |n: &str| kettle(n, w, h);
    if name == "colour640" {
        [
            ch(vec![k("VIS"), k("IR"), k("VIS")]),
            ch(vec![k("IR")]),
            ch(vec![k("ADF_ref"), k("TSIFSD_ref"), k("IFEVIP_ref")]),
        ]
    } else {
        [ch(vec![k("VIS")]), ch(vec![k("IR")]), ch(vec![k("TSIFSD_ref")])]
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("grey640", String::as_str);
    let reps: usize = args.get(2).map_or(5, |r| r.parse().unwrap());
    let [v, i, f] = case(name);
    let mut times = Vec::new();
    let mut values = vifb_metrics(&v, &i, &f).unwrap();
    for _ in 0..reps {
        let t = Instant::now();
        values = vifb_metrics(&v, &i, &f).unwrap();
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    if reps > 0 {
        let mut sorted = times.clone();
        sorted.sort_by(f64::total_cmp);
        let runs: Vec<String> = times.iter().map(|t| format!("{t:.2}")).collect();
        println!("{name} runs_ms {}", runs.join(" "));
        println!("{name} median_ms {:.2}", sorted[reps / 2]);
    }
    println!("{name} values {:?}", values.values());
}
