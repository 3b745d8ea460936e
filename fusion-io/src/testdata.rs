//! The repository's own test data, `tests/data/` (what is there and where it comes from:
//! `tests/data/README.md`).
//!
//! Tests reach every file through [`file()`] or [`vifb_dir`]: a file that is not there fails the
//! calling test with one line naming it, and no backtrace, instead of an I/O error deep in a
//! loader.

use std::path::{Path, PathBuf};

/// The four real VIS/IR pairs from the VIFB benchmark in `tests/data/vifb/`.
pub const VIFB_PAIRS: [&str; 4] = ["fight", "kettle", "manWalking", "peopleshadow"];

/// The published methods whose outputs are stored per pair (`P_M_ref.npy`, `P_M_ref.png`).
pub const VIFB_METHODS: [&str; 3] = ["ADF", "TSIFSD", "IFEVIP"];

/// The test data folder, `tests/data/` in the checkout (not checked).
pub fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data")
}

/// The path of `tests/data/<relative>`; when no such file exists the calling test fails with
/// one line naming it.
pub fn file(relative: &str) -> PathBuf {
    let path = dir().join(relative);
    if !path.is_file() {
        missing(&path);
    }
    path
}

/// `tests/data/vifb/`, after checking that every pair's inputs and published outputs are there.
pub fn vifb_dir() -> PathBuf {
    for pair in VIFB_PAIRS {
        for band in ["VIS", "IR"] {
            file(&format!("vifb/{pair}_{band}.png"));
        }
        for method in VIFB_METHODS {
            file(&format!("vifb/{pair}_{method}_ref.npy"));
            file(&format!("vifb/{pair}_{method}_ref.png"));
        }
    }
    dir().join("vifb")
}

/// Fails the calling test with one line and no backtrace: the message goes to standard error
/// (which the test harness shows for a failed test) and the unwind skips the panic hook, which
/// would print a backtrace under `RUST_BACKTRACE=1`.
fn missing(path: &Path) -> ! {
    let message = format!(
        "test data missing: {} (the repository's tests/data/ folder; its README lists the files)",
        path.display()
    );
    note!("{message}");
    std::panic::resume_unwind(Box::new(message))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_vifb_file_is_in_the_repository() {
        let d = vifb_dir();
        assert!(d.join("vifb_metrics.csv").is_file());
    }

    #[test]
    fn a_missing_file_fails_with_one_line_naming_it() {
        let caught = std::panic::catch_unwind(|| file("vifb/no_such_pair_VIS.png")).unwrap_err();
        let message = caught.downcast_ref::<String>().expect("a String payload");
        assert!(message.contains("no_such_pair_VIS.png"), "{message}");
        assert!(message.starts_with("test data missing: "), "{message}");
        assert!(!message.contains('\n'), "one line: {message}");
    }
}
