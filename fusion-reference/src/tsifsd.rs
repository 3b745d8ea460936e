//! TSIFSD f64 reference, written from the spec (`docs/reference/fusion-algorithms.md`,
//! TSIFSD, Part B; flight: Part A) on images in 0..255 grey-level units. Independent of the
//! core's integer code.
//!
//! * Base `B_k`: 35×35 mean as the sum of the 1,225 products `I·(1/1225)` (window rows top to
//!   bottom, left to right). Classic: circular padding; flight: replicate.
//! * Classic saliency `S_k = (B_k − Med_k)²`, `Med_k` the 3×3 median with zero padding.
//!   Flight saliency `S_k = |Scharr_x(I_k)| + |Scharr_y(I_k)|` with replicate padding.
//! * `w_k = S_k / (S_VIS + S_IR)`. Classic: unguarded, 0/0 gives NaN as published (the
//!   MATLAB cast then gives 0); flight: ½, ½ there.
//! * `F = (½B_VIS + ½B_IR) + (w_VIS·D_VIS + w_IR·D_IR)`, `D_k = I_k − B_k`, not cast.

use fusion_io::Gray;
use fusion_nostd::Variant;
use fusion_nostd::methods::tsifsd::TsifsdParams;

fn pick(i: isize, n: usize, circular: bool) -> usize {
    let n = n as isize;
    if circular { i.rem_euclid(n) as usize } else { i.clamp(0, n - 1) as usize }
}

/// The `size × size` mean, circular (classic) or replicate (flight) border.
pub fn box_mean(img: &Gray<f64>, size: usize, circular: bool) -> Gray<f64> {
    let r = (size / 2) as isize;
    let tap = 1.0 / (size * size) as f64;
    let mut out = Gray::new(img.width, img.height);
    for y in 0..img.height as isize {
        for x in 0..img.width as isize {
            let mut s = 0.0;
            for dy in -r..=r {
                let yy = pick(y + dy, img.height, circular);
                for dx in -r..=r {
                    s += img.at(pick(x + dx, img.width, circular), yy) * tap;
                }
            }
            out.data[y as usize * img.width + x as usize] = s;
        }
    }
    out
}

/// 3×3 median with zero padding (MATLAB `medfilt2` default).
pub fn median3_zero(img: &Gray<f64>) -> Gray<f64> {
    let mut out = Gray::new(img.width, img.height);
    for y in 0..img.height as isize {
        for x in 0..img.width as isize {
            let mut v = Vec::with_capacity(9);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (xx, yy) = (x + dx, y + dy);
                    let inside = xx >= 0 && yy >= 0 && xx < img.width as isize && yy < img.height as isize;
                    v.push(if inside { img.at(xx as usize, yy as usize) } else { 0.0 });
                }
            }
            v.sort_by(f64::total_cmp);
            out.data[y as usize * img.width + x as usize] = v[4];
        }
    }
    out
}

/// `|Scharr_x| + |Scharr_y|` with replicate padding.
pub fn scharr_l1(img: &Gray<f64>) -> Gray<f64> {
    const K: [[f64; 3]; 3] = [[-3.0, 0.0, 3.0], [-10.0, 0.0, 10.0], [-3.0, 0.0, 3.0]];
    let mut out = Gray::new(img.width, img.height);
    for y in 0..img.height as isize {
        for x in 0..img.width as isize {
            let (mut gx, mut gy) = (0.0, 0.0);
            for (j, dy) in (-1..=1).enumerate() {
                for (i, dx) in (-1..=1).enumerate() {
                    let v = img.at(pick(x + dx, img.width, false), pick(y + dy, img.height, false));
                    gx += K[j][i] * v;
                    gy += K[i][j] * v;
                }
            }
            out.data[y as usize * img.width + x as usize] = gx.abs() + gy.abs();
        }
    }
    out
}

/// TSIFSD fusion of a VIS/TIR pair (same size), real-valued result in 0..255 units before
/// the 8-bit cast (classic: NaN where both saliencies are 0). Panics on a size mismatch.
pub fn fuse_tsifsd(vis: &Gray<f64>, tir: &Gray<f64>, params: &TsifsdParams) -> Gray<f64> {
    assert_eq!((vis.width, vis.height), (tir.width, tir.height), "TSIFSD reference: sizes differ");
    let size = usize::from(params.mean_size);
    let classic = params.variant == Variant::Classic;
    let b_v = box_mean(vis, size, classic);
    let b_i = box_mean(tir, size, classic);
    let (s_v, s_i): (Vec<f64>, Vec<f64>) = if classic {
        let (m_v, m_i) = (median3_zero(vis), median3_zero(tir));
        (
            b_v.data.iter().zip(&m_v.data).map(|(b, m)| (b - m).powi(2)).collect(),
            b_i.data.iter().zip(&m_i.data).map(|(b, m)| (b - m).powi(2)).collect(),
        )
    } else {
        (scharr_l1(vis).data, scharr_l1(tir).data)
    };
    let data = (0..vis.data.len())
        .map(|i| {
            let (d_v, d_i) = (vis.data[i] - b_v.data[i], tir.data[i] - b_i.data[i]);
            let sum = s_v[i] + s_i[i];
            let (w_v, w_i) = if !classic && sum == 0.0 { (0.5, 0.5) } else { (s_v[i] / sum, s_i[i] / sum) };
            (0.5 * b_v.data[i] + 0.5 * b_i.data[i]) + (w_v * d_v + w_i * d_i)
        })
        .collect();
    Gray { width: vis.width, height: vis.height, data }
}
