//! f64 reference of the rescalers, written from `docs/reference/rescale-semantics.md`
//! without the core's code: every output pixel evaluates the formulas directly.

use fusion_io::Gray;
use fusion_nostd::Filter;

/// Keys cubic convolution kernel with a = −0.75.
pub fn keys(x: f64) -> f64 {
    let a = -0.75;
    let x = x.abs();
    if x <= 1.0 {
        (a + 2.0) * x.powi(3) - (a + 3.0) * x.powi(2) + 1.0
    } else if x < 2.0 {
        a * x.powi(3) - 5.0 * a * x.powi(2) + 8.0 * a * x - 4.0 * a
    } else {
        0.0
    }
}

/// The (source index, weight) taps of output sample `d` along one axis.
pub fn axis_taps(filter: Filter, n_src: usize, n_dst: usize, d: usize) -> Vec<(usize, f64)> {
    let clamp = |i: i64| i.clamp(0, n_src as i64 - 1) as usize;
    let s = n_src as f64 / n_dst as f64;
    match filter {
        Filter::Cubic => {
            let u = (d as f64 + 0.5) * s - 0.5;
            let i = u.floor();
            let t = u - i;
            let i = i as i64;
            vec![
                (clamp(i - 1), keys(1.0 + t)),
                (clamp(i), keys(t)),
                (clamp(i + 1), keys(1.0 - t)),
                (clamp(i + 2), keys(2.0 - t)),
            ]
        }
        Filter::Area if n_src >= n_dst => {
            // Output d covers [d·s, (d+1)·s) in source pixels; weight = overlap / s.
            let (lo, hi) = (d as f64 * s, (d + 1) as f64 * s);
            (lo.floor() as usize..(hi.ceil() as usize).min(n_src))
                .map(|k| (k, (hi.min(k as f64 + 1.0) - lo.max(k as f64)) / s))
                .filter(|&(_, w)| w > 0.0)
                .collect()
        }
        Filter::Area => {
            let i = (d as f64 * s).floor() as i64;
            let f = ((d + 1) as f64 - (i + 1) as f64 / s).max(0.0);
            vec![(clamp(i), 1.0 - f), (clamp(i + 1), f)]
        }
    }
}

/// Rescales `src` to `dw × dh`, unrounded and unclamped.
pub fn rescale_f64(src: &Gray<f64>, dw: usize, dh: usize, filter: Filter) -> Gray<f64> {
    let xt: Vec<_> = (0..dw).map(|x| axis_taps(filter, src.width, dw, x)).collect();
    let yt: Vec<_> = (0..dh).map(|y| axis_taps(filter, src.height, dh, y)).collect();
    let mut out = Gray::new(dw, dh);
    for (y, ty) in yt.iter().enumerate() {
        for (x, tx) in xt.iter().enumerate() {
            let mut v = 0.0;
            for &(sy, wy) in ty {
                for &(sx, wx) in tx {
                    v += wy * wx * src.at(sx, sy);
                }
            }
            out.data[y * dw + x] = v;
        }
    }
    out
}

/// Rounds and saturates like the u8 rescalers: cubic ties to even, area half up.
pub fn to_u8(value: f64, filter: Filter) -> u8 {
    let r = match filter {
        Filter::Cubic => value.round_ties_even(),
        Filter::Area => (value + 0.5).floor(),
    };
    r.clamp(0.0, 255.0) as u8
}

/// The u8 rescale by the f64 formulas, rounded as [`to_u8`].
pub fn rescale_u8(src: &Gray<u8>, dw: usize, dh: usize, filter: Filter) -> Gray<u8> {
    let f =
        Gray { width: src.width, height: src.height, data: src.data.iter().map(|&v| f64::from(v)).collect() };
    let r = rescale_f64(&f, dw, dh, filter);
    Gray { width: dw, height: dh, data: r.data.iter().map(|&v| to_u8(v, filter)).collect() }
}

/// Lanczos-3 kernel `sinc(x)·sinc(x/3)` for `|x| < 3`, else 0.
pub fn lanczos3(x: f64) -> f64 {
    let x = x.abs();
    if x < 1e-12 {
        1.0
    } else if x < 3.0 {
        let px = std::f64::consts::PI * x;
        3.0 * px.sin() * (px / 3.0).sin() / (px * px)
    } else {
        0.0
    }
}

/// Lanczos-3 taps of output sample `d` along one axis, MATLAB `imresize(…, 'lanczos3')`
/// style: half-pixel centres, the kernel stretched by `n_src / n_dst` when shrinking
/// (antialiasing), weights normalised to sum 1, edge samples replicated.
pub fn lanczos3_taps(n_src: usize, n_dst: usize, d: usize) -> Vec<(usize, f64)> {
    let s = n_src as f64 / n_dst as f64;
    let stretch = s.max(1.0);
    let u = (d as f64 + 0.5) * s - 0.5;
    let reach = (3.0 * stretch).ceil() as i64;
    let c = u.floor() as i64;
    let taps: Vec<(usize, f64)> = (c - reach..=c + reach + 1)
        .map(|i| (i.clamp(0, n_src as i64 - 1) as usize, lanczos3((u - i as f64) / stretch)))
        .filter(|&(_, w)| w != 0.0)
        .collect();
    let sum: f64 = taps.iter().map(|t| t.1).sum();
    taps.into_iter().map(|(i, w)| (i, w / sum)).collect()
}

/// Lanczos-3 rescale of a u8 image (the third method the study compares; host side only),
/// rounded half away from zero and saturated like MATLAB's `uint8`.
pub fn lanczos3_u8(src: &Gray<u8>, dw: usize, dh: usize) -> Gray<u8> {
    let xt: Vec<_> = (0..dw).map(|x| lanczos3_taps(src.width, dw, x)).collect();
    let yt: Vec<_> = (0..dh).map(|y| lanczos3_taps(src.height, dh, y)).collect();
    // Separable: rows first into f64, then columns.
    let mut tmp = vec![0.0f64; src.height * dw];
    for y in 0..src.height {
        for (x, tx) in xt.iter().enumerate() {
            tmp[y * dw + x] = tx.iter().map(|&(sx, w)| w * f64::from(src.at(sx, y))).sum();
        }
    }
    let mut out = Gray::new(dw, dh);
    for (y, ty) in yt.iter().enumerate() {
        for x in 0..dw {
            let v: f64 = ty.iter().map(|&(sy, w)| w * tmp[sy * dw + x]).sum();
            out.data[y * dw + x] = v.round().clamp(0.0, 255.0) as u8;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_weight_tables() {
        let w =
            |f, ns, nd, d| axis_taps(f, ns, nd, d).iter().map(|&(k, w)| (k, w * 256.0)).collect::<Vec<_>>();
        assert_eq!(w(Filter::Cubic, 8, 16, 5), vec![(1, -27.0), (2, 225.0), (3, 67.0), (4, -9.0)]);
        assert_eq!(w(Filter::Cubic, 16, 8, 0), vec![(0, -24.0), (0, 152.0), (1, 152.0), (2, -24.0)]);
        let sum: f64 = axis_taps(Filter::Area, 5, 2, 1).iter().map(|t| t.1).sum();
        assert!((sum - 1.0).abs() < 1e-12);
    }

    #[test]
    fn worked_example_up_row0() {
        let src = Gray {
            width: 4,
            height: 4,
            data: vec![188u8, 255, 213, 168, 255, 255, 0, 248, 0, 195, 182, 194, 45, 88, 221, 49],
        };
        let out = rescale_u8(&src, 8, 8, Filter::Cubic);
        assert_eq!(&out.data[..8], &[173, 198, 240, 255, 250, 216, 176, 152]);
    }

    #[test]
    fn lanczos3_interpolates_and_keeps_constants() {
        assert_eq!(lanczos3(0.0), 1.0);
        for k in 1..4 {
            assert!(lanczos3(f64::from(k)).abs() < 1e-15, "zero at the integers");
        }
        assert_eq!(lanczos3(3.5), 0.0);
        // weights sum to one, up and down
        for (ns, nd) in [(8, 16), (16, 8), (5, 13)] {
            for d in 0..nd {
                let sum: f64 = lanczos3_taps(ns, nd, d).iter().map(|t| t.1).sum();
                assert!((sum - 1.0).abs() < 1e-12);
            }
        }
        let c = Gray { width: 7, height: 5, data: vec![77u8; 35] };
        assert!(lanczos3_u8(&c, 14, 10).data.iter().all(|&v| v == 77));
        assert!(lanczos3_u8(&c, 3, 2).data.iter().all(|&v| v == 77));
        // a 2x upscale samples at ±1/4 pixel: a linear ramp stays a ramp inside the frame
        let ramp = Gray { width: 16, height: 1, data: (0..16u8).map(|v| v * 10).collect() };
        let up = lanczos3_u8(&ramp, 32, 1);
        for x in 8..24 {
            let want = (x as f64 + 0.5) / 2.0 - 0.5;
            assert!((f64::from(up.data[x]) - 10.0 * want).abs() <= 1.0, "x = {x}: {}", up.data[x]);
        }
    }
}
