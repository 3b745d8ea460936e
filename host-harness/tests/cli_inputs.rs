//! What the CLI reads and says (README, "What the CLI guarantees"): every name and format that
//! `fuse` writes is read back by `fuse` and `eval`, damaged or ambiguous inputs are refused in
//! one line naming the file, and what a run quietly could have done otherwise is said.

use fusion_io::{Gray, save_gray_u8};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// `FUSION_BIN=/path/to/fusion` runs these against another build (how they were checked to fail
/// before the fixes).
fn bin() -> PathBuf {
    std::env::var_os("FUSION_BIN").map_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_fusion")), PathBuf::from)
}

fn fusion<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    Command::new(bin()).args(args).output().unwrap()
}

/// A 16-bit binary PGM (P5, maxval 65535, big-endian samples), as cameras' tools write them.
fn save_pgm16(path: &Path, img: &Gray<u16>) {
    let mut bytes = format!("P5\n{} {}\n65535\n", img.width, img.height).into_bytes();
    bytes.extend(img.data.iter().flat_map(|v| v.to_be_bytes()));
    std::fs::write(path, bytes).unwrap();
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit 1 and one line `fusion: error: …` holding every one of `needles`.
#[track_caller]
fn refused(o: &Output, needles: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("fusion: error: "), "{err}");
    for n in needles {
        assert!(err.contains(n), "{err:?} should name {n:?}");
    }
}

#[track_caller]
fn ok(o: &Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

fn pattern(w: usize, h: usize, k: usize) -> Gray<u8> {
    Gray { width: w, height: h, data: (0..w * h).map(|i| ((i * k + i / w * 7 + k) % 251) as u8).collect() }
}

fn counts(w: usize, h: usize, k: usize) -> Gray<u16> {
    let data =
        (0..w * h).map(|i| (2500 + (i % w) * 40 + (i / w) * 13 + (i * k * 7919) % 97) as u16).collect();
    Gray { width: w, height: h, data }
}

/// Folders `v` and `t` holding `names` (8-bit PNG pairs).
fn folders(dir: &Path, names: &[&std::ffi::OsStr]) -> (PathBuf, PathBuf) {
    let (v, t) = (dir.join("v"), dir.join("t"));
    std::fs::create_dir_all(&v).unwrap();
    std::fs::create_dir_all(&t).unwrap();
    for (k, name) in names.iter().enumerate() {
        let mut file = name.to_os_string();
        file.push(".png");
        save_gray_u8(&v.join(&file), &pattern(24, 16, 3 + k)).unwrap();
        save_gray_u8(&t.join(&file), &pattern(24, 16, 11 + k)).unwrap();
    }
    (v, t)
}

#[cfg(target_os = "linux")]
#[test]
fn a_name_that_is_not_utf8_is_fused_like_any_other() {
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let odd = std::ffi::OsStr::from_bytes(b"frame_\xff\xfe");
    let (v, t) = folders(dir.path(), &[std::ffi::OsStr::new("frame_1"), odd]);
    let out = dir.path().join("out");
    let o = fusion(&["fuse", p(&v), p(&t), p(&out)]);
    ok(&o);
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("fused 2 of 2 pairs"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let mut name = odd.to_os_string();
    name.push(".png");
    // The output under the input's own bytes, equal to that pair fused on its own.
    let single = dir.path().join("single.png");
    let (vn, tn) = (v.join(&name), t.join(&name));
    ok(&fusion(&[std::ffi::OsStr::new("fuse"), vn.as_os_str(), tn.as_os_str(), single.as_os_str()]));
    assert_eq!(std::fs::read(out.join(&name)).unwrap(), std::fs::read(&single).unwrap());
    // eval pairs it too.
    ok(&fusion(&["eval", "--format", "csv", p(&v), p(&t), p(&out)]));
}

#[test]
fn what_fuse_writes_eval_reads_pgm_and_16_bit_thermal() {
    let dir = tempfile::tempdir().unwrap();
    let (v, t) = folders(dir.path(), &[std::ffi::OsStr::new("a"), std::ffi::OsStr::new("b")]);
    // PGM out, then eval over the three folders.
    let out = dir.path().join("pgm");
    ok(&fusion(&["fuse", "--format", "pgm", p(&v), p(&t), p(&out)]));
    assert!(out.join("a.pgm").is_file());
    let o = fusion(&["eval", "--format", "csv", p(&v), p(&t), p(&out)]);
    ok(&o);
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 4);
    // 16-bit thermal counts in PGM: paired, fused through the AGC, and scored by eval against the
    // same AGC mapping (the library's, fusion_engine::agc) as an 8-bit file.
    let t16 = dir.path().join("t16");
    std::fs::create_dir_all(&t16).unwrap();
    for (k, name) in ["a", "b"].iter().enumerate() {
        save_pgm16(&t16.join(format!("{name}.pgm")), &counts(24, 16, k + 1));
    }
    let fused = dir.path().join("fused16");
    ok(&fusion(&["fuse", p(&v), p(&t16), p(&fused)]));
    let o = fusion(&["eval", "--format", "csv", p(&v), p(&t16), p(&fused)]);
    ok(&o);
    assert!(stderr(&o).contains("14/16-bit counts"), "{}", stderr(&o));
    assert_eq!(stderr(&o).matches("14/16-bit counts").count(), 1, "said once: {}", stderr(&o));
    let t8 = dir.path().join("t8");
    std::fs::create_dir_all(&t8).unwrap();
    for (k, name) in ["a", "b"].iter().enumerate() {
        let c = counts(24, 16, k + 1);
        let params = fusion_nostd::AgcParams::linear();
        let mapped = fusion_engine::agc::map_counts(&mut fusion_engine::agc::fresh(), &c, &params).unwrap();
        save_gray_u8(&t8.join(format!("{name}.png")), &mapped).unwrap();
    }
    let o8 = fusion(&["eval", "--format", "csv", p(&v), p(&t8), p(&fused)]);
    ok(&o8);
    assert_eq!(o.stdout, o8.stdout);
}

#[test]
fn eval_csv_quotes_names_and_tells_the_mean_apart() {
    let dir = tempfile::tempdir().unwrap();
    let names = ["mean", "a,b", "say \"hi\""].map(std::ffi::OsStr::new);
    let (v, t) = folders(dir.path(), &names);
    let out = dir.path().join("out");
    ok(&fusion(&["fuse", p(&v), p(&t), p(&out)]));
    let o = fusion(&["eval", "--format", "csv", p(&v), p(&t), p(&out)]);
    ok(&o);
    let csv = String::from_utf8_lossy(&o.stdout).into_owned();
    let lines: Vec<&str> = csv.lines().collect();
    assert!(lines[0].starts_with("row,image,"), "{csv}");
    let metrics = lines[0].split(',').count() - 2;
    // Each line parses to its fields (the quoted names hold commas and quotes).
    let parse = |line: &str| -> Vec<String> {
        let (mut fields, mut field, mut quoted, mut chars) =
            (Vec::new(), String::new(), false, line.chars().peekable());
        while let Some(c) = chars.next() {
            match (c, quoted) {
                ('"', true) if chars.peek() == Some(&'"') => {
                    field.push('"');
                    chars.next();
                }
                ('"', _) => quoted = !quoted,
                (',', false) => fields.push(std::mem::take(&mut field)),
                (c, _) => field.push(c),
            }
        }
        fields.push(field);
        fields
    };
    let rows: Vec<Vec<String>> = lines[1..].iter().map(|l| parse(l)).collect();
    assert_eq!(rows.len(), 4, "{csv}");
    let mut images: Vec<&str> = rows.iter().filter(|r| r[0] == "image").map(|r| r[1].as_str()).collect();
    images.sort();
    assert_eq!(images, ["a,b", "mean", "say \"hi\""]);
    assert_eq!(rows.iter().filter(|r| r[0] == "mean").count(), 1);
    assert!(rows.iter().all(|r| r.len() == metrics + 2), "{csv}");
}

#[test]
fn damaged_or_ambiguous_images_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let t = dir.path().join("t.png");
    save_gray_u8(&t, &pattern(16, 16, 5)).unwrap();
    let out = dir.path().join("o.png");
    // A truncated JPEG (libjpeg's "premature end" is an error, not grey rows).
    let jpeg = std::fs::read(fusion_io::testdata::file("vifb_jpeg/IR/walkingnight.jpg")).unwrap();
    let cut = dir.path().join("cut.jpg");
    std::fs::write(&cut, &jpeg[..jpeg.len() / 2]).unwrap();
    refused(&fusion(&["eval", p(&cut), p(&cut), p(&cut)]), &["cut.jpg", "Premature end"]);
    // An animated PNG and a multi-page TIFF: not read as their first image.
    let frames = [pattern(16, 16, 1), pattern(16, 16, 2)];
    let apng = dir.path().join("anim.png");
    {
        let file = std::io::BufWriter::new(std::fs::File::create(&apng).unwrap());
        let mut enc = png::Encoder::new(file, 16, 16);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_animated(2, 0).unwrap();
        let mut w = enc.write_header().unwrap();
        for f in &frames {
            w.write_image_data(&f.data).unwrap();
        }
        w.finish().unwrap();
    }
    refused(&fusion(&["fuse", p(&apng), p(&t), p(&out)]), &["anim.png", "animated PNG of 2 images"]);
    let tif = dir.path().join("pages.tif");
    {
        let mut enc = tiff::encoder::TiffEncoder::new(std::fs::File::create(&tif).unwrap()).unwrap();
        for f in &frames {
            enc.write_image::<tiff::encoder::colortype::Gray8>(16, 16, &f.data).unwrap();
        }
    }
    refused(&fusion(&["fuse", p(&tif), p(&t), p(&out)]), &["pages.tif", "multi-page TIFF of 2 images"]);
    // A floating-point TIFF: named as such, not "Unknown(32)".
    let float = dir.path().join("float.tif");
    {
        let mut enc = tiff::encoder::TiffEncoder::new(std::fs::File::create(&float).unwrap()).unwrap();
        enc.write_image::<tiff::encoder::colortype::Gray32Float>(4, 4, &[0.5f32; 16]).unwrap();
    }
    let o = fusion(&["fuse", p(&float), p(&t), p(&out)]);
    refused(&o, &["float.tif", "32-bit (floating-point"]);
    assert!(!stderr(&o).contains("Unknown("), "{}", stderr(&o));
    // A decoder's reason once, not repeated by its source.
    let bad = dir.path().join("bad.png");
    std::fs::write(&bad, b"garbage, not a PNG").unwrap();
    let o = fusion(&["fuse", p(&bad), p(&t), p(&out)]);
    refused(&o, &["bad.png"]);
    assert_eq!(stderr(&o).matches("signature").count(), 1, "{}", stderr(&o));
    assert!(!out.exists());
}

#[test]
fn what_a_run_could_do_quietly_is_said() {
    let dir = tempfile::tempdir().unwrap();
    let (v, t) = folders(dir.path(), &["a", "b", "c"].map(std::ffi::OsStr::new));
    // AGC options on 8-bit thermal folders: said once, not per pair.
    let o =
        fusion(&["fuse", "--agc", "plateau", "--agc-smoothing", "2", p(&v), p(&t), p(&dir.path().join("o"))]);
    ok(&o);
    assert_eq!(stderr(&o).matches("are not used").count(), 1, "{}", stderr(&o));
    // Every pair failing leaves no empty output folder behind.
    let broken = dir.path().join("broken");
    std::fs::create_dir_all(&broken).unwrap();
    for name in ["a", "b", "c"] {
        std::fs::write(broken.join(format!("{name}.png")), b"not a PNG").unwrap();
    }
    let empty = dir.path().join("never");
    let o = fusion(&["--quiet", "fuse", p(&broken), p(&t), p(&empty)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!empty.exists(), "an empty output folder was left");
    // Standard output closed: refused before anything is written, not a summary lost with exit 0.
    let closed = dir.path().join("closed");
    let o = Command::new("sh")
        .arg("-c")
        .arg("exec \"$0\" fuse \"$1\" \"$2\" \"$3\" >&-")
        .args([bin().as_path(), &v, &t, &closed])
        .output()
        .unwrap();
    refused(&o, &["standard output is closed"]);
    assert!(!closed.exists());
    // DRIF's refusal says what it needs: one integer factor on both axes.
    let (vw, tw) = (dir.path().join("vw.png"), dir.path().join("tw.png"));
    save_gray_u8(&vw, &pattern(128, 1, 3)).unwrap();
    save_gray_u8(&tw, &pattern(64, 1, 5)).unwrap();
    refused(
        &fusion(&[
            "fuse",
            "--method",
            "drif",
            "--engine",
            "reference",
            p(&vw),
            p(&tw),
            p(&dir.path().join("d.png")),
        ]),
        &["one integer factor on both axes", "VIS 128x1, TIR 64x1"],
    );
}

#[test]
fn eval_says_when_a_folder_mean_is_undefined() {
    let dir = tempfile::tempdir().unwrap();
    let (v, t) = folders(dir.path(), &["a", "b"].map(std::ffi::OsStr::new));
    let out = dir.path().join("out");
    ok(&fusion(&["fuse", p(&v), p(&t), p(&out)]));
    // A constant image makes VIFB's CC undefined (0/0) on that triple.
    save_gray_u8(&out.join("b.png"), &Gray { width: 24, height: 16, data: vec![128; 24 * 16] }).unwrap();
    let o = fusion(&["eval", "--suite", "vifb", "--format", "csv", p(&v), p(&t), p(&out)]);
    ok(&o);
    let mean = String::from_utf8_lossy(&o.stdout).lines().last().unwrap().to_string();
    assert!(mean.to_lowercase().contains("nan"), "{mean}");
    assert!(stderr(&o).contains("is undefined on 1 of 2 images (b"), "{}", stderr(&o));
}

#[test]
fn outputs_that_cannot_be_made_name_their_path() {
    let dir = tempfile::tempdir().unwrap();
    let (v, t) = folders(dir.path(), &["a"].map(std::ffi::OsStr::new));
    // /proc takes no new entries, whoever runs the test (root included).
    for args in [
        vec!["fuse", p(&v), p(&t), "/proc/fusion-out"],
        vec!["render", "--frames", "1", "--vis-size", "16", "--out", "/proc/fusion-render"],
        vec!["navbench", "--frames", "2", "--vis-size", "64", "--seeds", "1", "--out", "/proc/fusion-nb"],
    ] {
        let o = fusion(&args);
        let path = args.last().unwrap();
        refused(&o, &[path]);
        assert!(!stderr(&o).contains(".fusion-"), "a temporary's name instead of the path: {}", stderr(&o));
    }
}

#[test]
fn a_small_sequence_renders_thermal_at_half_the_visible_size() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("seq");
    ok(&fusion(&["render", "--sequence", "approach", "--frames", "1", "--vis-size", "64", "--out", p(&out)]));
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    let tir = manifest["frames"][0]["files"]["tir"].as_str().unwrap();
    let (w, h, _) = fusion_io::image_header(&out.join(tir)).unwrap();
    assert_eq!((w, h), (32, 32));
}
