//! Ground truth of a rendered frame: which pixels see the target, and at what depth.

use crate::camera::Camera;
use crate::scene::Scene;
use rayon::prelude::*;

/// Per pixel, the distance along the pixel's ray to the target (m), or `None` where the ray
/// sees space. The same rays as the renders (pixel centres, one per pixel).
pub fn depth(scene: &Scene, camera: &Camera) -> Vec<Option<f32>> {
    let w = camera.width as usize;
    let mut out = vec![None; w * camera.height as usize];
    out.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        for (x, d) in row.iter_mut().enumerate() {
            let dir = camera.pixel_ray(x as u32, y as u32);
            *d = scene.intersect(camera.pose.position, dir, 0.0).map(|h| h.t);
        }
    });
    out
}

/// The target mask: `true` where the pixel's ray hits the target.
pub fn target_mask(scene: &Scene, camera: &Camera) -> Vec<bool> {
    depth(scene, camera).iter().map(Option::is_some).collect()
}

/// Per pixel, whether the pixel centre's ray misses the target (`target`, its [`target_mask`])
/// and hits the Earth's surface (the glow of the atmosphere above the limb not counted): the
/// Earth's mask.
pub fn earth_mask(camera: &Camera, earth: &crate::earth::EarthView, target: &[bool]) -> Vec<bool> {
    let w = camera.width as usize;
    let mut out = vec![false; w * camera.height as usize];
    out.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        for (x, m) in row.iter_mut().enumerate() {
            let dir = camera.pixel_ray(x as u32, y as u32);
            *m = !target.get(y * w + x).copied().unwrap_or(false)
                && matches!(
                    earth.hit(camera.pose.position, dir),
                    Some(crate::earth::EarthHit::Surface { .. })
                );
        }
    });
    out
}
