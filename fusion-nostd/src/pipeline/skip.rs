//! The scene-skipping planner: from the scene analysis, the window each method must run on
//! (with its halo, on both bands' grids), the plan per method and illumination, the fill
//! outside the window; see the module docs of [`crate::pipeline`], "Scene skipping".

use super::*;

/// The background rule: the value a method gives where both bands are flat at their levels,
/// `round(½(level_VIS + level_TIR))` — exact for ADF and TSIFSD on a constant pair (ADF: the
/// detail layers vanish, the base is the mean; TSIFSD: both saliencies vanish, the ½, ½ guard).
pub fn background_value(scene: &Scene) -> u8 {
    (u16::from(scene.vis.background) + u16::from(scene.tir.background)).div_ceil(2) as u8
}

/// What the skip plan decided for one frame.
pub(super) enum Plan {
    /// Fuse the whole frame (the reason, if analysis declined).
    Full(Option<Decline>),
    /// Nothing to fuse: the whole output is the background value (`exact`: that is the
    /// unskipped output too — ADF on an exactly constant pair).
    Empty { exact: bool },
    /// Fuse the window `computed`; `roi` inside it is exact.
    Window { computed: Rect, roi: Rect },
    /// ADF on an exactly constant background (or VIS taken constant): diffuse `computed`,
    /// covariance and output over `roi`; everything else is the background value, exactly.
    AdfWindow { computed: Rect, roi: Rect, vis_constant: bool },
    /// A frame-global method on the crop `computed` (`roi` grown by the halo) as a frame of its
    /// own; its output kept on `roi`, the background value everywhere else.
    Crop { computed: Rect, roi: Rect },
}

/// Grows a window to even corners (a 2× rescale's phase), clipped to the grid.
pub(super) fn align_even(r: Rect, (w, h): (usize, usize)) -> Rect {
    let hi = |v: usize, n: usize| if v >= n { n } else { (v.saturating_add(1) & !1).min(n) };
    Rect { x0: r.x0 & !1, y0: r.y0 & !1, x1: hi(r.x1, w), y1: hi(r.y1, h) }
}

/// What every plan needs to know about the frame besides the method.
struct Frame {
    grid: (usize, usize),
    /// A 2× rescale runs on the window: its corners must be even.
    rescale2: bool,
    /// Largest window worth skipping around, per cent of the frame.
    max_roi_percent: u8,
}

impl Frame {
    fn too_large(&self, r: &Rect) -> bool {
        // In u64: a usize product could saturate on the 32-bit targets and change the plan.
        r.area() as u64 * 100 > Rect::full(self.grid).area() as u64 * u64::from(self.max_roi_percent)
    }

    /// `r` grown by `halo` (even corners for a 2× rescale).
    fn grown(&self, r: Rect, halo: usize) -> Rect {
        let computed = r.grow(halo, self.grid);
        if self.rescale2 { align_even(computed, self.grid) } else { computed }
    }

    /// The crop plan around `target` (`None`: nothing to fuse); `check_size`: decline a window
    /// above `max_roi_percent` (the caller's own window is always honoured).
    fn crop(&self, target: Option<Rect>, halo: usize, check_size: bool) -> Plan {
        let Some(roi) = target.filter(|t| !t.is_empty()) else { return Plan::Empty { exact: false } };
        let computed = self.grown(roi, halo);
        if check_size && self.too_large(&computed) {
            return Plan::Full(Some(Decline::RoiTooLarge));
        }
        Plan::Crop { computed, roi }
    }

    /// The exact window of a local method around `target`; `circular`: TSIFSD classic, whose
    /// circular mean wraps at the frame's edges.
    fn local(&self, target: Option<Rect>, halo: usize, circular: bool, check_size: bool) -> Plan {
        let Some(target) = target.filter(|t| !t.is_empty()) else { return Plan::Empty { exact: false } };
        // Aligned first: the alignment can move an edge onto the frame's edge, and the
        // classic rule below must see where the window really ends.
        let mut computed = self.grown(target, halo);
        if circular {
            // Circular mean: a window touching a frame edge wraps to the opposite edge.
            if computed.x0 == 0 || computed.x1 == self.grid.0 {
                (computed.x0, computed.x1) = (0, self.grid.0);
            }
            if computed.y0 == 0 || computed.y1 == self.grid.1 {
                (computed.y0, computed.y1) = (0, self.grid.1);
            }
        }
        if check_size && self.too_large(&computed) {
            return Plan::Full(Some(Decline::RoiTooLarge));
        }
        Plan::Window { computed, roi: computed.shrink_inner(halo, self.grid) }
    }
}

pub(super) fn plan(
    scene: &Scene,
    pipeline: &FuseConfig,
    grid: (usize, usize),
    eclipse: bool,
    decision: Option<Decision>,
) -> Plan {
    let frame =
        Frame { grid, rescale2: scene.rescale_needed, max_roi_percent: pipeline.scene.max_roi_percent };
    let halo = pipeline.method.halo();
    let circular = matches!(&pipeline.method, Method::Tsifsd(p) if p.variant == crate::Variant::Classic);
    if let SkipPolicy::Window(w) = pipeline.skip {
        // The caller's window, whatever the analysis found.
        let w = Some(w.intersect(Rect::full(grid)));
        return if pipeline.method.frame_global() {
            frame.crop(w, halo, false)
        } else {
            frame.local(w, halo, circular, false)
        };
    }
    if let Some(d) = scene.decline {
        return Plan::Full(Some(d));
    }
    let noisy = scene.vis_blocks.is_some() || scene.tir_blocks.is_some();
    let target = if eclipse { scene.target_tir } else { scene.target };
    match &pipeline.method {
        // Noisy frames: the KL covariance sums the detail layers of the whole frame, which a
        // window cannot reproduce: the crop semantics.
        Method::Adf(_) if noisy => frame.crop(target, halo, true),
        Method::Adf(p) => {
            let vis_constant = eclipse;
            let varying = if vis_constant { scene.varying_tir } else { scene.varying };
            if p.variant == crate::Variant::Classic
                && (scene.tir.background != 0 || scene.vis.background != 0)
            {
                // Zero padding drains a non-zero constant background near the frame's edge:
                // its detail is not 0 there, so the rest of the frame is not provably silent.
                return Plan::Full(Some(Decline::GlobalStatistic));
            }
            let Some(varying) = varying else { return Plan::Empty { exact: !eclipse } };
            let roi = varying.grow(halo, grid);
            let computed = frame.grown(roi, halo);
            if frame.too_large(&computed) {
                let full = Rect::full(grid);
                return if vis_constant {
                    Plan::AdfWindow { computed: full, roi: full, vis_constant }
                } else {
                    Plan::Full(Some(if scene.varying == Some(full) || frame.too_large(&varying) {
                        Decline::GlobalStatistic
                    } else {
                        Decline::RoiTooLarge
                    }))
                };
            }
            Plan::AdfWindow { computed, roi, vis_constant }
        }
        Method::Ifevip(_) => frame.crop(target, halo, true),
        Method::Tsifsd(_) => frame.local(target, halo, circular, true),
        Method::Adaptive(_) => {
            // Local like TSIFSD flight (replicate borders); when the TIR frame passes through,
            // the window must hold its target alone.
            let target = if decision == Some(Decision::TirOnly) { scene.target_tir } else { target };
            frame.local(target, halo, false, true)
        }
    }
}

/// How a band's source frame relates to the fusion grid, for the rescale `filter`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BandRatio {
    /// Already on the grid: no rescale.
    Same,
    /// Exactly 2× up with the bicubic filter (the 2× kernel, window-exact).
    CubicUp2,
    /// Exactly 2× down with the area filter (the 2× kernel, window-exact).
    AreaDown2,
    /// Any other ratio or filter (the general path: the whole frame is rescaled).
    Other,
}

/// The [`BandRatio`] of a `src`-sized frame rescaled onto `grid` with `filter`.
pub(crate) fn band_ratio(src: (usize, usize), grid: (usize, usize), filter: Filter) -> BandRatio {
    if src == grid {
        BandRatio::Same
    } else if grid == (2 * src.0, 2 * src.1) && filter == Filter::Cubic {
        BandRatio::CubicUp2
    } else if src == (2 * grid.0, 2 * grid.1) && filter == Filter::Area {
        BandRatio::AreaDown2
    } else {
        BandRatio::Other
    }
}

/// What [`band_window`] produced.
pub(crate) struct BandWindow<'b> {
    /// The grid window `win` of the band.
    pub view: FrameRef<'b, u8>,
    /// Whether only the window (not the whole frame) was rescaled.
    pub window_only: bool,
    /// Band rows rescaled (0 when the source is already on the grid).
    pub rows: usize,
}

/// `src` brought onto the grid window `win`: a view of `src` itself when the sizes match, else
/// the window rescaled into `band`. Exact 2× ratios rescale only the source pixels the window's
/// taps read (plus the two-pixel bicubic margin; for 2× up the window must start on even
/// coordinates) — the same bits as the whole-frame rescale, since the phase is the same and no
/// tap crosses the cut; other ratios rescale the whole frame.
pub(crate) fn band_window<'b>(
    src: FrameRef<'b, u8>,
    grid: (usize, usize),
    win: Rect,
    filter: Filter,
    band: &'b mut [u8],
) -> Result<BandWindow<'b>, Error> {
    let (sw, sh) = src.size();
    let even = win.x0.is_multiple_of(2) && win.y0.is_multiple_of(2);
    let (view, window_only, rows) = match band_ratio((sw, sh), grid, filter) {
        BandRatio::Same => (src.sub_rect(win.x0, win.y0, win.width(), win.height())?, false, 0),
        BandRatio::CubicUp2 if even => {
            let sx0 = (win.x0 / 2).saturating_sub(2);
            let sy0 = (win.y0 / 2).saturating_sub(2);
            let sx1 = (win.x1.div_ceil(2) + 2).min(sw);
            let sy1 = (win.y1.div_ceil(2) + 2).min(sh);
            let (cw, ch) = (2 * (sx1 - sx0), 2 * (sy1 - sy0));
            let dst =
                band.get_mut(..cw * ch).ok_or(Error::ScratchTooSmall { needed: cw * ch, capacity: 0 })?;
            rescale(src.sub_rect(sx0, sy0, sx1 - sx0, sy1 - sy0)?, FrameMut::new(dst, cw, ch)?, filter)?;
            let view = FrameRef::new(&*dst, cw, ch)?;
            (view.sub_rect(win.x0 - 2 * sx0, win.y0 - 2 * sy0, win.width(), win.height())?, true, ch)
        }
        BandRatio::AreaDown2 => {
            let (cw, ch) = (win.width(), win.height());
            let dst =
                band.get_mut(..cw * ch).ok_or(Error::ScratchTooSmall { needed: cw * ch, capacity: 0 })?;
            rescale(
                src.sub_rect(2 * win.x0, 2 * win.y0, 2 * cw, 2 * ch)?,
                FrameMut::new(dst, cw, ch)?,
                filter,
            )?;
            (FrameRef::new(&*dst, cw, ch)?, true, ch)
        }
        BandRatio::CubicUp2 | BandRatio::Other => {
            let pixels = grid.0 * grid.1;
            let dst = band.get_mut(..pixels).ok_or(Error::ScratchTooSmall { needed: pixels, capacity: 0 })?;
            rescale(src, FrameMut::new(dst, grid.0, grid.1)?, filter)?;
            let view = FrameRef::new(&*dst, grid.0, grid.1)?;
            (view.sub_rect(win.x0, win.y0, win.width(), win.height())?, false, grid.1)
        }
    };
    Ok(BandWindow { view, window_only, rows })
}

/// Writes `value` to every pixel of `out` outside `keep`.
pub(super) fn fill_outside(out: &mut FrameMut<'_, u8>, keep: Rect, value: u8) {
    for (y, row) in out.rows_mut().enumerate() {
        if keep.is_empty() || y < keep.y0 || y >= keep.y1 {
            row.fill(value);
        } else {
            let (left, rest) = row.split_at_mut(keep.x0.min(row.len()));
            left.fill(value);
            rest.get_mut(keep.width()..).unwrap_or(&mut []).fill(value);
        }
    }
}

/// [`fuse`] with scene skipping (policy `Roi` or `All`).
pub(super) fn fuse_skipping(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    scratch: &mut ScratchMut<'_>,
    pipeline: &FuseConfig,
    seq: Option<&mut Sequence>,
) -> Result<FuseReport, Error> {
    let grid = fusion_grid(vis.size(), tir.size(), pipeline.rescale)?;
    if out.size() != grid {
        return Err(Error::SizeMismatch { expected: grid, got: out.size() });
    }
    pipeline.method.validate()?;
    // The scratch of a full run, checked whatever the plan: a too-small scratch is an error on
    // every frame, not only on those the analysis declines to skip.
    scratch.planes(pipeline.scratch_pixels(vis.size(), tir.size())?)?;
    if vis.size() != tir.size() {
        scratch.split_band(grid.0 * grid.1)?;
    }
    let scene = analyze(vis, tir, grid, &pipeline.scene)?;
    // The adaptive method decides on this frame's own analysis; a large target's frame is
    // ADF's from here on (its plan, its window forms), with nothing carried in a sequence.
    match &pipeline.method {
        Method::Adaptive(p) => match decide(&scene, p) {
            Decision::Adf => {
                let adf = FuseConfig { method: Method::Adf(p.adf), ..*pipeline };
                let mut r = skipping_decided(vis, tir, out, scratch, &adf, seq, scene, None, false)?;
                r.guards |= Guards::ADAPTIVE_ADF;
                Ok(r)
            }
            d => skipping_decided(vis, tir, out, scratch, pipeline, seq, scene, Some(d), false),
        },
        _ => skipping_decided(vis, tir, out, scratch, pipeline, seq, scene, None, true),
    }
}

/// [`fuse_skipping`] once the frame is analysed (`scene`) and the adaptive method has decided
/// (`decision`); `carries`: in a sequence, ADF takes its link (the carried weights).
#[allow(clippy::too_many_arguments)]
fn skipping_decided(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    mut out: FrameMut<'_, u8>,
    scratch: &mut ScratchMut<'_>,
    pipeline: &FuseConfig,
    seq: Option<&mut Sequence>,
    scene: Scene,
    decision: Option<Decision>,
    carries: bool,
) -> Result<FuseReport, Error> {
    let grid = scene.grid;
    let mut seq = seq;
    let mut scene = scene;
    // In a sequence, the target boxes of the last frames joined to this one's (not the caller's
    // window, which is taken as given).
    if let (Some(s), false) = (seq.as_deref_mut(), matches!(pipeline.skip, SkipPolicy::Window(_))) {
        scene = s.widen(scene);
    }
    let eclipse = pipeline.skip == SkipPolicy::All && scene.illumination == Illumination::Eclipse;
    let plan = plan(&scene, pipeline, grid, eclipse, decision);
    // In a sequence, ADF's link with the class the analysis found (the same rule on the same
    // statistics as outside skipping).
    let mut link = match (seq, &pipeline.method) {
        (Some(seq), Method::Adf(_)) if carries => Some(Link { seq, illumination: scene.illumination }),
        _ => None,
    };
    let rescaled = scene.rescale_needed;
    let mut report = SkipReport::none(pipeline.skip, grid, rescaled);
    report.illumination = Some(scene.illumination);
    let background = match decision {
        // The adaptive method's value on a flat pair: max(level_VIS, level_TIR), or the TIR
        // level when the TIR frame passes through.
        Some(Decision::TirOnly) => scene.tir.background,
        Some(Decision::Blend { .. }) => scene.vis.background.max(scene.tir.background),
        Some(Decision::Adf) | None => background_value(&scene),
    };
    let (computed, roi, vis_constant) = match plan {
        Plan::Full(declined) => {
            let mut r = on_grid(vis, tir, grid, scratch, pipeline.rescale, |v, t, s| {
                fuse_method_linked(v, t, out, &pipeline.method, s, decision, link.as_mut())
            })?;
            r.skip = SkipReport { declined, ..report };
            return Ok(r);
        }
        Plan::Empty { exact } => {
            out.fill(background);
            report.roi = Rect::default();
            report.computed = Rect::default();
            report.background = Some(background);
            report.exact_outside = exact;
            report.taken |= Skips::ROI;
            if eclipse {
                report.taken |= Skips::ECLIPSE_TIR_TARGET;
            }
            return Ok(FuseReport { grid, rescaled: false, guards: Guards::NONE, skip: report });
        }
        Plan::Window { computed, roi } | Plan::Crop { computed, roi } => (computed, roi, false),
        Plan::AdfWindow { computed, roi, vis_constant } => (computed, roi, vis_constant),
    };
    let crop = matches!(plan, Plan::Crop { .. });
    let (cw, ch) = (computed.width(), computed.height());
    // The method as it runs on the window (the crop's own parameters, see `Method::on_crop`).
    let method_here = if crop { pipeline.method.on_crop((cw, ch), grid) } else { pipeline.method };
    let (filter_vis_side, vis_rescaled) = match pipeline.rescale {
        RescalePolicy::TirUp => (Filter::Cubic, false),
        RescalePolicy::VisDown | RescalePolicy::None => (Filter::Area, true),
    };
    let needs_band = vis.size() != tir.size();
    let mut no_band: [u8; 0] = [];
    let (band, mut planes) = if needs_band {
        let (b, p) = scratch.split_band(grid.0 * grid.1)?;
        (b, p)
    } else {
        // A frame-global method on its crop needs its own scratch for the crop's size (IFEVIP's
        // resizes and key classes), never more than the whole frame's checked above.
        let pixels = if crop {
            FuseConfig { method: method_here, ..*pipeline }.scratch_pixels((cw, ch), (cw, ch))?
        } else {
            cw * ch
        };
        let [a, b, c] = scratch.planes(pixels)?;
        (&mut no_band[..], ScratchMut::from_slices([a, b, c]))
    };
    let (vis_w, tir_w, window_rescale) = if vis_rescaled {
        let b = band_window(vis, grid, computed, filter_vis_side, band)?;
        (b.view, tir.sub_rect(computed.x0, computed.y0, cw, ch)?, b.window_only)
    } else {
        let b = band_window(tir, grid, computed, filter_vis_side, band)?;
        (vis.sub_rect(computed.x0, computed.y0, cw, ch)?, b.view, b.window_only)
    };
    let mut out_w = out.sub_rect_mut(computed.x0, computed.y0, cw, ch)?;
    let guards = match &pipeline.method {
        _ if crop => {
            let g = fuse_method_linked(
                vis_w,
                tir_w,
                out_w.reborrow(),
                &method_here,
                &mut planes,
                decision,
                link.as_mut(),
            )?;
            fill_outside(&mut out, roi, background);
            report.exact_outside = false;
            report.taken |= Skips::CROP;
            g
        }
        Method::Adf(p) => {
            let exact = Rect {
                x0: roi.x0 - computed.x0,
                y0: roi.y0 - computed.y0,
                x1: roi.x1 - computed.x0,
                y1: roi.y1 - computed.y0,
            };
            let vis_opt = if vis_constant { None } else { Some(vis_w) };
            let level = scene.vis.background;
            let g = crate::methods::adf::fuse_adf_window_linked(
                vis_opt,
                level,
                tir_w,
                out_w,
                exact,
                grid.0 * grid.1,
                p,
                &mut planes,
                link.as_mut(),
            )?;
            fill_outside(&mut out, roi, background);
            report.exact_outside = !vis_constant;
            g
        }
        _ => {
            let g =
                fuse_method_decided(vis_w, tir_w, out_w.reborrow(), &pipeline.method, &mut planes, decision)?;
            fill_outside(&mut out, computed, background);
            report.exact_outside = roi == Rect::full(grid);
            g
        }
    };
    report.roi = roi;
    report.computed = computed;
    let written = if crop || matches!(pipeline.method, Method::Adf(_)) { roi } else { computed };
    report.background = (written != Rect::full(grid)).then_some(background);
    if computed != Rect::full(grid) || written != Rect::full(grid) {
        report.taken |= Skips::ROI;
    }
    if window_rescale {
        report.taken |= Skips::ROI_RESCALE;
    }
    if vis_constant {
        report.taken |= Skips::ECLIPSE_VIS;
    }
    if eclipse && (crop || matches!(pipeline.method, Method::Tsifsd(_) | Method::Adaptive(_))) {
        report.taken |= Skips::ECLIPSE_TIR_TARGET;
    }
    Ok(FuseReport { grid, rescaled, guards, skip: report })
}
