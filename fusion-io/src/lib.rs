//! # fusion-io
//!
//! Images in and out for the host side of the VIS/TIR fusion project — the `fusion` CLI, the
//! renderer, the metric suites, the navigation benchmark and the Python package all read and
//! write through this crate, and through nothing else:
//!
//! * **Pictures** ([`Gray`], [`Channels`], [`Picture`]): PNG, JPEG, TIFF and binary PGM/PPM in
//!   (8/16-bit grey, 8-bit colour), PNG, TIFF and PGM out, chosen by the extension
//!   ([`OutFormat`]); every input judged by its header against the memory limit before it is
//!   decoded. JPEG is decoded by libjpeg-turbo (its C source, built with cmake, through the
//!   `turbojpeg` crate) with libjpeg's defaults — the bytes MATLAB's `imread`, OpenCV and Pillow
//!   give, so metrics on JPEGs reproduce the field's published values; the other formats by
//!   the `image` crate.
//! * **The write path** ([`output`]): every file through an exclusive temporary in the
//!   destination folder, synced and renamed over the destination (a reader sees the old bytes
//!   or the new, never no file); related files all or none ([`output::Batch`]); new folders
//!   appear whole ([`output::in_new_folder`]); on SIGINT/SIGTERM/SIGHUP every temporary and
//!   every empty folder the run made is removed and every earlier output is as it was or
//!   replaced whole.
//! * **Inputs read as they were written**: images of a folder paired by their names' own bytes
//!   (UTF-8 or not), PGM/PPM included ([`folders`]); a file holding several images (an animated
//!   PNG, a multi-page TIFF) or samples no reader here takes (floating point) refused by name.
//! * **Console** ([`console`]): standard output and error without panics, `--quiet`, and the
//!   macros [`out!`], [`outln!`] and [`note!`].
//! * **The thermal camera's calibration files** ([`thermal`]): NUC tables and bad-pixel maps.
//! * **A camera pair's calibration** ([`rig`]): OpenCV's stereo calibration as it writes it
//!   (`FileStorage` YAML or JSON), for the registration of offset cameras.
//! * **Folders of pairs** ([`folders`]), **memory estimates and the limit** ([`memory`]),
//!   **`.npy` arrays** ([`npy`]) and **the repository's test data** ([`testdata`]).
//!
//! It sits just above the `no_std` core (a [`Gray`] lends the core a `FrameRef`) and below
//! every other host crate.
//!
//! ```
//! use fusion_io::{ColorPolicy, Gray, GrayInput, load_image, save_gray_u8};
//!
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("ramp.png");
//! let ramp = Gray { width: 4, height: 1, data: vec![0u8, 85, 170, 255] };
//! save_gray_u8(&path, &ramp)?; // atomic: a temporary, synced, renamed into place
//! assert_eq!(load_image(&path, ColorPolicy::Refuse)?, GrayInput::U8(ramp));
//! # Ok::<(), anyhow::Error>(())
//! ```

/// `print!` to standard output that returns an error (closed pipe, full disk) instead of
/// panicking: `out!(…)?`.
#[macro_export]
macro_rules! out {
    ($($t:tt)*) => { $crate::console::stdout_write(format_args!($($t)*)) };
}

/// `println!` that returns an error instead of panicking: `outln!(…)?`.
#[macro_export]
macro_rules! outln {
    () => { $crate::console::stdout_write(format_args!("\n")) };
    ($($t:tt)*) => { $crate::console::stdout_write(format_args!("{}\n", format_args!($($t)*))) };
}

/// `eprintln!` that never panics and respects `--quiet`: a failure of standard error is
/// remembered and ends the run with status 1 ([`console::stderr_failed`]).
#[macro_export]
macro_rules! note {
    ($($t:tt)*) => { $crate::console::stderr_note(format_args!($($t)*)) };
}

pub mod console;
pub mod folders;
mod jpeg;
pub mod memory;
pub mod npy;
pub mod output;
mod picture;
pub mod rig;
pub mod testdata;
pub mod thermal;

pub use output::{Batch, write_atomic, write_bytes};
pub use picture::{
    Channels, ColorPolicy, Gray, GrayInput, NamedPair, OutFormat, Picture, encode_channels, encode_image,
    encode_png, image_header, load_channels_u8, load_gray_u8, load_image, load_picture, rgb_to_gray_bt601,
    save_gray_u8, save_gray_u16, source_on_grid, vifb_pairs,
};
