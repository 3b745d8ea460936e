#![doc = include_str!("../README.md")]

pub mod camera;
pub mod dataset;
pub mod earth;
pub mod focal_plane;
pub mod glare;
pub mod image;
pub mod material;
pub mod noise;
pub mod render;
pub mod rig;
pub mod scene;
pub mod sequence;
pub mod surface;
pub mod thermal;
pub mod tir;
pub mod truth;
pub mod vis;

pub use camera::{Camera, FOCAL_PX_1024, FOV_DEG, Pose};
pub use dataset::{DatasetConfig, Manifest, render_dataset, trajectory};
pub use glam;
pub use image::Image;
pub use noise::{Band, NoiseParams, apply_sensor_noise};
pub use render::{RenderOptions, render};
pub use scene::{Material, Scene};
pub use surface::{SurfaceDetail, SurfacePoint};
pub use thermal::{ThermalParams, eclipse_transient, face_temperatures, steady_state};
pub use tir::{DnMapping, Radiometry, TirParams, render_tir, render_tir_over};
pub use vis::{Illumination, VisParams, render_vis, render_vis_over};
