//! The adaptive method's strip form ([`crate::strips`]): one pass, the frame's decision taken
//! first from the scene analysis of the input frames; rows `y − r … y + r` of both bands (the
//! binomial's `y ± 1` inside), so a halo of `max(n/2, 1)` rows and two rows of column sums.

use super::{AdaptiveParams, decide_frame, fuse_adaptive_rows, work_words};
use crate::Error;
use crate::methods::Guards;
use crate::strips::{StripForm, StripPlan, StripRun, Window};

impl StripForm for AdaptiveParams {
    fn plan(&self, (w, _): (usize, usize)) -> StripPlan {
        StripPlan { halo: self.halo(), passes: 1, work_words: work_words(w), wraps: false }
    }

    fn run(&self, s: &mut StripRun<'_, '_, '_>) -> Result<Guards, Error> {
        let (w, h) = s.walk.grid;
        let p = self;
        let decision = decide_frame(s.walk.vis, s.scene, p)?;
        let (cv, ct) =
            s.work.split_at_mut_checked(w).ok_or(Error::ScratchTooSmall { needed: 2 * w, capacity: 0 })?;
        let out = &mut *s.out;
        let mut guards = Guards::NONE;
        s.walk.run(s.band, s.report, |win| {
            let Window { vis: vis_w, tir: tir_w, y0, strip, .. } = win;
            let mut rows = out.sub_rect_mut(0, strip.start, w, strip.len())?;
            guards |=
                fuse_adaptive_rows(vis_w, tir_w, y0, h, strip, &mut rows, p, decision, [&mut *cv, &mut *ct])?;
            Ok(vis_w.height())
        })?;
        Ok(guards)
    }
}
