//! `fusion fuse` on raw thermal counts: `--nuc`, `--bad-pixels`, `--shutter` and
//! `--column-filter` give the bytes of the core's front end run by hand, then the AGC and the
//! fusion; the folder form carries the same chain; bad calibration files are refused with
//! nothing written.

use fusion_io::thermal::{BadPixels, NucTables};
use fusion_io::{ColorPolicy, Gray, load_gray_u8, save_gray_u8, save_gray_u16};
use fusion_nostd::thermal::{
    BadPixelMap, ColumnFilter, ColumnParams, Correction, correct_frame, shutter_update,
};
use render_host::focal_plane::{FocalPlane, FocalPlaneParams};
use render_host::image::Image;
use std::path::Path;
use std::process::{Command, Output};

fn fusion(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fusion")).args(args).output().expect("run fusion")
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

const W: usize = 48;
const H: usize = 40;

/// A camera (the renderer's focal plane) looking at a warm block, its raw counts at `t`, a
/// shutter frame, and a matching visible frame.
struct Rig {
    fp: FocalPlane,
    raw: Vec<Gray<u16>>,
    shutter: Gray<u16>,
    vis: Gray<u8>,
}

fn rig() -> Rig {
    let fp = FocalPlane::new(FocalPlaneParams::default(), W, H, 250.0);
    let scene = |k: usize| Image {
        width: W as u32,
        height: H as u32,
        data: (0..W * H)
            .map(|i| {
                let (x, y) = (i % W, i / W);
                if x > 10 + k && x < 30 + k && y > 8 && y < 30 { 0.6 } else { 0.05 + 0.001 * (x + y) as f32 }
            })
            .collect(),
    };
    let mut rng = render_host::noise::rng_for(3, 4);
    let raw = (0..2)
        .map(|k| Gray { width: W, height: H, data: fp.raw(&scene(k), 60.0 + k as f64, &mut rng) })
        .collect();
    let shutter = Gray { width: W, height: H, data: fp.shutter(150.0, 59.0, &mut rng) };
    let vis = Gray { width: W, height: H, data: (0..W * H).map(|i| ((i * 37) % 200) as u8 + 20).collect() };
    Rig { fp, raw, shutter, vis }
}

/// The front end by hand with the core: shutter, tables, map, column filter, then the AGC.
fn by_hand(r: &Rig, raw: &Gray<u16>, threshold: u16) -> Gray<u8> {
    let mut offset = r.fp.nuc_offset.clone();
    let bits = BadPixels::from_mask(W, H, &r.fp.bad_mask()).bits;
    let map = BadPixelMap::new(W, H, &bits).unwrap();
    shutter_update(&r.fp.nuc_gain, &mut offset, Some(&map), r.shutter.view().unwrap()).unwrap();
    let stages = Correction {
        nuc: Some(fusion_nostd::thermal::NucTables::new(W, H, &r.fp.nuc_gain, &offset).unwrap()),
        bad: Some(map),
    };
    let mut out = Gray::<u16>::new(W, H);
    let mut filter = ColumnFilter::new();
    let p = ColumnParams { threshold, radius: 16, smoothing: 0 };
    correct_frame(&stages, Some((&mut filter, &p)), raw.view().unwrap(), out.view_mut().unwrap()).unwrap();
    let mut tir = Gray::<u8>::new(W, H);
    fusion_nostd::agc_frame(
        &mut fusion_nostd::Agc::new(),
        out.view().unwrap(),
        tir.view_mut().unwrap(),
        &fusion_nostd::AgcParams::linear(),
    )
    .unwrap();
    tir
}

fn write_rig(r: &Rig, dir: &Path) {
    NucTables { width: W, height: H, gain: r.fp.nuc_gain.clone(), offset: r.fp.nuc_offset.clone() }
        .write(&dir.join("tir.nuc"))
        .unwrap();
    BadPixels::from_mask(W, H, &r.fp.bad_mask()).write(&dir.join("bad.png")).unwrap();
    save_gray_u16(&dir.join("shutter.png"), &r.shutter).unwrap();
    std::fs::create_dir_all(dir.join("vis")).unwrap();
    std::fs::create_dir_all(dir.join("raw")).unwrap();
    for (k, raw) in r.raw.iter().enumerate() {
        save_gray_u8(&dir.join(format!("vis/f{k}.png")), &r.vis).unwrap();
        save_gray_u16(&dir.join(format!("raw/f{k}.png")), raw).unwrap();
    }
}

#[test]
fn raw_counts_through_the_front_end_match_the_core_by_hand() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = rig();
    write_rig(&r, d);
    let (nuc, bad, sh) = (d.join("tir.nuc"), d.join("bad.png"), d.join("shutter.png"));
    let front = ["--nuc", p(&nuc), "--bad-pixels", p(&bad)];
    let shutter = ["--shutter", p(&sh)];
    for k in 0..2 {
        let out = d.join(format!("cli{k}.png"));
        let mut args = vec!["fuse", "--method", "tsifsd", "--rescale", "none"];
        args.extend_from_slice(&front);
        args.extend_from_slice(&shutter);
        args.extend_from_slice(&["--column-filter", "900"]);
        let (vis, raw) = (d.join(format!("vis/f{k}.png")), d.join(format!("raw/f{k}.png")));
        args.extend_from_slice(&[p(&vis), p(&raw), p(&out)]);
        let o = fusion(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        // The same fusion of the thermal frame corrected by hand.
        let tir8 = d.join(format!("tir8_{k}.png"));
        save_gray_u8(&tir8, &by_hand(&r, &r.raw[k], 900)).unwrap();
        let expect = d.join(format!("hand{k}.png"));
        let o = fusion(&["fuse", "--method", "tsifsd", "--rescale", "none", p(&vis), p(&tir8), p(&expect)]);
        assert!(o.status.success());
        assert_eq!(
            load_gray_u8(&out, ColorPolicy::Refuse).unwrap(),
            load_gray_u8(&expect, ColorPolicy::Refuse).unwrap(),
            "frame {k}"
        );
    }
    // The correction matters: without it the fused frame differs.
    let plain = d.join("plain.png");
    let o = fusion(&[
        "fuse",
        "--method",
        "tsifsd",
        "--rescale",
        "none",
        p(&d.join("vis/f0.png")),
        p(&d.join("raw/f0.png")),
        p(&plain),
    ]);
    assert!(o.status.success());
    assert_ne!(
        load_gray_u8(&plain, ColorPolicy::Refuse).unwrap(),
        load_gray_u8(&d.join("cli0.png"), ColorPolicy::Refuse).unwrap()
    );
    // The folder form carries the same chain: each output equals its single-pair run.
    let outs = d.join("outs");
    let mut args = vec!["fuse", "--method", "tsifsd", "--rescale", "none"];
    args.extend_from_slice(&front);
    args.extend_from_slice(&shutter);
    args.extend_from_slice(&["--column-filter", "900"]);
    let (vd, rd) = (d.join("vis"), d.join("raw"));
    args.extend_from_slice(&[p(&vd), p(&rd), p(&outs)]);
    let o = fusion(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for k in 0..2 {
        assert_eq!(
            load_gray_u8(&outs.join(format!("f{k}.png")), ColorPolicy::Refuse).unwrap(),
            load_gray_u8(&d.join(format!("cli{k}.png")), ColorPolicy::Refuse).unwrap(),
            "folder frame {k}"
        );
    }
    // A sequence's shutter frames (named like the frame they were captured at): frame f0 is
    // corrected with the factory tables, f1 after the shutter re-levelled them — as the single
    // pairs without and with --shutter.
    let shutters = d.join("shutters");
    std::fs::create_dir_all(&shutters).unwrap();
    std::fs::copy(&sh, shutters.join("f1.png")).unwrap();
    let seq_out = d.join("seq_out");
    let (vd, rd) = (d.join("vis"), d.join("raw"));
    let o = fusion(&[
        "fuse",
        "--method",
        "tsifsd",
        "--rescale",
        "none",
        "--nuc",
        p(&nuc),
        "--bad-pixels",
        p(&bad),
        "--shutter-dir",
        p(&shutters),
        p(&vd),
        p(&rd),
        p(&seq_out),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (k, with_shutter) in [(0, false), (1, true)] {
        let single = d.join(format!("single{k}.png"));
        let mut args = vec![
            "fuse",
            "--method",
            "tsifsd",
            "--rescale",
            "none",
            "--nuc",
            p(&nuc),
            "--bad-pixels",
            p(&bad),
        ];
        if with_shutter {
            args.extend_from_slice(&["--shutter", p(&sh)]);
        }
        let (v, r) = (d.join(format!("vis/f{k}.png")), d.join(format!("raw/f{k}.png")));
        args.extend_from_slice(&[p(&v), p(&r), p(&single)]);
        assert!(fusion(&args).status.success());
        assert_eq!(
            load_gray_u8(&seq_out.join(format!("f{k}.png")), ColorPolicy::Refuse).unwrap(),
            load_gray_u8(&single, ColorPolicy::Refuse).unwrap(),
            "sequence frame {k}"
        );
    }
    // One pair cannot follow a sequence's shutter frames.
    let o = fusion(&[
        "fuse",
        "--nuc",
        p(&nuc),
        "--shutter-dir",
        p(&shutters),
        p(&d.join("vis/f0.png")),
        p(&d.join("raw/f0.png")),
        p(&d.join("x.png")),
    ]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("two folders"));
}

#[test]
fn bad_calibration_files_are_refused_with_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = rig();
    write_rig(&r, d);
    let (vis, raw) = (d.join("vis/f0.png"), d.join("raw/f0.png"));
    let out = d.join("out.png");
    let nuc = d.join("tir.nuc");
    // A truncated table file, a table of another array, a map of another size, an 8-bit
    // thermal frame, a map that has lost three whole rows.
    let bytes = std::fs::read(&nuc).unwrap();
    std::fs::write(d.join("short.nuc"), &bytes[..bytes.len() - 2]).unwrap();
    NucTables { width: W + 1, height: H, gain: vec![16_384; (W + 1) * H], offset: vec![0; (W + 1) * H] }
        .write(&d.join("wide.nuc"))
        .unwrap();
    BadPixels::from_mask(W, H + 2, &vec![false; W * (H + 2)]).write(&d.join("tall.png")).unwrap();
    let mut rows = vec![false; W * H];
    rows[5 * W..8 * W].iter_mut().for_each(|b| *b = true);
    BadPixels::from_mask(W, H, &rows).write(&d.join("dead_rows.png")).unwrap();
    let tir8 = d.join("tir8.png");
    save_gray_u8(&tir8, &Gray { width: W, height: H, data: vec![9; W * H] }).unwrap();
    let (short, wide, tall, dead) =
        (d.join("short.nuc"), d.join("wide.nuc"), d.join("tall.png"), d.join("dead_rows.png"));
    let cases: [(&[&str], &str, &Path); 5] = [
        (&["--nuc", p(&short)], "needs", &raw),
        (&["--nuc", p(&wide)], "49x40", &raw),
        (&["--bad-pixels", p(&tall)], "48x42", &raw),
        (&["--nuc", p(&nuc)], "8-bit", &tir8),
        (&["--bad-pixels", p(&dead)], "no valid neighbour", &raw),
    ];
    for (extra, says, tir) in cases {
        let mut args = vec!["fuse"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&[p(&vis), p(tir), p(&out)]);
        let o = fusion(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{extra:?}");
        assert!(err.contains(says), "{extra:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{extra:?}: one line: {err}");
        assert!(!out.exists(), "{extra:?} wrote an output");
    }
}
