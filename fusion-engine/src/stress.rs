//! The stress study: every method and variant, core and f64 reference, over adversarial frames
//! (`fusion stress` prints it; the tests run it).
//!
//! Cases (VIS, TIR): all 0; all 255; 1-pixel checkerboards at full contrast, in phase and in
//! anti-phase; one hot pixel in each black band; impulse (salt-and-pepper) noise; ramps (VIS
//! horizontal, TIR vertical); one band constant (VIS, TIR); eclipse (VIS black); bands
//! negatively correlated (TIR = 255 − VIS); saturated VIS over a cold TIR; uniform random
//! noise in both bands. Each at several geometries: same-size pairs (one odd) and the pipeline
//! with rescale (VIS 2× TIR, bicubic TIR up and area VIS down, one odd).
//!
//! Per case and method it reports:
//! * **ref NaN** — pixels where the f64 reference (the published arithmetic) is NaN or ±∞, and
//!   what the core did there (the guard that fired; the core is integer and cannot produce NaN);
//! * **max err** — max |core − reference| of the 8-bit outputs, the reference cast as MATLAB's
//!   `uint8` (round half away, saturate), NaN pixels excluded; with **px ≠** the differing
//!   pixels. An overflow or wrap-around in the core shows here as a large error;
//! * **raw err** — ADF and TSIFSD: max |core pre-cast value (Q16) − reference value| in grey
//!   levels, before saturation (finite reference pixels);
//! * **guards** — the guards the core fired;
//! * **det** — the core run twice (fresh scratch, then scratch full of garbage) gives the same
//!   bytes and the same report.
//!
//! It exits non-zero if the core panics, refuses a valid input, differs between runs, or an
//! error exceeds [`bound`].

use crate::methods::{fuse_core, fuse_reference};
use anyhow::Result;
use fusion_io::Gray;
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, fusion_grid};
use fusion_nostd::{AdfParams, Filter, Guards, IfevipParams, ScratchMut, Variant};
use fusion_reference as reference;
use fusion_reference::{matlab_uint8, to_f64};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::panic::AssertUnwindSafe;

/// An adversarial case: a name, a description and how to draw each band at a given size.
#[derive(Debug, Clone, Copy)]
pub struct Case {
    /// Short name for the table.
    pub name: &'static str,
    /// What the frames hold.
    pub what: &'static str,
    vis: Pattern,
    tir: Pattern,
}

/// How one band of a case is drawn (in normalised coordinates, so that the two grids of a
/// rescaling pair see the same scene).
#[derive(Debug, Clone, Copy)]
enum Pattern {
    Constant(u8),
    Checker { invert: bool },
    HotPixel { fx: f64, fy: f64 },
    Impulse { seed: u64 },
    RampX,
    RampY,
    Scene { seed: u64 },
    InvertedScene { seed: u64 },
    SaturatedScene { seed: u64 },
    ColdScene { seed: u64 },
    Noise { seed: u64 },
}

/// The cases, in table order.
pub fn cases() -> Vec<Case> {
    use Pattern::*;
    let c = |name, what, vis, tir| Case { name, what, vis, tir };
    vec![
        c("zeros", "both bands 0", Constant(0), Constant(0)),
        c("full", "both bands 255", Constant(255), Constant(255)),
        c(
            "checker",
            "1-px checkerboards 0/255, in phase",
            Checker { invert: false },
            Checker { invert: false },
        ),
        c(
            "checker-anti",
            "1-px checkerboards 0/255, anti-phase",
            Checker { invert: false },
            Checker { invert: true },
        ),
        c(
            "hot-pixel",
            "black bands, one 255 pixel each (different places)",
            HotPixel { fx: 0.3, fy: 0.3 },
            HotPixel { fx: 0.5, fy: 0.5 },
        ),
        c(
            "impulse",
            "mid-grey scene + 8 % salt-and-pepper per band",
            Impulse { seed: 1 },
            Impulse { seed: 2 },
        ),
        c("ramps", "VIS horizontal ramp, TIR vertical ramp", RampX, RampY),
        c("vis-const", "VIS constant 128, TIR scene", Constant(128), Scene { seed: 3 }),
        c("tir-const", "VIS scene, TIR constant 77", Scene { seed: 4 }, Constant(77)),
        c("eclipse", "VIS black, TIR scene", Constant(0), Scene { seed: 5 }),
        c(
            "anti-corr",
            "TIR = 255 − VIS (negatively correlated)",
            Scene { seed: 6 },
            InvertedScene { seed: 6 },
        ),
        c(
            "sat-vis-cold-tir",
            "VIS saturated (255 over the target and glare), TIR cold (0–15)",
            SaturatedScene { seed: 7 },
            ColdScene { seed: 7 },
        ),
        c("noise", "uniform random 0–255, independent bands", Noise { seed: 8 }, Noise { seed: 9 }),
    ]
}

/// A smooth textured target on a dark background, in `[0, 255]`, at normalised `(u, v)`.
fn scene_value(u: f64, v: f64, seed: u64) -> f64 {
    let (dx, dy) = (u - 0.45, v - 0.5);
    let inside = (dx * dx) / 0.09 + (dy * dy) / 0.05 < 1.0;
    let phase = seed as f64;
    if inside {
        150.0 + 50.0 * (13.0 * u + phase).sin() * (9.0 * v).cos() + 30.0 * (40.0 * v).sin()
    } else {
        12.0 + 8.0 * (7.0 * u + 5.0 * v + phase).sin()
    }
}

impl Pattern {
    fn draw(self, w: usize, h: usize) -> Gray<u8> {
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let (u, v) = ((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64);
                let hash = |seed: u64| render_host::noise::mix64(seed.wrapping_mul(0x1_0000_0001) ^ i as u64);
                let s = |seed| scene_value(u, v, seed).clamp(0.0, 255.0) as u8;
                match self {
                    Pattern::Constant(c) => c,
                    Pattern::Checker { invert } => {
                        if ((x + y) % 2 == 0) != invert {
                            255
                        } else {
                            0
                        }
                    }
                    Pattern::HotPixel { fx, fy } => {
                        let (hx, hy) = ((fx * w as f64) as usize, (fy * h as f64) as usize);
                        if (x, y) == (hx.min(w - 1), hy.min(h - 1)) { 255 } else { 0 }
                    }
                    Pattern::Impulse { seed } => match hash(seed) % 25 {
                        0 => 0,
                        1 => 255,
                        _ => (100.0 + 0.3 * scene_value(u, v, seed)) as u8,
                    },
                    Pattern::RampX => (255 * x / (w - 1).max(1)) as u8,
                    Pattern::RampY => (255 * y / (h - 1).max(1)) as u8,
                    Pattern::Scene { seed } => s(seed),
                    Pattern::InvertedScene { seed } => 255 - s(seed),
                    Pattern::SaturatedScene { seed } => {
                        let glare = (u - 0.8).powi(2) + (v - 0.2).powi(2) < 0.02;
                        if s(seed) > 60 || glare { 255 } else { s(seed) }
                    }
                    Pattern::ColdScene { seed } => s(seed) / 16,
                    Pattern::Noise { seed } => hash(seed) as u8,
                }
            })
            .collect();
        Gray { width: w, height: h, data }
    }
}

/// A frame geometry: VIS size, TIR size and the rescale policy.
#[derive(Debug, Clone, Copy)]
pub struct Geometry {
    /// VIS width, height.
    pub vis: (usize, usize),
    /// TIR width, height.
    pub tir: (usize, usize),
    /// Rescale policy.
    pub rescale: RescalePolicy,
}

impl Geometry {
    fn label(&self) -> String {
        let (v, t) = (self.vis, self.tir);
        match self.rescale {
            RescalePolicy::None => format!("{}×{}", v.0, v.1),
            RescalePolicy::TirUp => format!("{}×{} ← TIR {}×{} ↑", v.0, v.1, t.0, t.1),
            RescalePolicy::VisDown => format!("VIS {}×{} ↓ → {}×{}", v.0, v.1, t.0, t.1),
        }
    }
}

/// The geometries of a run.
pub fn geometries(quick: bool) -> Vec<Geometry> {
    let g = |vis, tir, rescale| Geometry { vis, tir, rescale };
    if quick {
        vec![
            g((24, 24), (24, 24), RescalePolicy::None),
            g((17, 11), (17, 11), RescalePolicy::None),
            g((34, 22), (17, 11), RescalePolicy::TirUp),
            g((33, 21), (17, 11), RescalePolicy::VisDown),
        ]
    } else {
        vec![
            g((64, 64), (64, 64), RescalePolicy::None),
            g((97, 61), (97, 61), RescalePolicy::None),
            g((256, 256), (128, 128), RescalePolicy::TirUp),
            g((97, 61), (49, 31), RescalePolicy::TirUp),
            g((97, 61), (49, 31), RescalePolicy::VisDown),
        ]
    }
}

/// The six method configurations (both variants of each method), with table names.
pub fn methods(quick: bool) -> Vec<(&'static str, Method)> {
    let quick_ifevip = |m: Method| match m {
        Method::Ifevip(p) if quick => {
            Method::Ifevip(IfevipParams { quad_norm_dim: 128, quad_min_dim: 8, ..p })
        }
        m => m,
    };
    Method::all()
        .into_iter()
        .filter(|m| m.variant().is_some())
        .map(|m| (m.name().strip_suffix("-flight").unwrap_or(m.name()), quick_ifevip(m)))
        .collect()
}

/// The largest max abs error (grey levels) between the core's 8-bit output and the MATLAB
/// `uint8` cast of the f64 reference that a case may show, per method.
///
/// * ADF, TSIFSD: 2 levels — the fixed-point state and the weights differ from `f64` by far
///   less than a level, so a difference needs a rounding tie plus the diffusion's table error.
/// * IFEVIP: 3 levels — its published arithmetic casts to `uint8` after each of several steps,
///   so a rounding flipped near a .5 tie in one step moves the next.
/// * ADF with a degenerate eigenvector (`ADF_DEGENERATE_EIGENVECTOR`): no bound, the row is
///   reported, not judged. At an exact eigenvalue tie of the 2×2 covariance (a = c, b = 0 —
///   e.g. two bands that are transposes of each other on a square frame) every direction is an
///   eigenvector: the core's exact integer covariances detect the tie and apply the variant's
///   rule (flight ½, ½; classic p_IR = 1 as MATLAB's `eig`), while the `f64` reference sees
///   c₁₁ − c₂₂ and c₁₂ as rounding noise and `atan2` of that noise picks an arbitrary
///   direction.
/// * Classic ADF whose published weights leave [0, 1] (negatively correlated detail layers,
///   where v₁ + v₂ is small): 2·max(1, |p_IR| + |p_VIS|) levels — the weights multiply the
///   detail layers' fixed-point error (a few hundredths of a level) by their magnitude; this
///   amplification is why the flight variant replaces them.
pub fn bound(method: &Method, guards: Guards, weights: Option<(f64, f64)>) -> Option<u8> {
    match method {
        Method::Adf(_) if guards.contains(Guards::ADF_DEGENERATE_EIGENVECTOR) => None,
        Method::Adf(p) if p.variant == Variant::Classic => {
            let gain = weights.map_or(1.0, |(a, b)| (a.abs() + b.abs()).max(1.0));
            Some((2.0 * gain - 1e-6).ceil().min(255.0) as u8)
        }
        Method::Adf(_) | Method::Tsifsd(_) => Some(2),
        // One exact rational and one rounding: a level only at a rounding tie the f64 sums
        // resolve the other way.
        Method::Adaptive(_) => Some(1),
        Method::Ifevip(_) => Some(3),
    }
}

/// Short names of the guard bits.
pub fn guard_names(g: Guards) -> String {
    let names = [
        (Guards::ADF_ZERO_COVARIANCE, "zero-cov"),
        (Guards::ADF_DEGENERATE_EIGENVECTOR, "degenerate-eig"),
        (Guards::ADF_WEIGHT_CLAMPED, "weight-clamped"),
        (Guards::TSIFSD_ZERO_SALIENCY, "zero-saliency"),
        (Guards::IFEVIP_ZERO_ENTROPY, "zero-entropy"),
        (Guards::IFEVIP_FEW_PIXELS, "few-pixels"),
        (Guards::IFEVIP_ZERO_PEAK, "zero-peak"),
        (Guards::OUTPUT_SATURATED, "saturated"),
    ];
    let list: Vec<&str> = names.iter().filter(|(bit, _)| g.contains(*bit)).map(|(_, n)| *n).collect();
    if list.is_empty() { "–".into() } else { list.join(", ") }
}

/// One row of the stress table.
#[derive(Debug, Clone)]
pub struct Row {
    /// Case name.
    pub case: &'static str,
    /// Geometry label.
    pub geometry: String,
    /// Method name.
    pub method: &'static str,
    /// Pixels where the reference is NaN or ±∞.
    pub ref_nan: usize,
    /// Max |core − reference| of the u8 outputs (finite reference pixels).
    pub max_err: u8,
    /// Pixels whose u8 outputs differ.
    pub differing: usize,
    /// Pixels of the grid.
    pub pixels: usize,
    /// Max |core raw − reference raw| in grey levels (ADF, TSIFSD).
    pub raw_err: Option<f64>,
    /// Guards the core fired.
    pub guards: Guards,
    /// ADF: the f64 reference's KL weights `(p_IR, p_VIS)`.
    pub weights: Option<(f64, f64)>,
    /// Same bytes and report on the second run.
    pub deterministic: bool,
    /// The bound the row is judged against (`None`: reported only).
    pub bound: Option<u8>,
    /// Why the row fails, if it does.
    pub failure: Option<String>,
}

/// Runs the core pipeline with scratch pre-filled with garbage.
fn core_dirty(vis: &Gray<u8>, tir: &Gray<u8>, p: &FuseConfig) -> Result<(Gray<u8>, Guards)> {
    let (vs, ts) = ((vis.width, vis.height), (tir.width, tir.height));
    let (w, h) = fusion_grid(vs, ts, p.rescale)?;
    let n = p.scratch_pixels(vs, ts)?;
    let mut planes: [Vec<i32>; 3] = std::array::from_fn(|k| {
        (0..n)
            .map(|i| (render_host::noise::mix64((k * n + i) as u64) as i32) | i32::from(i % 7 == 0) << 31)
            .collect()
    });
    let mut band: Vec<u8> = (0..n).map(|i| render_host::noise::mix64(i as u64 ^ 0xBAD) as u8).collect();
    let [a, b, c] = &mut planes;
    let mut scratch = ScratchMut::with_band([a, b, c], &mut band);
    let mut out = Gray::<u8>::new(w, h);
    out.data.fill(0x5A);
    let report = fusion_nostd::pipeline::fuse(vis.view()?, tir.view()?, out.view_mut()?, &mut scratch, p)?;
    Ok((out, report.guards))
}

/// The f64 reference's ADF weights `(p_IR, p_VIS)` on the pair as the reference pipeline
/// aligns it (as [`fuse_reference`]: the rescaled band through the f64 rescaler and a u8 cast).
fn reference_kl_weights(vis: &Gray<u8>, tir: &Gray<u8>, p: &FuseConfig, params: &AdfParams) -> (f64, f64) {
    let Ok((w, h)) = fusion_grid((vis.width, vis.height), (tir.width, tir.height), p.rescale) else {
        return (f64::NAN, f64::NAN);
    };
    let on_grid = |img: &Gray<u8>, filter| {
        let img = if (img.width, img.height) == (w, h) {
            img.clone()
        } else {
            reference::rescale::rescale_u8(img, w, h, filter)
        };
        to_f64(&img)
    };
    let (v, t) = (on_grid(vis, Filter::Area), on_grid(tir, Filter::Cubic));
    let (a_v, a_t) = (reference::adf::diffuse(&v, params), reference::adf::diffuse(&t, params));
    let d_v: Vec<f64> = v.data.iter().zip(&a_v.data).map(|(i, a)| i - a).collect();
    let d_t: Vec<f64> = t.data.iter().zip(&a_t.data).map(|(i, a)| i - a).collect();
    reference::adf::kl_weights(&d_t, &d_v, params.variant)
}

/// Runs one case × geometry × method.
pub fn run_one(case: &Case, geometry: &Geometry, name: &'static str, method: Method) -> Row {
    let vis = case.vis.draw(geometry.vis.0, geometry.vis.1);
    let tir = case.tir.draw(geometry.tir.0, geometry.tir.1);
    let p = FuseConfig { rescale: geometry.rescale, method, ..Default::default() };
    let mut row = Row {
        case: case.name,
        geometry: geometry.label(),
        method: name,
        ref_nan: 0,
        max_err: 0,
        differing: 0,
        pixels: 0,
        raw_err: None,
        guards: Guards::NONE,
        weights: None,
        deterministic: false,
        bound: None,
        failure: None,
    };
    let core = std::panic::catch_unwind(AssertUnwindSafe(|| {
        let first = fuse_core(&vis, &tir, &p, true);
        let second = core_dirty(&vis, &tir, &p);
        (first, second)
    }));
    let (first, second) = match core {
        Ok((Ok(a), Ok(b))) => (a, b),
        Ok((a, b)) => {
            let e = a.err().or(b.err()).map(|e| format!("{e:#}")).unwrap_or_default();
            row.failure = Some(format!("core refused a valid input: {e}"));
            return row;
        }
        Err(_) => {
            row.failure = Some("core PANICKED".into());
            return row;
        }
    };
    row.guards = first.guards;
    row.deterministic = first.image == second.0 && first.guards == second.1;
    let reference = match fuse_reference(&vis, &tir, &p) {
        Ok(r) => r,
        Err(e) => {
            row.failure = Some(format!("reference failed: {e:#}"));
            return row;
        }
    };
    let ref_raw = reference.raw.as_ref().map(|r| r.data.as_slice()).unwrap_or(&[]);
    row.pixels = first.image.data.len();
    let mut raw_err = 0.0f64;
    for (i, &c) in first.image.data.iter().enumerate() {
        let r = ref_raw.get(i).copied().unwrap_or(f64::NAN);
        if !r.is_finite() {
            row.ref_nan += 1;
            continue;
        }
        let e = c.abs_diff(matlab_uint8(r));
        row.max_err = row.max_err.max(e);
        row.differing += usize::from(e != 0);
        if let (Some(core_raw), Method::Adf(_) | Method::Tsifsd(_)) = (&first.raw, &method) {
            raw_err = raw_err.max((core_raw.data[i] - r).abs());
        }
    }
    if matches!(method, Method::Adf(_) | Method::Tsifsd(_)) {
        row.raw_err = Some(raw_err);
    }
    if let Method::Adf(params) = &method {
        row.weights = Some(reference_kl_weights(&vis, &tir, &p, params));
    }
    row.bound = bound(&method, row.guards, row.weights);
    row.failure = if !row.deterministic {
        Some("output differs between runs".into())
    } else if row.bound.is_some_and(|b| row.max_err > b) {
        Some(format!("max error {} above the bound {}", row.max_err, row.bound.unwrap_or(0)))
    } else {
        None
    };
    row
}

/// Runs every case, geometry and method (in parallel) and returns the rows in table order.
pub fn run_all(quick: bool) -> Vec<Row> {
    let jobs: Vec<(Case, Geometry, &'static str, Method)> = cases()
        .into_iter()
        .flat_map(|c| {
            geometries(quick)
                .into_iter()
                .flat_map(move |g| methods(quick).into_iter().map(move |(n, m)| (c, g, n, m)))
        })
        .collect();
    jobs.par_iter().map(|(c, g, n, m)| run_one(c, g, n, *m)).collect()
}

/// Every run as a Markdown table: a row per case, geometry and method.
pub fn full_table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| case | geometry | method | ref NaN px | max err | px ≠ | raw err | ADF ref weights | guards | det | bound | verdict |\n\
         |---|---|---|---:|---:|---:|---:|---|---|---|---:|---|\n",
    );
    for r in rows {
        let raw = r.raw_err.map_or("–".into(), |e| format!("{e:.3}"));
        let bound = r.bound.map_or("–".into(), |b| b.to_string());
        let weights = r.weights.map_or("–".into(), |(a, b)| format!("{a:.3}, {b:.3}"));
        let verdict = r.failure.clone().unwrap_or_else(|| "ok".into());
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {}/{} | {} | {} | {} | {} | {} | {} |",
            r.case,
            r.geometry,
            r.method,
            r.ref_nan,
            r.max_err,
            r.differing,
            r.pixels,
            raw,
            weights,
            guard_names(r.guards),
            if r.deterministic { "yes" } else { "NO" },
            bound,
            verdict
        );
    }
    s
}

/// The summary: one row per case, one column per method: the max error over the geometries,
/// `N nan` when the reference had NaN pixels, and the guards fired (union over geometries).
pub fn summary_table(rows: &[Row], quick: bool) -> String {
    let names: Vec<&str> = methods(quick).iter().map(|(n, _)| *n).collect();
    let mut s = format!("| case | {} |\n|---|{}\n", names.join(" | "), "---|".repeat(names.len()));
    for case in cases() {
        let mut cells = Vec::new();
        for name in &names {
            let mine: Vec<&Row> = rows.iter().filter(|r| r.case == case.name && r.method == *name).collect();
            let err = mine.iter().map(|r| r.max_err).max().unwrap_or(0);
            let nan: usize = mine.iter().map(|r| r.ref_nan).sum();
            let guards = mine.iter().fold(Guards::NONE, |g, r| g | r.guards);
            let failed = mine.iter().any(|r| r.failure.is_some());
            let mut cell = format!("{err}");
            if nan > 0 {
                let _ = write!(cell, ", ref NaN {nan} px");
            }
            let g = Guards(guards.0 & !Guards::OUTPUT_SATURATED.0);
            if !g.is_empty() {
                let _ = write!(cell, " [{}]", guard_names(g));
            }
            if failed {
                cell.push_str(" **FAIL**");
            }
            cells.push(cell);
        }
        let _ = writeln!(s, "| {} | {} |", case.name, cells.join(" | "));
    }
    s
}
