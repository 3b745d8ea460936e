//! Scene analysis: what a frame pair needs, found cheaply before fusing it.
//!
//! Space is black: in the study's geometry the target covers a few per cent of the frame and
//! the rest is sensor background. [`analyze`] looks at both bands and returns a [`Scene`]:
//!
//! * **Background and noise per band** ([`BandStats`]): the background level is the median of
//!   a histogram and the noise its upper quartile above it (a robust σ: `1.4826·(q₇₅ − median)`, like the MAD but right for noise clipped at 0), both read from a fixed
//!   subsample (every 4th row, every 2nd pixel of frames above 2¹⁶ pixels; every pixel of
//!   smaller ones), so one bright target or a few hot pixels move neither.
//! * **Noise-aware threshold**: a pixel is signal when it exceeds
//!   `background + max(min_delta, k·1.4826·spread)` ([`SceneParams`]; `1.4826·spread` is σ for
//!   Gaussian noise, `k` = 6 by default). A target pixel also needs its right neighbour above
//!   the threshold (a 2-pixel run), so an isolated noise spike does not stretch the box.
//! * **Noisy bands** ([`BlockStats`]): real frames carry sensor noise (the study's model: σ ≈
//!   12 grey levels in VIS, ≈ 17 in TIR on black), so the 6σ pixel threshold (≈ 72 and ≈ 105)
//!   sits above most of the target and its signal box misses the dim parts. A band whose pixel
//!   spread is above [`SceneParams::max_noise_spread`] is analysed again in `b × b` block means
//!   ([`block_side`]: `b` brings white noise to half the limit, 4 for the study's noise in both
//!   bands; noise σ/b): the same median and spread, a threshold of
//!   [`SceneParams::block_k_sigma_tenths`] (5σ); a block counts when an 8-connected neighbour is
//!   above the threshold too, or alone at twice the distance (10σ), so a lone block of 1/f noise
//!   does not; the box is cut to the run of block columns and rows around the signal's mean
//!   with gaps of at most 8 blocks (a noise pair far away is dropped), grown by one block and
//!   [`SceneParams::noisy_margin`]. Two passes over the band (the first on every other block
//!   row), four pixels to a word. Tuned on the rendezvous sequences: every target pixel of both
//!   cameras inside the window on all 240 noisy frames (`BENCHMARKS.md`).
//! * **Target box** ([`Scene::target`]): the bounding box, on the fusion grid, of the signal of
//!   both bands (a noisy band's block box, grown by the noisy margin; each band's box mapped
//!   onto the grid with a margin covering the rescaler's taps), `None` when neither band has
//!   signal.
//! * **Varying box** ([`Scene::varying`]): the bounding box, on the grid, of the pixels that
//!   differ *at all* from their band's background level — what a method with a frame-global
//!   statistic needs to prove the rest of the frame is exactly constant (noiseless frames).
//! * **Illumination of VIS** ([`Illumination`]): `Eclipse` when VIS has no signal run above its
//!   threshold anywhere (no usable signal), `Saturated` when at least
//!   [`SceneParams::saturated_percent`] of the sampled signal pixels are 255, else `Light`.
//! * **Decline** ([`Decline`]): when a band's background is not dark
//!   (`level > max_background`), or its *block means* are still too noisy
//!   (`spread > max_noise_spread`: structure, not sensor noise), there is no "empty sky" to skip,
//!   and the plans must fuse the whole frame. Real scenes (the VIFB pairs) end here.
//! * Whether a rescale is needed at all ([`Scene::rescale_needed`]: the sizes differ).
//!
//! Cost: the subsampled histograms (1/8 of the pixels of a large frame, ≈ 4 instructions per
//! sample on Cortex-M7), then two box searches per band, 32 pixels at a time as eight 32-bit
//! words (`Probe::any`: "some byte ≠ background" by XOR, "some byte > threshold" by a carry
//! test), pixel by pixel only in the rare groups that pass. Each box is found by scanning rows
//! from the top and from the bottom to the first hit, then searching the rows between only left
//! and right of the box found so far; the signal runs (signal pixels are varying pixels) are
//! searched inside the varying box only. On the emulated Cortex-M7 the analysis costs a few
//! instructions per VIS pixel on a noisy frame that it declines (folding every row to its
//! minimum and maximum byte by byte cost several times more) and less on a clean one. The
//! figures, against the whole pipeline's, are in `BENCHMARKS.md` ("Scene skipping"), measured
//! as skip `roi` − skip `none` of TSIFSD on the declined frames with `fusion budget
//! --skip-study DATASET --target arm --frames 1 --whole-frames 0` (`fw/README.md`).
//!
//! ```
//! use fusion_nostd::scene::{analyze, Illumination, SceneParams};
//! use fusion_nostd::FrameRef;
//! let mut vis = [0u8; 64 * 64];
//! let tir = [0u8; 32 * 32];
//! for y in 20..30 {
//!     for x in 10..40 {
//!         vis[y * 64 + x] = 200;
//!     }
//! }
//! let scene = analyze(FrameRef::new(&vis, 64, 64)?, FrameRef::new(&tir, 32, 32)?, (64, 64), &SceneParams::default())?;
//! assert_eq!(scene.illumination, Illumination::Light);
//! let t = scene.target.unwrap();
//! assert_eq!((t.x0, t.y0, t.x1, t.y1), (10, 20, 40, 30));
//! assert!(scene.decline.is_none() && scene.rescale_needed);
//! # Ok::<(), fusion_nostd::Error>(())
//! ```

pub use crate::frame::Rect;
use crate::{Error, FrameRef, MAX_DIMENSION};

mod blocks;

pub use blocks::{block_side, block_stats};

/// Illumination class of the VIS frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Illumination {
    /// Usable signal above the background.
    Light,
    /// No usable signal: nothing rises above the noise threshold (the target is in eclipse).
    Eclipse,
    /// Signal, but a large part of it clipped at 255.
    Saturated,
}

/// Why the analysis (or a plan) declined to skip: the whole frame is fused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Decline {
    /// A band's background level is above [`SceneParams::max_background`] (not empty sky).
    BackgroundNotDark,
    /// A band's background noise spread is above [`SceneParams::max_noise_spread`].
    TooNoisy,
    /// The window the method needs covers more than [`SceneParams::max_roi_percent`] of the
    /// frame: skipping would save little.
    RoiTooLarge,
    /// The method uses a frame-global statistic that the plan cannot reproduce exactly from
    /// the window alone: ADF on a noiseless frame whose background is not exactly constant
    /// (or, classic, not 0). Noisy frames take the crop semantics instead (module docs of
    /// [`crate::pipeline`]).
    GlobalStatistic,
}

/// Thresholds of the analysis. [`Default`] is the setting measured in `BENCHMARKS.md`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SceneParams {
    /// `k` of the signal threshold `background + max(min_delta, k·1.4826·spread)`, in tenths
    /// (60 = 6σ).
    pub k_sigma_tenths: u16,
    /// Smallest step above the background that counts as signal, grey levels (`1..`).
    pub min_delta: u8,
    /// Highest background level (median) that still counts as empty sky.
    pub max_background: u8,
    /// Highest background noise spread (grey levels) that still counts as empty sky.
    pub max_noise_spread: u8,
    /// Largest window (with halo), per cent of the frame, worth skipping around.
    pub max_roi_percent: u8,
    /// Share of the sampled signal pixels at 255, per cent, from which VIS is `Saturated`.
    pub saturated_percent: u8,
    /// Grid pixels added around a noisy band's block target box: the dim edges of a target the
    /// block means miss (a cold panel in eclipse), and the background just around the target
    /// that a navigation front end measures contrast against (`fusion navbench`'s ring lies
    /// 8–24 px outside the target). Clean frames keep their exact boxes.
    pub noisy_margin: u16,
    /// `k` of the block means' threshold, tenths (40 = 4σ): lower than the pixels' because a
    /// signal block also needs a neighbour above it (see [`BlockStats`]).
    pub block_k_sigma_tenths: u16,
}

impl Default for SceneParams {
    fn default() -> Self {
        Self {
            k_sigma_tenths: 60,
            min_delta: 4,
            max_background: 48,
            max_noise_spread: 6,
            max_roi_percent: 60,
            saturated_percent: 25,
            noisy_margin: 32,
            block_k_sigma_tenths: 50,
        }
    }
}

impl SceneParams {
    /// Checks every field's range ([`Error::InvalidParameter`] names the field).
    pub fn validate(&self) -> Result<(), Error> {
        if self.min_delta == 0 {
            return Err(Error::InvalidParameter { name: "min_delta" });
        }
        if self.max_roi_percent > 100 {
            return Err(Error::InvalidParameter { name: "max_roi_percent" });
        }
        if self.saturated_percent > 100 {
            return Err(Error::InvalidParameter { name: "saturated_percent" });
        }
        Ok(())
    }
}

/// What the analysis found in one band (coordinates of the band's own frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BandStats {
    /// Background level: the median of the sampled pixels.
    pub background: u8,
    /// Noise: the upper quartile minus the background level (Q8 grey levels), the upper
    /// quartile read from the histogram as grouped data (bin `v` spans `[v − ½, v + ½)`).
    /// For Gaussian noise `1.4826·spread = σ` — like the MAD, but also right for noise clipped
    /// at 0 (a black background: half the pixels read 0, the MAD would read ≈ 0) and not fooled
    /// by quantisation.
    pub spread_q8: u16,
    /// Signal threshold: a pixel is signal when it is above this (may exceed 255: no signal).
    pub threshold: u16,
    /// Sampled pixels.
    pub samples: u32,
    /// Sampled pixels above `threshold`.
    pub signal_samples: u32,
    /// Sampled pixels at 255.
    pub saturated_samples: u32,
    /// Bounding box of the signal runs (two neighbours above `threshold`), if any.
    pub signal: Option<Rect>,
    /// Bounding box of the pixels different from `background`, if any.
    pub varying: Option<Rect>,
}

/// The block analysis of a noisy band: the signal found in `block × block` means, where the
/// pixels' 6σ threshold would miss a dim target (sensor noise of σ ≈ 12 grey levels puts the
/// pixel threshold near 72, above most of a sunlit target). Coordinates of the band's frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlockStats {
    /// Block side, pixels.
    pub block: usize,
    /// Background level of the block means (median).
    pub background: u8,
    /// Noise of the block means: upper quartile minus median, Q8 (as [`BandStats::spread_q8`]).
    pub spread_q8: u16,
    /// A block is signal when its mean is above this (may exceed 255: none).
    pub threshold: u16,
    /// Bounding box of the signal blocks grown by one block (a target edge that covers a block
    /// only in part may leave it below the threshold), clipped to the frame.
    pub signal: Option<Rect>,
}

/// The analysis of one frame pair (boxes on the fusion grid).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scene {
    /// The fusion grid.
    pub grid: (usize, usize),
    /// VIS statistics (VIS frame coordinates).
    pub vis: BandStats,
    /// TIR statistics (TIR frame coordinates).
    pub tir: BandStats,
    /// Illumination class of VIS.
    pub illumination: Illumination,
    /// Signal box of both bands on the grid (`None`: no signal anywhere).
    pub target: Option<Rect>,
    /// Signal box of TIR alone on the grid.
    pub target_tir: Option<Rect>,
    /// Box of the pixels differing from the background, both bands, on the grid.
    pub varying: Option<Rect>,
    /// The same for TIR alone.
    pub varying_tir: Option<Rect>,
    /// Why skipping is refused for this pair, if it is.
    pub decline: Option<Decline>,
    /// VIS's background is itself lit: brighter than [`SceneParams::max_background`], or
    /// structured in its block means beyond [`SceneParams::max_noise_spread`] (the sunlit
    /// Earth behind the target, a real scene). VIS then carries an image even where nothing
    /// rises above its noise threshold — the threshold is set by the scene's own structure —
    /// so "no signal" does not mean "dark" ([`crate::methods::adaptive::decide`]).
    pub vis_background_lit: bool,
    /// VIS block analysis, when its pixel noise is above [`SceneParams::max_noise_spread`]
    /// (its target box then comes from the blocks).
    pub vis_blocks: Option<BlockStats>,
    /// The same for TIR.
    pub tir_blocks: Option<BlockStats>,
    /// Whether the two frames have different sizes (a rescale is needed).
    pub rescale_needed: bool,
}

/// Histogram of a fixed subsample: every pixel of frames up to 2¹⁶ pixels, else every 2nd
/// pixel of every 4th row. Counts saturate at `u32::MAX` (only frames of more than 2³⁵ pixels
/// get there: those take the per-sample saturating loop, all others plain adds).
fn histogram(f: FrameRef<'_, u8>) -> ([u32; 256], u32) {
    let mut hist = [0u32; 256];
    let small = f.width().saturating_mul(f.height()) <= 1 << 16;
    let (sy, sx) = if small { (1, 1) } else { (4, 2) };
    let total = (f.height().div_ceil(sy) as u64).saturating_mul(f.width().div_ceil(sx) as u64);
    let Ok(n) = u32::try_from(total) else {
        return histogram_saturating(f, sy, sx);
    };
    let mut bump = |p: u8| {
        if let Some(h) = hist.get_mut(usize::from(p)) {
            *h = h.wrapping_add(1); // ≤ n < 2³²: never wraps
        }
    };
    for row in f.rows().step_by(sy) {
        if small {
            row.iter().for_each(|&p| bump(p));
        } else {
            let (pairs, rest) = row.as_chunks::<8>();
            for &[a, _, b, _, c, _, d, _] in pairs {
                bump(a);
                bump(b);
                bump(c);
                bump(d);
            }
            rest.iter().step_by(2).for_each(|&p| bump(p));
        }
    }
    (hist, n)
}

/// [`histogram`] with saturating counts, for subsamples of 2³² pixels or more.
#[cold]
fn histogram_saturating(f: FrameRef<'_, u8>, sy: usize, sx: usize) -> ([u32; 256], u32) {
    let mut hist = [0u32; 256];
    let mut n = 0u32;
    for row in f.rows().step_by(sy) {
        for &p in row.iter().step_by(sx) {
            if let Some(h) = hist.get_mut(usize::from(p)) {
                *h = h.saturating_add(1);
            }
            n = n.saturating_add(1);
        }
    }
    (hist, n)
}

/// The smallest value whose cumulative count reaches half the samples.
fn median_of(hist: &[u32; 256], n: u32) -> u8 {
    let half = n.div_ceil(2).max(1);
    let mut acc = 0u32;
    for (v, &c) in hist.iter().enumerate() {
        acc = acc.saturating_add(c);
        if acc >= half {
            return v as u8;
        }
    }
    255
}

/// The upper quartile of a histogram as grouped data, in Q8: bin `v` spans `[v − ½, v + ½)`,
/// interpolated linearly inside the bin.
fn upper_quartile_q8(hist: &[u32; 256], n: u32) -> u32 {
    let target = u64::from(n) * 3 * 64; // ¾·n in Q8 counts
    let mut before = 0u64;
    for (v, &c) in hist.iter().enumerate() {
        let c = u64::from(c);
        if c > 0 && (before + c) * 256 >= target {
            let into = (target - before * 256) / c; // Q8 fraction of the bin
            return ((v as u64 * 256 + into).saturating_sub(128)) as u32;
        }
        before += c;
    }
    255 << 8
}

/// Pixels per group of the word-wise scans: eight 32-bit words.
const GROUP: usize = 32;
/// The top bit of every byte of a word.
const HIGH: u32 = 0x8080_8080;
/// The low seven bits of every byte of a word.
const LOW7: u32 = 0x7f7f_7f7f;

/// `f` of every little-endian word of a group, OR-ed.
#[inline(always)]
fn fold_words(g: &[u8; GROUP], f: impl Fn(u32) -> u32) -> u32 {
    g.as_chunks::<4>().0.iter().fold(0, |acc, w| acc | f(u32::from_le_bytes(*w)))
}

/// What a box search looks for, pixel by pixel ([`Probe::hit`]) and, as a pre-filter that
/// never misses a hit, a whole group at a time ([`Probe::any`]).
trait Probe: Copy {
    /// False only when no position of the group is a hit (the group starts at `x` of a row).
    fn any(self, g: &[u8; GROUP]) -> bool;
    /// Whether `x` of `row` is a hit.
    fn hit(self, row: &[u8], x: usize) -> bool;
}

/// Hits: pixels different from `level`.
#[derive(Clone, Copy)]
struct Differs {
    level: u8,
    splat: u32,
}

impl Differs {
    fn new(level: u8) -> Self {
        Self { level, splat: u32::from(level) * 0x0101_0101 }
    }
}

impl Probe for Differs {
    #[inline(always)]
    fn any(self, g: &[u8; GROUP]) -> bool {
        fold_words(g, |w| w ^ self.splat) != 0
    }

    #[inline(always)]
    fn hit(self, row: &[u8], x: usize) -> bool {
        row.get(x).is_some_and(|&v| v != self.level)
    }
}

/// Hits: starts of 2-pixel runs above `t` (`x` and `x + 1` both above). The group test asks
/// whether any byte is above `t` (a run start is); `LOW` picks the formula for `t < 128`.
#[derive(Clone, Copy)]
struct RunAbove<const LOW: bool> {
    t: u8,
    /// Per byte: `127 − t` (`t < 128`) or `255 − t` (`t ≥ 128`).
    add: u32,
}

impl<const LOW: bool> RunAbove<LOW> {
    fn new(t: u8) -> Self {
        let add = if LOW { 127u8.wrapping_sub(t) } else { 255u8.wrapping_sub(t) };
        Self { t, add: u32::from(add) * 0x0101_0101 }
    }
}

impl<const LOW: bool> Probe for RunAbove<LOW> {
    #[inline(always)]
    fn any(self, g: &[u8; GROUP]) -> bool {
        let k = self.add;
        if LOW {
            // t < 128: a byte ≥ 128 is above t (its top bit); when all four bytes are below
            // 128, `byte + 127 − t` stays below 256 (no carry into the next byte) and reaches
            // 128 exactly when byte > t. A carry out of a byte ≥ 128 may set its neighbour's
            // flag, but the word then holds a byte above t anyway: exact for "any".
            (fold_words(g, |w| w.wrapping_add(k) | w) & HIGH) != 0
        } else {
            // t ≥ 128: byte > t ⇔ top bit set and (byte & 127) + 255 − t ≥ 128, the sum of
            // two 7-bit values (no carry between bytes).
            (fold_words(g, |w| ((w & LOW7) + k) & w) & HIGH) != 0
        }
    }

    #[inline(always)]
    fn hit(self, row: &[u8], x: usize) -> bool {
        let above = |x: usize| row.get(x).is_some_and(|&v| v > self.t);
        above(x) && above(x.wrapping_add(1))
    }
}

/// The first hit of `p` in columns `a..b` of `row`.
fn first_hit<P: Probe>(p: P, row: &[u8], a: usize, b: usize) -> Option<usize> {
    let (groups, _) = row.get(a..b)?.as_chunks::<GROUP>();
    let mut x = a;
    for g in groups {
        if p.any(g)
            && let Some(i) = (x..x + GROUP).find(|&i| p.hit(row, i))
        {
            return Some(i);
        }
        x += GROUP;
    }
    (x..b).find(|&i| p.hit(row, i))
}

/// The last hit of `p` in columns `a..b` of `row`.
fn last_hit<P: Probe>(p: P, row: &[u8], a: usize, b: usize) -> Option<usize> {
    let (_, groups) = row.get(a..b)?.as_rchunks::<GROUP>();
    let mut x = b;
    for g in groups.iter().rev() {
        x -= GROUP;
        if p.any(g)
            && let Some(i) = (x..x + GROUP).rev().find(|&i| p.hit(row, i))
        {
            return Some(i);
        }
    }
    (a..x).rev().find(|&i| p.hit(row, i))
}

/// First and last hit of `p` in columns `a..b` of `row`.
fn row_hits<P: Probe>(p: P, row: &[u8], a: usize, b: usize) -> Option<(usize, usize)> {
    let first = first_hit(p, row, a, b)?;
    Some((first, last_hit(p, row, first, b).unwrap_or(first)))
}

/// The bounding box of the hits of `p` inside columns `xs` × rows `ys` of `f`, as `(x0, y0,
/// last x, y1)`. The first and the last row with a hit are found scanning from the top and
/// from the bottom; the rows between them are searched only left and right of the box found
/// so far (a few pixels once the box spans the window).
fn hit_box<P: Probe>(
    f: FrameRef<'_, u8>,
    p: P,
    (a, b): (usize, usize),
    (ya, yb): (usize, usize),
) -> Option<(usize, usize, usize, usize)> {
    let hits = |y: usize| row_hits(p, f.row(y), a, b).map(|h| (y, h));
    let (y0, (mut x0, mut xl)) = (ya..yb).find_map(hits)?;
    let mut y1 = y0 + 1;
    if let Some((y, (f0, l))) = (y1..yb).rev().find_map(hits) {
        y1 = y + 1;
        x0 = x0.min(f0);
        xl = xl.max(l);
    }
    for y in y0 + 1..y1.saturating_sub(1) {
        if x0 <= a && xl.saturating_add(1) >= b {
            break;
        }
        let row = f.row(y);
        if let Some(x) = first_hit(p, row, a, x0) {
            x0 = x;
        }
        if let Some(x) = last_hit(p, row, xl + 1, b) {
            xl = x;
        }
    }
    Some((x0, y0, xl, y1))
}

/// Statistics and boxes of one band (the per-pixel part of [`analyze`], without the block
/// analysis of a noisy band).
pub fn band_stats(f: FrameRef<'_, u8>, p: &SceneParams) -> BandStats {
    let (hist, n) = histogram(f);
    let background = median_of(&hist, n);
    let spread_q8 = upper_quartile_q8(&hist, n)
        .saturating_sub(u32::from(background) << 8)
        .min(u32::from(u16::MAX)) as u16;
    // k·1.4826·spread rounded up: k in tenths, 1.4826 as 14826/10⁴, spread in Q8.
    let spread = (u64::from(spread_q8) * u64::from(p.k_sigma_tenths) * 14826).div_ceil(100_000 << 8);
    let delta = spread.max(u64::from(p.min_delta)).min(256) as u16;
    let threshold = u16::from(background) + delta;
    let signal_samples = hist
        .iter()
        .enumerate()
        .filter(|&(v, _)| v as u16 > threshold)
        .map(|(_, &c)| c)
        .fold(0u32, u32::saturating_add);
    let saturated_samples = if threshold < 255 { hist.get(255).copied().unwrap_or(0) } else { 0 };

    // Varying: pixels ≠ background. Signal pixels (> threshold > background) are varying
    // pixels, so the signal runs are searched inside the varying box only.
    let varying = hit_box(f, Differs::new(background), (0, f.width()), (0, f.height()));
    let signal = match (varying, u8::try_from(threshold)) {
        (Some((x0, y0, xl, y1)), Ok(t)) if t < 255 => {
            let win = ((x0, xl + 1), (y0, y1));
            if t < 128 {
                hit_box(f, RunAbove::<true>::new(t), win.0, win.1)
            } else {
                hit_box(f, RunAbove::<false>::new(t), win.0, win.1)
            }
        }
        _ => None,
    };
    BandStats {
        background,
        spread_q8,
        threshold,
        samples: n,
        signal_samples,
        saturated_samples,
        // The run's second pixel is signal too.
        signal: signal.map(|(x0, y0, xl, y1)| Rect { x0, y0, x1: xl + 2, y1 }),
        varying: varying.map(|(x0, y0, xl, y1)| Rect { x0, y0, x1: xl + 1, y1 }),
    }
}

/// The illumination class of a VIS band from its statistics ([`band_stats`]): no signal is
/// [`Illumination::Eclipse`], at least `saturated_percent` of the signal samples at 255 is
/// [`Illumination::Saturated`], anything else [`Illumination::Light`].
pub fn illumination(vis: &BandStats, params: &SceneParams) -> Illumination {
    if vis.signal.is_none() {
        Illumination::Eclipse
    } else if u64::from(vis.saturated_samples) * 100
        >= u64::from(params.saturated_percent) * u64::from(vis.signal_samples.max(1))
    {
        Illumination::Saturated
    } else {
        Illumination::Light
    }
}

/// `r` (in a `from`-sized frame) on a `to`-sized grid, grown by a margin that covers the
/// rescaler's taps (none when the sizes match), clipped to the grid.
pub fn map_rect(r: Rect, from: (usize, usize), to: (usize, usize)) -> Rect {
    if from == to {
        return r;
    }
    let axis = |a0: usize, a1: usize, f: usize, t: usize| {
        let f = f.max(1);
        let margin = 2 * t.div_ceil(f) + 2;
        let lo = (a0.saturating_mul(t) / f).saturating_sub(margin);
        let hi = a1.saturating_mul(t).div_ceil(f).saturating_add(margin).min(t);
        (lo, hi)
    };
    let (x0, x1) = axis(r.x0, r.x1, from.0, to.0);
    let (y0, y1) = axis(r.y0, r.y1, from.1, to.1);
    Rect { x0, y0, x1, y1 }
}

/// Analyses a VIS/TIR pair for the fusion grid `grid` (see the module docs).
///
/// Errors: [`Error::InvalidParameter`] for bad [`SceneParams`]; the views were validated when
/// built, so there is no other.
pub fn analyze(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    grid: (usize, usize),
    params: &SceneParams,
) -> Result<Scene, Error> {
    params.validate()?;
    let v = band_stats(vis, params);
    let t = band_stats(tir, params);
    let quiet = |b: &BandStats| b.spread_q8 <= u16::from(params.max_noise_spread) << 8;
    // A noisy band's target comes from its block means.
    let (vb, tb) = (
        (!quiet(&v)).then(|| block_stats(vis, v.spread_q8, params)),
        (!quiet(&t)).then(|| block_stats(tir, t.spread_q8, params)),
    );
    let illumination = illumination(&v, params);
    let on_grid = |b: Option<Rect>, from: (usize, usize)| b.map(|r| map_rect(r, from, grid));
    // A noisy band's box: its blocks', on the grid, grown by the margin.
    let target = |b: &BandStats, blocks: &Option<BlockStats>, size| match blocks {
        None => on_grid(b.signal, size),
        Some(k) => on_grid(k.signal, size).map(|r| r.grow(usize::from(params.noisy_margin), grid)),
    };
    let (target_vis, target_tir) = (target(&v, &vb, vis.size()), target(&t, &tb, tir.size()));
    let (varying_vis, varying_tir) = (on_grid(v.varying, vis.size()), on_grid(t.varying, tir.size()));
    let dark = |b: &BandStats| b.background <= params.max_background;
    // Noisy pixels are fine when the block means are quiet; noisy block means (structure in
    // the background, not sensor noise) are not.
    let blocks_quiet = |k: &Option<BlockStats>| {
        k.as_ref().is_none_or(|k| k.spread_q8 <= u16::from(params.max_noise_spread) << 8)
    };
    let vis_background_lit = !dark(&v) || !blocks_quiet(&vb);
    let decline = if !dark(&v) || !dark(&t) {
        Some(Decline::BackgroundNotDark)
    } else if !blocks_quiet(&vb) || !blocks_quiet(&tb) {
        Some(Decline::TooNoisy)
    } else {
        None
    };
    Ok(Scene {
        grid,
        vis: v,
        tir: t,
        illumination,
        target: Rect::join(target_vis, target_tir),
        target_tir,
        varying: Rect::join(varying_vis, varying_tir),
        varying_tir,
        decline,
        vis_background_lit,
        vis_blocks: vb,
        tir_blocks: tb,
        rescale_needed: vis.size() != tir.size(),
    })
}

#[cfg(test)]
mod tests;
