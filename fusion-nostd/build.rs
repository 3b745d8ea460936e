//! Sets `cfg(fusion_arm_dsp)` when the target has the Armv7E-M DSP instructions (`smlad`,
//! `smmulr`, `ssub16`, `sel`, `uadd16`) that the hot kernels use through inline assembly.
//! Arm target features are not visible to `cfg(target_feature)` on stable Rust, so the target
//! name decides: `thumbv7em-*` (Cortex-M4/M7) has them; other Arm targets (Cortex-M0/M3, M33
//! without the extension) take the portable code, which gives the same bits. A build with
//! `-C target-feature=+dsp` on another Arm target opts in.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(fusion_arm_dsp)");
    println!("cargo::rerun-if-changed=build.rs");
    let target = std::env::var("TARGET").unwrap_or_default();
    let features = std::env::var("CARGO_CFG_TARGET_FEATURE").unwrap_or_default();
    let arm = std::env::var("CARGO_CFG_TARGET_ARCH").is_ok_and(|a| a == "arm");
    if arm && (target.starts_with("thumbv7em") || features.split(',').any(|f| f == "dsp")) {
        println!("cargo::rustc-cfg=fusion_arm_dsp");
    }
}
