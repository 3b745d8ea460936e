//! Colour for fusion: a colour visible frame is fused by its luminance and its chroma restored.
//!
//! One convention, the one the fusion literature's code uses (OpenCV's `COLOR_RGB2YCrCb`, JPEG's
//! JFIF): YCbCr with BT.601 weights, full range, 8-bit, each value rounded half away from zero
//! and saturated:
//!
//! ```text
//! Y  =       0.299    R + 0.587    G + 0.114    B
//! Cb = 128 − 0.168736 R − 0.331264 G + 0.5      B
//! Cr = 128 + 0.5      R − 0.418688 G − 0.081312 B
//! R = Y + 1.402 (Cr − 128)
//! G = Y − 0.344136 (Cb − 128) − 0.714136 (Cr − 128)
//! B = Y + 1.772 (Cb − 128)
//! ```

use fusion_io::{Channels, Gray};

fn cast(v: f64) -> u8 {
    v.round().clamp(0.0, 255.0) as u8
}

/// The three planes Y, Cb, Cr of a colour image (three planes R, G, B).
pub fn rgb_to_ycbcr(rgb: &Channels) -> [Gray<u8>; 3] {
    let [r, g, b] = [0, 1, 2].map(|k| &rgb.planes[k]);
    let plane = |f: &dyn Fn(f64, f64, f64) -> f64| Gray {
        width: rgb.width,
        height: rgb.height,
        data: (0..r.len()).map(|i| cast(f(f64::from(r[i]), f64::from(g[i]), f64::from(b[i])))).collect(),
    };
    [
        plane(&|r, g, b| 0.299 * r + 0.587 * g + 0.114 * b),
        plane(&|r, g, b| 128.0 - 0.168736 * r - 0.331264 * g + 0.5 * b),
        plane(&|r, g, b| 128.0 + 0.5 * r - 0.418688 * g - 0.081312 * b),
    ]
}

/// The colour image (three planes R, G, B) of planes Y, Cb, Cr of one size.
pub fn ycbcr_to_rgb(y: &Gray<u8>, cb: &Gray<u8>, cr: &Gray<u8>) -> Channels {
    let plane = |f: &dyn Fn(f64, f64, f64) -> f64| {
        (0..y.data.len())
            .map(|i| {
                cast(f(f64::from(y.data[i]), f64::from(cb.data[i]) - 128.0, f64::from(cr.data[i]) - 128.0))
            })
            .collect()
    };
    Channels {
        width: y.width,
        height: y.height,
        planes: vec![
            plane(&|y, _, cr| y + 1.402 * cr),
            plane(&|y, cb, cr| y - 0.344136 * cb - 0.714136 * cr),
            plane(&|y, cb, _| y + 1.772 * cb),
        ],
    }
}

/// A fused luminance `y` back in colour with the visible frame's chroma: `cb` and `cr` follow
/// the luminance onto the fusion grid (area, as the VIS band) when their size differs, then
/// [`ycbcr_to_rgb`]. `fusion fuse` and the Python package (`vistir.fuse`) both colour here.
pub fn fused_in_colour(y: &Gray<u8>, cb: &Gray<u8>, cr: &Gray<u8>) -> anyhow::Result<Channels> {
    let grid = (y.width, y.height);
    let cb = fusion_io::source_on_grid(cb, grid, fusion_nostd::Filter::Area)?;
    let cr = fusion_io::source_on_grid(cr, grid, fusion_nostd::Filter::Area)?;
    Ok(ycbcr_to_rgb(y, &cb, &cr))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_colours_and_the_round_trip() {
        // Pure red, green, blue, white, black, a mid grey: Y/Cb/Cr by hand from the matrix.
        let rgb = Channels {
            width: 6,
            height: 1,
            planes: vec![
                vec![255, 0, 0, 255, 0, 128],
                vec![0, 255, 0, 255, 0, 128],
                vec![0, 0, 255, 255, 0, 128],
            ],
        };
        let [y, cb, cr] = rgb_to_ycbcr(&rgb);
        assert_eq!(y.data, vec![76, 150, 29, 255, 0, 128]); // 76.245, 149.685, 29.07
        assert_eq!(cb.data, vec![85, 44, 255, 128, 128, 128]); // 84.97, 43.53, 255.5 → 255
        assert_eq!(cr.data, vec![255, 21, 107, 128, 128, 128]); // 255.5, 21.24, 107.27
        // Back within one level per channel on every colour of a coarse lattice (three roundings
        // of at most ½ level each, spread by the inverse matrix's weights).
        let lattice: Vec<u8> = (0..=255).step_by(15).collect();
        let n = lattice.len();
        let mut planes = vec![Vec::new(), Vec::new(), Vec::new()];
        for &r in &lattice {
            for &g in &lattice {
                for &b in &lattice {
                    planes[0].push(r);
                    planes[1].push(g);
                    planes[2].push(b);
                }
            }
        }
        let rgb = Channels { width: n * n * n, height: 1, planes };
        let [y, cb, cr] = rgb_to_ycbcr(&rgb);
        let back = ycbcr_to_rgb(&y, &cb, &cr);
        for k in 0..3 {
            let worst = rgb.planes[k].iter().zip(&back.planes[k]).map(|(&a, &b)| a.abs_diff(b)).max();
            assert!(worst <= Some(1), "channel {k}: {worst:?}");
        }
    }
}
