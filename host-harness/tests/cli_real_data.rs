//! Real camera data through `fusion fuse` and `fusion eval`: VIFB's JPEG pairs in colour, 16-bit
//! thermal counts through the core AGC (PNG and TIFF), outputs by extension, whole folders with
//! a summary.

use fusion_engine::color::rgb_to_ycbcr;
use fusion_io::{
    Channels, ColorPolicy, Gray, Picture, load_gray_u8, load_picture, save_gray_u8, save_gray_u16,
};
use fusion_nostd::{Agc, AgcParams, agc_frame};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fusion(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fusion")).args(args).output().expect("run fusion")
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn jpeg(band: &str, name: &str) -> PathBuf {
    fusion_io::testdata::file(&format!("vifb_jpeg/{band}/{name}.jpg"))
}

fn rgb(path: &Path) -> Channels {
    match load_picture(path).unwrap() {
        Picture::Rgb8(c) => c,
        other => panic!("{} is not colour: {other:?}", path.display()),
    }
}

#[test]
fn a_colour_jpeg_pair_fuses_in_colour_with_the_grey_fusion_as_its_luminance() {
    let dir = tempfile::tempdir().unwrap();
    let (vis, tir) = (jpeg("VI", "fight"), jpeg("IR", "fight"));
    for method in ["tsifsd", "adf", "ifevip"] {
        let out = dir.path().join(format!("{method}.png"));
        ok(&fusion(&["fuse", "--method", method, p(&vis), p(&tir), p(&out)]));
        let fused = rgb(&out);
        // The same fusion on the VIS luminance alone (Y of YCbCr, BT.601 full range).
        let [y, cb, cr] = rgb_to_ycbcr(&rgb(&vis));
        let y_path = dir.path().join("y.png");
        save_gray_u8(&y_path, &y).unwrap();
        let grey_out = dir.path().join(format!("{method}-grey.png"));
        ok(&fusion(&["fuse", "--method", method, p(&y_path), p(&tir), p(&grey_out)]));
        let grey = load_gray_u8(&grey_out, ColorPolicy::Refuse).unwrap();
        let [fy, fcb, fcr] = rgb_to_ycbcr(&fused);
        let (mut checked, mut worst_y, mut worst_c) = (0, 0, 0);
        for i in 0..grey.data.len() {
            let clipped = (0..3).any(|k| matches!(fused.planes[k][i], 0 | 255));
            if clipped {
                continue;
            }
            checked += 1;
            worst_y = worst_y.max(fy.data[i].abs_diff(grey.data[i]));
            worst_c = worst_c.max(fcb.data[i].abs_diff(cb.data[i])).max(fcr.data[i].abs_diff(cr.data[i]));
        }
        assert!(checked > grey.data.len() / 2, "{method}: {checked} unclipped pixels");
        assert!(worst_y <= 1, "{method}: luminance off the grey fusion by {worst_y}");
        assert!(worst_c <= 1, "{method}: chroma off the visible frame's by {worst_c}");
        // --color gray gives a grey image.
        let g = dir.path().join(format!("{method}-gray.png"));
        ok(&fusion(&["fuse", "--method", method, "--color", "gray", p(&vis), p(&tir), p(&g)]));
        assert!(matches!(load_picture(&g).unwrap(), Picture::Gray8(_)));
    }
}

#[test]
fn outputs_follow_their_extension_and_anything_else_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (vis, tir) = (jpeg("VI", "manWalking"), jpeg("IR", "manWalking"));
    let (png, tif) = (dir.path().join("a.png"), dir.path().join("a.TIFF"));
    ok(&fusion(&["fuse", p(&vis), p(&tir), p(&png)]));
    ok(&fusion(&["fuse", p(&vis), p(&tir), p(&tif)]));
    assert_eq!(&std::fs::read(&tif).unwrap()[..2], b"II", "a little-endian TIFF");
    assert_eq!(load_picture(&png).unwrap(), load_picture(&tif).unwrap());
    let grey = dir.path().join("grey.png");
    ok(&fusion(&["fuse", "--color", "gray", p(&vis), p(&tir), p(&grey)]));
    for bad in ["a.jpg", "a.bmp", "noext"] {
        let out = dir.path().join(bad);
        let o = fusion(&["fuse", p(&vis), p(&tir), p(&out)]);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(".png, .tif, .tiff or .pgm"), "{err}");
        assert!(!out.exists(), "{bad} written");
        // The same rule for `fusion rescale` (8- and 16-bit).
        let o = fusion(&["rescale", "--width", "20", "--height", "16", p(&grey), p(&out)]);
        assert!(
            !o.status.success() && String::from_utf8_lossy(&o.stderr).contains(".png, .tif, .tiff or .pgm")
        );
        assert!(!out.exists(), "{bad} written by rescale");
    }
    let (small_png, small_tif) = (dir.path().join("s.png"), dir.path().join("s.tif"));
    for out in [&small_png, &small_tif] {
        ok(&fusion(&["rescale", "--width", "20", "--height", "16", p(&grey), p(out)]));
    }
    assert_eq!(&std::fs::read(&small_tif).unwrap()[..2], b"II");
    assert_eq!(load_picture(&small_png).unwrap(), load_picture(&small_tif).unwrap());

    // PGM (the C example's format): grey out, with the header the C example writes; read back
    // as the same pixels; PGM inputs fuse to the PNG inputs' bytes; a colour output is refused.
    let pgm = dir.path().join("grey.pgm");
    ok(&fusion(&["fuse", "--color", "gray", p(&vis), p(&tir), p(&pgm)]));
    let bytes = std::fs::read(&pgm).unwrap();
    let g = load_gray_u8(&grey, ColorPolicy::Refuse).unwrap();
    let header = format!("P5\n{} {} 255\n", g.width, g.height);
    assert_eq!(&bytes[..header.len()], header.as_bytes());
    assert_eq!(&bytes[header.len()..], &g.data[..]);
    let (vis_pgm, tir_pgm) = (dir.path().join("v.pgm"), dir.path().join("t.pgm"));
    ok(&fusion(&["rescale", "--width", "64", "--height", "48", p(&grey), p(&vis_pgm)]));
    ok(&fusion(&["rescale", "--width", "32", "--height", "24", p(&grey), p(&tir_pgm)]));
    let (vis_png, tir_png) = (dir.path().join("v.png"), dir.path().join("t.png"));
    ok(&fusion(&["rescale", "--width", "64", "--height", "48", p(&grey), p(&vis_png)]));
    ok(&fusion(&["rescale", "--width", "32", "--height", "24", p(&grey), p(&tir_png)]));
    let (from_pgm, from_png) = (dir.path().join("f1.pgm"), dir.path().join("f2.png"));
    ok(&fusion(&["fuse", "--method", "adf", p(&vis_pgm), p(&tir_pgm), p(&from_pgm)]));
    ok(&fusion(&["fuse", "--method", "adf", p(&vis_png), p(&tir_png), p(&from_png)]));
    assert_eq!(load_picture(&from_pgm).unwrap(), load_picture(&from_png).unwrap());
    let colour = dir.path().join("c.pgm");
    let o = fusion(&["fuse", p(&vis), p(&tir), p(&colour)]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("PGM holds grey only"));
    assert!(!colour.exists());
}

/// A thermal-like 16-bit frame: cold background, a warm block, counts in 14 bits.
fn counts(w: usize, h: usize) -> Gray<u16> {
    let data = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let warm = x > w / 3 && x < 2 * w / 3 && y > h / 4 && y < 3 * h / 4;
            let base = if warm { 9000 + 8 * x } else { 2500 };
            (base + (i * 7919) % 97) as u16
        })
        .collect();
    Gray { width: w, height: h, data }
}

#[test]
fn sixteen_bit_thermal_counts_fuse_through_the_core_agc_from_png_and_tiff() {
    let dir = tempfile::tempdir().unwrap();
    let vis = jpeg("VI", "walkingnight"); // 320 × 240
    let c = counts(160, 120);
    let (png16, tif16) = (dir.path().join("t16.png"), dir.path().join("t16.tif"));
    save_gray_u16(&png16, &c).unwrap();
    let bytes: Vec<u8> = c.data.iter().flat_map(|v| v.to_ne_bytes()).collect();
    image::save_buffer(&tif16, &bytes, 160, 120, image::ExtendedColorType::L16).unwrap();
    for (agc, params) in [("linear", AgcParams::linear()), ("plateau", AgcParams::plateau(160 * 120))] {
        // The AGC by hand through the core, then an ordinary 8-bit fusion.
        let mut mapped = Gray::<u8>::new(160, 120);
        agc_frame(&mut Agc::new(), c.view().unwrap(), mapped.view_mut().unwrap(), &params).unwrap();
        let t8 = dir.path().join(format!("t8-{agc}.png"));
        save_gray_u8(&t8, &mapped).unwrap();
        let expected = dir.path().join(format!("expected-{agc}.png"));
        ok(&fusion(&["fuse", p(&vis), p(&t8), p(&expected)]));
        let want = load_picture(&expected).unwrap();
        for input in [&png16, &tif16] {
            let out = dir.path().join(format!("out-{agc}.png"));
            ok(&fusion(&["fuse", "--agc", agc, p(&vis), p(input), p(&out)]));
            assert_eq!(load_picture(&out).unwrap(), want, "{agc} from {}", input.display());
        }
    }
    // The default is linear; --plateau alone asks for plateau equalisation with that plateau.
    let out = dir.path().join("default.png");
    ok(&fusion(&["fuse", p(&vis), p(&png16), p(&out)]));
    assert_eq!(load_picture(&out).unwrap(), load_picture(&dir.path().join("expected-linear.png")).unwrap());
    let (alone, both) = (dir.path().join("alone.png"), dir.path().join("both.png"));
    ok(&fusion(&["fuse", "--plateau", "9", p(&vis), p(&png16), p(&alone)]));
    ok(&fusion(&["fuse", "--agc", "plateau", "--plateau", "9", p(&vis), p(&png16), p(&both)]));
    assert_eq!(load_picture(&alone).unwrap(), load_picture(&both).unwrap());
    assert_ne!(load_picture(&alone).unwrap(), load_picture(&out).unwrap());
    let o = fusion(&["fuse", "--agc", "linear", "--plateau", "9", p(&vis), p(&png16), p(&alone)]);
    assert!(!o.status.success());
    // Folder-only options on one pair are refused rather than ignored.
    for opt in [["--jobs", "2"], ["--format", "tiff"]] {
        let o = fusion(&["fuse", opt[0], opt[1], p(&vis), p(&png16), p(&alone)]);
        assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("for folders"));
    }
    // A 16-bit visible frame is refused in one line.
    let o = fusion(&["fuse", p(&png16), p(&png16), p(&out)]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("16-bit"));
}

#[test]
fn a_rendered_16_bit_sequence_fuses_directly() {
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("seq");
    ok(&fusion(&[
        "render",
        "--sequence",
        "flyaround",
        "--frames",
        "3",
        "--vis-size",
        "128",
        "--tir-sizes",
        "64",
        "--tir16",
        "--quiet",
        "--out",
        p(&seq),
    ]));
    let out = dir.path().join("fused");
    let o = fusion(&["fuse", "--agc-smoothing", "3", p(&seq.join("vis")), p(&seq.join("tir16")), p(&out)]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("fused 3 of 3 pairs"));
    // The same as the AGC carried through the frames in order by hand, then one pair at a time.
    let params = AgcParams { smoothing: 3, ..AgcParams::linear() };
    let mut agc = fusion_engine::agc::fresh();
    for i in 0..3 {
        let name = format!("frame_{i:03}.png");
        let Picture::Gray16(counts) = load_picture(&seq.join("tir16").join(&name)).unwrap() else {
            panic!("tir16 is 16-bit")
        };
        let mapped = fusion_engine::agc::map_counts(&mut agc, &counts, &params).unwrap();
        let t8 = dir.path().join(format!("t8-{i}.png"));
        save_gray_u8(&t8, &mapped).unwrap();
        let single = dir.path().join(format!("single-{i}.png"));
        ok(&fusion(&["fuse", p(&seq.join("vis").join(&name)), p(&t8), p(&single)]));
        let f = load_picture(&out.join(&name)).unwrap();
        assert_eq!(f.size(), (128, 128));
        assert_eq!(f, load_picture(&single).unwrap(), "{name}");
    }
    // The outputs may not go into an input folder.
    let o = fusion(&["fuse", p(&seq.join("vis")), p(&seq.join("tir16")), p(&seq.join("vis"))]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("input folder"));
}

#[test]
fn folders_fuse_every_pair_report_each_failure_and_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let (vi, ir, out) = (dir.path().join("VI"), dir.path().join("IR"), dir.path().join("out"));
    std::fs::create_dir_all(&vi).unwrap();
    std::fs::create_dir_all(&ir).unwrap();
    for name in ["fight", "manWalking", "walkingnight"] {
        std::fs::copy(jpeg("VI", name), vi.join(format!("{name}.jpg"))).unwrap();
    }
    std::fs::copy(jpeg("IR", "fight"), ir.join("fight.jpg")).unwrap();
    std::fs::copy(jpeg("IR", "walkingnight"), ir.join("walkingnight.JPG")).unwrap();
    std::fs::write(ir.join("manWalking.png"), b"not an image").unwrap();
    std::fs::write(vi.join("notes.txt"), b"ignored: not an image extension").unwrap();
    let o = fusion(&["fuse", "--jobs", "2", "--format", "tiff", p(&vi), p(&ir), p(&out)]);
    assert_eq!(o.status.code(), Some(1));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("fused 2 of 3 pairs"), "{stdout}");
    assert!(stdout.contains("failed manWalking:") && stdout.contains("not a valid PNG"), "{stdout}");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("fuse [") && stderr.contains("fight: ok"), "plain progress lines: {stderr}");
    // Each fused output equals the single-pair run, in colour.
    for name in ["fight", "walkingnight"] {
        let single = dir.path().join(format!("{name}.tif"));
        let tir = if name == "fight" { ir.join("fight.jpg") } else { ir.join("walkingnight.JPG") };
        ok(&fusion(&["fuse", p(&vi.join(format!("{name}.jpg"))), p(&tir), p(&single)]));
        let folder = load_picture(&out.join(format!("{name}.tif"))).unwrap();
        assert!(matches!(folder, Picture::Rgb8(_)));
        assert_eq!(folder, load_picture(&single).unwrap(), "{name}");
    }
    assert!(!out.join("manWalking.tif").exists());
    // A pair with no partner is a failure too.
    std::fs::remove_file(ir.join("manWalking.png")).unwrap();
    let o = fusion(&["fuse", "--quiet", p(&vi), p(&ir), p(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stdout).contains("no thermal image manWalking.*"));

    // A stem held by two files of one folder is a failure of that stem (fight.tif and
    // fight.png are in `out` now): eval refuses it, then scores once the .tif are gone.
    std::fs::remove_file(vi.join("manWalking.jpg")).unwrap();
    let o = fusion(&["eval", p(&vi), p(&ir), p(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("two fused images with this name"));
    for name in ["fight", "walkingnight"] {
        std::fs::remove_file(out.join(format!("{name}.tif"))).unwrap();
    }
    // eval over the three folders: a row per triple equal to the single run, and the mean.
    let o = fusion(&["eval", "--suite", "vifb", "--format", "csv", p(&vi), p(&ir), p(&out)]);
    ok(&o);
    let csv = String::from_utf8_lossy(&o.stdout).to_string();
    let rows: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 4, "{csv}");
    assert_eq!(rows[0][..2], ["row", "image"]);
    let rows: Vec<Vec<&str>> = rows.into_iter().map(|r| r[1..].to_vec()).collect();
    assert_eq!(rows[3][0], "", "{csv}");
    let mut sums = vec![0.0; rows[0].len() - 1];
    for (row, name) in rows[1..3].iter().zip(["fight", "walkingnight"]) {
        assert_eq!(row[0], name);
        let tir = if name == "fight" { ir.join("fight.jpg") } else { ir.join("walkingnight.JPG") };
        let single = fusion(&[
            "eval",
            "--suite",
            "vifb",
            "--format",
            "csv",
            p(&vi.join(format!("{name}.jpg"))),
            p(&tir),
            p(&out.join(format!("{name}.png"))),
        ]);
        ok(&single);
        let single = String::from_utf8_lossy(&single.stdout).to_string();
        assert_eq!(row[1..].join(","), single.lines().nth(1).unwrap(), "{name}");
        for (s, v) in sums.iter_mut().zip(&row[1..]) {
            *s += v.parse::<f64>().unwrap();
        }
    }
    for (s, v) in sums.iter().zip(&rows[3][1..]) {
        assert!((s / 2.0 - v.parse::<f64>().unwrap()).abs() <= 1e-12 * s.abs().max(1.0), "mean {v}");
    }
}
