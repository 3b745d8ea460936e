//! Pinhole cameras and poses.
//!
//! Both cameras of the study share one pose and the 35.45° field of view (SPEED's 17.6 mm lens
//! on an 11.25 mm square sensor): f = 1601.9 px at 1024², 800.95 px at 512², principal point at
//! the image centre. Pixel `(x, y)` covers `[x, x+1) × [y, y+1)` and its centre is at
//! `(x + 0.5, y + 0.5)`, so a 512² pixel covers exactly a 2 × 2 block of the 1024² image.
//! Camera axes: x right, y down, z forward (optical axis).
//!
//! A camera of an offset rig ([`Camera::from_rig`], [`crate::rig`]) has its own intrinsics and
//! OpenCV's radial–tangential lens distortion, undistorted and projected by the same code as
//! the core's registration (`fusion_nostd::registration::Camera`).

use glam::{Mat3, Quat, Vec3};
use serde::{Deserialize, Serialize};

/// Field of view of both cameras, degrees.
pub const FOV_DEG: f64 = 35.45;
/// Focal length in pixels at 1024² (scaled linearly with the image width).
pub const FOCAL_PX_1024: f64 = 1601.9;

/// Position and orientation of a camera in the target frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Camera centre, metres.
    pub position: Vec3,
    /// Camera-to-target rotation: its columns are the camera x (right), y (down) and z
    /// (forward) axes in the target frame.
    pub rotation: Mat3,
}

impl Pose {
    /// A camera at `eye` looking at `target`, with the image "up" (−y) as close to `up` as
    /// possible. Falls back to another up vector when `up` is parallel to the view direction.
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Pose {
        let z = (target - eye).normalize();
        let mut x = z.cross(up);
        if x.length_squared() < 1e-10 {
            x = z.cross(z.any_orthogonal_vector());
        }
        let x = x.normalize();
        let y = z.cross(x);
        Pose { position: eye, rotation: Mat3::from_cols(x, y, z) }
    }

    /// The optical axis (camera +z) in the target frame.
    pub fn forward(&self) -> Vec3 {
        self.rotation.z_axis
    }

    /// Camera-to-target rotation as a unit quaternion.
    pub fn quaternion(&self) -> Quat {
        Quat::from_mat3(&self.rotation)
    }
}

/// A pinhole camera: intrinsics plus a [`Pose`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length, pixels.
    pub focal_px: f32,
    /// Principal point x, pixels (continuous coordinates: pixel centres at `x + 0.5`).
    pub cx: f32,
    /// Principal point y, pixels.
    pub cy: f32,
    /// Lens distortion `[k1, k2, p1, p2, k3]` in OpenCV's model (zero: an ideal pinhole).
    pub dist: [f32; 5],
    /// Pose in the target frame.
    pub pose: Pose,
}

impl Camera {
    /// The study's camera for a square `size`² image: f = 1601.9 × size / 1024 px, principal
    /// point at the centre.
    pub fn study(size: u32, pose: Pose) -> Camera {
        Camera {
            width: size,
            height: size,
            focal_px: (FOCAL_PX_1024 * f64::from(size) / 1024.0) as f32,
            cx: size as f32 / 2.0,
            cy: size as f32 / 2.0,
            dist: [0.0; 5],
            pose,
        }
    }

    /// A camera of a rig (`fusion_nostd::registration::Camera`: OpenCV's intrinsics, pixel
    /// centres at integers) at `pose`; `Err` unless its pixels are square (`fx = fy`: the
    /// renderer has one focal length).
    pub fn from_rig(c: &fusion_nostd::registration::Camera, pose: Pose) -> anyhow::Result<Camera> {
        anyhow::ensure!(
            (c.fx - c.fy).abs() <= 1e-4 * c.fx,
            "the renderer takes square pixels: fx {} and fy {} differ",
            c.fx,
            c.fy
        );
        Ok(Camera {
            width: c.width as u32,
            height: c.height as u32,
            focal_px: c.fx,
            cx: c.cx + 0.5,
            cy: c.cy + 0.5,
            dist: c.dist,
            pose,
        })
    }

    /// The camera in the core's form (OpenCV's pixel convention), for its lens model.
    fn lens(&self) -> fusion_nostd::registration::Camera {
        fusion_nostd::registration::Camera {
            fx: self.focal_px,
            fy: self.focal_px,
            cx: self.cx - 0.5,
            cy: self.cy - 0.5,
            dist: self.dist,
            width: self.width as usize,
            height: self.height as usize,
        }
    }

    /// The ideal (undistorted) normalised image coordinates `(x/z, y/z)` of the ray through
    /// continuous image point `(u, v)`.
    pub fn normalised(&self, u: f32, v: f32) -> (f32, f32) {
        if self.dist == [0.0; 5] {
            ((u - self.cx) / self.focal_px, (v - self.cy) / self.focal_px)
        } else {
            // The core's undistortion (the registration's own lens model), OpenCV's convention.
            self.lens().undistort(u - 0.5, v - 0.5)
        }
    }

    /// Unit ray direction (target frame) through continuous image point `(u, v)`.
    pub fn ray_dir(&self, u: f32, v: f32) -> Vec3 {
        let (x, y) = self.normalised(u, v);
        (self.pose.rotation * Vec3::new(x, y, 1.0)).normalize()
    }

    /// Unit ray direction through the centre of pixel `(x, y)`.
    pub fn pixel_ray(&self, x: u32, y: u32) -> Vec3 {
        self.ray_dir(x as f32 + 0.5, y as f32 + 0.5)
    }

    /// The centres of an `n × n` grid of equal sub-pixels of pixel `(x, y)` (continuous
    /// coordinates), row by row; `n = 1` gives the pixel centre. Averaging a render over them
    /// integrates the pixel's area, as a detector does.
    pub fn subpixels(x: u32, y: u32, n: u32) -> impl Iterator<Item = (f32, f32)> {
        let n = n.max(1);
        (0..n).flat_map(move |j| {
            (0..n).map(move |i| {
                (x as f32 + (i as f32 + 0.5) / n as f32, y as f32 + (j as f32 + 0.5) / n as f32)
            })
        })
    }

    /// Continuous image coordinates of a target-frame point, or `None` behind the camera.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let c = self.pose.rotation.transpose() * (p - self.pose.position);
        if c.z <= 0.0 {
            return None;
        }
        if self.dist == [0.0; 5] {
            return Some((self.cx + self.focal_px * c.x / c.z, self.cy + self.focal_px * c.y / c.z));
        }
        let (u, v) = self.lens().project(c.x / c.z, c.y / c.z);
        Some((u + 0.5, v + 0.5))
    }

    /// Full field of view in degrees across the width.
    pub fn fov_deg(&self) -> f64 {
        2.0 * (f64::from(self.width) / 2.0 / f64::from(self.focal_px)).atan().to_degrees()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intrinsics_match_the_study() {
        let pose = Pose::look_at(Vec3::new(0.0, -5.0, 0.0), Vec3::ZERO, Vec3::Z);
        let vis = Camera::study(1024, pose);
        let tir = Camera::study(512, pose);
        assert!((vis.focal_px - 1601.9).abs() < 1e-3);
        assert!((tir.focal_px - 800.95).abs() < 1e-3);
        assert!((vis.fov_deg() - FOV_DEG).abs() < 0.01, "{}", vis.fov_deg());
    }

    #[test]
    fn pairs_align_to_the_pixel() {
        let pose = Pose::look_at(Vec3::new(3.0, -4.0, 2.0), Vec3::ZERO, Vec3::Z);
        let vis = Camera::study(1024, pose);
        let tir = Camera::study(512, pose);
        for (x, y) in [(0, 0), (100, 300), (511, 511), (255, 17)] {
            // The centre of a TIR pixel is the shared corner of its 2 × 2 VIS block.
            let a = tir.pixel_ray(x, y);
            let b = vis.ray_dir(2.0 * x as f32 + 1.0, 2.0 * y as f32 + 1.0);
            assert!((a - b).length() < 1e-6);
        }
    }

    #[test]
    fn subpixels_tile_the_pixel() {
        let one: Vec<_> = Camera::subpixels(7, 3, 1).collect();
        assert_eq!(one, vec![(7.5, 3.5)]);
        let four: Vec<_> = Camera::subpixels(7, 3, 4).collect();
        assert_eq!(four.len(), 16);
        let mean = four.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0 / 16.0, a.1 + p.1 / 16.0));
        assert!((mean.0 - 7.5).abs() < 1e-5 && (mean.1 - 3.5).abs() < 1e-5);
        assert!(four.iter().all(|&(u, v)| (7.0..8.0).contains(&u) && (3.0..4.0).contains(&v)));
        assert_eq!(four[1].0 - four[0].0, 0.25);
    }

    #[test]
    fn project_inverts_ray() {
        let pose = Pose::look_at(Vec3::new(3.0, -4.0, 2.0), Vec3::ZERO, Vec3::Z);
        let cam = Camera::study(1024, pose);
        let d = cam.pixel_ray(700, 200);
        let (u, v) = cam.project(pose.position + 6.0 * d).unwrap();
        assert!((u - 700.5).abs() < 1e-2 && (v - 200.5).abs() < 1e-2);
        // Image up is world up here: a point above the target projects above the centre.
        let (_, v) = cam.project(Vec3::new(0.0, 0.0, 1.0)).unwrap();
        assert!(v < cam.cy);
    }
}
