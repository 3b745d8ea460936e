//! ADF's strip form ([`crate::strips`]): the diffusion's row pipeline of both bands (all
//! iterations in one group) with a halo of `iterations` rows. The KL weights come from the
//! covariance of the whole frame's detail layers, which no strip knows alone: the first pass
//! diffuses every strip and adds its rows to the exact integer sums (the order of addition
//! does not change them), the second diffuses again and writes the output.

use super::{AdfParams, Covariance, Fusion, diffuse_rows, stream_words};
use crate::Error;
use crate::methods::Guards;
use crate::strips::{StripForm, StripPlan, StripRun, Window};

impl StripForm for AdfParams {
    fn plan(&self, (w, _): (usize, usize)) -> StripPlan {
        StripPlan {
            halo: usize::from(self.iterations),
            passes: 2,
            work_words: stream_words(w, self),
            wraps: false,
        }
    }

    fn run(&self, s: &mut StripRun<'_, '_, '_>) -> Result<Guards, Error> {
        let (w, h) = s.walk.grid;
        let p = self;
        // In a sequence with weights carried from the previous frame: one pass.
        let carried = s.link.as_ref().map(|l| l.carried(p, w * h));
        if let Some(Ok(fusion)) = carried {
            return one_pass(p, s, fusion);
        }
        let (out, work) = (&mut *s.out, &mut *s.work);
        let mut cov = Covariance::new();
        s.walk.run(s.band, s.report, |win| {
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
        let mut guards = fusion.guards;
        let mut saturated = false;
        s.walk.run(s.band, s.report, |win| {
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
        if let (Some(link), Some(Err(restart))) = (s.link.as_mut(), carried) {
            link.record(p, w * h, Err(restart), &fusion, &fusion);
        }
        if saturated {
            guards |= Guards::OUTPUT_SATURATED;
        }
        Ok(guards)
    }
}

/// The one-pass form of a sequence frame: each strip diffused once, its kept rows fused with
/// the carried rule `fusion` and added to the frame's own covariance (carried to the next
/// frame).
fn one_pass(p: &AdfParams, s: &mut StripRun<'_, '_, '_>, fusion: Fusion) -> Result<Guards, Error> {
    let (w, h) = s.walk.grid;
    let (out, work) = (&mut *s.out, &mut *s.work);
    let mut cov = Covariance::new();
    let mut saturated = false;
    s.walk.run(s.band, s.report, |win| {
        let Window { vis: vis_w, tir: tir_w, y0, strip, .. } = win;
        let keep = strip.start - y0..strip.end - y0;
        diffuse_rows(vis_w, tir_w, p, work, keep.end, |y, a| {
            if keep.contains(&y) {
                let (iv, it) = (vis_w.row(y), tir_w.row(y));
                cov.add_row(iv, it, a);
                saturated |= fusion.u8_row(iv, it, a, out.row_mut(y0 + y));
            }
        })?;
        Ok(vis_w.height())
    })?;
    s.report.passes = 1;
    let own = cov.weights(w * h, p.variant);
    if let Some(link) = s.link.as_mut() {
        link.record(p, w * h, Ok(()), &fusion, &own);
    }
    Ok(if saturated { fusion.guards | Guards::OUTPUT_SATURATED } else { fusion.guards })
}
