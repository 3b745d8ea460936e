//! VIS rendering: sun-lit Lambertian shading with an optional Blinn–Phong lobe, shadow rays,
//! black space or the Earth behind the target ([`render_vis_over`], [`crate::earth`]).

use crate::camera::Camera;
use crate::earth::{EarthPixel, EarthView};
use crate::image::Image;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Illumination of a VIS frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Illumination {
    /// In sunlight.
    Light,
    /// In the Earth's shadow: no sun, only the (optional, weak) earthshine.
    Eclipse,
}

/// Default exposure: sunlit MLI (albedo 0.45) at 45° incidence lands at 0.64, a white-paint face
/// near normal incidence and specular glints saturate, as in the study's in-light frames.
pub const DEFAULT_EXPOSURE: f32 = 2.0;

/// Light sources and exposure of a VIS render.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct VisParams {
    /// Light or eclipse.
    pub illumination: Illumination,
    /// Unit vector from the target towards the sun (target frame).
    pub sun_dir: Vec3,
    /// Unit vector from the target towards the Earth (source of the earthshine).
    pub earth_dir: Vec3,
    /// Earthshine irradiance relative to the sun's (0 = none). Applies in both illuminations.
    pub earthshine: f32,
    /// Scale from reflected irradiance (sun = 1) to the [0, 1] pixel value. Fixed for a whole
    /// dataset (no auto-exposure), so light and eclipse frames compare directly.
    pub exposure: f32,
    /// Add the specular lobe.
    pub specular: bool,
    /// Fraction of the solar disc visible (penumbra: between 0 and 1; `Eclipse` overrides it to
    /// 0). Written datasets without the field read as 1.
    #[serde(default = "full_sun")]
    pub sun_fraction: f32,
    /// Sub-pixel samples per axis: each pixel averages `n × n` rays over its area
    /// ([`Camera::subpixels`]), the surface detail filtered over each sub-pixel's footprint.
    /// 1 (one ray through the pixel centre, the study's datasets) point-samples the scene:
    /// detail finer than a few pixels then aliases and slides against the surface as the view
    /// turns, which a feature tracker sees as drift. Written datasets without the field read 1.
    #[serde(default = "one_sample", skip_serializing_if = "is_one_sample")]
    pub samples: u32,
}

fn full_sun() -> f32 {
    1.0
}

/// One sample per pixel (the pixel centre).
pub(crate) fn one_sample() -> u32 {
    1
}

/// Whether `samples` is the default (not written: the study's manifests stay as they were).
pub(crate) fn is_one_sample(samples: &u32) -> bool {
    *samples == 1
}

impl VisParams {
    /// In sunlight, with the default sun and earth directions and exposure
    /// [`DEFAULT_EXPOSURE`].
    pub fn light() -> VisParams {
        VisParams {
            illumination: Illumination::Light,
            sun_dir: default_sun_dir(),
            earth_dir: default_earth_dir(),
            earthshine: 0.02,
            exposure: DEFAULT_EXPOSURE,
            specular: true,
            sun_fraction: 1.0,
            samples: 1,
        }
    }

    /// In eclipse: the same geometry, sun blocked, weak earthshine.
    pub fn eclipse() -> VisParams {
        VisParams { illumination: Illumination::Eclipse, ..VisParams::light() }
    }

    /// Builder: the same parameters with another illumination.
    pub fn with_illumination(self, illumination: Illumination) -> VisParams {
        VisParams { illumination, ..self }
    }
}

/// The default sun direction (target frame): above the solar panel, off to +x/+y, so the panel
/// is lit and its overhang shadows the bus sides.
pub fn default_sun_dir() -> Vec3 {
    Vec3::new(0.45, 0.35, 0.82).normalize()
}

/// The default earth direction (target frame): below the bus (nadir-pointing panel up).
pub fn default_earth_dir() -> Vec3 {
    Vec3::new(-0.2, 0.1, -1.0).normalize()
}

/// Renders one VIS frame: [`VisParams::samples`]² primary rays per pixel (one through the
/// centre by default), a shadow ray per light per hit. Pixel values are linear in reflected
/// radiance, `exposure × (albedo cos θ_s + specular)` averaged over the pixel, not clipped (the
/// DN conversion clips).
pub fn render_vis(scene: &Scene, camera: &Camera, params: &VisParams) -> Image {
    render_vis_over(scene, camera, params, None)
}

/// [`render_vis`] with the Earth behind the target where a ray misses it (`None`: black
/// space, the same bytes as [`render_vis`]). The Earth's radiance takes the same exposure.
pub fn render_vis_over(
    scene: &Scene,
    camera: &Camera,
    params: &VisParams,
    earth: Option<&EarthView>,
) -> Image {
    let mut img = Image::new(camera.width, camera.height);
    let w = camera.width as usize;
    let n = params.samples.max(1);
    // The footprint divisor: a sub-pixel sees 1/n of the pixel's footprint.
    let focal = camera.focal_px * n as f32;
    img.data.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        for (x, px) in row.iter_mut().enumerate() {
            let mut behind =
                earth.map(|e| EarthPixel::new(e, camera.pose.position, camera.pixel_ray(x as u32, y as u32)));
            let sum: f32 = Camera::subpixels(x as u32, y as u32, n)
                .map(|(u, v)| {
                    let d = camera.ray_dir(u, v);
                    shade(scene, camera, params, d, focal).unwrap_or_else(|| {
                        behind
                            .as_mut()
                            .map_or(0.0, |b| params.exposure * b.sample(d, EarthView::vis_radiance) as f32)
                    })
                })
                .sum();
            *px = sum / (n * n) as f32;
        }
    });
    img
}

/// The radiance of the target seen along the ray `d` (`None`: the ray misses it); a hit at
/// range `t` sees a footprint of `t / focal` metres.
fn shade(scene: &Scene, camera: &Camera, p: &VisParams, d: Vec3, focal: f32) -> Option<f32> {
    let origin = camera.pose.position;
    let hit = scene.intersect(origin, d, 0.0)?;
    let props = scene.faces[hit.face as usize].material.props();
    let (albedo, specular, shading_normal) = match &scene.detail {
        Some(detail) => {
            let s = detail.at(&scene.faces, hit.face, hit.point, hit.t / focal, 0.0);
            (s.albedo, s.specular, s.normal)
        }
        None => (props.diffuse_albedo, props.specular, hit.normal),
    };
    // Two-sided shading: the normals facing the camera.
    let facing = if hit.normal.dot(d) > 0.0 { -1.0 } else { 1.0 };
    let n_geo = facing * hit.normal;
    let n = facing * shading_normal;
    let start = hit.point + n_geo * scene.epsilon();
    let mut lights: [(Vec3, f32); 2] = [(p.sun_dir, p.sun_fraction), (p.earth_dir, p.earthshine)];
    if p.illumination == Illumination::Eclipse {
        lights[0].1 = 0.0;
    }
    let mut value = 0.0;
    for (l, e) in lights {
        let cos = n.dot(l);
        if e <= 0.0 || cos <= 0.0 || n_geo.dot(l) <= 0.0 || scene.occluded(start, l, 0.0, f32::INFINITY) {
            continue;
        }
        let mut v = albedo * cos;
        if p.specular {
            let h = (l - d).normalize();
            v += specular * n.dot(h).max(0.0).powf(props.shininess);
        }
        value += e * v;
    }
    Some(p.exposure * value)
}
