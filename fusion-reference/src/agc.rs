//! The thermal AGC (`fusion_nostd::agc`) written straight from its definition, in f64, without
//! the core's histogram walk: percentiles from the sorted samples, the plateau mapping as one
//! division per bin, smoothing as `(q_new − q) / 2ᵏ` rounded away from zero.

use fusion_io::Gray;
use fusion_nostd::AgcParams;
use fusion_nostd::agc::{AGC_BIN_SHIFT, AGC_BINS, AgcMode};

/// A sequence's AGC state: the smoothed Q8 mapping of the previous frame.
#[derive(Debug, Clone, Default)]
pub struct AgcReference {
    q8: Option<Vec<f64>>,
}

impl AgcReference {
    /// The Q8 mapping (256ths of an output level) of one frame's samples, before smoothing.
    pub fn frame_mapping(samples: &[u16], p: &AgcParams) -> Vec<f64> {
        let bins: Vec<usize> = samples.iter().map(|&x| usize::from(x) >> AGC_BIN_SHIFT).collect();
        let (lo_out, hi_out) = (f64::from(p.out_low), f64::from(p.out_high));
        let range = 256.0 * (hi_out - lo_out);
        let (base, mid, top) = (256.0 * lo_out, 128.0 * (lo_out + hi_out), 256.0 * hi_out);
        let round = |v: f64| (v + 0.5).floor();
        match p.mode {
            AgcMode::Plateau { limit } => {
                let mut count = vec![0u64; AGC_BINS];
                for &b in &bins {
                    count[b] += 1;
                }
                let clipped: Vec<f64> = count.iter().map(|&c| c.min(u64::from(limit)) as f64).collect();
                let first = count.iter().position(|&c| c > 0).unwrap_or(0);
                let total: f64 = clipped.iter().sum();
                let den = total - clipped[first];
                let mut below = 0.0; // clipped count of the bins after `first` up to b
                (0..AGC_BINS)
                    .map(|b| {
                        if b > first {
                            below += clipped[b];
                        }
                        if den == 0.0 {
                            if b < first {
                                base
                            } else if b == first {
                                mid
                            } else {
                                top
                            }
                        } else {
                            base + round(range * below / den)
                        }
                    })
                    .collect()
            }
            AgcMode::Linear { low, high } => {
                let mut sorted = bins.clone();
                sorted.sort_unstable();
                let n = sorted.len() as f64;
                let kth = |pct: u16| {
                    let k = (n * f64::from(pct) / 10_000.0).ceil().max(1.0) as usize;
                    sorted[k - 1]
                };
                let (lo, hi) = (kth(low), kth(high));
                (0..AGC_BINS)
                    .map(|b| {
                        if b < lo {
                            base
                        } else if b > hi {
                            top
                        } else if hi == lo {
                            mid
                        } else {
                            base + round(range * (b - lo) as f64 / (hi - lo) as f64)
                        }
                    })
                    .collect()
            }
        }
    }

    /// Maps one frame of a sequence (the frame's own histogram, smoothed with the previous
    /// frames' mapping when `p.smoothing > 0`).
    pub fn frame(&mut self, input: &Gray<u16>, p: &AgcParams) -> Gray<u8> {
        let new = Self::frame_mapping(&input.data, p);
        let scale = f64::from(1u32 << p.smoothing);
        let q8 = match self.q8.take() {
            Some(old) if p.smoothing > 0 => {
                // The step 1/2ᵏ of the way, rounded away from zero (towards the new mapping).
                old.iter()
                    .zip(&new)
                    .map(|(&o, &n)| {
                        let step = (n - o) / scale;
                        o + if step > 0.0 { step.ceil() } else { step.floor() }
                    })
                    .collect()
            }
            _ => new,
        };
        let table: Vec<u8> = q8.iter().map(|&q| ((q + 128.0) / 256.0).floor() as u8).collect();
        self.q8 = Some(q8);
        Gray {
            width: input.width,
            height: input.height,
            data: input.data.iter().map(|&x| table[usize::from(x) >> AGC_BIN_SHIFT]).collect(),
        }
    }
}
