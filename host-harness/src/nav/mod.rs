//! Relative-navigation front end for judging fused streams: features on the target, and (with
//! the navigation benchmark) their tracks and the relative motion they give.
//!
//! Detection is `imageproc`'s FAST-9 segment test with its non-maximum suppression; this module
//! only restricts it to the target and counts.

pub mod bench;
pub mod features;
pub mod pose;
pub mod track;
