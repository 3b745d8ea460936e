//! `fusion report` end to end on a tiny rendered dataset (VIS 128², TIR 64² and 128², 2 frames):
//! the core's four method rows and the study's four host-only ones (gff, mgff, tepgfl, drif).

use fusion_io::{ColorPolicy, load_gray_u8};
use std::process::Command;

fn fusion(args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_fusion")).args(args).output().unwrap();
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn report_writes_every_table_chart_and_conclusion() {
    let dir = tempfile::tempdir().unwrap();
    let (data, out) = (dir.path().join("data"), dir.path().join("report"));
    let (data_s, out_s) = (data.to_str().unwrap(), out.to_str().unwrap());
    fusion(&["render", "--out", data_s, "--frames", "2", "--vis-size", "128", "--tir-sizes", "64,128"]);
    fusion(&["report", "--data", data_s, "--out", out_s, "--repeats", "1"]);

    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    for t in 2..=7 {
        assert!(md.contains(&format!("## Table {t}")), "table {t} missing");
    }
    let verdicts = md.matches("confirmed**").count();
    assert!(verdicts >= 16, "{verdicts} verdicts");
    for finding in
        ["*GFF darkens with TIR upscaling*", "*TEPGFL halos*", "*DRIF is textureless*", "*DRIF is slow*"]
    {
        assert!(md.contains(finding), "{finding} missing");
    }

    // Every cell has a value per frame; rescaling PSNRs are finite and plausible.
    let tables = std::fs::read_to_string(out.join("tables.csv")).unwrap();
    let mut t2 = 0;
    for line in tables.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        // two frames; the timings of Table 7 pool both illuminations
        assert_eq!(f[5], if f[0] == "t7" { "4" } else { "2" }, "{line}");
        if f[0] == "t2" && f[2] == "PSNR_S" {
            let v: f64 = f[3].parse().unwrap();
            assert!((10.0..60.0).contains(&v), "{line}");
            t2 += 1;
        }
        if f[2] == "SSIM" {
            let v: f64 = f[3].parse().unwrap();
            assert!((-2.0..=2.0).contains(&v), "1:2 SSIM is a sum of two SSIMs: {line}");
        }
    }
    assert_eq!(t2, 3, "area, bicubic, lanczos3");
    // Eight method rows in Tables 4 (TIR up) and 7; drif has no Table 5 (VIS down) row and a
    // "different res" Table 6 row.
    let rows = |table: &str, col: &str| -> Vec<String> {
        tables
            .lines()
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|f| f[0] == table && f[2] == col)
            .map(|f| f[1].to_string())
            .collect()
    };
    let all = ["adf", "drif", "gff", "ifevip", "mgff", "tepgfl", "tsifsd", "tsifsd-classic"];
    assert_eq!(rows("t4-eclipse", "AG"), all);
    assert_eq!(rows("t4-light", "level"), all);
    assert_eq!(
        rows("t5-light", "halo"),
        ["adf", "gff", "ifevip", "mgff", "tepgfl", "tsifsd", "tsifsd-classic"]
    );
    assert_eq!(rows("t7", "big"), all);
    assert_eq!(rows("t7", "small").len(), 7);
    let t6 = rows("t6-eclipse", "PSNR_S");
    assert_eq!(t6.len(), 7 * 3 + 1);
    assert!(t6.contains(&"drif|different res".to_string()) && t6.contains(&"gff|VIS down".to_string()));
    for name in ["gff", "mgff", "tepgfl", "drif"] {
        assert!(md.contains(&format!("| {name} | host f64 |")), "Table 7 row of {name}");
    }

    let charts = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with("frames_"))
        .count();
    assert_eq!(charts, 10, "5 per-frame charts per illumination");
    let sheet = load_gray_u8(&out.join("contact_sheet.png"), ColorPolicy::Refuse).unwrap();
    // VIS, TIR up, then the eight methods; the column names on top (one 20-px line), the row
    // names ("eclipse", "light": 7 characters of 10 px) on the left.
    assert_eq!((sheet.width, sheet.height), (7 * 10 + 4 + 10 * 256 + 11 * 4, 20 + 4 + 2 * 256 + 3 * 4));
}
