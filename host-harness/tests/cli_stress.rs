//! `fusion stress --quick` end to end: every case, geometry and method runs, the core never
//! panics, is deterministic and stays within the stated error bounds (exit 0), and the table
//! file lists every case.

use std::process::Command;

#[test]
fn quick_stress_passes_and_writes_the_table() {
    let dir = tempfile::tempdir().unwrap();
    let table = dir.path().join("stress.md");
    let out = Command::new(env!("CARGO_BIN_EXE_fusion"))
        .args(["stress", "--quick", "--out", table.to_str().unwrap()])
        .output()
        .expect("run fusion stress");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "fusion stress --quick failed:\n{stdout}\n{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stdout.contains("0 failures"), "{stdout}");
    let doc = std::fs::read_to_string(&table).unwrap();
    for case in fusion_engine::stress::cases() {
        assert!(doc.contains(&format!("| {} |", case.name)), "case {} missing from the table", case.name);
    }
    // 13 cases × 4 geometries × 6 methods, every one deterministic.
    let runs = doc.lines().filter(|l| l.ends_with("| ok |")).count();
    assert_eq!(runs, fusion_engine::stress::cases().len() * 4 * 6, "{doc}");
}
