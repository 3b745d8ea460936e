//! Thermal model: one temperature per thermal node from a radiative balance.
//!
//! For node `n` with faces `f` (area `A_f`, material α, ε, η, coupling `h`, internal heat `q`):
//!
//! ```text
//! Σ_f A_f [ (α − η) G max(0, n̂_f·ŝ) s_f  +  ε E_IR  +  q_f ]           absorbed + internal
//!     = Σ_f A_f [ ε σ T⁴  +  h (T − T_bus) ]                            emitted + conducted
//! ```
//!
//! `G` is the solar constant, `s_f` the sunlit fraction of the face (shadow rays from sample
//! points on it), `E_IR` the Earth-IR flux (absorbed with ε) and `T_bus` the temperature of the
//! thermally controlled bus interior. `E_IR` and the coupling form the floor a shaded face
//! settles on instead of heading to 0 K. The steady state solves the balance per node by
//! bisection (the right-hand side grows monotonically with T). The eclipse transient integrates
//! `C dT/dt = absorbed − emitted` per node (RK4, 1 s steps) from a starting state with `G = 0`,
//! where `C = Σ_f A_f c_f` from the materials' areal heat capacities.

use crate::scene::Scene;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Stefan–Boltzmann constant, W/(m² K⁴).
pub const SIGMA: f64 = 5.670_374_419e-8;

/// Environment of the thermal model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThermalParams {
    /// Solar constant, W/m².
    pub solar_flux: f64,
    /// Earth-IR flux reaching the target, W/m² (absorbed with ε).
    pub earth_ir_flux: f64,
    /// Temperature of the bus interior, K.
    pub bus_temperature: f64,
    /// Unit vector towards the sun (target frame).
    pub sun_dir: Vec3,
    /// Shadow-ray samples per triangle for the sunlit fractions.
    pub lit_samples_per_triangle: u32,
}

impl Default for ThermalParams {
    fn default() -> Self {
        ThermalParams {
            solar_flux: 1361.0,
            earth_ir_flux: 60.0,
            bus_temperature: 293.0,
            sun_dir: crate::vis::default_sun_dir(),
            lit_samples_per_triangle: 64,
        }
    }
}

/// Sunlit fraction of every face (0 for faces turned away from the sun).
pub fn sunlit_fractions(scene: &Scene, sun_dir: Vec3, samples: u32) -> Vec<f64> {
    let mut lit = vec![0.0f64; scene.faces.len()];
    let mut area = vec![0.0f64; scene.faces.len()];
    let eps = scene.epsilon();
    let samples = samples.max(1);
    for (tri, &f) in scene.triangles.iter().zip(&scene.triangle_face) {
        let face = &scene.faces[f as usize];
        let (a, b, c) = (Vec3::from(tri.v0), Vec3::from(tri.v1), Vec3::from(tri.v2));
        let ta = f64::from(0.5 * (b - a).cross(c - a).length());
        area[f as usize] += ta;
        if face.normal.dot(sun_dir) <= 0.0 {
            continue;
        }
        let mut free = 0u32;
        for k in 0..samples {
            // R2 low-discrepancy points folded into the triangle.
            let (mut u, mut v) = (
                (0.5 + k as f64 * 0.754_877_666_246_692_7).fract(),
                (0.5 + k as f64 * 0.569_840_290_998_053_3).fract(),
            );
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let p = a + (b - a) * u as f32 + (c - a) * v as f32 + face.normal * eps;
            if !scene.occluded(p, sun_dir, 0.0, f32::INFINITY) {
                free += 1;
            }
        }
        lit[f as usize] += ta * f64::from(free) / f64::from(samples);
    }
    lit.iter().zip(&area).map(|(l, a)| if *a > 0.0 { l / a } else { 0.0 }).collect()
}

/// Per-node heat balance terms, precomputed once.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeBalance {
    /// Absorbed solar power in sunlight, W.
    pub solar: Vec<f64>,
    /// Earth-IR absorbed plus internal heat plus `Σ h A T_bus`, W (present in and out of eclipse).
    pub constant: Vec<f64>,
    /// `Σ ε A σ`, W/K⁴.
    pub radiative: Vec<f64>,
    /// `Σ h A`, W/K.
    pub conductive: Vec<f64>,
    /// Heat capacity `Σ c A`, J/K.
    pub capacity: Vec<f64>,
}

impl NodeBalance {
    /// Collects the balance terms of every node of `scene`.
    pub fn new(scene: &Scene, params: &ThermalParams) -> NodeBalance {
        let n = scene.node_count;
        let lit = sunlit_fractions(scene, params.sun_dir, params.lit_samples_per_triangle);
        let mut b = NodeBalance {
            solar: vec![0.0; n],
            constant: vec![0.0; n],
            radiative: vec![0.0; n],
            conductive: vec![0.0; n],
            capacity: vec![0.0; n],
        };
        for (face, lit) in scene.faces.iter().zip(lit) {
            let m = face.material.props();
            let a = f64::from(face.area);
            let i = face.node as usize;
            let cos = f64::from(face.normal.dot(params.sun_dir)).max(0.0);
            b.solar[i] += a * (m.solar_absorptance - m.electrical_efficiency) * params.solar_flux * cos * lit;
            b.constant[i] += a
                * (m.ir_emittance * params.earth_ir_flux
                    + face.internal_heat
                    + m.bus_coupling * params.bus_temperature);
            b.radiative[i] += a * m.ir_emittance * SIGMA;
            b.conductive[i] += a * m.bus_coupling;
            b.capacity[i] += a * m.areal_heat_capacity;
        }
        b
    }

    /// Net heat into node `i` at temperature `t`, W.
    pub fn net(&self, i: usize, t: f64, sun: bool) -> f64 {
        self.net_in_sun(i, t, if sun { 1.0 } else { 0.0 })
    }

    /// Net heat into node `i` at temperature `t` with `sun_fraction` of the solar disc visible
    /// (1 in light, 0 in eclipse, between in the penumbra), W.
    pub fn net_in_sun(&self, i: usize, t: f64, sun_fraction: f64) -> f64 {
        let input = self.constant[i] + sun_fraction * self.solar[i];
        input - self.radiative[i] * t.powi(4) - self.conductive[i] * t
    }

    /// Steady-state temperature of node `i`, K.
    pub fn steady(&self, i: usize, sun: bool) -> f64 {
        let (mut lo, mut hi) = (0.0f64, 3000.0f64);
        if self.radiative[i] <= 0.0 && self.conductive[i] <= 0.0 {
            return 0.0;
        }
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if self.net(i, mid, sun) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}

/// Steady-state node temperatures in sunlight, K.
pub fn steady_state(scene: &Scene, params: &ThermalParams) -> Vec<f64> {
    let b = NodeBalance::new(scene, params);
    (0..scene.node_count).map(|i| b.steady(i, true)).collect()
}

/// Node temperatures after `seconds` in eclipse, starting from `start` (e.g. the sunlit steady
/// state), by RK4 with steps of at most 1 s.
pub fn eclipse_transient(scene: &Scene, params: &ThermalParams, start: &[f64], seconds: f64) -> Vec<f64> {
    advance(&NodeBalance::new(scene, params), start, seconds, 0.0)
}

/// Node temperatures after `seconds` under `balance` with `sun_fraction` of the sun (see
/// [`NodeBalance::net_in_sun`]), from `start`, by RK4 with steps of at most 1 s. A node without
/// heat capacity takes its steady state at once.
pub fn advance(balance: &NodeBalance, start: &[f64], seconds: f64, sun_fraction: f64) -> Vec<f64> {
    let b = balance;
    let steps = seconds.max(0.0).ceil() as usize;
    let dt = if steps > 0 { seconds / steps as f64 } else { 0.0 };
    (0..b.capacity.len())
        .map(|i| {
            let c = b.capacity[i];
            let mut t = start.get(i).copied().unwrap_or(0.0);
            if c <= 0.0 {
                return b.steady(i, sun_fraction > 0.5);
            }
            let f = |t: f64| b.net_in_sun(i, t.max(0.0), sun_fraction) / c;
            for _ in 0..steps {
                let k1 = f(t);
                let k2 = f(t + 0.5 * dt * k1);
                let k3 = f(t + 0.5 * dt * k2);
                let k4 = f(t + dt * k3);
                t += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            }
            t.max(0.0)
        })
        .collect()
}

/// Face temperatures from node temperatures (each face takes its node's).
pub fn face_temperatures(scene: &Scene, node_temperatures: &[f64]) -> Vec<f32> {
    scene
        .faces
        .iter()
        .map(|f| node_temperatures.get(f.node as usize).copied().unwrap_or(0.0) as f32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Material;

    #[test]
    fn steady_state_balances() {
        let sc = Scene::tango().unwrap();
        let p = ThermalParams::default();
        let b = NodeBalance::new(&sc, &p);
        let t = steady_state(&sc, &p);
        for (i, &ti) in t.iter().enumerate() {
            let scale = b.constant[i] + b.solar[i];
            assert!(b.net(i, ti, true).abs() < 1e-6 * scale, "node {i}");
            assert!((150.0..420.0).contains(&ti), "node {i}: {ti} K");
        }
    }

    #[test]
    fn eclipse_cools_and_settles_on_the_floor() {
        let sc = Scene::tango().unwrap();
        let p = ThermalParams::default();
        let b = NodeBalance::new(&sc, &p);
        let t0 = steady_state(&sc, &p);
        let t10 = eclipse_transient(&sc, &p, &t0, 600.0);
        let t_long = eclipse_transient(&sc, &p, &t0, 200_000.0);
        for i in 0..sc.node_count {
            assert!(t10[i] <= t0[i] + 1e-9, "node {i} warmed in eclipse");
            assert!((t_long[i] - b.steady(i, false)).abs() < 0.5, "node {i}");
            assert!(t_long[i] > 150.0, "node {i} has no floor: {} K", t_long[i]);
        }
        // Light MLI cools much faster than the heavy panel.
        let mli =
            sc.faces.iter().find(|f| f.material == Material::MliKapton && f.normal.x > 0.5).unwrap().node
                as usize;
        let panel = sc.faces.iter().find(|f| f.material == Material::GaAsCell).unwrap().node as usize;
        assert!(
            (t0[mli] - t10[mli]) / (t0[mli] - t_long[mli])
                > (t0[panel] - t10[panel]) / (t0[panel] - t_long[panel])
        );
    }
}
