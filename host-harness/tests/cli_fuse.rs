//! `fusion fuse` end to end: every method and engine, `--raw`, rescale policies, bad input.

use fusion_io::npy::read_npy_2d;
use fusion_io::{ColorPolicy, Gray, load_gray_u8, save_gray_u8};
use std::path::Path;
use std::process::{Command, Output};

fn fusion(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fusion")).args(args).output().expect("run fusion")
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// A deterministic textured frame with a bright blob.
fn frame(w: usize, h: usize, seed: usize) -> Gray<u8> {
    let data = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let blob = if (x as f64 - 0.4 * w as f64).powi(2) + (y as f64 - 0.5 * h as f64).powi(2)
                < (w * h / 20) as f64
            {
                150
            } else {
                20
            };
            (blob + (x * 7 + y * 13 + seed) % 40 + (i * seed) % 9) as u8
        })
        .collect();
    Gray { width: w, height: h, data }
}

#[test]
fn every_method_and_engine_writes_a_grid_sized_image_and_raw_values() {
    let dir = tempfile::tempdir().unwrap();
    let (vis, tir) = (dir.path().join("vis.png"), dir.path().join("tir.png"));
    save_gray_u8(&vis, &frame(64, 48, 1)).unwrap();
    save_gray_u8(&tir, &frame(32, 24, 2)).unwrap();
    for method in ["adf", "tsifsd", "ifevip"] {
        let mut images = Vec::new();
        for engine in ["core", "reference"] {
            for (rescale, size) in [("tir-up", (64, 48)), ("vis-down", (32, 24))] {
                let out = dir.path().join(format!("{method}-{engine}-{rescale}.png"));
                let raw = dir.path().join(format!("{method}-{engine}-{rescale}.npy"));
                let o = fusion(&[
                    "fuse",
                    "--method",
                    method,
                    "--engine",
                    engine,
                    "--rescale",
                    rescale,
                    "--raw",
                    p(&raw),
                    p(&vis),
                    p(&tir),
                    p(&out),
                ]);
                assert!(
                    o.status.success(),
                    "{method} {engine} {rescale}: {}",
                    String::from_utf8_lossy(&o.stderr)
                );
                let img = load_gray_u8(&out, ColorPolicy::Refuse).unwrap();
                assert_eq!((img.width, img.height), size);
                let raw = read_npy_2d(&raw).unwrap();
                assert_eq!((raw.width, raw.height), size);
                // The PNG is the MATLAB uint8 cast of the raw value (f32-rounded in the file).
                for (&v, &r) in img.data.iter().zip(&raw.data) {
                    assert!(
                        (f64::from(v) - r.clamp(0.0, 255.0)).abs() <= 0.5 + 1e-3,
                        "{method} {engine}: {v} vs {r}"
                    );
                }
                if rescale == "tir-up" {
                    images.push(img);
                }
            }
        }
        // core and reference agree within two grey levels
        let max = images[0].data.iter().zip(&images[1].data).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
        assert!(max <= 2, "{method}: core vs reference max {max}");
    }
}

#[test]
fn bad_input_is_one_line_and_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let (vis, tir) = (dir.path().join("vis.png"), dir.path().join("tir.png"));
    save_gray_u8(&vis, &frame(64, 48, 1)).unwrap();
    save_gray_u8(&tir, &frame(32, 24, 2)).unwrap();
    let out = dir.path().join("out.png");
    let missing = dir.path().join("missing.png");
    let cases: [(Vec<&str>, &str); 3] = [
        (vec!["fuse", "--rescale", "none", p(&vis), p(&tir), p(&out)], "size"),
        (vec!["fuse", p(&vis), p(&missing), p(&out)], "thermal"),
        (vec!["fuse", "--method", "nope", p(&vis), p(&tir), p(&out)], "nope"),
    ];
    for (args, needle) in cases {
        let o = fusion(&args);
        assert!(!o.status.success(), "{args:?} must fail");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{err}");
        assert!(err.to_lowercase().contains(needle), "{args:?}: {err}");
        assert!(!out.exists(), "no output left behind");
    }
}

/// `--window X0,Y0,X1,Y1`: the caller's skip window. TSIFSD is bit-identical to the whole-frame
/// run inside it, ADF gives the fusion of the crop there (the crop fused on its own, the same
/// bits), the background value fills the rest; a malformed or empty box, or `--window` beside
/// `--skip`, is refused in one line.
#[test]
fn a_caller_window_fuses_that_box_only() {
    let dir = tempfile::tempdir().unwrap();
    let (vis, tir) = (dir.path().join("vis.png"), dir.path().join("tir.png"));
    let (v, t) = (frame(64, 48, 1), frame(64, 48, 2));
    save_gray_u8(&vis, &v).unwrap();
    save_gray_u8(&tir, &t).unwrap();
    let (x0, y0, x1, y1) = (12usize, 10usize, 40usize, 30usize);
    let run = |method: &str, extra: &[&str], out: &Path| {
        let mut args = vec!["fuse", "--method", method, "--rescale", "none"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&[p(&vis), p(&tir), p(out)]);
        let o = fusion(&args);
        assert!(o.status.success(), "{method} {extra:?}: {}", String::from_utf8_lossy(&o.stderr));
        (load_gray_u8(out, ColorPolicy::Refuse).unwrap(), String::from_utf8_lossy(&o.stdout).to_string())
    };
    let inside = |x: usize, y: usize| x >= x0 && x < x1 && y >= y0 && y < y1;
    // TSIFSD: exact inside the box.
    let (whole, _) = run("tsifsd", &[], &dir.path().join("t_whole.png"));
    let (win, text) = run("tsifsd", &["--window", "12,10,40,30"], &dir.path().join("t_win.png"));
    assert!(text.contains("bit-identical to --skip none"), "{text}");
    for y in 0..48 {
        for x in 0..64 {
            if inside(x, y) {
                assert_eq!(win.at(x, y), whole.at(x, y), "tsifsd ({x}, {y})");
            }
        }
    }
    // ADF: the crop grown by its halo (10 iterations), fused as a pair of its own.
    let h = 10;
    let (cx0, cy0, cx1, cy1) = (x0 - h, y0 - h, x1 + h, y1 + h);
    let crop = |g: &Gray<u8>| Gray {
        width: cx1 - cx0,
        height: cy1 - cy0,
        data: (cy0..cy1).flat_map(|y| (cx0..cx1).map(move |x| (x, y))).map(|(x, y)| g.at(x, y)).collect(),
    };
    let (cv, ct) = (dir.path().join("cv.png"), dir.path().join("ct.png"));
    save_gray_u8(&cv, &crop(&v)).unwrap();
    save_gray_u8(&ct, &crop(&t)).unwrap();
    let o = fusion(&[
        "fuse",
        "--method",
        "adf",
        "--rescale",
        "none",
        p(&cv),
        p(&ct),
        p(&dir.path().join("c.png")),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cropped = load_gray_u8(&dir.path().join("c.png"), ColorPolicy::Refuse).unwrap();
    let (win, text) = run("adf", &["--window", "12,10,40,30"], &dir.path().join("a_win.png"));
    assert!(text.contains("crop semantics"), "{text}");
    let bg = win.at(0, 0);
    for y in 0..48 {
        for x in 0..64 {
            let want = if inside(x, y) { cropped.at(x - cx0, y - cy0) } else { bg };
            assert_eq!(win.at(x, y), want, "adf ({x}, {y})");
        }
    }
    // Refused: not four numbers, an empty box, beside --skip.
    for bad in [
        vec!["--window", "1,2,3"],
        vec!["--window", "5,5,5,9"],
        vec!["--window", "1,2,30,40", "--skip", "roi"],
    ] {
        let mut args = vec!["fuse"];
        args.extend_from_slice(&bad);
        args.extend_from_slice(&[p(&vis), p(&tir), "/nonexistent/out.png"]);
        let o = fusion(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains("--window"), "{bad:?}: {err}");
    }
}

/// `--sequence-mode` on two folders: the pairs in natural name order (frame_9 before
/// frame_10), each ADF frame with the previous frame's weights — the library's sequence
/// fuser's bytes over the same frames in that order, whole frame and in strips; the first frame
/// is the single-pair fusion; a single pair and `--jobs` are refused.
#[test]
fn sequence_mode_carries_the_weights_in_name_order() {
    let dir = tempfile::tempdir().unwrap();
    let (vd, td) = (dir.path().join("vis"), dir.path().join("tir"));
    std::fs::create_dir_all(&vd).unwrap();
    std::fs::create_dir_all(&td).unwrap();
    let names = ["frame_8", "frame_9", "frame_10", "frame_11", "frame_100"];
    let frames: Vec<_> =
        (0..names.len()).map(|k| (frame(64, 48, 3 + 5 * k), frame(32, 24, 40 + 11 * k))).collect();
    for (name, (v, t)) in names.iter().zip(&frames) {
        save_gray_u8(&vd.join(format!("{name}.png")), v).unwrap();
        save_gray_u8(&td.join(format!("{name}.png")), t).unwrap();
    }
    let config = fusion_nostd::pipeline::FuseConfig {
        method: fusion_nostd::pipeline::Method::Adf(fusion_nostd::AdfParams::default()),
        ..Default::default()
    };
    for (strips, form) in [
        (None, fusion_engine::sequence::Form::WholeFrame),
        (Some("17"), fusion_engine::sequence::Form::Strips { max_rows: 17 }),
    ] {
        let out = dir.path().join(format!("out-{}", strips.unwrap_or("whole")));
        let mut args = vec!["fuse", "--method", "adf", "--sequence-mode"];
        if let Some(rows) = strips {
            args.extend(["--strips", rows]);
        }
        args.extend([p(&vd), p(&td), p(&out)]);
        let o = fusion(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let log = String::from_utf8_lossy(&o.stderr);
        assert!(log.contains("frame_9: ok (carried weights"), "{log}");
        let mut seq = fusion_engine::sequence::SequenceFuser::new(
            config,
            fusion_nostd::sequence::SequenceParams::default(),
            form,
        );
        for (name, (v, t)) in names.iter().zip(&frames) {
            let want = seq.fuse(v, t).unwrap();
            let got = load_gray_u8(&out.join(format!("{name}.png")), ColorPolicy::Refuse).unwrap();
            assert_eq!(got.data, want.image.data, "{name} ({:?})", want.step.pass);
        }
    }
    // The first frame is the single pair fused alone; the others are not.
    let single = dir.path().join("single.png");
    let first = |n: &str| (vd.join(format!("{n}.png")), td.join(format!("{n}.png")));
    for (name, same) in [("frame_8", true), ("frame_9", false)] {
        let (v, t) = first(name);
        let o = fusion(&["fuse", "--method", "adf", p(&v), p(&t), p(&single)]);
        assert!(o.status.success());
        let alone = load_gray_u8(&single, ColorPolicy::Refuse).unwrap();
        let seq =
            load_gray_u8(&dir.path().join(format!("out-whole/{name}.png")), ColorPolicy::Refuse).unwrap();
        assert_eq!(alone.data == seq.data, same, "{name}");
    }
    let (v, t) = first("frame_8");
    for args in [
        vec!["fuse", "--method", "adf", "--sequence-mode", p(&v), p(&t), p(&single)],
        vec!["fuse", "--method", "adf", "--sequence-mode", "--jobs", "2", p(&vd), p(&td), "x"],
    ] {
        let o = fusion(&args);
        assert_eq!(o.status.code(), Some(1));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.trim().lines().count() == 1 && err.contains("--sequence-mode"), "{err}");
    }
}
