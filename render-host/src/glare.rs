//! The sun in or near the visible camera's field of view: its disc, the optics' stray light
//! around it, and the detector's blooming — the glare a sunward look gives a visible camera.
//!
//! Applied to a VIS render before it is clipped (values are in the renderer's unit, where a
//! white Lambertian face square to the sun reads `exposure`), in three steps:
//!
//! 1. **The solar disc** where a pixel sees empty space: the sun's radiance in that unit is
//!    `1 / α²` (a disc of solid angle `π α²` giving the irradiance that makes a white face
//!    read 1, so its radiance is `π / (π α²)` times a white face's `1 / π`), 46 200 at the
//!    sun's angular radius α = 0.2665° ([`crate::sequence::SUN_ANGULAR_RADIUS`]), times the
//!    visible fraction of the disc (a partly eclipsed sun spread over its disc) and the
//!    exposure; each pixel integrates a 4 × 4 grid of rays, so the disc's edge is
//!    anti-aliased.
//! 2. **Stray light** from the optics (scatter off the lens surfaces, the baffle's edges) on
//!    every pixel, in or out of view of the sun: `stray · (1° / θ)^exponent` times the sun's
//!    visible fraction and the exposure, `θ` the angle between the pixel's ray and the sun
//!    (no less than α) — with the defaults a halo that saturates within ≈ 0.7° of the sun,
//!    reads ≈ 5 grey levels 5° away and ≈ 0.3 at 20°.
//! 3. **Blooming** along columns: a pixel's charge above the full well (1.0) spills up and
//!    down its column, half each way, filling the pixels it reaches to the full well; the
//!    fraction `blooming` of the excess spills (1: a CCD without an anti-blooming drain, 0: a
//!    CMOS array, where nothing spills), the rest drains, and what reaches the column's ends
//!    is lost. This acts on every saturated pixel, so the target's specular glints bloom too.
//!
//! The sequences apply it with [`SequenceConfig::glare`](crate::sequence::SequenceConfig)
//! (`fusion render --sequence … --glare`); without it every render is as before.

use crate::camera::Camera;
use crate::image::Image;
use crate::sequence::SUN_ANGULAR_RADIUS;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The glare model's parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GlareParams {
    /// Stray light 1° from the sun, relative to a white face square to the sun.
    pub stray: f32,
    /// How fast the stray light falls with the angle from the sun.
    pub stray_exponent: f32,
    /// Fraction of the charge above the full well that spills along the column.
    pub blooming: f32,
}

impl Default for GlareParams {
    /// Stray light 0.5 at 1° falling as `θ⁻²`; an anti-blooming drain that lets one part in
    /// ten thousand of the excess spill (the sun's disc in a 1024² frame then streaks ≈ 50 rows
    /// up and down its columns; 1e-3 streaks the whole column).
    fn default() -> Self {
        GlareParams { stray: 0.5, stray_exponent: 2.0, blooming: 1e-4 }
    }
}

impl GlareParams {
    /// Refuses parameters no camera has (negative or not finite).
    pub fn check(&self) -> Result<(), String> {
        let ok = |v: f32| v.is_finite() && v >= 0.0;
        if !(ok(self.stray) && ok(self.stray_exponent) && ok(self.blooming) && self.blooming <= 1.0) {
            return Err(format!(
                "glare: stray {}, exponent {} and blooming {} must be finite and non-negative, blooming at most 1",
                self.stray, self.stray_exponent, self.blooming
            ));
        }
        Ok(())
    }
}

/// The sun's radiance in the renderer's unit per unit exposure (`1 / α²`).
pub fn sun_radiance() -> f32 {
    (1.0 / (SUN_ANGULAR_RADIUS * SUN_ANGULAR_RADIUS)) as f32
}

/// Adds the solar disc (where `open[i]`: pixel `i` sees empty space) and the stray light to
/// `img`, seen by `cam`, the sun along the unit `sun` (the camera's frame of reference, as its
/// rays), `fraction` of its disc visible, at `exposure`.
pub fn add_sun(
    img: &mut Image,
    cam: &Camera,
    sun: Vec3,
    fraction: f32,
    exposure: f32,
    open: &[bool],
    p: &GlareParams,
) {
    if fraction <= 0.0 {
        return;
    }
    let sun = sun.normalize();
    let alpha = SUN_ANGULAR_RADIUS as f32;
    let one_degree = 1f32.to_radians();
    // Beyond this angle from the sun no sub-pixel ray can fall on the disc (a pixel is less
    // than a degree across in any camera here).
    let near = alpha + one_degree;
    for y in 0..img.height {
        for x in 0..img.width {
            let i = (y * img.width + x) as usize;
            let theta = cam.pixel_ray(x, y).dot(sun).clamp(-1.0, 1.0).acos();
            let mut v = p.stray * (one_degree / theta.max(alpha)).powf(p.stray_exponent);
            if open.get(i).copied().unwrap_or(false) && theta < near {
                let inside = Camera::subpixels(x, y, 4)
                    .filter(|&(u, w)| cam.ray_dir(u, w).dot(sun).clamp(-1.0, 1.0).acos() < alpha)
                    .count();
                v += sun_radiance() * inside as f32 / 16.0;
            }
            img.data[i] += v * fraction * exposure;
        }
    }
}

/// Spills `fraction` of every pixel's charge above `full_well` along its column, half up and
/// half down, filling the pixels it reaches to the full well (see the module docs).
pub fn bloom(img: &mut Image, full_well: f32, fraction: f32) {
    let (w, h) = (img.width as usize, img.height as usize);
    if fraction <= 0.0 {
        return;
    }
    for x in 0..w {
        let mut y = 0;
        while y < h {
            if img.data[y * w + x] <= full_well {
                y += 1;
                continue;
            }
            // A saturated run [a, b): its excess, the run capped at the full well.
            let a = y;
            let mut excess = 0.0f64;
            while y < h && img.data[y * w + x] > full_well {
                excess += f64::from(img.data[y * w + x] - full_well);
                img.data[y * w + x] = full_well;
                y += 1;
            }
            let half = excess * f64::from(fraction) / 2.0;
            let mut fill = |rows: &mut dyn Iterator<Item = usize>| {
                let mut left = half;
                for r in rows {
                    if left <= 0.0 {
                        break;
                    }
                    let v = &mut img.data[r * w + x];
                    let room = f64::from(full_well - *v).max(0.0);
                    let take = room.min(left);
                    *v += take as f32;
                    left -= take;
                }
            };
            fill(&mut (0..a).rev());
            fill(&mut (y..h));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Pose;

    #[test]
    fn blooming_conserves_the_spilled_charge_and_spills_both_ways() {
        let mut img = Image::new(1, 40);
        img.data[20] = 11.0; // 10 above the full well
        let before: f64 = img.data.iter().map(|&v| f64::from(v)).sum();
        bloom(&mut img, 1.0, 0.5);
        let after: f64 = img.data.iter().map(|&v| f64::from(v)).sum();
        // Half of the 10 spilled (2.5 each way): the column gained 5 − 10 = −5.
        assert!((after - (before - 5.0)).abs() < 1e-5, "{before} -> {after}");
        assert!(img.data.iter().all(|&v| v <= 1.0));
        // 2.5 up: rows 19, 18 full, row 17 half; the same down.
        assert_eq!(&img.data[17..24], &[0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5]);
        assert_eq!(img.data[16], 0.0);
        // No drain on a column end: what reaches it is lost, nothing wraps.
        let mut edge = Image::new(1, 4);
        edge.data[0] = 9.0;
        bloom(&mut edge, 1.0, 1.0);
        assert_eq!(edge.data, vec![1.0, 1.0, 1.0, 1.0]);
        // Nothing spills without blooming.
        let mut cmos = Image::new(1, 5);
        cmos.data[2] = 3.0;
        bloom(&mut cmos, 1.0, 0.0);
        assert_eq!(cmos.data, vec![0.0, 0.0, 3.0, 0.0, 0.0]);
    }

    #[test]
    fn the_sun_disc_has_its_angular_size_and_radiance() {
        // A 512² camera looking straight at the sun: the disc's pixels (centre within α) sum
        // to the disc's area in pixels, π (α f)², each at the sun's radiance.
        let cam = Camera::study(512, Pose::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y));
        let mut img = Image::new(512, 512);
        let open = vec![true; 512 * 512];
        let no_stray = GlareParams { stray: 0.0, ..GlareParams::default() };
        add_sun(&mut img, &cam, Vec3::Z, 1.0, 1.0, &open, &no_stray);
        let area: f64 = img.data.iter().map(|&v| f64::from(v)).sum::<f64>() / f64::from(sun_radiance());
        let f = f64::from(cam.focal_px);
        let expect = std::f64::consts::PI * (SUN_ANGULAR_RADIUS * f).powi(2);
        assert!((area - expect).abs() < 0.03 * expect, "{area} px against {expect}");
        // A closed pixel (the target in front) shows no disc, only stray light.
        let mut img2 = Image::new(512, 512);
        let mut shut = open.clone();
        shut[256 * 512 + 256] = false;
        add_sun(&mut img2, &cam, Vec3::Z, 1.0, 1.0, &shut, &no_stray);
        assert_eq!(img2.data[256 * 512 + 256], 0.0);
        // Half the disc visible: half the radiance.
        let mut half = Image::new(512, 512);
        add_sun(&mut half, &cam, Vec3::Z, 0.5, 1.0, &open, &no_stray);
        assert!((half.data[256 * 512 + 256] - 0.5 * img.data[256 * 512 + 256]).abs() < 1.0);
    }

    #[test]
    fn stray_light_falls_as_the_power_law() {
        // The sun along +z, a camera looking 10° away: a pixel's stray light is
        // 0.5 · (1°/θ)² with θ its own ray's angle from the sun.
        let axis = glam::Quat::from_rotation_x(10f32.to_radians()) * Vec3::Z;
        let cam = Camera::study(64, Pose::look_at(Vec3::ZERO, axis, Vec3::Y));
        let mut img = Image::new(64, 64);
        add_sun(&mut img, &cam, Vec3::Z, 1.0, 0.8, &vec![true; 64 * 64], &GlareParams::default());
        for (x, y) in [(0, 0), (32, 32), (63, 10)] {
            let theta = cam.pixel_ray(x, y).dot(Vec3::Z).acos();
            let expect = 0.8 * 0.5 * (1f32.to_radians() / theta).powi(2);
            let got = img.data[(y * 64 + x) as usize];
            assert!((got - expect).abs() < 1e-4 * expect, "({x}, {y}): {got} against {expect}");
        }
        // An eclipsed sun gives nothing.
        let mut dark = Image::new(64, 64);
        add_sun(&mut dark, &cam, Vec3::Z, 0.0, 0.8, &vec![true; 64 * 64], &GlareParams::default());
        assert!(dark.data.iter().all(|&v| v == 0.0));
    }
}
