//! Relative-navigation front end for judging image streams (issue 20): what a chaser's
//! feature-based navigation would get out of VIS, TIR or a fused stream.
//!
//! * [`features`] — FAST-9 corners on the target (`imageproc`), after a Gaussian pre-smoothing
//!   that keeps the sensor noise from firing the test.
//! * [`track`] — BRIEF descriptors (`imageproc`) and mutual-best matching frame to frame.
//! * [`pose`] — the frame-to-frame relative pose by PnP-RANSAC (`sqpnp_simple`) against the
//!   rendered depth, and its error against the ground truth.
//! * [`bench`] — `fusion navbench`'s engine: every stream of a rendezvous sequence
//!   (`render_host::sequence`) through the three, summarised per illumination phase.
//!
//! Written here only what no maintained crate does: the RANSAC loop, the matching window and
//! the measures.

pub mod bench;
pub mod features;
pub mod pose;
pub mod track;
