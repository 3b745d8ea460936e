//! The thermal camera's focal plane: the raw counts of an uncooled microbolometer array, with
//! the artefacts its front end must remove, and the factory calibration that removes them.
//!
//! The renderer's TIR value `v` (0..1 over `[T_min, T_max]`, linear in brightness temperature
//! with the default DN mapping, blur and the study's temporal noise included) is what an ideal
//! array would see. The array turns it into counts, pixel `p = (x, y)` at time `t`:
//!
//! `raw = P + g(p)·R·(T_max − T_min)·v + o(p) + c(x) + r(y) + R·ΔT(t)·(k̄ + k(p) + k_c(x)) + n`
//!
//! rounded and clamped to `bits`, where
//! * `R` is the responsivity (counts per kelvin of scene) and `P` the pedestal (counts);
//! * `g(p)` the pixel's gain, `1 + N(0, gain_spread)`;
//! * `o(p)`, `c(x)`, `r(y)`: pixel, column and row offsets, normal, their spreads in kelvin of
//!   scene (times `R`) — the column offsets are the readout's stripes;
//! * `ΔT(t) = fpa_drift·t`: the focal plane warming since the calibration (a camera after
//!   power-up), and `k̄ + k(p) + k_c(x)` the offset's drift per kelvin of focal plane (mean,
//!   pixel and column parts, kelvin of scene per kelvin);
//! * `n ~ N(0, NETD·R)`: the array's own temporal noise, on top of the study's;
//! * dead pixels stuck near 0 and hot ones near full scale (`bad_fraction` of the array,
//!   half each), plus `bad_clusters` dead 3 × 3 blocks.
//!
//! **The shutter.** Every `shutter_period_s` the camera closes its shutter (a flat field at
//! `shutter_temperature_k`): it captures a shutter frame and holds its video for
//! `shutter_frozen_frames` frames (the previous frame repeated).
//!
//! **The factory calibration** (ground truth of what a two-point calibration at `ΔT = 0`
//! gives): `G = 1/ĝ` and `O = −(P + ô + ĉ + r̂)/ĝ`, where the estimates carry a relative gain
//! error `N(0, calibration_gain_error)` and an offset error `N(0, calibration_offset_error_k)·R`
//! per pixel — the corrected counts are then `R·(T_max − T_min)·v` (scene counts above
//! `T_min`), with the residual pattern of an imperfect calibration and of the drift since.
//! The factory's bad-pixel map flags every dead and hot pixel.
//!
//! **Defaults** ([`FocalPlaneParams::default`]) are representative of the uncooled 17 µm
//! VOx/a-Si arrays of the camera cores flown or proposed for rendezvous (FLIR Tau 2 / Boson,
//! Lynred Pico class): 14-bit output, NETD 50 mK (datasheet values "< 50 mK"), operability
//! ≥ 99.8 % (datasheets state > 99 %), flat-field correction by a shutter every few tens of
//! seconds to minutes with a video freeze of about half a second (one frame at 1 Hz). The
//! uncorrected offset and gain spreads (10 K of scene, 3 %) and the drift figures are our
//! choice of the orders of magnitude the literature on non-uniformity correction reports —
//! an uncorrected frame is dominated by its pattern — not one camera's measurement.

use crate::image::{Image, write_png16};
use crate::noise::{NoiseRng, mix64, rng_for};
use anyhow::{Context, Result};
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Parameters of the focal-plane model (see the module's documentation for the formula).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FocalPlaneParams {
    /// Seed of the array's own pattern (the same camera across noise seeds by default).
    pub array_seed: u64,
    /// ADC bits of the raw counts.
    pub bits: u32,
    /// Responsivity `R`, counts per kelvin of scene.
    pub responsivity_counts_per_k: f64,
    /// Pedestal `P`, counts.
    pub pedestal_counts: f64,
    /// Relative spread of the pixel gains (σ of `g − 1`).
    pub gain_spread: f64,
    /// Spread of the pixel offsets, kelvin of scene.
    pub offset_spread_k: f64,
    /// Spread of the column offsets, kelvin of scene.
    pub column_spread_k: f64,
    /// Spread of the row offsets, kelvin of scene.
    pub row_spread_k: f64,
    /// Fraction of the array that is dead or hot (half each), scattered.
    pub bad_fraction: f64,
    /// Dead 3 × 3 clusters.
    pub bad_clusters: u32,
    /// Focal-plane warming, kelvin per second.
    pub fpa_drift_k_per_s: f64,
    /// Mean offset drift, kelvin of scene per kelvin of focal plane.
    pub drift_mean: f64,
    /// Spread of the pixel offset drift, kelvin of scene per kelvin of focal plane.
    pub drift_pixel_spread: f64,
    /// Spread of the column offset drift, kelvin of scene per kelvin of focal plane.
    pub drift_column_spread: f64,
    /// NETD, kelvin (the array's temporal noise, added to the study's).
    pub netd_k: f64,
    /// Time between shutter closures, s (0: never).
    pub shutter_period_s: f64,
    /// Frames the video holds at a shutter closure.
    pub shutter_frozen_frames: u32,
    /// Temperature of the shutter's flat field, K.
    pub shutter_temperature_k: f64,
    /// Relative error of the factory's gain estimate (σ).
    pub calibration_gain_error: f64,
    /// Error of the factory's offset estimate, kelvin of scene (σ).
    pub calibration_offset_error_k: f64,
}

impl Default for FocalPlaneParams {
    fn default() -> Self {
        FocalPlaneParams {
            array_seed: 0,
            bits: 14,
            responsivity_counts_per_k: 40.0,
            pedestal_counts: 2_000.0,
            gain_spread: 0.03,
            offset_spread_k: 10.0,
            column_spread_k: 4.0,
            row_spread_k: 1.0,
            bad_fraction: 0.002,
            bad_clusters: 2,
            fpa_drift_k_per_s: 0.05,
            drift_mean: 1.5,
            drift_pixel_spread: 0.5,
            drift_column_spread: 0.5,
            netd_k: 0.05,
            shutter_period_s: 40.0,
            shutter_frozen_frames: 1,
            shutter_temperature_k: 293.0,
            calibration_gain_error: 0.002,
            calibration_offset_error_k: 0.3,
        }
    }
}

/// How a pixel fails.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stuck {
    /// Works.
    No,
    /// Stuck at this many counts.
    At(f64),
}

/// One array, drawn from [`FocalPlaneParams`]: its pattern, its bad pixels and its factory
/// calibration.
#[derive(Clone, Debug)]
pub struct FocalPlane {
    /// The parameters.
    pub params: FocalPlaneParams,
    /// Array width, px.
    pub width: usize,
    /// Array height, px.
    pub height: usize,
    /// Scene range `T_max − T_min` of `v`, K.
    pub scene_range_k: f64,
    gain: Vec<f64>,
    /// `P + o + c + r`, counts.
    offset: Vec<f64>,
    /// Offset drift per kelvin of focal plane, counts.
    drift: Vec<f64>,
    stuck: Vec<Stuck>,
    /// The factory's NUC tables (Q2.14 gain, offset in counts).
    pub nuc_gain: Vec<u16>,
    /// The factory's offsets, counts.
    pub nuc_offset: Vec<i16>,
}

fn normal(rng: &mut NoiseRng) -> f64 {
    StandardNormal.sample(rng)
}

impl FocalPlane {
    /// Draws the array (its pattern from `params.array_seed`) for frames of `width × height`
    /// whose values span `scene_range_k` kelvin.
    pub fn new(params: FocalPlaneParams, width: usize, height: usize, scene_range_k: f64) -> FocalPlane {
        let n = width * height;
        let rk = params.responsivity_counts_per_k;
        let mut rng = rng_for(mix64(params.array_seed ^ 0xF0CA_1F1A), 0);
        let cols: Vec<(f64, f64)> = (0..width)
            .map(|_| {
                (
                    normal(&mut rng) * params.column_spread_k * rk,
                    normal(&mut rng) * params.drift_column_spread * rk,
                )
            })
            .collect();
        let rows: Vec<f64> = (0..height).map(|_| normal(&mut rng) * params.row_spread_k * rk).collect();
        let mut gain = Vec::with_capacity(n);
        let mut offset = Vec::with_capacity(n);
        let mut drift = Vec::with_capacity(n);
        for i in 0..n {
            let (x, y) = (i % width, i / width);
            gain.push(1.0 + normal(&mut rng) * params.gain_spread);
            offset.push(
                params.pedestal_counts + normal(&mut rng) * params.offset_spread_k * rk + cols[x].0 + rows[y],
            );
            drift
                .push(params.drift_mean * rk + normal(&mut rng) * params.drift_pixel_spread * rk + cols[x].1);
        }
        let full = f64::from((1u32 << params.bits) - 1);
        let mut stuck = vec![Stuck::No; n];
        for s in stuck.iter_mut() {
            let u: f64 = rng.random();
            if u < params.bad_fraction / 2.0 {
                *s = Stuck::At(rng.random_range(0.0..0.02) * full);
            } else if u < params.bad_fraction {
                *s = Stuck::At(full - rng.random_range(0.0..0.02) * full);
            }
        }
        for _ in 0..params.bad_clusters {
            if width < 5 || height < 5 {
                break;
            }
            let (x0, y0) = (rng.random_range(1..width - 4), rng.random_range(1..height - 4));
            for y in y0..y0 + 3 {
                for x in x0..x0 + 3 {
                    stuck[y * width + x] = Stuck::At(rng.random_range(0.0..0.02) * full);
                }
            }
        }
        // The factory's two-point estimates, with their errors.
        let mut nuc_gain = Vec::with_capacity(n);
        let mut nuc_offset = Vec::with_capacity(n);
        for (&g, &o) in gain.iter().zip(&offset) {
            let g_hat = g * (1.0 + normal(&mut rng) * params.calibration_gain_error);
            let o_hat = o + normal(&mut rng) * params.calibration_offset_error_k * rk;
            nuc_gain.push((16_384.0 / g_hat).round().clamp(0.0, 65_535.0) as u16);
            nuc_offset.push((-o_hat / g_hat).round().clamp(-32_768.0, 32_767.0) as i16);
        }
        FocalPlane { params, width, height, scene_range_k, gain, offset, drift, stuck, nuc_gain, nuc_offset }
    }

    /// The focal plane's warming at time `t`, K.
    pub fn fpa_delta_k(&self, t: f64) -> f64 {
        self.params.fpa_drift_k_per_s * t
    }

    /// The factory's bad-pixel map (`true` = dead or hot).
    pub fn bad_mask(&self) -> Vec<bool> {
        self.stuck.iter().map(|s| *s != Stuck::No).collect()
    }

    /// Raw counts of a frame whose ideal values are `v` (0..1), at time `t`; `rng` draws the
    /// array's temporal noise.
    pub fn raw(&self, v: &Image, t: f64, rng: &mut NoiseRng) -> Vec<u16> {
        self.expose(|i| f64::from(v.data.get(i).copied().unwrap_or(0.0)), t, rng)
    }

    /// The shutter's flat field at time `t` (its value on the scene scale from `t_min`).
    pub fn shutter(&self, t_min: f64, t: f64, rng: &mut NoiseRng) -> Vec<u16> {
        let v = (self.params.shutter_temperature_k - t_min) / self.scene_range_k;
        self.expose(|_| v, t, rng)
    }

    fn expose(&self, value: impl Fn(usize) -> f64, t: f64, rng: &mut NoiseRng) -> Vec<u16> {
        let p = &self.params;
        let rk = p.responsivity_counts_per_k;
        let full = f64::from((1u32 << p.bits) - 1);
        let dt = self.fpa_delta_k(t);
        (0..self.width * self.height)
            .map(|i| {
                let counts = match self.stuck.get(i) {
                    Some(Stuck::At(c)) => *c,
                    _ => {
                        let g = self.gain.get(i).copied().unwrap_or(1.0);
                        let o = self.offset.get(i).copied().unwrap_or(0.0);
                        let d = self.drift.get(i).copied().unwrap_or(0.0);
                        o + g * rk * self.scene_range_k * value(i) + dt * d + normal(rng) * p.netd_k * rk
                    }
                };
                counts.round().clamp(0.0, full) as u16
            })
            .collect()
    }

    /// The frames (indices) at which the shutter closes in a sequence of `frames` at
    /// `frame_rate_hz`, with the frames whose video it freezes.
    pub fn shutter_frames(&self, frames: usize, frame_rate_hz: f64) -> Vec<(usize, Vec<usize>)> {
        let p = &self.params;
        if p.shutter_period_s <= 0.0 {
            return Vec::new();
        }
        let mut out = Vec::new();
        let mut k = 1.0;
        loop {
            let i = (k * p.shutter_period_s * frame_rate_hz).round() as usize;
            if i >= frames {
                break;
            }
            let frozen = (i..(i + p.shutter_frozen_frames as usize).min(frames)).collect();
            out.push((i, frozen));
            k += 1.0;
        }
        out
    }

    /// Writes frame `v`'s raw counts at time `t` to `out_dir/rel` (16-bit PNG); `rng` draws the
    /// array's temporal noise.
    pub fn write_raw(&self, out_dir: &Path, rel: &str, v: &Image, t: f64, rng: &mut NoiseRng) -> Result<()> {
        write_png16(&out_dir.join(rel), &self.gray16(self.raw(v, t, rng))?)
    }

    /// Writes the shutter's flat field at time `t` to `out_dir/rel` (16-bit PNG).
    pub fn write_shutter(
        &self,
        out_dir: &Path,
        rel: &str,
        t_min: f64,
        t: f64,
        rng: &mut NoiseRng,
    ) -> Result<()> {
        write_png16(&out_dir.join(rel), &self.gray16(self.shutter(t_min, t, rng))?)
    }

    fn gray16(&self, data: Vec<u16>) -> Result<image::ImageBuffer<image::Luma<u16>, Vec<u16>>> {
        image::ImageBuffer::from_raw(self.width as u32, self.height as u32, data).context("raw frame size")
    }

    /// Writes the factory calibration into `out_dir`: the NUC tables at `{stem}.nuc`
    /// (`fusion_io::thermal::NucTables`) and the bad-pixel map at `{stem}_bad_pixels.png`;
    /// returns both paths as given (relative to `out_dir`).
    pub fn write_calibration(&self, out_dir: &Path, stem: &str) -> Result<(String, String)> {
        let (nuc, bad) = (format!("{stem}.nuc"), format!("{stem}_bad_pixels.png"));
        let tables = fusion_io::thermal::NucTables {
            width: self.width,
            height: self.height,
            gain: self.nuc_gain.clone(),
            offset: self.nuc_offset.clone(),
        };
        tables.write(&out_dir.join(&nuc))?;
        fusion_io::thermal::BadPixels::from_mask(self.width, self.height, &self.bad_mask())
            .write(&out_dir.join(&bad))?;
        Ok((nuc, bad))
    }

    /// The ideal corrected counts of a value `v`: `R·(T_max − T_min)·v`.
    pub fn ideal_counts(&self, v: f64) -> f64 {
        self.params.responsivity_counts_per_k * self.scene_range_k * v
    }
}

/// A frame the shutter froze repeats the raw counts of the frame before: copies the file
/// `out_dir/from` over `out_dir/to` (call in frame order, so a run of frozen frames repeats the
/// last live one).
pub fn repeat_frozen(out_dir: &Path, from: &str, to: &str) -> Result<()> {
    let src = out_dir.join(from);
    let bytes = std::fs::read(&src).with_context(|| format!("cannot read {}", src.display()))?;
    fusion_io::write_bytes(&out_dir.join(to), &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factory_tables_undo_the_pattern_at_calibration() {
        let p = FocalPlaneParams {
            netd_k: 0.0,
            bad_fraction: 0.0,
            bad_clusters: 0,
            ..FocalPlaneParams::default()
        };
        let fp = FocalPlane::new(p, 64, 48, 250.0);
        let v = Image { width: 64, height: 48, data: vec![0.5; 64 * 48] };
        let raw = fp.raw(&v, 0.0, &mut rng_for(1, 2));
        // Uncorrected: the pattern (≈ 10 K of offsets at 40 counts/K).
        let sd = |d: &[f64]| {
            let m = d.iter().sum::<f64>() / d.len() as f64;
            (d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / d.len() as f64).sqrt()
        };
        let raw_f: Vec<f64> = raw.iter().map(|&r| f64::from(r)).collect();
        assert!(sd(&raw_f) > 300.0, "{}", sd(&raw_f));
        // Corrected with the tables: the calibration's residual (0.3 K ≈ 12 counts, plus
        // rounding) around the ideal level.
        let corrected: Vec<f64> = raw
            .iter()
            .zip(fp.nuc_gain.iter().zip(&fp.nuc_offset))
            .map(|(&x, (&g, &o))| (f64::from(g) * f64::from(x) / 16_384.0).round() + f64::from(o))
            .collect();
        let m = corrected.iter().sum::<f64>() / corrected.len() as f64;
        assert!((m - fp.ideal_counts(0.5)).abs() < 5.0, "{m}");
        assert!(sd(&corrected) < 20.0, "{}", sd(&corrected));
    }
}
