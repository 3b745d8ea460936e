//! IFEVIP f64 reference, written from the spec (`docs/reference/fusion-algorithms.md`,
//! IFEVIP, Part B; guards of Part A) on images in 0..255 grey-level units holding 8-bit
//! values. Independent of the core's integer code (it shares only the parameter type).
//!
//! Steps, as the published MATLAB code does them:
//! 1. IR → `D×D` (`D` = 512) with MATLAB `imresize` bicubic ([`imresize`]: Keys a = −0.5,
//!    antialiasing kernel when shrinking, symmetric reflection at the ends, the dimension with the
//!    smaller scale resized first, the result rounded to `uint8` after each pass). Skipped
//!    (identity) when the IR already is `D×D`.
//! 2. Quadtree (`qtdecomp`): split while `max − min > 51` and the side is above 32.
//! 3. Local minimum: `imerode` by a 32×32 square (rows `r−15…r+16`), outside ignored.
//! 4. Per-leaf cubic Bézier patch of side `n + 1` from the 4×4 control points at the offsets
//!    `{1, n/2, 3n/4, n+1}`, on a one-pixel replicate-padded grid, written from the largest
//!    leaves down, column-major within a level; the pad is dropped.
//! 5. Back to the IR size with `imresize` (double in, double out), 6. 9×9 Gaussian σ 4.5 with
//!    zero padding, 7. `R = IR ⊖ uint8(bg)`, 8. `r_H = H(IR)/H(VIS)`,
//!    `Feat = R + (IR − VIS)·r_H`, `m` = mean of the top 0.1 % of `max(Feat, 0) + VIS`,
//!    `g = min(255/m, 0.8)`, `F = VIS ⊕ uint8(g·Feat)`.
//!
//! Guards: `k = round(0.001·N)`; classic keeps the published results of the degenerate cases
//! (`k = 0` → `g = 0.8`, the MATLAB `min(NaN, 0.8)`; `H(VIS) = 0` → `F = VIS`, what the
//! published code's `Inf`/`NaN` arithmetic and the `uint8` cast give), flight uses `k ≥ 1` and
//! `r_H = 1` when `H(VIS) = 0`. `m = 0` → `g = 0.8` in both.

use fusion_io::Gray;
use fusion_nostd::Variant;
use fusion_nostd::methods::ifevip::IfevipParams;

/// MATLAB's bicubic kernel (Keys, a = −0.5), written with the same masks as `imresize`.
pub fn cubic(x: f64) -> f64 {
    let a = x.abs();
    let (a2, a3) = (a * a, a * a * a);
    let inner = if a <= 1.0 { 1.0 } else { 0.0 };
    let outer = if 1.0 < a && a <= 2.0 { 1.0 } else { 0.0 };
    (1.5 * a3 - 2.5 * a2 + 1.0) * inner + (-0.5 * a3 + 2.5 * a2 - 4.0 * a + 2.0) * outer
}

/// One output sample's taps: 0-based input indices (end points replicated) and weights.
pub type Taps = Vec<(usize, f64)>;

/// MATLAB `imresize`'s `contributions`: the taps of every output sample along one dimension,
/// for a resize from `in_len` to `out_len` samples with antialiasing when shrinking, indices
/// outside the input reflected symmetrically (the end sample repeated). Columns
/// whose weight is 0 for every output are removed, as MATLAB does.
pub fn contributions(in_len: usize, out_len: usize) -> Vec<Taps> {
    let scale = out_len as f64 / in_len as f64;
    let (antialias, width) = if scale < 1.0 { (true, 4.0 / scale) } else { (false, 4.0) };
    let h = |x: f64| if antialias { scale * cubic(scale * x) } else { cubic(x) };
    let p = width.ceil() as isize + 2;
    let mut rows: Vec<Vec<(isize, f64)>> = (1..=out_len)
        .map(|x| {
            let u = x as f64 / scale + 0.5 * (1.0 - 1.0 / scale);
            let left = (u - width / 2.0).floor() as isize;
            let w: Vec<(isize, f64)> = (0..p).map(|k| (left + k, h(u - (left + k) as f64))).collect();
            let sum: f64 = w.iter().map(|t| t.1).sum();
            w.into_iter().map(|(i, v)| (i, v / sum)).collect()
        })
        .collect();
    // Kill the columns that are zero for every output sample.
    let keep: Vec<bool> = (0..p as usize).map(|k| rows.iter().any(|r| r[k].1 != 0.0)).collect();
    for r in &mut rows {
        let mut k = 0;
        r.retain(|_| {
            k += 1;
            keep[k - 1]
        });
    }
    rows.into_iter().map(|r| r.into_iter().map(|(i, w)| (boundary(i, in_len), w)).collect()).collect()
}

/// 0-based index of the 1-based, possibly out-of-range, tap index `i`: symmetric reflection
/// with the end sample repeated (`aux = [1:n, n:-1:1]; aux(mod(i-1, 2n)+1)`), the boundary rule
/// of the `imresize` that produced the published outputs. Clamping (replicating the end
/// points, as later MATLAB releases do) moves 0.01–1.7 % of the published pixels by 1–2 levels
/// on the VIFB pairs; the reflection reproduces all of them.
fn boundary(i: isize, n: usize) -> usize {
    let n2 = 2 * n as isize;
    let m = (i - 1).rem_euclid(n2);
    (if m < n as isize { m } else { n2 - 1 - m }) as usize
}

/// MATLAB `uint8()`: round half away from zero, saturate, NaN → 0.
pub fn to_u8(v: f64) -> f64 {
    if v.is_nan() { 0.0 } else { v.round().clamp(0.0, 255.0) }
}

/// MATLAB `imresize(img, [out_h out_w], 'bicubic')`. `uint8` rounds after every pass (the
/// image class is `uint8`); otherwise double in, double out. The dimension with the smaller
/// scale goes first (rows on a tie, MATLAB's stable `sort`).
pub fn imresize(img: &Gray<f64>, out_w: usize, out_h: usize, uint8: bool) -> Gray<f64> {
    let pass_rows = |src: &Gray<f64>| -> Gray<f64> {
        // Along dimension 1 (vertical).
        let taps = contributions(src.height, out_h);
        let mut dst = Gray::new(src.width, out_h);
        for (y, t) in taps.iter().enumerate() {
            for x in 0..src.width {
                let mut acc = 0.0;
                for &(i, w) in t {
                    acc += w * src.data[i * src.width + x];
                }
                dst.data[y * src.width + x] = if uint8 { to_u8(acc) } else { acc };
            }
        }
        dst
    };
    let pass_cols = |src: &Gray<f64>| -> Gray<f64> {
        let taps = contributions(src.width, out_w);
        let mut dst = Gray::new(out_w, src.height);
        for y in 0..src.height {
            for (x, t) in taps.iter().enumerate() {
                let mut acc = 0.0;
                for &(i, w) in t {
                    acc += w * src.data[y * src.width + i];
                }
                dst.data[y * out_w + x] = if uint8 { to_u8(acc) } else { acc };
            }
        }
        dst
    };
    if out_w == img.width && out_h == img.height {
        return img.clone();
    }
    let scale_rows = out_h as f64 / img.height as f64;
    let scale_cols = out_w as f64 / img.width as f64;
    if scale_cols < scale_rows { pass_rows(&pass_cols(img)) } else { pass_cols(&pass_rows(img)) }
}

/// `qtdecomp(img, threshold/255, min)` on a `d×d` image: the leaves as `(row, col, side)`,
/// 0-based top-left corners.
pub fn quadtree(img: &Gray<f64>, threshold: f64, min: usize) -> Vec<(usize, usize, usize)> {
    fn split(
        img: &Gray<f64>,
        r: usize,
        c: usize,
        n: usize,
        thr: f64,
        min: usize,
        out: &mut Vec<(usize, usize, usize)>,
    ) {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for y in r..r + n {
            for x in c..c + n {
                let v = img.data[y * img.width + x];
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        if hi - lo > thr && n / 2 >= min {
            let h = n / 2;
            for (dr, dc) in [(0, 0), (h, 0), (0, h), (h, h)] {
                split(img, r + dr, c + dc, h, thr, min, out);
            }
        } else {
            out.push((r, c, n));
        }
    }
    let mut out = Vec::new();
    split(img, 0, 0, img.width, threshold, min, &mut out);
    out
}

/// `imerode` by a flat `size×size` square (origin at element `⌊(size+1)/2⌋`), outside ignored.
pub fn erode(img: &Gray<f64>, size: usize) -> Gray<f64> {
    let o = size.div_ceil(2);
    let (lo, hi) = (o as isize - 1, (size - o) as isize);
    let (w, h) = (img.width as isize, img.height as isize);
    let mut out = Gray::new(img.width, img.height);
    for y in 0..h {
        for x in 0..w {
            let mut m = f64::INFINITY;
            for yy in (y - lo).max(0)..=(y + hi).min(h - 1) {
                for xx in (x - lo).max(0)..=(x + hi).min(w - 1) {
                    m = m.min(img.data[(yy * w + xx) as usize]);
                }
            }
            out.data[(y * w + x) as usize] = m;
        }
    }
    out
}

/// The cubic Bernstein matrix as printed in the published code (symmetric).
const M: [[f64; 4]; 4] =
    [[-1.0, 3.0, -3.0, 1.0], [3.0, -6.0, 3.0, 0.0], [-3.0, 3.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]];

/// The Bézier background of a `d×d` grid from its leaves and local-minimum image.
pub fn bezier_background(leaves: &[(usize, usize, usize)], minimum: &Gray<f64>) -> Gray<f64> {
    let d = minimum.width;
    let dp = d + 1;
    // One-pixel replicate pad at the bottom/right.
    let pad = |r: usize, c: usize| minimum.data[r.min(d - 1) * d + c.min(d - 1)];
    let mut bg = vec![0.0; dp * dp];
    let mut order = leaves.to_vec();
    // Largest side first; column-major order of the top-left corners within a level.
    order.sort_by(|a, b| b.2.cmp(&a.2).then(a.1.cmp(&b.1)).then(a.0.cmp(&b.0)));
    for &(r0, c0, n) in &order {
        let offs = [0, n / 2 - 1, 3 * n / 4 - 1, n];
        let mut p = [[0.0; 4]; 4];
        for (a, &oa) in offs.iter().enumerate() {
            for (b, &ob) in offs.iter().enumerate() {
                p[a][b] = pad(r0 + oa, c0 + ob);
            }
        }
        let tm = |i: usize| -> [f64; 4] {
            let t = i as f64 / n as f64;
            let tv = [t * t * t, t * t, t, 1.0];
            let mut o = [0.0; 4];
            for (k, ok) in o.iter_mut().enumerate() {
                *ok = (0..4).map(|q| tv[q] * M[q][k]).sum();
            }
            o
        };
        // (T·M)·P, then ·(M·Tᵀ).
        for i in 0..=n {
            let ti = tm(i);
            let mut tp = [0.0; 4];
            for (b, v) in tp.iter_mut().enumerate() {
                *v = (0..4).map(|a| ti[a] * p[a][b]).sum();
            }
            for j in 0..=n {
                let tj = tm(j);
                let v: f64 = (0..4).map(|b| tp[b] * tj[b]).sum();
                bg[(r0 + i) * dp + c0 + j] = v;
            }
        }
    }
    let data = (0..d).flat_map(|r| (0..d).map(move |c| (r, c))).map(|(r, c)| bg[r * dp + c]).collect();
    Gray { width: d, height: d, data }
}

/// `fspecial('gaussian', size, size/2)`.
pub fn gaussian_kernel(size: usize) -> Vec<f64> {
    let sigma = size as f64 / 2.0;
    let half = (size as f64 - 1.0) / 2.0;
    let mut h: Vec<f64> = (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as f64 - half, (i / size) as f64 - half);
            (-(x * x + y * y) / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let max = h.iter().cloned().fold(0.0, f64::max);
    for v in &mut h {
        if *v < f64::EPSILON * max {
            *v = 0.0;
        }
    }
    let sum: f64 = h.iter().sum();
    h.iter().map(|v| v / sum).collect()
}

/// `imfilter(img, kernel)`: 2-D correlation, zero padding, same size.
pub fn filter_zero(img: &Gray<f64>, kernel: &[f64], size: usize) -> Gray<f64> {
    let half = (size / 2) as isize;
    let (w, h) = (img.width as isize, img.height as isize);
    let mut out = Gray::new(img.width, img.height);
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for ky in 0..size as isize {
                let yy = y + ky - half;
                if yy < 0 || yy >= h {
                    continue;
                }
                for kx in 0..size as isize {
                    let xx = x + kx - half;
                    if xx < 0 || xx >= w {
                        continue;
                    }
                    acc += kernel[(ky * size as isize + kx) as usize] * img.data[(yy * w + xx) as usize];
                }
            }
            out.data[(y * w + x) as usize] = acc;
        }
    }
    out
}

/// Shannon entropy (log₂) of the 256-bin histogram of an 8-bit image.
pub fn entropy(img: &Gray<f64>) -> f64 {
    let mut hist = [0usize; 256];
    for &v in &img.data {
        hist[v.clamp(0.0, 255.0) as usize] += 1;
    }
    let n = img.data.len() as f64;
    hist.iter().filter(|&&c| c > 0).map(|&c| c as f64 / n).map(|p| -p * p.log2()).sum()
}

/// The IR background of step 1 (after the Gaussian, before rounding), at the IR's size.
pub fn background(tir: &Gray<f64>, params: &IfevipParams) -> Gray<f64> {
    let d = usize::from(params.quad_norm_dim);
    let ir512 = imresize(tir, d, d, true);
    let leaves = quadtree(&ir512, f64::from(params.split_threshold), usize::from(params.quad_min_dim));
    let minimum = erode(&ir512, usize::from(params.erode_size));
    let bg = bezier_background(&leaves, &minimum);
    let bg = imresize(&bg, tir.width, tir.height, false);
    let g = usize::from(params.gauss_size);
    filter_zero(&bg, &gaussian_kernel(g), g)
}

/// IFEVIP of an aligned VIS/TIR pair (8-bit values as `f64`); the output holds integers
/// 0..=255. Panics if the sizes differ (host-side reference).
pub fn fuse_ifevip(vis: &Gray<f64>, tir: &Gray<f64>, params: &IfevipParams) -> Gray<f64> {
    assert_eq!((vis.width, vis.height), (tir.width, tir.height), "IFEVIP: frame sizes differ");
    let flight = params.variant == Variant::Flight;
    let bg = background(tir, params);
    // R = IR ⊖ uint8(bg), in uint8 arithmetic.
    let r: Vec<f64> = tir.data.iter().zip(&bg.data).map(|(&ir, &b)| (ir - to_u8(b)).max(0.0)).collect();
    let (h_ir, h_vis) = (entropy(tir), entropy(vis));
    if h_vis == 0.0 && !flight {
        return vis.clone();
    }
    let ratio = if h_vis == 0.0 { 1.0 } else { h_ir / h_vis };
    let feat: Vec<f64> =
        r.iter().zip(&tir.data).zip(&vis.data).map(|((&r, &ir), &v)| r + (ir - v) * ratio).collect();
    let mut added: Vec<f64> = feat.iter().zip(&vis.data).map(|(&f, &v)| f.max(0.0) + v).collect();
    added.sort_by(|a, b| b.total_cmp(a));
    let n = added.len();
    let ratio_top = f64::from(params.top_ppm) / 1e6;
    let mut k = (ratio_top * n as f64).round() as usize;
    if flight {
        k = k.max(1);
    }
    let cap = f64::from(params.gain_cap_percent) / 100.0;
    let g = if k == 0 {
        cap
    } else {
        let m = added[..k].iter().sum::<f64>() / k as f64;
        if m == 0.0 { cap } else { (255.0 / m).min(cap) }
    };
    let data = feat.iter().zip(&vis.data).map(|(&f, &v)| (v + to_u8(g * f)).min(255.0)).collect();
    Gray { width: vis.width, height: vis.height, data }
}
