//! The one write path (`fusion_io::output`): outputs are all or nothing, never redirected,
//! only regular files are replaced, long names work, a failing standard output is an error.
//! Interruptions: `cli_interrupt.rs`.

use fusion_io::{Gray, save_gray_u8};
use std::path::Path;
use std::process::{Command, Output};

fn pattern(w: usize, h: usize, k: usize) -> Gray<u8> {
    Gray { width: w, height: h, data: (0..w * h).map(|i| ((i * k + i / w * 7) % 251) as u8).collect() }
}

fn fusion(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fusion")).args(args).output().unwrap()
}

fn pair(dir: &Path) -> (String, String) {
    let (v, t) = (dir.join("v.png"), dir.join("t.png"));
    save_gray_u8(&v, &pattern(40, 32, 3)).unwrap();
    save_gray_u8(&t, &pattern(40, 32, 5)).unwrap();
    (v.to_str().unwrap().to_string(), t.to_str().unwrap().to_string())
}

/// The folder's entries other than the inputs, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "v.png" && n != "t.png")
        .collect();
    names.sort();
    names
}

fn one_line_error(out: &Output) -> String {
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!err.contains("internal error"), "{err}");
    err
}

#[test]
fn several_outputs_commit_all_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let (v, t) = pair(dir.path());
    let raw = dir.path().join("raw.npy");
    // The image's folder does not exist: the raw array, staged first, must not appear either.
    let out = fusion(&[
        "fuse",
        "--method",
        "adf",
        "--engine",
        "reference",
        &v,
        &t,
        "no/such/dir/f.png",
        "--raw",
        raw.to_str().unwrap(),
    ]);
    one_line_error(&out);
    assert_eq!(listing(dir.path()), Vec::<String>::new(), "nothing written, no temporary left");
    // The same path for both outputs is refused (one would overwrite the other).
    let f = dir.path().join("f.png");
    let out = fusion(&[
        "fuse",
        "--method",
        "adf",
        "--engine",
        "reference",
        &v,
        &t,
        f.to_str().unwrap(),
        "--raw",
        f.to_str().unwrap(),
    ]);
    assert!(one_line_error(&out).contains("two outputs"));
    assert_eq!(listing(dir.path()), Vec::<String>::new());
    // Both succeed together.
    let out = fusion(&[
        "fuse",
        "--method",
        "adf",
        "--engine",
        "reference",
        &v,
        &t,
        f.to_str().unwrap(),
        "--raw",
        raw.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(listing(dir.path()), vec!["f.png".to_string(), "raw.npy".to_string()]);
}

#[cfg(unix)]
#[test]
fn links_are_not_followed_and_only_regular_files_are_replaced() {
    use std::os::unix::fs::{FileTypeExt, PermissionsExt, symlink};
    let dir = tempfile::tempdir().unwrap();
    let (v, t) = pair(dir.path());
    // A link at the output name: the link is replaced by the output, its target is untouched.
    let victim = dir.path().join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    let link = dir.path().join("out.png");
    symlink(&victim, &link).unwrap();
    let out = fusion(&["fuse", "--method", "tsifsd", &v, &t, link.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    let meta = std::fs::symlink_metadata(&link).unwrap();
    assert!(meta.file_type().is_file(), "the output is a regular file now");
    assert_eq!(meta.permissions().mode() & 0o077, 0, "outputs are private to their owner");

    // A FIFO, a folder and a device given as the output are refused, and stay what they were.
    let fifo = dir.path().join("pipe.png");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let out = fusion(&["fuse", "--method", "tsifsd", &v, &t, fifo.to_str().unwrap()]);
    assert!(one_line_error(&out).contains("not a regular file"));
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    let folder = dir.path().join("folder.png");
    std::fs::create_dir(&folder).unwrap();
    assert!(
        one_line_error(&fusion(&["fuse", "--method", "tsifsd", &v, &t, folder.to_str().unwrap()]))
            .contains("folder")
    );
    assert!(folder.is_dir());
    let out = fusion(&["rescale", "--width", "20", "--height", "16", &v, "/dev/null"]);
    assert!(one_line_error(&out).contains("not a regular file"));
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
    let mut left = listing(dir.path());
    left.retain(|n| n.starts_with(".fusion-"));
    assert!(left.is_empty(), "temporaries left: {left:?}");
}

#[test]
fn the_longest_legal_name_works() {
    let dir = tempfile::tempdir().unwrap();
    let (v, t) = pair(dir.path());
    // 255 bytes is the usual file-name limit; the temporary's name does not grow with it.
    let name = format!("{}.png", "n".repeat(251));
    let out_path = dir.path().join(&name);
    let out = fusion(&["fuse", "--method", "tsifsd", &v, &t, out_path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(listing(dir.path()), vec![name]);
}

#[cfg(target_os = "linux")]
#[test]
fn a_full_standard_output_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let (v, t) = pair(dir.path());
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
    let out =
        Command::new(env!("CARGO_BIN_EXE_fusion")).args(["eval", &v, &t, &t]).stdout(full).output().unwrap();
    assert!(one_line_error(&out).contains("standard output"));
}
