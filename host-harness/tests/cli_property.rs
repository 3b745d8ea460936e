//! Property tests over the CLI's damaged inputs (README, "What the CLI guarantees"): a rendered
//! navbench sequence and a folder of pairs, each damaged by a few random edits (manifest values
//! of the wrong size, sign, type or presence, frames and masks truncated, resized, replaced by
//! noise, by folders or removed), then judged or fused and scored. Whatever the damage, the run
//! ends with status 0 or 1 — never a panic (101), an abort (134) or a signal — with an error as
//! one line `fusion: error: …`, and no temporary left behind.
//!
//! CI runs a few cases per property (`PROPTEST_CASES`, default 12); the closing notes report
//! long runs (`PROPTEST_CASES=2000 cargo test --release -p host-harness --test cli_property`).

use proptest::prelude::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn fusion<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    let bin = std::env::var_os("FUSION_BIN")
        .map_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_fusion")), PathBuf::from);
    Command::new(bin).args(args).output().unwrap()
}

fn config() -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(12);
    ProptestConfig { cases, failure_persistence: None, ..ProptestConfig::default() }
}

/// The run ended cleanly: 0, or 1 with the error as one line; nothing of ours left behind.
/// With `FUSION_PROPERTY_LOG=FILE` each run's status and last line of standard error are
/// appended to FILE (what the long runs reported).
fn ended_cleanly(o: &Output, scratch: &Path) -> Result<(), TestCaseError> {
    let err = String::from_utf8_lossy(&o.stderr);
    if let Some(log) = std::env::var_os("FUSION_PROPERTY_LOG") {
        use std::io::Write;
        let last = err.trim_end().lines().last().unwrap_or_default().to_string();
        let mut f = std::fs::OpenOptions::new().create(true).append(true).open(log).unwrap();
        writeln!(f, "{:?}\t{}", o.status.code(), last.replace(scratch.to_str().unwrap_or_default(), ""))
            .unwrap();
    }
    prop_assert!(matches!(o.status.code(), Some(0 | 1)), "status {:?}: {err}", o.status);
    prop_assert!(!err.contains("internal error") && !err.contains("panicked"), "{err}");
    if o.status.code() == Some(1) {
        let last = err.trim_end().lines().last().unwrap_or_default();
        prop_assert!(last.starts_with("fusion: error: "), "{err}");
        prop_assert_eq!(err.matches("fusion: error:").count(), 1, "{}", err);
    }
    prop_assert!(temporaries(scratch).is_empty(), "left behind: {:?}", temporaries(scratch));
    Ok(())
}

fn temporaries(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else { continue };
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with(".fusion-") {
                found.push(e.path());
            }
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(e.path());
            }
        }
    }
    found
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// Every file under `dir`, sorted (relative paths).
fn listing(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            if e.file_type().unwrap().is_dir() {
                stack.push(e.path());
            } else {
                out.push(e.path().strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out.sort();
    out
}

/// A rendered approach sequence (3 frames, VIS 64², TIR 32²) as navbench's data folder,
/// rendered once per test process.
fn clean_sequence() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let seq = dir.path().join("seed-1/approach");
        let o = fusion(&[
            "--quiet",
            "render",
            "--sequence",
            "approach",
            "--frames",
            "3",
            "--vis-size",
            "64",
            "--samples",
            "1",
            "--out",
            seq.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        dir
    })
    .path()
}

/// One edit of the data.
#[derive(Debug, Clone)]
enum Edit {
    /// A manifest value (by JSON pointer) set to another value.
    Set(&'static str, Value),
    /// A manifest key removed.
    Remove(&'static str),
    /// The manifest cut after this fraction of its bytes.
    CutManifest(f64),
    /// The frame list kept to its first `n` entries.
    KeepFrames(usize),
    /// A file (by its index in the sorted listing) cut after this fraction of its bytes.
    Cut(usize, f64),
    /// A file replaced by an 8-bit grey PNG of this size.
    Resize(usize, u32, u32),
    /// A file replaced by a 16-bit grey PNG.
    Deepen(usize),
    /// A file replaced by random bytes.
    Noise(usize, u64),
    /// A file removed.
    Delete(usize),
    /// A file replaced by a folder of that name.
    Folder(usize),
}

/// Manifest places whose damage navbench must refuse or survive.
const NUMBERS: [&str; 14] = [
    "/vis_camera/size",
    "/tir_camera/size",
    "/vis_camera/focal_px",
    "/tir_camera/focal_px",
    "/vis_camera/principal_point/0",
    "/config/frames",
    "/config/vis_size",
    "/config/tir_size",
    "/frames/0/range_m",
    "/frames/1/time_s",
    "/frames/1/sun_fraction",
    "/frames/0/position_m/2",
    "/frames/1/quaternion_wxyz/0",
    "/frames/2/target_pixels/0",
];
const KEYS: [&str; 10] = [
    "/vis_camera",
    "/tir_camera/size",
    "/frames",
    "/frames/0/files/vis",
    "/frames/1/files/vis_mask",
    "/frames/1/quaternion_wxyz",
    "/frames/2/phase",
    "/frames/0/position_m",
    "/config",
    "/phase_frames",
];

fn value() -> impl Strategy<Value = Value> {
    prop_oneof![
        prop::sample::select(vec![0.0, -1.0, 1.0, 2.0, 3.0, 0.5, 1e9, 1e300, -1e300, 16385.0, 65536.0])
            .prop_map(Value::from),
        Just(Value::from("NaN")),
        Just(Value::Null),
        Just(Value::Array(vec![])),
        Just(Value::from("frame_000.png")),
        Just(Value::from("../../../etc/passwd")),
        Just(Value::from("/dev/zero")),
    ]
}

fn edit(files: usize) -> impl Strategy<Value = Edit> {
    prop_oneof![
        (prop::sample::select(NUMBERS.to_vec()), value()).prop_map(|(k, v)| Edit::Set(k, v)),
        (prop::sample::select(KEYS.to_vec()), value()).prop_map(|(k, v)| Edit::Set(k, v)),
        prop::sample::select(KEYS.to_vec()).prop_map(Edit::Remove),
        (0.0..1.0f64).prop_map(Edit::CutManifest),
        (0usize..4).prop_map(Edit::KeepFrames),
        (0..files, 0.0..1.0f64).prop_map(|(f, x)| Edit::Cut(f, x)),
        (
            0..files,
            prop::sample::select(vec![0u32, 1, 3, 31, 32, 33, 63, 64, 65, 128]),
            prop::sample::select(vec![1u32, 3, 32, 64, 65])
        )
            .prop_map(|(f, w, h)| Edit::Resize(f, w, h)),
        (0..files).prop_map(Edit::Deepen),
        (0..files, any::<u64>()).prop_map(|(f, s)| Edit::Noise(f, s)),
        (0..files).prop_map(Edit::Delete),
        (0..files).prop_map(Edit::Folder),
    ]
}

/// Applies `edit` to the data folder `seq` (the manifest and the files of `files`).
fn apply(seq: &Path, files: &[PathBuf], edit: &Edit) {
    let manifest = seq.join("manifest.json");
    let edit_json = |f: &dyn Fn(&mut Value)| {
        let Ok(bytes) = std::fs::read(&manifest) else { return };
        let Ok(mut m) = serde_json::from_slice::<Value>(&bytes) else { return };
        f(&mut m);
        std::fs::write(&manifest, serde_json::to_vec(&m).unwrap()).unwrap();
    };
    let file = |k: usize| seq.join(&files[k % files.len()]);
    let replace = |path: &Path, bytes: &[u8]| {
        if path.is_dir() {
            let _ = std::fs::remove_dir_all(path);
        }
        std::fs::write(path, bytes).unwrap();
    };
    match edit {
        Edit::Set(pointer, v) => edit_json(&|m| {
            if let Some(slot) = m.pointer_mut(pointer) {
                *slot = v.clone();
            }
        }),
        Edit::Remove(pointer) => edit_json(&|m| {
            let (parent, key) = pointer.rsplit_once('/').unwrap();
            match m.pointer_mut(if parent.is_empty() { "" } else { parent }) {
                Some(Value::Object(o)) => {
                    o.remove(key);
                }
                Some(Value::Array(a)) => {
                    if let Ok(i) = key.parse::<usize>()
                        && i < a.len()
                    {
                        a.remove(i);
                    }
                }
                _ => {}
            }
        }),
        Edit::CutManifest(x) => {
            if let Ok(bytes) = std::fs::read(&manifest) {
                replace(&manifest, &bytes[..(bytes.len() as f64 * x) as usize]);
            }
        }
        Edit::KeepFrames(n) => edit_json(&|m| {
            if let Some(Value::Array(a)) = m.get_mut("frames") {
                a.truncate(*n);
            }
        }),
        Edit::Cut(k, x) => {
            let path = file(*k);
            if let Ok(bytes) = std::fs::read(&path) {
                replace(&path, &bytes[..(bytes.len() as f64 * x) as usize]);
            }
        }
        Edit::Resize(k, w, h) => {
            let path = file(*k);
            let mut png = Vec::new();
            if *w > 0 {
                image::GrayImage::from_fn(*w, *h, |x, y| image::Luma([((x * 7 + y * 3) % 256) as u8]))
                    .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                    .unwrap();
            }
            replace(&path, &png);
        }
        Edit::Deepen(k) => {
            let path = file(*k);
            let mut png = Vec::new();
            image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(64, 64, |x, y| {
                image::Luma([(x * 900 + y) as u16])
            })
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
            replace(&path, &png);
        }
        Edit::Noise(k, seed) => {
            let mut s = *seed;
            let bytes: Vec<u8> = (0..64 + seed % 4000)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    (s >> 56) as u8
                })
                .collect();
            replace(&file(*k), &bytes);
        }
        Edit::Delete(k) => {
            let path = file(*k);
            let _ = std::fs::remove_file(&path);
            let _ = std::fs::remove_dir_all(&path);
        }
        Edit::Folder(k) => {
            let path = file(*k);
            let _ = std::fs::remove_file(&path);
            let _ = std::fs::create_dir_all(&path);
        }
    }
}

proptest! {
    #![proptest_config(config())]

    /// navbench on damaged sequence data: judged, or refused in one line.
    #[test]
    fn navbench_on_damaged_data_ends_cleanly(edits in prop::collection::vec(edit(19), 1..4)) {
        let clean = clean_sequence();
        let scratch = tempfile::tempdir().unwrap();
        let data = scratch.path().join("data");
        copy_tree(clean, &data);
        let seq = data.join("seed-1/approach");
        let files: Vec<PathBuf> = listing(&seq).into_iter().filter(|p| p != Path::new("manifest.json")).collect();
        for e in &edits {
            apply(&seq, &files, e);
        }
        let out = scratch.path().join("nb");
        let o = fusion(&[
            "--quiet", "navbench", "--data", data.to_str().unwrap(), "--out", out.to_str().unwrap(),
            "--seeds", "1", "--vis-size", "64", "--sources", "vis,tir", "--sequences", "approach", "--frames", "3",
        ]);
        ended_cleanly(&o, scratch.path())?;
    }

    /// Folder runs of fuse and eval on damaged folders: every pair fused or listed as failed.
    #[test]
    fn folder_runs_on_damaged_folders_end_cleanly(edits in prop::collection::vec(edit(8), 1..5)) {
        let scratch = tempfile::tempdir().unwrap();
        let (v, t) = (scratch.path().join("v"), scratch.path().join("t"));
        std::fs::create_dir_all(&v).unwrap();
        std::fs::create_dir_all(&t).unwrap();
        for k in 0..4u32 {
            let img = |m: u32| image::GrayImage::from_fn(40, 30, move |x, y| image::Luma([((x * m + y * 5 + k) % 256) as u8]));
            img(3).save(v.join(format!("f{k}.png"))).unwrap();
            img(7).save(t.join(format!("f{k}.png"))).unwrap();
        }
        let files: Vec<PathBuf> = (0..4).flat_map(|k| [PathBuf::from(format!("v/f{k}.png")), PathBuf::from(format!("t/f{k}.png"))]).collect();
        for e in &edits {
            apply(scratch.path(), &files, e);
        }
        let out = scratch.path().join("out");
        let o = fusion(&["--quiet", "fuse", "--jobs", "2", v.to_str().unwrap(), t.to_str().unwrap(), out.to_str().unwrap()]);
        ended_cleanly(&o, scratch.path())?;
        if out.is_dir() {
            let o = fusion(&["--quiet", "eval", "--format", "csv", v.to_str().unwrap(), t.to_str().unwrap(), out.to_str().unwrap()]);
            ended_cleanly(&o, scratch.path())?;
        }
    }
}
