//! Puts the linker map of the target on the link search path: the workspace's `../memory.x`
//! for Cortex-M (read by cortex-m-rt's `link.x`), `riscv-virt.ld` for RV32 and `aarch64-virt.ld` for the
//! Cortex-A53 (passed with `-T` from `.cargo/config.toml`).
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR set by cargo"));
    let target = env::var("TARGET").unwrap_or_default();
    if target.starts_with("riscv") {
        fs::copy("riscv-virt.ld", out.join("riscv-virt.ld")).expect("copy riscv-virt.ld");
    } else if target.starts_with("aarch64") {
        fs::copy("aarch64-virt.ld", out.join("aarch64-virt.ld")).expect("copy aarch64-virt.ld");
    } else {
        fs::copy("../memory.x", out.join("memory.x")).expect("copy ../memory.x");
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-changed=riscv-virt.ld");
    println!("cargo:rerun-if-changed=aarch64-virt.ld");
    println!("cargo:rerun-if-changed=build.rs");
}
