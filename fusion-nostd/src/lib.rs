//! # fusion-nostd
//!
//! The flight core of the VIS/TIR fusion project: `#![no_std]`, no allocator, integer /
//! fixed-point first so every target produces the same bits.
//!
//! * [`frame`] — owned const-generic [`Frame`] storage and validated views
//!   [`FrameRef`] / [`FrameMut`].
//! * [`rescalers`] — bicubic and area rescalers ([`rescale`]) with OpenCV conventions
//!   (bit-exact with `cv2.resize` on u8 at factor 2).
//! * [`scratch`] — caller-owned work planes ([`Scratch`], [`ScratchMut`]).
//! * [`methods`] — the fusion methods, one folder each.
//! * [`pipeline`] — the per-frame entry point: rescale one band onto the other's grid, fuse.
//! * [`strips`] — the same pipeline strip by strip in a fixed 512 KiB working set
//!   ([`fuse_strips`]), bit-identical to the whole-frame run.
//! * [`sequence`] — a camera sequence fused frame after frame with ADF's KL weights carried from
//!   the frame before ([`fuse_in_sequence`], [`fuse_strips_in_sequence`]): one pass over the
//!   strips instead of two.
//! * [`scene`] — scene analysis (background, noise, target box, illumination) that lets the
//!   pipeline skip what the scene does not need ([`pipeline::SkipPolicy`]).
//! * [`thermal`] — the thermal camera's front end on raw focal-plane counts: two-point
//!   non-uniformity correction, the shutter's offset update, bad-pixel replacement, a
//!   column-noise filter; by frame, strip or row.
//! * [`agc`] — thermal automatic gain control: 14/16-bit counts to 8 bits (plateau histogram
//!   equalisation or a percentile stretch), by frame, strip or row, with temporal smoothing.
//! * [`Error`] — the one small `Copy` error type; bad input is an `Err`, never a panic.
//! * [`cpu`] — which instruction set the host kernels run (AVX-512, AVX2 or portable, chosen at
//!   run time on x86-64; NEON on AArch64; [`cpu::limit_isa`] caps it for tests and benchmarks).
//!
//! Everything a firmware or host user calls is re-exported here at the root: the frames and
//! scratch, [`FuseConfig`] (method, rescale policy, skip policy, scene thresholds), [`fuse`]
//! and [`fuse_strips`], [`FuseReport`] and [`StripReport`], [`Guards`], [`Error`], the
//! rescaler and the AGC. The modules hold each part's documentation; the firmware's
//! per-step hooks sit in a hidden `stages` module. The source tree: one folder per method
//! under `methods/` (its whole-frame code, its strip form `strips.rs`, its tests), and one file
//! per instruction set beside a kernel's portable code, named after it (`armv7em.rs` for the
//! Armv7E-M DSP assembly, `neon.rs`, `avx2.rs`, `avx512.rs`; the short DSP sequences in
//! `arch.rs`).
//!
//! Words used throughout: a *band* is one camera's image, VIS or TIR (the scratch's *band plane*
//! holds the one rescaled onto the other's grid); the *grid* is the size both are fused on; a
//! *strip* is a run of grid rows fused together ([`strips`]) and its *window* the strip with
//! the method's halo rows; a *window* of the scene analysis is the target's [`Rect`].
//!
//! # Quick start
//!
//! Firmware declares the frames and the work memory statically (on a board, in a linker
//! section in external SDRAM); nothing in the core allocates. One VIS/TIR pair, fused with the
//! default configuration (TIR upscaled to the VIS grid with bicubic, TSIFSD flight variant):
//!
//! ```
//! use fusion_nostd::{Error, FrameMut, Frame512, Frame1024, FuseConfig, Scratch1024, fuse};
//!
//! static mut VIS: Frame1024 = Frame1024::filled(0); // visible camera, 1024²
//! static mut TIR: Frame512 = Frame512::filled(0); // microbolometer, 512²
//! static mut FUSED: Frame1024 = Frame1024::filled(0);
//! static mut SCRATCH: Scratch1024 = Scratch1024::new(); // 13 MiB of work planes
//!
//! /// One frame of the navigation loop, into `out`.
//! fn fuse_frame(out: Option<FrameMut<'_, u8>>) -> Result<fusion_nostd::FuseReport, Error> {
//!     // SAFETY: the frame loop is the only code that touches these statics and never
//!     // re-enters itself (one thread of control).
//!     let (vis, tir, fused, scratch) = unsafe {
//!         (&*(&raw const VIS), &*(&raw const TIR), &mut *(&raw mut FUSED), &mut *(&raw mut SCRATCH))
//!     };
//!     let out = out.unwrap_or_else(|| fused.view_mut());
//!     fuse(vis.view(), tir.view(), out, &mut scratch.view_mut(), &FuseConfig::default())
//! }
//!
//! // The cameras' drivers fill VIS and TIR; then:
//! let report = fuse_frame(None)?;
//! assert_eq!(report.grid, (1024, 1024)); // the VIS grid
//! assert!(report.rescaled); // TIR was upscaled
//!
//! // Bad input is an `Err`, never a panic: here an output on the wrong grid, refused before
//! // anything is written. Flight code keeps its last good frame and tells navigation.
//! let mut wrong = Frame512::filled(7);
//! match fuse_frame(Some(wrong.view_mut())) {
//!     Err(Error::SizeMismatch { .. }) => assert!(wrong.pixels().iter().all(|&p| p == 7)),
//!     other => panic!("expected a size mismatch, got {other:?}"),
//! }
//! # Ok::<(), Error>(())
//! ```
//!
//! The same frame in strips, in a fixed 512 KiB working set that fits on-chip SRAM (the frames
//! stay in external memory; [`strips`] says what each method needs): the same bytes.
//!
//! ```
//! use fusion_nostd::strips::{STRIP_SCRATCH_BYTES, StripScratch512K, fuse_strips};
//! use fusion_nostd::{Frame512, Frame1024, FuseConfig, Scratch1024, fuse};
//!
//! static mut STRIPS: StripScratch512K = StripScratch512K::new();
//! # static mut SCRATCH: Scratch1024 = Scratch1024::new();
//! // SAFETY: as above, one thread of control owns the statics.
//! let strips = unsafe { &mut *(&raw mut STRIPS) };
//!
//! // A test pattern (on a board: the cameras' frames in static memory).
//! let mut vis = Box::new(Frame1024::filled(0));
//! let mut tir = Box::new(Frame512::filled(0));
//! for (i, p) in vis.pixels_mut().iter_mut().enumerate() { *p = (i % 251) as u8; }
//! for (i, p) in tir.pixels_mut().iter_mut().enumerate() { *p = (i / 512 % 256) as u8; }
//!
//! let config = FuseConfig::default();
//! let mut out = Box::new(Frame1024::filled(0));
//! let (report, layout) =
//!     fuse_strips(vis.view(), tir.view(), out.view_mut(), &mut strips.view_mut(), &config, usize::MAX)?;
//! assert!(layout.working_set_bytes() <= STRIP_SCRATCH_BYTES);
//! assert!(layout.strips > 1);
//!
//! // Bit-identical to the whole-frame run.
//! # let scratch = unsafe { &mut *(&raw mut SCRATCH) };
//! let mut whole = Box::new(Frame1024::filled(0));
//! let whole_report = fuse(vis.view(), tir.view(), whole.view_mut(), &mut scratch.view_mut(), &config)?;
//! assert_eq!(out.pixels(), whole.pixels());
//! assert_eq!(report.guards, whole_report.guards);
//! # Ok::<(), fusion_nostd::Error>(())
//! ```
//!
//! # Robustness
//!
//! A core that panics on a flight computer loses the navigation chain, and one that silently
//! writes a wrong frame corrupts it. The contract:
//!
//! | input | outcome |
//! |---|---|
//! | a width or height of 0 | [`Error::ZeroDimension`] when the view is built (and from [`FuseConfig::scratch_pixels`]) |
//! | a side above [`MAX_DIMENSION`] (2¹⁴) | [`Error::DimensionTooLarge`] (views, [`FuseConfig::scratch_pixels`]) |
//! | a stride below the width | [`Error::StrideTooSmall`] |
//! | a buffer shorter than `(h − 1)·stride + w`, or a geometry whose length overflows `usize` | [`Error::BufferTooSmall`] |
//! | VIS, TIR and output sizes that do not fit the rescale policy (policy `None` with different sizes, an output that is not the fusion grid, a method called with frames of different sizes) | [`Error::SizeMismatch`] |
//! | scratch planes (or the band plane, when the pipeline rescales) shorter than [`FuseConfig::scratch_pixels`] | [`Error::ScratchTooSmall`] with both numbers |
//! | a parameter outside its documented range | [`Error::InvalidParameter`] naming the field; [`pipeline::fuse_raw`] with IFEVIP (no pre-cast value): `name: "method"` |
//! | [`strips::fuse_strips`] with what strips do not run (scene skipping, `max_rows` 0; a rescale that is not an exact 2× of the policy's filter; a strip scratch too small for one row and its halos, or for IFEVIP's passes) | [`Error::InvalidParameter`] naming it, [`Error::UnsupportedRatio`], [`Error::ScratchTooSmall`]; the output is untouched |
//! | `f32` NaN, +∞, −∞ | [`Error::NonFinite`] (destination untouched) |
//! | `f32` magnitude above [`rescalers::F32_MAX_MAGNITUDE`] (2¹²⁰) | [`Error::ValueOutOfRange`]: the filter's overshoot could overflow to ±∞ |
//! | `f32` denormals, ±0, the largest accepted magnitude | ordinary values; the output is finite |
//! | one pixel, one row, one column, odd sizes, 2¹⁴ × 1, 1 × 2¹⁴, any non-2× rescale ratio, TIR larger than VIS | valid: `Ok`, every method and variant |
//! | constant, black, saturated, checkerboard, anti-correlated bands | valid: `Ok`; where the published arithmetic is undefined (0/0, a degenerate eigenvector, zero entropy, …) a documented guard rule applies and [`Guards`] says which |
//! | `u16` samples | the full 16-bit range is valid (there is no bit-depth parameter); integer outputs saturate, never wrap |
//!
//! On `Err` the output view may hold a partial result (the fusion entries) and must not be used;
//! nothing outside a view is ever written. The output does not depend on what the scratch held.
//! `tests/tests/robustness.rs` asserts every row of this table.
//!
//! How it is checked:
//! * **Lints**: outside tests the crate denies `unwrap`, `expect`, `panic!`, `unreachable!`,
//!   `todo!`, `unimplemented!` and indexing/slicing (`clippy::indexing_slicing`).
//! * **No panic path in the linked image**: `fw/` has an `exercise` function that calls every
//!   public entry point (the rescaler for u8, u16 and f32, [`pipeline::fuse`],
//!   [`pipeline::fuse_raw`], [`pipeline::fuse_method`], each method's u8 and pre-cast entry,
//!   [`strips::fuse_strips`], the stage functions, with sizes, strides and parameters hidden from the optimiser by
//!   `black_box`), and with `--features panic-check` its panic handler calls an undefined symbol:
//!   the firmware links only if the optimiser removed every panic path (release, fat LTO,
//!   Cortex-M7 and RV32). `fw/panic-sites.sh` lists the functions that still reach one. `.ci/run`
//!   builds it (see `fw/README.md`, "No-panic status").
//! * **Fuzzing**: `fuzz/` (`cargo +nightly fuzz run pipeline|rescale_u8|rescale_u16|rescale_f32`)
//!   decodes arbitrary bytes into sizes, strides, buffer lengths, policies, methods, parameters,
//!   scratch sizes and pixels, and checks the expected `Err`, no write outside the view,
//!   determinism with dirty scratch, raw-vs-u8 consistency and the rescalers against each other;
//!   the workspace test `tests/tests/fuzz_replay.rs` replays the committed corpus on stable.
//! * **Numerical stress**: `fusion stress` runs every method and variant, core and f64
//!   reference, over adversarial frames (`BENCHMARKS.md`, "Stress").
//! * **Determinism**: `tests/tests/determinism.rs` (dirty and reused scratch, strides, the
//!   firmware's results on Cortex-M7, RV32 and Cortex-A53 against the host's); `fusion budget` compares
//!   every target run with the host byte for byte.
#![no_std]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::unreachable,
        clippy::todo,
        clippy::unimplemented
    )
)]

// The README's Rust examples compile and run as doctests of this crate.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
struct ReadmeDoctests;

pub mod agc;
#[cfg(fusion_arm_dsp)]
mod arch;
pub mod cpu;
pub mod error;
#[doc(hidden)]
pub mod filters;
pub mod frame;
pub mod methods;
pub mod pipeline;
pub mod registration;
pub mod rescalers;
pub mod scene;
pub mod scratch;
pub mod sequence;
pub mod strips;
pub mod thermal;

// The front door: what firmware and host code call, by name, at the root.
pub use agc::{AGC_MAX_SMOOTHING, Agc, AgcMode, AgcParams, AgcReport, agc_frame};
pub use error::Error;
pub use frame::{Frame, Frame512, Frame1024, FrameMut, FrameRef, MAX_DIMENSION, Rect};
pub use methods::adaptive::AdaptiveParams;
pub use methods::adf::AdfParams;
pub use methods::ifevip::IfevipParams;
pub use methods::tsifsd::TsifsdParams;
pub use methods::{Guards, Variant};
pub use pipeline::{
    FuseConfig, FuseReport, Method, RescalePolicy, SkipPolicy, SkipReport, Skips, fuse, fuse_in_sequence,
    fusion_grid,
};
pub use rescalers::{Filter, Sample, rescale};
pub use scene::{Decline, Illumination, SceneParams};
pub use scratch::{SCRATCH_PLANES, Scratch, Scratch512, Scratch1024, ScratchMut};
pub use sequence::{Sequence, SequenceParams};
pub use strips::{
    STRIP_SCRATCH_BYTES, StripReport, StripScratch, StripScratch512K, StripScratchMut, fuse_strips,
    fuse_strips_in_sequence,
};

/// The firmware's stage hooks: the pipeline's steps one at a time (a method on frames already
/// on one grid, the pre-cast output, the adaptive decision, the scene-skip plan's parts) and
/// the kernels the budget measures alone. Public for `fw/`, the tests and the fuzz targets,
/// which time or check each step; not the interface a user calls (use [`fuse`] and
/// [`fuse_strips`]), and free to change with the pipeline.
#[doc(hidden)]
pub mod stages {
    pub use crate::filters::box_sum::box_sum_u8;
    pub use crate::methods::round_away_sat_u8;
    pub use crate::pipeline::{
        adaptive_decision, background_value, fuse_method, fuse_method_decided, fuse_raw,
    };
    pub use crate::rescalers::rescale_general_u8;
}
