//! VIFB's 13 metrics against VIFB's own MATLAB code (run under GNU Octave on the twelve shared
//! triples: `tests/data/vifb/vifb_metrics.csv`, see `tests/data/README.md`): every value to
//! 1e-6 relative.

use fusion_io::load_channels_u8;
use fusion_io::testdata;
use fusion_metrics::vifb::{KEYS, vifb_metrics};

const TOLERANCE: f64 = 1e-6;

#[test]
fn all_thirteen_metrics_match_vifbs_code_on_every_shared_triple() {
    let dir = testdata::vifb_dir();
    let csv = std::fs::read_to_string(testdata::file("vifb/vifb_metrics.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(&header[3..], &KEYS, "the reference's columns are the suite's keys");
    let mut rows = 0;
    let mut worst = vec![0f64; KEYS.len()];
    let mut failures = Vec::new();
    for line in lines.filter(|l| !l.trim().is_empty()) {
        let cells: Vec<&str> = line.split(',').collect();
        let load = |name: &str| load_channels_u8(&dir.join(name)).unwrap();
        let m = vifb_metrics(&load(cells[0]), &load(cells[1]), &load(cells[2])).unwrap();
        for (k, (key, ours)) in KEYS.iter().zip(m.values()).enumerate() {
            let theirs: f64 = cells[3 + k].parse().unwrap();
            let rel = ((ours - theirs) / theirs).abs();
            worst[k] = worst[k].max(rel);
            if rel.is_nan() || rel > TOLERANCE {
                failures
                    .push(format!("{} {key}: ours {ours:.10e}, VIFB {theirs:.10e}, rel {rel:.2e}", cells[2]));
            }
        }
        rows += 1;
    }
    assert_eq!(rows, 12, "four pairs × three published outputs");
    for (key, w) in KEYS.iter().zip(&worst) {
        eprintln!("{key:<5} worst relative difference {w:.2e}");
    }
    assert!(failures.is_empty(), "{} values off:\n{}", failures.len(), failures.join("\n"));
}
