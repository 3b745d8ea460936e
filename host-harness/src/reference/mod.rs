//! f64 reference implementations, written straight from the specs on `f64` images in
//! 0..255 grey-level units, independent of the core's code.

pub mod adaptive;
pub mod adf;
pub mod agc;
pub mod ifevip;
pub mod rescale;
pub mod tsifsd;
