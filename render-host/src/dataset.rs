//! Datasets in the study's layout: a camera on a tilted ellipse around the target, VIS in light
//! and in eclipse, TIR at 512² and 1024², noiseless and noisy, PNGs plus a JSON manifest.

use crate::camera::{Camera, Pose};
use crate::focal_plane::{FocalPlane, FocalPlaneParams, repeat_frozen};
use crate::image::Image;
use crate::image::{write_png8, write_png16};
use crate::noise::{Band, NoiseParams, apply_sensor_noise, rng_for};
use crate::scene::{Material, Scene};
use crate::thermal::{ThermalParams, eclipse_transient, face_temperatures, steady_state};
use crate::tir::{TirParams, render_tir};
use crate::vis::{Illumination, VisParams, render_vis};
use anyhow::{Result, bail};
use fusion_io::output::write_json;
use glam::{Mat3, Vec3};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Everything that defines a dataset. `Default` is the study's layout.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetConfig {
    /// Frames per set.
    pub frames: usize,
    /// Seed of every random draw.
    pub seed: u64,
    /// Target mesh (OBJ); `None` = the procedural [`target`](Self::target).
    pub mesh: Option<PathBuf>,
    /// The procedural target rendered without a mesh. Configurations without the field read
    /// the Tango-like one.
    #[serde(default, skip_serializing_if = "crate::scene::Target::is_default")]
    pub target: crate::scene::Target,
    /// Scale applied to the OBJ mesh's coordinates (to metres).
    pub mesh_scale: f32,
    /// Material of OBJ faces whose names give no hint.
    pub mesh_default_material: Material,
    /// VIS image size (square), pixels.
    pub vis_size: u32,
    /// TIR image sizes (square), pixels; one set each.
    pub tir_sizes: Vec<u32>,
    /// Full axes of the camera's ellipse (major, minor), m.
    pub ellipse_full_axes_m: [f64; 2],
    /// Tilt of the ellipse plane about its major axis added every `frames_per_tilt` frames, °.
    pub tilt_step_deg: f64,
    /// Frames on one ellipse before it tilts.
    pub frames_per_tilt: usize,
    /// VIS lighting (its illumination field is overridden per set).
    pub vis: VisParams,
    /// Thermal environment (its sun direction is overridden by `vis.sun_dir`).
    pub thermal: ThermalParams,
    /// TIR radiometry and DN mapping.
    pub tir: TirParams,
    /// Also write TIR sets after this many minutes in eclipse (lumped transient).
    pub tir_eclipse_minutes: Option<f64>,
    /// Sensor noise.
    pub noise: NoiseParams,
    /// Write the noiseless images.
    pub write_clean: bool,
    /// Write the noisy images.
    pub write_noisy: bool,
    /// Also write 16-bit TIR PNGs.
    pub tir_16bit: bool,
    /// Tile size of the contact sheet, px (0 = no contact sheet).
    pub contact_sheet_thumb: u32,
    /// Frames (columns) on the contact sheet, evenly spaced over the dataset (0 = all).
    #[serde(default)]
    pub contact_sheet_frames: usize,
    /// Procedural surface detail on the target (`crate::surface`: cells, crinkled MLI, bolts,
    /// in-face temperature gradients); `false`: flat faces (the renders before issue 20).
    /// Manifests written before the field existed read as `false`.
    #[serde(default)]
    pub surface_detail: bool,
    /// Seed of the surface detail: part of the target's make-up, so it is not `seed` (which
    /// draws the sensor noise): another noise seed shows the same spacecraft.
    #[serde(default)]
    pub surface_seed: u64,
    /// Write the thermal camera's raw counts too: per TIR set `raw/` (16-bit PNG of the
    /// focal plane's counts, [`crate::focal_plane`], from the noisy frame) and `shutter/` (its
    /// flat fields, on the frames the shutter closes), frames [`DATASET_FRAME_INTERVAL_S`]
    /// apart; the factory calibration per TIR size in `calibration/` (named by the sets'
    /// `nuc` and `bad_pixels`). Absent from manifests written without it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub focal_plane: Option<FocalPlaneParams>,
}

/// Time between two frames of a dataset for the focal plane's drift and shutter, s: the
/// study's layout has no clock, so its frames are taken as a 1 Hz video like the sequences.
pub const DATASET_FRAME_INTERVAL_S: f64 = 1.0;

impl Default for DatasetConfig {
    fn default() -> Self {
        DatasetConfig {
            frames: 20,
            seed: 1,
            mesh: None,
            target: crate::scene::Target::default(),
            mesh_scale: 1.0,
            mesh_default_material: Material::MliKapton,
            vis_size: 1024,
            tir_sizes: vec![512, 1024],
            ellipse_full_axes_m: [14.5, 8.0],
            tilt_step_deg: 45.0,
            frames_per_tilt: 5,
            vis: VisParams::light(),
            thermal: ThermalParams::default(),
            tir: TirParams::default(),
            tir_eclipse_minutes: None,
            noise: NoiseParams::default(),
            write_clean: true,
            write_noisy: true,
            tir_16bit: false,
            contact_sheet_thumb: 160,
            contact_sheet_frames: 5,
            surface_detail: true,
            surface_seed: 0,
            focal_plane: None,
        }
    }
}

impl DatasetConfig {
    /// A quick demo: the study's layout with 4 frames.
    pub fn demo() -> Self {
        DatasetConfig { frames: 4, ..Self::default() }
    }

    /// A tiny layout for tests: `frames` frames, VIS `size`², TIR `size/2`² and `size`².
    pub fn small(frames: usize, size: u32) -> Self {
        DatasetConfig {
            frames,
            vis_size: size,
            tir_sizes: vec![size / 2, size],
            contact_sheet_thumb: 32,
            contact_sheet_frames: 0,
            ..Self::default()
        }
    }

    /// Loads the target this configuration names.
    pub fn scene(&self) -> Result<Scene> {
        let scene = match &self.mesh {
            None => self.target.scene()?,
            Some(p) => Scene::from_obj(p, self.mesh_default_material, self.mesh_scale)?,
        };
        Ok(if self.surface_detail { scene.with_surface_detail(self.surface_seed) } else { scene })
    }
}

/// One camera position of a dataset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryPoint {
    /// The camera pose.
    pub pose: Pose,
    /// Eccentric anomaly on the ellipse, °.
    pub anomaly_deg: f64,
    /// Tilt of the ellipse plane, °.
    pub tilt_deg: f64,
}

/// The camera trajectory: frame `i` sits on the ellipse `x = a cos θ`, `y' = b sin θ` around
/// `centre` (`a`, `b` the semi-axes, major axis along the target's x), whose plane is tilted about
/// the major axis by `tilt_step × g`, `g = ⌊i / frames_per_tilt⌋`. With `k = frames_per_tilt`,
/// `j = i mod k` and `n = round(180° / tilt_step)` distinct tilts, `θ = 360° (j + (g mod n)/n) / k`:
/// each tilt starts a fraction of a step further round, so no two frames share a position (the
/// study's 20 frames: θ on an 18° grid, ranges 4–7.25 m). The camera looks at `centre` with
/// image-up along the ellipse plane's normal.
pub fn trajectory(cfg: &DatasetConfig, centre: Vec3) -> Vec<TrajectoryPoint> {
    let k = cfg.frames_per_tilt.max(1);
    let (a, b) = (cfg.ellipse_full_axes_m[0] / 2.0, cfg.ellipse_full_axes_m[1] / 2.0);
    let tilts =
        if cfg.tilt_step_deg.abs() > 1e-9 { (180.0 / cfg.tilt_step_deg.abs()).round().max(1.0) } else { 1.0 };
    (0..cfg.frames)
        .map(|i| {
            let (g, j) = (i / k, i % k);
            let tilt = cfg.tilt_step_deg * g as f64;
            let offset = (g as f64 % tilts) / tilts;
            let theta = std::f64::consts::TAU * (j as f64 + offset) / k as f64;
            let rot = Mat3::from_rotation_x(tilt.to_radians() as f32);
            let local = Vec3::new((a * theta.cos()) as f32, (b * theta.sin()) as f32, 0.0);
            let eye = centre + rot * local;
            TrajectoryPoint {
                pose: Pose::look_at(eye, centre, rot * Vec3::Z),
                anomaly_deg: theta.to_degrees(),
                tilt_deg: tilt,
            }
        })
        .collect()
}

/// What one set of a dataset shows.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum SetKind {
    /// VIS under an illumination.
    Vis {
        /// Light or eclipse.
        illumination: Illumination,
    },
    /// TIR of the sunlit steady state.
    Tir,
    /// TIR after `tir_eclipse_minutes` in eclipse.
    TirEclipse,
}

/// One set of a dataset as recorded in the manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SetInfo {
    /// Name, also the folder: `vis_light`, `vis_eclipse`, `tir512`, `tir1024`, `tir512_eclipse` ….
    pub name: String,
    /// What it shows.
    pub kind: SetKind,
    /// Sensor band.
    pub band: Band,
    /// Image width, px.
    pub width: u32,
    /// Image height, px.
    pub height: u32,
    /// Focal length, px.
    pub focal_px: f32,
    /// Principal point (x, y), px (pixel centres at `i + 0.5`).
    pub principal_point: [f32; 2],
    /// The thermal camera's factory NUC tables (`fusion_io::thermal`), with raw counts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nuc: Option<String>,
    /// The thermal camera's factory bad-pixel map (8-bit PNG, 255 = bad), with raw counts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bad_pixels: Option<String>,
}

/// The files of one frame of one set (paths relative to the dataset folder).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameFiles {
    /// Noiseless 8-bit PNG.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clean: Option<String>,
    /// Noisy 8-bit PNG.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noisy: Option<String>,
    /// Noiseless 16-bit PNG (TIR with `tir_16bit`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clean16: Option<String>,
    /// Noisy 16-bit PNG (TIR with `tir_16bit`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noisy16: Option<String>,
    /// The focal plane's raw counts, 16-bit PNG (TIR with `focal_plane`); on a frozen frame
    /// the previous frame's counts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub raw: Option<String>,
    /// The shutter's flat field, on the frames where it closes (TIR with `focal_plane`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shutter: Option<String>,
}

/// The random stream of frame `frame` of set `set`: a hash of the set's name and the frame
/// index, so a set's noise does not depend on which other sets the dataset has.
pub fn noise_stream(set: &str, frame: usize) -> u64 {
    // FNV-1a over the name, then the frame index mixed in.
    let h =
        set.bytes().fold(0xCBF2_9CE4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01B3));
    crate::noise::mix64(h) ^ frame as u64
}

/// The frames shown on the contact sheet: `n` evenly spaced indices out of `frames` (all of
/// them when `n` is 0 or at least `frames`).
pub fn contact_sheet_columns(frames: usize, n: usize) -> Vec<usize> {
    if n == 0 || n >= frames {
        return (0..frames).collect();
    }
    if n == 1 {
        return vec![0];
    }
    (0..n).map(|k| (k * (frames - 1) + (n - 1) / 2) / (n - 1)).collect()
}

/// One frame in the manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameInfo {
    /// Frame index.
    pub index: usize,
    /// Camera position in the target frame, m.
    pub position_m: [f32; 3],
    /// Camera-to-target rotation, row-major; columns are the camera x (right), y (down), z
    /// (optical axis) in the target frame.
    pub rotation_cam_to_target: [[f32; 3]; 3],
    /// The same rotation as a unit quaternion (w, x, y, z).
    pub quaternion_wxyz: [f32; 4],
    /// Distance from the camera to the target centre, m.
    pub range_m: f32,
    /// Eccentric anomaly on the ellipse, °.
    pub anomaly_deg: f64,
    /// Tilt of the ellipse plane, °.
    pub tilt_deg: f64,
    /// Files per set name.
    pub files: BTreeMap<String, FrameFiles>,
    /// The thermal focal plane's warming since its calibration, K (with `focal_plane`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fpa_delta_k: Option<f64>,
    /// The shutter froze the thermal video on this frame: every `raw` repeats the frame before.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub tir_frozen: bool,
}

/// The JSON manifest of a dataset (`manifest.json` in its folder).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Program and version that wrote it.
    pub generator: String,
    /// Seed of every random draw.
    pub seed: u64,
    /// Target: `tango` or the OBJ path.
    pub target: String,
    /// Target centre the cameras look at (target frame), m.
    pub target_centre_m: [f32; 3],
    /// Unit vector towards the sun (target frame).
    pub sun_direction: [f32; 3],
    /// Unit vector towards the Earth (earthshine).
    pub earth_direction: [f32; 3],
    /// TIR DN range: temperatures mapped to 0 and to full scale, K.
    pub temperature_range_k: [f64; 2],
    /// Sunlit steady-state temperature per thermal node, K.
    pub node_temperatures_k: Vec<f64>,
    /// Node temperatures after the eclipse transient, K (if rendered).
    pub eclipse_node_temperatures_k: Option<Vec<f64>>,
    /// Face → thermal node and material.
    pub faces: Vec<(u32, Material)>,
    /// The configuration that produced the dataset (noise parameters, radiometry, …).
    pub config: DatasetConfig,
    /// The sets.
    pub sets: Vec<SetInfo>,
    /// The frames.
    pub frames: Vec<FrameInfo>,
    /// Contact-sheet file, if written.
    pub contact_sheet: Option<String>,
    /// Rows of the contact sheet, top to bottom (`set/clean`, `set/noisy`).
    pub contact_sheet_rows: Vec<String>,
    /// Frame index of each contact-sheet column, left to right.
    #[serde(default)]
    pub contact_sheet_columns: Vec<usize>,
}

/// The sets a configuration produces, in order.
pub fn sets(cfg: &DatasetConfig) -> Vec<SetInfo> {
    let mut out = Vec::new();
    let mut push = |name: String, kind: SetKind, band: Band, size: u32| {
        let cam = Camera::study(size, Pose::look_at(Vec3::X, Vec3::ZERO, Vec3::Z));
        out.push(SetInfo {
            name,
            kind,
            band,
            width: size,
            height: size,
            focal_px: cam.focal_px,
            principal_point: [cam.cx, cam.cy],
            nuc: None,
            bad_pixels: None,
        });
    };
    for ill in [Illumination::Light, Illumination::Eclipse] {
        let name = match ill {
            Illumination::Light => "vis_light",
            Illumination::Eclipse => "vis_eclipse",
        };
        push(name.into(), SetKind::Vis { illumination: ill }, Band::Vis, cfg.vis_size);
    }
    for &s in &cfg.tir_sizes {
        push(format!("tir{s}"), SetKind::Tir, Band::Tir, s);
    }
    if cfg.tir_eclipse_minutes.is_some() {
        for &s in &cfg.tir_sizes {
            push(format!("tir{s}_eclipse"), SetKind::TirEclipse, Band::Tir, s);
        }
    }
    out
}

fn arr(v: Vec3) -> [f32; 3] {
    v.to_array()
}

/// Files per set of one frame, and its contact-sheet thumbnails.
type FrameOutput = (BTreeMap<String, FrameFiles>, Vec<Image>);

/// Renders a dataset into `out_dir` (created if missing): per set a folder with `clean/` and
/// `noisy/` PNGs named `frame_NNN.png` (and `clean16/`, `noisy16/` for 16-bit TIR; `raw/`,
/// `shutter/` and `calibration/` with [`DatasetConfig::focal_plane`]), plus
/// `manifest.json` and `contact_sheet.png`. Frames render in parallel (rayon), and so do the rows
/// of each image; `progress` shows an `indicatif` bar counting images.
///
/// The contact sheet has one row per set and version (`vis_light/clean`, `vis_light/noisy`, …,
/// see [`Manifest::contact_sheet_rows`]) and one column per selected frame; each tile is the
/// square around the target's bounding sphere (so tiles of one column show the same region in
/// every band), area-averaged to `contact_sheet_thumb` pixels.
pub fn render_dataset(cfg: &DatasetConfig, out_dir: &Path, progress: bool) -> Result<Manifest> {
    if cfg.frames == 0 {
        bail!("a dataset needs at least one frame");
    }
    if cfg.vis_size == 0 || cfg.tir_sizes.contains(&0) {
        bail!("image sizes must be positive");
    }
    if (1..cfg.tir_sizes.len()).any(|i| cfg.tir_sizes[..i].contains(&cfg.tir_sizes[i])) {
        bail!("TIR sizes must be distinct: {:?}", cfg.tir_sizes);
    }
    let scene = cfg.scene()?;
    let sun = cfg.vis.sun_dir.normalize();
    let thermal = ThermalParams { sun_dir: sun, ..cfg.thermal };
    let node_t = steady_state(&scene, &thermal);
    let eclipse_t = cfg.tir_eclipse_minutes.map(|m| eclipse_transient(&scene, &thermal, &node_t, m * 60.0));
    let face_t = face_temperatures(&scene, &node_t);
    let face_t_eclipse = eclipse_t.as_ref().map(|t| face_temperatures(&scene, t));
    let set_list = sets(cfg);
    let traj = trajectory(cfg, scene.centre);
    let tir_params = TirParams { earth_dir: cfg.vis.earth_dir, ..cfg.tir };

    // One thermal camera per TIR size (the eclipse sets are the same camera later on).
    let range_k = cfg.tir.t_max - cfg.tir.t_min;
    let focal_planes: BTreeMap<u32, FocalPlane> = cfg
        .focal_plane
        .map(|p| {
            cfg.tir_sizes.iter().map(|&s| (s, FocalPlane::new(p, s as usize, s as usize, range_k))).collect()
        })
        .unwrap_or_default();
    let shutters = focal_planes
        .values()
        .next()
        .map(|fp| fp.shutter_frames(cfg.frames, 1.0 / DATASET_FRAME_INTERVAL_S))
        .unwrap_or_default();

    fusion_io::output::make_folders(out_dir)?;
    if !focal_planes.is_empty() {
        let d = out_dir.join("calibration");
        fusion_io::output::make_folders(&d)?;
    }
    for s in &set_list {
        let raw = s.band == Band::Tir && !focal_planes.is_empty();
        for sub in ["clean", "noisy", "clean16", "noisy16", "raw", "shutter"] {
            let wanted = match sub {
                "clean" => cfg.write_clean,
                "noisy" => cfg.write_noisy,
                "clean16" => cfg.write_clean && cfg.tir_16bit && s.band == Band::Tir,
                "noisy16" => cfg.write_noisy && cfg.tir_16bit && s.band == Band::Tir,
                "raw" => raw,
                _ => raw && !shutters.is_empty(),
            };
            if wanted {
                let d = out_dir.join(&s.name).join(sub);
                fusion_io::output::make_folders(&d)?;
            }
        }
    }

    let bar =
        if progress { ProgressBar::new((cfg.frames * set_list.len()) as u64) } else { ProgressBar::hidden() };
    if let Ok(style) =
        ProgressStyle::with_template("{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} images (eta {eta})")
    {
        bar.set_style(style);
    }
    bar.set_message("rendering");

    let thumb = cfg.contact_sheet_thumb;
    let columns =
        if thumb > 0 { contact_sheet_columns(cfg.frames, cfg.contact_sheet_frames) } else { Vec::new() };
    // Per frame: the files per set and the thumbnails (set-major: clean, noisy).
    let results: Vec<Result<FrameOutput>> = traj
        .par_iter()
        .enumerate()
        .map(|(i, tp)| {
            let mut files = BTreeMap::new();
            let mut thumbs = Vec::new();
            for s in &set_list {
                let cam = Camera::study(s.width, tp.pose);
                let mut clean = match s.kind {
                    SetKind::Vis { illumination } => render_vis(
                        &scene,
                        &cam,
                        &VisParams { sun_dir: sun, ..cfg.vis }.with_illumination(illumination),
                    ),
                    SetKind::Tir => render_tir(&scene, &cam, &face_t, &tir_params),
                    SetKind::TirEclipse => {
                        render_tir(&scene, &cam, face_t_eclipse.as_deref().unwrap_or(&face_t), &tir_params)
                    }
                };
                // The noisy frame is the clean frame as stored (clipped to [0, 1]) through the
                // sensor model, so space is 0 in both bands before the noise.
                clean.clip();
                let mut rng = rng_for(cfg.seed, noise_stream(&s.name, i));
                let noisy = apply_sensor_noise(&clean, &cfg.noise, s.band, &mut rng);
                let mut ff = FrameFiles::default();
                let name = format!("frame_{i:03}.png");
                let sixteen = cfg.tir_16bit && s.band == Band::Tir;
                for (img, wanted, sub, sub16, slot, slot16) in [
                    (&clean, cfg.write_clean, "clean", "clean16", &mut ff.clean, &mut ff.clean16),
                    (&noisy, cfg.write_noisy, "noisy", "noisy16", &mut ff.noisy, &mut ff.noisy16),
                ] {
                    if !wanted {
                        continue;
                    }
                    let rel = format!("{}/{sub}/{name}", s.name);
                    write_png8(&out_dir.join(&rel), &img.to_gray8())?;
                    *slot = Some(rel);
                    if sixteen {
                        let rel = format!("{}/{sub16}/{name}", s.name);
                        write_png16(&out_dir.join(&rel), &img.to_gray16())?;
                        *slot16 = Some(rel);
                    }
                }
                if let Some(fp) = focal_planes.get(&s.width).filter(|_| s.band == Band::Tir) {
                    let t = i as f64 * DATASET_FRAME_INTERVAL_S;
                    let rel = format!("{}/raw/{name}", s.name);
                    let mut rng = rng_for(cfg.seed, noise_stream(&format!("{}_raw", s.name), i));
                    fp.write_raw(out_dir, &rel, &noisy, t, &mut rng)?;
                    ff.raw = Some(rel);
                    if shutters.iter().any(|(k, _)| *k == i) {
                        let rel = format!("{}/shutter/{name}", s.name);
                        let mut rng = rng_for(cfg.seed, noise_stream(&format!("{}_shutter", s.name), i));
                        fp.write_shutter(out_dir, &rel, cfg.tir.t_min, t, &mut rng)?;
                        ff.shutter = Some(rel);
                    }
                }
                if columns.contains(&i) {
                    let (x0, y0, side) = target_square(&scene, &cam);
                    thumbs.push(clean.crop_thumbnail(x0, y0, side, thumb));
                    thumbs.push(noisy.crop_thumbnail(x0, y0, side, thumb));
                }
                files.insert(s.name.clone(), ff);
                bar.inc(1);
            }
            Ok((files, thumbs))
        })
        .collect();
    bar.finish_and_clear();

    let mut frames = Vec::with_capacity(cfg.frames);
    let mut thumbs = Vec::with_capacity(cfg.frames);
    for (i, (r, tp)) in results.into_iter().zip(&traj).enumerate() {
        let (files, th) = r?;
        let q = tp.pose.quaternion();
        frames.push(FrameInfo {
            index: i,
            position_m: arr(tp.pose.position),
            rotation_cam_to_target: rows_of(tp.pose.rotation),
            quaternion_wxyz: [q.w, q.x, q.y, q.z],
            range_m: (tp.pose.position - scene.centre).length(),
            anomaly_deg: tp.anomaly_deg,
            tilt_deg: tp.tilt_deg,
            files,
            fpa_delta_k: focal_planes
                .values()
                .next()
                .map(|fp| fp.fpa_delta_k(i as f64 * DATASET_FRAME_INTERVAL_S)),
            tir_frozen: shutters.iter().any(|(_, frozen)| frozen.contains(&i)),
        });
        if !th.is_empty() {
            thumbs.push(th);
        }
    }

    // The shutter froze the video: those frames repeat the counts of the frame before, in order.
    for f in frames.iter().filter(|f| f.tir_frozen) {
        let Some(prev) = f.index.checked_sub(1) else { continue };
        for (set, ff) in &f.files {
            if let Some(this) = &ff.raw {
                repeat_frozen(out_dir, &format!("{set}/raw/frame_{prev:03}.png"), this)?;
            }
        }
    }
    let mut set_list = set_list;
    for (size, fp) in &focal_planes {
        let (nuc, bad) = fp.write_calibration(out_dir, &format!("calibration/tir{size}"))?;
        for s in set_list.iter_mut().filter(|s| s.band == Band::Tir && s.width == *size) {
            (s.nuc, s.bad_pixels) = (Some(nuc.clone()), Some(bad.clone()));
        }
    }

    let mut rows = Vec::new();
    for s in &set_list {
        rows.push(format!("{}/clean", s.name));
        rows.push(format!("{}/noisy", s.name));
    }
    let contact_sheet = if thumb > 0 {
        let names: Vec<String> = columns.iter().map(|f| format!("frame {f}")).collect();
        let sheet = contact_sheet(&thumbs, &names, &rows);
        fusion_io::save_gray_u8(&out_dir.join("contact_sheet.png"), &sheet)?;
        Some("contact_sheet.png".to_string())
    } else {
        None
    };

    let manifest = Manifest {
        generator: format!("render-host {}", env!("CARGO_PKG_VERSION")),
        seed: cfg.seed,
        target: cfg
            .mesh
            .as_ref()
            .map_or_else(|| cfg.target.as_str().to_string(), |p| p.display().to_string()),
        target_centre_m: arr(scene.centre),
        sun_direction: arr(sun),
        earth_direction: arr(cfg.vis.earth_dir.normalize()),
        temperature_range_k: [cfg.tir.t_min, cfg.tir.t_max],
        node_temperatures_k: node_t,
        eclipse_node_temperatures_k: eclipse_t,
        faces: scene.faces.iter().map(|f| (f.node, f.material)).collect(),
        config: cfg.clone(),
        sets: set_list,
        frames,
        contact_sheet,
        contact_sheet_rows: if thumb > 0 { rows } else { Vec::new() },
        contact_sheet_columns: columns,
    };
    write_json(&out_dir.join("manifest.json"), &manifest)?;
    Ok(manifest)
}

/// The square around the target's bounding sphere (15 % margin) in `cam`'s image: top-left
/// corner and side, px, at most the image width (the contact sheets' tiles).
pub fn target_square(scene: &Scene, cam: &Camera) -> (f32, f32, f32) {
    let (u, v) = cam.project(scene.centre).unwrap_or((cam.cx, cam.cy));
    let range = (cam.pose.position - scene.centre).length().max(1e-3);
    let side = (2.3 * cam.focal_px * scene.radius / range).min(cam.width as f32);
    (u - side / 2.0, v - side / 2.0, side)
}

/// Row-major entries of a 3 × 3 matrix.
pub(crate) fn rows_of(m: Mat3) -> [[f32; 3]; 3] {
    let t = m.transpose();
    [t.x_axis.to_array(), t.y_axis.to_array(), t.z_axis.to_array()]
}

/// Tiles thumbnails into one labelled sheet (`fusion_report::sheet::labelled_sheet`):
/// `per_frame[c]` holds the thumbnails of column (frame) `c`, top to bottom; the columns are
/// named `column_names`, the rows `row_names`; 2-px mid-grey gutters.
pub fn contact_sheet(
    per_frame: &[Vec<Image>],
    column_names: &[String],
    row_names: &[String],
) -> fusion_io::Gray<u8> {
    let rows = per_frame.iter().map(Vec::len).max().unwrap_or(0);
    let tiles: Vec<Vec<fusion_io::Gray<u8>>> = (0..rows)
        .map(|r| per_frame.iter().filter_map(|col| col.get(r).map(Image::to_gray_u8)).collect())
        .collect();
    let columns: Vec<&str> = column_names.iter().map(String::as_str).collect();
    let rows: Vec<&str> = row_names.iter().map(String::as_str).collect();
    fusion_report::sheet::labelled_sheet(&tiles, 2, &columns, &rows)
}
