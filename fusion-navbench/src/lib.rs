//! # fusion-navbench
//!
//! The navigation judge (`fusion navbench`): what a chaser's feature-based relative navigation
//! gets out of VIS, TIR or a fused stream of a rendered rendezvous sequence, against the
//! rendered ground truth.
//!
//! * [`features`] — FAST-9 corners on the target (`imageproc`), after a Gaussian pre-smoothing
//!   that keeps the sensor noise from firing the test.
//! * [`track`] — BRIEF descriptors (`imageproc`) and mutual-best matching frame to frame.
//! * [`pose`] — the frame-to-frame relative pose by PnP-RANSAC (`sqpnp_simple`) against the
//!   rendered depth, and its error against the ground truth.
//! * [`bench`](mod@bench) — `fusion navbench`'s engine: every stream of a rendezvous sequence
//!   (`render_host::sequence`) through the three, summarised per illumination phase.
//!
//! Written here only what no maintained crate does: the RANSAC loop, the matching window and
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
pub mod features;
pub mod filter;
pub mod model;
pub mod pose;
pub mod seeds;
pub mod silhouette;
pub mod track;
pub mod tracker;
