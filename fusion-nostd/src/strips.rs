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
//! | adaptive (blend, pass-through; a large target's frame runs ADF's row above) | `methods::adaptive::fuse_adaptive_rows`: column sums of the box slid down the strip, the binomial's rows read in place | `max(n/2, 1)` = 17 | 1 | `2·W` words (8 KiB at W = 1024) |
//! | IFEVIP (both variants) | `methods::ifevip::stream` (crate-private): the IR onto the quadtree grid a few rows at a time (quadtree block ranges, erosion at every candidate crossing from a ring of rows); the background rows from the leaves' Bézier rows; `R` and the top-`k` keys; the output | pass 1: the vertical taps of the IR onto the `D` grid, less one (9 at 1024 → 512); passes 2 and 3: none | 3: analysis, keys (`R` kept in the output frame), output | the crossings' minima, then per pass its tables and row buffers, up to 32 rows a chunk, and the top-`k` buffer (250.8 KiB at W = 1024, `D` = 512) |
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

use crate::methods::Guards;
use crate::methods::adaptive::{Decided, Decision, decide_frame};
use crate::pipeline::{
    BandRatio, FuseConfig, FuseReport, Method, RescalePolicy, SkipPolicy, SkipReport, band_ratio,
    band_window, fusion_grid, sequence_link,
};
use crate::scene::Rect;
use crate::sequence::{Link, Sequence};
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

/// Grid rows of a band outside its strip window.
#[derive(Clone, Copy)]
pub(crate) enum Rest<'b> {
    /// The band is on the grid: the whole input frame.
    Frame(FrameRef<'b, u8>),
    /// The rescaled rows from this grid row on (the rows a circular window wraps to).
    Rows(usize, FrameRef<'b, u8>),
    /// None.
    Nothing,
}

/// One strip's window as [`Walk::run`] hands it to the method: both bands on the grid rows
/// `y0 .. y0 + vis.height()` and, for the methods that wrap around the frame, the rows beyond.
pub(crate) struct Window<'b> {
    /// VIS on the window's grid rows.
    pub(crate) vis: FrameRef<'b, u8>,
    /// TIR on the window's grid rows.
    pub(crate) tir: FrameRef<'b, u8>,
    /// The window's first grid row.
    pub(crate) y0: usize,
    /// The grid rows to keep (inside the window).
    pub(crate) strip: core::ops::Range<usize>,
    vis_rest: Rest<'b>,
    tir_rest: Rest<'b>,
    /// Grid rows beyond the window that a wrapping method reads (from the other edge).
    pub(crate) wrapped: usize,
}

impl<'b> Window<'b> {
    /// Grid row `y` of VIS: from the window, else from the rows beyond it (`None`: neither).
    pub(crate) fn vis_row(&self, y: usize) -> Option<&'b [u8]> {
        Self::row(self.vis, self.y0, self.vis_rest, y)
    }

    /// Grid row `y` of TIR: from the window, else from the rows beyond it (`None`: neither).
    pub(crate) fn tir_row(&self, y: usize) -> Option<&'b [u8]> {
        Self::row(self.tir, self.y0, self.tir_rest, y)
    }

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
pub(crate) struct Walk<'f> {
    /// The whole VIS frame.
    pub(crate) vis: FrameRef<'f, u8>,
    /// The whole TIR frame.
    pub(crate) tir: FrameRef<'f, u8>,
    /// The fusion grid.
    pub(crate) grid: (usize, usize),
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
    pub(crate) fn run(
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

/// What a method's strip form needs from the walker.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StripPlan {
    /// Grid rows of halo on each side of a strip in the first pass (the passes of
    /// [`StripRun::rest`] have none).
    pub(crate) halo: usize,
    /// Passes over the strips.
    pub(crate) passes: usize,
    /// Work words the method needs at the grid's width (checked before anything runs).
    pub(crate) work_words: usize,
    /// Whether the method's window wraps around the frame's top and bottom (a circular window),
    /// so a strip near an edge also needs rows from the other edge.
    pub(crate) wraps: bool,
}

/// A method's strip form: what it needs ([`StripPlan`]) and its passes over the strips. Each
/// method implements it in its own folder (`methods/<method>/strips.rs`); [`fuse_strips`] only
/// walks.
pub(crate) trait StripForm {
    /// The method's needs on a grid.
    fn plan(&self, grid: (usize, usize)) -> StripPlan;
    /// Runs the passes, writing every output row; returns the guards (with
    /// [`Guards::OUTPUT_SATURATED`] when an output saturated).
    fn run(&self, s: &mut StripRun<'_, '_, '_>) -> Result<Guards, Error>;
}

/// What a [`StripForm`] runs on.
pub(crate) struct StripRun<'a, 'f, 'o> {
    /// The strips with the method's halo.
    pub(crate) walk: &'a Walk<'f>,
    /// The same grid in halo-free strips (for passes that read the strip's own rows only).
    pub(crate) rest: &'a Walk<'f>,
    /// The band buffer the walks rescale into.
    pub(crate) band: &'a mut [u8],
    /// The method's work words.
    pub(crate) work: &'a mut [i32],
    /// The output frame (the grid).
    pub(crate) out: &'a mut FrameMut<'o, u8>,
    /// The rows and words counted so far.
    pub(crate) report: &'a mut StripReport,
    /// In a sequence, the frame's link to it (ADF: the carried weights; `None` otherwise).
    pub(crate) link: Option<Link<'a>>,
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
    out: FrameMut<'_, u8>,
    scratch: &mut StripScratchMut<'_>,
    pipeline: &FuseConfig,
    max_rows: usize,
) -> Result<(FuseReport, StripReport), Error> {
    strips_maybe_in_sequence(vis, tir, out, scratch, pipeline, max_rows, None)
}

/// Fuses the next frame pair of a sequence strip by strip: [`crate::pipeline::fuse_in_sequence`]'s
/// bytes and carry rule ([`crate::sequence`]), in the strip working set. An ADF frame fused
/// with carried weights takes **one pass** over the strips (it diffuses each strip once,
/// writing the output with the carried weights while it sums its own covariance for the next
/// frame; [`StripReport::passes`] = 1); a frame with its own weights takes the two passes of
/// [`fuse_strips`]. [`Sequence::last_step`] says which.
///
/// Errors: those of [`fuse_strips`], and [`Error::InvalidParameter`]
/// (`"size_change_percent"`) for bad sequence parameters. A failed call leaves the carried
/// weights as they were.
pub fn fuse_strips_in_sequence(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    scratch: &mut StripScratchMut<'_>,
    pipeline: &FuseConfig,
    max_rows: usize,
    seq: &mut Sequence,
) -> Result<(FuseReport, StripReport), Error> {
    let carries = matches!(pipeline.method, Method::Adf(_));
    seq.frame(carries, |seq| strips_maybe_in_sequence(vis, tir, out, scratch, pipeline, max_rows, Some(seq)))
}

/// [`fuse_strips`], in a sequence when `seq` is given.
fn strips_maybe_in_sequence(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    scratch: &mut StripScratchMut<'_>,
    pipeline: &FuseConfig,
    max_rows: usize,
    seq: Option<&mut Sequence>,
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
    let link = sequence_link(vis, pipeline, seq)?;
    let at = Setup { vis, tir, pipeline, grid, max_rows, link };
    match &pipeline.method {
        Method::Tsifsd(p) => strips_with(p, out, scratch, at),
        Method::Adf(p) => strips_with(p, out, scratch, at),
        Method::Ifevip(p) => strips_with(p, out, scratch, at),
        // The adaptive method decides on the input frames first; a large target's frame runs
        // ADF's strip form (its two passes and work words).
        Method::Adaptive(p) => match decide_frame(vis, tir, grid, &pipeline.scene, p)? {
            Decision::Adf => {
                let (mut fuse, strips) = strips_with(&p.adf, out, scratch, at)?;
                fuse.guards |= Guards::ADAPTIVE_ADF;
                Ok((fuse, strips))
            }
            decision => strips_with(&Decided { params: *p, decision }, out, scratch, at),
        },
    }
}

/// What [`strips_with`] runs on once the configuration and the grid are checked.
struct Setup<'f, 'c, 's> {
    vis: FrameRef<'f, u8>,
    tir: FrameRef<'f, u8>,
    pipeline: &'c FuseConfig,
    grid: (usize, usize),
    max_rows: usize,
    link: Option<Link<'s>>,
}

/// [`fuse_strips`] after the checks of the configuration and the grid, with `form`.
fn strips_with<F: StripForm>(
    form: &F,
    mut out: FrameMut<'_, u8>,
    scratch: &mut StripScratchMut<'_>,
    at: Setup<'_, '_, '_>,
) -> Result<(FuseReport, StripReport), Error> {
    let Setup { vis, tir, pipeline, grid, max_rows, link } = at;
    let (w, h) = grid;
    let StripPlan { halo, passes, work_words: words, wraps: wrap } = form.plan(grid);
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
    let guards = form.run(&mut StripRun {
        walk: &walk,
        rest: &rest,
        band,
        work,
        out: &mut out,
        report: &mut report,
        link,
    })?;
    let fuse =
        FuseReport { grid, rescaled, guards, skip: SkipReport::none(SkipPolicy::None, grid, rescaled) };
    Ok((fuse, report))
}
