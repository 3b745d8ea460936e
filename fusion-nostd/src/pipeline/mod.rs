//! The one entry point a firmware calls per frame pair: align the two bands on one grid, fuse.
//!
//! ```text
//! VIS (e.g. 1024²) ─┐                       ┌─ rescale TIR up (bicubic)  ─┐
//!                   ├─ RescalePolicy ───────┼─ rescale VIS down (area)   ─┼─ Method ─→ fused u8
//! TIR (e.g. 512²)  ─┘                       └─ none (sizes must match)   ─┘
//! ```
//!
//! The rescaled band goes into the scratch's `u8` band plane; the method borrows the `i32`
//! work planes. When both frames already share a grid the rescale is skipped whatever the
//! policy says (and [`FuseReport::rescaled`] says so). The same pipeline runs strip by strip in
//! a 512 KiB working set instead of these planes: [`crate::strips::fuse_strips`] (every
//! method, both variants, the same bytes).
//!
//! # Scene skipping
//!
//! With [`SkipPolicy::Roi`], [`SkipPolicy::All`] or [`SkipPolicy::Window`], [`fuse`] first runs
//! [`crate::scene::analyze`] and then picks a plan per method ([`FuseReport::skip`] says which):
//!
//! * **TSIFSD** (both variants; local): window = target box grown by the halo
//!   `mean_size/2 + 1` (the 35×35 mean's radius; the 3×3 median/Scharr is inside it), corners
//!   made even for a 2× rescale; classic (circular mean): an axis the window touches at a frame
//!   edge is taken whole, so the wrap is the frame's. The method runs on the window; the ROI =
//!   window shrunk by the halo on every side not on the frame edge is bit-identical to
//!   `None`; the halo ring keeps the window's values; outside the window the output is the
//!   background rule `round(½(level_VIS + level_TIR))` (the method's exact value on a flat
//!   pair). The error outside is measured, not bounded a priori.
//! * **ADF** (global KL covariance), **noiseless frames**: only when the frame outside the
//!   *varying box* (pixels differing from their band's level at all) is exactly constant and,
//!   classic (zero padding), that level is 0. Then the detail layers vanish outside the box
//!   grown by N (iterations), the covariance is the sum over that region with the frame's
//!   pixel count ([`crate::methods::adf::fuse_adf_window`]), and the **whole** output is
//!   bit-identical (outside: the background rule, exact there). Otherwise declined:
//!   [`Decline::GlobalStatistic`].
//! * **Crop semantics** — ADF on noisy frames, IFEVIP on every frame (frame-global statistics:
//!   ADF's KL covariance, IFEVIP's entropies, quadtree background and peak, which no window can
//!   reproduce bit for bit): with W the target box and W′ = W grown by
//!   [`Method::halo`] (even corners for a 2× rescale, so the rescale's phase is kept), the
//!   output inside W is, bit for bit, the method run on the crop W′ of both bands on the grid
//!   as a frame of its own, restricted to W — `fuse(crop(VIS, W′), crop(TIR, W′))`; outside W
//!   the background rule. IFEVIP's quadtree grid follows the crop ([`Method::on_crop`]: one of
//!   its pixels covers about as many frame pixels as in the whole frame, instead of the crop
//!   being resized up to 512²). The statistics are then those of the target region, which is what
//!   the weights are meant to weigh ([`Skips::CROP`]; [`SkipReport::roi`] = W,
//!   [`SkipReport::computed`] = W′). A crop above `max_roi_percent` is declined
//!   ([`Decline::RoiTooLarge`]).
//! * **Noisy frames** (sensor noise above `max_noise_spread`): the target box comes from the
//!   analysis's block means ([`crate::scene::BlockStats`]), so TSIFSD and the adaptive method
//!   skip them as above (outside the window: the background value, here the noise's level),
//!   ADF and IFEVIP with the crop semantics. (An adaptive frame with a large target is ADF's:
//!   it skips with ADF's plans, [`crate::Guards::ADAPTIVE_ADF`].)
//! * **The caller's window** ([`SkipPolicy::Window`], e.g. a navigation filter's predicted
//!   target box): the same plans with that box in place of the analysis's target box and no
//!   size limit — TSIFSD and the adaptive method exact on the ROI, ADF and IFEVIP the crop
//!   semantics on every frame; no eclipse plan; never declined.
//! * The analysis declines a non-dark background, or one whose block means are still noisy
//!   ([`Decline::BackgroundNotDark`], [`Decline::TooNoisy`]), and a window above
//!   `max_roi_percent` is not worth it
//!   ([`Decline::RoiTooLarge`]); a declined frame is fused whole, bit-identical to `None`.
//! * **Rescale**: for an exact 2× ratio only the source pixels the window's taps read are
//!   rescaled (the same bits: same phase, no tap crosses the cut); other ratios rescale the whole
//!   frame. Same-size frames are never rescaled.
//! * **Eclipse** (`All`, VIS classified [`Illumination::Eclipse`]): ADF takes VIS as its constant
//!   background level and skips its diffusion ([`Skips::ECLIPSE_VIS`]: the output is ADF of
//!   (level, TIR), exact against `None` only when VIS really is that constant); TSIFSD's window
//!   follows the TIR target alone ([`Skips::ECLIPSE_TIR_TARGET`]; its VIS-side work, the box
//!   sum, is ≈ 5 % and kept).

use crate::methods::adaptive::{AdaptiveParams, Decision, decide, decide_frame, fuse_adaptive};
use crate::methods::adf::{AdfParams, fuse_adf_linked, fuse_adf_raw};
use crate::methods::ifevip::{IfevipParams, fuse_ifevip};
use crate::methods::tsifsd::{TsifsdParams, fuse_tsifsd, fuse_tsifsd_raw};
use crate::methods::{Guards, Variant};
use crate::scene::{Decline, Illumination, Rect, Scene, SceneParams, analyze, band_stats, illumination};
use crate::sequence::{Link, Sequence};
use crate::{Error, Filter, FrameMut, FrameRef, ScratchMut, rescale};

/// Which band is rescaled onto the other's grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum RescalePolicy {
    /// Upscale TIR to the VIS grid with bicubic (the study's recommendation; default).
    #[default]
    TirUp,
    /// Downscale VIS to the TIR grid with area.
    VisDown,
    /// No rescale: the frames must already have the same size.
    None,
}

/// The fusion method and its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// Anisotropic diffusion + Karhunen–Loève fusion.
    Adf(AdfParams),
    /// Two-scale image fusion with saliency detection.
    Tsifsd(TsifsdParams),
    /// Infrared feature extraction + visual information preservation.
    Ifevip(IfevipParams),
    /// Illumination-adaptive fusion for navigation ([`crate::methods::adaptive`]): the per-frame
    /// decision (ADF on a large target, TIR through when VIS has no signal, else the blend)
    /// comes from the scene analysis of both input frames.
    Adaptive(AdaptiveParams),
}

impl Default for Method {
    fn default() -> Self {
        Method::Tsifsd(TsifsdParams::default())
    }
}

/// What the pipeline may skip, after [`crate::scene::analyze`] (see "Scene skipping" below).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum SkipPolicy {
    /// Fuse every pixel (today's behaviour; no analysis runs).
    #[default]
    None,
    /// Fuse (and rescale) only a window around the target, write the background elsewhere.
    Roi,
    /// `Roi`, plus the eclipse plan: when VIS has no signal, its side of the work is skipped
    /// where the method allows (ADF: VIS is taken as its constant background level) and the
    /// window follows the TIR target alone.
    All,
    /// Fuse only the caller's window (grid coordinates; e.g. the navigation filter's predicted
    /// target box), whatever the analysis found: `Roi`'s semantics with this box in place of
    /// the analysis's target box, the crop semantics for every frame-global method, no
    /// eclipse plan. The analysis still runs (the background value, the adaptive decision).
    /// The box is clipped to the grid; an empty one gives the background everywhere.
    Window(Rect),
}

/// A whole per-frame configuration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FuseConfig {
    /// How the two bands are brought onto one grid.
    pub rescale: RescalePolicy,
    /// How they are fused.
    pub method: Method,
    /// What may be skipped (default: nothing).
    pub skip: SkipPolicy,
    /// Thresholds of the scene analysis (used when `skip` is not `None`).
    pub scene: SceneParams,
}

impl FuseConfig {
    /// Pixels each scratch plane (the three `i32` planes and the `u8` band plane) must hold to
    /// fuse a `vis`-sized frame with a `tir`-sized one, or [`Error::SizeMismatch`] when the
    /// policy cannot align them.
    ///
    /// Sizes a view could not have are refused first: a zero side ([`Error::ZeroDimension`]) or
    /// a side above [`crate::MAX_DIMENSION`] ([`Error::DimensionTooLarge`]).
    pub fn scratch_pixels(&self, vis: (usize, usize), tir: (usize, usize)) -> Result<usize, Error> {
        for value in [vis.0, vis.1, tir.0, tir.1] {
            if value == 0 {
                return Err(Error::ZeroDimension);
            }
            if value > crate::MAX_DIMENSION {
                return Err(Error::DimensionTooLarge { value });
            }
        }
        let (w, h) = fusion_grid(vis, tir, self.rescale)?;
        let pixels = w.checked_mul(h).ok_or(Error::DimensionTooLarge { value: w.max(h) })?;
        Ok(match &self.method {
            Method::Adf(_) | Method::Tsifsd(_) | Method::Adaptive(_) => pixels,
            Method::Ifevip(p) => crate::methods::ifevip::scratch_pixels(w, h, p).max(pixels),
        })
    }
}

/// What one [`fuse`] call did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FuseReport {
    /// Width and height of the grid the frames were fused on (= the output size).
    pub grid: (usize, usize),
    /// Whether a band was rescaled (false when the sizes already matched).
    pub rescaled: bool,
    /// The guards the method fired.
    pub guards: Guards,
    /// What the scene skipping did.
    pub skip: SkipReport,
}

/// Which skips a [`fuse`] call took: a bit set like [`Guards`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Skips(pub u32);

impl Skips {
    /// Nothing skipped.
    pub const NONE: Skips = Skips(0);
    /// The method ran on a window only ([`SkipReport::computed`]); the background rule wrote
    /// the rest.
    pub const ROI: Skips = Skips(1 << 0);
    /// The rescale ran on the window only.
    pub const ROI_RESCALE: Skips = Skips(1 << 1);
    /// Eclipse plan: VIS taken as its constant background level, its diffusion skipped (ADF).
    pub const ECLIPSE_VIS: Skips = Skips(1 << 2);
    /// Eclipse plan: the window follows the TIR target alone (VIS has no signal).
    pub const ECLIPSE_TIR_TARGET: Skips = Skips(1 << 3);
    /// The frames already shared a grid: no rescale (also without scene skipping).
    pub const NO_RESCALE: Skips = Skips(1 << 4);
    /// Crop semantics (a frame-global method, see "Scene skipping"): the method ran on the
    /// crop [`SkipReport::computed`] as a frame of its own; [`SkipReport::roi`] holds that
    /// fusion's output (not the whole frame's), the background value is everywhere else.
    pub const CROP: Skips = Skips(1 << 5);

    /// Whether every bit of `other` is set in `self`.
    pub const fn contains(self, other: Skips) -> bool {
        self.0 & other.0 == other.0
    }
}

impl core::ops::BitOr for Skips {
    type Output = Skips;
    fn bitor(self, rhs: Skips) -> Skips {
        Skips(self.0 | rhs.0)
    }
}

impl core::ops::BitOrAssign for Skips {
    fn bitor_assign(&mut self, rhs: Skips) {
        self.0 |= rhs.0;
    }
}

/// The scene-skipping part of a [`FuseReport`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SkipReport {
    /// The policy asked for.
    pub policy: SkipPolicy,
    /// VIS illumination (`None` when no analysis ran: policy `None`).
    pub illumination: Option<Illumination>,
    /// The pixels guaranteed bit-identical to [`SkipPolicy::None`] (the whole grid when nothing
    /// was skipped; empty when the pair has no target). With [`Skips::ECLIPSE_VIS`] the
    /// guarantee is against the same method on VIS replaced by its background level; with
    /// [`Skips::CROP`] against the same method on the crop `computed` of both bands (on the
    /// grid, after the rescale).
    pub roi: Rect,
    /// The window the method actually ran on (`roi` plus its halo).
    pub computed: Rect,
    /// The background value the plan wrote (`None` when it wrote none): outside `computed` for
    /// TSIFSD and the adaptive method (their halo ring keeps the window's values), outside
    /// `roi` for ADF and IFEVIP (for ADF's exact plans the exact value, see `exact_outside`),
    /// everywhere for an empty frame.
    pub background: Option<u8>,
    /// Whether the output outside `roi` is proven bit-identical as well (ADF on an exactly
    /// constant background).
    pub exact_outside: bool,
    /// The skips taken.
    pub taken: Skips,
    /// Why the ROI skip was declined (the whole frame was fused), if it was.
    pub declined: Option<Decline>,
}

impl SkipReport {
    /// Nothing skipped on a `grid`-sized frame.
    pub fn none(policy: SkipPolicy, grid: (usize, usize), rescaled: bool) -> Self {
        Self {
            policy,
            illumination: None,
            roi: Rect::full(grid),
            computed: Rect::full(grid),
            background: None,
            exact_outside: true,
            taken: if rescaled { Skips::NONE } else { Skips::NO_RESCALE },
            declined: None,
        }
    }
}

/// The grid `policy` fuses on, given the two input sizes.
pub fn fusion_grid(
    vis: (usize, usize),
    tir: (usize, usize),
    policy: RescalePolicy,
) -> Result<(usize, usize), Error> {
    match policy {
        RescalePolicy::TirUp => Ok(vis),
        RescalePolicy::VisDown => Ok(tir),
        RescalePolicy::None if vis == tir => Ok(vis),
        RescalePolicy::None => Err(Error::SizeMismatch { expected: vis, got: tir }),
    }
}

/// Runs one method on two frames of the same size.
///
/// The adaptive method takes its per-frame [`Decision`] from the scene analysis (default
/// [`SceneParams`]) of these frames; [`fuse`] takes it from the input frames before any
/// rescale ([`adaptive_decision`]), so call [`fuse_method_decided`] with that decision to get
/// [`fuse`]'s bits from frames already on the grid.
#[doc(hidden)]
pub fn fuse_method(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    method: &Method,
    scratch: &mut ScratchMut<'_>,
) -> Result<Guards, Error> {
    fuse_method_decided(vis, tir, out, method, scratch, None)
}

/// [`fuse_method`] with the adaptive method's per-frame decision given (`None`: taken from
/// these frames as [`fuse_method`] does; ignored by the other methods).
#[doc(hidden)]
pub fn fuse_method_decided(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    method: &Method,
    scratch: &mut ScratchMut<'_>,
    decision: Option<Decision>,
) -> Result<Guards, Error> {
    fuse_method_linked(vis, tir, out, method, scratch, decision, None)
}

/// [`fuse_method_decided`], in a sequence when `link` is given (ADF's weights; the other
/// methods ignore it).
pub(crate) fn fuse_method_linked(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    method: &Method,
    scratch: &mut ScratchMut<'_>,
    decision: Option<Decision>,
    link: Option<&mut Link<'_>>,
) -> Result<Guards, Error> {
    match method {
        Method::Adf(p) => fuse_adf_linked(vis, tir, out, p, scratch, link),
        Method::Tsifsd(p) => fuse_tsifsd(vis, tir, out, p, scratch),
        Method::Ifevip(p) => fuse_ifevip(vis, tir, out, p, scratch),
        Method::Adaptive(p) => {
            let decision = match decision {
                Some(d) => d,
                None => decide_frame(vis, tir, vis.size(), &SceneParams::default(), p)?,
            };
            fuse_adaptive(vis, tir, out, p, decision, scratch)
        }
    }
}

/// The adaptive method's per-frame decision for an input pair, as [`fuse`] takes it: the scene
/// analysis of both frames as given, on the fusion grid, with `pipeline.scene`. `None` for the
/// other methods.
#[doc(hidden)]
pub fn adaptive_decision(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    pipeline: &FuseConfig,
) -> Result<Option<Decision>, Error> {
    match &pipeline.method {
        Method::Adaptive(p) => {
            let grid = fusion_grid(vis.size(), tir.size(), pipeline.rescale)?;
            Ok(Some(decide_frame(vis, tir, grid, &pipeline.scene, p)?))
        }
        _ => Ok(None),
    }
}

/// Fuses a VIS/TIR pair into `out`: rescale by `pipeline.rescale`, then `pipeline.method`.
///
/// `out` must have the size of the fusion grid (the VIS size for [`RescalePolicy::TirUp`],
/// the TIR size for [`RescalePolicy::VisDown`]). Errors: [`Error::SizeMismatch`] for a wrong
/// output size or (policy `None`) different input sizes, [`Error::ScratchTooSmall`], and any
/// error of the method. On error `out` may hold a partial result and must not be used.
pub fn fuse(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    scratch: &mut ScratchMut<'_>,
    pipeline: &FuseConfig,
) -> Result<FuseReport, Error> {
    fuse_maybe_in_sequence(vis, tir, out, scratch, pipeline, None)
}

/// Fuses the next frame pair of a sequence like [`fuse`], with the frame-global weights the
/// sequence carries ([`crate::sequence`]: ADF's KL weights from the previous frame, unless
/// the illumination class, the covariance's size or the parameters changed; the other methods
/// per frame). [`Sequence::last_step`] then says how the frame was fused. Scene skipping works
/// as in [`fuse`] (a crop's weights are carried to the next crop). The first frame of a
/// sequence is [`fuse`]'s bytes; [`crate::strips::fuse_strips_in_sequence`] gives the same
/// bytes as this for the same frames.
///
/// Errors: those of [`fuse`], and [`Error::InvalidParameter`] (`"size_change_percent"`) for
/// bad sequence parameters. A failed call leaves the carried weights as they were.
pub fn fuse_in_sequence(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    scratch: &mut ScratchMut<'_>,
    pipeline: &FuseConfig,
    seq: &mut Sequence,
) -> Result<FuseReport, Error> {
    let carries = matches!(pipeline.method, Method::Adf(_));
    seq.frame(carries, |seq| fuse_maybe_in_sequence(vis, tir, out, scratch, pipeline, Some(seq)))
}

/// [`fuse`], in a sequence when `seq` is given.
fn fuse_maybe_in_sequence(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out: FrameMut<'_, u8>,
    scratch: &mut ScratchMut<'_>,
    pipeline: &FuseConfig,
    seq: Option<&mut Sequence>,
) -> Result<FuseReport, Error> {
    if pipeline.skip != SkipPolicy::None {
        return fuse_skipping(vis, tir, out, scratch, pipeline, seq);
    }
    pipeline.method.validate()?;
    let decision = adaptive_decision(vis, tir, pipeline)?;
    let mut link = sequence_link(vis, pipeline, seq)?;
    on_grid(vis, tir, out.size(), scratch, pipeline.rescale, |v, t, s| {
        fuse_method_linked(v, t, out, &pipeline.method, s, decision, link.as_mut())
    })
}

/// The link of an ADF frame to its sequence: the sequence and the illumination class of the
/// input VIS frame (the scene analysis's rule on the same band statistics). `None` outside a
/// sequence and for the methods that carry nothing.
pub(crate) fn sequence_link<'s>(
    vis: FrameRef<'_, u8>,
    pipeline: &FuseConfig,
    seq: Option<&'s mut Sequence>,
) -> Result<Option<Link<'s>>, Error> {
    match (seq, &pipeline.method) {
        (Some(seq), Method::Adf(_)) => {
            pipeline.scene.validate()?;
            let illumination = illumination(&band_stats(vis, &pipeline.scene), &pipeline.scene);
            Ok(Some(Link { seq, illumination }))
        }
        _ => Ok(None),
    }
}

/// Like [`fuse`], but writes the method's real-valued result before the 8-bit cast, in Q16
/// (`raw / 65536.0` grey levels); [`fuse`] is this value cast with
/// [`crate::methods::round_away_sat_u8`]`(raw, 16)`.
///
/// ADF and TSIFSD only: IFEVIP's published arithmetic saturates to `uint8` at every step, so
/// its pre-cast value is its output, and the adaptive method has no published pre-cast value
/// to compare with; for them this returns [`Error::InvalidParameter`]
/// (`name: "method"`).
#[doc(hidden)]
pub fn fuse_raw(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    raw: FrameMut<'_, i32>,
    scratch: &mut ScratchMut<'_>,
    pipeline: &FuseConfig,
) -> Result<FuseReport, Error> {
    on_grid(vis, tir, raw.size(), scratch, pipeline.rescale, |v, t, s| match &pipeline.method {
        Method::Adf(p) => fuse_adf_raw(v, t, raw, p, s),
        Method::Tsifsd(p) => fuse_tsifsd_raw(v, t, raw, p, s),
        Method::Ifevip(_) | Method::Adaptive(_) => Err(Error::InvalidParameter { name: "method" }),
    })
}

/// Brings both bands onto the fusion grid of `policy` (rescaling one into the scratch's band
/// plane when the sizes differ) and runs `fuse_on_grid` there with the remaining planes.
fn on_grid(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    out_size: (usize, usize),
    scratch: &mut ScratchMut<'_>,
    policy: RescalePolicy,
    fuse_on_grid: impl FnOnce(FrameRef<'_, u8>, FrameRef<'_, u8>, &mut ScratchMut<'_>) -> Result<Guards, Error>,
) -> Result<FuseReport, Error> {
    let grid = fusion_grid(vis.size(), tir.size(), policy)?;
    if out_size != grid {
        return Err(Error::SizeMismatch { expected: grid, got: out_size });
    }
    if vis.size() == tir.size() {
        let guards = fuse_on_grid(vis, tir, scratch)?;
        return Ok(FuseReport {
            grid,
            rescaled: false,
            guards,
            skip: SkipReport::none(SkipPolicy::None, grid, false),
        });
    }
    let (band, mut planes) = scratch.split_band(grid.0 * grid.1)?;
    let guards = match policy {
        RescalePolicy::TirUp => {
            rescale(tir, FrameMut::new(band, grid.0, grid.1)?, Filter::Cubic)?;
            fuse_on_grid(vis, FrameRef::new(band, grid.0, grid.1)?, &mut planes)?
        }
        RescalePolicy::VisDown | RescalePolicy::None => {
            rescale(vis, FrameMut::new(band, grid.0, grid.1)?, Filter::Area)?;
            fuse_on_grid(FrameRef::new(band, grid.0, grid.1)?, tir, &mut planes)?
        }
    };
    Ok(FuseReport { grid, rescaled: true, guards, skip: SkipReport::none(SkipPolicy::None, grid, true) })
}

impl Method {
    /// Every method and variant with the default parameters, in a fixed order: ADF, TSIFSD
    /// and IFEVIP each classic then flight, then the adaptive method (one variant). Tests,
    /// firmware sweeps and tools iterate this instead of listing the methods by hand.
    pub fn all() -> [Method; 7] {
        let (c, f) = (Variant::Classic, Variant::Flight);
        [
            Method::Adf(AdfParams { variant: c, ..AdfParams::default() }),
            Method::Adf(AdfParams { variant: f, ..AdfParams::default() }),
            Method::Tsifsd(TsifsdParams { variant: c, ..TsifsdParams::default() }),
            Method::Tsifsd(TsifsdParams { variant: f, ..TsifsdParams::default() }),
            Method::Ifevip(IfevipParams { variant: c, ..IfevipParams::default() }),
            Method::Ifevip(IfevipParams { variant: f, ..IfevipParams::default() }),
            Method::Adaptive(AdaptiveParams::default()),
        ]
    }

    /// The methods' short names, in the order of [`Method::defaults`] (the CLI's, the C
    /// interface's and the firmware's numbering).
    pub const KINDS: [&'static str; 4] = ["adf", "tsifsd", "ifevip", "adaptive"];

    /// Each method with its default parameters (the flight variants), in the order of
    /// [`Method::KINDS`].
    pub fn defaults() -> [Method; 4] {
        Self::KINDS.map(|kind| Self::named(kind, Variant::Flight).unwrap_or_default())
    }

    /// The method a firmware job's run names (`fw/src/job.rs`; the budget's host comparison
    /// builds the same): [`Method::named`], except that the adaptive method's classic variant is
    /// its blend alone ([`AdaptiveParams::blend_only`], the cost of a small target's frame).
    #[doc(hidden)]
    pub fn for_job(kind: &str, variant: Variant) -> Option<Method> {
        match (kind, variant) {
            ("adaptive", Variant::Classic) => Some(Method::Adaptive(AdaptiveParams::blend_only())),
            _ => Self::named(kind, variant),
        }
    }

    /// The method called `kind` (one of [`Method::KINDS`]) with its default parameters in
    /// `variant` (the adaptive method has one); `None` for another name.
    pub fn named(kind: &str, variant: Variant) -> Option<Method> {
        Self::all().into_iter().find(|m| m.kind() == kind && m.variant().is_none_or(|v| v == variant))
    }

    /// The method's short name: `adf`, `tsifsd`, `ifevip`, `adaptive` (the CLI's and the C
    /// interface's).
    pub fn kind(&self) -> &'static str {
        match self {
            Method::Adf(_) => "adf",
            Method::Tsifsd(_) => "tsifsd",
            Method::Ifevip(_) => "ifevip",
            Method::Adaptive(_) => "adaptive",
        }
    }

    /// The variant, for the methods that have two (`None` for the adaptive method).
    pub fn variant(&self) -> Option<Variant> {
        match self {
            Method::Adf(p) => Some(p.variant),
            Method::Tsifsd(p) => Some(p.variant),
            Method::Ifevip(p) => Some(p.variant),
            Method::Adaptive(_) => None,
        }
    }

    /// `<method>-<variant>` (`adf-flight`, `tsifsd-classic`, …) or `adaptive`: the names of
    /// `fusion navbench`'s sources and of the budget table's rows.
    pub fn name(&self) -> &'static str {
        match (self.kind(), self.variant()) {
            ("adf", Some(Variant::Classic)) => "adf-classic",
            ("adf", _) => "adf-flight",
            ("tsifsd", Some(Variant::Classic)) => "tsifsd-classic",
            ("tsifsd", _) => "tsifsd-flight",
            ("ifevip", Some(Variant::Classic)) => "ifevip-classic",
            ("ifevip", _) => "ifevip-flight",
            _ => "adaptive",
        }
    }

    /// Checks the method's parameters.
    pub fn validate(&self) -> Result<(), Error> {
        match self {
            Method::Adf(p) => p.validate(),
            Method::Tsifsd(p) => p.validate(),
            Method::Ifevip(p) => p.validate(),
            Method::Adaptive(p) => p.validate(),
        }
    }

    /// Radius of the neighbourhood an output pixel depends on (grid pixels): the window halo
    /// of the skip plans. ADF: one pixel per diffusion iteration; TSIFSD: the mean filter's
    /// radius (the 3×3 median / Scharr is inside it) plus one; adaptive: the base box's radius
    /// (the 3×3 binomial is inside it). IFEVIP has no local radius (its background and peak
    /// are frame-global); its halo is the context its crop is given: the erosion's radius plus
    /// the Gaussian's (`erode_size/2 + gauss_size/2`, 20 by default), so that a target pixel
    /// near the window's edge still sees the background around it.
    pub fn halo(&self) -> usize {
        match self {
            Method::Adf(p) => usize::from(p.iterations),
            Method::Tsifsd(p) => usize::from(p.mean_size / 2) + 1,
            Method::Ifevip(p) => usize::from(p.erode_size / 2) + usize::from(p.gauss_size / 2),
            Method::Adaptive(p) => p.halo(),
        }
    }

    /// The method as the crop semantics runs it on a `crop` of a `grid`-sized frame: IFEVIP with
    /// its quadtree grid scaled to the crop ([`IfevipParams::on_crop`]); the others unchanged.
    pub fn on_crop(&self, crop: (usize, usize), grid: (usize, usize)) -> Method {
        match self {
            Method::Ifevip(p) => Method::Ifevip(p.on_crop(crop.0.max(crop.1), grid.0.max(grid.1))),
            m => *m,
        }
    }

    /// Whether the output depends on statistics of the whole frame (ADF's KL covariance,
    /// IFEVIP's entropies, quadtree background and peak), so that a window can reproduce it
    /// only in special cases: these methods skip with the crop semantics (module docs, "Scene
    /// skipping").
    pub fn frame_global(&self) -> bool {
        matches!(self, Method::Adf(_) | Method::Ifevip(_))
    }
}

mod skip;

pub use skip::background_value;
use skip::fuse_skipping;
pub(crate) use skip::{BandRatio, band_ratio, band_window};
