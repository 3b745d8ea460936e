//! `fusion rescale` end to end: output equals the core, bad input gives one line and exit 1.

use fusion_io::{ColorPolicy, Gray, GrayInput, load_image, save_gray_u8, save_gray_u16};
use std::path::Path;
use std::process::{Command, Output};

fn fusion(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fusion")).args(args).output().expect("run fusion")
}

fn assert_clean_failure(out: &Output, needle: &str) {
    assert_eq!(out.status.code(), Some(1), "exit code");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "one-line error, got: {err}");
    assert!(err.contains(needle), "error {err:?} should mention {needle:?}");
    assert!(!err.contains("panicked"), "no panic: {err}");
}

#[test]
fn rescales_8_and_16_bit_pngs() {
    let dir = tempfile::tempdir().unwrap();
    let src = Gray { width: 5, height: 3, data: (0..15u8).map(|v| v * 17).collect() };
    let inp = dir.path().join("in.png");
    let outp = dir.path().join("out.png");
    save_gray_u8(&inp, &src).unwrap();
    let out = fusion(&["rescale", "--filter", "area", "--width", "10", "--height", "6", p(&inp), p(&outp)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let GrayInput::U8(got) = load_image(&outp, ColorPolicy::Refuse).unwrap() else {
        panic!("8-bit output expected")
    };
    assert_eq!((got.width, got.height), (10, 6));
    assert_eq!(got.at(9, 5), src.at(4, 2), "area 2× up replicates");

    let src16 = Gray { width: 4, height: 4, data: (0..16u16).map(|v| v * 4000).collect() };
    save_gray_u16(&inp, &src16).unwrap();
    let out = fusion(&["rescale", "--filter", "cubic", "--width", "2", "--height", "2", p(&inp), p(&outp)]);
    assert!(out.status.success());
    let GrayInput::U16(got) = load_image(&outp, ColorPolicy::Refuse).unwrap() else {
        panic!("16-bit output expected")
    };
    let mut want = Gray::<u16>::new(2, 2);
    fusion_nostd::rescale(src16.view().unwrap(), want.view_mut().unwrap(), fusion_nostd::Filter::Cubic)
        .unwrap();
    assert_eq!(got, want);
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

#[test]
fn bad_input_is_one_line_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let outp = dir.path().join("out.png");
    let o = p(&outp);
    assert_clean_failure(
        &fusion(&["rescale", "--width", "4", "--height", "4", "/no/such.png", o]),
        "cannot open",
    );
    let junk = dir.path().join("junk.png");
    std::fs::write(&junk, b"\x89PNG\r\n\x1a\ntruncated").unwrap();
    assert_clean_failure(
        &fusion(&["rescale", "--width", "4", "--height", "4", p(&junk), o]),
        "not a valid PNG",
    );
    let rgb = dir.path().join("rgb.png");
    image::save_buffer(&rgb, &[1, 2, 3, 4, 5, 6], 2, 1, image::ExtendedColorType::Rgb8).unwrap();
    assert_clean_failure(&fusion(&["rescale", "--width", "4", "--height", "4", p(&rgb), o]), "colour");
    let grey = dir.path().join("g.png");
    save_gray_u8(&grey, &Gray { width: 2, height: 2, data: vec![1, 2, 3, 4] }).unwrap();
    assert_clean_failure(&fusion(&["rescale", "--width", "0", "--height", "4", p(&grey), o]), "zero");
    assert_clean_failure(
        &fusion(&["rescale", "--width", "4", "--height", "4", p(&grey), "/no/such/dir/o.png"]),
        "cannot write",
    );
    assert!(!outp.exists(), "no output written on failure");
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(leftovers.len(), 3, "no temporary files: {leftovers:?}");
}
