//! The thermal front end (`fusion_nostd::thermal`) in `f64`, from its definitions: the two-point
//! correction `G·x + O`, the shutter's re-levelling, the bad-pixel median and the column-noise
//! filter's clipped-difference profile — real-valued, no rounding until the caller compares.

/// Two-point correction of `raw` with real gains and offsets: `G(p)·x(p) + O(p)`, unclamped.
pub fn nuc(raw: &[u16], gain: &[f64], offset: &[f64]) -> Vec<f64> {
    raw.iter().zip(gain).zip(offset).map(|((&x, &g), &o)| g * f64::from(x) + o).collect()
}

/// The shutter's new offsets: `O' = O + m − c` with `c = G·S + O` the corrected shutter frame
/// and `m` its mean over the pixels where `valid` holds.
pub fn shutter_offsets(shutter: &[u16], gain: &[f64], offset: &[f64], valid: &[bool]) -> Vec<f64> {
    let c = nuc(shutter, gain, offset);
    let (sum, n) =
        c.iter().zip(valid).filter(|(_, v)| **v).fold((0.0, 0.0), |(s, n), (c, _)| (s + c, n + 1.0));
    let m = sum / n;
    offset.iter().zip(&c).map(|(&o, &c)| o + m - c).collect()
}

/// Bad-pixel replacement of a `w × h` frame (`bad[i]` true for a bad pixel): the median of the
/// valid 8-neighbours (the mean of the middle two for an even count), else the nearest valid
/// pixel of the row (left first); `None` for a pixel with neither.
pub fn replace_bad(frame: &[f64], bad: &[bool], w: usize, h: usize) -> Vec<Option<f64>> {
    let mut out: Vec<Option<f64>> = frame.iter().map(|&v| Some(v)).collect();
    for y in 0..h {
        for x in 0..w {
            if !bad[y * w + x] {
                continue;
            }
            let mut vals = Vec::new();
            for v in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for u in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    if (u, v) != (x, y) && !bad[v * w + u] {
                        vals.push(frame[v * w + u]);
                    }
                }
            }
            vals.sort_by(f64::total_cmp);
            let k = vals.len();
            out[y * w + x] = if k > 0 {
                Some(if k % 2 == 1 { vals[k / 2] } else { 0.5 * (vals[k / 2 - 1] + vals[k / 2]) })
            } else {
                (1..w).find_map(|d| {
                    let left = x.checked_sub(d).filter(|&u| !bad[y * w + u]);
                    let right = Some(x + d).filter(|&u| u < w && !bad[y * w + u]);
                    left.or(right).map(|u| frame[y * w + u])
                })
            };
        }
    }
    out
}

/// The column-noise filter's estimate for a `w × h` frame: per column the mean of the
/// differences to the column on the left over the rows where it is within `threshold`, summed into a profile, less the profile's
/// mean over the `2r + 1` columns around (cut at the frame's edges).
pub fn column_estimate(frame: &[f64], w: usize, h: usize, threshold: f64, radius: usize) -> Vec<f64> {
    let mut profile = vec![0.0; w];
    for x in 1..w {
        let d: Vec<f64> = (0..h)
            .map(|y| frame[y * w + x] - frame[y * w + x - 1])
            .filter(|d| d.abs() <= threshold)
            .collect();
        let mean = if d.is_empty() { 0.0 } else { d.iter().sum::<f64>() / d.len() as f64 };
        profile[x] = profile[x - 1] + mean;
    }
    (0..w)
        .map(|x| {
            let (lo, hi) = (x.saturating_sub(radius), (x + radius).min(w - 1));
            let s = profile[lo..=hi].iter().sum::<f64>() / (hi - lo + 1) as f64;
            profile[x] - s
        })
        .collect()
}
