//! The Earth behind the target, in both bands: a sphere of the Earth's mean radius below the
//! orbit, drawn where a camera ray misses the target.
//!
//! **Geometry** (the target body frame, metres): the Earth's centre lies along the unit vector
//! `towards` at `R_E + altitude` from the scene's centre; a ray from the camera that hits the
//! sphere sees the surface point there, one that passes within the atmosphere's few scale
//! heights of it sees the limb's glow. The surface pattern is fixed to the Earth: a direction in
//! the body frame is turned into the Earth-fixed frame by [`EarthView::to_surface`] (the
//! sequences turn it with the target's attitude and with the ground moving under the orbit), so
//! clouds and coasts move across the frames as they would.
//!
//! **The surface**, seeded and deterministic (3-D Perlin fBm on the unit sphere): ocean and land
//! (about 30 % land), and a cloud field covering about half of it. Per point a *cloud cover*
//! `c` ∈ [0, 1] (optical thickness ramps over the field's top) mixes the clear surface with the
//! cloud.
//!
//! **VIS** (reflected radiance in the renderer's unit, sun irradiance = 1, like the target's
//! `albedo cos θ`): `a cos θ_s` with albedos ocean [`OCEAN_ALBEDO`], land [`LAND_ALBEDO`]
//! (± the field's variation), cloud [`CLOUD_ALBEDO`] (thin to thick); the terminator softened
//! over ±[`TWILIGHT`] of `cos θ_s`; the night side black. The atmosphere adds a thin bright limb:
//! along a ray whose closest approach to the surface is at height `h` (or that hits it at
//! emission cosine `μ`), the slant optical depth of a layer of scale height [`SCALE_HEIGHT_M`] is
//! `τ₀ √(2πR/H) e^{−h/H}` (grazing) or `τ₀/μ` (hitting), and the glow is
//! [`LIMB_RADIANCE`]` · (1 − e^{−τ})` where the point below is sunlit.
//!
//! **TIR** (brightness temperature → the band's radiance, [`crate::tir`]): clear ocean
//! `280 + 12 cos φ` K (φ latitude in the Earth-fixed frame), clear land `278 + 30 max(0, cos θ_s)`
//! K (warm by day, cool at night), cloud tops from 265 K (thin, low) to 220 K (thick, high); the
//! cloud cover mixes radiances. Limb darkening by the same slab atmosphere at [`ATMOSPHERE_K`]:
//! `L = B(T) e^{−τ_ir/μ} + B(T_atm)(1 − e^{−τ_ir/μ})`, and a grazing ray sees `B(T_atm)(1 −
//! e^{−τ})`. So the Earth's thermal contrast with the target spans the target's own range: cold
//! cloud tops below a 260 K panel, warm clear ground above it.

use glam::{DQuat, DVec3, Vec3};
use noise::{NoiseFn, Perlin};
use serde::{Deserialize, Serialize};

/// The Earth's mean radius, m.
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;
/// Default orbit altitude, m (low Earth orbit).
pub const DEFAULT_ALTITUDE_M: f64 = 500_000.0;
/// Gravitational parameter of the Earth, m³/s².
pub const EARTH_MU: f64 = 3.986_004_418e14;
/// Albedo of clear ocean.
pub const OCEAN_ALBEDO: f64 = 0.06;
/// Mean albedo of clear land (vegetation to desert: ± 0.08 across the field).
pub const LAND_ALBEDO: f64 = 0.2;
/// Albedo of thin and of thick cloud.
pub const CLOUD_ALBEDO: (f64, f64) = (0.35, 0.75);
/// Half-width of the terminator's soft edge, in `cos θ_s`.
pub const TWILIGHT: f64 = 0.03;
/// Atmospheric scale height, m.
pub const SCALE_HEIGHT_M: f64 = 8_000.0;
/// Vertical optical depth of the atmosphere in the visible (Rayleigh at ≈ 550 nm).
pub const TAU_VIS: f64 = 0.1;
/// Vertical optical depth in the thermal window (10–12 µm, water vapour continuum).
pub const TAU_IR: f64 = 0.1;
/// Radiance of an optically thick, sunlit limb (renderer units, sun irradiance = 1).
pub const LIMB_RADIANCE: f64 = 0.25;
/// Temperature of the emitting atmosphere, K (upper troposphere).
pub const ATMOSPHERE_K: f64 = 220.0;
/// Heights above the surface beyond which the atmosphere is not drawn, m.
const ATMOSPHERE_TOP_M: f64 = 12.0 * SCALE_HEIGHT_M;

/// The Earth of a sequence or dataset: where it is and its surface's seed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EarthParams {
    /// Orbit altitude, m.
    pub altitude_m: f64,
    /// Seed of the land and cloud fields.
    pub seed: u64,
}

impl Default for EarthParams {
    fn default() -> Self {
        EarthParams { altitude_m: DEFAULT_ALTITUDE_M, seed: 1 }
    }
}

impl EarthParams {
    /// Mean motion of a circular orbit at this altitude, rad/s (the ground moves under the
    /// orbit at this rate).
    pub fn mean_motion(&self) -> f64 {
        (EARTH_MU / (EARTH_RADIUS_M + self.altitude_m).powi(3)).sqrt()
    }

    /// Cosine of the Earth's angular radius seen from the orbit.
    pub fn cos_angular_radius(&self) -> f64 {
        let s = EARTH_RADIUS_M / (EARTH_RADIUS_M + self.altitude_m);
        (1.0 - s * s).sqrt()
    }
}

/// The Earth as one frame sees it (everything in the target body frame).
pub struct EarthView {
    /// The Earth's centre relative to the scene's origin, m.
    centre: DVec3,
    /// Body frame → Earth-fixed frame (where the surface pattern lives).
    pub to_surface: DQuat,
    /// Unit vector towards the sun.
    sun: DVec3,
    land: Perlin,
    cloud: Perlin,
}

/// What a ray sees of the Earth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EarthHit {
    /// The surface: the outward normal there (body frame) and the emission cosine `μ`.
    Surface {
        /// Outward normal at the point, body frame.
        normal: DVec3,
        /// Cosine between the normal and the ray back to the camera.
        mu: f64,
    },
    /// The atmosphere above the limb: the point of closest approach's normal and its height.
    Limb {
        /// Outward normal below the closest approach, body frame.
        normal: DVec3,
        /// Height of the closest approach above the surface, m.
        height_m: f64,
    },
}

/// Fractal sum of `octaves` Perlin octaves at `p`, roughly in [−1, 1].
fn fbm(noise: &Perlin, p: DVec3, octaves: u32) -> f64 {
    let (mut sum, mut amp, mut freq, mut norm) = (0.0, 1.0, 1.0, 0.0);
    for _ in 0..octaves {
        sum += amp * noise.get((p * freq).to_array());
        norm += amp;
        amp *= 0.5;
        freq *= 2.03;
    }
    sum / norm * 1.6
}

/// `smoothstep` of `x` over `[a, b]`.
fn smooth(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl EarthView {
    /// The Earth along `towards` (unit, body frame) at `params.altitude_m` below the scene's
    /// `centre`, its surface turned by `to_surface`, lit from `sun` (unit, body frame).
    pub fn new(params: &EarthParams, centre: Vec3, towards: Vec3, to_surface: DQuat, sun: Vec3) -> EarthView {
        let towards = towards.as_dvec3().normalize();
        let seed = crate::noise::mix64(params.seed ^ 0x4541_5254);
        EarthView {
            centre: centre.as_dvec3() + towards * (EARTH_RADIUS_M + params.altitude_m),
            to_surface,
            sun: sun.as_dvec3().normalize(),
            land: Perlin::new((seed >> 32) as u32),
            cloud: Perlin::new(seed as u32),
        }
    }

    /// What the ray from `origin` along the unit `d` sees of the Earth, if anything.
    pub fn hit(&self, origin: Vec3, d: Vec3) -> Option<EarthHit> {
        let (o, d) = (origin.as_dvec3(), d.as_dvec3().normalize());
        let oc = o - self.centre;
        let b = d.dot(oc);
        if b >= 0.0 {
            return None; // heading away from the Earth
        }
        // Closest approach of the ray to the centre.
        let closest_sq = (oc.length_squared() - b * b).max(0.0);
        let r2 = EARTH_RADIUS_M * EARTH_RADIUS_M;
        if closest_sq <= r2 {
            let t = -b - (r2 - closest_sq).sqrt();
            let normal = (oc + d * t) / EARTH_RADIUS_M;
            return Some(EarthHit::Surface { normal, mu: (-d.dot(normal)).clamp(0.0, 1.0) });
        }
        let height_m = closest_sq.sqrt() - EARTH_RADIUS_M;
        (height_m < ATMOSPHERE_TOP_M).then(|| EarthHit::Limb { normal: (oc - d * b).normalize(), height_m })
    }

    /// The Earth-fixed direction of a body-frame normal.
    fn surface_point(&self, normal: DVec3) -> DVec3 {
        self.to_surface * normal
    }

    /// Land fraction and cloud cover at an Earth-fixed unit vector, both in [0, 1], and the
    /// land's albedo variation in [−1, 1].
    pub fn fields(&self, p: DVec3) -> (f64, f64, f64) {
        let (land, cloud) = self.cover(p);
        (land, cloud, fbm(&self.land, p * 9.0 + DVec3::splat(17.0), 3).clamp(-1.0, 1.0))
    }

    /// Land fraction and cloud cover alone (what the thermal band needs).
    fn cover(&self, p: DVec3) -> (f64, f64) {
        let land = smooth(0.57, 0.61, fbm(&self.land, p * 2.2, 6) * 0.5 + 0.5);
        let cloud = smooth(0.42, 0.58, fbm(&self.cloud, p * 4.5, 7) * 0.5 + 0.5);
        (land, cloud)
    }

    /// Reflected radiance along a ray that sees the Earth (renderer units: sun irradiance = 1).
    pub fn vis_radiance(&self, hit: &EarthHit) -> f64 {
        match *hit {
            EarthHit::Surface { normal, mu } => {
                let cos_s = normal.dot(self.sun);
                let lit = smooth(-TWILIGHT, TWILIGHT, cos_s);
                let (land, cloud, var) = self.fields(self.surface_point(normal));
                let clear = OCEAN_ALBEDO + land * (LAND_ALBEDO + 0.08 * var - OCEAN_ALBEDO);
                let cloud_albedo = CLOUD_ALBEDO.0 + (CLOUD_ALBEDO.1 - CLOUD_ALBEDO.0) * cloud;
                let albedo = clear + cloud * (cloud_albedo - clear);
                let tau = TAU_VIS / mu.max(0.02);
                let surface = albedo * cos_s.max(0.0) * lit * (-tau).exp();
                surface + LIMB_RADIANCE * lit * (1.0 - (-tau).exp())
            }
            EarthHit::Limb { normal, height_m } => {
                let lit = smooth(-0.1, 0.1, normal.dot(self.sun));
                LIMB_RADIANCE * lit * (1.0 - (-slant_depth(TAU_VIS, height_m)).exp())
            }
        }
    }

    /// Infrared radiance along a ray that sees the Earth, W/(m² sr) in the renderer's black-body
    /// form (`σT⁴/π` of the brightness temperature).
    pub fn tir_radiance(&self, hit: &EarthHit) -> f64 {
        let b = crate::tir::TirParams::blackbody_radiance;
        match *hit {
            EarthHit::Surface { normal, mu } => {
                let p = self.surface_point(normal);
                let (land, cloud) = self.cover(p);
                let cos_lat = (1.0 - p.z * p.z).max(0.0).sqrt();
                let day = normal.dot(self.sun).max(0.0);
                let clear = (1.0 - land) * b(280.0 + 12.0 * cos_lat) + land * b(278.0 + 30.0 * day);
                let top = b(265.0 - 45.0 * cloud);
                let surface = clear + cloud * (top - clear);
                let transmitted = (-TAU_IR / mu.max(0.02)).exp();
                surface * transmitted + b(ATMOSPHERE_K) * (1.0 - transmitted)
            }
            EarthHit::Limb { height_m, .. } => {
                b(ATMOSPHERE_K) * (1.0 - (-slant_depth(TAU_IR, height_m)).exp())
            }
        }
    }
}

impl EarthView {
    /// The irradiance the Earth drawn here gives a surface facing it (normal along `towards`,
    /// unit, body frame), relative to the sun's: `(1/π) ∫ v cos θ dω` over the Earth's disc,
    /// `v` its reflected radiance in the renderer's unit ([`Self::vis_radiance`]), by the
    /// midpoint rule on a 32 × 64 grid of (cos θ, φ) — the earthshine that agrees with the
    /// picture behind the target.
    pub fn earthshine(&self, towards: Vec3) -> f64 {
        let axis = towards.as_dvec3().normalize();
        let (u, v) = axis.any_orthonormal_pair();
        let c0 = {
            let dist = self.centre.length();
            (1.0 - (EARTH_RADIUS_M / dist).powi(2)).max(0.0).sqrt()
        };
        let (nr, nphi) = (32, 64);
        let (dc, dphi) = ((1.0 - c0) / f64::from(nr), std::f64::consts::TAU / f64::from(nphi));
        let mut sum = 0.0;
        for i in 0..nr {
            let c = c0 + (f64::from(i) + 0.5) * dc;
            let s = (1.0 - c * c).max(0.0).sqrt();
            for j in 0..nphi {
                let phi = (f64::from(j) + 0.5) * dphi;
                let d = axis * c + (u * phi.cos() + v * phi.sin()) * s;
                if let Some(hit @ EarthHit::Surface { .. }) = self.hit(Vec3::ZERO, d.as_vec3()) {
                    sum += self.vis_radiance(&hit) * c * dc * dphi;
                }
            }
        }
        sum / std::f64::consts::PI
    }
}

/// Emission cosine above which one evaluation of the Earth serves a whole pixel.
const SMOOTH_MU: f64 = 0.2;

/// One pixel's view of the Earth for its sample rays, evaluated once where it can be: the
/// surface's pattern changes little within a pixel, so where the pixel centre's ray meets the
/// surface at `μ` ≥ 0.2 the centre's value serves every sample that misses the target; at the
/// limb and above it (where the picture changes within a pixel) each sample is its own. This
/// keeps the Earth's cost per pixel at one evaluation instead of the `n²` samples'.
pub struct EarthPixel<'a> {
    view: &'a EarthView,
    origin: Vec3,
    centre_ray: Vec3,
    centre: Option<Option<EarthHit>>,
    value: Option<f64>,
}

impl<'a> EarthPixel<'a> {
    /// The pixel whose centre's ray from `origin` is `centre_ray`.
    pub fn new(view: &'a EarthView, origin: Vec3, centre_ray: Vec3) -> EarthPixel<'a> {
        EarthPixel { view, origin, centre_ray, centre: None, value: None }
    }

    /// What the sample ray `d` (which missed the target) sees of the Earth through `f` (the
    /// band's radiance of a hit, [`EarthView::vis_radiance`] or [`EarthView::tir_radiance`]), 0
    /// where it sees space.
    pub fn sample(&mut self, d: Vec3, f: impl Fn(&EarthView, &EarthHit) -> f64) -> f64 {
        let (view, origin, centre_ray) = (self.view, self.origin, self.centre_ray);
        let centre = *self.centre.get_or_insert_with(|| view.hit(origin, centre_ray));
        match centre {
            Some(hit @ EarthHit::Surface { mu, .. }) if mu >= SMOOTH_MU => {
                *self.value.get_or_insert_with(|| f(view, &hit))
            }
            _ => view.hit(origin, d).map_or(0.0, |h| f(view, &h)),
        }
    }
}

/// Optical depth along a ray grazing the atmosphere at `height_m` (exponential layer of vertical
/// depth `tau0`, Chapman's grazing form `τ₀ √(2πR/H) e^{−h/H}`).
pub fn slant_depth(tau0: f64, height_m: f64) -> f64 {
    tau0 * (std::f64::consts::TAU * EARTH_RADIUS_M / SCALE_HEIGHT_M).sqrt()
        * (-height_m / SCALE_HEIGHT_M).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view(sun: Vec3) -> EarthView {
        EarthView::new(&EarthParams::default(), Vec3::ZERO, Vec3::NEG_Z, DQuat::IDENTITY, sun)
    }

    #[test]
    fn a_ray_straight_down_hits_the_surface_at_the_altitude() {
        let e = view(Vec3::NEG_Z);
        let Some(EarthHit::Surface { normal, mu }) = e.hit(Vec3::ZERO, Vec3::NEG_Z) else { panic!() };
        assert!((normal - DVec3::Z).length() < 1e-12 && (mu - 1.0).abs() < 1e-12);
        // The disc's edge: rays just inside the angular radius hit, just outside see the limb.
        let c = EarthParams::default().cos_angular_radius();
        let s = (1.0 - c * c).sqrt();
        let inside = Vec3::new((s * 0.999) as f32, 0.0, -(1.0 - (s * 0.999) * (s * 0.999)).sqrt() as f32);
        assert!(matches!(e.hit(Vec3::ZERO, inside), Some(EarthHit::Surface { .. })));
        let outside = Vec3::new((s * 1.001) as f32, 0.0, -(1.0 - (s * 1.001) * (s * 1.001)).sqrt() as f32);
        assert!(matches!(e.hit(Vec3::ZERO, outside), Some(EarthHit::Limb { .. })));
        assert!(e.hit(Vec3::ZERO, Vec3::Z).is_none());
    }

    #[test]
    fn the_night_side_is_dark_and_the_sunlit_nadir_follows_the_albedo() {
        // Sun overhead of the nadir point: radiance = albedo · e^{−τ} + limb term (μ = 1).
        let e = view(Vec3::Z);
        let hit = e.hit(Vec3::ZERO, Vec3::NEG_Z).unwrap();
        let (land, cloud, var) = e.fields(DVec3::Z);
        let clear = OCEAN_ALBEDO + land * (LAND_ALBEDO + 0.08 * var - OCEAN_ALBEDO);
        let albedo = clear + cloud * (CLOUD_ALBEDO.0 + (CLOUD_ALBEDO.1 - CLOUD_ALBEDO.0) * cloud - clear);
        let expected = albedo * (-TAU_VIS).exp() + LIMB_RADIANCE * (1.0 - (-TAU_VIS).exp());
        assert!((e.vis_radiance(&hit) - expected).abs() < 1e-12);
        // Sun behind the Earth: the nadir is on the night side.
        let night = view(Vec3::NEG_Z);
        assert_eq!(night.vis_radiance(&night.hit(Vec3::ZERO, Vec3::NEG_Z).unwrap()), 0.0);
    }

    #[test]
    fn about_a_third_is_land_and_about_half_is_cloud() {
        // Over the whole sphere (a Fibonacci lattice of 20 000 points), as the module says.
        let e = view(Vec3::Z);
        let n = 20_000;
        let (mut land, mut cloud) = (0.0, 0.0);
        for i in 0..n {
            let z = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
            let r = (1.0 - z * z).sqrt();
            let phi = f64::from(i) * 2.399_963_229_728_653;
            let (l, c, _) = e.fields(DVec3::new(r * phi.cos(), r * phi.sin(), z));
            land += l;
            cloud += c;
        }
        let (land, cloud) = (land / f64::from(n), cloud / f64::from(n));
        assert!((0.2..0.4).contains(&land), "land {land}");
        assert!((0.35..0.6).contains(&cloud), "cloud {cloud}");
    }

    #[test]
    fn thermal_brightness_spans_cloud_tops_to_warm_ground() {
        // Seen from straight above (μ = 1) everywhere on the globe (sun over +z): the coldest
        // places are thick cloud tops near 225 K, the warmest sunlit clear land near 300 K.
        let e = view(Vec3::Z);
        let (mut t_min, mut t_max) = (f64::INFINITY, 0.0f64);
        let n = 5_000;
        for i in 0..n {
            let z = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
            let r = (1.0 - z * z).sqrt();
            let phi = f64::from(i) * 2.399_963_229_728_653;
            let hit = EarthHit::Surface { normal: DVec3::new(r * phi.cos(), r * phi.sin(), z), mu: 1.0 };
            let t = (std::f64::consts::PI * e.tir_radiance(&hit) / crate::thermal::SIGMA).powf(0.25);
            t_min = t_min.min(t);
            t_max = t_max.max(t);
        }
        assert!((220.0..235.0).contains(&t_min) && (290.0..310.0).contains(&t_max), "{t_min} .. {t_max} K");
    }
}
