//! # fusion-navbench
//!
//! The navigation judge (`fusion navbench`): what a chaser's relative navigation gets out of
//! VIS, TIR or a fused stream of a rendered rendezvous sequence, against the rendered ground
//! truth, beside the judge's floor and ceiling, over several noise seeds.
//!
//! The chain, one module per stage:
//! * [`model`] — the target's shape as a model-based tracker knows it: back-projection of a
//!   pixel at the *estimated* pose, visibility, the image box, the silhouette.
//! * [`tracker`] — the front end: Shi–Tomasi corners tracked over frames by pyramidal
//!   Lucas–Kanade with a forward–backward check (`optical-flow-lk`), anchored on the model.
//! * [`warp`] — each track's anchor window warped by its model face's plane to the predicted
//!   pose and matched there (Gauss–Newton on position, gain and bias): the exact position.
//! * [`pose`] — PnP-RANSAC (`sqpnp_simple`) and Levenberg–Marquardt refinement
//!   (`levenberg-marquardt`) with its covariance; relative poses and their errors.
//! * [`edges`] — the model's creases found in the image along their normals around the
//!   prediction and the pose fitted to them (Gauss–Newton, Tukey weights): the absolute cue.
//! * [`silhouette`] — the target's outline against the model's: a position measurement.
//! * [`registration`] — an offset rig's thermal frame on the visible grid at the filter's
//!   range, and the misregistration it leaves (from the rendered depth).
//! * [`region`] — the part of a frame that holds the scene (a skipped fusion's window): the
//!   front end reads nothing outside it.
//! * [`filter`] — the navigation filter: an MEKF on the relative attitude and the target's
//!   position in the camera's frame.
//! * [`baseline`] — `zero-motion` and `oracle` (ground-truth correspondences).
//! * [`bench`](mod@bench) — `fusion navbench`'s engine: every source of a sequence through the
//!   chain, per frame and per illumination phase.
//! * [`seeds`] — figures over seeds (mean, spread) and verdicts only outside the spread.
//! * [`features`], [`track`] — the earlier pairwise front end (FAST-9 + BRIEF frame to frame,
//!   PnP against the rendered depth), kept beside the new one as `pairwise_*`.
//!
//! Written here only what no maintained crate does: the RANSAC loop, the MEKF, the model
//! back-projection, the model-warped template match, the model-edge fit, the outline cue, the matching window and
//! the measures.

//! ```
//! use fusion_navbench::pose::{RelativePose, pnp_ransac};
//! use render_host::glam::{DQuat, DVec2, DVec3};
//!
//! // Points on a target 8 m ahead, seen again after a 2° turn and a 5 cm step.
//! let truth = RelativePose { rotation: DQuat::from_rotation_y(2f64.to_radians()), translation: DVec3::new(0.05, 0.0, 0.0) };
//! let points: Vec<DVec3> = (0..30).map(|i| DVec3::new((i % 6) as f64 * 0.3 - 0.75, (i / 6) as f64 * 0.3 - 0.6, 8.0 + (i % 3) as f64 * 0.2)).collect();
//! let image: Vec<DVec2> = points.iter().map(|&x| { let y = truth.rotation * x + truth.translation; DVec2::new(y.x / y.z, y.y / y.z) }).collect();
//! let found = pnp_ransac(&points, &image, 1600.0, 7).expect("a pose");
//! assert_eq!(found.inliers, 30);
//! assert!(found.pose.rotation_error_deg(&truth) < 1e-6);
//! ```

pub mod baseline;
pub mod bench;
pub mod edges;
pub mod features;
pub mod filter;
pub mod model;
pub mod pose;
pub mod region;
pub mod registration;
pub mod seeds;
pub mod silhouette;
pub mod track;
pub mod tracker;
pub mod warp;
