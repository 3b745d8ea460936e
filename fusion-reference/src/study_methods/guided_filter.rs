//! Box sums and the guided filter, O(1) per pixel whatever the radius.
//!
//! Guided filter: He, Sun, Tang, "Guided image filtering", ECCV 2010 / IEEE TPAMI 35(6), 2013.
//! For a guidance image `I`, an input `p`, a window radius `r` and a regulariser `ε`, every
//! `(2r+1)²` window `ω_k` fits the linear model `q = a_k I + b_k`:
//!
//! ```text
//! a_k = cov_k(I, p) / (var_k(I) + ε)        b_k = mean_k(p) − a_k mean_k(I)
//! q_i = mean_{k ∋ i}(a_k) · I_i + mean_{k ∋ i}(b_k)
//! ```
//!
//! Every mean is a box mean. As in the authors' O(1) formulation, a window that leaves the
//! image is clipped to it and divided by the number of pixels inside (`boxfilter(I, r) ./ N`);
//! no padding is invented. The box sums are running sums along rows (prefix differences) and
//! along columns (a sliding accumulator), so the cost does not depend on `r`.

use fusion_io::Gray;

/// Mean over the `(2r+1)²` window centred on each pixel, clipped to the image (the divisor is
/// the number of pixels inside the clipped window).
///
/// Rows are averaged from prefix sums; columns by a sliding sum of row means kept in a ring of
/// `2r + 2` rows (the clipped window is a rectangle, so its mean is the mean over its rows of
/// the row means), so the cost is O(1) per pixel and the working set a few hundred rows at most.
pub fn box_mean(img: &Gray<f64>, r: usize) -> Gray<f64> {
    let mut out = vec![0.0; img.data.len()];
    box_mean_into(&img.data, img.width, r, &mut out);
    Gray { width: img.width, height: img.height, data: out }
}

/// [`box_mean`] of the `w`-wide plane `src` into `out` (same length).
pub fn box_mean_into(src: &[f64], w: usize, r: usize, out: &mut [f64]) {
    if w == 0 || src.is_empty() {
        return;
    }
    let h = src.len() / w;
    let inv_x: Vec<f64> = (0..w).map(|x| 1.0 / ((x + r + 1).min(w) - x.saturating_sub(r)) as f64).collect();
    let mut prefix = vec![0.0; w + 1];
    let slots = (2 * r + 2).min(h + 1);
    let mut ring = vec![0.0; slots * w];
    // The clipped horizontal mean of row `y` into its ring slot.
    let mut row_mean = |y: usize, ring: &mut [f64]| {
        let row = &src[y * w..(y + 1) * w];
        for (x, &v) in row.iter().enumerate() {
            prefix[x + 1] = prefix[x] + v;
        }
        let dst = &mut ring[(y % slots) * w..(y % slots + 1) * w];
        for (x, d) in dst.iter_mut().enumerate() {
            *d = (prefix[(x + r + 1).min(w)] - prefix[x.saturating_sub(r)]) * inv_x[x];
        }
    };
    let mut acc = vec![0.0; w];
    for y in 0..=r.min(h - 1) {
        row_mean(y, &mut ring);
        let slot = &ring[(y % slots) * w..(y % slots + 1) * w];
        acc.iter_mut().zip(slot).for_each(|(a, &v)| *a += v);
    }
    for y in 0..h {
        let inv_y = 1.0 / ((y + r + 1).min(h) - y.saturating_sub(r)) as f64;
        out[y * w..(y + 1) * w].iter_mut().zip(&acc).for_each(|(o, &a)| *o = a * inv_y);
        if y + r + 1 < h {
            let yy = y + r + 1;
            row_mean(yy, &mut ring);
            let slot = &ring[(yy % slots) * w..(yy % slots + 1) * w];
            acc.iter_mut().zip(slot).for_each(|(a, &v)| *a += v);
        }
        if y >= r {
            let yy = y - r;
            let slot = &ring[(yy % slots) * w..(yy % slots + 1) * w];
            acc.iter_mut().zip(slot).for_each(|(a, &v)| *a -= v);
        }
    }
}

/// The guided filter of `input` with guidance `guide` (same size), window radius `r`,
/// regulariser `eps` (in the squared units of `guide`). A window with `var(I) + ε = 0` (only
/// possible with `ε = 0` on a flat guide) takes `a = 0`, i.e. the window mean of `p`.
///
/// Panics if the two images differ in size (callers check sizes first).
pub fn guided_filter(guide: &Gray<f64>, input: &Gray<f64>, r: usize, eps: f64) -> Gray<f64> {
    assert_eq!((guide.width, guide.height), (input.width, input.height), "guided filter: sizes differ");
    let (w, n) = (guide.width, guide.data.len());
    let (i_img, p_img) = (&guide.data, &input.data);
    // Five planes, reused: the window means of I and p, then of a and b; the products; the
    // correlations, then a and b in place.
    let (mut mean_i, mut mean_p, mut tmp, mut a, mut b) =
        (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    box_mean_into(i_img, w, r, &mut mean_i);
    box_mean_into(p_img, w, r, &mut mean_p);
    tmp.iter_mut().zip(i_img.iter().zip(p_img)).for_each(|(t, (&i, &p))| *t = i * p);
    box_mean_into(&tmp, w, r, &mut a); // corr(I, p)
    tmp.iter_mut().zip(i_img).for_each(|(t, &i)| *t = i * i);
    box_mean_into(&tmp, w, r, &mut b); // corr(I, I)
    for k in 0..n {
        let (mi, mp) = (mean_i[k], mean_p[k]);
        let var = (b[k] - mi * mi).max(0.0);
        let cov = a[k] - mi * mp;
        let den = var + eps;
        let ak = if den > 0.0 { cov / den } else { 0.0 };
        a[k] = ak;
        b[k] = mp - ak * mi;
    }
    box_mean_into(&a, w, r, &mut mean_i); // mean of a
    box_mean_into(&b, w, r, &mut mean_p); // mean of b
    for k in 0..n {
        tmp[k] = mean_i[k] * i_img[k] + mean_p[k];
    }
    Gray { width: w, height: guide.height, data: tmp }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: usize, h: usize, mut f: impl FnMut(usize, usize) -> f64) -> Gray<f64> {
        Gray { width: w, height: h, data: (0..w * h).map(|i| f(i % w, i / w)).collect() }
    }

    /// A direct (O(r²)) clipped box mean.
    fn box_mean_direct(g: &Gray<f64>, r: usize) -> Gray<f64> {
        img(g.width, g.height, |x, y| {
            let (mut s, mut n) = (0.0, 0.0);
            for yy in y.saturating_sub(r)..(y + r + 1).min(g.height) {
                for xx in x.saturating_sub(r)..(x + r + 1).min(g.width) {
                    s += g.at(xx, yy);
                    n += 1.0;
                }
            }
            s / n
        })
    }

    fn noise(w: usize, h: usize, seed: u64) -> Gray<f64> {
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        img(w, h, |_, _| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 33) % 256) as f64
        })
    }

    #[test]
    fn box_mean_hand_case() {
        // 3×3 ramp 1..9, r = 1: corner (0,0) averages {1,2,4,5}; centre averages all nine.
        let g = img(3, 3, |x, y| (y * 3 + x + 1) as f64);
        let m = box_mean(&g, 1);
        assert!((m.at(0, 0) - 3.0).abs() < 1e-12);
        assert!((m.at(1, 1) - 5.0).abs() < 1e-12);
        assert!((m.at(2, 1) - (2.0 + 3.0 + 5.0 + 6.0 + 8.0 + 9.0) / 6.0).abs() < 1e-12);
    }

    #[test]
    fn box_mean_matches_the_direct_sum_for_any_radius_and_shape() {
        for (w, h) in [(1, 1), (1, 7), (9, 1), (13, 6), (6, 13)] {
            let g = noise(w, h, (w * 31 + h) as u64);
            for r in [0, 1, 2, 5, 20] {
                let (fast, direct) = (box_mean(&g, r), box_mean_direct(&g, r));
                for (a, b) in fast.data.iter().zip(&direct.data) {
                    assert!((a - b).abs() < 1e-9, "{w}x{h} r={r}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn guided_filter_of_a_constant_is_the_constant() {
        let guide = noise(17, 11, 3);
        let p = img(17, 11, |_, _| 42.5);
        for (r, eps) in [(1, 1e-6), (4, 0.3), (45, 1e3)] {
            let q = guided_filter(&guide, &p, r, eps);
            assert!(q.data.iter().all(|v| (v - 42.5).abs() < 1e-9), "r={r} eps={eps}");
        }
        // flat guide too, even with ε = 0 (the 0/0 window takes a = 0)
        let q = guided_filter(&p, &noise(17, 11, 4), 2, 0.0);
        assert!(q.data.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn guided_filter_with_tiny_eps_and_i_equal_p_reproduces_p() {
        // Textured image with a flat patch: textured windows give a ≈ 1, b ≈ 0; flat windows
        // give a·I + b = p whatever a is.
        let mut p = noise(24, 19, 7);
        for y in 5..12 {
            for x in 3..14 {
                p.data[y * 24 + x] = 77.0;
            }
        }
        for r in [1, 3, 8] {
            let q = guided_filter(&p, &p, r, 1e-9);
            for (a, b) in q.data.iter().zip(&p.data) {
                assert!((a - b).abs() < 1e-6, "r={r}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn guided_filter_is_linear_in_the_input_and_smooths_with_large_eps() {
        let (guide, p1, p2) = (noise(15, 15, 1), noise(15, 15, 2), noise(15, 15, 5));
        let combo = img(15, 15, |x, y| 2.0 * p1.at(x, y) - 0.5 * p2.at(x, y));
        let (q1, q2, qc) = (
            guided_filter(&guide, &p1, 2, 50.0),
            guided_filter(&guide, &p2, 2, 50.0),
            guided_filter(&guide, &combo, 2, 50.0),
        );
        for k in 0..q1.data.len() {
            assert!((qc.data[k] - (2.0 * q1.data[k] - 0.5 * q2.data[k])).abs() < 1e-8);
        }
        // ε → ∞: a → 0, the output is the mean of the window means of p (a box blur).
        let q = guided_filter(&guide, &p1, 2, 1e30);
        let blur = box_mean(&box_mean(&p1, 2), 2);
        for (a, b) in q.data.iter().zip(&blur.data) {
            assert!((a - b).abs() < 1e-6);
        }
    }
}
