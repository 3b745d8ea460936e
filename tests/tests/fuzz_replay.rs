//! The fuzz targets on stable Rust: replays every committed input of `fuzz/corpus/<target>/`
//! and `fuzz/regressions/<target>/` (crashes found by fuzzing, kept after the fix) through the
//! same harness functions `cargo fuzz` runs (`fuzz/src/lib.rs`, included here as a module),
//! plus a fixed set of seeded random inputs, so CI covers the fuzz oracles without nightly.
//!
//! Fuzzing itself (nightly): `cd fuzz && cargo +nightly fuzz run pipeline -- -max_total_time=120`
//! (targets `pipeline`, `rescale_u8`, `rescale_u16`, `rescale_f32`); see the README's
//! "Robustness" section.

#[allow(dead_code)]
#[path = "../../fuzz/src/lib.rs"]
mod harness;

use fusion_tests::TestRng;
use std::path::{Path, PathBuf};

type Target = fn(&[u8]);

const TARGETS: [(&str, Target); 4] = [
    ("pipeline", harness::pipeline),
    ("rescale_u8", harness::rescale_u8),
    ("rescale_u16", harness::rescale_u16),
    ("rescale_f32", harness::rescale_f32),
];

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

/// The files of `dir` in name order (none if it does not exist).
fn inputs(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_file()).collect())
        .unwrap_or_default();
    files.sort();
    files
}

fn replay(target: &str, run: Target, dir: &str) -> usize {
    let files = inputs(&fuzz_dir().join(dir).join(target));
    for file in &files {
        let data = std::fs::read(file).unwrap();
        let name = file.display().to_string();
        if std::panic::catch_unwind(|| run(&data)).is_err() {
            panic!("{target}: {name} fails (replay: cd fuzz && cargo +nightly fuzz run {target} {name})");
        }
    }
    files.len()
}

/// Every crash input found by fuzzing, kept as a regression test after its fix.
#[test]
fn regressions_replay_cleanly() {
    for (target, run) in TARGETS {
        let n = replay(target, run, "regressions");
        println!("{target}: {n} regression inputs");
    }
}

/// The committed (minimised) corpus of every target.
#[test]
fn corpus_replays_cleanly() {
    for (target, run) in TARGETS {
        let n = replay(target, run, "corpus");
        println!("{target}: {n} corpus inputs");
    }
}

/// Seeded random inputs (fixed seed: the same inputs on every run), lengths 0..600.
#[test]
fn seeded_random_inputs() {
    for (k, (target, run)) in TARGETS.into_iter().enumerate() {
        let mut rng = TestRng::new(0xF022 + k as u64);
        for i in 0..400 {
            let len = (rng.next_u64() % 600) as usize;
            let data: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
            if std::panic::catch_unwind(|| run(&data)).is_err() {
                panic!("{target}: seeded input {i} fails: {data:?}");
            }
        }
    }
}
