//! # fusion-campaign
//!
//! Monte Carlo campaigns of the navigation judge: thousands of cases (trajectory × sun phase
//! angle × the Earth behind or not × target × glare × sensor seed), each one sequence rendered
//! and every stream judged, summarised over cases.
//!
//! This crate is the part every engine shares, one module per stage:
//! * [`file`](mod@file) — the campaign file (TOML), read and checked with one-line errors.
//! * [`plan`] — its cases in a fixed order, each with a stable id (a hash of its parameters and
//!   the campaign seed) and a sensor seed drawn from the id, so a rerun is bit-identical.
//! * [`case`] — one case run: rendered into a scratch folder, judged, one row per stream and
//!   phase.
//!
//! `fusion campaign plan FILE` lists the cases; the distributed run (Dask), the resume, the
//! fault handling and the report are the Python package's (`vistir.campaign`, which calls
//! [`case::run`] in each worker).
//!
//! ```
//! use fusion_campaign::{file::CampaignFile, plan::plan};
//!
//! let file = CampaignFile::parse(
//!     r#"
//!     name = "example"
//!     seed = 7
//!     replicas = 2
//!     frames = 12
//!     vis_size = 128
//!     sources = ["vis", "tir"]
//!     [axes]
//!     trajectory = ["flyaround"]
//!     sun_phase = { from = 0, to = 180, steps = 3 }
//!     earth = [false, true]
//!     "#,
//!     "example.toml",
//! )
//! .expect("a valid file");
//! let cases = plan(&file).expect("a plan");
//! assert_eq!(cases.len(), 3 * 2 * 2); // phases × Earth × replicas
//! assert_eq!(cases[0].sun_phase_deg, Some(0.0));
//! assert_eq!(cases[0].id.len(), 16);
//! // The same file plans the same ids.
//! assert_eq!(plan(&file).unwrap(), cases);
//! ```

pub mod case;
pub mod file;
pub mod plan;
