//! Two-dimensional real FFTs for the frequency-domain filters of Qcb and Qcv.
//!
//! MATLAB's `ifft2(ifftshift(fftshift(fft2(I)) .* S))` with a real filter `S` that is even in
//! both frequencies equals a real-to-complex transform of the rows, a complex transform of the
//! half-spectrum's columns, the product with `S` at each bin's signed frequency, and the
//! inverse — the real part of MATLAB's result, at half the work. Sizes need not be powers of
//! two (`rustfft` plans mixed radices and Bluestein).

use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// The smallest size `≥ n` whose only prime factors are 2, 3, 5 and 7 (fast to transform).
pub(super) fn fast_size(n: usize) -> usize {
    (n.max(1)..)
        .find(|&m| {
            let mut r = m;
            for p in [2, 3, 5, 7] {
                while r % p == 0 {
                    r /= p;
                }
            }
            r == 1
        })
        .expect("every n has a 7-smooth successor")
}

/// Planned transforms for one `width × height` grid.
pub(super) struct Spectra2d {
    /// Columns of the image.
    pub width: usize,
    /// Rows of the image.
    pub height: usize,
    /// Bins per spectrum row: `width/2 + 1`.
    half: usize,
    row_fwd: Arc<dyn RealToComplex<f64>>,
    row_inv: Arc<dyn ComplexToReal<f64>>,
    col_fwd: Arc<dyn Fft<f64>>,
    col_inv: Arc<dyn Fft<f64>>,
}

impl Spectra2d {
    /// Plans the transforms of a `width × height` image.
    pub fn new(width: usize, height: usize) -> Self {
        let mut real = RealFftPlanner::<f64>::new();
        let mut complex = FftPlanner::<f64>::new();
        Self {
            width,
            height,
            half: width / 2 + 1,
            row_fwd: real.plan_fft_forward(width),
            row_inv: real.plan_fft_inverse(width),
            col_fwd: complex.plan_fft_forward(height),
            col_inv: complex.plan_fft_inverse(height),
        }
    }

    /// The half spectrum (`height × (width/2 + 1)`, row-major, un-normalised) of a real image.
    pub fn forward(&self, img: &[f64]) -> Vec<Complex<f64>> {
        let (w, h, half) = (self.width, self.height, self.half);
        let mut spec = vec![Complex::default(); h * half];
        let mut row = vec![0f64; w];
        let mut scratch = self.row_fwd.make_scratch_vec();
        for y in 0..h {
            row.copy_from_slice(&img[y * w..(y + 1) * w]);
            self.row_fwd
                .process_with_scratch(&mut row, &mut spec[y * half..(y + 1) * half], &mut scratch)
                .expect("buffer lengths come from the plan");
        }
        self.columns(&mut spec, &*self.col_fwd);
        spec
    }

    /// The real image whose spectrum is `spec` times `filter(ky, kx)` (FFT indices; the filter
    /// must be even in both frequencies), normalised like MATLAB's `ifft2`.
    pub fn inverse_filtered(&self, spec: &[Complex<f64>], filter: impl Fn(usize, usize) -> f64) -> Vec<f64> {
        let (w, h, half) = (self.width, self.height, self.half);
        let mut work: Vec<Complex<f64>> = spec.to_vec();
        for ky in 0..h {
            for (kx, v) in work[ky * half..(ky + 1) * half].iter_mut().enumerate() {
                *v *= filter(ky, kx);
            }
        }
        self.columns(&mut work, &*self.col_inv);
        let mut out = vec![0f64; w * h];
        let mut scratch = self.row_inv.make_scratch_vec();
        let norm = 1.0 / (w * h) as f64;
        for y in 0..h {
            let row = &mut work[y * half..(y + 1) * half];
            // The real part of the full inverse: the DC and Nyquist bins count by their real part.
            row[0].im = 0.0;
            if w % 2 == 0 {
                row[half - 1].im = 0.0;
            }
            let dst = &mut out[y * w..(y + 1) * w];
            self.row_inv
                .process_with_scratch(row, dst, &mut scratch)
                .expect("buffer lengths come from the plan");
            dst.iter_mut().for_each(|v| *v *= norm);
        }
        out
    }

    /// Transforms every column of a half spectrum in place: transposed so that the columns
    /// are contiguous, all transformed in one batch, transposed back.
    fn columns(&self, spec: &mut [Complex<f64>], fft: &dyn Fft<f64>) {
        let (h, half) = (self.height, self.half);
        let mut cols = vec![Complex::default(); h * half];
        transpose::transpose(spec, &mut cols, half, h);
        let mut scratch = vec![Complex::default(); fft.get_inplace_scratch_len()];
        fft.process_with_scratch(&mut cols, &mut scratch);
        transpose::transpose(&cols, spec, h, half);
    }
}
