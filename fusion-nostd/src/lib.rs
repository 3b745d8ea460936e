//! # fusion-nostd
//!
//! The flight core of the VIS/TIR fusion project: `#![no_std]`, no allocator, integer /
//! fixed-point first so every target produces the same bits.
//!
//! * [`frame`] — owned const-generic [`Frame`] storage and validated views
//!   [`FrameRef`] / [`FrameMut`].
//! * [`rescale`](mod@rescale) — bicubic and area rescalers with OpenCV conventions
//!   (bit-exact with `cv2.resize` on u8 at factor 2).
//! * [`scratch`] — caller-owned work planes ([`Scratch`], [`ScratchMut`]).
//! * [`fuse`] — the fusion methods.
//! * [`filters`] — integer filters shared by the methods.
//! * [`pipeline`] — the per-frame entry point: rescale one band onto the other's grid, fuse.
//! * [`Error`] — the one small `Copy` error type; bad input is an `Err`, never a panic.
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

#[macro_use]
mod cpu;
pub mod error;
pub mod filters;
pub mod frame;
pub mod fuse;
pub mod pipeline;
pub mod rescale;
pub mod scratch;

pub use error::Error;
pub use frame::{Frame, Frame512, Frame1024, FrameMut, FrameRef, MAX_DIMENSION};
pub use fuse::adf::AdfParams;
pub use fuse::ifevip::IfevipParams;
pub use fuse::tsifsd::TsifsdParams;
pub use fuse::{Guards, Variant};
pub use pipeline::{FuseReport, Method, Pipeline, RescalePolicy, fuse};
pub use rescale::{Filter, Sample, rescale};
pub use scratch::{SCRATCH_PLANES, Scratch, Scratch512, Scratch1024, ScratchMut};
