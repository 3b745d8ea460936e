//! The target's surface materials (optical and thermal properties, from Fortescue, *Spacecraft
//! Systems Engineering*) and its faces: the parts of the mesh that share one material, normal
//! and thermal node. Shared by the scene (`crate::scene`) and its surface detail
//! (`crate::surface`).

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Surface materials of the target (optical and thermal properties in [`MaterialProps`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Material {
    /// Triple-junction GaAs solar cells under a cover glass.
    GaAsCell,
    /// Multi-layer insulation with an outer Kapton layer.
    MliKapton,
    /// White-paint radiator.
    WhitePaint,
    /// Polished aluminium (antenna rods, panel frame).
    PolishedAluminium,
}

/// Optical (VIS) and thermal properties of a [`Material`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialProps {
    /// Solar absorptance α.
    pub solar_absorptance: f64,
    /// Infrared (hemispherical) emittance ε; also the IR absorptance (Kirchhoff).
    pub ir_emittance: f64,
    /// Fraction of the incident solar flux leaving as electrical power (cells only).
    pub electrical_efficiency: f64,
    /// Conductive coupling to the bus interior, W/(m² K) of face area.
    pub bus_coupling: f64,
    /// Areal heat capacity, J/(m² K), for the lumped transient.
    pub areal_heat_capacity: f64,
    /// Diffuse (Lambertian) VIS albedo.
    pub diffuse_albedo: f32,
    /// Weight of the Blinn–Phong specular lobe.
    pub specular: f32,
    /// Blinn–Phong exponent.
    pub shininess: f32,
}

impl Material {
    /// All materials, in a fixed order.
    pub const ALL: [Material; 4] =
        [Material::GaAsCell, Material::MliKapton, Material::WhitePaint, Material::PolishedAluminium];

    /// Properties of this material. α/ε follow Fortescue, *Spacecraft Systems Engineering*; the
    /// couplings, heat capacities and VIS reflectances are engineering estimates (README).
    pub fn props(self) -> MaterialProps {
        match self {
            Material::GaAsCell => MaterialProps {
                solar_absorptance: 0.88,
                ir_emittance: 0.80,
                electrical_efficiency: 0.25,
                bus_coupling: 0.5,
                areal_heat_capacity: 1800.0,
                diffuse_albedo: 0.08,
                specular: 0.35,
                shininess: 60.0,
            },
            Material::MliKapton => MaterialProps {
                solar_absorptance: 0.40,
                ir_emittance: 0.63,
                electrical_efficiency: 0.0,
                bus_coupling: 0.05,
                areal_heat_capacity: 100.0,
                diffuse_albedo: 0.45,
                specular: 0.25,
                shininess: 15.0,
            },
            Material::WhitePaint => MaterialProps {
                solar_absorptance: 0.12,
                ir_emittance: 0.90,
                electrical_efficiency: 0.0,
                bus_coupling: 1.0,
                areal_heat_capacity: 3000.0,
                diffuse_albedo: 0.85,
                specular: 0.02,
                shininess: 8.0,
            },
            Material::PolishedAluminium => MaterialProps {
                solar_absorptance: 0.24,
                ir_emittance: 0.08,
                electrical_efficiency: 0.0,
                bus_coupling: 0.5,
                areal_heat_capacity: 7300.0,
                diffuse_albedo: 0.15,
                specular: 0.8,
                shininess: 200.0,
            },
        }
    }

    /// Guesses a material from an OBJ/MTL material or object name ("solar", "panel", "cell" →
    /// cells; "radiator", "paint", "white" → paint; "antenna", "alu", "metal" → aluminium).
    pub fn from_name_hint(name: &str) -> Option<Material> {
        let n = name.to_ascii_lowercase();
        let has = |keys: &[&str]| keys.iter().any(|k| n.contains(k));
        if has(&["solar", "panel", "cell", "gaas"]) {
            Some(Material::GaAsCell)
        } else if has(&["radiator", "paint", "white"]) {
            Some(Material::WhitePaint)
        } else if has(&["antenna", "alu", "metal", "rod"]) {
            Some(Material::PolishedAluminium)
        } else if has(&["mli", "kapton", "foil", "blanket"]) {
            Some(Material::MliKapton)
        } else {
            None
        }
    }
}

/// One flat part of the target with one material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Face {
    /// Surface material.
    pub material: Material,
    /// Outward unit normal.
    pub normal: Vec3,
    /// Area, m².
    pub area: f32,
    /// Thermal node this face belongs to.
    pub node: u32,
    /// Internal (electronics) heat dumped through this face, W/m².
    pub internal_heat: f64,
}
