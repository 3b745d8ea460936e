//! Rendezvous sequences: a chaser's camera over time, with target attitude motion, an eclipse
//! crossing through the penumbra, sensor noise and per-frame ground truth, for judging what a
//! fused stream does for relative navigation.
//!
//! Three named trajectories ([`SequenceName`]), all at [`SequenceConfig::frame_rate_hz`]
//! (default 1 Hz) for [`SequenceConfig::frames`] frames (default 120):
//!
//! * **`approach`**: closing from 50 m to 5 m along a fixed line of sight on the sunlit side
//!   (a sun phase angle of 14.3° at the first frame) with a slow lateral drift of ± 10°; the
//!   range shrinks geometrically (a constant ratio per frame, as a glide-slope approach whose
//!   closing rate is proportional to range), so the 0.74 m target spans 24 px of the VIS frame
//!   at the start and 237 px at the end (the study's working ranges); the target tumbles at
//!   1 °/s about a tilted axis. In sunlight throughout.
//! * **`flyaround`**: a full circumnavigation at 8 m (the target ≈ 150 px across in VIS) on a
//!   plane tilted 30° from the target's x–y plane, starting and ending on the sunlit side, the
//!   target spinning at 0.5 °/s about its z axis; the pair enters the Earth's shadow at 35 % of
//!   the sequence and leaves it at 65 %, each time through an 8 s penumbra (the visible
//!   fraction of the solar disc as the Earth's limb crosses it: a circular segment, not a
//!   switch).
//! * **`radial`**: closing from 30 m to 5 m from above, along a line 40° from the radial
//!   towards the sun (drifting ± 8° across the orbit plane), so **the Earth fills the
//!   background** of every frame ([`crate::earth`], on by default); the target tumbles at 1 °/s.
//!   Laid out in the orbit's local frame, where the sun turns away from the zenith at the orbit's
//!   mean motion (0.0635 °/s at 500 km) and the ground under the camera turns with it, so the
//!   terminator stays where it is on the ground and **the eclipse comes from the geometry**: the
//!   visible fraction of the solar disc as it sets behind the Earth's limb
//!   ([`sun_fraction_above_limb`]). By default the phase angle starts at 68° (the sun 108° from
//!   the zenith, the ground below in night): light until 59 s, penumbra to 67 s, then eclipse,
//!   the thermal camera seeing the target against the warm night Earth throughout. With
//!   `--sun-phase 0` the same approach is in daylight over a lit Earth; above ≈ 72° it starts in
//!   the shadow.
//!
//! Options of every sequence: the sun–target–camera phase angle
//! ([`SequenceConfig::sun_phase_deg`], `--sun-phase`; on `radial` the sun then sets with the
//! orbit) and the Earth behind the target ([`SequenceConfig::earth`],
//! `--earth`, [`crate::earth`]). In `approach` and `flyaround` the sun is fixed and the
//! flyaround's eclipse is scheduled, not cast by the Earth drawn (with `--earth` the Earth
//! behind the target stays lit in its eclipse); `radial` is the sequence where both agree.
//!
//! Each pixel integrates [`SEQUENCE_SAMPLES`]² rays over its area (the study's datasets shoot
//! one through its centre): the surface detail then moves with the surface as the view turns,
//! as a feature tracker needs it to.
//!
//! The thermal state follows the sequence: the node temperatures start from the sunlit steady
//! state and are integrated frame to frame ([`crate::thermal::advance`]) with the sun direction
//! in the target frame and the visible sun fraction of that moment, so the target cools in
//! eclipse and warms after it.
//!
//! Ground truth per frame ([`SequenceFrame`]): the camera-to-target pose (camera position in
//! the target frame and the rotation of the camera axes into it, matrix and quaternion), the
//! range, the sun direction and fraction, the illumination [`Phase`], and each camera's target
//! mask as a PNG (255 where the pixel's ray hits the target).

use crate::camera::{Camera, Pose};
use crate::dataset::{contact_sheet, noise_stream, rows_of};
use crate::focal_plane::{FocalPlane, FocalPlaneParams};
use crate::image::Image;
use crate::image::{write_png8, write_png16};
use crate::noise::{Band, NoiseParams, apply_sensor_noise, rng_for};
use crate::scene::{Scene, Target};
use crate::thermal::{NodeBalance, ThermalParams, advance, face_temperatures, steady_state};
use crate::tir::{TirParams, render_tir_over};
use crate::truth::{earth_mask, target_mask};
use crate::vis::{VisParams, render_vis_over};
use anyhow::{Context, Result, bail};
use fusion_io::output::write_json;
use glam::{Quat, Vec3};
use image::GrayImage;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The named rendezvous trajectories.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum SequenceName {
    /// Closing from 50 m to 5 m in sunlight, the target tumbling.
    Approach,
    /// A circumnavigation at 8 m through an eclipse (entry and exit through the penumbra).
    Flyaround,
    /// Closing from 30 m to 5 m along the radial from above, the Earth behind the target, the
    /// orbit carrying the pair into the Earth's shadow.
    Radial,
}

impl SequenceName {
    /// Every sequence, in a fixed order.
    pub const ALL: [SequenceName; 3] =
        [SequenceName::Approach, SequenceName::Flyaround, SequenceName::Radial];

    /// The name as written on the command line and in manifests.
    pub fn as_str(self) -> &'static str {
        match self {
            SequenceName::Approach => "approach",
            SequenceName::Flyaround => "flyaround",
            SequenceName::Radial => "radial",
        }
    }
}

/// Illumination phase of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// The whole solar disc is visible.
    Light,
    /// Part of it.
    Penumbra,
    /// None of it.
    Eclipse,
}

impl Phase {
    /// The phase of a visible sun fraction.
    pub fn of(sun_fraction: f64) -> Phase {
        if sun_fraction >= 1.0 {
            Phase::Light
        } else if sun_fraction <= 0.0 {
            Phase::Eclipse
        } else {
            Phase::Penumbra
        }
    }

    /// `light`, `penumbra` or `eclipse`.
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Light => "light",
            Phase::Penumbra => "penumbra",
            Phase::Eclipse => "eclipse",
        }
    }
}

/// Sub-pixel samples per axis of the sequences' renders (VIS and TIR): a pixel integrates
/// 4 × 4 rays, so that the surface detail moves with the surface as the view turns. One ray
/// per pixel (the study's datasets) aliases the detail on slanted faces (the solar cells' grid,
/// the blanket's crinkles): rendered features then slide against their 3D points by
/// 0.2–1 px per frame and a model-based tracker drifts (BENCHMARKS.md, "The navigation judge").
pub const SEQUENCE_SAMPLES: u32 = 4;

/// Everything that defines a sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceConfig {
    /// Which trajectory.
    pub name: SequenceName,
    /// Number of frames.
    pub frames: usize,
    /// Frames per second.
    pub frame_rate_hz: f64,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Seed of the target's surface detail.
    pub surface_seed: u64,
    /// The target ([`Target`]); manifests without the field read the Tango-like one.
    #[serde(default, skip_serializing_if = "Target::is_default")]
    pub target: Target,
    /// VIS image size (square), px.
    pub vis_size: u32,
    /// TIR image size (square), px.
    pub tir_size: u32,
    /// VIS lighting (sun direction, fraction and illumination are set per frame).
    pub vis: VisParams,
    /// Thermal environment (the sun direction is set per frame).
    pub thermal: ThermalParams,
    /// TIR radiometry and DN mapping.
    pub tir: TirParams,
    /// Sensor noise.
    pub noise: NoiseParams,
    /// Write the noiseless frames too.
    pub write_clean: bool,
    /// Write the noisy TIR as 16-bit counts too (`tir16/`), for the thermal AGC. Manifests
    /// without the field read `false`.
    #[serde(default)]
    pub write_tir16: bool,
    /// Write the thermal camera's raw counts too (`tir_raw/`, 16-bit PNG of `bits`-bit
    /// counts), through this focal-plane model ([`crate::focal_plane`]), with its shutter
    /// frames (`tir_shutter/`) and the factory calibration (`calibration/`). Manifests without
    /// the field read `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub focal_plane: Option<FocalPlaneParams>,
    /// The Earth behind the target in both bands ([`crate::earth`]), along `vis.earth_dir` at
    /// its altitude, the ground moving under the orbit; the earthshine then follows the Earth
    /// drawn. Manifests without it: black space.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub earth: Option<crate::earth::EarthParams>,
    /// The sun–target–camera phase angle at the first frame, degrees (0: the sun behind the
    /// camera, 180: behind the target, in the camera's view). The sun turns from the first
    /// frame's line of sight towards `vis.sun_dir` by this angle (the trajectory itself is laid
    /// out with `vis.sun_dir`, so only the lighting changes); `None`: the sun at `vis.sun_dir`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sun_phase_deg: Option<f64>,
    /// The sun in or near the visible camera's view: its disc, stray light and blooming
    /// ([`crate::glare`]). Manifests without it: none (the renders before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub glare: Option<crate::glare::GlareParams>,
    /// An offset camera pair instead of today's aligned one: each camera with its own
    /// intrinsics, distortion and pose on the chaser ([`crate::rig`]); `vis_size` and
    /// `tir_size` are then the rig's widths. Written beside the frames as
    /// `calibration/rig.json` (the manifest's `rig`), not in the configuration.
    #[serde(skip)]
    pub rig: Option<fusion_nostd::registration::Rig>,
}

impl SequenceConfig {
    /// The default sequence of `name`: 120 frames at 1 Hz, VIS 1024², TIR 512², noisy and clean;
    /// `radial` with its Earth ([`sequence_earth`]).
    pub fn new(name: SequenceName) -> SequenceConfig {
        SequenceConfig {
            name,
            frames: 120,
            frame_rate_hz: 1.0,
            seed: 1,
            surface_seed: 0,
            target: Target::default(),
            vis_size: 1024,
            tir_size: 512,
            vis: VisParams { samples: SEQUENCE_SAMPLES, ..VisParams::light() },
            thermal: ThermalParams::default(),
            tir: TirParams { samples: SEQUENCE_SAMPLES, ..TirParams::default() },
            noise: NoiseParams::default(),
            write_clean: true,
            write_tir16: false,
            focal_plane: None,
            earth: sequence_earth(name, None, 1, 0),
            sun_phase_deg: None,
            glare: None,
            rig: None,
        }
    }

    /// Time of frame `i`, s.
    pub fn time(&self, i: usize) -> f64 {
        i as f64 / self.frame_rate_hz
    }

    /// Duration from the first to the last frame, s.
    pub fn duration(&self) -> f64 {
        self.time(self.frames.saturating_sub(1)).max(1e-9)
    }
}

/// The inertial state of one frame: target attitude, camera position and up vector (in a frame
/// centred on the target, target body axes at `t = 0`), sun direction and fraction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertialState {
    /// Target attitude: body → inertial.
    pub attitude: Quat,
    /// Camera position relative to the target centre, m.
    pub eye: Vec3,
    /// Camera up vector (image up is its opposite projection: camera y points down).
    pub up: Vec3,
    /// Unit vector towards the sun.
    pub sun: Vec3,
    /// Visible fraction of the solar disc.
    pub sun_fraction: f64,
}

/// Approach: first and last range, m.
pub const APPROACH_RANGE_M: (f64, f64) = (50.0, 5.0);
/// Flyaround: the constant range, m.
pub const FLYAROUND_RANGE_M: f64 = 8.0;
/// Radial: first and last range, m.
pub const RADIAL_RANGE_M: (f64, f64) = (30.0, 5.0);
/// Radial: the line of sight's angle from the local zenith, towards the sun in the orbit
/// plane, degrees (the camera above the target and on the sun's side; every ray of a 35° field
/// still ends on the Earth, whose limb is 68° from the nadir at 500 km).
pub const RADIAL_OFF_ZENITH_DEG: f64 = 40.0;
/// Radial: the sun–target–camera phase angle at the first frame, degrees, unless `--sun-phase`
/// says otherwise; the sun is then 68° + 40° = 108° from the zenith. At 500 km the Earth's
/// shadow begins where that angle reaches 112.0°; the orbit turns it by 0.0635 °/s, so the pair
/// enters the penumbra at 59 s and the umbra at 67 s.
pub const RADIAL_SUN_PHASE_DEG: f64 = 68.0;
/// Angular radius of the solar disc, rad (0.2665°).
pub const SUN_ANGULAR_RADIUS: f64 = 0.004_651;

/// Penumbra duration of the flyaround's eclipse entry and exit, s.
pub const PENUMBRA_S: f64 = 8.0;

/// Visible fraction of a disc whose occulting edge (a straight line: the Earth's limb is far
/// larger than the sun) has advanced `progress` ∈ [0, 1] of the disc's diameter: the circular
/// segment left uncovered.
pub fn disc_fraction_uncovered(progress: f64) -> f64 {
    let p = progress.clamp(0.0, 1.0);
    // Covered segment of a unit disc with chord at height h = 1 − 2p from the centre.
    let h = 1.0 - 2.0 * p;
    let covered = (h.acos() - h * (1.0 - h * h).max(0.0).sqrt()) / std::f64::consts::PI;
    (1.0 - covered).clamp(0.0, 1.0)
}

/// The inertial state of frame `i` (see the module docs for the trajectories).
pub fn state(cfg: &SequenceConfig, i: usize) -> InertialState {
    let mut st = laid_out(cfg, i);
    // The radial sequence's sun moves with the orbit: its phase is laid out with it.
    if let Some(phase) = cfg.sun_phase_deg.filter(|_| cfg.name != SequenceName::Radial) {
        st.sun = phased_sun(laid_out(cfg, 0).eye.normalize(), st.sun, phase);
    }
    st
}

/// The Earth a sequence `name` draws: at `altitude_m` when asked (`--earth`), else its own
/// (`radial`'s) if it has one, seeded from the sequence's noise and surface seeds so that
/// `fusion render` and the navigation judge, rendering the same sequence, draw the same Earth.
pub fn sequence_earth(
    name: SequenceName,
    altitude_m: Option<f64>,
    seed: u64,
    surface_seed: u64,
) -> Option<crate::earth::EarthParams> {
    let own = (name == SequenceName::Radial).then_some(crate::earth::DEFAULT_ALTITUDE_M);
    altitude_m.or(own).map(|altitude_m| crate::earth::EarthParams { altitude_m, seed: surface_seed ^ seed })
}

/// Visible fraction of the solar disc seen from an orbit at `altitude_m` when the sun is
/// `nadir_angle` (rad) from the nadir: the Earth's limb lies `asin(R / (R + h))` from the nadir
/// and crosses the disc (angular radius [`SUN_ANGULAR_RADIUS`]) as a straight edge.
pub fn sun_fraction_above_limb(nadir_angle: f64, altitude_m: f64) -> f64 {
    use crate::earth::EARTH_RADIUS_M;
    let limb = (EARTH_RADIUS_M / (EARTH_RADIUS_M + altitude_m)).asin();
    let above = nadir_angle - limb;
    disc_fraction_uncovered((SUN_ANGULAR_RADIUS - above) / (2.0 * SUN_ANGULAR_RADIUS))
}

/// The sun at `phase` degrees from the line of sight `eye` (unit, target → camera), in the
/// plane holding `eye` and `sun` (any plane through `eye` when the two are parallel).
pub fn phased_sun(eye: Vec3, sun: Vec3, phase: f64) -> Vec3 {
    (Quat::from_axis_angle(turning_axis(eye, sun), phase.to_radians() as f32) * eye).normalize()
}

/// The unit axis that turns `from` towards `to` (`from × to`), or any axis normal to `from`
/// when the two are parallel.
fn turning_axis(from: Vec3, to: Vec3) -> Vec3 {
    let axis = from.cross(to);
    if axis.length() > 1e-6 { axis.normalize() } else { from.any_orthonormal_vector() }
}

/// The state of frame `i` with the sun at `vis.sun_dir` (the trajectories are laid out with it).
fn laid_out(cfg: &SequenceConfig, i: usize) -> InertialState {
    let t = cfg.time(i);
    let u = t / cfg.duration();
    let sun = cfg.vis.sun_dir.normalize();
    match cfg.name {
        SequenceName::Approach => {
            let range = APPROACH_RANGE_M.0 * (APPROACH_RANGE_M.1 / APPROACH_RANGE_M.0).powf(u);
            let drift = (10.0f64.to_radians() * (std::f64::consts::PI * u).sin()) as f32;
            // On the sunlit side (14.3° from the sun at the start): the approach sees the lit
            // panel and two lit sides.
            let base = Vec3::new(0.6, 0.45, 0.65).normalize();
            let dir = Quat::from_axis_angle(Vec3::Z, drift) * base;
            let axis = Vec3::new(0.3, 0.2, 1.0).normalize();
            InertialState {
                attitude: Quat::from_axis_angle(axis, (1.0f64.to_radians() * t) as f32),
                eye: dir * range as f32,
                up: Vec3::Z,
                sun,
                sun_fraction: 1.0,
            }
        }
        SequenceName::Flyaround => {
            let normal = Quat::from_axis_angle(Vec3::X, 30f32.to_radians()) * Vec3::Z;
            // Start (and end) on the sunlit side: the sun's direction projected on the plane; the
            // eclipse falls while the camera is on the far side.
            let start = (sun - normal * sun.dot(normal)).normalize();
            // A full circle over the sequence (the last frame one step short of the first).
            let angle = std::f64::consts::TAU * t / (cfg.duration() + 1.0 / cfg.frame_rate_hz);
            let eye = Quat::from_axis_angle(normal, angle as f32) * start * FLYAROUND_RANGE_M as f32;
            let duration = cfg.duration();
            let (entry, exit) = (0.35 * duration, 0.65 * duration);
            let sun_fraction = if t < entry {
                1.0
            } else if t < entry + PENUMBRA_S {
                disc_fraction_uncovered((t - entry) / PENUMBRA_S)
            } else if t < exit {
                0.0
            } else if t < exit + PENUMBRA_S {
                disc_fraction_uncovered(1.0 - (t - exit) / PENUMBRA_S)
            } else {
                1.0
            };
            InertialState {
                attitude: Quat::from_axis_angle(Vec3::Z, (0.5f64.to_radians() * t) as f32),
                eye,
                up: normal,
                sun,
                sun_fraction,
            }
        }
        SequenceName::Radial => {
            // In the orbit's local frame (the Earth fixed along `vis.earth_dir`, the sun in the
            // orbit plane through it and `vis.sun_dir`): the sun turns away from the zenith at
            // the mean motion, the ground under the orbit with it (`earth_view`), and the pair
            // enters the shadow where the sun sets behind the limb.
            let earth = cfg.earth.unwrap_or_default();
            let zenith = -cfg.vis.earth_dir.normalize();
            let normal = turning_axis(zenith, sun);
            let off = RADIAL_OFF_ZENITH_DEG.to_radians();
            let phase = cfg.sun_phase_deg.unwrap_or(RADIAL_SUN_PHASE_DEG).to_radians();
            let zeta = off + phase + earth.mean_motion() * t;
            let sun = (Quat::from_axis_angle(normal, zeta as f32) * zenith).normalize();
            // The line of sight `off` from the zenith towards the sun, drifting ± 8° across the
            // orbit plane.
            let sight = Quat::from_axis_angle(normal, off as f32) * zenith;
            let drift = (8.0f64.to_radians() * (std::f64::consts::PI * u).sin()) as f32;
            let dir = Quat::from_axis_angle(sight.cross(normal).normalize(), drift) * sight;
            let range = RADIAL_RANGE_M.0 * (RADIAL_RANGE_M.1 / RADIAL_RANGE_M.0).powf(u);
            // The target's panel (its +z) halfway between the first frame's sun and line of
            // sight (lit and in view), then tumbling at 1 °/s.
            let panel = Quat::from_axis_angle(normal, (off + 0.5 * phase) as f32) * zenith;
            let spin = Vec3::new(-0.4, 0.3, 1.0).normalize();
            let tumble = Quat::from_axis_angle(spin, (1.0f64.to_radians() * t) as f32);
            InertialState {
                attitude: tumble * Quat::from_rotation_arc(Vec3::Z, panel.normalize()),
                eye: dir * range as f32,
                // Image up towards the sky.
                up: (zenith - dir * zenith.dot(dir)).normalize(),
                sun,
                sun_fraction: sun_fraction_above_limb(std::f64::consts::PI - zeta, earth.altitude_m),
            }
        }
    }
}

/// Writes a camera's mask as an 8-bit PNG (255 where set) at `rel` in `out_dir`.
fn write_mask(out_dir: &Path, rel: &str, cam: &Camera, mask: &[bool]) -> Result<()> {
    let bytes = mask.iter().map(|&m| if m { 255u8 } else { 0 }).collect();
    let img = GrayImage::from_raw(cam.width, cam.height, bytes).context("mask size")?;
    write_png8(&out_dir.join(rel), &img)
}

/// The Earth as frame `i` sees it: along the configured Earth direction (inertial) turned into
/// the target's body frame, its surface turned by the target's attitude and by the ground's
/// motion under the orbit (the orbit's mean motion about the normal of the plane holding the
/// Earth and the sun directions).
pub fn earth_view(
    cfg: &SequenceConfig,
    earth: &crate::earth::EarthParams,
    st: &InertialState,
    centre: Vec3,
    i: usize,
) -> crate::earth::EarthView {
    let to_body = st.attitude.inverse();
    let towards = cfg.vis.earth_dir.normalize();
    let normal = towards.cross(st.sun.normalize());
    let normal = if normal.length() > 1e-3 { normal.normalize() } else { towards.any_orthonormal_vector() };
    let ground = glam::DQuat::from_axis_angle(normal.as_dvec3(), earth.mean_motion() * cfg.time(i));
    let to_surface = ground * st.attitude.as_dquat().normalize();
    crate::earth::EarthView::new(earth, centre, to_body * towards, to_surface, to_body * st.sun)
}

/// The camera pose of a state in the target body frame (the frame the scene is built in): the
/// camera looks at the scene's centre with `state.up` as image up.
pub fn camera_pose(state: &InertialState, scene: &Scene) -> Pose {
    let to_body = state.attitude.inverse();
    let eye = scene.centre + to_body * state.eye;
    Pose::look_at(eye, scene.centre, to_body * state.up)
}

/// The files of one frame (paths relative to the sequence folder).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SequenceFiles {
    /// VIS, with sensor noise.
    pub vis: String,
    /// TIR, with sensor noise.
    pub tir: String,
    /// VIS without noise (when written).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vis_clean: Option<String>,
    /// TIR without noise (when written).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tir_clean: Option<String>,
    /// TIR with sensor noise as 16-bit counts (when written; `write_tir16`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tir16: Option<String>,
    /// The thermal camera's raw counts (when written; `focal_plane`). On a frame whose video the
    /// shutter froze, the previous frame's counts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tir_raw: Option<String>,
    /// The shutter's flat field captured at this frame (raw counts), when the shutter closed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tir_shutter: Option<String>,
    /// VIS target mask: 255 where the pixel sees the target, 0 elsewhere.
    pub vis_mask: String,
    /// TIR target mask.
    pub tir_mask: String,
    /// VIS Earth mask (with the Earth drawn): 255 where the pixel centre's ray misses the target
    /// and hits the Earth's surface (the limb's glow above it not counted).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vis_earth_mask: Option<String>,
    /// TIR Earth mask.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tir_earth_mask: Option<String>,
}

/// Ground truth of one frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceFrame {
    /// Frame index.
    pub index: usize,
    /// Time since the first frame, s.
    pub time_s: f64,
    /// Illumination phase.
    pub phase: Phase,
    /// Visible fraction of the solar disc.
    pub sun_fraction: f64,
    /// Camera position in the target frame, m.
    pub position_m: [f32; 3],
    /// Camera-to-target rotation, row-major; columns are the camera x (right), y (down), z
    /// (optical axis) in the target frame.
    pub rotation_cam_to_target: [[f32; 3]; 3],
    /// The same rotation as a unit quaternion (w, x, y, z).
    pub quaternion_wxyz: [f32; 4],
    /// Distance from the camera to the target centre, m.
    pub range_m: f32,
    /// Unit vector towards the sun in the target frame.
    pub sun_dir_target: [f32; 3],
    /// Target pixels in the VIS and TIR masks.
    pub target_pixels: [usize; 2],
    /// Mean node temperature of the target, K (weighted by face area).
    pub mean_temperature_k: f64,
    /// The thermal focal plane's warming since its calibration, K (with `focal_plane`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fpa_delta_k: Option<f64>,
    /// The shutter froze the thermal video on this frame: `tir_raw` repeats the frame before.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub tir_frozen: bool,
    /// With `glare`: the sun's angle from the VIS optical axis, degrees (in view below the
    /// half field of view, 17.5° in the study's camera).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sun_off_axis_deg: Option<f64>,
    /// With `glare`: VIS pixels at full well before the sensor noise (sun, halo, blooming,
    /// glints).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vis_saturated_pixels: Option<usize>,
    /// Files.
    pub files: SequenceFiles,
}

impl SequenceFrame {
    /// The camera pose this frame was rendered with (from the manifest's position and
    /// rotation).
    pub fn pose(&self) -> Pose {
        Pose {
            position: Vec3::from_array(self.position_m),
            rotation: glam::Mat3::from_cols_array_2d(&self.rotation_cam_to_target).transpose(),
        }
    }
}

/// Intrinsics of one camera of the sequence.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Image size (square), px.
    pub size: u32,
    /// Focal length, px.
    pub focal_px: f32,
    /// Principal point (x, y), px; pixel centres at `i + 0.5`.
    pub principal_point: [f32; 2],
}

impl Intrinsics {
    fn of(c: &Camera) -> Intrinsics {
        Intrinsics { size: c.width, focal_px: c.focal_px, principal_point: [c.cx, c.cy] }
    }
}

/// The manifest of a sequence (`manifest.json` in its folder).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceManifest {
    /// Program and version that wrote it.
    pub generator: String,
    /// The configuration.
    pub config: SequenceConfig,
    /// VIS camera.
    pub vis_camera: Intrinsics,
    /// TIR camera (same pose as VIS, unless `rig`).
    pub tir_camera: Intrinsics,
    /// Frames in each phase: light, penumbra, eclipse.
    pub phase_frames: [usize; 3],
    /// The thermal camera's factory NUC tables (`fusion_io::thermal`), with `focal_plane`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nuc: Option<String>,
    /// The thermal camera's factory bad-pixel map (8-bit PNG, 255 = bad), with `focal_plane`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bad_pixels: Option<String>,
    /// An offset rig's calibration (OpenCV `FileStorage` JSON, `fusion_io::rig`): the cameras
    /// are not aligned; without it they share one pose.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig: Option<String>,
    /// The frames.
    pub frames: Vec<SequenceFrame>,
}

/// Per frame: the node temperatures (integrated along the sequence), the state and the pose.
fn timeline(cfg: &SequenceConfig, scene: &Scene) -> Vec<(InertialState, Vec<f64>)> {
    let mut out = Vec::with_capacity(cfg.frames);
    let mut temps: Vec<f64> = Vec::new();
    let mut prev_fraction = 1.0;
    for i in 0..cfg.frames {
        let st = state(cfg, i);
        let sun_body = st.attitude.inverse() * st.sun;
        let params = ThermalParams { sun_dir: sun_body, ..cfg.thermal };
        if i == 0 {
            temps = steady_state(scene, &params);
        } else {
            // Over the frame interval, with this frame's geometry and the mean sun fraction of
            // the interval's ends.
            let balance = NodeBalance::new(scene, &params);
            temps =
                advance(&balance, &temps, 1.0 / cfg.frame_rate_hz, 0.5 * (prev_fraction + st.sun_fraction));
        }
        prev_fraction = st.sun_fraction;
        out.push((st, temps.clone()));
    }
    out
}

/// Renders a sequence into `out_dir`: `vis/`, `tir/` (noisy), `vis_clean/`, `tir_clean/`,
/// `vis_mask/`, `tir_mask/` with `frame_NNN.png` each, `manifest.json` and `contact_sheet.png`
/// (VIS and TIR of eight frames spread over the sequence). The scene carries the surface detail.
pub fn render_sequence(cfg: &SequenceConfig, out_dir: &Path, progress: bool) -> Result<SequenceManifest> {
    if cfg.frames == 0 {
        bail!("a sequence needs at least one frame");
    }
    if !(cfg.frame_rate_hz.is_finite() && cfg.frame_rate_hz > 0.0) {
        bail!("the frame rate must be positive");
    }
    if cfg.vis_size == 0 || cfg.tir_size == 0 {
        bail!("image sizes must be positive");
    }
    let scene = cfg.target.scene()?.with_surface_detail(cfg.surface_seed);
    let name = cfg.name.as_str();
    let mut dirs = vec!["vis", "tir", "vis_mask", "tir_mask"];
    if cfg.write_clean {
        dirs.extend(["vis_clean", "tir_clean"]);
    }
    if cfg.write_tir16 {
        dirs.push("tir16");
    }
    if cfg.earth.is_some() {
        dirs.extend(["vis_earth_mask", "tir_earth_mask"]);
    }
    let focal_plane = cfg.focal_plane.map(|p| {
        FocalPlane::new(p, cfg.tir_size as usize, cfg.tir_size as usize, cfg.tir.t_max - cfg.tir.t_min)
    });
    let shutters =
        focal_plane.as_ref().map(|f| f.shutter_frames(cfg.frames, cfg.frame_rate_hz)).unwrap_or_default();
    if focal_plane.is_some() {
        dirs.extend(["tir_raw", "tir_shutter", "calibration"]);
    } else if cfg.rig.is_some() {
        dirs.push("calibration");
    }
    for d in &dirs {
        let p = out_dir.join(d);
        fusion_io::output::make_folders(&p)?;
    }
    let bar = if progress { ProgressBar::new(cfg.frames as u64) } else { ProgressBar::hidden() };
    if let Ok(style) =
        ProgressStyle::with_template("{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} frames (eta {eta})")
    {
        bar.set_style(style);
    }
    bar.set_message(format!("rendering {name}"));
    let area: f64 = scene.faces.iter().map(|f| f64::from(f.area)).sum();
    let sheet_frames: Vec<usize> = crate::dataset::contact_sheet_columns(cfg.frames, 8);
    let results: Vec<Result<(SequenceFrame, Vec<Image>)>> = timeline(cfg, &scene)
        .into_par_iter()
        .enumerate()
        .map(|(i, (st, node_t))| {
            let pose = camera_pose(&st, &scene);
            let sun_body = (st.attitude.inverse() * st.sun).normalize();
            let earth_body = (st.attitude.inverse() * cfg.vis.earth_dir).normalize();
            let earth = cfg.earth.map(|e| earth_view(cfg, &e, &st, scene.centre, i));
            let mut vis_params = VisParams {
                sun_dir: sun_body,
                earth_dir: earth_body,
                sun_fraction: st.sun_fraction as f32,
                ..cfg.vis
            };
            if let Some(e) = &earth {
                vis_params.earthshine = e.earthshine(earth_body) as f32;
            }
            let face_t = face_temperatures(&scene, &node_t);
            let (vis_cam, tir_cam) = cameras(cfg, pose)?;
            // Each camera's target and Earth masks (ground truth, and where the sun can show).
            let masks = [&vis_cam, &tir_cam].map(|cam| {
                let target = target_mask(&scene, cam);
                let earth = earth.as_ref().map(|e| earth_mask(cam, e, &target));
                (target, earth)
            });
            let mut vis = render_vis_over(&scene, &vis_cam, &vis_params, earth.as_ref());
            let (mut sun_off_axis_deg, mut vis_saturated_pixels) = (None, None);
            if let Some(g) = &cfg.glare {
                let (target, earth) = &masks[0];
                let open: Vec<bool> = match earth {
                    Some(e) => target.iter().zip(e).map(|(t, e)| !t && !e).collect(),
                    None => target.iter().map(|t| !t).collect(),
                };
                crate::glare::add_sun(
                    &mut vis,
                    &vis_cam,
                    sun_body,
                    st.sun_fraction as f32,
                    cfg.vis.exposure,
                    &open,
                    g,
                );
                crate::glare::bloom(&mut vis, 1.0, g.blooming);
                let axis = vis_cam.pose.forward();
                sun_off_axis_deg = Some(f64::from(axis.dot(sun_body).clamp(-1.0, 1.0)).acos().to_degrees());
                vis_saturated_pixels = Some(vis.data.iter().filter(|&&v| v >= 1.0).count());
            }
            let tir_params = TirParams { earth_dir: earth_body, ..cfg.tir };
            let mut tir = render_tir_over(&scene, &tir_cam, &face_t, &tir_params, earth.as_ref());
            vis.clip();
            tir.clip();
            let vis_noisy = apply_sensor_noise(
                &vis,
                &cfg.noise,
                Band::Vis,
                &mut rng_for(cfg.seed, noise_stream(&format!("{name}_vis"), i)),
            );
            let tir_noisy = apply_sensor_noise(
                &tir,
                &cfg.noise,
                Band::Tir,
                &mut rng_for(cfg.seed, noise_stream(&format!("{name}_tir"), i)),
            );
            let file = format!("frame_{i:03}.png");
            let mut files = SequenceFiles {
                vis: format!("vis/{file}"),
                tir: format!("tir/{file}"),
                vis_mask: format!("vis_mask/{file}"),
                tir_mask: format!("tir_mask/{file}"),
                ..SequenceFiles::default()
            };
            write_png8(&out_dir.join(&files.vis), &vis_noisy.to_gray8())?;
            write_png8(&out_dir.join(&files.tir), &tir_noisy.to_gray8())?;
            if cfg.write_tir16 {
                let t = format!("tir16/{file}");
                write_png16(&out_dir.join(&t), &tir_noisy.to_gray16())?;
                files.tir16 = Some(t);
            }
            let mut fpa_delta_k = None;
            if let Some(fp) = &focal_plane {
                let t = cfg.time(i);
                let r = format!("tir_raw/{file}");
                let mut rng = rng_for(cfg.seed, noise_stream(&format!("{name}_tir_raw"), i));
                fp.write_raw(out_dir, &r, &tir_noisy, t, &mut rng)?;
                files.tir_raw = Some(r);
                if shutters.iter().any(|(s, _)| *s == i) {
                    let sh = format!("tir_shutter/{file}");
                    let mut rng = rng_for(cfg.seed, noise_stream(&format!("{name}_tir_shutter"), i));
                    fp.write_shutter(out_dir, &sh, cfg.tir.t_min, t, &mut rng)?;
                    files.tir_shutter = Some(sh);
                }
                fpa_delta_k = Some(fp.fpa_delta_k(t));
            }
            if cfg.write_clean {
                let (v, t) = (format!("vis_clean/{file}"), format!("tir_clean/{file}"));
                write_png8(&out_dir.join(&v), &vis.to_gray8())?;
                write_png8(&out_dir.join(&t), &tir.to_gray8())?;
                (files.vis_clean, files.tir_clean) = (Some(v), Some(t));
            }
            let mut target_pixels = [0usize; 2];
            for (k, (cam, rel)) in
                [(&vis_cam, &files.vis_mask), (&tir_cam, &files.tir_mask)].into_iter().enumerate()
            {
                let (mask, earth_pixels) = &masks[k];
                target_pixels[k] = mask.iter().filter(|&&m| m).count();
                write_mask(out_dir, rel, cam, mask)?;
                if let Some(e) = earth_pixels {
                    let band = if k == 0 { "vis" } else { "tir" };
                    let rel = format!("{band}_earth_mask/{file}");
                    write_mask(out_dir, &rel, cam, e)?;
                    *(if k == 0 { &mut files.vis_earth_mask } else { &mut files.tir_earth_mask }) = Some(rel);
                }
            }
            let mut thumbs = Vec::new();
            if sheet_frames.contains(&i) {
                thumbs.push(vis_noisy.thumbnail(200));
                thumbs.push(tir_noisy.thumbnail(200));
            }
            let q = pose.quaternion();
            let mean_t =
                scene.faces.iter().zip(&face_t).map(|(f, &t)| f64::from(f.area) * f64::from(t)).sum::<f64>()
                    / area;
            bar.inc(1);
            Ok((
                SequenceFrame {
                    index: i,
                    time_s: cfg.time(i),
                    phase: Phase::of(st.sun_fraction),
                    sun_fraction: st.sun_fraction,
                    position_m: pose.position.to_array(),
                    rotation_cam_to_target: rows_of(pose.rotation),
                    quaternion_wxyz: [q.w, q.x, q.y, q.z],
                    range_m: (pose.position - scene.centre).length(),
                    sun_dir_target: sun_body.to_array(),
                    target_pixels,
                    mean_temperature_k: mean_t,
                    fpa_delta_k,
                    tir_frozen: shutters.iter().any(|(_, frozen)| frozen.contains(&i)),
                    sun_off_axis_deg,
                    vis_saturated_pixels,
                    files,
                },
                thumbs,
            ))
        })
        .collect();
    bar.finish_and_clear();
    let mut frames = Vec::with_capacity(cfg.frames);
    let mut columns = Vec::new();
    for r in results {
        let (f, thumbs) = r?;
        if !thumbs.is_empty() {
            columns.push(thumbs);
        }
        frames.push(f);
    }
    // The shutter froze the video: those frames repeat the counts of the frame before, in
    // order (a run of frozen frames repeats the last live one).
    for f in frames.iter().filter(|f| f.tir_frozen) {
        if let (Some(prev), Some(this)) = (f.index.checked_sub(1), &f.files.tir_raw) {
            crate::focal_plane::repeat_frozen(out_dir, &format!("tir_raw/frame_{prev:03}.png"), this)?;
        }
    }
    let (mut nuc, mut bad_pixels) = (None, None);
    if let Some(fp) = &focal_plane {
        let (n, b) = fp.write_calibration(out_dir, "calibration/tir")?;
        (nuc, bad_pixels) = (Some(n), Some(b));
    }
    let mut phase_frames = [0usize; 3];
    for f in &frames {
        phase_frames[f.phase as usize] += 1;
    }
    let names: Vec<String> = sheet_frames
        .iter()
        .map(|&i| format!("{i} {}", frames.get(i).map_or("", |f| f.phase.as_str())))
        .collect();
    let sheet = contact_sheet(&columns, &names, &["VIS".to_string(), "TIR".to_string()]);
    fusion_io::save_gray_u8(&out_dir.join("contact_sheet.png"), &sheet)?;
    let reference = cameras(cfg, Pose::look_at(Vec3::Z, Vec3::ZERO, Vec3::Y))?;
    let rig = match &cfg.rig {
        Some(r) => {
            let rel = "calibration/rig.json";
            fusion_io::write_bytes(&out_dir.join(rel), fusion_io::rig::to_json(r).as_bytes())?;
            Some(rel.to_string())
        }
        None => None,
    };
    let manifest = SequenceManifest {
        generator: format!("render-host {}", env!("CARGO_PKG_VERSION")),
        config: cfg.clone(),
        vis_camera: Intrinsics::of(&reference.0),
        tir_camera: Intrinsics::of(&reference.1),
        rig,
        phase_frames,
        nuc,
        bad_pixels,
        frames,
    };
    write_json(&out_dir.join("manifest.json"), &manifest)?;
    Ok(manifest)
}

/// The sequence's two cameras with the visible one at `pose`: the study's aligned pair, or
/// the rig's.
pub fn cameras(cfg: &SequenceConfig, pose: Pose) -> Result<(Camera, Camera)> {
    match &cfg.rig {
        Some(rig) => crate::rig::cameras(rig, pose),
        None => Ok((Camera::study(cfg.vis_size, pose), Camera::study(cfg.tir_size, pose))),
    }
}

/// Reads a sequence's `manifest.json` and refuses one whose values a renderer could not have
/// written ([`SequenceManifest::check`]): a damaged or hand-edited manifest is named, not judged.
pub fn read_manifest(dir: &Path) -> Result<SequenceManifest> {
    let path = dir.join("manifest.json");
    let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
    let m: SequenceManifest = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a sequence manifest", path.display()))?;
    m.check().map_err(|why| anyhow::anyhow!("{}: {why}", path.display()))?;
    Ok(m)
}

/// Whether a manifest's file name stays inside the sequence's folder (relative, no `..`).
fn inside_folder(name: &str) -> bool {
    !name.is_empty() && Path::new(name).components().all(|c| matches!(c, std::path::Component::Normal(_)))
}

/// Tolerance of the manifest's consistency checks: its poses are stored in `f32`.
const MANIFEST_TOLERANCE: f32 = 1e-3;

impl SequenceManifest {
    /// Checks what a renderer guarantees of its manifest: cameras with a positive focal length
    /// and the principal point on the image; frames in time order; per frame a finite position
    /// and a positive range, a unit quaternion, a rotation that is orthonormal and that
    /// quaternion's, a sun fraction in [0, 1], a unit sun direction, and files named inside the
    /// sequence's folder. The reason names the frame and the field.
    pub fn check(&self) -> std::result::Result<(), String> {
        for (name, c) in [("vis_camera", &self.vis_camera), ("tir_camera", &self.tir_camera)] {
            if c.size == 0 {
                return Err(format!("{name}.size 0 is not an image size"));
            }
            if !(c.focal_px.is_finite() && c.focal_px > 0.0) {
                return Err(format!("{name}.focal_px {} is not a positive length", c.focal_px));
            }
            let on_image = |v: f32| v.is_finite() && (0.0..=c.size as f32).contains(&v);
            if !c.principal_point.iter().all(|&v| on_image(v)) {
                return Err(format!(
                    "{name}.principal_point {:?} is not on the {}x{} image",
                    c.principal_point, c.size, c.size
                ));
            }
        }
        for name in [&self.nuc, &self.bad_pixels, &self.rig].into_iter().flatten() {
            if !inside_folder(name) {
                return Err(format!("file {name:?} is not a path inside the sequence's folder"));
            }
        }
        let tol = MANIFEST_TOLERANCE;
        for (k, f) in self.frames.iter().enumerate() {
            let bad = |what: String| Err(format!("frame {k}: {what}"));
            if k > 0 && f.time_s.partial_cmp(&self.frames[k - 1].time_s) != Some(std::cmp::Ordering::Greater)
            {
                return bad(format!(
                    "time_s {} is not after the frame before ({})",
                    f.time_s,
                    self.frames[k - 1].time_s
                ));
            }
            if !f.time_s.is_finite() {
                return bad(format!("time_s {} is not finite", f.time_s));
            }
            if !(0.0..=1.0).contains(&f.sun_fraction) {
                return bad(format!("sun_fraction {} is outside 0 to 1", f.sun_fraction));
            }
            let p = Vec3::from_array(f.position_m);
            if !(p.is_finite() && f.range_m.is_finite() && f.range_m > 0.0) {
                return bad(format!(
                    "position_m {:?} and range_m {} are not a position",
                    f.position_m, f.range_m
                ));
            }
            let q = glam::Quat::from_xyzw(
                f.quaternion_wxyz[1],
                f.quaternion_wxyz[2],
                f.quaternion_wxyz[3],
                f.quaternion_wxyz[0],
            );
            if !q.is_finite() || (q.length() - 1.0).abs() > tol {
                return bad(format!("quaternion_wxyz {:?} is not a unit quaternion", f.quaternion_wxyz));
            }
            let r = glam::Mat3::from_cols_array_2d(&f.rotation_cam_to_target).transpose();
            let rq = glam::Mat3::from_quat(q);
            let differs = |a: glam::Mat3, b: glam::Mat3| {
                (0..3).any(|i| (a.col(i) - b.col(i)).abs().max_element() > tol || !a.col(i).is_finite())
            };
            if differs(r.transpose() * r, glam::Mat3::IDENTITY) || differs(r, rq) {
                return bad("rotation_cam_to_target is not the rotation of quaternion_wxyz".to_string());
            }
            let sun = Vec3::from_array(f.sun_dir_target);
            if !sun.is_finite() || (sun.length() - 1.0).abs() > tol {
                return bad(format!("sun_dir_target {:?} is not a unit vector", f.sun_dir_target));
            }
            let files = &f.files;
            let named = [Some(&files.vis), Some(&files.tir), Some(&files.vis_mask), Some(&files.tir_mask)]
                .into_iter()
                .chain(
                    [
                        &files.vis_clean,
                        &files.tir_clean,
                        &files.tir16,
                        &files.tir_raw,
                        &files.tir_shutter,
                        &files.vis_earth_mask,
                        &files.tir_earth_mask,
                    ]
                    .map(Option::as_ref),
                )
                .flatten();
            for name in named {
                if !inside_folder(name) {
                    return bad(format!("file {name:?} is not a path inside the sequence's folder"));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sun_phase_angle_is_the_angle_asked_and_the_trajectory_stays() {
        for name in [SequenceName::Approach, SequenceName::Flyaround] {
            let plain = SequenceConfig::new(name);
            let angle = |st: &InertialState| {
                f64::from(st.eye.normalize().dot(st.sun).clamp(-1.0, 1.0)).acos().to_degrees()
            };
            // The approach's own sun is 14.3° from its first line of sight, as the module says.
            if name == SequenceName::Approach {
                assert!((angle(&state(&plain, 0)) - 14.3).abs() < 0.1, "{}", angle(&state(&plain, 0)));
            }
            for phase in [0.0, 45.0, 90.0, 150.0, 180.0] {
                let cfg = SequenceConfig { sun_phase_deg: Some(phase), ..plain.clone() };
                let (a, b) = (state(&cfg, 0), state(&plain, 0));
                assert!((angle(&a) - phase).abs() < 0.01, "{name:?} {phase}: {}", angle(&a));
                assert_eq!(
                    (a.eye, a.attitude, a.up, a.sun_fraction),
                    (b.eye, b.attitude, b.up, b.sun_fraction)
                );
                assert!((a.sun.length() - 1.0).abs() < 1e-6);
                // One sun for the whole sequence.
                assert_eq!(state(&cfg, 7).sun, a.sun);
            }
        }
    }

    /// The radial sequence against geometry worked independently: the Earth behind every pixel
    /// (the camera corners' rays end on the Earth's sphere), the first phase angle as asked,
    /// the eclipse where the target is in the Earth's cylindrical shadow (light and umbra
    /// frames; the penumbra lies within a disc's width of the cylinder), the sun fixed on the
    /// ground (the terminator does not slide), and the penumbra as long as the sun's diameter
    /// takes at the mean motion (2 × 0.2665° / 0.063 51 °/s = 8.39 s at 500 km).
    #[test]
    fn the_radial_sequence_has_the_earth_behind_and_its_eclipse_from_the_geometry() {
        use crate::earth::{EARTH_RADIUS_M, EarthParams};
        let cfg = SequenceConfig { vis_size: 64, tir_size: 32, ..SequenceConfig::new(SequenceName::Radial) };
        let earth = cfg.earth.expect("radial draws the Earth");
        let scene = Scene::tango().unwrap();
        let nadir = cfg.vis.earth_dir.normalize().as_dvec3();
        let r = EARTH_RADIUS_M + earth.altitude_m;
        // The Earth's centre from the target, inertial (orbit-local) frame.
        let centre = nadir * r;
        let angle = |a: Vec3, b: Vec3| f64::from(a.normalize().dot(b.normalize()).clamp(-1.0, 1.0)).acos();
        let (mut light, mut umbra) = (0, 0);
        let mut on_ground = None;
        for i in 0..cfg.frames {
            let st = state(&cfg, i);
            // Every corner ray of the VIS camera ends on the Earth.
            let pose = camera_pose(&st, &scene);
            let (vis, _) = cameras(&cfg, pose).unwrap();
            for (x, y) in [(0, 0), (63, 0), (0, 63), (63, 63)] {
                let d = (st.attitude * vis.pixel_ray(x, y)).as_dvec3();
                let o = st.eye.as_dvec3();
                // Ray o + s d meets the sphere |p − centre| = R.
                let oc = o - centre;
                let b = oc.dot(d);
                let disc = b * b - (oc.length_squared() - EARTH_RADIUS_M * EARTH_RADIUS_M);
                assert!(
                    disc > 0.0 && -b - disc.sqrt() > 0.0,
                    "frame {i}: corner ({x}, {y}) misses the Earth"
                );
            }
            if i == 0 {
                let phase = angle(st.eye, st.sun).to_degrees();
                assert!((phase - RADIAL_SUN_PHASE_DEG).abs() < 0.01, "{phase}");
            }
            // The target (at −centre from the Earth's centre) in the shadow cylinder.
            let p = -centre;
            let sun = st.sun.as_dvec3().normalize();
            let in_cylinder = p.dot(sun) < 0.0 && p.cross(sun).length() < EARTH_RADIUS_M;
            if st.sun_fraction >= 1.0 {
                assert!(!in_cylinder, "frame {i}: lit inside the shadow");
                light += 1;
            } else if st.sun_fraction <= 0.0 {
                assert!(in_cylinder, "frame {i}: eclipsed outside the shadow");
                umbra += 1;
            }
            // The sun as the ground sees it stays put.
            let view = earth_view(&cfg, &earth, &st, scene.centre, i);
            let sun_on_ground = view.to_surface * (st.attitude.inverse() * st.sun).as_dvec3();
            let first = *on_ground.get_or_insert(sun_on_ground);
            assert!((sun_on_ground - first).length() < 1e-5, "frame {i}: the terminator slid");
        }
        assert!(light > 50 && umbra > 45, "light {light}, umbra {umbra}");
        // The penumbra's length from the fraction alone, on a fine clock.
        let fine = SequenceConfig { frames: 1201, frame_rate_hz: 10.0, ..cfg.clone() };
        let partial = (0..fine.frames)
            .filter(|&i| {
                (0.0..1.0).contains(&state(&fine, i).sun_fraction) && state(&fine, i).sun_fraction > 0.0
            })
            .count();
        let expect = 2.0 * SUN_ANGULAR_RADIUS / EarthParams::default().mean_motion();
        assert!(
            (partial as f64 / 10.0 - expect).abs() < 0.25,
            "{} s against {expect} s",
            partial as f64 / 10.0
        );
        assert!((expect - 8.39).abs() < 0.01, "{expect}");
    }

    #[test]
    fn the_sun_sets_behind_the_limb_as_a_disc() {
        // 500 km: the limb 68.01° from the nadir (asin(6371 / 6871)).
        let limb = (6371.0f64 / 6871.0).asin();
        assert!((limb.to_degrees() - 68.01).abs() < 0.01);
        assert_eq!(sun_fraction_above_limb(limb + 0.01, 500e3), 1.0);
        assert!(sun_fraction_above_limb(limb - 0.01, 500e3).abs() < 1e-12);
        assert!((sun_fraction_above_limb(limb, 500e3) - 0.5).abs() < 1e-9);
        // Half a radius above the limb: a quarter of the diameter covered.
        let f = sun_fraction_above_limb(limb + 0.5 * SUN_ANGULAR_RADIUS, 500e3);
        assert!((f - disc_fraction_uncovered(0.25)).abs() < 1e-6, "{f}");
    }

    #[test]
    fn the_uncovered_disc_fraction_is_a_circular_segment() {
        assert_eq!(disc_fraction_uncovered(0.0), 1.0);
        assert!(disc_fraction_uncovered(1.0).abs() < 1e-12);
        assert!((disc_fraction_uncovered(0.5) - 0.5).abs() < 1e-12);
        // Symmetric, and monotone.
        for k in 0..=20 {
            let p = f64::from(k) / 20.0;
            assert!((disc_fraction_uncovered(p) + disc_fraction_uncovered(1.0 - p) - 1.0).abs() < 1e-12);
            assert!(disc_fraction_uncovered(p + 0.01) <= disc_fraction_uncovered(p));
        }
        // At a quarter of the diameter: 1 − (acos(0.5) − 0.5·√0.75)/π = 0.8045.
        assert!((disc_fraction_uncovered(0.25) - 0.804_498).abs() < 1e-5);
    }
}
