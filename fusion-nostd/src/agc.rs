//! Thermal automatic gain control (AGC): a microbolometer's 14/16-bit counts to an 8-bit frame.
//!
//! Every thermal camera has this step between its counts and the image the fusion sees. Two
//! mappings, both integer and the same bits on every target:
//!
//! * [`AgcMode::Plateau`] — plateau histogram equalisation (the usual thermal-camera AGC): the
//!   histogram's bins are clipped at a plateau of `limit` pixels, so that a large uniform area
//!   (cold space behind the target) cannot claim the output range, and the clipped cumulative
//!   histogram is the mapping. As OpenCV's `equalizeHist` does, the darkest occupied bin maps to
//!   `out_low`: `t(b) = out_low + (out_high − out_low)·(C(b) − C(b₀)) / (C_total − C(b₀))`,
//!   C the clipped cumulative count and b₀ the first occupied bin.
//! * [`AgcMode::Linear`] — a linear stretch between two percentiles of the frame's counts:
//!   `t(b) = out_low + (out_high − out_low)·(b − lo)/(hi − lo)`, clamped, where `lo` (`hi`) is
//!   the first bin whose cumulative count reaches `⌈N·low/10 000⌉` (`⌈N·high/10 000⌉`, at least 1).
//!
//! **Histogram.** 2¹⁴ bins of four counts each ([`AGC_BIN_SHIFT`]): a 16-bit sample `x` falls
//! in bin `x >> 2`, a 14-bit camera's counts use bins 0..4 096. The mapping is a table over the
//! bins, so counts within one bin map to the same output level (a bin is 1/64 of an output
//! level when the frame spans the 16-bit range, and 4 counts, ≤ the noise of a microbolometer,
//! otherwise). 64 KiB of histogram, 32 KiB of smoothed mapping and 16 KiB of table: [`Agc`]
//! (112 KiB, all zero when new, so it can live in `.bss`).
//!
//! **Rounding.** The mapping is held in Q8 (256ths of an output level):
//! `q(b) = 256·out_low + ⌊(256·(out_high − out_low)·num + den/2) / den⌋` (round half up,
//! exact: computed by a remainder walk, no division per bin), and the table is
//! `⌊(q + 128) / 256⌋`. A degenerate frame (every pixel in one bin; linear `hi == lo`) maps
//! that bin to mid-range, bins below it to `out_low` and above it to `out_high`.
//!
//! **Temporal smoothing** (`smoothing = k > 0`, for sequences): the Q8 mapping moves 1/2ᵏ of
//! the way to the new frame's each frame, the step `(q_new − q) / 2ᵏ` rounded away from zero
//! (so it reaches the new mapping exactly when the scene holds still, from above and from
//! below), and the level does not flicker when the histogram changes from frame to frame. The
//! first frame after [`Agc::new`] or [`Agc::reset`] takes its own mapping.
//!
//! **Frames, strips, rows.** [`agc_frame`] accumulates the whole frame, builds the mapping and
//! applies it. Strip by strip, two orders:
//! * a first pass: [`Agc::accumulate`] every strip, [`Agc::update`], then [`Agc::apply`] every
//!   strip — the bits of [`agc_frame`];
//! * the previous frame's mapping (one pass, for a camera read out line by line): per strip
//!   [`Agc::apply`] (the mapping built at the end of the last frame) then
//!   [`Agc::accumulate`]; [`Agc::update`] at the end of the frame. Each frame is mapped with
//!   the table of the frame before it (the mapping built at its end is [`agc_frame`]'s for
//!   it). The first frame needs a mapping: run it with a first pass, or accept
//!   [`Error::InvalidParameter`] `"agc mapping"`.

use crate::error::Error;
use crate::frame::{FrameMut, FrameRef};

/// Bins of the AGC histogram and mapping table.
pub const AGC_BINS: usize = 1 << 14;
/// A 16-bit sample `x` falls in bin `x >> AGC_BIN_SHIFT`.
pub const AGC_BIN_SHIFT: u32 = 2;
/// Percentiles of [`AgcMode::Linear`] are in 1/`AGC_PERCENT_SCALE` of the pixels.
pub const AGC_PERCENT_SCALE: u16 = 10_000;
/// The largest [`AgcParams::smoothing`] shift.
pub const AGC_MAX_SMOOTHING: u8 = 8;

/// How counts map to output levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AgcMode {
    /// Plateau histogram equalisation; `limit` (≥ 1) is the most pixels a bin counts with.
    /// [`AgcParams::plateau_for`] gives the default for a frame size.
    Plateau {
        /// Plateau, in pixels per bin.
        limit: u32,
    },
    /// Linear stretch between two percentiles, in 1/10 000 of the pixels
    /// (`low < high ≤ 10 000`; e.g. 100 and 9 990 for 1 % and 99.9 %).
    Linear {
        /// Lower percentile.
        low: u16,
        /// Upper percentile.
        high: u16,
    },
}

/// AGC parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AgcParams {
    /// The mapping.
    pub mode: AgcMode,
    /// Output level of the coldest counts.
    pub out_low: u8,
    /// Output level of the hottest counts (`> out_low`).
    pub out_high: u8,
    /// Temporal smoothing shift `k` (0 = none, at most [`AGC_MAX_SMOOTHING`]): the mapping
    /// moves 1/2ᵏ of the way to each new frame's.
    pub smoothing: u8,
}

impl AgcParams {
    /// The default plateau for a frame of `pixels`: `max(1, pixels / 2¹⁸)` (1 for a 512² frame,
    /// 4 for 1024²). Low, because on a target against cold space the background's sensor noise
    /// fills many bins and a high plateau spreads it over the output range: on the rendered
    /// `approach` sequence the target's contrast-to-noise ratio falls as the plateau rises
    /// (BENCHMARKS.md, "Thermal AGC").
    pub const fn plateau_for(pixels: usize) -> u32 {
        let p = pixels >> 18;
        if p == 0 {
            1
        } else if p > u32::MAX as usize {
            u32::MAX
        } else {
            p as u32
        }
    }

    /// Plateau equalisation over the full 8-bit range for a frame of `pixels`, no smoothing.
    pub const fn plateau(pixels: usize) -> Self {
        AgcParams {
            mode: AgcMode::Plateau { limit: Self::plateau_for(pixels) },
            out_low: 0,
            out_high: 255,
            smoothing: 0,
        }
    }

    /// A linear stretch between the 1 % and 99.9 % percentiles over the full 8-bit range, no
    /// smoothing (the percentiles that gave the highest target contrast-to-noise ratio on the
    /// rendered sequences; BENCHMARKS.md, "Thermal AGC").
    pub const fn linear() -> Self {
        AgcParams { mode: AgcMode::Linear { low: 100, high: 9_990 }, out_low: 0, out_high: 255, smoothing: 0 }
    }

    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), Error> {
        match self.mode {
            AgcMode::Plateau { limit: 0 } => {
                return Err(Error::InvalidParameter { name: "agc plateau limit" });
            }
            AgcMode::Linear { low, high } if low >= high || high > AGC_PERCENT_SCALE => {
                return Err(Error::InvalidParameter { name: "agc percentiles" });
            }
            _ => {}
        }
        if self.out_low >= self.out_high {
            return Err(Error::InvalidParameter { name: "agc output range" });
        }
        if self.smoothing > AGC_MAX_SMOOTHING {
            return Err(Error::InvalidParameter { name: "agc smoothing" });
        }
        Ok(())
    }
}

/// What one [`Agc::update`] found, for telemetry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AgcReport {
    /// Pixels in the histogram.
    pub pixels: u32,
    /// Plateau: first and last occupied bin; linear: the two percentile bins.
    pub bins: (u16, u16),
    /// Bins whose count the plateau clipped (0 for linear).
    pub clipped_bins: u32,
}

/// The AGC's state: histogram, smoothed mapping and table (112 KiB; zero when new).
pub struct Agc {
    hist: [u32; AGC_BINS],
    /// The mapping in Q8 (256ths of an output level), smoothed.
    map_q8: [u16; AGC_BINS],
    lut: [u8; AGC_BINS],
    pixels: u32,
    mapped: bool,
}

impl Default for Agc {
    fn default() -> Self {
        Self::new()
    }
}

/// The bin of a 16-bit sample.
#[inline(always)]
fn bin(x: u16) -> usize {
    usize::from(x >> AGC_BIN_SHIFT)
}

impl Agc {
    /// An empty histogram and no mapping.
    pub const fn new() -> Self {
        Agc { hist: [0; AGC_BINS], map_q8: [0; AGC_BINS], lut: [0; AGC_BINS], pixels: 0, mapped: false }
    }

    /// Forgets the histogram and the mapping (a new sequence).
    pub fn reset(&mut self) {
        self.hist.fill(0);
        self.pixels = 0;
        self.mapped = false;
    }

    /// Whether a mapping exists (after the first [`Agc::update`]).
    pub fn has_mapping(&self) -> bool {
        self.mapped
    }

    /// The current table: output level per bin.
    pub fn table(&self) -> &[u8; AGC_BINS] {
        &self.lut
    }

    /// Adds samples (any rows, any order) to the histogram. `Err` (nothing added) when the
    /// histogram would count more than `u32::MAX` pixels before the next [`Agc::update`].
    pub fn accumulate(&mut self, samples: &[u16]) -> Result<(), Error> {
        let n =
            u32::try_from(samples.len()).map_err(|_| Error::InvalidParameter { name: "agc pixel count" })?;
        self.pixels =
            self.pixels.checked_add(n).ok_or(Error::InvalidParameter { name: "agc pixel count" })?;
        for &x in samples {
            if let Some(h) = self.hist.get_mut(bin(x)) {
                *h += 1;
            }
        }
        Ok(())
    }

    /// Maps samples through the current table into `out` (same length). `Err` without a
    /// mapping or with lengths that differ (nothing written).
    pub fn apply(&self, samples: &[u16], out: &mut [u8]) -> Result<(), Error> {
        if !self.mapped {
            return Err(Error::InvalidParameter { name: "agc mapping" });
        }
        if samples.len() != out.len() {
            return Err(Error::BufferTooSmall { needed: samples.len(), got: out.len() });
        }
        for (o, &x) in out.iter_mut().zip(samples) {
            *o = self.lut.get(bin(x)).copied().unwrap_or(0);
        }
        Ok(())
    }

    /// Builds the mapping from the histogram (smoothed with the previous one when
    /// `params.smoothing > 0`), then empties the histogram for the next frame. `Err` for bad
    /// parameters or an empty histogram (state unchanged).
    pub fn update(&mut self, params: &AgcParams) -> Result<AgcReport, Error> {
        params.validate()?;
        if self.pixels == 0 {
            return Err(Error::InvalidParameter { name: "agc histogram (no pixels)" });
        }
        let range = u64::from(params.out_high - params.out_low) * 256;
        let base = u32::from(params.out_low) * 256;
        let mid = (u32::from(params.out_low) + u32::from(params.out_high)) * 128;
        let top = u32::from(params.out_high) * 256;
        let first = self.hist.iter().position(|&h| h > 0).unwrap_or(0);
        let last = self.hist.iter().rposition(|&h| h > 0).unwrap_or(0);
        let mut report =
            AgcReport { pixels: self.pixels, bins: (first as u16, last as u16), clipped_bins: 0 };
        // Each bin's new Q8 value is merged with the smoothed state as it is produced.
        let shift = if self.mapped { u32::from(params.smoothing) } else { 0 };
        let put = |b: usize, q: u32, map: &mut [u16; AGC_BINS], lut: &mut [u8; AGC_BINS]| {
            let Some(slot) = map.get_mut(b) else { return };
            let q = q as i32;
            let old = i32::from(*slot);
            // The step rounded away from zero: an arithmetic shift floors, so a rising step
            // adds 2ᵏ − 1 first (round up), a falling one floors (rounds down).
            let d = q - old;
            let s = match shift {
                0 => q,
                k if d > 0 => old + ((d + (1 << k) - 1) >> k),
                k => old + (d >> k),
            };
            *slot = s as u16;
            if let Some(l) = lut.get_mut(b) {
                *l = ((s + 128) >> 8) as u8;
            }
        };
        match params.mode {
            AgcMode::Plateau { limit } => {
                let clip = |h: u32| h.min(limit);
                report.clipped_bins = self.hist.iter().filter(|&&h| h > limit).count() as u32;
                let total: u64 = self.hist.iter().map(|&h| u64::from(clip(h))).sum();
                let c0 = u64::from(clip(self.hist.get(first).copied().unwrap_or(0)));
                let den = total - c0;
                // q(b) = base + ⌊(range·c + den/2)/den⌋ with c = C(b) − C(b₀), walked as
                // ⌊(2·range·c + den)/(2·den)⌋ with a running quotient and remainder.
                let (mut quot, mut rem) = (0u32, den);
                for b in 0..AGC_BINS {
                    let h = u64::from(clip(self.hist.get(b).copied().unwrap_or(0)));
                    let q = if den == 0 {
                        match b.cmp(&first) {
                            core::cmp::Ordering::Less => base,
                            core::cmp::Ordering::Equal => mid,
                            core::cmp::Ordering::Greater => top,
                        }
                    } else {
                        if b > first {
                            rem += 2 * range * h;
                            while rem >= 2 * den {
                                rem -= 2 * den;
                                quot += 1;
                            }
                        }
                        base + quot
                    };
                    put(b, q, &mut self.map_q8, &mut self.lut);
                }
            }
            AgcMode::Linear { low, high } => {
                let n = u64::from(self.pixels);
                let rank = |p: u16| (n * u64::from(p)).div_ceil(u64::from(AGC_PERCENT_SCALE)).max(1);
                let (k_lo, k_hi) = (rank(low), rank(high));
                let (mut lo, mut hi, mut c) = (None, None, 0u64);
                for (b, &h) in self.hist.iter().enumerate() {
                    c += u64::from(h);
                    if lo.is_none() && c >= k_lo {
                        lo = Some(b);
                    }
                    if c >= k_hi {
                        hi = Some(b);
                        break;
                    }
                }
                let (lo, hi) = (lo.unwrap_or(first), hi.unwrap_or(last));
                report.bins = (lo as u16, hi as u16);
                let den = (hi - lo) as u64;
                let (mut quot, mut rem) = (0u32, den);
                for b in 0..AGC_BINS {
                    let q = if b < lo {
                        base
                    } else if b > hi {
                        top
                    } else if den == 0 {
                        mid
                    } else {
                        if b > lo {
                            rem += 2 * range;
                            while rem >= 2 * den {
                                rem -= 2 * den;
                                quot += 1;
                            }
                        }
                        base + quot
                    };
                    put(b, q, &mut self.map_q8, &mut self.lut);
                }
            }
        }
        self.mapped = true;
        self.hist.fill(0);
        self.pixels = 0;
        Ok(report)
    }
}

/// The whole frame: histogram, mapping (smoothed with `agc`'s previous one when
/// `params.smoothing > 0`), table applied into `output` (the input's size).
pub fn agc_frame(
    agc: &mut Agc,
    input: FrameRef<'_, u16>,
    mut output: FrameMut<'_, u8>,
    params: &AgcParams,
) -> Result<AgcReport, Error> {
    params.validate()?;
    let size = (input.width(), input.height());
    if (output.width(), output.height()) != size {
        return Err(Error::SizeMismatch { expected: size, got: (output.width(), output.height()) });
    }
    // The frame's own histogram: whatever was accumulated before is dropped. A frame holds
    // at most 2²⁸ pixels, so the count cannot overflow.
    agc.hist.fill(0);
    agc.pixels = 0;
    for row in input.rows() {
        agc.accumulate(row)?;
    }
    let report = agc.update(params)?;
    for (y, row) in input.rows().enumerate() {
        agc.apply(row, output.row_mut(y))?;
    }
    Ok(report)
}
