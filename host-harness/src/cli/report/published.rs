//! The study's published numbers (Tables 2–7) that `report.md` puts beside ours.

#[allow(unused_imports)]
use super::*;

/// The study's numbers (docs/reference/study-results.md) for the rows we have.
pub(super) fn study_t2(r: &str) -> (f64, f64, f64) {
    match r {
        "area" => (0.0065, 22.13, 0.48),
        "bicubic" => (0.0063, 22.29, 0.49),
        _ => (0.0063, 22.24, 0.48),
    }
}

pub(super) fn study_t3(r: &str, ill: &str) -> (f64, f64, f64) {
    match (r, ill) {
        ("area", "eclipse") => (0.00075, 31.34, 0.57),
        ("bicubic", "eclipse") => (0.00094, 30.34, 0.54),
        ("lanczos3", "eclipse") => (0.00104, 29.87, 0.51),
        ("area", _) => (0.0022, 27.19, 0.56),
        ("bicubic", _) => (0.0024, 26.70, 0.53),
        _ => (0.0025, 26.48, 0.50),
    }
}

/// Study rows of Tables 4 and 5 (eclipse only; TSIFSD classic and flight share the TSIFSD row).
pub(super) fn study_t45(table: &str, method: &str) -> Option<[f64; 5]> {
    let up = table == "t4";
    Some(match (method.split('-').next()?, up) {
        ("adf", true) => [14.66, 0.98, 0.848, 1.96, 12.31],
        ("adf", false) => [14.56, 1.232, 0.867, 0.976, 12.04],
        ("tsifsd", true) => [13.10, 0.84, 0.835, 1.95, 11.97],
        ("tsifsd", false) => [10.89, 0.842, 0.893, 1.076, 11.7],
        ("ifevip", true) => [20.35, 1.50, 0.818, 1.26, 15.52],
        ("ifevip", false) => [16.67, 1.91, 0.906, 1.03, 14.72],
        ("gff", true) => [15.35, 1.52, 0.878, 1.94, 11.76],
        ("gff", false) => [15.39, 1.51, 0.927, 1.00, 11.62],
        ("mgff", true) => [16.13, 1.01, 0.837, 1.94, 12.14],
        ("mgff", false) => [13.74, 1.05, 0.900, 1.160, 11.90],
        ("tepgfl", true) => [14.97, 0.94, 0.784, 1.12, 18.63],
        ("tepgfl", false) => [12.94, 0.873, 0.831, 0.437, 17.6],
        _ => return None,
    })
}

/// Study PSNR_S of Table 6: (eclipse, light).
pub(super) fn study_t6_psnr(method: &str, input: &str) -> Option<(f64, f64)> {
    Some(match (method.split('-').next()?, input) {
        ("adf", "VIS down") => (25.58, 24.35),
        ("adf", "TIR up") => (29.20, 29.12),
        ("adf", "same res") => (29.36, 29.32),
        ("tsifsd", "VIS down") => (25.69, 24.50),
        ("tsifsd", "TIR up") => (29.97, 29.85),
        ("tsifsd", "same res") => (30.44, 30.26),
        ("ifevip", "VIS down") => (21.21, 20.00),
        ("ifevip", "TIR up") => (26.10, 26.06),
        ("ifevip", "same res") => (25.86, 25.84),
        ("gff", "VIS down") => (22.22, 22.82),
        ("gff", "TIR up") => (24.91, 26.67),
        ("gff", "same res") => (28.56, 29.13),
        ("mgff", "VIS down") => (24.96, 23.89),
        ("mgff", "TIR up") => (28.84, 28.73),
        ("mgff", "same res") => (28.58, 28.45),
        ("tepgfl", "VIS down") => (21.14, 21.81),
        ("tepgfl", "TIR up") => (23.97, 26.21),
        ("tepgfl", "same res") => (24.64, 26.55),
        ("drif", "different res") => (27.12, 26.30),
        _ => return None,
    })
}

pub(super) fn study_t7(method: &str) -> Option<(f64, f64)> {
    Some(match method.split('-').next()? {
        "adf" => (0.012, 0.045),
        "tsifsd" => (0.013, 0.056),
        "ifevip" => (0.024, 0.094),
        "gff" => (0.153, 0.549),
        "mgff" => (0.136, 0.536),
        "tepgfl" => (0.241, 1.040),
        // "~6 s (different resolution)": VIS 1024² with TIR 512², output on the 1024² grid
        "drif" => (f64::NAN, 6.0),
        _ => return None,
    })
}
