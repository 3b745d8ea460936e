//! The row pipeline (temporal blocking: [`RowPipeline::run_group`]) and the diffusion's
//! entries: [`diffuse_pair`] (a whole plane, all iterations in groups as the work memory
//! allows, or plain Jacobi sweeps for frames too small for one stage), [`diffuse_rows`] (the
//! streaming form, all iterations in one group, for the strip pipeline) and the work it needs,
//! [`stream_words`].

use super::super::AdfParams;
use super::flux::{TABLE_WORDS, Table, table_view};
use super::pack::{Band, fill_row};
use super::row::Diffusion;
use crate::filters::border::Border;
use crate::{Error, FrameRef};

/// Rows of work memory per pipeline stage, each `w + 2` words: two state rows and the north
/// fluxes.
const STAGE_ROWS: usize = 3;

/// Where the first stage of a pipeline group reads its rows.
#[derive(Clone, Copy)]
enum Input<'a> {
    /// The two input bands (first group).
    Bands(Band<'a>, Band<'a>),
    /// The base layers themselves (later groups, read before being overwritten).
    Layers,
}

/// The base layers of both bands, packed Q7 words: a whole plane (`w·h`, row `y` at `y·w`), or
/// one row that every finished row replaces (the streaming form).
struct Layers<'s> {
    a: &'s mut [i32],
    whole: bool,
}

impl Layers<'_> {
    /// Where row `y` (`w` words) is.
    fn range(&self, y: usize, w: usize) -> core::ops::Range<usize> {
        if self.whole { y * w..y * w + w } else { 0..w }
    }

    fn row_mut(&mut self, y: usize, w: usize) -> &mut [i32] {
        let r = self.range(y, w);
        self.a.get_mut(r).unwrap_or(&mut [])
    }

    /// Row `y` (the last one finished, in the streaming form).
    fn row(&self, y: usize, w: usize) -> &[i32] {
        self.a.get(self.range(y, w)).unwrap_or(&[])
    }
}

/// Writes the one-column pads of a padded row (`row[0]`, `row[w+1]`) by the border rule.
#[inline]
fn set_pads(row: &mut [i32], border: Border) {
    let n = row.len();
    let (left, right) = match border {
        Border::Replicate => (row.get(1).copied(), row.get(n.wrapping_sub(2)).copied()),
        _ => (Some(0), Some(0)),
    };
    if let (Some(l), Some(first)) = (left, row.first_mut()) {
        *first = l;
    }
    if let (Some(r), Some(last)) = (right, row.last_mut()) {
        *last = r;
    }
}

/// One stage's memory: the two state rows (row `j` in slot `j % 2`) and the north sums of
/// the oldest row not yet updated.
fn stage_rows(mem: &mut [i32], stride: usize) -> Option<[&mut [i32]; STAGE_ROWS]> {
    let mut rows = mem.chunks_exact_mut(stride.max(1));
    Some([rows.next()?, rows.next()?, rows.next()?])
}

/// Work words of a pipeline group of `stages` iterations on `w`-wide rows: the stages' rows.
pub(super) fn group_words(w: usize, stages: usize) -> usize {
    stages * STAGE_ROWS * (w + 2)
}

/// A running diffusion: the constants, the flux table if one is used, the frame size.
pub(super) struct RowPipeline<'t> {
    d: Diffusion,
    table: Option<&'t [i16]>,
    size: (usize, usize),
}

impl<'t> RowPipeline<'t> {
    /// Splits the flux table off the front of `work` when the row loops read one and it fits
    /// (with at least `min_rest` words left), tabulates it, and returns the rest of `work`.
    pub(super) fn new<'w: 't>(
        d: Diffusion,
        size: (usize, usize),
        work: &'w mut [i32],
        min_rest: usize,
    ) -> (Self, &'w mut [i32]) {
        if d.wants_table() && work.len() >= TABLE_WORDS + min_rest {
            let Some((tw, rest)) = work.split_at_mut_checked(TABLE_WORDS) else {
                return (Self { d, table: None, size }, &mut []);
            };
            let table = table_view(tw).map(|t| {
                d.fx.tabulate(t);
                &*t
            });
            return (Self { d, table, size }, rest);
        }
        (Self { d, table: None, size }, work)
    }

    /// Runs `stages` Jacobi iterations in one pass down the frame (temporal blocking): stage
    /// `s` keeps the last two rows of iterate `s` and the north sums of their pairs, and turns
    /// each new row of iterate `s` into the previous row of iterate `s + 1`, which goes
    /// straight into stage `s + 1` (the last stage writes `layers`). All the work rows live
    /// in `mem` ([`group_words`]), so the frame is read and written
    /// once per group of iterations and the working set stays in cache.
    fn run_group(&self, input: Input<'_>, layers: &mut Layers<'_>, mem: &mut [i32], stages: usize) {
        let (w, h) = self.size;
        let Some(mem) = mem.get_mut(..group_words(w, stages)) else { return };
        mem.fill(0);
        for t in 0..h + stages {
            self.step(t, input, layers, mem, stages);
        }
    }

    /// Step `t` (`0 .. h + stages`) of a pipeline group: input row `t` enters stage 0 and
    /// every stage passes on the row it can now finish; the last stage writes row
    /// `t − stages` (when `t ≥ stages`) to `layers`. `mem` holds the group's zeroed work
    /// ([`group_words`]) and is carried from step to step.
    fn step(&self, t: usize, input: Input<'_>, layers: &mut Layers<'_>, mem: &mut [i32], stages: usize) {
        let (w, h) = self.size;
        let stride = w + 2;
        let per_stage = STAGE_ROWS * stride;
        let Some(mem) = mem.get_mut(..stages * per_stage) else { return };
        let border = self.d.border;
        let mut chunks = mem.chunks_exact_mut(per_stage.max(1));
        let mut cur = chunks.next();
        // The input row t enters stage 0.
        if t < h
            && let Some([s0, s1, _]) = cur.as_deref_mut().and_then(|m| stage_rows(m, stride))
        {
            let slot = if t.is_multiple_of(2) { s0 } else { s1 };
            let dst = slot.get_mut(1..=w).unwrap_or(&mut []);
            match input {
                Input::Bands(vis, tir) => fill_row(dst, &vis, &tir, t),
                Input::Layers => dst.iter_mut().zip(layers.row(t, w)).for_each(|(d, &v)| *d = v),
            }
            set_pads(slot, border);
        }
        for s in 0..stages {
            let mut next = chunks.next();
            // Row j of iterate s has just arrived at stage s (j = h: the bottom pad).
            let Some(j) = t.checked_sub(s) else { break };
            if j <= h
                && let Some([s0, s1, north]) = cur.as_deref_mut().and_then(|m| stage_rows(m, stride))
            {
                let (older, newer) = if j % 2 == 0 { (s1, s0) } else { (s0, s1) };
                if j == 0 {
                    // The pairs between the top pad row and row 0.
                    let top: &[i32] = match border {
                        Border::Replicate => newer,
                        _ => {
                            older.fill(0);
                            older
                        }
                    };
                    match self.table {
                        Some(tb) => self.d.top_north(&Table(tb), top, newer, north),
                        None => self.d.top_north(&self.d.fx, top, newer, north),
                    }
                } else {
                    // Output row j − 1 of iterate s + 1, from rows j − 1 (`older`) and j
                    // (`newer`), or the bottom pad row when j = h.
                    let (p, q): (&[i32], &[i32]) = if j < h {
                        (older, newer)
                    } else {
                        // Row h − 1 is `older`; the free slot becomes the zero pad row.
                        match border {
                            Border::Replicate => (older, older),
                            _ => {
                                newer.fill(0);
                                (older, newer)
                            }
                        }
                    };
                    let y = j - 1;
                    match next.as_deref_mut().and_then(|m| stage_rows(m, stride)) {
                        Some([n0, n1, _]) => {
                            let slot = if y % 2 == 0 { n0 } else { n1 };
                            self.d.row(self.table, p, q, north, slot.get_mut(1..=w).unwrap_or(&mut []));
                            set_pads(slot, border);
                        }
                        None => self.d.row(self.table, p, q, north, layers.row_mut(y, w)),
                    }
                }
            }
            cur = next.take();
        }
    }

    /// Plain Jacobi sweeps (8 fluxes per pixel) between `state` and `spare` (frames too small
    /// for one pipeline stage); the result ends in `state`.
    pub(super) fn sweeps(
        &self,
        vis: Band<'_>,
        tir: Band<'_>,
        state: &mut [i32],
        spare: &mut [i32],
        iterations: u16,
    ) {
        let (w, h) = self.size;
        let n = w * h;
        let (Some(a), Some(b)) = (state.get_mut(..n), spare.get_mut(..n)) else { return };
        for (y, row) in a.chunks_exact_mut(w.max(1)).enumerate().take(h) {
            fill_row(row, &vis, &tir, y);
        }
        for i in 0..iterations {
            let (src, dst) = if i % 2 == 0 { (&*a, &mut *b) } else { (&*b, &mut *a) };
            // (Sweeps run only when not even one stage fits, so no table was taken either.)
            self.d.iterate(&self.d.fx, src, dst, w);
        }
        if iterations % 2 == 1 {
            a.iter_mut().zip(b.iter()).for_each(|(a, &b)| *a = b);
        }
    }
}

/// Work words [`diffuse_rows`] needs for `w`-wide frames: the flux table, the row pipeline of
/// all iterations and the output row — independent of the height (64 572 words, 252.2 KiB,
/// at W = 1024 with 10 iterations).
pub(crate) fn stream_words(w: usize, params: &AdfParams) -> usize {
    TABLE_WORDS + group_words(w, usize::from(params.iterations)) + w
}

/// The size the bands share (a [`Band::Level`] takes any size).
fn band_size(vis: &Band<'_>, tir: &Band<'_>, size: (usize, usize)) -> Result<(), Error> {
    for b in [vis, tir] {
        if let Band::Frame(f) = b
            && f.size() != size
        {
            return Err(Error::SizeMismatch { expected: size, got: f.size() });
        }
    }
    Ok(())
}

/// Diffuses both bands with `params.iterations` Perona–Malik steps into the base layers,
/// `state` (`w·h` words: pixel `(x, y)` at `y·w + x`, VIS in the low and TIR in the high 16
/// bits, Q7), using `work` as work memory: the flux table and the row pipeline's rows. With
/// 32 768 (the table) `+ 3·(w + 2)·iterations` words all iterations run in one pass down the
/// frame; with less, in groups, and without the table when it does not fit; a frame too small
/// for one stage (fewer than about 3 rows) takes plain Jacobi sweeps with `work` (at least
/// `w·h`) as the second plane — the same bits every way. Step 1 of ADF, public for tests and
/// benches.
pub fn diffuse_pair(
    vis: Band<'_>,
    tir: Band<'_>,
    size: (usize, usize),
    params: &AdfParams,
    state: &mut [i32],
    work: &mut [i32],
) -> Result<(), Error> {
    params.validate()?;
    diffuse_with(Diffusion::new(params), vis, tir, size, params.iterations, state, work)
}

/// [`diffuse_pair`] with the given constants (the tests switch the row loops).
pub(super) fn diffuse_with(
    d: Diffusion,
    vis: Band<'_>,
    tir: Band<'_>,
    size: (usize, usize),
    iterations: u16,
    state: &mut [i32],
    work: &mut [i32],
) -> Result<(), Error> {
    band_size(&vis, &tir, size)?;
    let (w, h) = size;
    let pixels = w * h;
    let capacity = state.len();
    let state = state.get_mut(..pixels).ok_or(Error::ScratchTooSmall { needed: pixels, capacity })?;
    let (pipe, mem) = RowPipeline::new(d, size, work, group_words(w, 1));
    let stages = usize::from(iterations);
    let group = stages.min(mem.len().checked_div(STAGE_ROWS * (w + 2)).unwrap_or(0));
    if group == 0 {
        let capacity = mem.len();
        if capacity < pixels {
            return Err(Error::ScratchTooSmall { needed: pixels, capacity });
        }
        pipe.sweeps(vis, tir, state, mem, iterations);
        return Ok(());
    }
    let mut layers = Layers { a: state, whole: true };
    let mut done = 0;
    let mut input = Input::Bands(vis, tir);
    while done < stages {
        let n = group.min(stages - done);
        pipe.run_group(input, &mut layers, mem, n);
        input = Input::Layers;
        done += n;
    }
    Ok(())
}

/// Diffuses both bands together through one row pipeline (all iterations in one group, the
/// streaming form of [`diffuse_pair`], the same bits) and hands every row `y < until` of the
/// packed base layers to `sink(y, row)`, top to bottom; rows from `until` on are not finished
/// (row `y` needs the input only up to row `y + iterations`). Memory: `work`,
/// [`stream_words`] words; no plane. The strip pipeline ([`crate::strips`]) runs it on windows.
pub(crate) fn diffuse_rows(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    params: &AdfParams,
    work: &mut [i32],
    until: usize,
    mut sink: impl FnMut(usize, &[i32]),
) -> Result<(), Error> {
    params.validate()?;
    let size = vis.size();
    band_size(&Band::Frame(vis), &Band::Frame(tir), size)?;
    let (w, h) = size;
    let stages = usize::from(params.iterations);
    let needed = stream_words(w, params);
    let capacity = work.len();
    let work = work.get_mut(..needed).ok_or(Error::ScratchTooSmall { needed, capacity })?;
    let (row, work) = work.split_at_mut_checked(w).ok_or(Error::ScratchTooSmall { needed, capacity })?;
    let (pipe, mem) = RowPipeline::new(Diffusion::new(params), size, work, group_words(w, stages));
    let mem = mem.get_mut(..group_words(w, stages)).ok_or(Error::ScratchTooSmall { needed, capacity })?;
    mem.fill(0);
    let mut layers = Layers { a: row, whole: false };
    let input = Input::Bands(Band::Frame(vis), Band::Frame(tir));
    for t in 0..until.min(h) + stages {
        pipe.step(t, input, &mut layers, mem, stages);
        if let Some(y) = t.checked_sub(stages) {
            sink(y, layers.row(y, w));
        }
    }
    Ok(())
}
