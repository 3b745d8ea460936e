//! What used to be accepted silently is now explicit (issue 24, item 4): refused with one line,
//! or done with a one-line note on standard error that `--quiet` silences; guards print as names.

use fusion_io::{Gray, save_gray_u8};
use std::path::Path;
use std::process::{Command, Output};

fn pattern(w: usize, h: usize, k: usize) -> Gray<u8> {
    Gray { width: w, height: h, data: (0..w * h).map(|i| ((i * k + i / w * 7) % 251) as u8).collect() }
}

fn fusion(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fusion")).args(args).output().unwrap()
}

fn path(dir: &Path, name: &str, img: &Gray<u8>) -> String {
    let p = dir.join(name);
    save_gray_u8(&p, img).unwrap();
    p.to_str().unwrap().to_string()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn refused_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let (v, t) =
        (path(dir.path(), "v.png", &pattern(40, 32, 3)), path(dir.path(), "t.png", &pattern(40, 32, 5)));
    let out = dir.path().join("o.png");
    let out = out.to_str().unwrap();
    // 16-bit colour, like 16-bit grey, is not taken for an 8-bit input.
    let rgb16 = dir.path().join("rgb16.png");
    let img =
        image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_pixel(40, 32, image::Rgb([1000, 2000, 3000]));
    img.save(&rgb16).unwrap();
    let o = fusion(&["fuse", rgb16.to_str().unwrap(), &t, out]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("16-bit colour") && stderr(&o).lines().count() == 1, "{}", stderr(&o));
    // The study's host methods have one variant: --variant is not ignored, it is refused.
    let o = fusion(&["fuse", "--method", "gff", "--variant", "classic", &v, &t, out]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("drop --variant"), "{}", stderr(&o));
    assert!(!Path::new(out).exists());
}

#[test]
fn noted_on_stderr_and_silenced_by_quiet() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let out = out.to_str().unwrap();
    // Different aspect ratios are stretched, with a note.
    let (v, t) =
        (path(dir.path(), "v.png", &pattern(64, 32, 3)), path(dir.path(), "t.png", &pattern(20, 20, 5)));
    let o = fusion(&["fuse", &v, &t, out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("aspect ratio"), "{}", stderr(&o));
    let o = fusion(&["--quiet", "fuse", &v, &t, out]);
    assert!(o.status.success());
    assert_eq!(stderr(&o), "", "--quiet silences notes");
    // The classic TSIFSD reference on black frames: 0/0 weights, NaN in --raw, said so.
    let flat = Gray { width: 40, height: 32, data: vec![0u8; 40 * 32] };
    let (v, t) = (path(dir.path(), "fv.png", &flat), path(dir.path(), "ft.png", &flat));
    let raw = dir.path().join("r.npy");
    let o = fusion(&[
        "fuse",
        "--method",
        "tsifsd",
        "--variant",
        "classic",
        "--engine",
        "reference",
        &v,
        &t,
        out,
        "--raw",
        raw.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("NaN"), "{}", stderr(&o));
}

#[test]
fn guards_print_as_names() {
    let dir = tempfile::tempdir().unwrap();
    // A bright VIS over a bright TIR saturates the output: the guard is named, not a hex mask.
    let bright = Gray { width: 40, height: 32, data: (0..40 * 32).map(|i| 200 + (i % 56) as u8).collect() };
    let (v, t) = (path(dir.path(), "v.png", &bright), path(dir.path(), "t.png", &bright));
    let out = dir.path().join("o.png");
    let o = fusion(&["fuse", "--method", "ifevip", &v, &t, out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let line = err.lines().find(|l| l.contains("guards:")).unwrap_or_else(|| panic!("no guards line: {err}"));
    assert!(!line.contains("0x"), "{line}");
    let names: Vec<&str> = fusion_nostd::Guards::NAMED.iter().map(|(_, n)| *n).collect();
    let listed = line.split("guards: ").nth(1).unwrap().split(" (").next().unwrap();
    assert!(listed.split(", ").all(|n| names.contains(&n)), "{line}");
}
