//! Strip processing: fuse a frame pair in horizontal strips with halos, in a fixed working set
//! of [`STRIP_SCRATCH_BYTES`] (512 KiB) besides the input and output frames, bit-identical to
//! the whole-frame [`crate::pipeline::fuse`].
//!
//! The whole-frame pipeline keeps three `i32` planes and the rescaled band (13 bytes per grid
//! pixel, 13 MiB at 1024²). A flight processor's fast RAM holds a few hundred KiB, so
//! [`fuse_strips`] walks the grid top to bottom in strips of rows. For each strip it brings
//! the strip's *window* (the strip grown by the method's halo, cut at the frame's edges) onto
//! the grid — rescaling only the source rows the window's taps read, into the scratch's band
//! buffer — and runs a row-streaming form of the method on the window, keeping only the strip's
//! rows. Where a window ends inside the frame the halo absorbs the window's own border rule;
//! where it ends at the frame's edge the border rule is the frame's. So every kept row is the
//! whole-frame row, bit for bit (tested on rendered, synthetic and VIFB frames).
//!
//! | method | streaming form | halo (grid rows) | passes | work memory at width W |
//! |---|---|---|---|---|
//! | TSIFSD flight | the flight kernel started at the strip's first row: column sums of the 35×35 window and a ring of `2r + 3` rows of lane words | `max(r, 1)` = 17 (the mean's radius; the Scharr rows `y ± 1` lie inside it) | 1 | `(W + 2r + 1) + (2r + 3)·W` words (152.1 KiB at W = 1024) |
//! | TSIFSD classic | the column sums of the circular 35×35 window slid down the strip, the box row by the circular horizontal pass, the zero-padded median's rows | `max(r, 1)` = 17, plus up to `r` rows from the frame's other edge for the strips near the top and bottom (the circular window wraps; the band keeps a tail for them) | 1 | `4·W` words: column sums and box row of both bands (16 KiB at W = 1024) |
//! | ADF (both variants) | the diffusion's row pipeline of both bands (all iterations in one group) | `iterations` = 10 | 2: the covariance (global KL weights), then the output | `32 768 + iterations·3·(W + 2) + W` words: the flux table, the pipeline and its output row (252.2 KiB at W = 1024, 10 iterations) |
//! | adaptive | `fuse::adaptive::fuse_adaptive_rows`: column sums of the box slid down the strip, the binomial's rows read in place | `max(n/2, 1)` = 17 | 1 | `2·W` words (8 KiB at W = 1024) |
//! | IFEVIP (both variants) | `fuse::ifevip::stream` (crate-private): the IR onto the quadtree grid a few rows at a time (quadtree block ranges, erosion at every candidate crossing from a ring of rows); the background rows from the leaves' Bézier rows; `R` and the top-`k` keys; the output | pass 1: the vertical taps of the IR onto the `D` grid, less one (9 at 1024 → 512); passes 2 and 3: none | 3: analysis, keys (`R` kept in the output frame), output | the crossings' minima, then per pass its tables and row buffers, up to 32 rows a chunk, and the top-`k` buffer (250.8 KiB at W = 1024, `D` = 512) |
//!
//! ADF's weights come from the covariance of the whole frame's detail layers, which no strip
//! knows alone: the first pass diffuses every strip and adds its rows to the exact integer sums
//! (the order of addition does not change them), the second diffuses again and writes the
//! output. The diffusion therefore runs twice; [`StripReport`] counts the rows.
//!
//! IFEVIP's quadtree, its gain (the peak of the top 0.1 % of the keys) and its entropy ratio
//! are global too: pass 1 gathers the histograms and the tree, pass 2 computes every pixel's
//! `R` (written into the output frame, which nothing else needs until pass 3) and keeps the
//! exact top `k` keys, pass 3 writes `F` over `R`. The band is therefore rescaled three times.
//! The background's vertical run grows as the grid shrinks below `D`: a wide grid less than
//! about `D/4` rows high (128 at the published `D` = 512) can need more than the work words
//! ([`Error::ScratchTooSmall`]), as can an erosion window of more than ≈ 90 rows or a
//! `top_ppm` far above the published 0.1 % (the keys are kept exactly, two words each).
//!
//! Not in strips (an `Err`, never a different result):
//! * Scene skipping ([`Error::InvalidParameter`] `"skip"`): strips run `SkipPolicy::None`.
//! * A rescale that is not an exact 2× ratio of the policy's filter ([`Error::UnsupportedRatio`]):
//!   only the 2× kernels rescale a window with the whole frame's bits. Same-size frames need
//!   no band at all.
//!
//! Memory: [`StripScratch`] (`static` on the firmware): [`STRIP_WORK_WORDS`] `i32` words for the
//! method and [`STRIP_BAND_BYTES`] bytes for the window of the rescaled band. The strip height
//! is the largest the band holds (or `max_rows`, if smaller): at W = 1024 with TIR up, 212
//! rows (TSIFSD flight), 226 rows (ADF) and 228 rows (IFEVIP's pass 1; its halo-free passes
//! 246), five strips per frame; 185 rows, six strips, for TSIFSD classic (the band's tail holds
//! the wrapped rows).

use crate::fuse::adaptive::{decide_frame, fuse_adaptive_rows, work_words as adaptive_words};
use crate::fuse::adf::{Covariance, diffuse_rows, stream_words};
use crate::fuse::ifevip::stream::{Analysis, Keys, Tree, crossing_words, output_rows};
use crate::fuse::ifevip::{EntropyRatio, GainTables, Gains, top_k};
use crate::fuse::tsifsd::{classic_words, flight_words, fuse_tsifsd_classic_rows, fuse_tsifsd_flight_rows};
use crate::fuse::{Guards, Variant};
use crate::pipeline::{
    BandRatio, FuseReport, Method, Pipeline, RescalePolicy, SkipPolicy, SkipReport, band_ratio, band_window,
    fusion_grid,
};
use crate::scene::Rect;
use crate::{Error, Filter, FrameMut, FrameRef};

/// `i32` words of method work memory in a [`StripScratch512K`] (256 KiB; ADF needs 64 572 at
/// W = 1024, see the table above).
pub const STRIP_WORK_WORDS: usize = 64 * 1024;
/// Bytes of band window in a [`StripScratch512K`] (256 KiB: 256 rows of a 1024-wide grid).
pub const STRIP_BAND_BYTES: usize = 256 * 1024;
/// The whole strip working set of a [`StripScratch512K`]: 512 KiB.
pub const STRIP_SCRATCH_BYTES: usize = STRIP_WORK_WORDS * 4 + STRIP_BAND_BYTES;

/// Caller-owned strip memory: `WORDS` `i32` words for the method, `BAND` bytes for the window
/// of the rescaled band.
#[derive(Debug, Clone)]
#[repr(C)]
pub struct StripScratch<const WORDS: usize, const BAND: usize> {
    work: [i32; WORDS],
    band: [u8; BAND],
}

/// The 512 KiB strip scratch: fuses grids up to 1024 wide (TSIFSD, ADF with up to 10
/// iterations, IFEVIP with the published quadtree grid; wider grids, more iterations or a grid
/// much shorter than IFEVIP's quadtree grid need more work words).
pub type StripScratch512K = StripScratch<STRIP_WORK_WORDS, STRIP_BAND_BYTES>;

impl<const WORDS: usize, const BAND: usize> StripScratch<WORDS, BAND> {
    /// Zeroed scratch (usable in `static` initialisers).
    pub const fn new() -> Self {
        Self { work: [0; WORDS], band: [0; BAND] }
    }

    /// Borrows the memory as an unsized view.
    pub fn view_mut(&mut self) -> StripScratchMut<'_> {
        StripScratchMut { work: &mut self.work, band: &mut self.band }
    }
}

impl<const WORDS: usize, const BAND: usize> Default for StripScratch<WORDS, BAND> {
    fn default() -> Self {
        Self::new()
    }
}

/// Borrowed strip memory.
#[derive(Debug)]
pub struct StripScratchMut<'a> {
    work: &'a mut [i32],
    band: &'a mut [u8],
}

impl<'a> StripScratchMut<'a> {
    /// Strip memory from caller-provided slices.
    pub fn from_slices(work: &'a mut [i32], band: &'a mut [u8]) -> Self {
        Self { work, band }
    }

    /// Bytes of the whole working set (work words and band).
    pub fn bytes(&self) -> usize {
        self.work.len() * 4 + self.band.len()
    }
}

/// What a [`fuse_strips`] run did, for the working-set and halo-overhead reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StripReport {
    /// Number of strips per pass (IFEVIP: of its first pass, which has the halo).
    pub strips: usize,
    /// Grid rows per strip (the last strip may be shorter; IFEVIP: first pass).
    pub strip_rows: usize,
    /// Grid rows of the method's halo on each side of a strip.
    pub halo_rows: usize,
    /// Passes over the strips (1: TSIFSD; 2: ADF, covariance then output; 3: IFEVIP, analysis,
    /// keys, output).
    pub passes: usize,
    /// Grid rows of the windows the method read over all passes, halos included (the
    /// whole-frame run reads the grid's height once). TSIFSD computes output rows for the
    /// strip's rows only (its halo rows are read for the window sums); ADF diffuses its windows
    /// down to the strip's last row.
    pub method_rows: usize,
    /// Rows of the rescaled band produced over all passes, halos and tap margins included
    /// (0 when the frames share a grid; the whole-frame run produces the grid's height once).
    pub band_rows: usize,
    /// Work words the method used.
    pub work_words: usize,
    /// Most band bytes one window used.
    pub band_bytes: usize,
}

impl StripReport {
    /// The working set this run used: work words and the largest band window, in bytes.
    pub fn working_set_bytes(&self) -> usize {
        self.work_words * 4 + self.band_bytes
    }
}

/// The methods that run in strips, with their parameters.
enum Streamed<'p> {
    TsifsdFlight(&'p crate::TsifsdParams),
    TsifsdClassic(&'p crate::TsifsdParams),
    Adf(&'p crate::AdfParams),
    Ifevip(&'p crate::IfevipParams),
    Adaptive(&'p crate::fuse::adaptive::AdaptiveParams),
}

/// Grid rows of a band outside its strip window.
#[derive(Clone, Copy)]
enum Rest<'b> {
    /// The band is on the grid: the whole input frame.
    Frame(FrameRef<'b, u8>),
    /// The rescaled rows from this grid row on (the rows a circular window wraps to).
    Rows(usize, FrameRef<'b, u8>),
    /// None.
    Nothing,
}

/// One strip's window as [`Walk::run`] hands it to the method: both bands on the grid rows
/// `y0 .. y0 + vis.height()` and, for the methods that wrap around the frame, the rows beyond.
struct Window<'b> {
    vis: FrameRef<'b, u8>,
    tir: FrameRef<'b, u8>,
    y0: usize,
    /// The grid rows to keep (inside the window).
    strip: core::ops::Range<usize>,
    vis_rest: Rest<'b>,
    tir_rest: Rest<'b>,
    /// Grid rows beyond the window that a wrapping method reads (from the other edge).
    wrapped: usize,
}

impl<'b> Window<'b> {
    /// Grid row `y` of a band: from the window, else from the rows beyond it.
    fn row(win: FrameRef<'b, u8>, y0: usize, rest: Rest<'b>, y: usize) -> Option<&'b [u8]> {
        let inside = |f: FrameRef<'b, u8>, first: usize| {
            y.checked_sub(first).filter(|&i| i < f.height()).map(|i| f.row(i))
        };
        inside(win, y0).or(match rest {
            Rest::Frame(f) => inside(f, 0),
            Rest::Rows(first, f) => inside(f, first),
            Rest::Nothing => None,
        })
    }
}

/// The strips of one frame pair and how each window is brought onto the grid.
struct Walk<'f> {
    vis: FrameRef<'f, u8>,
    tir: FrameRef<'f, u8>,
    grid: (usize, usize),
    /// The policy's filter.
    filter: Filter,
    /// Whether the sizes differ (a band is rescaled), and whether it is a 2× cubic up.
    rescaled: bool,
    up2: bool,
    halo: usize,
    strip_rows: usize,
    /// Whether the method's window wraps around the frame's top and bottom (TSIFSD classic's
    /// circular mean), so a strip near an edge also needs rows from the other edge.
    wrap: bool,
    /// Band bytes reserved for the strip window (the rest holds the wrapped rows).
    window_bytes: usize,
}

impl Walk<'_> {
    /// One pass: for each strip, top to bottom, its [`Window`] (the rescaled band's rows in
    /// `band`) and `f(window)`, which returns the grid rows the method read. Adds the rows to
    /// `report`.
    fn run(
        &self,
        band: &mut [u8],
        report: &mut StripReport,
        mut f: impl FnMut(Window<'_>) -> Result<usize, Error>,
    ) -> Result<(), Error> {
        let (w, h) = self.grid;
        for s0 in (0..h).step_by(self.strip_rows.max(1)) {
            let s1 = (s0 + self.strip_rows).min(h);
            let mut y0 = s0.saturating_sub(self.halo);
            if self.up2 {
                y0 &= !1; // the 2× kernel's phase: windows start on an even grid row
            }
            let y1 = (s1 + self.halo).min(h);
            let win = Rect { x0: 0, y0, x1: w, y1 };
            // The bands' windows where they are on the grid (the rescaled one's is `Err`).
            let (vis, tir) = (self.vis.sub_rect(0, y0, w, y1 - y0), self.tir.sub_rect(0, y0, w, y1 - y0));
            // The rows a wrapping window reads beyond the frame's edge that the window lacks: the
            // bottom rows for a strip near the top, the top rows for one near the bottom (at most
            // one of them: a strip near both edges has the whole frame in its window).
            let wrapped = match self.wrap {
                true if s0 < self.halo && y1 < h => Some((h.saturating_sub(self.halo - s0).max(y1), h)),
                true if s1 + self.halo > h && y0 > 0 => Some((0, (s1 + self.halo - h).min(y0))),
                _ => None,
            };
            let wrapped_rows = wrapped.map_or(0, |(e0, e1)| e1 - e0);
            let at = self.window_bytes.min(band.len());
            let (main, extra) =
                band.split_at_mut_checked(at).ok_or(Error::ScratchTooSmall { needed: at, capacity: 0 })?;
            let (window, band_rows) = if !self.rescaled {
                let (vis_rest, tir_rest) = (Rest::Frame(self.vis), Rest::Frame(self.tir));
                (
                    Window {
                        vis: vis?,
                        tir: tir?,
                        y0,
                        strip: s0..s1,
                        vis_rest,
                        tir_rest,
                        wrapped: wrapped_rows,
                    },
                    0,
                )
            } else {
                let (src, on_grid) =
                    if self.filter == Filter::Cubic { (self.tir, vis?) } else { (self.vis, tir?) };
                let b = band_window(src, self.grid, win, self.filter, main)?;
                let (rest, extra_rows) = match wrapped {
                    Some((e0, e1)) => {
                        let e0 = if self.up2 { e0 & !1 } else { e0 };
                        let e = band_window(
                            src,
                            self.grid,
                            Rect { x0: 0, y0: e0, x1: w, y1: e1 },
                            self.filter,
                            extra,
                        )?;
                        (Rest::Rows(e0, e.view), e.rows)
                    }
                    None => (Rest::Nothing, 0),
                };
                let full = Rest::Frame(if self.filter == Filter::Cubic { self.vis } else { self.tir });
                let window = if self.filter == Filter::Cubic {
                    Window {
                        vis: on_grid,
                        tir: b.view,
                        y0,
                        strip: s0..s1,
                        vis_rest: full,
                        tir_rest: rest,
                        wrapped: wrapped_rows,
                    }
                } else {
                    Window {
                        vis: b.view,
                        tir: on_grid,
                        y0,
                        strip: s0..s1,
                        vis_rest: rest,
                        tir_rest: full,
                        wrapped: wrapped_rows,
                    }
                };
                (window, b.rows + extra_rows)
            };
            report.band_rows += band_rows;
            report.band_bytes = report.band_bytes.max(band_rows * w);
            report.method_rows += f(window)?;
        }
        Ok(())
    }
}

/// IFEVIP's three passes (see `fuse::ifevip::stream`): the analysis walk with the
/// step-1 halo, then keys and output over halo-free strips (`rest`). Returns the work words
/// used and the guards, and whether an output saturated. Each pass is a function of its own
/// (never inlined), so their state — a few KiB each — never shares one stack frame.
fn fuse_ifevip_strips(
    walk: &Walk<'_>,
    rest: &Walk<'_>,
    band: &mut [u8],
    work: &mut [i32],
    out: &mut FrameMut<'_, u8>,
    p: &crate::IfevipParams,
    report: &mut StripReport,
) -> Result<((usize, Guards), bool), Error> {
    let (w, h) = walk.grid;
    let capacity = work.len();
    let (cross, work) = work
        .split_at_mut_checked(crossing_words(p))
        .ok_or(Error::ScratchTooSmall { needed: crossing_words(p), capacity })?;
    let (tree, used_analysis) = ifevip_analysis(walk, band, cross, work, p, report)?;
    let mut guards = Guards::NONE;
    let Some(ratio) = EntropyRatio::of(&tree.hist_ir, &tree.hist_vis, p, &mut guards) else {
        // Classic with a constant visible image: F = VIS.
        rest.run(band, report, |win| {
            let rel = win.strip.start - win.y0;
            let mut rows = out.sub_rect_mut(0, win.strip.start, w, win.strip.len())?;
            for (o, v) in rows.rows_mut().zip(win.vis.rows().skip(rel)) {
                for (o, v) in o.iter_mut().zip(v) {
                    *o = *v;
                }
            }
            Ok(win.strip.len())
        })?;
        return Ok(((crossing_words(p) + used_analysis, guards), false));
    };
    let k = top_k((w * h) as u64, p, &mut guards);
    let (top, used_keys) = ifevip_keys(rest, band, work, out, &tree, p, ratio.q24, k, report)?;
    let gains = Gains::new(top, k, ratio.q32, p, &mut guards);
    let saturated = ifevip_output(rest, band, out, &gains, report)?;
    Ok(((crossing_words(p) + used_analysis.max(used_keys), guards), saturated))
}

/// IFEVIP pass 1: the tree and the histograms, and the work words it took.
#[inline(never)]
fn ifevip_analysis<'c>(
    walk: &Walk<'_>,
    band: &mut [u8],
    cross: &'c mut [i32],
    work: &mut [i32],
    p: &crate::IfevipParams,
    report: &mut StripReport,
) -> Result<(Tree<'c>, usize), Error> {
    let mut analysis = Analysis::new(walk.grid, p, cross, work)?;
    walk.run(band, report, |win| {
        analysis.add_window(win.vis, win.tir, win.y0, win.strip.clone())?;
        Ok(win.vis.height())
    })?;
    let used = analysis.words();
    Ok((analysis.finish()?, used))
}

/// IFEVIP pass 2: `R` into `out`, and the sum of the `k` largest keys with the work words taken.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn ifevip_keys(
    rest: &Walk<'_>,
    band: &mut [u8],
    work: &mut [i32],
    out: &mut FrameMut<'_, u8>,
    tree: &Tree<'_>,
    p: &crate::IfevipParams,
    ratio_q24: i64,
    k: u64,
    report: &mut StripReport,
) -> Result<(i128, usize), Error> {
    let w = rest.grid.0;
    let mut keys = Keys::new(tree, rest.grid, p, ratio_q24, k, work)?;
    rest.run(band, report, |win| {
        let rows = out.sub_rect_mut(0, win.strip.start, w, win.strip.len())?;
        keys.add_rows(win.vis, win.tir, win.y0, win.strip.clone(), rows)?;
        Ok(win.strip.len())
    })?;
    Ok((keys.top_sum(), keys.words()))
}

/// IFEVIP pass 3: `F` in place; whether an output saturated.
#[inline(never)]
fn ifevip_output(
    rest: &Walk<'_>,
    band: &mut [u8],
    out: &mut FrameMut<'_, u8>,
    gains: &Gains,
    report: &mut StripReport,
) -> Result<bool, Error> {
    let w = rest.grid.0;
    let tables = GainTables::new(gains.g_q, gains.b_q);
    let mut saturated = false;
    rest.run(band, report, |win| {
        let rows = out.sub_rect_mut(0, win.strip.start, w, win.strip.len())?;
        saturated |= output_rows(win.vis, win.tir, win.y0, win.strip.clone(), rows, &tables)?;
        Ok(win.strip.len())
    })?;
    Ok(saturated)
}

/// Fuses a VIS/TIR pair like [`crate::pipeline::fuse`] with `pipeline.skip` =
/// [`SkipPolicy::None`], but strip by strip in `scratch` (see the module docs): the same
/// bytes, the same guards. `max_rows` caps the strip height (`usize::MAX`: as tall as the
/// scratch allows; smaller strips cost more halo rows).
///
/// Errors: those of [`crate::pipeline::fuse`]; [`Error::InvalidParameter`] for what strips do
/// not run (`"skip"`, `"max_rows"` for 0); [`Error::UnsupportedRatio`] for a rescale that is not an exact 2× of the policy's filter;
/// [`Error::ScratchTooSmall`] (in bytes of band or words of work) when not even a one-row strip
/// and its halos fit. Nothing is written to `out` before these checks pass.
pub fn fuse_strips(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    mut out: FrameMut<'_, u8>,
    scratch: &mut StripScratchMut<'_>,
    pipeline: &Pipeline,
    max_rows: usize,
) -> Result<(FuseReport, StripReport), Error> {
    if pipeline.skip != SkipPolicy::None {
        return Err(Error::InvalidParameter { name: "skip" });
    }
    if max_rows == 0 {
        return Err(Error::InvalidParameter { name: "max_rows" });
    }
    pipeline.method.validate()?;
    let grid = fusion_grid(vis.size(), tir.size(), pipeline.rescale)?;
    if out.size() != grid {
        return Err(Error::SizeMismatch { expected: grid, got: out.size() });
    }
    let (w, h) = grid;
    let (streamed, halo, passes, words) = match &pipeline.method {
        // The kernels read rows y − r … y + r for output row y (the Scharr or median rows y ± 1
        // lie inside for r ≥ 1): a halo of max(r, 1) rows keeps every output row exact.
        Method::Tsifsd(p) if p.variant == Variant::Flight => {
            let r = usize::from(p.mean_size / 2);
            (Streamed::TsifsdFlight(p), r.max(1), 1, flight_words(w, r))
        }
        Method::Tsifsd(p) => {
            let r = usize::from(p.mean_size / 2);
            (Streamed::TsifsdClassic(p), r.max(1), 1, classic_words(w))
        }
        Method::Adf(p) => (Streamed::Adf(p), usize::from(p.iterations), 2, stream_words(w, p)),
        // Pass 1's halo holds the vertical taps of the IR onto the quadtree grid; passes 2
        // and 3 read the strip's own rows only.
        Method::Ifevip(p) => (Streamed::Ifevip(p), Analysis::halo(grid, p), 3, 0),
        // Rows y − r … y + r of both bands (the binomial's y ± 1 inside): two rows of column
        // sums; the frame's decision comes from the scene analysis of the input frames first.
        Method::Adaptive(p) => (Streamed::Adaptive(p), p.halo(), 1, adaptive_words(w)),
    };
    if scratch.work.len() < words {
        return Err(Error::ScratchTooSmall { needed: words, capacity: scratch.work.len() });
    }
    // The band: which input is rescaled, with which filter, and whether its 2× kernel can
    // rescale a window with the whole frame's bits.
    let (src, filter) = match pipeline.rescale {
        RescalePolicy::TirUp => (tir.size(), Filter::Cubic),
        RescalePolicy::VisDown | RescalePolicy::None => (vis.size(), Filter::Area),
    };
    let rescaled = vis.size() != tir.size();
    let ratio = band_ratio(src, grid, filter);
    if ratio == BandRatio::Other {
        return Err(Error::UnsupportedRatio);
    }
    let up2 = ratio == BandRatio::CubicUp2;
    // Window rows: the strip, its halo on both sides and (2× up) one row of alignment; the
    // band of a 2× up window holds up to 9 rows more (the taps' margins). A wrapping window
    // (TSIFSD classic) also needs up to `halo` rows from the frame's other edge, with their own
    // alignment row and margins.
    let wrap = matches!(streamed, Streamed::TsifsdClassic(_));
    let band_rows_max = if rescaled { scratch.band.len() / w.max(1) } else { usize::MAX };
    let margin = if up2 { 9 } else { 0 };
    // The strips of a walk with `halo` rows on each side: as tall as the band holds.
    let walk = |halo: usize| -> Result<Walk<'_>, Error> {
        let wrapped_rows = if wrap && rescaled { halo + usize::from(up2) + margin } else { 0 };
        let fixed = margin + 2 * halo + usize::from(up2) + wrapped_rows;
        let fit = band_rows_max.saturating_sub(fixed);
        if fit == 0 {
            let needed = w * (fixed + 1);
            return Err(Error::ScratchTooSmall { needed, capacity: scratch.band.len() });
        }
        let strip_rows = fit.min(max_rows).min(h);
        let window_bytes = w * (strip_rows + margin + 2 * halo + usize::from(up2));
        Ok(Walk { vis, tir, grid, filter, rescaled, up2, halo, strip_rows, wrap, window_bytes })
    };
    let first = walk(halo)?;
    let mut report = StripReport {
        strips: h.div_ceil(first.strip_rows.max(1)),
        strip_rows: first.strip_rows,
        halo_rows: halo,
        passes,
        method_rows: 0,
        band_rows: 0,
        work_words: words,
        band_bytes: 0,
    };
    let rest = walk(0)?;
    let walk = first;
    let StripScratchMut { work, band } = scratch;
    let mut guards = Guards::NONE;
    match streamed {
        Streamed::TsifsdFlight(p) => walk.run(band, &mut report, |win| {
            let Window { vis: vis_w, tir: tir_w, y0, strip, .. } = win;
            let rows = out.sub_rect_mut(0, strip.start, w, strip.len())?;
            guards |= fuse_tsifsd_flight_rows(vis_w, tir_w, rows, strip.start - y0, p, work)?;
            Ok(vis_w.height())
        })?,
        Streamed::TsifsdClassic(p) => walk.run(band, &mut report, |win| {
            let rows = out.sub_rect_mut(0, win.strip.start, w, win.strip.len())?;
            let vis_row = |y| Window::row(win.vis, win.y0, win.vis_rest, y);
            let tir_row = |y| Window::row(win.tir, win.y0, win.tir_rest, y);
            guards |= fuse_tsifsd_classic_rows(vis_row, tir_row, grid, win.strip.clone(), rows, p, work)?;
            Ok(win.vis.height() + win.wrapped)
        })?,
        Streamed::Adf(p) => {
            let mut cov = Covariance::new();
            walk.run(band, &mut report, |win| {
                let Window { vis: vis_w, tir: tir_w, y0, strip, .. } = win;
                let keep = strip.start - y0..strip.end - y0;
                diffuse_rows(vis_w, tir_w, p, work, keep.end, |y, a| {
                    if keep.contains(&y) {
                        cov.add_row(vis_w.row(y), tir_w.row(y), a);
                    }
                })?;
                Ok(vis_w.height())
            })?;
            let fusion = cov.weights(w * h, p.variant);
            guards |= fusion.guards;
            let mut saturated = false;
            walk.run(band, &mut report, |win| {
                let Window { vis: vis_w, tir: tir_w, y0, strip, .. } = win;
                let keep = strip.start - y0..strip.end - y0;
                diffuse_rows(vis_w, tir_w, p, work, keep.end, |y, a| {
                    if keep.contains(&y) {
                        let (iv, it) = (vis_w.row(y), tir_w.row(y));
                        saturated |= fusion.u8_row(iv, it, a, out.row_mut(y0 + y));
                    }
                })?;
                Ok(vis_w.height())
            })?;
            if saturated {
                guards |= Guards::OUTPUT_SATURATED;
            }
        }
        Streamed::Adaptive(p) => {
            let decision = decide_frame(vis, &pipeline.scene, p)?;
            let (cv, ct) =
                work.split_at_mut_checked(w).ok_or(Error::ScratchTooSmall { needed: 2 * w, capacity: 0 })?;
            walk.run(band, &mut report, |win| {
                let Window { vis: vis_w, tir: tir_w, y0, strip, .. } = win;
                let mut rows = out.sub_rect_mut(0, strip.start, w, strip.len())?;
                guards |= fuse_adaptive_rows(
                    vis_w,
                    tir_w,
                    y0,
                    h,
                    strip,
                    &mut rows,
                    p,
                    decision,
                    [&mut *cv, &mut *ct],
                )?;
                Ok(vis_w.height())
            })?;
        }
        Streamed::Ifevip(p) => {
            let (used, saturated) = fuse_ifevip_strips(&walk, &rest, band, work, &mut out, p, &mut report)?;
            report.work_words = used.0;
            guards |= used.1;
            if saturated {
                guards |= Guards::OUTPUT_SATURATED;
            }
        }
    }
    let fuse =
        FuseReport { grid, rescaled, guards, skip: SkipReport::none(SkipPolicy::None, grid, rescaled) };
    Ok((fuse, report))
}
