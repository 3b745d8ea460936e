//! VIFB's 13 against the values the suite gave before the speed work of issue 43 (commit
//! `dd1d640`'s code), stored bit for bit in `vifb_frozen.txt`: every value must stay within
//! 1e-12 relative (NaN stays NaN). Most are bit-identical; the test prints how many are not and
//! the largest relative drift.
//!
//! The file was written by the code before the change with
//! `FROZEN_WRITE=1 cargo test --release -p fusion-metrics --test vifb_frozen` (one line per case
//! and key: case, key, the value's bits in hex, the value).

use fusion_io::{Channels, ColorPolicy, Gray, load_channels_u8, load_gray_u8, testdata};
use fusion_metrics::vifb::{KEYS, vifb_metrics};

const TOLERANCE: f64 = 1e-12;

/// A deterministic 8-bit pattern (SplitMix64), smoothed a little so that it has edges and flat
/// parts; `levels` limits the values (few levels give equal strengths and empty bins).
fn pattern(w: usize, h: usize, seed: u64, levels: u64) -> Vec<u8> {
    let mut s = seed;
    let mut next = || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    let raw: Vec<u64> = (0..w * h).map(|_| next() % levels).collect();
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let right = raw[y * w + (x + 1).min(w - 1)];
            let below = raw[(y + 1).min(h - 1) * w + x];
            ((2 * raw[i] + right + below) * 255 / (4 * (levels - 1))) as u8
        })
        .collect()
}

fn kettle(name: &str, w: usize, h: usize) -> Vec<u8> {
    let img: Gray<u8> =
        load_gray_u8(&testdata::file(&format!("vifb/kettle_{name}.png")), ColorPolicy::Refuse).unwrap();
    fusion_io::source_on_grid(&img, (w, h), fusion_nostd::Filter::Cubic).unwrap().data
}

fn cases() -> Vec<(String, [Channels; 3])> {
    let mut out = Vec::new();
    let dir = testdata::vifb_dir();
    let load = |name: &str| load_channels_u8(&dir.join(name)).unwrap();
    for pair in ["fight", "kettle", "manWalking", "peopleshadow"] {
        for m in ["ADF", "TSIFSD", "IFEVIP"] {
            let t = [
                load(&format!("{pair}_VIS.png")),
                load(&format!("{pair}_IR.png")),
                load(&format!("{pair}_{m}_ref.png")),
            ];
            out.push((format!("{pair}_{m}"), t));
        }
    }
    let (w, h) = (640, 480);
    let ch = |planes: Vec<Vec<u8>>, w, h| Channels { width: w, height: h, planes };
    let k = |n: &str| kettle(n, w, h);
    out.push((
        "kettle640_grey".into(),
        [ch(vec![k("VIS")], w, h), ch(vec![k("IR")], w, h), ch(vec![k("TSIFSD_ref")], w, h)],
    ));
    out.push((
        "kettle640_colour".into(),
        [
            ch(vec![k("VIS"), k("IR"), k("VIS")], w, h),
            ch(vec![k("IR")], w, h),
            ch(vec![k("ADF_ref"), k("TSIFSD_ref"), k("IFEVIP_ref")], w, h),
        ],
    ));
    // Odd sizes (prime, Bluestein FFT lengths), few levels, colour against colour.
    for (w, h, levels) in [(37, 23, 256), (61, 17, 3), (11, 11, 256), (131, 97, 16)] {
        let p = |seed| pattern(w, h, seed, levels);
        out.push((
            format!("noise{w}x{h}_{levels}_grey"),
            [ch(vec![p(1)], w, h), ch(vec![p(2)], w, h), ch(vec![p(3)], w, h)],
        ));
        out.push((
            format!("noise{w}x{h}_{levels}_colour"),
            [
                ch(vec![p(4), p(5), p(6)], w, h),
                ch(vec![p(7), p(8), p(9)], w, h),
                ch(vec![p(10), p(11), p(12)], w, h),
            ],
        ));
    }
    // Constant non-zero channels: Qcb and Qcv are NaN.
    out.push((
        "constant_grey".into(),
        [
            ch(vec![vec![9; 256]], 16, 16),
            ch(vec![pattern(16, 16, 13, 256)], 16, 16),
            ch(vec![vec![9; 256]], 16, 16),
        ],
    ));
    out
}

#[test]
fn values_stay_within_1e_12_of_the_code_before_the_speed_work() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/vifb_frozen.txt");
    let mut lines = Vec::new();
    let mut got = Vec::new();
    for (name, [v, i, f]) in cases() {
        let m = vifb_metrics(&v, &i, &f).unwrap();
        for (key, value) in KEYS.iter().zip(m.values()) {
            lines.push(format!("{name} {key} {:016x} {value:e}", value.to_bits()));
            got.push((name.clone(), *key, value));
        }
    }
    if std::env::var_os("FROZEN_WRITE").is_some() {
        std::fs::write(&path, lines.join("\n") + "\n").unwrap();
        return;
    }
    let stored = std::fs::read_to_string(&path).unwrap();
    let stored: Vec<&str> = stored.lines().collect();
    assert_eq!(stored.len(), got.len(), "one stored line per case and key");
    let (mut differ, mut worst, mut failures) = (0, 0f64, Vec::new());
    for (line, (name, key, value)) in stored.iter().zip(&got) {
        let cells: Vec<&str> = line.split(' ').collect();
        assert_eq!((cells[0], cells[1]), (name.as_str(), *key));
        let want = f64::from_bits(u64::from_str_radix(cells[2], 16).unwrap());
        if want.to_bits() == value.to_bits() || (want.is_nan() && value.is_nan()) {
            continue;
        }
        differ += 1;
        let rel = ((value - want) / want).abs();
        worst = worst.max(rel);
        if !(rel <= TOLERANCE || (want == 0.0 && *value == 0.0)) {
            failures.push(format!("{name} {key}: now {value:e}, before {want:e}, rel {rel:.2e}"));
        }
    }
    eprintln!("{differ} of {} values differ in bits; largest relative drift {worst:.2e}", got.len());
    assert!(failures.is_empty(), "{} values drifted:\n{}", failures.len(), failures.join("\n"));
}
