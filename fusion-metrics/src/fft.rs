//! Two-dimensional real FFTs for the frequency-domain filters of Qcb and Qcv.
//!
//! MATLAB's `ifft2(ifftshift(fftshift(fft2(I)) .* S))` with a real filter `S` that is even in
//! both frequencies equals a real-to-complex transform of the rows, a complex transform of the
//! half-spectrum's columns, the product with `S` at each bin's signed frequency, and the
//! inverse — the real part of MATLAB's result, at half the work. Sizes need not be powers of
//! two (`rustfft` plans mixed radices and Bluestein).
//!
//! Spectra are kept in column layout (bin `(ky, kx)` at `kx·height + ky`): the forward
//! transform ends with the column FFTs and the inverse starts with them, so each direction
//! needs one transpose, and the filters are element-wise products in that layout. Every
//! buffer and scratch lives in the plan and is reused from one transform to the next; the
//! arithmetic is the same as transforming row-major spectra (the same plans on the same data).

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

/// Planned transforms and their buffers for one `width × height` grid.
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
    /// A half spectrum in row layout (`height × half`).
    rows: Vec<Complex<f64>>,
    /// A half spectrum in column layout, for the inverse.
    work: Vec<Complex<f64>>,
    /// One image row (the real transform uses its input as scratch).
    line: Vec<f64>,
    row_fwd_scratch: Vec<Complex<f64>>,
    row_inv_scratch: Vec<Complex<f64>>,
    col_scratch: Vec<Complex<f64>>,
}

impl Spectra2d {
    /// Plans the transforms of a `width × height` image.
    pub fn new(width: usize, height: usize) -> Self {
        let mut real = RealFftPlanner::<f64>::new();
        let mut complex = FftPlanner::<f64>::new();
        let half = width / 2 + 1;
        let (row_fwd, row_inv) = (real.plan_fft_forward(width), real.plan_fft_inverse(width));
        let (col_fwd, col_inv) = (complex.plan_fft_forward(height), complex.plan_fft_inverse(height));
        let col_scratch_len = col_fwd.get_inplace_scratch_len().max(col_inv.get_inplace_scratch_len());
        Self {
            width,
            height,
            half,
            rows: vec![Complex::default(); half * height],
            work: vec![Complex::default(); half * height],
            line: vec![0.0; width],
            row_fwd_scratch: row_fwd.make_scratch_vec(),
            row_inv_scratch: row_inv.make_scratch_vec(),
            col_scratch: vec![Complex::default(); col_scratch_len],
            row_fwd,
            row_inv,
            col_fwd,
            col_inv,
        }
    }

    /// Bins of a half spectrum: `(width/2 + 1) · height`.
    pub fn len(&self) -> usize {
        self.half * self.height
    }

    /// `filter(ky, kx)` (FFT indices) at every bin, in column layout.
    pub fn table(&self, filter: impl Fn(usize, usize) -> f64) -> Vec<f64> {
        let mut t = Vec::with_capacity(self.len());
        for kx in 0..self.half {
            t.extend((0..self.height).map(|ky| filter(ky, kx)));
        }
        t
    }

    /// The half spectrum (un-normalised, column layout) of a real `width × height` image into
    /// `out` (`len()` bins).
    pub fn forward(&mut self, img: &[f64], out: &mut [Complex<f64>]) {
        let (w, h, half) = (self.width, self.height, self.half);
        for y in 0..h {
            self.line.copy_from_slice(&img[y * w..(y + 1) * w]);
            self.row_fwd
                .process_with_scratch(
                    &mut self.line,
                    &mut self.rows[y * half..(y + 1) * half],
                    &mut self.row_fwd_scratch,
                )
                .expect("buffer lengths come from the plan");
        }
        transpose::transpose(&self.rows, out, half, h);
        self.col_fwd.process_with_scratch(out, &mut self.col_scratch);
    }

    /// The real image whose spectrum (column layout) has `bin(i)` at bin `i` — a spectrum times
    /// a filter that is even in both frequencies — normalised like MATLAB's `ifft2`, into the
    /// first `width` samples of `height` rows of `out`, `stride` apart.
    pub fn inverse(&mut self, bin: impl Fn(usize) -> Complex<f64>, out: &mut [f64], stride: usize) {
        let (w, h, half) = (self.width, self.height, self.half);
        for (i, v) in self.work.iter_mut().enumerate() {
            *v = bin(i);
        }
        self.col_inv.process_with_scratch(&mut self.work, &mut self.col_scratch);
        transpose::transpose(&self.work, &mut self.rows, h, half);
        let norm = 1.0 / (w * h) as f64;
        for y in 0..h {
            let row = &mut self.rows[y * half..(y + 1) * half];
            // The real part of the full inverse: the DC and Nyquist bins count by their real part.
            row[0].im = 0.0;
            if w % 2 == 0 {
                row[half - 1].im = 0.0;
            }
            let dst = &mut out[y * stride..y * stride + w];
            self.row_inv
                .process_with_scratch(row, dst, &mut self.row_inv_scratch)
                .expect("buffer lengths come from the plan");
            dst.iter_mut().for_each(|v| *v *= norm);
        }
    }
}
