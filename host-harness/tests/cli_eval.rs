//! `fusion eval` prints the library's metrics in full precision; sources on another grid are
//! rescaled first; colour is scored per channel by the VIFB suite.

use fusion_io::{Channels, Gray, save_gray_u8};
use fusion_metrics::noise_metrics;
use fusion_metrics::table::study_metrics;
use fusion_metrics::vifb::{KEYS, vifb_metrics};
use std::path::Path;
use std::process::Command;

fn pattern(w: usize, h: usize, k: usize) -> Gray<u8> {
    Gray { width: w, height: h, data: (0..w * h).map(|i| ((i * k + i / w * 7) % 251) as u8).collect() }
}

fn eval(args: &[&str], files: [&Path; 3]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_fusion")).arg("eval").args(args).args(files).output().unwrap()
}

#[test]
fn csv_output_is_the_library_value_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let (vis, tir, fused) = (pattern(24, 20, 3), pattern(24, 20, 5), pattern(24, 20, 11));
    let p = |n: &str| dir.path().join(n);
    save_gray_u8(&p("v.png"), &vis).unwrap();
    save_gray_u8(&p("t.png"), &tir).unwrap();
    save_gray_u8(&p("f.png"), &fused).unwrap();
    let out = eval(
        &["--format", "csv", "--ref", p("t.png").to_str().unwrap()],
        [&p("v.png"), &p("t.png"), &p("f.png")],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("AG,MI,FMI,FMI_pixel,FMI_gradient,SSIM,RMSE,MSE_S,PSNR_S,SSIM_S"));
    let values: Vec<f64> = lines.next().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    let s = study_metrics(&vis, &tir, &fused);
    let nm = noise_metrics(&fused, &tir);
    let f = s.fusion;
    let want =
        [f.ag, f.mi, f.fmi, s.fmi_pixel, s.fmi_gradient, f.ssim, f.rmse, nm.mse_s, nm.psnr_s, nm.ssim_s];
    assert_eq!(values.len(), want.len());
    for (got, want) in values.iter().zip(want) {
        assert_eq!(got.to_bits(), want.to_bits(), "{got} vs {want}: CSV carries every bit");
    }

    // A half-size TIR source is upscaled to the fused grid; a mismatched reference is refused.
    save_gray_u8(&p("t2.png"), &pattern(12, 10, 5)).unwrap();
    assert!(eval(&[], [&p("v.png"), &p("t2.png"), &p("f.png")]).status.success());
    let bad = eval(&["--ref", p("t2.png").to_str().unwrap()], [&p("v.png"), &p("t.png"), &p("f.png")]);
    assert_eq!(bad.status.code(), Some(1));
}

#[test]
fn vifb_suite_json_scores_colour_per_channel_in_full_precision() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    let (w, h) = (32, 24);
    let rgb =
        |k: [usize; 3]| Channels { width: w, height: h, planes: k.map(|k| pattern(w, h, k).data).to_vec() };
    let (vis, fused) = (rgb([3, 13, 17]), rgb([11, 19, 23]));
    let tir = Channels::from_gray(pattern(w, h, 5));
    let save_rgb = |path: &Path, c: &Channels| {
        let mut img = image::RgbImage::new(w as u32, h as u32);
        for (i, px) in img.pixels_mut().enumerate() {
            px.0 = [c.planes[0][i], c.planes[1][i], c.planes[2][i]];
        }
        img.save(path).unwrap();
    };
    save_rgb(&p("v.png"), &vis);
    save_rgb(&p("f.png"), &fused);
    save_gray_u8(&p("t.png"), &tir.plane(0)).unwrap();
    let out = eval(&["--suite", "vifb", "--format", "json"], [&p("v.png"), &p("t.png"), &p("f.png")]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let want = vifb_metrics(&vis, &tir, &fused).unwrap();
    let keys: Vec<&String> = json.as_object().unwrap().keys().collect();
    assert_eq!(keys.len(), 13);
    for (key, v) in KEYS.iter().zip(want.values()) {
        assert_eq!(json[key].as_f64().unwrap().to_bits(), v.to_bits(), "{key}");
    }

    // `--suite all` nests the suites; the VIFB object is the same.
    let out = eval(&["--suite", "all", "--format", "json"], [&p("v.png"), &p("t.png"), &p("f.png")]);
    let all: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(all["vifb"], json);
    assert!(all["study"]["FMI_gradient"].is_f64());

    // Too small for SSIM's window: one line, exit 1.
    let small = pattern(8, 8, 3);
    save_gray_u8(&p("s.png"), &small).unwrap();
    let bad = eval(&["--suite", "vifb"], [&p("s.png"), &p("s.png"), &p("s.png")]);
    assert_eq!(bad.status.code(), Some(1));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("11x11") && err.lines().count() == 1, "{err}");
}
