//! The target model as a model-based tracker knows it: its shape, rendered at the tracker's
//! *estimated* pose, never at the true one.
//!
//! A tracker of a known, uncooperative target gets the 3D position of a new feature by
//! casting its pixel's ray against the CAD model placed at the current pose estimate; an error
//! in that estimate goes into the point and from there into every later pose, as on board.
//! Here the ray-traced scene of the renderer plays the CAD model (the same triangles; the
//! surface detail is texture, not shape).

use render_host::glam::{DMat3, DQuat, DVec2, DVec3, Mat3, Vec3};
use render_host::{Camera, Pose, Scene};

/// Offset of the four neighbour rays of the depth-edge test, px.
pub const EDGE_PROBE_PX: f64 = 3.0;
/// Largest relative depth difference between a feature's ray and its neighbours: beyond it the
/// feature sits on a depth edge (the outline against space, or one part in front of another)
/// and its 3D position is ambiguous.
pub const EDGE_DEPTH_TOLERANCE: f64 = 0.03;

/// The camera `intrinsics` (size, focal length, principal point, distortion) at an estimated
/// pose: camera → target attitude and position in the target frame.
pub fn camera_at(intrinsics: &Camera, attitude: DQuat, position: DVec3) -> Camera {
    let m = DMat3::from_quat(attitude.normalize());
    let rotation = Mat3::from_cols(m.x_axis.as_vec3(), m.y_axis.as_vec3(), m.z_axis.as_vec3());
    Camera { pose: Pose { position: position.as_vec3(), rotation }, ..*intrinsics }
}

/// Normalised image coordinates `((u − cx)/f, (v − cy)/f)` of the continuous image position
/// `(u, v)` (pixel centres at `x + 0.5`), the lens's distortion removed: what PnP takes.
pub fn normalised(cam: &Camera, u: f64, v: f64) -> DVec2 {
    if cam.dist != [0.0; 5] {
        let (x, y) = cam.normalised(u as f32, v as f32);
        return DVec2::new(f64::from(x), f64::from(y));
    }
    let f = f64::from(cam.focal_px);
    DVec2::new((u - f64::from(cam.cx)) / f, (v - f64::from(cam.cy)) / f)
}

/// A point on the model, as back-projection finds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelPoint {
    /// The point, target frame, m.
    pub point: DVec3,
    /// The face it lies on (index into the scene's faces).
    pub face: u32,
    /// The face's outward unit normal, target frame.
    pub normal: DVec3,
}

/// The target's shape.
pub struct TargetModel<'a> {
    scene: &'a Scene,
}

impl<'a> TargetModel<'a> {
    /// The model of a scene.
    pub fn new(scene: &'a Scene) -> Self {
        TargetModel { scene }
    }

    fn range(&self, cam: &Camera, u: f64, v: f64) -> Option<f64> {
        let dir = cam.ray_dir(u as f32, v as f32);
        self.scene.intersect(cam.pose.position, dir, 0.0).map(|h| f64::from(h.t))
    }

    /// The model face seen at continuous image position `(u, v)` by `cam`.
    pub fn face_at(&self, cam: &Camera, u: f64, v: f64) -> Option<u32> {
        let dir = cam.ray_dir(u as f32, v as f32);
        self.scene.intersect(cam.pose.position, dir, 0.0).map(|h| h.face)
    }

    /// The model point seen at continuous image position `(u, v)` (pixel centres at
    /// `x + 0.5`) by the camera `cam`, when the ray hits the model away from a depth edge
    /// ([`EDGE_PROBE_PX`], [`EDGE_DEPTH_TOLERANCE`]).
    pub fn back_project(&self, cam: &Camera, u: f64, v: f64) -> Option<ModelPoint> {
        let dir = cam.ray_dir(u as f32, v as f32);
        let hit = self.scene.intersect(cam.pose.position, dir, 0.0)?;
        let t = f64::from(hit.t);
        let d = EDGE_PROBE_PX;
        for (du, dv) in [(d, 0.0), (-d, 0.0), (0.0, d), (0.0, -d)] {
            let tn = self.range(cam, u + du, v + dv)?;
            if (tn - t).abs() > EDGE_DEPTH_TOLERANCE * t {
                return None;
            }
        }
        Some(ModelPoint {
            point: cam.pose.position.as_dvec3() + dir.as_dvec3() * t,
            face: hit.face,
            normal: hit.normal.as_dvec3().normalize(),
        })
    }

    /// Whether the target-frame point `x` is seen by `cam`: in front of it, inside the image
    /// and not hidden behind another part of the model.
    pub fn visible(&self, cam: &Camera, x: DVec3) -> bool {
        let Some((u, v)) = cam.project(x.as_vec3()) else { return false };
        if u < 0.0 || v < 0.0 || u >= cam.width as f32 || v >= cam.height as f32 {
            return false;
        }
        let origin = cam.pose.position;
        let to = x.as_vec3() - origin;
        let dist = to.length();
        let dir: Vec3 = to / dist;
        !self.scene.occluded(origin, dir, 0.0, dist * (1.0 - 1e-3) - self.scene.epsilon())
    }

    /// The image box `(x0, y0, x1, y1)` (px, clamped to the image) holding the model's bounding
    /// sphere seen by `cam`, grown by `margin` of its size; `None` when it is behind the camera
    /// or outside the image.
    pub fn image_box(&self, cam: &Camera, margin: f64) -> Option<(u32, u32, u32, u32)> {
        let c = self.scene.centre;
        let local = cam.pose.rotation.transpose() * (c - cam.pose.position);
        let r = f64::from(self.scene.radius);
        let z = f64::from(local.z);
        if z <= r * 1.01 {
            return None;
        }
        let (u, v) = cam.project(c)?;
        let half = f64::from(cam.focal_px) * r / (z * z - r * r).sqrt() * (1.0 + margin);
        let clamp = |a: f64, hi: u32| a.clamp(0.0, f64::from(hi)) as u32;
        let (x0, x1) = (clamp(f64::from(u) - half, cam.width), clamp(f64::from(u) + half, cam.width));
        let (y0, y1) = (clamp(f64::from(v) - half, cam.height), clamp(f64::from(v) + half, cam.height));
        (x1 > x0 && y1 > y0).then_some((x0, y0, x1, y1))
    }
}

/// The zeroth and first moments of a target's image: its area (px²) and centroid (px, pixel
/// centres at `x + 0.5`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Silhouette {
    /// Area, px².
    pub area: f64,
    /// Centroid x.
    pub cx: f64,
    /// Centroid y.
    pub cy: f64,
}

impl TargetModel<'_> {
    /// The model's silhouette seen by `cam` inside `bbox`, ray-cast on a grid of `step` px.
    pub fn silhouette(&self, cam: &Camera, bbox: (u32, u32, u32, u32), step: u32) -> Option<Silhouette> {
        let (x0, y0, x1, y1) = bbox;
        let step = step.max(1);
        let (mut n, mut sx, mut sy) = (0f64, 0f64, 0f64);
        for y in (y0..y1).step_by(step as usize) {
            for x in (x0..x1).step_by(step as usize) {
                let (u, v) = (x as f32 + 0.5, y as f32 + 0.5);
                if self.scene.intersect(cam.pose.position, cam.ray_dir(u, v), 0.0).is_some() {
                    n += 1.0;
                    sx += f64::from(u);
                    sy += f64::from(v);
                }
            }
        }
        (n > 0.0).then(|| Silhouette { area: n * f64::from(step * step), cx: sx / n, cy: sy / n })
    }

    /// The camera-frame position of the model's reference point (the scene centre) seen by
    /// `cam`, m.
    pub fn centre_in_camera(&self, cam: &Camera) -> DVec3 {
        (cam.pose.rotation.transpose() * (self.scene.centre - cam.pose.position)).as_dvec3()
    }

    /// The scene centre, target frame.
    pub fn centre(&self) -> DVec3 {
        self.scene.centre.as_dvec3()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use render_host::sequence::{SequenceConfig, SequenceName, camera_pose, state};

    /// At the true pose a back-projected point re-projects to its pixel and is visible; the
    /// depth edge test refuses a ray on the outline; the box holds every target pixel.
    #[test]
    fn back_projection_reprojects_and_the_box_holds_the_target() {
        let scene = Scene::tango().expect("scene");
        let cfg = SequenceConfig::new(SequenceName::Flyaround);
        let pose = camera_pose(&state(&cfg, 5), &scene);
        let cam = Camera::study(256, pose);
        let q = DQuat::from_mat3(&pose.rotation.as_dmat3());
        let est = camera_at(&cam, q, pose.position.as_dvec3());
        let model = TargetModel::new(&scene);
        let depth = render_host::truth::depth(&scene, &cam);
        let (mut inner, mut edges) = (0, 0);
        let (x0, y0, x1, y1) = model.image_box(&est, 0.0).expect("box");
        for y in 0..256u32 {
            for x in 0..256u32 {
                let hit = depth[(y * 256 + x) as usize].is_some();
                if hit {
                    assert!(x >= x0 && x < x1 && y >= y0 && y < y1, "({x}, {y}) outside the box");
                }
                if x % 4 != 0 || y % 4 != 0 || !hit {
                    continue;
                }
                let (u, v) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
                match model.back_project(&est, u, v).map(|m| m.point) {
                    Some(p) => {
                        let (pu, pv) = est.project(p.as_vec3()).expect("in front");
                        assert!((f64::from(pu) - u).abs() < 1e-2 && (f64::from(pv) - v).abs() < 1e-2);
                        assert!(model.visible(&est, p));
                        inner += 1;
                    }
                    None => edges += 1,
                }
            }
        }
        assert!(inner > 50 && edges > 0, "{inner} inner, {edges} on edges");
        // A point 20 cm behind a visible surface point, on the same ray, is hidden by it.
        let (u, v) = (f64::from(x0 + x1) / 2.0, f64::from(y0 + y1) / 2.0);
        if let Some(p) = model.back_project(&est, u, v).map(|m| m.point) {
            let dir = (p - est.pose.position.as_dvec3()).normalize();
            assert!(!model.visible(&est, p + dir * 0.2));
        }
    }
}
