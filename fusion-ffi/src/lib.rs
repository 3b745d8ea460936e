//! # fusion-ffi — the fusion core from C and C++
//!
//! `extern "C"` functions over the `no_std` core [`fusion_nostd`] for flight software written in
//! C or C++ (cFS applications, F´ components, generated GNC code). The header is
//! `include/fusion.h`, generated from this crate by cbindgen (`tests/header.rs` fails when the
//! committed header is stale; `FUSION_FFI_BLESS=1 cargo test` rewrites it).
//!
//! What a flight application calls:
//!
//! | call | what |
//! |---|---|
//! | [`fusion_config_default`] | TSIFSD flight, TIR upscaled onto the VIS grid, no skipping |
//! | [`fusion_output_size`], [`fusion_scratch_bytes`] | the fused frame's size and the work memory a pair needs |
//! | [`fusion_fuse`] | one VIS/TIR pair, whole frame, with the skip policy |
//! | [`fusion_fuse_strips`] | the same bytes strip by strip in a fixed working set ([`FUSION_STRIP_SCRATCH_BYTES`], 512 KiB) |
//! | [`fusion_sequence_state_bytes`], [`fusion_sequence_init`], [`fusion_fuse_in_sequence`], [`fusion_fuse_strips_in_sequence`] | a sequence of pairs with ADF's weights carried from frame to frame (one pass over the strips) |
//! | [`fusion_rescale_u8`], [`fusion_rescale_u16`] | the OpenCV-exact bicubic and area rescalers |
//! | [`fusion_agc_state_bytes`], [`fusion_agc_init`], [`fusion_agc_frame`] | 14/16-bit thermal counts to 8 bits |
//! | [`fusion_register_scratch_bytes`], [`fusion_register_u8`], [`fusion_register_u16`] | an offset camera pair's thermal frame onto the visible grid at a range |
//! | [`fusion_status_text`], [`FusionError`] | what went wrong, in one line |
//!
//! ## Rules (also in the header)
//!
//! * **Ownership**: every buffer belongs to the caller. The library keeps no pointer after a
//!   call returns, allocates nothing and has no global state.
//! * **Threads**: every function is reentrant. Calls may run at the same time on different
//!   threads or cores as long as each has its own output, scratch and AGC state; inputs may be
//!   shared read-only.
//! * **Errors**: every function that can fail returns a [`FusionStatus`] (0 = success) and, when
//!   the caller passes a [`FusionError`], fills it with the details. Nothing panics across the
//!   boundary: the core returns errors, and a panic (none is reachable: `--features
//!   panic-check`) would abort.
//! * **Buffers**: an image is `data`, `width`, `height` and a row `stride` in elements
//!   (`stride ≥ width`); the buffer must hold `(height − 1)·stride + width` elements. The output
//!   must not overlap an input or the scratch ([`FusionStatus::Overlap`]); scratch and AGC state
//!   must be 4-byte aligned, a sequence state 8-byte aligned ([`FusionStatus::Misaligned`]). On an error the output may hold a
//!   partial frame and must not be used.
#![no_std]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)
)]

#[cfg(test)]
extern crate std;

mod agc;
mod fuse;
mod image;
mod registration;
mod sequence;
mod status;
#[cfg(test)]
mod tests;
mod thermal;

pub use agc::{
    FusionAgcParams, FusionAgcReport, fusion_agc_frame, fusion_agc_init, fusion_agc_linear,
    fusion_agc_plateau, fusion_agc_state_bytes,
};
pub use fuse::{
    FUSION_STRIP_SCRATCH_BYTES, FusionConfig, FusionMethod, FusionReport, FusionRescale, FusionSkip,
    FusionVariant, fusion_config_default, fusion_fuse, fusion_fuse_strips, fusion_output_size,
    fusion_scratch_bytes,
};
pub use image::{
    FusionFilter, FusionImage, FusionImage16, FusionImageMut, FusionImageMut16, fusion_rescale_u8,
    fusion_rescale_u16,
};
pub use registration::{
    FusionCamera, FusionRegisterParams, FusionRig, fusion_register_scratch_bytes, fusion_register_u8,
    fusion_register_u16,
};
pub use sequence::{
    FusionPass, FusionRestart, FusionSequenceStep, fusion_fuse_in_sequence, fusion_fuse_strips_in_sequence,
    fusion_sequence_init, fusion_sequence_state_bytes,
};
pub use status::{FusionError, FusionStatus, fusion_status_text, fusion_version};
pub use thermal::{
    FusionColumnParams, FusionThermalTables, fusion_column_frame, fusion_column_init,
    fusion_column_state_bytes, fusion_thermal_correct, fusion_thermal_shutter,
};

/// Guard bits of [`FusionReport::guards`] (`fusion_nostd::Guards`): ADF's detail covariance was
/// zero.
pub const FUSION_GUARD_ADF_ZERO_COVARIANCE: u32 = 1 << 0;
/// ADF's KL eigenvector was degenerate.
pub const FUSION_GUARD_ADF_DEGENERATE_EIGENVECTOR: u32 = 1 << 1;
/// ADF's published KL weights left [0, 1]; the flight rule replaced them.
pub const FUSION_GUARD_ADF_WEIGHT_CLAMPED: u32 = 1 << 2;
/// TSIFSD: both saliencies 0 at some pixel; weights ½, ½.
pub const FUSION_GUARD_TSIFSD_ZERO_SALIENCY: u32 = 1 << 3;
/// IFEVIP: the visible frame has zero entropy.
pub const FUSION_GUARD_IFEVIP_ZERO_ENTROPY: u32 = 1 << 4;
/// IFEVIP: too few pixels for the published top-k; k ≥ 1 used.
pub const FUSION_GUARD_IFEVIP_FEW_PIXELS: u32 = 1 << 5;
/// IFEVIP: the peak mean was 0; gain 0.8 used.
pub const FUSION_GUARD_IFEVIP_ZERO_PEAK: u32 = 1 << 6;
/// Some output pixel saturated to 0 or 255.
pub const FUSION_GUARD_OUTPUT_SATURATED: u32 = 1 << 7;
/// Adaptive: VIS had no usable signal; the TIR frame passed through.
pub const FUSION_GUARD_ADAPTIVE_TIR_ONLY: u32 = 1 << 8;
/// Adaptive: glare in VIS; TIR took (part of) some pixels.
pub const FUSION_GUARD_ADAPTIVE_GLARE: u32 = 1 << 9;
/// Adaptive: the target was large; the frame was fused by ADF (flight).
pub const FUSION_GUARD_ADAPTIVE_ADF: u32 = 1 << 10;

/// A panic cannot unwind into C: none is reachable from the exported functions (the
/// `panic-check` link proves it), and if one were, the process would abort.
#[cfg(all(not(test), not(feature = "panic-check")))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    unsafe extern "C" {
        /// The C library's `abort` (glibc on hosts, newlib on bare-metal Arm).
        fn abort() -> !;
    }
    // SAFETY: `abort` takes no argument and never returns.
    unsafe { abort() }
}

/// With `panic-check`, a reachable panic is a link error: this symbol is defined nowhere.
#[cfg(all(not(test), feature = "panic-check"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    unsafe extern "C" {
        /// Undefined on purpose.
        fn fusion_ffi_panic_is_reachable() -> !;
    }
    // SAFETY: never linked; the program does not link if this call survives optimisation.
    unsafe { fusion_ffi_panic_is_reachable() }
}

/// The precompiled `compiler_builtins` of hosted targets carries unwind tables that name
/// `rust_eh_personality`; with `panic = "abort"` nothing unwinds, so nothing calls it. Defined
/// so a C program links the static library without a Rust standard library beside it.
#[cfg(all(not(test), target_os = "linux"))]
#[unsafe(no_mangle)]
extern "C" fn rust_eh_personality() {}
