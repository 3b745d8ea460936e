//! Sequence mode: fuse frame k with the frame-global weights measured while fusing frame k − 1,
//! so a frame is fused in **one pass** over its rows.
//!
//! ADF's KL weights are a statistic of the whole frame's detail layers. Fused on its own, a
//! frame needs them before its first output row: [`crate::strips::fuse_strips`] diffuses every
//! strip twice (once for the covariance, once for the output; 2.07× the whole-frame count on
//! the Cortex-M7 at 1024²), and a camera read out line by line cannot be fused as it arrives.
//! In a sequence one frame's weights serve the next ([`Sequence`] carries them): on the rendered
//! noisy rendezvous sequences they move by about half their value from frame to frame, yet the
//! carried weights change no pixel of a whole frame by more than 1 level (classic 2; inside a
//! skip crop up to 82; `BENCHMARKS.md`, "Sequence mode").
//!
//! * frame k is fused with the weights **carried** from frame k − 1 ([`Pass::Carried`]), while
//!   its own covariance is summed on the way (exact integer sums, the same as the two-pass
//!   form's) and becomes the weights carried to frame k + 1;
//! * the **first** frame, and a frame whose carried weights no longer fit it, takes the
//!   two-pass form with its own weights ([`Pass::Own`], and [`Restart`] says why): the VIS
//!   illumination class changed ([`crate::scene::Illumination`], from the same band statistics
//!   the scene analysis uses), the covariance's pixel count (the grid, or the crop of the
//!   skip plan) changed by more than [`SequenceParams::size_change_percent`], or the method's
//!   parameters changed.
//!
//! **Skip windows over the sequence.** With scene skipping (`Roi`, `All`), the target boxes
//! of the last [`SequenceParams::window_frames`] frames (5 by default) are joined to the
//! frame's own before the skip plan is made, for every method: a target going dim (the
//! terminator, the eclipse entry, a cold side at the level of space) is still held by the boxes
//! of the frames that saw it. The caller's window (`SkipPolicy::Window`) is taken as given.
//!
//! The rule is the same in the whole-frame pipeline ([`crate::pipeline::fuse_in_sequence`],
//! with or without scene skipping: a crop's weights are carried to the next crop) and in strips
//! ([`crate::strips::fuse_strips_in_sequence`]): the two give the same bytes for the same
//! sequence of frames, and a frame fused with carried weights equal to its own is the
//! per-frame fusion bit for bit. Only ADF (both variants) carries weights; the other methods
//! are fused per frame ([`Pass::PerFrame`]) and leave nothing carried (IFEVIP's quadtree,
//! gain and entropy ratio are frame-global too, but its three strip passes are not carried:
//! see `BENCHMARKS.md`).
//!
//! ```
//! use fusion_nostd::pipeline::{FuseConfig, Method, fuse, fuse_in_sequence};
//! use fusion_nostd::sequence::{Pass, Restart, Sequence, SequenceParams};
//! use fusion_nostd::{AdfParams, Frame, Scratch};
//!
//! let mut scratch: Box<Scratch<{ 64 * 64 }>> = Box::new(Scratch::new());
//! let config = FuseConfig { method: Method::Adf(AdfParams::default()), ..FuseConfig::default() };
//! let mut seq = Sequence::new(SequenceParams::default());
//! let frame = |k: usize| {
//!     let (mut vis, mut tir) = (Frame::<u8, 64, 64>::filled(0), Frame::<u8, 64, 64>::filled(0));
//!     for (i, (v, t)) in vis.pixels_mut().iter_mut().zip(tir.pixels_mut()).enumerate() {
//!         *v = ((i * 7 + k * 13) % 251) as u8;
//!         *t = ((i / 64 * 3 + i % 64 + k) % 200) as u8;
//!     }
//!     (vis, tir)
//! };
//! let (mut out, mut alone) = (Frame::<u8, 64, 64>::filled(0), Frame::<u8, 64, 64>::filled(0));
//! for k in 0..3 {
//!     let (vis, tir) = frame(k);
//!     fuse_in_sequence(vis.view(), tir.view(), out.view_mut(), &mut scratch.view_mut(), &config, &mut seq)?;
//!     let step = seq.last_step().unwrap();
//!     fuse(vis.view(), tir.view(), alone.view_mut(), &mut scratch.view_mut(), &config)?;
//!     if k == 0 {
//!         // The first frame: its own weights, the per-frame fusion's bytes.
//!         assert_eq!(step.pass, Pass::Own(Restart::First));
//!         assert_eq!(out.pixels(), alone.pixels());
//!     } else {
//!         // Later frames: the previous frame's weights.
//!         assert_eq!(step.pass, Pass::Carried);
//!         assert_ne!(step.p_ir_used_q30, step.p_ir_own_q30);
//!     }
//! }
//! # Ok::<(), fusion_nostd::Error>(())
//! ```

use crate::Error;
use crate::methods::Guards;
use crate::methods::adf::AdfParams;
use crate::scene::{Illumination, Rect, Scene};

/// Most frames whose target boxes a sequence remembers ([`SequenceParams::window_frames`]).
pub const MAX_WINDOW_FRAMES: usize = 8;

/// When carried weights are given up for the frame's own, and how far back the skip windows
/// look.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SequenceParams {
    /// Largest change of the covariance's pixel count between two frames (the grid, or the
    /// skip plan's crop) that still carries the weights, per cent of the smaller count
    /// (`100..`; 150: a crop may grow or shrink by up to 1.5× in area). A larger change takes
    /// the two-pass form ([`Restart::Size`]).
    pub size_change_percent: u16,
    /// With scene skipping (`Roi`, `All`): the target boxes of this many previous frames are
    /// joined to the frame's own (`0..=`[`MAX_WINDOW_FRAMES`]; 0: the frame's own alone). A
    /// target going dim — the terminator, the eclipse entry, a cold side at the level of space
    /// — is then still held by the boxes of the frames that saw it. Every method.
    pub window_frames: u8,
}

impl Default for SequenceParams {
    fn default() -> Self {
        Self { size_change_percent: 150, window_frames: 5 }
    }
}

impl SequenceParams {
    /// Checks every field's range ([`Error::InvalidParameter`] names the field).
    pub fn validate(&self) -> Result<(), Error> {
        if self.size_change_percent < 100 {
            return Err(Error::InvalidParameter { name: "size_change_percent" });
        }
        if usize::from(self.window_frames) > MAX_WINDOW_FRAMES {
            return Err(Error::InvalidParameter { name: "window_frames" });
        }
        Ok(())
    }
}

/// The target boxes of the last frames fused with skipping (the scene analysis's own, both
/// bands and TIR alone), newest last, on one grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Boxes {
    grid: (usize, usize),
    target: [Option<Rect>; MAX_WINDOW_FRAMES],
    target_tir: [Option<Rect>; MAX_WINDOW_FRAMES],
    len: usize,
}

impl Boxes {
    const EMPTY: Boxes = Boxes {
        grid: (0, 0),
        target: [None; MAX_WINDOW_FRAMES],
        target_tir: [None; MAX_WINDOW_FRAMES],
        len: 0,
    };
}

/// Why a frame of a sequence took its own weights (the two-pass form).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Restart {
    /// Nothing carried: the sequence's first frame (or the first after [`Sequence::reset`],
    /// or after a frame of another method).
    First,
    /// The VIS illumination class differs from the previous frame's.
    Illumination,
    /// The covariance's pixel count changed by more than
    /// [`SequenceParams::size_change_percent`].
    Size,
    /// The method's parameters differ from the previous frame's.
    Method,
}

/// How a frame of a sequence was fused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Pass {
    /// With the weights carried from the previous frame: one pass.
    Carried,
    /// With the frame's own weights (the two-pass form in strips), and why.
    Own(Restart),
    /// Fused per frame: the method carries nothing (TSIFSD, IFEVIP, the adaptive method; the
    /// carried weights are dropped), or ADF's skip plan found nothing to fuse (the frame is its
    /// background value; the carried weights are kept).
    PerFrame,
}

/// What the last frame of a [`Sequence`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SequenceStep {
    /// Carried, own, or per frame.
    pub pass: Pass,
    /// The VIS illumination class the rule compared (`None` for [`Pass::PerFrame`]).
    pub illumination: Option<Illumination>,
    /// The covariance's pixel count (0 for [`Pass::PerFrame`]).
    pub pixels: usize,
    /// ADF's IR weight the frame was fused with, Q30 (0 for [`Pass::PerFrame`]).
    pub p_ir_used_q30: i64,
    /// ADF's IR weight of the frame's own covariance, Q30: what the per-frame fusion uses, and
    /// what is carried to the next frame (0 for [`Pass::PerFrame`]).
    pub p_ir_own_q30: i64,
}

/// The weights a frame leaves for the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Carry {
    method: AdfParams,
    illumination: Illumination,
    pixels: usize,
    p_ir_q30: i64,
    guards: Guards,
}

/// A frame's place in a [`Sequence`]: the sequence and the frame's VIS illumination class
/// (what the carry rule compares). The methods that carry weights pick and record them
/// through it (ADF: `methods::adf`).
pub(crate) struct Link<'s> {
    pub(crate) seq: &'s mut Sequence,
    pub(crate) illumination: Illumination,
}

/// What a frame of ADF is, for the carry rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct FrameKey {
    pub(crate) method: AdfParams,
    pub(crate) illumination: Illumination,
    pub(crate) pixels: usize,
}

/// A sequence's state: the weights the last ADF frame leaves for the next (a few words; the
/// caller owns it, e.g. `static` on a firmware). See the module docs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sequence {
    params: SequenceParams,
    carry: Option<Carry>,
    last: Option<SequenceStep>,
    boxes: Boxes,
}

impl Default for Sequence {
    fn default() -> Self {
        Self::new(SequenceParams::default())
    }
}

impl Sequence {
    /// A sequence with nothing carried yet.
    pub const fn new(params: SequenceParams) -> Self {
        Self { params, carry: None, last: None, boxes: Boxes::EMPTY }
    }

    /// Forgets the carried weights and the remembered target boxes: the next frame takes its
    /// own ([`Restart::First`]).
    pub fn reset(&mut self) {
        self.carry = None;
        self.last = None;
        self.boxes = Boxes::EMPTY;
    }

    /// The scene analysis of a frame fused with skipping, its target boxes joined with those
    /// of the last [`SequenceParams::window_frames`] frames on the same grid; the frame's own
    /// boxes are remembered for the next.
    pub(crate) fn widen(&mut self, mut scene: Scene) -> Scene {
        let n = usize::from(self.params.window_frames).min(MAX_WINDOW_FRAMES);
        if n == 0 {
            return scene;
        }
        let b = &mut self.boxes;
        if b.grid != scene.grid {
            *b = Boxes { grid: scene.grid, ..Boxes::EMPTY };
        }
        let (own, own_tir) = (scene.target, scene.target_tir);
        let kept = b.len.min(n);
        let first = b.len - kept;
        for k in first..b.len {
            let (t, tt) = (b.target.get(k).copied().flatten(), b.target_tir.get(k).copied().flatten());
            scene.target = Rect::join(scene.target, t);
            scene.target_tir = Rect::join(scene.target_tir, tt);
        }
        // Remember this frame's own boxes (the newest `n`, oldest dropped first).
        if b.len == MAX_WINDOW_FRAMES {
            b.target.rotate_left(1);
            b.target_tir.rotate_left(1);
            b.len -= 1;
        }
        if let (Some(t), Some(tt)) = (b.target.get_mut(b.len), b.target_tir.get_mut(b.len)) {
            (*t, *tt) = (own, own_tir);
            b.len += 1;
        }
        scene
    }

    /// The rule's parameters.
    pub fn params(&self) -> SequenceParams {
        self.params
    }

    /// What the last frame fused in this sequence did (`None` before the first, or when the
    /// last call failed).
    pub fn last_step(&self) -> Option<SequenceStep> {
        self.last
    }

    /// Whether the next ADF frame `key` would be fused with carried weights (one pass): the
    /// weights and their guards, else why not.
    pub(crate) fn carried(&self, key: &FrameKey) -> Result<(i64, Guards), Restart> {
        let c = self.carry.as_ref().ok_or(Restart::First)?;
        if c.method != key.method {
            return Err(Restart::Method);
        }
        if c.illumination != key.illumination {
            return Err(Restart::Illumination);
        }
        let (lo, hi) = (c.pixels.min(key.pixels) as u128, c.pixels.max(key.pixels) as u128);
        if hi * 100 > lo * u128::from(self.params.size_change_percent) {
            return Err(Restart::Size);
        }
        Ok((c.p_ir_q30, c.guards))
    }

    /// Records an ADF frame: its own weights are carried to the next frame.
    pub(crate) fn record(&mut self, key: &FrameKey, pass: Pass, used: i64, own: (i64, Guards)) {
        self.carry = Some(Carry {
            method: key.method,
            illumination: key.illumination,
            pixels: key.pixels,
            p_ir_q30: own.0,
            guards: own.1,
        });
        self.last = Some(SequenceStep {
            pass,
            illumination: Some(key.illumination),
            pixels: key.pixels,
            p_ir_used_q30: used,
            p_ir_own_q30: own.0,
        });
    }

    /// Records a frame of a method that carries nothing: the carried weights are dropped (the
    /// next ADF frame starts afresh).
    pub(crate) fn record_per_frame(&mut self) {
        self.carry = None;
        self.last = Some(SequenceStep {
            pass: Pass::PerFrame,
            illumination: None,
            pixels: 0,
            p_ir_used_q30: 0,
            p_ir_own_q30: 0,
        });
    }

    /// Records an ADF frame the skip plan filled with its background value alone (no target):
    /// no weights used, the carry kept for the next frame.
    pub(crate) fn record_unfused(&mut self) {
        self.last = Some(SequenceStep {
            pass: Pass::PerFrame,
            illumination: None,
            pixels: 0,
            p_ir_used_q30: 0,
            p_ir_own_q30: 0,
        });
    }

    /// Runs one frame's fusion `fuse` in this sequence (the pipeline's and the strips' entry
    /// points): checks the parameters, records a frame of a method that carries nothing (or an
    /// ADF frame with nothing to fuse), and on an error puts the sequence back as it was.
    pub(crate) fn frame<R>(
        &mut self,
        carries: bool,
        fuse: impl FnOnce(&mut Sequence) -> Result<R, Error>,
    ) -> Result<R, Error> {
        self.clear_step();
        self.params.validate()?;
        let before = *self;
        let result = fuse(self);
        match &result {
            Ok(_) if !carries => self.record_per_frame(),
            Ok(_) if self.last.is_none() => self.record_unfused(),
            Ok(_) => {}
            Err(_) => {
                *self = before;
                self.clear_step();
            }
        }
        result
    }

    /// Marks the last call as failed (nothing to report; the carry is kept as it was).
    pub(crate) fn clear_step(&mut self) {
        self.last = None;
    }
}
