//! TSIFSD's strip form ([`crate::strips`]): one pass. The flight kernel starts at the strip's
//! first row (column sums of the mean window and a ring of lane words); the classic form slides
//! the circular window's column sums down the strip and reads the rows it wraps to from the
//! frame's other edge. The kernels read rows `y − r … y + r` for output row `y` (the Scharr or
//! median rows `y ± 1` lie inside for `r ≥ 1`): a halo of `max(r, 1)` rows keeps every output
//! row exact.

use super::{TsifsdParams, classic_words, flight_words, fuse_tsifsd_classic_rows, fuse_tsifsd_flight_rows};
use crate::Error;
use crate::methods::{Guards, Variant};
use crate::strips::{StripForm, StripPlan, StripRun, Window};

impl StripForm for TsifsdParams {
    fn plan(&self, (w, _): (usize, usize)) -> StripPlan {
        let r = usize::from(self.mean_size / 2);
        let (work_words, wraps) = match self.variant {
            Variant::Flight => (flight_words(w, r), false),
            Variant::Classic => (classic_words(w), true),
        };
        StripPlan { halo: r.max(1), passes: 1, work_words, wraps }
    }

    fn run(&self, s: &mut StripRun<'_, '_, '_>) -> Result<Guards, Error> {
        let grid = s.walk.grid;
        let w = grid.0;
        let (p, out, work) = (self, &mut *s.out, &mut *s.work);
        let mut guards = Guards::NONE;
        match self.variant {
            Variant::Flight => s.walk.run(s.band, s.report, |win| {
                let Window { vis: vis_w, tir: tir_w, y0, strip, .. } = win;
                let rows = out.sub_rect_mut(0, strip.start, w, strip.len())?;
                guards |= fuse_tsifsd_flight_rows(vis_w, tir_w, rows, strip.start - y0, p, work)?;
                Ok(vis_w.height())
            })?,
            Variant::Classic => s.walk.run(s.band, s.report, |win| {
                let rows = out.sub_rect_mut(0, win.strip.start, w, win.strip.len())?;
                let vis_row = |y| win.vis_row(y);
                let tir_row = |y| win.tir_row(y);
                guards |= fuse_tsifsd_classic_rows(vis_row, tir_row, grid, win.strip.clone(), rows, p, work)?;
                Ok(win.vis.height() + win.wrapped)
            })?,
        }
        Ok(guards)
    }
}
