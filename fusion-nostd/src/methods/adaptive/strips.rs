//! The adaptive method's strip form ([`crate::strips`]) for a blend or pass-through frame: one
//! pass, the frame's decision taken first by the caller from the scene analysis of the input
//! frames (a [`Decision::Adf`] frame runs ADF's own strip form instead); rows `y − r … y + r`
//! of both bands (the binomial's `y ± 1` inside), so a halo of `max(n/2, 1)` rows and two rows
//! of column sums.

use super::{AdaptiveParams, Decision, fuse_adaptive_rows, work_words};
use crate::Error;
use crate::methods::Guards;
use crate::strips::{StripForm, StripPlan, StripRun, Window};

/// The adaptive method with the frame's decision (not [`Decision::Adf`]: that one is an
/// [`Error::InvalidParameter`] from the row form).
pub(crate) struct Decided {
    /// The method's parameters.
    pub(crate) params: AdaptiveParams,
    /// The frame's decision.
    pub(crate) decision: Decision,
}

impl StripForm for Decided {
    fn plan(&self, (w, _): (usize, usize)) -> StripPlan {
        StripPlan { halo: self.params.halo(), passes: 1, work_words: work_words(w), wraps: false }
    }

    fn run(&self, s: &mut StripRun<'_, '_, '_>) -> Result<Guards, Error> {
        let (w, h) = s.walk.grid;
        let Decided { params: p, decision } = self;
        let (cv, ct) =
            s.work.split_at_mut_checked(w).ok_or(Error::ScratchTooSmall { needed: 2 * w, capacity: 0 })?;
        let out = &mut *s.out;
        let mut guards = Guards::NONE;
        s.walk.run(s.band, s.report, |win| {
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
                *decision,
                [&mut *cv, &mut *ct],
            )?;
            Ok(vis_w.height())
        })?;
        Ok(guards)
    }
}
