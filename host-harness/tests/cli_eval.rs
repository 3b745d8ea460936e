//! `fusion eval` prints the library's metrics; sources on another grid are rescaled first.

use host_harness::io::{Gray, save_gray_u8};
use host_harness::metrics::{fusion_metrics, noise_metrics};
use std::process::Command;

fn pattern(w: usize, h: usize, k: usize) -> Gray<u8> {
    Gray { width: w, height: h, data: (0..w * h).map(|i| ((i * k + i / w * 7) % 251) as u8).collect() }
}

#[test]
fn csv_output_matches_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let (vis, tir, fused) = (pattern(24, 20, 3), pattern(24, 20, 5), pattern(24, 20, 11));
    let p = |n: &str| dir.path().join(n);
    save_gray_u8(&p("v.png"), &vis).unwrap();
    save_gray_u8(&p("t.png"), &tir).unwrap();
    save_gray_u8(&p("f.png"), &fused).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fusion"))
        .args(["eval", "--format", "csv", "--ref", p("t.png").to_str().unwrap()])
        .args([p("v.png"), p("t.png"), p("f.png")])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("AG,MI,FMI,SSIM,RMSE,MSE_S,PSNR_S,SSIM_S"));
    let values: Vec<f64> = lines.next().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    let fm = fusion_metrics(&vis, &tir, &fused);
    let nm = noise_metrics(&fused, &tir);
    let want = [fm.ag, fm.mi, fm.fmi, fm.ssim, fm.rmse, nm.mse_s, nm.psnr_s, nm.ssim_s];
    for (got, want) in values.iter().zip(want) {
        // Printed with 4 decimals (PSNR with 2).
        assert!((got - want).abs() <= 0.005 + 1e-4 * want.abs(), "{got} vs {want}");
    }

    // A half-size TIR source is upscaled to the fused grid; a mismatched reference is refused.
    save_gray_u8(&p("t2.png"), &pattern(12, 10, 5)).unwrap();
    let ok = Command::new(env!("CARGO_BIN_EXE_fusion"))
        .arg("eval")
        .args([p("v.png"), p("t2.png"), p("f.png")])
        .output()
        .unwrap();
    assert!(ok.status.success());
    let bad = Command::new(env!("CARGO_BIN_EXE_fusion"))
        .args(["eval", "--ref", p("t2.png").to_str().unwrap()])
        .args([p("v.png"), p("t.png"), p("f.png")])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(1));
}
