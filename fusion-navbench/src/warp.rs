//! Model-warped templates: a track's window, cut from the frame it was anchored in, warped by
//! the plane of the model face it lies on to where the predicted pose puts it, and matched
//! there by Gauss–Newton on position, gain and bias.
//!
//! Translation-only Lucas–Kanade compares the anchor's window with an upright window of the
//! new frame. When the view turns, a face's patch is foreshortened (on the fly-around the view
//! turns 3° per frame: a face seen at 60° shrinks by 9 % across per frame), and the window's
//! best upright match slides by a fraction of a pixel per frame in the direction of its texture
//! — the track leaves its 3D point. With the model the tracker knows how the patch deforms: the
//! anchor pixels are cast onto the face's plane from the camera at the anchor estimate and
//! projected with the camera at the prediction (the plane's homography, exact per pixel), so
//! only the position is left to solve. A pose error changes the warp only to second order.
//!
//! Only window pixels whose ray hits the same face in the anchor frame enter the template:
//! a feature near an edge keeps the half of its window that lies on its face.
//!
//! Images: pixel centres at integer coordinates (as `optical-flow-lk`); cameras: pixel centres
//! at `x + 0.5` (as `render_host::Camera`).

use crate::model::TargetModel;
use image::GrayImage;
use nalgebra::{Matrix4, Vector4};
use render_host::Camera;
use render_host::glam::{DVec2, DVec3};

/// Half the template's side, px (a 21 × 21 window, as the Lucas–Kanade one).
pub const HALF_WINDOW: i32 = 10;
/// Fewest window pixels on the feature's face for a template.
pub const MIN_TEMPLATE_PIXELS: usize = 120;
/// Gauss–Newton iterations at most.
pub const MAX_ITERATIONS: usize = 20;
/// Gauss–Newton stops when the position moves less than this, px.
pub const CONVERGED_PX: f64 = 0.005;
/// Smallest normalised cross-correlation between the template and the warped window at the
/// solution: below it the match is refused (occlusion, a glint, a wrong minimum).
pub const MIN_ZNCC: f64 = 0.8;

/// A frame as the matcher samples it: grey values and their central-difference gradients.
pub struct GradientImage {
    width: usize,
    height: usize,
    value: Vec<f32>,
    gx: Vec<f32>,
    gy: Vec<f32>,
}

impl GradientImage {
    /// The grey values of `img` and their gradients (central differences, one-sided at the
    /// border).
    pub fn new(img: &GrayImage) -> Self {
        let (w, h) = (img.width() as usize, img.height() as usize);
        let value: Vec<f32> = img.as_raw().iter().map(|&p| f32::from(p)).collect();
        let mut gx = vec![0f32; w * h];
        let mut gy = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let (xl, xr) = (x.saturating_sub(1), (x + 1).min(w - 1));
                let (yu, yd) = (y.saturating_sub(1), (y + 1).min(h - 1));
                gx[y * w + x] = (value[y * w + xr] - value[y * w + xl]) / (xr - xl).max(1) as f32;
                gy[y * w + x] = (value[yd * w + x] - value[yu * w + x]) / (yd - yu).max(1) as f32;
            }
        }
        GradientImage { width: w, height: h, value, gx, gy }
    }

    /// Value and gradient at `(x, y)` (bilinear), or `None` outside the image.
    fn sample(&self, x: f64, y: f64) -> Option<(f64, f64, f64)> {
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        if x0 + 1 >= self.width || y0 + 1 >= self.height {
            return None;
        }
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let i = y0 * self.width + x0;
        let w = self.width;
        let lerp = |p: &[f32]| {
            let top = f64::from(p[i]) * (1.0 - fx) + f64::from(p[i + 1]) * fx;
            let bottom = f64::from(p[i + w]) * (1.0 - fx) + f64::from(p[i + w + 1]) * fx;
            top * (1.0 - fy) + bottom * fy
        };
        Some((lerp(&self.value), lerp(&self.gx), lerp(&self.gy)))
    }
}

/// A feature's window in its anchor frame, on its model face.
#[derive(Clone, Debug, PartialEq)]
pub struct Template {
    /// The feature's position in the anchor frame (pixel centres at integers).
    pub centre: (f32, f32),
    /// Offsets from the centre of the window pixels on the feature's face, px.
    offsets: Vec<(i32, i32)>,
    /// Their grey values.
    values: Vec<f64>,
    /// The face's plane in the target frame: a point on it and its normal.
    plane: (DVec3, DVec3),
    /// The camera at the anchor estimate.
    anchor: Camera,
}

impl Template {
    /// The template of the feature at integer position `centre` of `frame` (the frame seen by
    /// `anchor`, the camera at the estimate), lying at `point` on the model face `face` with
    /// outward normal `normal`; `None` when too few window pixels lie on that face.
    pub fn cut(
        frame: &GrayImage,
        anchor: &Camera,
        model: &TargetModel,
        centre: (u32, u32),
        point: DVec3,
        (face, normal): (u32, DVec3),
    ) -> Option<Template> {
        let (w, h) = (frame.width() as i32, frame.height() as i32);
        let (cx, cy) = (centre.0 as i32, centre.1 as i32);
        if cx < HALF_WINDOW || cy < HALF_WINDOW || cx + HALF_WINDOW >= w || cy + HALF_WINDOW >= h {
            return None;
        }
        let mut offsets = Vec::new();
        let mut values = Vec::new();
        for dy in -HALF_WINDOW..=HALF_WINDOW {
            for dx in -HALF_WINDOW..=HALF_WINDOW {
                let (x, y) = (cx + dx, cy + dy);
                if model.face_at(anchor, f64::from(x) + 0.5, f64::from(y) + 0.5) != Some(face) {
                    continue;
                }
                offsets.push((dx, dy));
                values.push(f64::from(frame.get_pixel(x as u32, y as u32).0[0]));
            }
        }
        (offsets.len() >= MIN_TEMPLATE_PIXELS).then_some(Template {
            centre: (centre.0 as f32, centre.1 as f32),
            offsets,
            values,
            plane: (point, normal),
            anchor: *anchor,
        })
    }

    /// Where the anchor-frame position `a` (pixel centres at integers) lands in the frame seen
    /// by `current`, through the face's plane.
    fn map(&self, current: &Camera, a: DVec2) -> Option<DVec2> {
        let dir = self.anchor.ray_dir(a.x as f32 + 0.5, a.y as f32 + 0.5).as_dvec3();
        let origin = self.anchor.pose.position.as_dvec3();
        let (p, n) = self.plane;
        let denom = dir.dot(n);
        if denom.abs() < 1e-9 {
            return None;
        }
        let t = (p - origin).dot(n) / denom;
        if t <= 0.0 {
            return None;
        }
        let (u, v) = current.project((origin + dir * t).as_vec3())?;
        Some(DVec2::new(f64::from(u) - 0.5, f64::from(v) - 0.5))
    }

    /// The window's offsets from its centre in the frame seen by `current`.
    fn warped_offsets(&self, current: &Camera) -> Option<Vec<DVec2>> {
        let c = DVec2::new(f64::from(self.centre.0), f64::from(self.centre.1));
        let mid = self.map(current, c)?;
        self.offsets
            .iter()
            .map(|&(dx, dy)| Some(self.map(current, c + DVec2::new(f64::from(dx), f64::from(dy)))? - mid))
            .collect()
    }

    /// The feature's position in `frame` (seen by `current`, the camera at the prediction),
    /// refined from `start`: Gauss–Newton on the position, a gain and a bias over the warped
    /// window. `None` when it leaves the image, does not converge or correlates below
    /// [`MIN_ZNCC`].
    pub fn refine(&self, frame: &GradientImage, current: &Camera, start: (f32, f32)) -> Option<(f32, f32)> {
        let offsets = self.warped_offsets(current)?;
        // Parameters: centre x, y, gain, bias.
        let mut c = DVec2::new(f64::from(start.0), f64::from(start.1));
        let (mut gain, mut bias) = (1.0f64, 0.0f64);
        let mut converged = false;
        for _ in 0..MAX_ITERATIONS {
            let mut jtj = Matrix4::<f64>::zeros();
            let mut jtr = Vector4::<f64>::zeros();
            for (o, &t) in offsets.iter().zip(&self.values) {
                let q = c + *o;
                let (i, ix, iy) = frame.sample(q.x, q.y)?;
                let r = gain * i + bias - t;
                let j = Vector4::new(gain * ix, gain * iy, i, 1.0);
                jtj += j * j.transpose();
                jtr += j * r;
            }
            let step = jtj.try_inverse()? * jtr;
            c -= DVec2::new(step[0], step[1]);
            gain -= step[2];
            bias -= step[3];
            if !(gain > 0.2 && gain < 5.0) {
                return None;
            }
            if step[0].hypot(step[1]) < CONVERGED_PX {
                converged = true;
                break;
            }
        }
        if !converged {
            return None;
        }
        let samples: Option<Vec<f64>> =
            offsets.iter().map(|o| frame.sample(c.x + o.x, c.y + o.y).map(|s| s.0)).collect();
        (zncc(&samples?, &self.values) >= MIN_ZNCC).then_some((c.x as f32, c.y as f32))
    }
}

/// Zero-mean normalised cross-correlation of two equally long samples (0 when either is flat).
fn zncc(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa <= 0.0 || sbb <= 0.0 { 0.0 } else { sab / (saa * sbb).sqrt() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracker::smooth;
    use optical_flow_lk::{DetectorContext, Grid};
    use render_host::sequence::{SEQUENCE_SAMPLES, SequenceConfig, SequenceName, camera_pose, state};
    use render_host::{Scene, VisParams, render_vis};

    /// Two consecutive frames of the fly-around (3° of view turn), rendered as the sequences
    /// are (4 × 4 sub-pixels): matched from a start 1.5 px off, every template lands on its
    /// 3D point's projection at the second frame's true pose (the rendered ground truth) to a
    /// tenth of a pixel in the median; and a template seen by an unmoved camera maps onto
    /// itself.
    #[test]
    fn warped_templates_land_on_their_points() {
        let scene = Scene::tango().expect("scene").with_surface_detail(0);
        let model = TargetModel::new(&scene);
        let cfg = SequenceConfig::new(SequenceName::Flyaround);
        let size = 512;
        let params = VisParams { specular: false, samples: SEQUENCE_SAMPLES, ..VisParams::light() };
        let frame = |i: usize| {
            let cam = Camera::study(size, camera_pose(&state(&cfg, i), &scene));
            let img = render_vis(&scene, &cam, &params);
            let gray = GrayImage::from_raw(size, size, img.to_gray_u8().data).expect("size");
            (cam, smooth(&gray))
        };
        let (ca, a) = frame(100);
        let (cb, b) = frame(101);
        let (x0, y0, x1, y1) = model.image_box(&ca, 0.1).expect("box");
        let crop = image::imageops::crop_imm(&a, x0, y0, x1 - x0, y1 - y0).to_image();
        let grid = Grid { cols: 6, rows: 6, max_per_cell: 8 };
        let corners = DetectorContext::new().detect_grid(&crop, grid, 0.02, 5, &[]).to_vec();
        let gb = GradientImage::new(&b);
        let ga = GradientImage::new(&a);
        let mut residuals = Vec::new();
        for c in corners {
            let (x, y) = (c.x + x0, c.y + y0);
            let Some(hit) = model.back_project(&ca, f64::from(x) + 0.5, f64::from(y) + 0.5) else { continue };
            let Some(t) = Template::cut(&a, &ca, &model, (x, y), hit.point, (hit.face, hit.normal)) else {
                continue;
            };
            // The unmoved camera: the template finds itself where it was cut.
            let same = t.refine(&ga, &ca, (x as f32 + 0.7, y as f32 - 0.6)).expect("self match");
            assert!((same.0 - x as f32).hypot(same.1 - y as f32) < 0.05, "{same:?} vs ({x}, {y})");
            let (u, v) = cb.project(hit.point.as_vec3()).expect("in front");
            let truth = (u - 0.5, v - 0.5);
            if let Some(q) = t.refine(&gb, &cb, (truth.0 + 1.5, truth.1 - 1.0)) {
                residuals.push(f64::from((q.0 - truth.0).hypot(q.1 - truth.1)));
            }
        }
        residuals.sort_by(f64::total_cmp);
        assert!(residuals.len() >= 15, "{} templates matched", residuals.len());
        let median = residuals[residuals.len() / 2];
        assert!(median < 0.1, "median residual {median:.3} px over {}", residuals.len());
    }
}
