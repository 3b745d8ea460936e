//! Procedural surface detail: what a feature tracker sees on a real spacecraft's faces.
//!
//! A flat-shaded box has corners on its outline and nothing inside. Real surfaces carry the
//! texture navigation uses, in both bands, and [`SurfaceDetail`] adds it per material as a
//! function of the hit point in the body frame (seeded, deterministic, no image textures):
//!
//! | material | VIS | TIR |
//! |---|---|---|
//! | GaAs cells | 40 × 70 mm cells (dark, ± 12 % per cell) between 1.5 mm light substrate gaps, a 1.2 mm bright bus bar along each cell | gaps and bus bars off the cell temperature; each string of cells (a row) its own operating point; 6 % of the cells shunted and hot in sunlight |
//! | MLI (Kapton) | crinkles: multi-octave albedo noise ± 35 % and a perturbed normal (moving glints); 12 mm tape seams every 0.25 m; in most seam cells a patch (label, tape square, Velcro pad, 40–100 × 30–80 mm) | the crinkles' low octaves as temperature ripple; seams and patches at the tape's emittance (0.3 against 0.63) |
//! | white paint | 8 mm dark bolt heads every 60 mm along the perimeter, 20 mm in | bolt heads at metal emittance; electronics boxes behind the radiator as warm patches (+8 K) |
//! | aluminium | unchanged | unchanged |
//!
//! In TIR every detailed face also **mirrors the Earth's infrared glow** (`render_tir`): a
//! fraction `1 − ε` of the Earth's radiance (a 255 K black body filling a disc of ≈ 68° radius
//! seen from low orbit) wherever the relief turns the reflected ray into that disc. On the
//! crinkled MLI (ε 0.63) this mottles the blanket with warm and cold patches that move with
//! the view — the strongest texture a microbolometer sees on a real blanket, in light and in
//! eclipse alike; polished aluminium (ε 0.08) mirrors almost all of it.
//!
//! And on every face, **conduction**: a face exchanges heat with the bus through its mount,
//! so the pixels near the mount (the face centre for the bus sides and the panel, which sits on
//! the bus) sit closer to the bus temperature than the edges. The temperature offsets scale
//! with `T_face − T_bus`: in sunlight a hot panel shows cooler substrate gaps and a cool centre,
//! in eclipse the same structure reverses as the face cools below the bus — the pattern stays
//! visible in both phases, as on orbit.
//!
//! **No aliasing.** A pixel sees a footprint of `range / focal` metres (VIS at 100 m: 62 mm).
//! The line patterns (gaps, bars, seams, bolts) are box-filtered exactly over the footprint, and
//! noise octaves and per-cell variations fade out as their size falls below two footprints, so
//! a far target shows the mean albedo instead of Moiré.

use crate::material::{Face, Material};
use glam::Vec3;
use noise::{NoiseFn, Perlin};
use obvhs::triangle::Triangle;

/// Per-pixel surface properties at one hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Diffuse VIS albedo.
    pub albedo: f32,
    /// Weight of the specular lobe.
    pub specular: f32,
    /// Shading normal (unit; the geometric normal tilted by the surface relief).
    pub normal: Vec3,
    /// IR emittance.
    pub emittance: f64,
    /// Temperature offset from the face's node temperature, K.
    pub delta_t: f64,
}

/// A face's tangent frame and extent, for the procedural patterns.
#[derive(Clone, Copy, Debug)]
struct FaceFrame {
    u_axis: Vec3,
    v_axis: Vec3,
    centre: Vec3,
    /// (u, v) bounds of the face's vertices.
    u_range: (f32, f32),
    v_range: (f32, f32),
}

/// Procedural surface detail for a scene's faces (see the module docs).
#[derive(Clone)]
pub struct SurfaceDetail {
    frames: Vec<FaceFrame>,
    noise: Perlin,
    seed: u32,
    /// Bus interior temperature, K: the conduction term pulls the mounts towards it.
    pub bus_temperature: f64,
}

impl std::fmt::Debug for SurfaceDetail {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceDetail").field("faces", &self.frames.len()).field("seed", &self.seed).finish()
    }
}

/// Cell pitch along u and v, gap and bus-bar widths (m).
const CELL: (f32, f32) = (0.042, 0.072);
const CELL_GAP: f32 = 0.0015;
const BUS_BAR: f32 = 0.0012;
/// Fraction of cells running hot (shunted through their bypass diode).
const HOT_CELL_FRACTION: f32 = 0.06;
/// Emittance of the aluminised tape on seams and patches.
const TAPE_EMITTANCE: f64 = 0.3;
/// MLI tape seams: pitch and width (m).
const SEAM_PITCH: f32 = 0.25;
const SEAM: f32 = 0.012;
/// Bolt heads on painted faces: pitch along the edges, inset, diameter (m).
const BOLT_PITCH: f32 = 0.06;
const BOLT_INSET: f32 = 0.02;
const BOLT: f32 = 0.008;
/// Conduction length from a face's mount (m) and the fraction of `T_bus − T_face` recovered there.
const MOUNT_LENGTH: f32 = 0.22;
const MOUNT_PULL: f64 = 0.35;

impl SurfaceDetail {
    /// Detail for `scene` with the given seed (the seed moves the noise, the per-cell values and
    /// the electronics boxes; the grids are fixed by the hardware's layout).
    pub fn new(faces: &[Face], triangles: &[Triangle], triangle_face: &[u32], seed: u64) -> SurfaceDetail {
        let mut acc: Vec<(Vec3, f32, [f32; 4])> =
            vec![
                (Vec3::ZERO, 0.0, [f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY]);
                faces.len()
            ];
        let axes: Vec<(Vec3, Vec3)> = faces.iter().map(|f| tangent_axes(f.normal)).collect();
        for (tri, &face) in triangles.iter().zip(triangle_face) {
            let (u_axis, v_axis) = axes[face as usize];
            let a = &mut acc[face as usize];
            for v in [tri.v0, tri.v1, tri.v2] {
                let p = Vec3::from(v);
                a.0 += p;
                a.1 += 1.0;
                let (u, w) = (p.dot(u_axis), p.dot(v_axis));
                a.2 = [a.2[0].min(u), a.2[1].max(u), a.2[2].min(w), a.2[3].max(w)];
            }
        }
        let frames = acc
            .iter()
            .zip(&axes)
            .map(|((sum, n, b), &(u_axis, v_axis))| FaceFrame {
                u_axis,
                v_axis,
                centre: if *n > 0.0 { *sum / *n } else { Vec3::ZERO },
                u_range: (b[0], b[1]),
                v_range: (b[2], b[3]),
            })
            .collect();
        let seed32 = (crate::noise::mix64(seed ^ 0x5355_5246) >> 32) as u32;
        SurfaceDetail { frames, noise: Perlin::new(seed32), seed: seed32, bus_temperature: 293.0 }
    }

    /// The surface at `point` (body frame) on face `face`, seen with a pixel footprint of
    /// `footprint` metres; `node_temperature` is the face's node temperature (K).
    pub fn at(
        &self,
        faces: &[Face],
        face: u32,
        point: Vec3,
        footprint: f32,
        node_temperature: f64,
    ) -> SurfacePoint {
        let f = &faces[face as usize];
        let props = f.material.props();
        let mut s = SurfacePoint {
            albedo: props.diffuse_albedo,
            specular: props.specular,
            normal: f.normal,
            emittance: props.ir_emittance,
            delta_t: 0.0,
        };
        let Some(frame) = self.frames.get(face as usize) else { return s };
        let d = point - frame.centre;
        let (u, v) = (d.dot(frame.u_axis), d.dot(frame.v_axis));
        let fp = footprint.max(1e-5);
        let excess = node_temperature - self.bus_temperature;
        // Conduction to the bus through the mount at the face centre.
        let r2 = (u * u + v * v) / (MOUNT_LENGTH * MOUNT_LENGTH);
        s.delta_t = -MOUNT_PULL * excess * f64::from((-r2).exp());
        match f.material {
            Material::GaAsCell => self.cells(&mut s, frame, point, fp, excess),
            Material::MliKapton => self.mli(&mut s, frame, point, fp, excess),
            Material::WhitePaint => self.paint(&mut s, frame, point, fp),
            Material::PolishedAluminium => {}
        }
        s
    }

    fn cells(&self, s: &mut SurfacePoint, fr: &FaceFrame, p: Vec3, fp: f32, excess: f64) {
        let (u, v) = (p.dot(fr.u_axis) - fr.u_range.0, p.dot(fr.v_axis) - fr.v_range.0);
        let (iu, iv) = ((u / CELL.0).floor() as i32, (v / CELL.1).floor() as i32);
        // Per-cell albedo scatter and per-string (row) operating point, faded with the footprint.
        let cell_weight = fade(fp, CELL.0);
        let scatter = 0.12 * cell_weight * (self.hash(iu, iv, 1) * 2.0 - 1.0);
        let string = f64::from(cell_weight * (self.hash(0, iv, 2) * 2.0 - 1.0));
        let gap = grid_coverage(u, v, CELL, CELL_GAP, fp);
        let bar = line_coverage(u - CELL_GAP, CELL.0, BUS_BAR, fp) * (1.0 - gap);
        let cell = 1.0 - gap - bar;
        s.albedo = cell * s.albedo * (1.0 + scatter) + gap * 0.45 + bar * 0.70;
        s.specular = cell * s.specular + bar * 0.6 + gap * 0.05;
        // Gaps absorb less sunlight and emit more: off the cell temperature by a fraction of the
        // face's excess over the bus (cooler in sun, warmer in eclipse); bars run warmer (current).
        s.emittance = f64::from(cell) * s.emittance + f64::from(gap) * 0.86 + f64::from(bar) * 0.80;
        s.delta_t += excess * (-0.08 * f64::from(gap) + 0.03 * f64::from(bar) + 0.025 * string);
        // Shunted cells (≈ 6 %, through their bypass diode) dissipate their power: hot spots in
        // sunlight, gone in eclipse.
        if self.hash(iu, iv, 4) < HOT_CELL_FRACTION {
            let inside = box_coverage(
                u - (iu as f32 + 0.5) * CELL.0,
                v - (iv as f32 + 0.5) * CELL.1,
                (CELL.0 - CELL_GAP) / 2.0,
                (CELL.1 - CELL_GAP) / 2.0,
                fp,
            );
            s.delta_t += 0.15 * excess.max(0.0) * f64::from(inside);
        }
    }

    fn mli(&self, s: &mut SurfacePoint, fr: &FaceFrame, p: Vec3, fp: f32, excess: f64) {
        let (u, v) = (p.dot(fr.u_axis), p.dot(fr.v_axis));
        let (h, gu, gv) = self.fbm(u, v, 0.09, 4, fp);
        let (low, _, _) = self.fbm(u, v, 0.30, 2, fp);
        let seams = grid_coverage(
            u - fr.u_range.0 - 0.11,
            v - fr.v_range.0 - 0.07,
            (SEAM_PITCH, SEAM_PITCH),
            SEAM,
            fp,
        );
        // Patches on the blanket: labels, aluminised tape squares, Velcro pads (one in most
        // seam cells, seeded size and place): bright in VIS, low emittance in TIR.
        let (cu, cv) = ((u - fr.u_range.0 - 0.11) / SEAM_PITCH, (v - fr.v_range.0 - 0.07) / SEAM_PITCH);
        let (iu, iv) = (cu.floor() as i32, cv.floor() as i32);
        let mut patch = 0.0;
        if self.hash(iu, iv, 5) < 0.7 {
            let (hu, hv) = (0.02 + 0.03 * self.hash(iu, iv, 6), 0.015 + 0.025 * self.hash(iu, iv, 7));
            let (pu, pv) = (0.25 + 0.5 * self.hash(iu, iv, 8), 0.25 + 0.5 * self.hash(iu, iv, 9));
            patch = box_coverage(
                (cu - iu as f32 - pu) * SEAM_PITCH,
                (cv - iv as f32 - pv) * SEAM_PITCH,
                hu,
                hv,
                fp,
            );
        }
        let seams = seams.max(patch);
        let blanket = 1.0 - seams;
        s.albedo = blanket * s.albedo * (1.0 + 0.35 * h) + seams * 0.75;
        s.specular = blanket * s.specular * (1.0 + 0.5 * h.abs()) + seams * 0.5;
        // Crinkles tilt the normal (slopes of ≈ ±0.3): the glints move with the view.
        let tilt = 0.3 * blanket;
        s.normal = (s.normal - tilt * (gu * fr.u_axis + gv * fr.v_axis)).normalize();
        s.emittance = f64::from(blanket) * s.emittance + f64::from(seams) * TAPE_EMITTANCE;
        s.delta_t += excess * 0.05 * f64::from(low);
    }

    fn paint(&self, s: &mut SurfacePoint, fr: &FaceFrame, p: Vec3, fp: f32) {
        let (u, v) = (p.dot(fr.u_axis), p.dot(fr.v_axis));
        let bolts = bolt_coverage(u, v, fr, fp);
        s.albedo = (1.0 - bolts) * s.albedo + bolts * 0.15;
        s.specular = (1.0 - bolts) * s.specular + bolts * 0.5;
        s.emittance = f64::from(1.0 - bolts) * s.emittance + f64::from(bolts) * 0.15;
        // Electronics boxes behind the radiator: two warm rectangles (seeded place), +8 K.
        for k in 0..2 {
            let cu = lerp(fr.u_range.0, fr.u_range.1, 0.25 + 0.5 * self.hash(k, 0, 3));
            let cv = lerp(fr.v_range.0, fr.v_range.1, 0.3 + 0.4 * self.hash(k, 1, 3));
            let inside = box_coverage(u - cu, v - cv, 0.09, 0.06, fp.max(0.005));
            s.delta_t += 8.0 * f64::from(inside);
        }
    }

    /// Fractal noise in [-1, 1] (roughly) and its gradient, octaves fading with the footprint.
    fn fbm(&self, u: f32, v: f32, wavelength: f32, octaves: u32, fp: f32) -> (f32, f32, f32) {
        let (mut sum, mut gu, mut gv, mut amp, mut lambda) = (0.0f32, 0.0f32, 0.0f32, 1.0f32, wavelength);
        for o in 0..octaves {
            let w = fade(fp, lambda / 2.0);
            if w <= 0.0 {
                break;
            }
            let (x, y) = (f64::from(u / lambda), f64::from(v / lambda));
            let z = f64::from(o) * 17.0;
            let e = 0.05;
            let n0 = self.noise.get([x, y, z]) as f32;
            let nx = self.noise.get([x + e, y, z]) as f32;
            let ny = self.noise.get([x, y + e, z]) as f32;
            sum += w * amp * n0;
            // d/du of amp·n(u/λ): the slope of a relief whose height is amp·λ/4·n.
            gu += w * amp * (nx - n0) / e as f32 / 4.0;
            gv += w * amp * (ny - n0) / e as f32 / 4.0;
            amp *= 0.5;
            lambda *= 0.5;
        }
        (sum, gu, gv)
    }

    /// A value in [0, 1) from the seed and two indices.
    fn hash(&self, a: i32, b: i32, salt: u64) -> f32 {
        let key = (u64::from(a as u32) << 32 | u64::from(b as u32))
            ^ (u64::from(self.seed) << 7)
            ^ salt.wrapping_mul(0x9E37_79B9);
        (crate::noise::mix64(key) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Two unit tangents of a face with normal `n`: `u` perpendicular to the world axis most aligned
/// with `n`'s smallest component, so box faces get grids along their edges.
fn tangent_axes(n: Vec3) -> (Vec3, Vec3) {
    let a = n.abs();
    let helper = if a.x <= a.y && a.x <= a.z {
        Vec3::X
    } else if a.y <= a.z {
        Vec3::Y
    } else {
        Vec3::Z
    };
    let u = n.cross(helper).normalize_or_zero();
    let u = if u == Vec3::ZERO { n.any_orthonormal_vector() } else { u };
    (u, n.cross(u).normalize_or_zero())
}

/// Weight of a detail of size `size` seen through a footprint `fp`: 1 when the detail spans two
/// footprints or more, 0 at one footprint or less.
fn fade(fp: f32, size: f32) -> f32 {
    (size / fp - 1.0).clamp(0.0, 1.0)
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// Integral over [0, x] of a pulse train: pulses of width `w` at `0, p, 2p, …`.
fn pulse_integral(x: f32, p: f32, w: f32) -> f32 {
    let k = (x / p).floor();
    k * w + (x - k * p).clamp(0.0, w)
}

/// Fraction of the footprint `[x − fp/2, x + fp/2]` covered by lines of width `w`, period `p`
/// (the exact box filter of the pulse train).
fn line_coverage(x: f32, p: f32, w: f32, fp: f32) -> f32 {
    ((pulse_integral(x + fp / 2.0, p, w) - pulse_integral(x - fp / 2.0, p, w)) / fp).clamp(0.0, 1.0)
}

/// Coverage of a grid of lines along both axes (a square footprint, separable).
fn grid_coverage(u: f32, v: f32, pitch: (f32, f32), w: f32, fp: f32) -> f32 {
    let (a, b) = (line_coverage(u, pitch.0, w, fp), line_coverage(v, pitch.1, w, fp));
    1.0 - (1.0 - a) * (1.0 - b)
}

/// Coverage of the rectangle `|u| ≤ hu, |v| ≤ hv` by a square footprint centred at (u, v).
fn box_coverage(u: f32, v: f32, hu: f32, hv: f32, fp: f32) -> f32 {
    let span = |x: f32, h: f32| ((x + fp / 2.0).min(h) - (x - fp / 2.0).max(-h)).max(0.0) / fp;
    span(u, hu) * span(v, hv)
}

/// Coverage of the bolt heads (squares of side [`BOLT`]) along the perimeter of the face.
fn bolt_coverage(u: f32, v: f32, fr: &FaceFrame, fp: f32) -> f32 {
    let (u0, u1, v0, v1) = (
        fr.u_range.0 + BOLT_INSET,
        fr.u_range.1 - BOLT_INSET,
        fr.v_range.0 + BOLT_INSET,
        fr.v_range.1 - BOLT_INSET,
    );
    // Lines of bolts along u at v0 and v1, along v at u0 and u1.
    let along = |x: f32, start: f32| line_coverage(x - start + BOLT / 2.0, BOLT_PITCH, BOLT, fp);
    let across = |y: f32, at: f32| box_coverage(0.0, y - at, 1.0, BOLT / 2.0, fp);
    let rows = (across(v, v0) + across(v, v1)) * along(u, u0) * f32::from(u >= u0 - fp && u <= u1 + fp);
    let cols = (across(u, u0) + across(u, u1)) * along(v, v0) * f32::from(v >= v0 - fp && v <= v1 + fp);
    (rows + cols).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_coverage_is_the_duty_cycle_for_a_wide_footprint_and_exact_for_a_narrow_one() {
        // Wide footprint: any whole number of periods averages to w/p.
        assert!((line_coverage(0.123, 0.04, 0.002, 0.4) - 0.05).abs() < 1e-4);
        // Narrow footprint inside a line and between lines.
        assert_eq!(line_coverage(0.001, 0.04, 0.002, 1e-4), 1.0);
        assert_eq!(line_coverage(0.02, 0.04, 0.002, 1e-4), 0.0);
        // Half over a line's edge.
        assert!((line_coverage(0.002, 0.04, 0.002, 0.001) - 0.5).abs() < 1e-3);
    }

    #[test]
    fn fade_keeps_large_details_and_drops_subpixel_ones() {
        assert_eq!(fade(0.01, 0.05), 1.0);
        assert_eq!(fade(0.05, 0.04), 0.0);
        assert!((fade(0.02, 0.03) - 0.5).abs() < 1e-6);
    }
}
