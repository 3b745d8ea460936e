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
    let frames = 44;
    let o = fusion(&[
        "navbench",
        "--out",
        out.to_str().unwrap(),
        "--frames",
        &frames.to_string(),
        "--vis-size",
        "128",
        "--seeds",
        "1,2",
        "--sources",
        "vis,tir,adaptive,adaptive-skip",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The sequences were rendered into OUT/data, one folder per seed.
    for seed in [1, 2] {
        for seq in ["approach", "flyaround", "radial", "radial@10"] {
            assert!(out.join(format!("data/seed-{seed}/{seq}/manifest.json")).is_file(), "{seed} {seq}");
        }
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("navbench.json")).unwrap()).unwrap();
    assert_eq!(json["seeds"], serde_json::json!([1, 2]));
    let sources = json["sources"].as_object().unwrap();
    // The baselines are always there, beside the sources asked for.
    let expected = ["zero-motion", "oracle", "vis", "tir", "adaptive", "adaptive-skip"];
    for s in expected {
        let phases = sources.get(s).unwrap_or_else(|| panic!("source {s} missing")).as_object().unwrap();
        // The flyaround crosses the eclipse: all three phases are there, and the whole.
        for p in ["light", "penumbra", "eclipse", "all"] {
            let x = &phases[p];
            for key in [
                "cnr",
                "target_features",
                "inlier_ratio",
                "rot_err_deg_median",
                "lost_frac",
                "availability",
                "availability_rel",
                "att_rms_deg",
                "pos_rms_pct",
                "rel_pos_rms_pct",
                "nees",
                "pairwise_rot_err_deg_median",
            ] {
                assert!(x.get(key).is_some(), "{s} {p} lacks {key}");
            }
            // Over two seeds a figure is its mean and spread.
            let lost = &x["lost_frac"];
            let (mean, sd) = (lost["mean"].as_f64().unwrap(), lost["sd"].as_f64().unwrap());
            assert!((0.0..=1.0).contains(&mean) && sd >= 0.0, "{s} {p}: {lost}");
        }
    }
    assert_eq!(sources.len(), expected.len());
    assert!(json["by_sequence"]["flyaround"]["oracle"]["all"]["availability"]["mean"].as_f64().is_some());
    let k = &json["skip"]["adaptive"];
    assert!(
        k["target_coverage_min"]["mean"].as_f64().is_some()
            && k["window_frac_mean"]["mean"].as_f64().is_some()
    );
    let csv = std::fs::read_to_string(out.join("per_frame.csv")).unwrap();
    // The default run: two seeds × four sequences (black space, and the Earth at two phases).
    assert_eq!(csv.lines().count(), 1 + 2 * 4 * frames * expected.len());
    // The relative position's columns come last: the earlier columns keep their places.
    assert!(csv.lines().next().unwrap().ends_with(",misregistration_p95_px,rel_pos_err_pct,available_rel"));
    let md = std::fs::read_to_string(out.join("navbench.md")).unwrap();
    assert!(
        md.contains("## flyaround: eclipse")
            && md.contains("## Targets")
            && md.contains("better single camera")
    );
    verdicts_are_outside_the_spread(&md, &json);
    for chart in ["approach_attitude_error", "flyaround_position_error", "flyaround_features"] {
        assert!(
            out.join(format!("{chart}.png")).is_file() || out.join(format!("{chart}.svg")).is_file(),
            "{chart}"
        );
    }
    // One seed: plain numbers, and no verdict at all.
    let one = dir.path().join("one");
    let o = fusion(&[
        "navbench",
        "--out",
        one.to_str().unwrap(),
        "--frames",
        "8",
        "--vis-size",
        "96",
        "--seeds",
        "7",
        "--sources",
        "vis",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(one.join("navbench.json")).unwrap()).unwrap();
    assert!(
        json["sources"]["vis"]["light"]["lost_frac"].as_f64().is_some(),
        "{}",
        json["sources"]["vis"]["light"]
    );
    let md = std::fs::read_to_string(one.join("navbench.md")).unwrap();
    assert!(!md.contains("| better |") && !md.contains("| worse |"));
}

/// Every "better" or "worse" in navbench.md's verdict tables is a difference of means larger
/// than the larger of the two spreads in navbench.json (the rule the table claims).
fn verdicts_are_outside_the_spread(md: &str, json: &serde_json::Value) {
    let mut context: Option<(String, String, String)> = None; // (sequence, phase, camera)
    for line in md.lines() {
        if let Some(rest) = line.strip_prefix("The better single camera in ") {
            // "The better single camera in {seq} {phase} is **{cam}**. …"
            let mut words = rest.split_whitespace();
            let (seq, phase) = (words.next().unwrap().to_string(), words.next().unwrap().to_string());
            let cam = rest.split("**").nth(1).unwrap().to_string();
            context = Some((seq, phase, cam));
            continue;
        }
        if line.starts_with("## ") {
            context = None;
        }
        let Some((seq, phase, cam)) = &context else { continue };
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 6 || cells[1] == "stream" || cells[1].starts_with("---") {
            continue;
        }
        for (col, key) in [(2, "availability"), (3, "att_rms_deg"), (4, "rot_err_deg_median")] {
            if cells[col] != "better" && cells[col] != "worse" {
                continue;
            }
            let get = |src: &str| &json["by_sequence"][seq.as_str()][src][phase.as_str()][key];
            let (a, b) = (get(cells[1]), get(cam));
            let d = (a["mean"].as_f64().unwrap() - b["mean"].as_f64().unwrap()).abs();
            let spread = a["sd"].as_f64().unwrap().max(b["sd"].as_f64().unwrap());
            assert!(
                d > spread,
                "{seq} {phase} {}: '{}' on {key} with |Δ| {d} ≤ spread {spread}",
                cells[1],
                cells[col]
            );
        }
    }
}

/// A sequence spec (`NAME[+earth][@DEG]`) renders that sequence into a folder of its name, its
/// rows carry the name, the Earth targets are reported for it, and data rendered as another
/// sequence under that name is refused in one line.
#[test]
fn navbench_runs_a_sequence_spec_with_the_earth_and_a_sun_phase() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nb");
    let run = |specs: &str| {
        fusion(&[
            "--quiet",
            "navbench",
            "--out",
            out.to_str().unwrap(),
            "--frames",
            "4",
            "--vis-size",
            "96",
            "--seeds",
            "1",
            "--sources",
            "vis,tir,adaptive,adaptive-skip",
            "--sequences",
            specs,
        ])
    };
    let o = run("approach+earth@40,radial@10");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value = serde_json::from_slice(
        &std::fs::read(out.join("data/seed-1/approach+earth@40/manifest.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(m["config"]["name"], "approach");
    assert_eq!(m["config"]["sun_phase_deg"], 40.0);
    assert!(m["config"]["earth"].is_object(), "{}", m["config"]);
    // The Earth is drawn: its mask is not empty on the first frame.
    let mask = image::open(out.join("data/seed-1/approach+earth@40/vis_earth_mask/frame_000.png"))
        .unwrap()
        .to_luma8();
    assert!(mask.pixels().any(|p| p[0] > 0));
    let csv = std::fs::read_to_string(out.join("per_frame.csv")).unwrap();
    let seqs: std::collections::BTreeSet<&str> =
        csv.lines().skip(1).map(|l| l.split(',').next().unwrap()).collect();
    assert_eq!(seqs, ["approach+earth@40", "radial@10"].into_iter().collect());
    let md = std::fs::read_to_string(out.join("navbench.md")).unwrap();
    assert!(md.contains("## Targets with the Earth behind the target"));
    assert!(md.contains("| radial@10 | adaptive |"), "{md}");
    assert!(out.join("approach+earth@40_attitude_error.png").is_file());
    // The folder `radial@10` holds radial at 10°; asked as another sequence, it is refused.
    std::fs::rename(out.join("data/seed-1/radial@10"), out.join("data/seed-1/radial@20")).unwrap();
    let o = run("radial@20");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && err.contains("rendered as another sequence")
            && err.trim().lines().count() == 1,
        "{err}"
    );
    // A spec that cannot be is refused by the argument parser, naming why.
    let o = run("radial+earth");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("drop '+earth'"), "{err}");
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

/// Issue 44, class 5: damaged sequence data is refused in one line naming the file (exit 1),
/// never a panic, an abort or silently wrong figures — a mask or a frame of the wrong size,
/// camera sizes of 0 or 100 000 in the manifest, a manifest with one frame; and sizes the run
/// could not hold are refused before anything is rendered.
#[test]
fn navbench_refuses_damaged_data_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let clean = dir.path().join("clean");
    for seq in ["approach", "flyaround"] {
        let o = fusion(&[
            "--quiet",
            "render",
            "--sequence",
            seq,
            "--frames",
            "3",
            "--vis-size",
            "64",
            "--tir-sizes",
            "32",
            "--samples",
            "1",
            "--out",
            clean.join("seed-1").join(seq).to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let copy = |name: &str| {
        let to = dir.path().join(name);
        for seq in ["approach", "flyaround"] {
            let (src, dst) = (clean.join("seed-1").join(seq), to.join("seed-1").join(seq));
            for sub in ["", "vis", "tir", "vis_clean", "tir_clean", "vis_mask", "tir_mask"] {
                std::fs::create_dir_all(dst.join(sub)).unwrap();
                for e in std::fs::read_dir(src.join(sub)).unwrap() {
                    let e = e.unwrap();
                    if e.file_type().unwrap().is_file() {
                        std::fs::copy(e.path(), dst.join(sub).join(e.file_name())).unwrap();
                    }
                }
            }
        }
        to
    };
    let approach = |data: &std::path::Path| data.join("seed-1").join("approach");
    let edit_manifest = |data: &std::path::Path, edit: &dyn Fn(&mut serde_json::Value)| {
        let path = approach(data).join("manifest.json");
        let mut m: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        edit(&mut m);
        std::fs::write(&path, serde_json::to_vec(&m).unwrap()).unwrap();
    };
    let tiny = image::GrayImage::new(3, 3);
    let mut cases: Vec<(std::path::PathBuf, &str)> = Vec::new();
    let d = copy("mask");
    tiny.save(approach(&d).join("vis_mask/frame_001.png")).unwrap();
    cases.push((d, "frame_001.png: 3×3"));
    let d = copy("frame");
    image::GrayImage::new(48, 48).save(approach(&d).join("vis/frame_002.png")).unwrap();
    cases.push((d, "frame_002.png: 48×48"));
    for size in [0, 100_000] {
        let d = copy(&format!("size{size}"));
        edit_manifest(&d, &|m| m["vis_camera"]["size"] = size.into());
        cases.push((d, "vis_camera.size"));
    }
    // Values no renderer writes: judged silently before (exit 0, figures of nothing).
    let impossible: [(&str, &str, serde_json::Value, &str); 5] = [
        ("focal", "/vis_camera/focal_px", 0.0.into(), "vis_camera.focal_px 0"),
        ("quat", "/frames/1/quaternion_wxyz/0", 3.0.into(), "frame 1: quaternion_wxyz"),
        ("time", "/frames/2/time_s", 0.5.into(), "frame 2: time_s 0.5 is not after"),
        ("sun", "/frames/0/sun_fraction", 2.0.into(), "frame 0: sun_fraction 2"),
        ("escape", "/frames/0/files/vis", "../../../etc/passwd".into(), "not a path inside"),
    ];
    for (name, pointer, value, needle) in impossible {
        let d = copy(name);
        edit_manifest(&d, &|m| *m.pointer_mut(pointer).unwrap() = value.clone());
        cases.push((d, needle));
    }
    let d = copy("one");
    edit_manifest(&d, &|m| {
        let first = m["frames"][0].clone();
        m["frames"] = serde_json::Value::Array(vec![first]);
    });
    cases.push((d, "at least 2 frames"));
    for (data, needle) in &cases {
        let out = data.join("nb");
        let o = fusion(&[
            "navbench",
            "--data",
            data.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--seeds",
            "1",
            "--vis-size",
            "64",
            "--sources",
            "vis",
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{needle}: {err}");
        let last = err.trim().lines().last().unwrap_or_default();
        assert!(last.starts_with("fusion: error: ") && last.contains(needle), "{needle}: {err}");
        assert!(!err.contains("panicked") && !out.join("navbench.md").exists(), "{needle}: {err}");
    }
    // Class 11: an output that is a file is named.
    let afile = dir.path().join("afile");
    std::fs::write(&afile, b"x").unwrap();
    let o = fusion(&["navbench", "--out", afile.to_str().unwrap(), "--frames", "2", "--vis-size", "64"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.code() == Some(1) && err.contains("afile"), "{err}");
    // A size the run cannot hold, refused before anything is rendered.
    let out = dir.path().join("big");
    let o = fusion(&["navbench", "--out", out.to_str().unwrap(), "--vis-size", "65536"]);
    assert_eq!(o.status.code(), Some(1));
    let o =
        fusion(&["--max-memory", "100M", "navbench", "--out", out.to_str().unwrap(), "--vis-size", "2048"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.code() == Some(1) && err.contains("memory limit"), "{err}");
    assert!(!out.join("data").exists(), "nothing rendered");
    // Class 6: the render's estimate counts the thermal sizes too.
    let seq = dir.path().join("rs");
    let o = fusion(&[
        "--max-memory",
        "20M",
        "render",
        "--sequence",
        "approach",
        "--frames",
        "1",
        "--vis-size",
        "16",
        "--tir-sizes",
        "2048",
        "--out",
        seq.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.code() == Some(1) && err.contains("--tir-sizes 2048") && err.contains("memory limit"),
        "{err}"
    );
    assert!(!seq.exists(), "nothing rendered");
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
