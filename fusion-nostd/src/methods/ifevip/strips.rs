//! IFEVIP's strip form ([`crate::strips`]): three passes, since the quadtree, the gain (the
//! peak of the top 0.1 % of the keys) and the entropy ratio are global. Pass 1 gathers the
//! histograms and the tree (with the halo of the IR's vertical taps onto the quadtree grid),
//! pass 2 computes every pixel's `R` (written into the output frame, which nothing else needs
//! until pass 3) and keeps the exact top `k` keys, pass 3 writes `F` over `R`; passes 2 and 3
//! read the strip's own rows only (see [`super::stream`]).

use super::stream::{Analysis, Keys, Tree, crossing_words, output_rows};
use super::{EntropyRatio, GainTables, Gains, IfevipParams, top_k};
use crate::methods::Guards;
use crate::strips::{StripForm, StripPlan, StripReport, StripRun, Walk};
use crate::{Error, FrameMut};

impl StripForm for IfevipParams {
    fn plan(&self, grid: (usize, usize)) -> StripPlan {
        // The work words depend on the passes' tables and are checked by each pass.
        StripPlan { halo: Analysis::halo(grid, self), passes: 3, work_words: 0, wraps: false }
    }

    fn run(&self, s: &mut StripRun<'_, '_, '_>) -> Result<Guards, Error> {
        let ((used, mut guards), saturated) =
            fuse_ifevip_strips(s.walk, s.rest, s.band, s.work, s.out, self, s.report)?;
        s.report.work_words = used;
        if saturated {
            guards |= Guards::OUTPUT_SATURATED;
        }
        Ok(guards)
    }
}

/// IFEVIP's three passes (see `methods::ifevip::stream`): the analysis walk with the
/// step-1 halo, then keys and output over halo-free strips (`rest`). Returns the work words
/// used and the guards, and whether an output saturated. Each pass is a function of its own
/// (never inlined), so their state — a few KiB each — never shares one stack frame.
fn fuse_ifevip_strips(
    walk: &Walk<'_>,
    rest: &Walk<'_>,
    band: &mut [u8],
    work: &mut [i32],
    out: &mut FrameMut<'_, u8>,
    p: &IfevipParams,
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
    p: &IfevipParams,
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
    p: &IfevipParams,
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
