//! TIR rendering: every face is a Lambertian emitter at its temperature; no lights, no shadows;
//! behind the target black space or the Earth ([`render_tir_over`], [`crate::earth`]).
//!
//! Two radiometric modes:
//! - [`Radiometry::Radiometric`] (default): a resolved Lambertian emitter traced with one ray per
//!   pixel is seen with radiance `L = ε σ T⁴ / π`, times the lens's `cos⁴ θ` fall-off off axis.
//! - [`Radiometry::Study`]: the published facet-to-camera view-factor weighting,
//!   `q = F ε σ T⁴` with `F ≈ (n̂_c·ŝ)(n̂_f·ŝ) A_c / (π S²)`. We report it as an equivalent
//!   radiance `L = (n̂_c·ŝ)(n̂_f·ŝ) (S_ref/S)² ε σ T⁴ / π`, i.e. `F` normalised by its value for
//!   a facet seen face-on, on axis, at the reference range `S_ref` (where both modes agree).
//!   It counts distance and facet obliquity on top of what a pixel already integrates.
//!
//! DN: a fixed temperature range `[T_min, T_max]` (not each frame's min/max) maps to [0, 1].
//! [`DnMapping::Temperature`] (default) maps the brightness temperature `T_b = (πL/σ)^¼`
//! linearly, `v = (T_b − T_min) / (T_max − T_min)`; [`DnMapping::Radiance`] maps the radiance,
//! `v = (L − L(T_min)) / (L(T_max) − L(T_min))` with `L(T) = σT⁴/π` (a black body). Space
//! (≈ 3 K) falls below `T_min` and clips to 0.

use crate::camera::Camera;
use crate::earth::{EarthPixel, EarthView};
use crate::image::Image;
use crate::scene::Scene;
use crate::thermal::SIGMA;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// How a pixel's value follows from the temperature of the face it sees.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Radiometry {
    /// Radiance `εσT⁴/π` with `cos⁴` fall-off (physically right).
    Radiometric,
    /// The study's view-factor weighting `F ε σ T⁴`.
    Study,
}

/// How radiance becomes a [0, 1] value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum DnMapping {
    /// Linear in radiance between `L(T_min)` and `L(T_max)` (a raw microbolometer signal is
    /// linear in flux). Over 150–400 K a 300 K black body lands at 0.30 and MLI (ε = 0.63) at
    /// 0.18: the frames use a quarter of the range.
    Radiance,
    /// Linear in brightness temperature `(πL/σ)^¼` between `T_min` and `T_max` (the default,
    /// like a radiometric camera's temperature-scaled video; 300 K black body → 0.60).
    Temperature,
}

/// Parameters of a TIR render.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TirParams {
    /// Radiometric mode.
    pub radiometry: Radiometry,
    /// DN mapping.
    pub dn_mapping: DnMapping,
    /// Temperature mapped to 0, K.
    pub t_min: f64,
    /// Temperature mapped to 1 (full scale), K.
    pub t_max: f64,
    /// Reference range `S_ref` of the study mode, m.
    pub study_reference_range: f64,
    /// Unit vector from the target towards the Earth (target frame): with surface detail, the
    /// faces mirror the Earth's infrared glow where their relief turns the reflected ray
    /// towards it (see [`render_tir`]). Manifests without the field read the default.
    #[serde(default = "crate::vis::default_earth_dir")]
    pub earth_dir: glam::Vec3,
    /// Sub-pixel samples per axis: each pixel averages the radiance of `n × n` rays over its
    /// area (as [`crate::VisParams::samples`]). Written datasets without the field read 1.
    #[serde(default = "crate::vis::one_sample", skip_serializing_if = "crate::vis::is_one_sample")]
    pub samples: u32,
}

/// Brightness temperature of the Earth's infrared emission seen from orbit, K (≈ 240 W/m²).
pub const EARTH_IR_TEMPERATURE_K: f64 = 255.0;

/// Cosine of the Earth's angular radius seen from low orbit (≈ 68° at 500 km altitude).
pub const EARTH_COS_HALF_ANGLE: f32 = 0.37;

impl Default for TirParams {
    fn default() -> Self {
        TirParams {
            radiometry: Radiometry::Radiometric,
            dn_mapping: DnMapping::Temperature,
            t_min: 150.0,
            t_max: 400.0,
            // The mean of the ellipse's semi-axes (7.25 m, 4 m).
            study_reference_range: 5.625,
            earth_dir: crate::vis::default_earth_dir(),
            samples: 1,
        }
    }
}

impl TirParams {
    /// Black-body radiance `σT⁴/π`, W/(m² sr).
    pub fn blackbody_radiance(t: f64) -> f64 {
        SIGMA * t.powi(4) / PI
    }

    /// The [0, 1] value (unclipped) of radiance `l`.
    pub fn value_of_radiance(&self, l: f64) -> f64 {
        match self.dn_mapping {
            DnMapping::Radiance => {
                let (lo, hi) = (Self::blackbody_radiance(self.t_min), Self::blackbody_radiance(self.t_max));
                (l - lo) / (hi - lo)
            }
            DnMapping::Temperature => {
                let tb = (PI * l.max(0.0) / SIGMA).powf(0.25);
                (tb - self.t_min) / (self.t_max - self.t_min)
            }
        }
    }
}

/// Renders one TIR frame from per-face temperatures (K, indexed like [`Scene::faces`]).
/// Values are in [0, 1] after the DN mapping, unclipped (the DN conversion clips).
pub fn render_tir(scene: &Scene, camera: &Camera, face_temperatures: &[f32], params: &TirParams) -> Image {
    render_tir_over(scene, camera, face_temperatures, params, None)
}

/// [`render_tir`] with the Earth behind the target where a ray misses it (`None`: black space,
/// the same bytes as [`render_tir`]); its radiance takes the lens's `cos⁴` fall-off in both
/// radiometric modes (the study's view factor is the target's facets', not the Earth's).
pub fn render_tir_over(
    scene: &Scene,
    camera: &Camera,
    face_temperatures: &[f32],
    params: &TirParams,
    background: Option<&EarthView>,
) -> Image {
    let mut img = Image::new(camera.width, camera.height);
    let w = camera.width as usize;
    let axis = camera.pose.forward();
    let earth = params.earth_dir.normalize_or_zero();
    let earth_radiance = TirParams::blackbody_radiance(EARTH_IR_TEMPERATURE_K);
    let n = params.samples.max(1);
    // The footprint divisor: a sub-pixel sees 1/n of the pixel's footprint.
    let focal = camera.focal_px * n as f32;
    // The radiance along the ray `d` (0: space).
    // The radiance of the target along the ray `d` (`None`: the ray misses it).
    let radiance = |d: glam::Vec3| -> Option<f64> {
        let hit = scene.intersect(camera.pose.position, d, 0.0)?;
        let face = &scene.faces[hit.face as usize];
        let t = f64::from(face_temperatures.get(hit.face as usize).copied().unwrap_or(0.0));
        let (t, eps, reflected) = match &scene.detail {
            Some(detail) => {
                let s = detail.at(&scene.faces, hit.face, hit.point, hit.t / focal, t);
                // The relief's mirror image of the Earth: (1 − ε) of its radiance where the
                // reflected ray points inside the Earth's disc (soft limb).
                let n = if s.normal.dot(d) > 0.0 { -s.normal } else { s.normal };
                let r = d - 2.0 * d.dot(n) * n;
                let c = r.dot(earth);
                let cover = ((c - EARTH_COS_HALF_ANGLE) / 0.1 + 0.5).clamp(0.0, 1.0);
                (t + s.delta_t, s.emittance, (1.0 - s.emittance) * f64::from(cover) * earth_radiance)
            }
            None => (t, face.material.props().ir_emittance, 0.0),
        };
        let cos_c = f64::from(axis.dot(d)).max(0.0);
        let weight = match params.radiometry {
            Radiometry::Radiometric => cos_c.powi(4),
            Radiometry::Study => {
                let cos_f = f64::from(face.normal.dot(d)).abs();
                let s = f64::from(hit.t);
                cos_c * cos_f * (params.study_reference_range / s).powi(2)
            }
        };
        Some(weight * (eps * TirParams::blackbody_radiance(t) + reflected))
    };
    img.data.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        for (x, px) in row.iter_mut().enumerate() {
            let mut behind = background
                .map(|e| EarthPixel::new(e, camera.pose.position, camera.pixel_ray(x as u32, y as u32)));
            let sum: f64 = Camera::subpixels(x as u32, y as u32, n)
                .map(|(u, v)| {
                    let d = camera.ray_dir(u, v);
                    radiance(d).unwrap_or_else(|| {
                        let lens = f64::from(axis.dot(d)).max(0.0).powi(4);
                        behind.as_mut().map_or(0.0, |b| lens * b.sample(d, EarthView::tir_radiance))
                    })
                })
                .sum();
            *px = params.value_of_radiance(sum / f64::from(n * n)) as f32;
        }
    });
    img
}
