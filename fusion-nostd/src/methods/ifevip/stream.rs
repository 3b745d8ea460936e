//! The strip form of IFEVIP: the same bytes as [`super::fuse_ifevip`], computed from windows
//! of grid rows in a work area of a few hundred KiB ([`crate::strips`] walks the windows).
//!
//! The whole-frame method keeps three `i32` planes (12 MiB at 1024²). The strip form makes
//! three passes over the grid, each reading the strips top to bottom, and keeps only what a
//! later pass needs:
//!
//! 1. **Analysis** ([`Analysis`]): the IR and VIS histograms (step 8) and the IR on the
//!    `D×D` quadtree grid (step 1), produced a few rows at a time from the strip's window
//!    (its halo holds the vertical taps). Each `D`-row is consumed at once: the quadtree
//!    needs only the range of every smallest block ([`BlockRanges`]), and the erosion
//!    (step 3) is taken, from a ring of the last `erode_size` rows, at the crossings of every
//!    line where *some* tree could put a control point ([`bezier::candidate_lines`]) — the
//!    tree is known only at the end. Kept: the leaves and the minima at those crossings.
//! 2. **Keys** ([`Background`], [`Keys`]): the background of the strip's rows (steps 4–6:
//!    the Bézier rows the column taps read, rendered once each into a sliding buffer, then the
//!    combined resize-and-Gaussian passes), `R = IR ⊖ uint8(bg)` (step 7), written as bytes into
//!    the *output frame* (free until pass 3), and every key into a [`TopK`] buffer, which gives
//!    the exact sum of the `k` largest (steps 9–10).
//! 3. **Output** ([`output_rows`]): the gains (step 11), then `F` from `VIS`, `IR` and the
//!    stored `R`, in place (step 12 through [`super::GainTables`]: the whole frame's 511 KiB
//!    table does not fit).
//!
//! Every number is the one the whole-frame run computes: the passes' sums are exact integers
//! whatever rows they are split into, the patches are written leaf by leaf in the same order,
//! and the erosion reads the same windows (tested against the whole frame on rendered,
//! synthetic and VIFB frames).
//!
//! Work memory (`i32` words): the crossings' minima stay for pass 2; pass 1 adds
//! the tap tables, the erosion ring (`erode_size × D`) and its row buffers, pass 2 the
//! combined tables, the Bézier rows, the two pass buffers and the top-`k` buffer. Each pass
//! takes the largest chunk (up to 32 rows) its words hold. At 1024² with the published
//! parameters the larger pass takes 250.8 KiB of the strip scratch's 256 KiB of work words
//! (`fusion budget`, strip table). The limits (`Error::ScratchTooSmall`, before anything is
//! written to the output): a grid much shorter than `D`, whose every background row reads a
//! long run of `D`-wide Bézier rows (66 for a 94-row grid: wide grids below about `D/4` rows do
//! not fit, with the wide horizontal table beside them); an `erode_size` ring of more than
//! ≈ 90 rows at `D` = 512; a `top_ppm` whose `k` keys (two words each) outgrow what is left
//! (≈ 1 % of the pixels at 1024²).

use super::bezier;
use super::imresize::{self, Output, Taps};
use super::peak::{Classes, Gate, TopK};
use super::quadtree::{BlockRanges, Leaf, MAX_LEAVES};
use super::{IfevipParams, MAX_NORM_DIM, bg_u8};
use crate::filters::{erode, gauss};
use crate::{Error, FrameMut, FrameRef};
use heapless::Vec;

/// Grid rows a pass handles at a time: more needs more memory for the same work.
const MAX_CHUNK: usize = 32;

/// Takes the first `n` words of `rest`.
fn take<'a>(rest: &mut &'a mut [i32], n: usize) -> Result<&'a mut [i32], Error> {
    let capacity = rest.len();
    let (head, tail) = core::mem::take(rest)
        .split_at_mut_checked(n)
        .ok_or(Error::ScratchTooSmall { needed: n, capacity })?;
    *rest = tail;
    Ok(head)
}

/// The lines (per axis) where the erosion is taken, and each one's index among them.
#[derive(Debug, Clone)]
struct Lines {
    marked: [bool; MAX_NORM_DIM],
    index: [u16; MAX_NORM_DIM],
    count: usize,
}

impl Lines {
    fn candidates(d: usize, min_dim: usize) -> Self {
        let mut marked = [false; MAX_NORM_DIM];
        bezier::candidate_lines(d, min_dim, &mut marked);
        let mut index = [0u16; MAX_NORM_DIM];
        let mut count = 0usize;
        for (i, &m) in index.iter_mut().zip(&marked) {
            if m {
                *i = count as u16;
                count += 1;
            }
        }
        Self { marked, index, count }
    }

    fn index(&self, line: usize) -> usize {
        usize::from(self.index.get(line).copied().unwrap_or(0))
    }
}

/// Words of the crossings' minima (kept from pass 1 to pass 2).
pub(crate) fn crossing_words(params: &IfevipParams) -> usize {
    let lines = Lines::candidates(usize::from(params.quad_norm_dim), usize::from(params.quad_min_dim));
    lines.count * lines.count
}

/// Pass 1: histograms, quadtree ranges and the erosion at the candidate crossings.
pub(crate) struct Analysis<'c, 'w> {
    params: IfevipParams,
    grid: (usize, usize),
    d: usize,
    hist_ir: [u32; 256],
    hist_vis: [u32; 256],
    ranges: BlockRanges,
    lines: Lines,
    crossings: &'c mut [i32],
    /// The tables of step 1 (`None`: the axis is already `D` long).
    taps_v: Option<Taps<'w>>,
    taps_h: Option<Taps<'w>>,
    /// Shifted vertical taps of one chunk.
    chunk_taps: &'w mut [i32],
    ring: &'w mut [i32],
    acc: &'w mut [i32],
    tmp: &'w mut [i32],
    out: &'w mut [i32],
    chunk: usize,
    /// The next `D`-row to produce.
    next: usize,
    /// Work words taken (besides the crossings).
    words: usize,
}

/// The leaves and the control minima pass 1 leaves for pass 2.
pub(crate) struct Tree<'c> {
    leaves: Vec<Leaf, MAX_LEAVES>,
    lines: Lines,
    crossings: &'c [i32],
    /// The histograms of step 8.
    pub(crate) hist_ir: [u32; 256],
    pub(crate) hist_vis: [u32; 256],
}

impl<'c, 'w> Analysis<'c, 'w> {
    /// Grid rows of halo pass 1 needs above a strip: the vertical taps' longest run, less one.
    /// (The walk grows windows on both sides; the rows below a strip go unread here.)
    pub(crate) fn halo(grid: (usize, usize), params: &IfevipParams) -> usize {
        let d = usize::from(params.quad_norm_dim);
        if grid.1 == d { 0 } else { imresize::max_taps(grid.1, d).saturating_sub(1) }
    }

    /// Pass 1's state in `work` for a `grid` (width, height).
    pub(crate) fn new(
        grid: (usize, usize),
        params: &IfevipParams,
        crossings: &'c mut [i32],
        work: &'w mut [i32],
    ) -> Result<Self, Error> {
        params.validate()?;
        let (w, h) = grid;
        let d = usize::from(params.quad_norm_dim);
        let total = work.len();
        let lines = Lines::candidates(d, usize::from(params.quad_min_dim));
        let ranges = BlockRanges::new(d, usize::from(params.quad_min_dim))?;
        let (needed, capacity) = (lines.count * lines.count, crossings.len());
        let crossings = crossings.get_mut(..needed).ok_or(Error::ScratchTooSmall { needed, capacity })?;
        let mut rest = work;
        let taps_v = if h != d {
            Some(imresize::build(h, d, take(&mut rest, imresize::table_len(h, d))?)?)
        } else {
            None
        };
        let taps_h = if w != d {
            Some(imresize::build(w, d, take(&mut rest, imresize::table_len(w, d))?)?)
        } else {
            None
        };
        let size = usize::from(params.erode_size);
        let ring = take(&mut rest, size * d)?;
        let acc = take(&mut rest, d)?;
        // Per chunk of c D-rows: the shifted vertical taps, the first pass's rows and the D-rows.
        let stride = taps_v.as_ref().map_or(0, |t| t.taps() + 2);
        let run = taps_v.as_ref().map_or(1, |t| t.taps());
        let step = h.div_ceil(d);
        let rows_first = w != d && h != d && w > h;
        let words = |c: usize| {
            let tmp = if rows_first { d * ((c - 1) * step + run + 1) } else { w * c };
            c * stride + tmp + d * c
        };
        let chunk = (1..=MAX_CHUNK.min(d))
            .rev()
            .find(|&c| words(c) <= rest.len())
            .ok_or(Error::ScratchTooSmall { needed: words(1), capacity: rest.len() })?;
        let chunk_taps = take(&mut rest, chunk * stride)?;
        let tmp = take(&mut rest, words(chunk) - chunk * stride - d * chunk)?;
        let out = take(&mut rest, d * chunk)?;
        let words = total - rest.len();
        Ok(Self {
            params: *params,
            grid,
            d,
            hist_ir: [0; 256],
            hist_vis: [0; 256],
            ranges,
            lines,
            crossings,
            taps_v,
            taps_h,
            chunk_taps,
            ring,
            acc,
            tmp,
            out,
            chunk,
            next: 0,
            words,
        })
    }

    /// Work words this pass takes besides the crossings.
    pub(crate) fn words(&self) -> usize {
        self.words
    }

    /// The last grid row `D`-row `i` reads.
    fn last_row(&self, i: usize) -> usize {
        match &self.taps_v {
            Some(t) => t.start(i).map_or(usize::MAX, |s| s + t.taps() - 1),
            None => i,
        }
    }

    /// The first grid row `D`-row `i` reads.
    fn first_row(&self, i: usize) -> usize {
        match &self.taps_v {
            Some(t) => t.start(i).unwrap_or(usize::MAX),
            None => i,
        }
    }

    /// One strip: `vis` and `tir` are the bands on grid rows `y0 ..`, `strip` the rows that are
    /// this strip's own (counted in the histograms). Produces every `D`-row whose taps end
    /// inside the strip; the window must reach back over their runs ([`Analysis::halo`]).
    pub(crate) fn add_window(
        &mut self,
        vis: FrameRef<'_, u8>,
        tir: FrameRef<'_, u8>,
        y0: usize,
        strip: core::ops::Range<usize>,
    ) -> Result<(), Error> {
        for y in strip.clone() {
            let i = y.checked_sub(y0).ok_or(Error::InvalidParameter { name: "rows" })?;
            if i >= vis.height() || i >= tir.height() {
                return Err(Error::InvalidParameter { name: "rows" });
            }
            for (&v, &t) in vis.row(i).iter().zip(tir.row(i)) {
                if let Some(c) = self.hist_vis.get_mut(usize::from(v)) {
                    *c += 1;
                }
                if let Some(c) = self.hist_ir.get_mut(usize::from(t)) {
                    *c += 1;
                }
            }
        }
        while self.next < self.d && self.last_row(self.next) < strip.end {
            let i0 = self.next;
            let mut i1 = i0 + 1;
            while i1 < self.d && i1 - i0 < self.chunk && self.last_row(i1) < strip.end {
                i1 += 1;
            }
            self.resize_chunk(tir, y0, i0..i1)?;
            self.consume(i0..i1)?;
            self.next = i1;
        }
        Ok(())
    }

    /// Step 1 for `D`-rows `rows` from the IR window starting at grid row `y0`, into `out`.
    fn resize_chunk(
        &mut self,
        tir: FrameRef<'_, u8>,
        y0: usize,
        rows: core::ops::Range<usize>,
    ) -> Result<(), Error> {
        let (w, d, c) = (self.grid.0, self.d, rows.len());
        let first = self.first_row(rows.start);
        let last = self.last_row(rows.end - 1);
        let rel = first.checked_sub(y0).ok_or(Error::InvalidParameter { name: "rows" })?;
        let span = last + 1 - first;
        let window = tir.sub_rect(0, rel, w, span)?;
        let dst = FrameMut::new(self.out.get_mut(..d * c).unwrap_or(&mut []), d, c)?;
        match (&self.taps_v, &self.taps_h) {
            (None, None) => {
                let mut dst = dst;
                for (o, r) in dst.rows_mut().zip(window.rows()) {
                    for (o, &v) in o.iter_mut().zip(r) {
                        *o = i32::from(v);
                    }
                }
            }
            (None, Some(th)) => imresize::pass_rows(window, th, dst, Output::U8),
            (Some(tv), None) => {
                let taps = tv.window(rows, first, self.chunk_taps)?;
                imresize::pass_cols(window, &taps, dst, Output::U8);
            }
            (Some(tv), Some(th)) if w > self.grid.1 => {
                // The wider side first, as the whole-frame resize does: rows, then columns.
                let tmp = FrameMut::new(self.tmp.get_mut(..d * span).unwrap_or(&mut []), d, span)?;
                imresize::pass_rows(window, th, tmp, Output::U8);
                let taps = tv.window(rows, first, self.chunk_taps)?;
                imresize::pass_cols(
                    FrameRef::new(self.tmp.get(..d * span).unwrap_or(&[]), d, span)?,
                    &taps,
                    dst,
                    Output::U8,
                );
            }
            (Some(tv), Some(th)) => {
                let taps = tv.window(rows, first, self.chunk_taps)?;
                let tmp = FrameMut::new(self.tmp.get_mut(..w * c).unwrap_or(&mut []), w, c)?;
                imresize::pass_cols(window, &taps, tmp, Output::U8);
                let tmp = FrameRef::new(self.tmp.get(..w * c).unwrap_or(&[]), w, c)?;
                imresize::pass_rows_u8_range(tmp, th, dst);
            }
        }
        Ok(())
    }

    /// The quadtree ranges and the erosion of `D`-rows `rows` (now in `out`).
    fn consume(&mut self, rows: core::ops::Range<usize>) -> Result<(), Error> {
        let d = self.d;
        let size = usize::from(self.params.erode_size).max(1);
        for (k, i) in rows.enumerate() {
            let row = self.out.get(k * d..(k + 1) * d).ok_or(Error::InvalidParameter { name: "rows" })?;
            self.ranges.add_row(i, row)?;
            let slot = self
                .ring
                .get_mut((i % size) * d..(i % size + 1) * d)
                .ok_or(Error::InvalidParameter { name: "rows" })?;
            for (s, &v) in slot.iter_mut().zip(row) {
                *s = v;
            }
            let after = size - size.div_ceil(2).max(1);
            if let Some(r) = i.checked_sub(after) {
                self.erode_row(r, i)?;
            }
        }
        Ok(())
    }

    /// The erosion at the crossings of candidate row `r` (when it is one), from the ring's rows
    /// up to `last`.
    fn erode_row(&mut self, r: usize, last: usize) -> Result<(), Error> {
        if !self.lines.marked.get(r).copied().unwrap_or(false) {
            return Ok(());
        }
        let (d, size) = (self.d, usize::from(self.params.erode_size).max(1));
        let origin = size.div_ceil(2).max(1);
        let (before, after) = (origin - 1, size - origin);
        let ring: &[i32] = self.ring;
        let row = |y: usize| ring.get((y % size) * d..(y % size + 1) * d).unwrap_or(&[]);
        let base = self.lines.index(r) * self.lines.count;
        let (lines, crossings) = (&self.lines, &mut *self.crossings);
        erode::min_at_row(
            row,
            r.saturating_sub(before)..=last,
            lines.marked.get(..d).unwrap_or(&[]),
            before,
            after,
            self.acc,
            |x, v| {
                if let Some(c) = crossings.get_mut(base + lines.index(x)) {
                    *c = v;
                }
            },
        );
        Ok(())
    }

    /// After the last strip: the erosion of the last rows and the quadtree.
    pub(crate) fn finish(mut self) -> Result<Tree<'c>, Error> {
        if self.next != self.d {
            return Err(Error::InvalidParameter { name: "rows" });
        }
        let d = self.d;
        let size = usize::from(self.params.erode_size).max(1);
        let after = size - size.div_ceil(2).max(1);
        for r in d.saturating_sub(after)..d {
            self.erode_row(r, d - 1)?;
        }
        let leaves = self.ranges.leaves(i32::from(self.params.split_threshold))?;
        Ok(Tree {
            leaves,
            lines: self.lines,
            crossings: self.crossings,
            hist_ir: self.hist_ir,
            hist_vis: self.hist_vis,
        })
    }
}

impl Tree<'_> {
    /// The erosion minimum at control point `(r, c)` (both candidate lines).
    fn control(&self, r: usize, c: usize) -> i32 {
        let i = self.lines.index(r) * self.lines.count + self.lines.index(c);
        self.crossings.get(i).copied().unwrap_or(0)
    }
}

/// Steps 4–6 for a few grid rows at a time: the Bézier rows the column taps read (each
/// rendered once, in a buffer that slides down the grid), then the combined
/// resize-and-Gaussian passes.
struct Background<'t, 'r> {
    tree: &'t Tree<'t>,
    d: usize,
    w: usize,
    taps_v: Taps<'r>,
    /// `None`: a square grid, whose rows take the column table.
    taps_h: Option<Taps<'r>>,
    chunk_taps: &'r mut [i32],
    bez: &'r mut [i32],
    /// The `D`-rows in `bez`.
    bez_rows: core::ops::Range<usize>,
    col: &'r mut [i32],
}

impl<'t, 'r> Background<'t, 'r> {
    /// The background of grid rows `rows` (at most the chunk) into `out` (`W` wide).
    fn rows(&mut self, rows: core::ops::Range<usize>, out: FrameMut<'_, i32>) -> Result<(), Error> {
        let (d, c) = (self.d, rows.len());
        let run = self.taps_v.taps();
        let bad = Error::InvalidParameter { name: "rows" };
        let first = self.taps_v.start(rows.start).ok_or(bad)?;
        let end = self.taps_v.start(rows.end - 1).ok_or(bad)? + run;
        // Slide: keep the rows already rendered, render the rest.
        let kept = match self.bez_rows.start <= first {
            true => self.bez_rows.end.saturating_sub(first).min(end - first),
            false => 0,
        };
        let capacity = self.bez.len();
        let from = (first - self.bez_rows.start.min(first)) * d;
        // Toward the front: a forward copy never reads what it already overwrote; apart (the
        // usual case) the halves are two slices and the copy is a `memcpy`.
        let n = if from == 0 { 0 } else { kept * d };
        match self.bez.split_at_mut_checked(from) {
            Some((head, tail)) if from >= n => {
                for (o, &v) in head.iter_mut().zip(tail.iter().take(n)) {
                    *o = v;
                }
            }
            _ => {
                for i in 0..n {
                    if let Some(&v) = self.bez.get(from + i)
                        && let Some(o) = self.bez.get_mut(i)
                    {
                        *o = v;
                    }
                }
            }
        }
        let fresh = first + kept..end;
        let needed = (end - first) * d;
        let dst = self.bez.get_mut(kept * d..needed).ok_or(Error::ScratchTooSmall { needed, capacity })?;
        let tree = self.tree;
        if !fresh.is_empty() {
            let dst = FrameMut::new(dst, d, fresh.len())?;
            bezier::render_rows(&tree.leaves, d, |r, c| tree.control(r, c), fresh.start, dst)?;
        }
        self.bez_rows = first..end;
        let bez = FrameRef::new(self.bez.get(..(end - first) * d).unwrap_or(&[]), d, end - first)?;
        let taps = self.taps_v.window(rows, first, self.chunk_taps)?;
        let col = FrameMut::new(self.col.get_mut(..d * c).unwrap_or(&mut []), d, c)?;
        imresize::pass_cols(bez, &taps, col, Output::Same);
        let col = FrameRef::new(self.col.get(..d * c).unwrap_or(&[]), d, c)?;
        let taps_h = self.taps_h.as_ref().unwrap_or(&self.taps_v);
        if taps_h.outputs() != self.w {
            return Err(bad);
        }
        imresize::pass_rows(col, taps_h, out, Output::Same);
        Ok(())
    }
}

/// Pass 2: `R` into the output frame and the `k` largest keys.
pub(crate) struct Keys<'t, 'r> {
    background: Background<'t, 'r>,
    bg: &'r mut [i32],
    chunk: usize,
    classes: Classes,
    top: TopK<'r>,
    /// The top-k threshold in 32-bit form, rebuilt when it rises.
    gate: Gate,
    words: usize,
}

impl<'t, 'r> Keys<'t, 'r> {
    /// Pass 2's state in `work` (free after pass 1) for the entropy ratio `ratio_q24` and the
    /// `k` of step 10.
    pub(crate) fn new(
        tree: &'t Tree<'t>,
        grid: (usize, usize),
        params: &IfevipParams,
        ratio_q24: i64,
        k: u64,
        work: &'r mut [i32],
    ) -> Result<Self, Error> {
        let (w, h) = grid;
        let d = usize::from(params.quad_norm_dim);
        let total = work.len();
        let (weights, n) = gauss::weights(usize::from(params.gauss_size), u32::from(params.gauss_size), 2)?;
        let weights = weights.get(..n).unwrap_or(&[]);
        let (taps_v, rest) = imresize::build_smoothed_front(d, h, weights, work)?;
        let (taps_h, mut rest) = if w == h {
            (None, rest)
        } else {
            let (t, rest) = imresize::build_smoothed_front(d, w, weights, rest)?;
            (Some(t), rest)
        };
        let (stride, run) = (taps_v.taps() + 2, taps_v.taps());
        // D-rows a chunk of c grid rows reads.
        let span = |c: usize| {
            (0..h.saturating_sub(c - 1))
                .map(|g| {
                    let (a, b) = (taps_v.start(g).unwrap_or(0), taps_v.start(g + c - 1).unwrap_or(0));
                    b + run - a
                })
                .max()
                .unwrap_or(run)
        };
        let k = usize::try_from(k).map_err(|_| Error::InvalidParameter { name: "top_ppm" })?;
        // The top-k buffer: room for twice k keys (a cut per k kept pixels at worst) or 4096,
        // if the words hold that beside a one-row chunk; else whatever they hold above k.
        let words = |c: usize| c * stride + span(c) * d + c * d + c * w;
        let least = TopK::WORDS_PER_KEY * (k + 1);
        let roomy = TopK::WORDS_PER_KEY * (2 * k + 2).max(4096);
        let top_words = roomy.min(rest.len().saturating_sub(words(1))).max(least);
        let avail = rest.len().saturating_sub(top_words);
        let chunk = (1..=MAX_CHUNK.min(h))
            .rev()
            .find(|&c| words(c) <= avail)
            .ok_or(Error::ScratchTooSmall { needed: words(1) + least, capacity: rest.len() })?;
        let chunk_taps = take(&mut rest, chunk * stride)?;
        let bez = take(&mut rest, span(chunk) * d)?;
        let col = take(&mut rest, chunk * d)?;
        let bg = take(&mut rest, chunk * w)?;
        let top = TopK::new(take(&mut rest, top_words)?, k)?;
        let classes = Classes::new(ratio_q24);
        let words = total - rest.len();
        Ok(Self {
            background: Background { tree, d, w, taps_v, taps_h, chunk_taps, bez, bez_rows: 0..0, col },
            bg,
            chunk,
            gate: Gate::new(&classes, top.threshold()),
            classes,
            top,
            words,
        })
    }

    /// Work words this pass takes besides the crossings.
    pub(crate) fn words(&self) -> usize {
        self.words
    }

    /// One strip: the bands on grid rows `y0 ..`, `strip` the rows to do; `out` holds the
    /// strip's rows and receives `R`.
    pub(crate) fn add_rows(
        &mut self,
        vis: FrameRef<'_, u8>,
        tir: FrameRef<'_, u8>,
        y0: usize,
        strip: core::ops::Range<usize>,
        mut out: FrameMut<'_, u8>,
    ) -> Result<(), Error> {
        let w = self.background.w;
        let bad = Error::InvalidParameter { name: "rows" };
        let mut g0 = strip.start;
        while g0 < strip.end {
            let g1 = (g0 + self.chunk).min(strip.end);
            let c = g1 - g0;
            let bg = FrameMut::new(self.bg.get_mut(..w * c).unwrap_or(&mut []), w, c)?;
            self.background.rows(g0..g1, bg)?;
            for (k, g) in (g0..g1).enumerate() {
                let i = g.checked_sub(y0).filter(|&i| i < vis.height() && i < tir.height()).ok_or(bad)?;
                let o = g.checked_sub(strip.start).filter(|&o| o < out.height()).ok_or(bad)?;
                let bg = self.bg.get(k * w..(k + 1) * w).unwrap_or(&[]);
                let (classes, top, gate) = (&self.classes, &mut self.top, &mut self.gate);
                for (((o, &v), &t), &b) in out.row_mut(o).iter_mut().zip(vis.row(i)).zip(tir.row(i)).zip(bg) {
                    let r = (i32::from(t) - bg_u8(b)).max(0);
                    *o = r as u8;
                    if gate.passes(classes, v, t, r) {
                        let threshold = top.threshold();
                        top.push(classes.key_of(v, t, r));
                        if top.threshold() != threshold {
                            *gate = Gate::new(classes, top.threshold());
                        }
                    }
                }
            }
            g0 = g1;
        }
        Ok(())
    }

    /// The sum (Q24) of the `k` largest keys of every pixel added.
    pub(crate) fn top_sum(&self) -> i128 {
        self.top.sum()
    }
}

/// Pass 3 for one strip: `F` from the bands (grid rows `y0 ..`) and the `R` bytes pass 2 left
/// in `out` (the strip's rows), in place. Returns whether some output saturated.
pub(crate) fn output_rows(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    y0: usize,
    strip: core::ops::Range<usize>,
    mut out: FrameMut<'_, u8>,
    tables: &super::GainTables,
) -> Result<bool, Error> {
    let rel = strip.start.checked_sub(y0).ok_or(Error::InvalidParameter { name: "rows" })?;
    if rel + out.height() > vis.height().min(tir.height()) {
        return Err(Error::InvalidParameter { name: "rows" });
    }
    let mut saturated = false;
    for (i, o) in out.rows_mut().enumerate() {
        saturated |= tables.row_in_place(o, vis.row(rel + i), tir.row(rel + i));
    }
    Ok(saturated)
}
