//! Geometry: materials, the two procedural targets ([`Target`]: the Tango-like small satellite
//! and a box-wing satellite with long solar arrays), OBJ meshes and the BVH.
//!
//! A [`Scene`] is a triangle soup grouped into *faces* (one flat part with one material, e.g. a
//! side of the bus: two triangles) and *thermal nodes* (one temperature: a bus side is its own
//! node, the whole solar-panel slab is one node, each antenna rod is one node). Ray queries go
//! through an `obvhs` compressed wide BVH (CWBVH): [`Scene::intersect`] is the closest hit for
//! primary rays, [`Scene::occluded`] the any-hit query for shadow rays.

use anyhow::{Context, Result, bail};
use glam::{Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    ray::{Ray, RayHit},
    triangle::Triangle,
};

use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Duration;

pub use crate::material::{Face, Material, MaterialProps};

/// A ray–scene intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// Index into [`Scene::faces`].
    pub face: u32,
    /// Index of the triangle in the scene's input order ([`Scene::triangles`]).
    pub triangle: u32,
    /// Outward geometric normal of the face hit.
    pub normal: Vec3,
    /// World-space hit point.
    pub point: Vec3,
}

/// Triangles, faces, thermal nodes and the BVH over them.
pub struct Scene {
    /// Triangles in input order.
    pub triangles: Vec<Triangle>,
    /// Face index of each triangle (input order).
    pub triangle_face: Vec<u32>,
    /// Faces.
    pub faces: Vec<Face>,
    /// Number of thermal nodes (faces refer to them by [`Face::node`]).
    pub node_count: usize,
    /// Centre of the bounding box; the cameras of a dataset look here.
    pub centre: Vec3,
    /// Half the bounding-box diagonal, m.
    pub radius: f32,
    /// Procedural surface detail (cells, crinkled MLI, bolts, in-face temperature gradients);
    /// `None`: flat faces, one albedo and one temperature each ([`Scene::with_surface_detail`]).
    pub detail: Option<crate::surface::SurfaceDetail>,
    bvh: CwBvh,
    /// Triangles laid out in BVH order (`bvh.primitive_indices`), with their input index.
    bvh_tris: Vec<(Triangle, u32)>,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("triangles", &self.triangles.len())
            .field("faces", &self.faces.len())
            .field("node_count", &self.node_count)
            .field("centre", &self.centre)
            .field("radius", &self.radius)
            .finish()
    }
}

/// Collects triangles, faces and nodes; [`MeshBuilder::build`] makes the [`Scene`].
#[derive(Debug, Default, Clone)]
pub struct MeshBuilder {
    tris: Vec<Triangle>,
    tri_face: Vec<u32>,
    faces: Vec<Face>,
    nodes: u32,
}

fn tri(a: Vec3, b: Vec3, c: Vec3) -> Triangle {
    Triangle { v0: a.into(), v1: b.into(), v2: c.into() }
}

impl MeshBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// A new thermal node id.
    pub fn new_node(&mut self) -> u32 {
        self.nodes += 1;
        self.nodes - 1
    }

    /// Adds one face made of `triangles` (counter-clockwise seen from outside). Degenerate
    /// triangles are dropped; returns the face index, or `None` if nothing was left.
    pub fn add_face(
        &mut self,
        triangles: &[[Vec3; 3]],
        material: Material,
        node: u32,
        internal_heat: f64,
    ) -> Option<u32> {
        let mut area = 0.0f32;
        let mut normal = Vec3::ZERO;
        let face = self.faces.len() as u32;
        for &[a, b, c] in triangles {
            let cr = (b - a).cross(c - a);
            let len = cr.length();
            if len <= 1e-12 || !len.is_finite() {
                continue;
            }
            area += 0.5 * len;
            normal += cr;
            self.tris.push(tri(a, b, c));
            self.tri_face.push(face);
        }
        if area <= 0.0 {
            return None;
        }
        self.nodes = self.nodes.max(node + 1);
        self.faces.push(Face { material, normal: normal.normalize(), area, node, internal_heat });
        Some(face)
    }

    /// Adds a planar quad `a b c d` (counter-clockwise seen from outside) as one face.
    pub fn add_quad(&mut self, q: [Vec3; 4], material: Material, node: u32, internal_heat: f64) {
        let [a, b, c, d] = q;
        self.add_face(&[[a, b, c], [a, c, d]], material, node, internal_heat);
    }

    /// Adds the sides of an axis-aligned box. `sides` gives material, node and internal heat per
    /// side in the order −x, +x, −y, +y, −z, +z; `None` leaves that side open.
    pub fn add_box(&mut self, min: Vec3, max: Vec3, sides: [Option<(Material, u32, f64)>; 6]) {
        let centre = 0.5 * (min + max);
        let half = 0.5 * (max - min);
        for (i, side) in sides.iter().enumerate() {
            let Some((material, node, heat)) = *side else { continue };
            let axis = i / 2;
            let sign = if i % 2 == 0 { -1.0 } else { 1.0 };
            let e = [Vec3::X, Vec3::Y, Vec3::Z];
            let n = e[axis] * sign;
            // u × v = +axis; swap for the negative side so u × v = n.
            let (mut u, mut v) = (e[(axis + 1) % 3], e[(axis + 2) % 3]);
            if sign < 0.0 {
                std::mem::swap(&mut u, &mut v);
            }
            let hu = u * half.dot(u).abs();
            let hv = v * half.dot(v).abs();
            let c = centre + n * half.dot(n).abs();
            self.add_quad([c - hu - hv, c + hu - hv, c + hu + hv, c - hu + hv], material, node, heat);
        }
    }

    /// Adds a closed prism ("rod") of `sides` facets and circumradius `radius` from `start` to
    /// `end`; every facet is its own face, all on thermal node `node`.
    pub fn add_rod(
        &mut self,
        start: Vec3,
        end: Vec3,
        radius: f32,
        sides: u32,
        material: Material,
        node: u32,
    ) {
        let d = (end - start).normalize();
        let (e1, _) = d.any_orthonormal_pair();
        // A right-handed (e1, e2, d) frame, so the facets below wind outward.
        let e2 = d.cross(e1);
        let ring: Vec<Vec3> = (0..sides)
            .map(|k| {
                let phi = std::f32::consts::TAU * k as f32 / sides as f32;
                radius * (phi.cos() * e1 + phi.sin() * e2)
            })
            .collect();
        for k in 0..ring.len() {
            let (p0, p1) = (ring[k], ring[(k + 1) % ring.len()]);
            self.add_quad([start + p0, start + p1, end + p1, end + p0], material, node, 0.0);
        }
        let end_cap: Vec<[Vec3; 3]> =
            (1..ring.len() - 1).map(|k| [end + ring[0], end + ring[k], end + ring[k + 1]]).collect();
        let start_cap: Vec<[Vec3; 3]> =
            (1..ring.len() - 1).map(|k| [start + ring[0], start + ring[k + 1], start + ring[k]]).collect();
        self.add_face(&end_cap, material, node, 0.0);
        self.add_face(&start_cap, material, node, 0.0);
    }

    /// Builds the BVH and the scene. Fails on an empty mesh or non-finite vertices.
    pub fn build(self) -> Result<Scene> {
        if self.tris.is_empty() {
            bail!("the mesh has no (non-degenerate) triangles");
        }
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for t in &self.tris {
            for v in [t.v0, t.v1, t.v2] {
                let v = Vec3::from(v);
                if !v.is_finite() {
                    bail!("the mesh has a non-finite vertex");
                }
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        let bvh = build_cwbvh_from_tris(&self.tris, BvhBuildParams::medium_build(), &mut Duration::default());
        let bvh_tris = bvh.primitive_indices.iter().map(|&i| (self.tris[i as usize], i)).collect();
        Ok(Scene {
            triangles: self.tris,
            triangle_face: self.tri_face,
            faces: self.faces,
            node_count: self.nodes as usize,
            centre: 0.5 * (lo + hi),
            radius: 0.5 * (hi - lo).length(),
            detail: None,
            bvh,
            bvh_tris,
        })
    }
}

/// `dir` with every `-0.0` component turned into `+0.0` (`-0.0 + 0.0 = +0.0` in IEEE 754).
///
/// obvhs 0.4 picks a child box's near/far planes from `dir < 0` but inverts a zero component
/// to `signum(x) / ε`, which is negative for `-0.0`: the two disagree and a ray such as `-X`
/// (whose y and z are `-0.0`) misses every box. Found by this crate's tests.
fn positive_zeros(dir: Vec3) -> Vec3A {
    Vec3A::from(dir) + Vec3A::ZERO
}

/// Dimensions of the procedural Tango-like target, metres.
pub mod tango {
    /// Bus size (x, y, z).
    pub const BUS: [f32; 3] = [0.74, 0.57, 0.30];
    /// Solar-panel slab size (x, y) and thickness.
    pub const PANEL: [f32; 3] = [0.74, 0.77, 0.02];
    /// Antenna rod circumradius.
    pub const ROD_RADIUS: f32 = 0.006;
}

/// Dimensions of the procedural box-wing target, metres.
pub mod box_wing {
    /// Bus size (x, y, z).
    pub const BUS: [f32; 3] = [0.80, 0.70, 0.90];
    /// One solar wing: length along y, width along z, thickness along x.
    pub const WING: [f32; 3] = [1.30, 0.60, 0.025];
    /// Gap between the bus side and a wing's inner edge (the yoke's length along y).
    pub const YOKE: f32 = 0.18;
    /// Antenna dish radius and depth, on the +z (Earth) deck.
    pub const DISH: [f32; 2] = [0.30, 0.07];
    /// Yoke and feed-strut circumradius.
    pub const STRUT_RADIUS: f32 = 0.012;
}

/// The named targets the renderer and the navigation judge know (`--target`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Target {
    /// The Tango-like small satellite ([`Scene::tango`]): a 0.74 m bus under one solar panel.
    #[default]
    #[serde(rename = "tango")]
    #[cfg_attr(feature = "clap", value(name = "tango"))]
    Tango,
    /// A box-wing satellite ([`Scene::box_wing`]): a 0.9 m bus, two 1.3 m solar wings on yokes
    /// (3.4 m tip to tip), a dish on the Earth deck.
    #[serde(rename = "boxwing")]
    #[cfg_attr(feature = "clap", value(name = "boxwing"))]
    BoxWing,
}

impl Target {
    /// Every named target, in a fixed order.
    pub const ALL: [Target; 2] = [Target::Tango, Target::BoxWing];

    /// The name as written on the command line and in manifests.
    pub fn as_str(self) -> &'static str {
        match self {
            Target::Tango => "tango",
            Target::BoxWing => "boxwing",
        }
    }

    /// The target's scene (flat faces; add detail with [`Scene::with_surface_detail`]).
    pub fn scene(self) -> Result<Scene> {
        match self {
            Target::Tango => Scene::tango(),
            Target::BoxWing => Scene::box_wing(),
        }
    }

    /// Whether this is the default target (manifests leave it out, so the ones written before
    /// the choice existed read the same).
    pub fn is_default(&self) -> bool {
        *self == Target::default()
    }
}

impl Scene {
    /// The procedural Tango-like target, in its body frame (metres): an MLI-covered bus
    /// 0.74 × 0.57 × 0.30 m centred at the origin with a white-paint radiator on −y (dumping
    /// the internal heat), a 0.74 × 0.77 × 0.02 m solar-panel slab on top (+z: GaAs cells,
    /// underside white paint, polished-aluminium edges; one thermal node) and three polished
    /// aluminium antenna rods (two on +x, one under the bus).
    pub fn tango() -> Result<Scene> {
        use Material::*;
        let [bx, by, bz] = tango::BUS;
        let [px, py, pt] = tango::PANEL;
        let mut m = MeshBuilder::new();
        // Bus: one node per side; the top is covered by the panel, so it is left open.
        let mut bus = [None; 6];
        for (i, side) in bus.iter_mut().enumerate().take(5) {
            let node = m.new_node();
            *side = Some(match i {
                // −y: radiator, 30 W of electronics over 0.74 × 0.30 m.
                2 => (WhitePaint, node, 30.0 / (f64::from(bx) * f64::from(bz))),
                _ => (MliKapton, node, 0.0),
            });
        }
        let bmin = Vec3::new(-bx / 2.0, -by / 2.0, -bz / 2.0);
        m.add_box(bmin, -bmin, bus);
        // Solar panel: one node (a thin conductive slab).
        let panel = m.new_node();
        let pmin = Vec3::new(-px / 2.0, -py / 2.0, bz / 2.0);
        let pmax = Vec3::new(px / 2.0, py / 2.0, bz / 2.0 + pt);
        let edge = Some((PolishedAluminium, panel, 0.0));
        m.add_box(
            pmin,
            pmax,
            [edge, edge, edge, edge, Some((WhitePaint, panel, 0.0)), Some((GaAsCell, panel, 0.0))],
        );
        // Antenna rods, rooted 5 mm inside the bus.
        let rods = [
            (Vec3::new(bx / 2.0, 0.20, -0.08), Vec3::new(1.0, 0.35, -0.5), 0.26),
            (Vec3::new(bx / 2.0, -0.20, -0.08), Vec3::new(1.0, -0.35, -0.5), 0.26),
            (Vec3::new(-0.22, 0.0, -bz / 2.0), Vec3::new(-0.45, 0.0, -1.0), 0.20),
        ];
        for (root, dir, len) in rods {
            let d = dir.normalize();
            let node = m.new_node();
            m.add_rod(root - 0.005 * d, root + len * d, tango::ROD_RADIUS, 6, PolishedAluminium, node);
        }
        m.build()
    }

    /// The procedural box-wing target, in its body frame (metres; [`box_wing`]): an MLI bus
    /// 0.80 × 0.70 × 0.90 m centred at the origin, white-paint radiators on ±y (the usual
    /// north and south faces, 60 W of electronics each), two solar wings 1.30 × 0.60 m along
    /// ±y on aluminium yokes (GaAs cells on +x, white paint on −x, each wing one thermal node)
    /// and on the +z deck a white-painted dish 0.6 m across, 7 cm deep, with an aluminium feed
    /// strut. Faces wind outward; the dish has a front and a back 1.5 cm apart.
    pub fn box_wing() -> Result<Scene> {
        use Material::*;
        let [bx, by, bz] = box_wing::BUS;
        let [wl, ww, wt] = box_wing::WING;
        let mut m = MeshBuilder::new();
        // Bus: one node per side; ±y radiators (60 W over 0.80 × 0.90 m each).
        let radiator = 60.0 / (f64::from(bx) * f64::from(bz));
        let mut bus = [None; 6];
        for (i, side) in bus.iter_mut().enumerate() {
            let node = m.new_node();
            *side =
                Some(if i == 2 || i == 3 { (WhitePaint, node, radiator) } else { (MliKapton, node, 0.0) });
        }
        let bmin = Vec3::new(-bx / 2.0, -by / 2.0, -bz / 2.0);
        m.add_box(bmin, -bmin, bus);
        // Wings on ±y: cells facing +x, paint on −x, aluminium edges; yokes from the bus side.
        for sign in [-1.0f32, 1.0] {
            let node = m.new_node();
            let (y0, y1) = (by / 2.0 + box_wing::YOKE, by / 2.0 + box_wing::YOKE + wl);
            let (ylo, yhi) = if sign > 0.0 { (y0, y1) } else { (-y1, -y0) };
            let min = Vec3::new(-wt / 2.0, ylo, -ww / 2.0);
            let max = Vec3::new(wt / 2.0, yhi, ww / 2.0);
            let edge = Some((PolishedAluminium, node, 0.0));
            m.add_box(
                min,
                max,
                [Some((WhitePaint, node, 0.0)), Some((GaAsCell, node, 0.0)), edge, edge, edge, edge],
            );
            let yoke = m.new_node();
            for z in [-0.2f32, 0.2] {
                let root = Vec3::new(0.0, sign * (by / 2.0 - 0.005), z);
                let tip = Vec3::new(0.0, sign * (y0 + 0.005), z * 0.6);
                m.add_rod(root, tip, box_wing::STRUT_RADIUS, 6, PolishedAluminium, yoke);
            }
        }
        // The dish on the +z deck: a concave front (facing +z) and a back 1.5 cm below, a rim
        // between them; one thermal node. Its base stands 5 cm off the deck.
        let [r, depth] = box_wing::DISH;
        let dish = m.new_node();
        let segments = 24;
        let base = bz / 2.0 + 0.05;
        let ring = |k: u32, z: f32| {
            let phi = std::f32::consts::TAU * k as f32 / segments as f32;
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        };
        let (apex_front, apex_back) = (Vec3::new(0.0, 0.0, base), Vec3::new(0.0, 0.0, base - 0.015));
        for k in 0..segments {
            let (a, b) = (ring(k, base + depth), ring(k + 1, base + depth));
            let (ab, bb) = (ring(k, base + depth - 0.015), ring(k + 1, base + depth - 0.015));
            // Front (concave, facing +z), back (facing −z), rim (facing out).
            m.add_face(&[[apex_front, a, b]], WhitePaint, dish, 0.0);
            m.add_face(&[[apex_back, bb, ab]], WhitePaint, dish, 0.0);
            m.add_quad([ab, bb, b, a], PolishedAluminium, dish, 0.0);
        }
        // The support post under the dish and the feed strut to its focus.
        let strut = m.new_node();
        m.add_rod(
            Vec3::new(0.0, 0.0, bz / 2.0 - 0.005),
            apex_back,
            box_wing::STRUT_RADIUS * 2.0,
            6,
            PolishedAluminium,
            strut,
        );
        let focus = base + r * r / (4.0 * depth);
        m.add_rod(
            Vec3::new(r * 0.95, 0.0, base + depth),
            Vec3::new(0.0, 0.0, focus),
            box_wing::STRUT_RADIUS,
            6,
            PolishedAluminium,
            strut,
        );
        m.build()
    }

    /// The same scene with procedural surface detail (`crate::surface`), seeded.
    pub fn with_surface_detail(mut self, seed: u64) -> Scene {
        self.detail =
            Some(crate::surface::SurfaceDetail::new(&self.faces, &self.triangles, &self.triangle_face, seed));
        self
    }

    /// Loads a Wavefront OBJ mesh (triangulated on load), scaled by `scale`. Each triangle is its
    /// own face and thermal node; its material comes from the MTL material or object name
    /// ([`Material::from_name_hint`]) or else `default_material`. Winding should be
    /// counter-clockwise seen from outside (the thermal model uses the normal's sign).
    pub fn from_obj(path: &Path, default_material: Material, scale: f32) -> Result<Scene> {
        let opts = tobj::LoadOptions {
            triangulate: true,
            ignore_points: true,
            ignore_lines: true,
            ..Default::default()
        };
        let (models, materials) = tobj::load_obj(path, &opts)
            .with_context(|| format!("cannot load OBJ mesh {}", path.display()))?;
        let materials = materials.unwrap_or_default();
        let mut m = MeshBuilder::new();
        for model in &models {
            let mesh = &model.mesh;
            let material = mesh
                .material_id
                .and_then(|id| materials.get(id))
                .and_then(|mt| Material::from_name_hint(&mt.name))
                .or_else(|| Material::from_name_hint(&model.name))
                .unwrap_or(default_material);
            let p = &mesh.positions;
            let vertex = |i: u32| -> Result<Vec3> {
                let i = i as usize * 3;
                match p.get(i..i + 3) {
                    Some(v) => Ok(Vec3::new(v[0], v[1], v[2]) * scale),
                    None => bail!("{}: vertex index out of range", path.display()),
                }
            };
            for idx in mesh.indices.chunks_exact(3) {
                let t = [vertex(idx[0])?, vertex(idx[1])?, vertex(idx[2])?];
                let node = m.nodes;
                m.add_face(&[t], material, node, 0.0);
            }
        }
        m.build().with_context(|| format!("OBJ mesh {}", path.display()))
    }

    /// Closest hit along `dir` (unit) from `origin`, for `t` in `[tmin, ∞)`.
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32) -> Option<Hit> {
        let ray = Ray::new(Vec3A::from(origin), positive_zeros(dir), tmin, f32::INFINITY);
        let mut hit = RayHit::none();
        if !self.bvh.ray_traverse(ray, &mut hit, |r, id| self.bvh_tris[id].0.intersect(r)) {
            return None;
        }
        let (_, tri_index) = self.bvh_tris[hit.primitive_id as usize];
        let face = self.triangle_face[tri_index as usize];
        Some(Hit {
            t: hit.t,
            face,
            triangle: tri_index,
            normal: self.faces[face as usize].normal,
            point: origin + hit.t * dir,
        })
    }

    /// Any-hit query: is anything in the way along `dir` from `origin` for `t` in `(tmin, tmax)`?
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let ray = Ray::new(Vec3A::from(origin), positive_zeros(dir), tmin, tmax);
        !self.bvh.ray_traverse_miss(ray, |r, id| self.bvh_tris[id].0.intersect(r))
    }

    /// Ray offset that keeps a secondary ray off the surface it starts on.
    pub fn epsilon(&self) -> f32 {
        1e-5 * self.radius.max(1e-3) + 1e-5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_normals_point_outward() {
        let mut m = MeshBuilder::new();
        let s = Some((Material::MliKapton, 0, 0.0));
        m.add_box(Vec3::splat(-1.0), Vec3::splat(1.0), [s; 6]);
        let sc = m.build().unwrap();
        for (tri, &f) in sc.triangles.iter().zip(&sc.triangle_face) {
            let c = Vec3::from(tri.v0 + tri.v1 + tri.v2) / 3.0;
            let n = sc.faces[f as usize].normal;
            assert!(c.dot(n) > 0.9, "face {f} normal {n} at {c}");
            assert!((Vec3::from(tri.compute_normal()) - n).length() < 1e-5);
        }
        let area: f32 = sc.faces.iter().map(|f| f.area).sum();
        assert!((area - 24.0).abs() < 1e-4);
    }

    #[test]
    fn rod_normals_point_outward() {
        let mut m = MeshBuilder::new();
        m.add_rod(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0), 0.1, 6, Material::PolishedAluminium, 0);
        let sc = m.build().unwrap();
        for (tri, &f) in sc.triangles.iter().zip(&sc.triangle_face) {
            let c = Vec3::from(tri.v0 + tri.v1 + tri.v2) / 3.0 - Vec3::new(0.0, 0.0, 0.5);
            assert!(c.dot(sc.faces[f as usize].normal) > 0.0);
        }
        assert_eq!(sc.node_count, 1);
    }

    /// The box-wing target: its areas by material worked from the dimensions, every face's
    /// normal pointing away from the part it closes (checked on the bus, the wings and the
    /// dish's front), its span, and rays from outside that hit what the geometry says.
    #[test]
    fn box_wing_dimensions_and_normals() {
        let sc = Scene::box_wing().unwrap();
        let [bx, by, bz] = box_wing::BUS;
        let [wl, ww, wt] = box_wing::WING;
        let area = |m: Material| -> f32 { sc.faces.iter().filter(|f| f.material == m).map(|f| f.area).sum() };
        assert!((area(Material::GaAsCell) - 2.0 * wl * ww).abs() < 1e-4, "{}", area(Material::GaAsCell));
        assert!((area(Material::MliKapton) - 2.0 * (by * bz + bx * by)).abs() < 1e-4);
        // White paint: two radiators, two wing backs, the dish's two cones (slant area π r s).
        let [r, d] = box_wing::DISH;
        let cone = std::f32::consts::PI * r * (r * r + d * d).sqrt();
        let paint = 2.0 * bx * bz + 2.0 * wl * ww + 2.0 * cone;
        // 24 facets approximate the cone: their area is the inscribed polygon's, a little less.
        assert!(
            (area(Material::WhitePaint) - paint).abs() < 0.01 * paint,
            "{} against {paint}",
            area(Material::WhitePaint)
        );
        // Span: wing tip to wing tip along y.
        let tip = by / 2.0 + box_wing::YOKE + wl;
        let hi = sc.triangles.iter().flat_map(|t| [t.v0.y, t.v1.y, t.v2.y]).fold(f32::MIN, f32::max);
        assert!((hi - tip).abs() < 1e-5);
        // The cells face +x, the wing backs −x; a ray from +x onto a wing meets its cells.
        let h = sc.intersect(Vec3::new(5.0, 1.0, 0.0), -Vec3::X, 0.0).unwrap();
        assert_eq!(sc.faces[h.face as usize].material, Material::GaAsCell);
        assert!((h.point.x - wt / 2.0).abs() < 1e-5 && h.normal.x > 0.99);
        let h = sc.intersect(Vec3::new(-5.0, -1.0, 0.0), Vec3::X, 0.0).unwrap();
        assert_eq!(sc.faces[h.face as usize].material, Material::WhitePaint);
        assert!(h.normal.x < -0.99);
        // From above, the dish's concave front faces up.
        let h = sc.intersect(Vec3::new(0.1, 0.05, 5.0), -Vec3::Z, 0.0).unwrap();
        assert_eq!(sc.faces[h.face as usize].material, Material::WhitePaint);
        assert!(h.normal.z > 0.9, "{}", h.normal);
        // Bus sides (the first six nodes): every face's normal points away from the centre.
        for (tri, &f) in sc.triangles.iter().zip(&sc.triangle_face) {
            let c = Vec3::from(tri.v0 + tri.v1 + tri.v2) / 3.0;
            if sc.faces[f as usize].node < 6 {
                assert!(c.dot(sc.faces[f as usize].normal) > 0.0, "bus face {f} at {c}");
            }
        }
        // Nodes: 6 bus sides, per wing a panel and its yokes, the dish, the struts.
        assert_eq!(sc.node_count, 6 + 2 * 2 + 1 + 1);
        assert_eq!(Target::BoxWing.scene().unwrap().triangles.len(), sc.triangles.len());
    }

    #[test]
    fn tango_dimensions() {
        let sc = Scene::tango().unwrap();
        assert_eq!(sc.node_count, 5 + 1 + 3);
        let area = |m: Material| -> f32 { sc.faces.iter().filter(|f| f.material == m).map(|f| f.area).sum() };
        assert!((area(Material::GaAsCell) - 0.74 * 0.77).abs() < 1e-4);
        assert!((area(Material::WhitePaint) - (0.74 * 0.30 + 0.74 * 0.77)).abs() < 1e-4);
    }
}
