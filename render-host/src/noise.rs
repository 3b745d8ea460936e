//! Sensor noise: Gaussian blur, additive white Gaussian noise, 1/f ("pink") noise, clipping.
//!
//! Every draw comes from a [`NoiseRng`] (xoshiro256++, a fixed, portable algorithm) seeded from
//! the dataset seed and the image's identity, so the same seed gives the same bytes whatever the
//! thread count.

use crate::image::Image;
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand_distr::{Distribution, StandardNormal};
use rustfft::{FftPlanner, num_complex::Complex};
use serde::{Deserialize, Serialize};

/// The random generator behind all noise.
pub type NoiseRng = Xoshiro256PlusPlus;

/// Parameters of the sensor-noise model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoiseParams {
    /// Standard deviation of the Gaussian blur, pixels (0 = none).
    pub blur_sigma_px: f32,
    /// Variance of the additive white Gaussian noise on [0, 1].
    pub awgn_variance: f64,
    /// Variance of the 1/f noise on [0, 1] (TIR only).
    pub pink_variance: f64,
    /// Exponent α of the 1/f amplitude spectrum `(f_x² + f_y²)^(−α/2)`.
    pub pink_alpha: f64,
}

impl Default for NoiseParams {
    fn default() -> Self {
        NoiseParams { blur_sigma_px: 1.0, awgn_variance: 0.0022, pink_variance: 0.0022, pink_alpha: 1.0 }
    }
}

/// Which sensor an image comes from (TIR adds the 1/f noise).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Band {
    /// Visible camera.
    Vis,
    /// Thermal-infrared microbolometer.
    Tir,
}

/// SplitMix64's increment (the golden ratio in 64 bits).
const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64's step as a hash (Steele, Lea & Flood 2014): `z` advanced by one increment, then
/// finalised; a well-mixed 64-bit value of `z`.
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(GOLDEN_GAMMA);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The host side's one small seeded generator (SplitMix64): test frames, the stress study's
/// patterns, the BRIEF test pattern. Its `k`-th output is [`mix64`] of `seed + k·γ`, so a
/// stream can also be read at any position without stepping (as the stress patterns do).
/// The renderer's image noise uses [`NoiseRng`] ([`rng_for`]), seeded through [`mix64`].
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator whose first output is `mix64(seed)`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let out = mix64(self.0);
        self.0 = self.0.wrapping_add(GOLDEN_GAMMA);
        out
    }
}

/// A generator for one image: `seed` is the dataset seed, `stream` names the image.
pub fn rng_for(seed: u64, stream: u64) -> NoiseRng {
    NoiseRng::seed_from_u64(mix64(mix64(seed) ^ stream))
}

/// Separable Gaussian blur with a kernel truncated at 4σ, edges clamped.
pub fn gaussian_blur(img: &Image, sigma: f32) -> Image {
    if sigma <= 0.0 || img.data.is_empty() {
        return img.clone();
    }
    let r = (4.0 * sigma).ceil() as isize;
    let mut k: Vec<f32> = (-r..=r).map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp()).collect();
    let s: f32 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    let (w, h) = (img.width as isize, img.height as isize);
    let mut tmp = Image::new(img.width, img.height);
    for y in 0..h {
        let row = &img.data[(y * w) as usize..((y + 1) * w) as usize];
        let out = &mut tmp.data[(y * w) as usize..((y + 1) * w) as usize];
        for (x, o) in out.iter_mut().enumerate() {
            let x = x as isize;
            *o = k
                .iter()
                .enumerate()
                .map(|(j, kv)| kv * row[(x + j as isize - r).clamp(0, w - 1) as usize])
                .sum();
        }
    }
    let mut out = Image::new(img.width, img.height);
    for y in 0..h {
        for x in 0..w {
            out.data[(y * w + x) as usize] = k
                .iter()
                .enumerate()
                .map(|(j, kv)| kv * tmp.data[((y + j as isize - r).clamp(0, h - 1) * w + x) as usize])
                .sum();
        }
    }
    out
}

/// Adds white Gaussian noise of the given variance.
pub fn add_awgn(img: &mut Image, variance: f64, rng: &mut NoiseRng) {
    let sd = variance.max(0.0).sqrt() as f32;
    for v in &mut img.data {
        let n: f32 = StandardNormal.sample(rng);
        *v += sd * n;
    }
}

/// In-place 2-D FFT of a row-major `w × h` array.
fn fft2(data: &mut [Complex<f64>], w: usize, h: usize, inverse: bool) {
    let mut planner = FftPlanner::<f64>::new();
    let (row_fft, col_fft) = if inverse {
        (planner.plan_fft_inverse(w), planner.plan_fft_inverse(h))
    } else {
        (planner.plan_fft_forward(w), planner.plan_fft_forward(h))
    };
    row_fft.process(data);
    let mut t = transpose(data, w, h);
    col_fft.process(&mut t);
    data.copy_from_slice(&transpose(&t, h, w));
}

fn transpose(data: &[Complex<f64>], w: usize, h: usize) -> Vec<Complex<f64>> {
    let mut out = vec![Complex::new(0.0, 0.0); w * h];
    for y in 0..h {
        for x in 0..w {
            out[x * h + y] = data[y * w + x];
        }
    }
    out
}

/// Signed frequency (cycles/pixel) of FFT bin `i` of `n`.
pub fn fft_freq(i: usize, n: usize) -> f64 {
    let i = i as f64;
    let n = n as f64;
    if i < n / 2.0 { i / n } else { (i - n) / n }
}

/// A zero-mean, unit-variance 1/f^α field: white Gaussian noise filtered in the Fourier domain
/// by `(f_x² + f_y²)^(−α/2)` (DC removed), real part kept, then normalised to unit variance.
pub fn pink_noise(width: u32, height: u32, alpha: f64, rng: &mut NoiseRng) -> Vec<f32> {
    let (w, h) = (width as usize, height as usize);
    if w == 0 || h == 0 {
        return Vec::new();
    }
    let mut buf: Vec<Complex<f64>> =
        (0..w * h).map(|_| Complex::new(StandardNormal.sample(rng), 0.0)).collect();
    fft2(&mut buf, w, h, false);
    for y in 0..h {
        let fy = fft_freq(y, h);
        for x in 0..w {
            let fx = fft_freq(x, w);
            let f2 = fx * fx + fy * fy;
            buf[y * w + x] *= if f2 > 0.0 { f2.powf(-alpha / 2.0) } else { 0.0 };
        }
    }
    fft2(&mut buf, w, h, true);
    let n = (w * h) as f64;
    let mean = buf.iter().map(|c| c.re).sum::<f64>() / n;
    let var = buf.iter().map(|c| (c.re - mean).powi(2)).sum::<f64>() / n;
    let k = if var > 0.0 { 1.0 / var.sqrt() } else { 0.0 };
    buf.iter().map(|c| ((c.re - mean) * k) as f32).collect()
}

/// The full sensor model: blur, AWGN, (TIR) 1/f noise, clip to [0, 1].
pub fn apply_sensor_noise(img: &Image, params: &NoiseParams, band: Band, rng: &mut NoiseRng) -> Image {
    let mut out = gaussian_blur(img, params.blur_sigma_px);
    add_awgn(&mut out, params.awgn_variance, rng);
    if band == Band::Tir && params.pink_variance > 0.0 {
        let sd = params.pink_variance.sqrt() as f32;
        let pink = pink_noise(out.width, out.height, params.pink_alpha, rng);
        out.data.iter_mut().zip(pink).for_each(|(v, p)| *v += sd * p);
    }
    out.clip();
    out
}

/// Radially averaged power spectrum of a square image: `(frequency, mean power)` for each
/// integer radius `1..n/2` (in bins), frequencies in cycles/pixel.
pub fn radial_power_spectrum(data: &[f32], n: usize) -> Vec<(f64, f64)> {
    let mut buf: Vec<Complex<f64>> = data.iter().map(|&v| Complex::new(f64::from(v), 0.0)).collect();
    fft2(&mut buf, n, n, false);
    let mut sum = vec![0.0; n / 2 + 1];
    let mut cnt = vec![0usize; n / 2 + 1];
    for y in 0..n {
        for x in 0..n {
            let r = (fft_freq(x, n).hypot(fft_freq(y, n)) * n as f64).round() as usize;
            if r < sum.len() {
                sum[r] += buf[y * n + x].norm_sqr();
                cnt[r] += 1;
            }
        }
    }
    (1..sum.len()).filter(|&r| cnt[r] > 0).map(|r| (r as f64 / n as f64, sum[r] / cnt[r] as f64)).collect()
}
