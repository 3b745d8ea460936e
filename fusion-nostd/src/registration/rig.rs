//! The map of an offset camera pair at a range: which thermal pixel each visible pixel sees.
//!
//! Two pinhole cameras with OpenCV's radial–tangential distortion (`k1, k2, p1, p2, k3`) and
//! the pose between them in `stereoCalibrate`'s convention, camera 1 = VIS, camera 2 = TIR:
//! `X_tir = R·X_vis + T` (metres). The target is taken to lie in the plane `Z_vis = range`
//! (perpendicular to the visible optical axis). For a visible pixel `(u, v)`:
//!
//! 1. undistort: `(u − cx)/fx, (v − cy)/fy` through OpenCV's fixed-point iteration
//!    (`undistortPoints`) to the ideal normalised ray `(x, y, 1)`;
//! 2. the plane: `X_vis = range·(x, y, 1)`, `X_tir = R·X_vis + T` — the plane-induced
//!    homography `H = R + T·(0, 0, 1)/range` of the normalised rays;
//! 3. distort `(X/Z, Y/Z)` with the thermal lens and project with its intrinsics.
//!
//! A full map is 6 bytes a visible pixel (6 MiB at 1024²), so it is never kept: [`RigMap`]
//! evaluates steps 1–3 exactly on a grid of nodes every `step` pixels (the expensive part,
//! 65 × 65 nodes at 1024² and step 16 — once per range), and [`RigMap::rows`] fills the
//! fixed-point map of any run of rows by bilinear interpolation between the nodes (a
//! strip's map, then [`super::remap`] that strip). Lens distortion and the homography are
//! smooth, so the interpolation error is far below the map's 1/32-pixel quantum on real
//! lenses (measured in `tests/tests/registration.rs` against OpenCV's functions).

use super::tables::{TAB_BITS, TAB_SIZE};
use crate::error::Error;
use core::num::NonZeroUsize;

/// One camera: pinhole intrinsics in pixels (OpenCV's camera matrix), distortion
/// `[k1, k2, p1, p2, k3]` in OpenCV's order, and its image size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Focal lengths, px.
    pub fx: f32,
    /// Focal length along y, px.
    pub fy: f32,
    /// Principal point x, px (pixel centres at integers, OpenCV's convention).
    pub cx: f32,
    /// Principal point y, px.
    pub cy: f32,
    /// `[k1, k2, p1, p2, k3]`.
    pub dist: [f32; 5],
    /// Image width, px.
    pub width: usize,
    /// Image height, px.
    pub height: usize,
}

/// A VIS/TIR camera pair: `X_tir = r·X_vis + t` (row-major rotation, metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rig {
    /// The visible camera (camera 1).
    pub vis: Camera,
    /// The thermal camera (camera 2).
    pub tir: Camera,
    /// Rotation from the visible to the thermal camera frame.
    pub r: [[f32; 3]; 3],
    /// Translation, metres.
    pub t: [f32; 3],
}

/// Iterations of the undistortion (OpenCV's `undistortPoints` stops after 5 by default; 20
/// take the residual of wide-angle lenses to below 10⁻⁶ of a pixel).
pub const UNDISTORT_ITERATIONS: usize = 20;

impl Camera {
    fn check(&self) -> Result<(), Error> {
        let finite = [self.fx, self.fy, self.cx, self.cy].iter().chain(&self.dist).all(|v| v.is_finite());
        if !finite {
            return Err(Error::NonFinite);
        }
        if !(self.fx > 0.0 && self.fy > 0.0) {
            return Err(Error::InvalidParameter { name: "focal length" });
        }
        crate::thermal::pixels(self.width, self.height).map(|_| ())
    }

    /// The ideal normalised ray of the (distorted) pixel `(u, v)`.
    pub fn undistort(&self, u: f32, v: f32) -> (f32, f32) {
        let [k1, k2, p1, p2, k3] = self.dist;
        let (x0, y0) = ((u - self.cx) / self.fx, (v - self.cy) / self.fy);
        let (mut x, mut y) = (x0, y0);
        for _ in 0..UNDISTORT_ITERATIONS {
            let r2 = x * x + y * y;
            let radial = 1.0 + ((k3 * r2 + k2) * r2 + k1) * r2;
            let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
            let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
            if radial == 0.0 {
                break;
            }
            x = (x0 - dx) / radial;
            y = (y0 - dy) / radial;
        }
        (x, y)
    }

    /// The pixel of the normalised ray `(x, y)` (distortion, then the intrinsics).
    pub fn project(&self, x: f32, y: f32) -> (f32, f32) {
        let [k1, k2, p1, p2, k3] = self.dist;
        let r2 = x * x + y * y;
        let radial = 1.0 + ((k3 * r2 + k2) * r2 + k1) * r2;
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        (self.fx * xd + self.cx, self.fy * yd + self.cy)
    }
}

impl Rig {
    /// Checks the pair: finite values, positive focal lengths, sizes within the core's limits.
    pub fn check(&self) -> Result<(), Error> {
        self.vis.check()?;
        self.tir.check()?;
        if !self.r.iter().flatten().chain(&self.t).all(|v| v.is_finite()) {
            return Err(Error::NonFinite);
        }
        Ok(())
    }

    /// The thermal pixel the visible pixel `(u, v)` sees on the plane `Z_vis = range`, or
    /// `None` when the plane point is behind the thermal camera.
    pub fn tir_position(&self, u: f32, v: f32, range: f32) -> Option<(f32, f32)> {
        let (x, y) = self.vis.undistort(u, v);
        let p = [range * x, range * y, range];
        let [r0, r1, r2] = self.r;
        let dot = |r: [f32; 3]| r[0] * p[0] + r[1] * p[1] + r[2] * p[2];
        let (xt, yt, zt) = (dot(r0) + self.t[0], dot(r1) + self.t[1], dot(r2) + self.t[2]);
        (zt > 0.0).then(|| self.tir.project(xt / zt, yt / zt))
    }
}

/// Nodes a [`RigMap`] of a `width × height` visible frame needs at `step` pixels.
pub const fn node_count(width: usize, height: usize, step: usize) -> usize {
    match step {
        0 => 0,
        s => (width.div_ceil(s) + 1) * (height.div_ceil(s) + 1),
    }
}

/// Default node spacing, px.
pub const NODE_STEP: usize = 16;

/// The thermal positions of a node grid over the visible frame at one range (see the module's
/// documentation); fills fixed-point maps row by row.
#[derive(Debug)]
pub struct RigMap<'a> {
    nodes: &'a [[f32; 2]],
    cols: NonZeroUsize,
    step: NonZeroUsize,
    width: usize,
    height: usize,
    tir: (usize, usize),
}

/// Positions behind the thermal camera are sent far outside its image (the remap's border).
const OUTSIDE: f32 = -4096.0;

/// `a + (b − a)·t` for both coordinates.
#[inline]
fn lerp(a: (f32, f32), b: (f32, f32), t: f32) -> (f32, f32) {
    (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t)
}

impl<'a> RigMap<'a> {
    /// Evaluates `rig` at `range` metres on nodes every `step` visible pixels into `nodes`
    /// (at least [`node_count`] entries). `Err` (nothing computed) for a bad rig, a range that
    /// is not positive and finite, `step` 0 or a short buffer.
    pub fn new(rig: &Rig, range: f32, step: usize, nodes: &'a mut [[f32; 2]]) -> Result<Self, Error> {
        rig.check()?;
        if !(range.is_finite() && range > 0.0) {
            return Err(Error::InvalidParameter { name: "range" });
        }
        let Some(step) = NonZeroUsize::new(step) else {
            return Err(Error::InvalidParameter { name: "node step" });
        };
        let (w, h) = (rig.vis.width, rig.vis.height);
        let needed = node_count(w, h, step.get());
        let got = nodes.len();
        let nodes = nodes.get_mut(..needed).ok_or(Error::BufferTooSmall { needed, got })?;
        let cols = NonZeroUsize::new(w.div_ceil(step.get()) + 1).unwrap_or(NonZeroUsize::MIN);
        for (i, n) in nodes.iter_mut().enumerate() {
            let (u, v) = (((i % cols) * step.get()) as f32, ((i / cols) * step.get()) as f32);
            let (x, y) = rig.tir_position(u, v, range).unwrap_or((OUTSIDE, OUTSIDE));
            *n = [x, y];
        }
        Ok(RigMap { nodes, cols, step, width: w, height: h, tir: (rig.tir.width, rig.tir.height) })
    }

    /// The visible frame's `(width, height)`.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The thermal frame's `(width, height)`.
    pub fn tir_size(&self) -> (usize, usize) {
        self.tir
    }

    /// The thermal position of visible pixel `(u, v)`, interpolated between the nodes (down
    /// the node columns first, then across: the same arithmetic as [`RigMap::rows`]).
    pub fn position(&self, u: usize, v: usize) -> (f32, f32) {
        let s = self.step;
        let (left, right) = self.row_ends(u / s, v);
        lerp(left, right, (u % s) as f32 / s.get() as f32)
    }

    /// The positions at visible row `v` of node columns `cu` and `cu + 1`.
    #[inline]
    fn row_ends(&self, cu: usize, v: usize) -> ((f32, f32), (f32, f32)) {
        let s = self.step;
        let (cv, fv) = (v / s, (v % s) as f32 / s.get() as f32);
        let at = |c: usize, r: usize| {
            let [x, y] = self.nodes.get(r * self.cols.get() + c).copied().unwrap_or([OUTSIDE; 2]);
            (x, y)
        };
        (lerp(at(cu, cv), at(cu, cv + 1), fv), lerp(at(cu + 1, cv), at(cu + 1, cv + 1), fv))
    }

    /// Fills the fixed-point map of visible rows `y0 .. y0 + rows` (`rows = frac.len() /
    /// width`): per pixel its position in 1/32 pixel, `xy` the integer part, `frac` the
    /// sub-pixel index `fy·32 + fx`. Row by row and node cell by node cell: the cell's two ends
    /// at the row in `f32` ([`RigMap::position`] at the cell's corners, clamped to ±4000 px),
    /// then across the cell in integers (Q12 of 1/32 pixel, the step truncated), so a pixel
    /// costs a few integer operations on every target (no FPU needed across the cell); the
    /// position is within 1/64 + 2·10⁻⁴ px of [`RigMap::position`].
    /// `Err` (nothing written) for arrays of different lengths or rows past the frame.
    pub fn rows(&self, y0: usize, xy: &mut [i16], frac: &mut [u16]) -> Result<(), Error> {
        let w = self.width;
        if xy.len() != 2 * frac.len() || !frac.len().is_multiple_of(w) {
            return Err(Error::InvalidParameter { name: "map rows (xy must be twice frac, whole rows)" });
        }
        let rows = frac.len().checked_div(w).unwrap_or(0);
        if y0 + rows > self.height {
            return Err(Error::InvalidParameter { name: "map rows past the frame" });
        }
        const Q: i32 = 12;
        let to_q = |p: f32| {
            let scaled = p.clamp(-4000.0, 4000.0) * (TAB_SIZE as f32 * (1 << Q) as f32);
            super::tables::round_even(scaled) as i32
        };
        let split = |q: i32| {
            let p32 = (q + (1 << (Q - 1))) >> Q;
            ((p32 >> TAB_BITS) as i16, (p32 & (TAB_SIZE as i32 - 1)) as u16)
        };
        // Chunk sizes provably non-zero (the width is, but not to the compiler: no panic path).
        let (s, row) = (self.step.get(), w.max(1));
        for (r, (row_xy, row_frac)) in
            xy.chunks_exact_mut((2 * row).max(1)).zip(frac.chunks_exact_mut(row)).enumerate()
        {
            let v = y0 + r;
            for (cu, (cell_xy, cell_frac)) in
                row_xy.chunks_mut((2 * s).max(1)).zip(row_frac.chunks_mut(s)).enumerate()
            {
                let (left, right) = self.row_ends(cu, v);
                let (lx, ly) = (to_q(left.0), to_q(left.1));
                let step = s as i32;
                let (dx, dy) = (
                    (to_q(right.0) - lx).checked_div(step).unwrap_or(0),
                    (to_q(right.1) - ly).checked_div(step).unwrap_or(0),
                );
                let (mut qx, mut qy) = (lx, ly);
                for (p, f) in cell_xy.chunks_exact_mut(2).zip(cell_frac.iter_mut()) {
                    let ((ix, fx), (iy, fy)) = (split(qx), split(qy));
                    if let [px, py] = p {
                        (*px, *py) = (ix, iy);
                    }
                    *f = fy * TAB_SIZE as u16 + fx;
                    (qx, qy) = (qx + dx, qy + dy);
                }
            }
        }
        Ok(())
    }
}
