//! Small linear filters the study methods share, with MATLAB `imfilter(…, 'replicate')`
//! semantics: correlation (not convolution) and samples outside the image replaced by the
//! nearest edge sample.

use fusion_io::Gray;

fn clamp(i: isize, n: usize) -> usize {
    i.clamp(0, n as isize - 1) as usize
}

/// Correlation with a 3×3 kernel, replicate border.
pub fn correlate3_replicate(img: &Gray<f64>, k: &[[f64; 3]; 3]) -> Gray<f64> {
    let (w, h) = (img.width, img.height);
    let mut out = Gray::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (j, krow) in k.iter().enumerate() {
                let yy = clamp(y as isize + j as isize - 1, h);
                for (i, &kv) in krow.iter().enumerate() {
                    s += kv * img.data[yy * w + clamp(x as isize + i as isize - 1, w)];
                }
            }
            out.data[y * w + x] = s;
        }
    }
    out
}

/// Correlation with the separable kernel `taps ⊗ taps` (odd length), replicate border.
pub fn separable_replicate(img: &Gray<f64>, taps: &[f64]) -> Gray<f64> {
    let (w, h) = (img.width, img.height);
    let r = (taps.len() / 2) as isize;
    let mut tmp = Gray::<f64>::new(w, h);
    for y in 0..h {
        let row = &img.data[y * w..(y + 1) * w];
        for x in 0..w {
            tmp.data[y * w + x] =
                taps.iter().enumerate().map(|(i, &t)| t * row[clamp(x as isize + i as isize - r, w)]).sum();
        }
    }
    let mut out = Gray::<f64>::new(w, h);
    for y in 0..h {
        let dst = &mut out.data[y * w..(y + 1) * w];
        for (i, &t) in taps.iter().enumerate() {
            let src = &tmp.data[clamp(y as isize + i as isize - r, h) * w..][..w];
            dst.iter_mut().zip(src).for_each(|(d, &s)| *d += t * s);
        }
    }
    out
}

/// MATLAB `fspecial('gaussian', size, sigma)` as its 1-D factor: `exp(−x²/2σ²)` on
/// `x = −size/2 … size/2`, normalised to sum 1 (the 2-D kernel is the outer product, and is
/// normalised when the factor is).
pub fn gaussian_taps(size: usize, sigma: f64) -> Vec<f64> {
    let r = (size as f64 - 1.0) / 2.0;
    let taps: Vec<f64> = (0..size).map(|i| (-(i as f64 - r).powi(2) / (2.0 * sigma * sigma)).exp()).collect();
    let sum: f64 = taps.iter().sum();
    taps.iter().map(|t| t / sum).collect()
}

/// The `size × size` mean (MATLAB `fspecial('average', size)`), replicate border, in O(1) per
/// pixel (running sums over the padded rows and columns).
pub fn box_mean_replicate(img: &Gray<f64>, size: usize) -> Gray<f64> {
    let (w, h) = (img.width, img.height);
    let r = size / 2;
    let norm = 1.0 / size as f64;
    // One axis: running sum over a replicate-padded line.
    let line = |src: &[f64], dst: &mut [f64]| {
        let n = src.len();
        let at = |i: isize| src[clamp(i, n)];
        let mut s: f64 = (-(r as isize)..=r as isize).map(at).sum();
        for (x, d) in dst.iter_mut().enumerate() {
            *d = s * norm;
            let x = x as isize;
            s += at(x + r as isize + 1) - at(x - r as isize);
        }
    };
    let mut tmp = Gray::new(w, h);
    for (src, dst) in img.data.chunks_exact(w).zip(tmp.data.chunks_exact_mut(w)) {
        line(src, dst);
    }
    let mut out = Gray::new(w, h);
    let (mut col, mut res) = (vec![0.0; h], vec![0.0; h]);
    for x in 0..w {
        col.iter_mut().zip(tmp.data[x..].iter().step_by(w)).for_each(|(c, &v)| *c = v);
        line(&col, &mut res);
        out.data[x..].iter_mut().step_by(w).zip(&res).for_each(|(o, &v)| *o = v);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: usize, h: usize, f: impl Fn(usize, usize) -> f64) -> Gray<f64> {
        Gray { width: w, height: h, data: (0..w * h).map(|i| f(i % w, i / w)).collect() }
    }

    #[test]
    fn laplacian_hand_case_and_constant() {
        const L: [[f64; 3]; 3] = [[0.0, 1.0, 0.0], [1.0, -4.0, 1.0], [0.0, 1.0, 0.0]];
        let mut g = img(5, 5, |_, _| 10.0);
        assert!(correlate3_replicate(&g, &L).data.iter().all(|&v| v == 0.0));
        g.data[12] = 14.0; // centre spike: -16 there, +4 at its four neighbours
        let l = correlate3_replicate(&g, &L);
        assert_eq!(l.at(2, 2), -16.0);
        assert_eq!(l.at(1, 2), 4.0);
        assert_eq!(l.at(1, 1), 0.0);
    }

    #[test]
    fn gaussian_taps_sum_to_one_and_are_symmetric() {
        let t = gaussian_taps(11, 5.0);
        assert!((t.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        assert!((t[0] - t[10]).abs() < 1e-16 && t[5] > t[4]);
        // 2-D correlation of a constant stays constant (replicate border)
        let g = separable_replicate(&img(7, 4, |_, _| 3.0), &t);
        assert!(g.data.iter().all(|v| (v - 3.0).abs() < 1e-12));
    }

    #[test]
    fn replicate_box_mean_matches_the_direct_sum() {
        let g = img(9, 6, |x, y| ((x * 37 + y * 11) % 17) as f64);
        for size in [1, 3, 5, 31] {
            let fast = box_mean_replicate(&g, size);
            let direct = separable_replicate(&g, &vec![1.0 / size as f64; size]);
            for (a, b) in fast.data.iter().zip(&direct.data) {
                assert!((a - b).abs() < 1e-9, "size {size}");
            }
        }
    }
}
