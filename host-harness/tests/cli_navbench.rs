//! `fusion navbench` end to end on small sequences: the files it promises, `navbench.json` in
//! the shape the issue fixes, and one-line refusals of bad arguments.

use std::process::Command;

fn fusion(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_fusion")).args(args).output().unwrap()
}

#[test]
fn navbench_writes_the_summary_shape_csv_and_charts() {
    // A source the benchmark does not know: one line naming it, nothing written.
    let dir0 = tempfile::tempdir().unwrap();
    let o = fusion(&["navbench", "--out", dir0.path().join("x").to_str().unwrap(), "--sources", "vis,nope"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("unknown source 'nope'") && err.trim().lines().count() == 1,
        "{err}"
    );
    assert!(!dir0.path().join("x").exists());
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nb");
    let o = fusion(&["navbench", "--out", out.to_str().unwrap(), "--frames", "44", "--vis-size", "128"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The sequences were rendered into OUT/data.
    for seq in ["approach", "flyaround"] {
        assert!(out.join("data").join(seq).join("manifest.json").is_file(), "{seq}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("navbench.json")).unwrap()).unwrap();
    let sources = json["sources"].as_object().unwrap();
    let mut expected =
        vec!["vis".to_string(), "tir".to_string(), "adaptive".to_string(), "adaptive-skip".to_string()];
    for m in ["adf", "tsifsd", "ifevip"] {
        for v in ["classic", "flight"] {
            expected.push(format!("{m}-{v}"));
            expected.push(format!("{m}-{v}-skip"));
        }
    }
    for s in &expected {
        let phases = sources.get(s).unwrap_or_else(|| panic!("source {s} missing")).as_object().unwrap();
        // The flyaround crosses the eclipse: all three phases are there.
        for p in ["light", "penumbra", "eclipse"] {
            let x = &phases[p];
            for key in ["cnr", "target_features", "inlier_ratio", "rot_err_deg_median", "lost_frac"] {
                assert!(x.get(key).is_some(), "{s} {p} lacks {key}");
            }
            let lost = x["lost_frac"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&lost));
        }
    }
    assert_eq!(sources.len(), expected.len());
    for m in ["adf-flight", "tsifsd-classic", "ifevip-flight"] {
        let k = &json["skip"][m];
        assert!(
            k["target_coverage_min"].as_f64().is_some() && k["window_frac_mean"].as_f64().is_some(),
            "{m}"
        );
    }
    let csv = std::fs::read_to_string(out.join("per_frame.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * 44 * expected.len());
    let md = std::fs::read_to_string(out.join("navbench.md")).unwrap();
    assert!(md.contains("## eclipse") && md.contains("better single camera"));
    for chart in ["approach_rotation_error", "flyaround_features"] {
        assert!(
            out.join(format!("{chart}.png")).is_file() || out.join(format!("{chart}.svg")).is_file(),
            "{chart}"
        );
    }
}

#[test]
fn navbench_refuses_bad_arguments_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nb");
    for args in [vec!["--frames", "1"], vec!["--vis-size", "63"], vec!["--vis-size", "100", "--frames", "0"]]
    {
        let mut all = vec!["navbench", "--out", out.to_str().unwrap()];
        all.extend(args.iter().copied());
        let o = fusion(&all);
        assert_eq!(o.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
    // A sequence is always the procedural target with its detail.
    let o = fusion(&["render", "--sequence", "approach", "--flat", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(String::from_utf8_lossy(&o.stderr).trim().lines().count(), 1);
    assert!(!out.exists(), "nothing written");
}

#[test]
fn render_sequence_writes_frames_masks_and_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("seq");
    let o = fusion(&[
        "render",
        "--sequence",
        "flyaround",
        "--frames",
        "3",
        "--vis-size",
        "64",
        "--tir-sizes",
        "32",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(said.contains("flyaround") && said.contains("3 frames"), "{said}");
    for sub in ["vis", "tir", "vis_clean", "tir_clean", "vis_mask", "tir_mask"] {
        for i in 0..3 {
            assert!(out.join(format!("{sub}/frame_{i:03}.png")).is_file(), "{sub} {i}");
        }
    }
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["frames"].as_array().unwrap().len(), 3);
    assert_eq!(m["vis_camera"]["size"], 64);
    assert_eq!(m["tir_camera"]["size"], 32);
    assert!(m["frames"][0]["quaternion_wxyz"].as_array().unwrap().len() == 4);
}
