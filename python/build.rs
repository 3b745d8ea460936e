//! The commit the package is built from, for `vistir._code_version` (what a campaign records
//! as the code behind its results): `git describe --always --dirty`, or `unknown` outside a
//! git checkout (an sdist).

use std::process::Command;

fn main() {
    let rev = Command::new("git")
        .args(["describe", "--always", "--dirty", "--abbrev=12", "--exclude=*"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".to_string());
    println!("cargo:rustc-env=VISTIR_GIT_REV={rev}");
    // A new commit or a change to the index moves it.
    for f in ["../.git/HEAD", "../.git/index"] {
        println!("cargo:rerun-if-changed={f}");
    }
}
