//! One call renders a dataset or a sequence into a folder: [`RenderOptions`] and [`render`]
//! (what `fusion render` and `vistir.render` call).

use crate::dataset::{DatasetConfig, render_dataset};
use crate::scene::Material;
use crate::sequence::{SEQUENCE_SAMPLES, SequenceConfig, SequenceName, render_sequence};
use crate::tir::{DnMapping, Radiometry};
use crate::{TirParams, VisParams};
use anyhow::{Result, bail, ensure};
use std::path::PathBuf;
use std::time::Instant;

/// What to render: a dataset in the study's layout or a rendezvous sequence, and where. The
/// `fusion render` flags and the Python `vistir.render` keywords are these fields; [`Default`]
/// gives their defaults (only `out` has none: it starts empty).
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Output folder (a new folder appears whole or not at all; an existing one is written into).
    pub out: PathBuf,
    /// Frames per set [default: 20, or 4 with --demo; 120 with --sequence].
    pub frames: Option<usize>,
    /// Render a rendezvous sequence instead of the study's layout: `approach` (50 m → 5 m in
    /// light, the target tumbling) or `flyaround` (a circumnavigation at 8 m through an
    /// eclipse), at 1 Hz, VIS `--vis-size`², TIR the first of `--tir-sizes`, with per-frame
    /// ground truth (`render_host::sequence`).
    pub sequence: Option<SequenceName>,
    /// Seed of every random draw (same seed, same bytes).
    pub seed: u64,
    /// VIS image size (square), px.
    pub vis_size: u32,
    /// TIR image sizes (square), px, one set each; `None`: half the VIS size and the VIS size
    /// (the study's 512² and 1024² beside a 1024² VIS), a sequence the first of them (half, as
    /// `fusion navbench` renders). See [`RenderOptions::tir_sizes_or_default`].
    pub tir_sizes: Option<Vec<u32>>,
    /// Render this OBJ mesh instead of the procedural target.
    pub mesh: Option<PathBuf>,
    /// The procedural target (datasets without `mesh`, and sequences).
    pub target: crate::scene::Target,
    /// Scale from the OBJ's units to metres.
    pub mesh_scale: f32,
    /// TIR radiometry: `radiometric` (εσT⁴/π with cos⁴ fall-off) or `study` (view-factor weighting).
    pub radiometry: Radiometry,
    /// TIR DN mapping over the temperature range: linear in `radiance` or in `temperature`.
    pub tir_dn: DnMapping,
    /// TIR temperature mapped to DN 0, K.
    pub t_min: f64,
    /// TIR temperature mapped to full scale, K.
    pub t_max: f64,
    /// Also write 16-bit TIR PNGs (`clean16/`, `noisy16/`; with --sequence: `tir16/`, noisy).
    pub tir16: bool,
    /// Also write the thermal camera's raw counts through the default focal-plane model
    /// (`crate::focal_plane`), its shutter frames and factory calibration: a sequence's
    /// `tir_raw/`, `tir_shutter/`, `calibration/`; in the study's layout each TIR set's `raw/`
    /// and `shutter/` and `calibration/tir<size>.*`.
    pub raw_tir: bool,
    /// Also write TIR sets after this many minutes in eclipse (lumped transient).
    pub eclipse_minutes: Option<f64>,
    /// Leave out the specular lobe in VIS.
    pub no_specular: bool,
    /// Flat faces: one albedo and one temperature per face, no cells, crinkles, bolts or
    /// in-face gradients (the target as rendered before the surface detail).
    pub flat: bool,
    /// VIS exposure: pixel value of a white Lambertian face lit by the sun at normal incidence.
    pub exposure: f32,
    /// Earthshine relative to the sun (VIS, also lights the eclipse set).
    pub earthshine: f32,
    /// Contact-sheet tile size, px (0 = no contact sheet). Tiles crop the frame to the target.
    pub sheet_thumb: u32,
    /// Frames (columns) on the contact sheet, evenly spaced (0 = every frame).
    pub sheet_frames: usize,
    /// A quick demo: 4 frames unless --frames is given.
    pub demo: bool,
    /// Sub-pixel samples per axis, VIS and TIR (each pixel integrates n × n rays) [default: 1,
    /// the study's datasets; 4 with --sequence, `sequence::SEQUENCE_SAMPLES`].
    pub samples: Option<u32>,
    /// With a sequence: an offset camera pair instead of the aligned one — `offset` (the
    /// built-in [`crate::rig::offset_rig`]) or an OpenCV calibration file (`fusion_io::rig`);
    /// the cameras' sizes are the rig's.
    pub rig: Option<PathBuf>,
    /// With a sequence: the Earth behind the target in both bands at this orbit altitude, km
    /// ([`crate::earth`]); `None`: black space.
    pub earth_km: Option<f64>,
    /// With a sequence: the sun–target–camera phase angle at the first frame, degrees (0–180).
    pub sun_phase_deg: Option<f64>,
    /// With a sequence: the sun's disc, stray light and blooming in the visible camera
    /// ([`crate::glare`], default parameters).
    pub glare: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            out: PathBuf::new(),
            frames: None,
            sequence: None,
            seed: 1,
            vis_size: 1024,
            tir_sizes: None,
            mesh: None,
            target: crate::scene::Target::default(),
            mesh_scale: 1.0,
            radiometry: Radiometry::Radiometric,
            tir_dn: DnMapping::Temperature,
            t_min: 150.0,
            t_max: 400.0,
            tir16: false,
            raw_tir: false,
            earth_km: None,
            sun_phase_deg: None,
            glare: false,
            eclipse_minutes: None,
            no_specular: false,
            flat: false,
            exposure: crate::vis::DEFAULT_EXPOSURE,
            earthshine: 0.02,
            sheet_thumb: 160,
            sheet_frames: 5,
            demo: false,
            samples: None,
            rig: None,
        }
    }
}

impl RenderOptions {
    /// The TIR sizes given, or half the VIS size and the VIS size (one size when they are the
    /// same, at `--vis-size 1`).
    pub fn tir_sizes_or_default(&self) -> Vec<u32> {
        self.tir_sizes.clone().unwrap_or_else(|| {
            let mut sizes = vec![(self.vis_size / 2).max(1), self.vis_size];
            sizes.dedup();
            sizes
        })
    }

    /// The dataset configuration these options describe; a one-line error names the bad option.
    pub fn config(&self) -> Result<DatasetConfig> {
        let mut cfg = if self.demo { DatasetConfig::demo() } else { DatasetConfig::default() };
        if let Some(n) = self.frames {
            if n == 0 {
                bail!("--frames must be at least 1");
            }
            cfg.frames = n;
        }
        if !(self.t_min.is_finite() && self.t_max.is_finite() && self.t_min >= 0.0 && self.t_max > self.t_min)
        {
            bail!("need 0 <= --t-min < --t-max");
        }
        if !(self.mesh_scale.is_finite() && self.mesh_scale > 0.0) {
            bail!("--mesh-scale must be positive");
        }
        if let Some(m) = self.eclipse_minutes
            && !(m.is_finite() && m >= 0.0)
        {
            bail!("--eclipse-minutes must be a non-negative number");
        }
        if !(self.earthshine.is_finite() && self.earthshine >= 0.0) {
            bail!("--earthshine must be non-negative");
        }
        if !(self.exposure.is_finite() && self.exposure > 0.0) {
            bail!("--exposure must be positive");
        }
        let tir_sizes = self.tir_sizes_or_default();
        if self.vis_size == 0 || tir_sizes.is_empty() || tir_sizes.contains(&0) {
            bail!("--vis-size and --tir-sizes must be positive");
        }
        if let Some(phase) = self.sun_phase_deg {
            if self.sequence.is_none() {
                bail!("--sun-phase sets the lighting of a sequence: give --sequence");
            }
            if !(phase.is_finite() && (0.0..=180.0).contains(&phase)) {
                bail!("--sun-phase must be between 0 and 180 degrees");
            }
        }
        if self.glare && self.sequence.is_none() {
            bail!("--glare adds the sun's glare to a sequence's visible frames: give --sequence");
        }
        if let Some(km) = self.earth_km {
            if self.sequence.is_none() {
                bail!("--earth draws the Earth behind a sequence's target: give --sequence");
            }
            if !(km.is_finite() && (150.0..=40_000.0).contains(&km)) {
                bail!("--earth: the orbit altitude must be between 150 and 40000 km");
            }
        }
        if let Some(n) = self.samples
            && !(1..=MAX_SAMPLES).contains(&n)
        {
            bail!("--samples must be between 1 and {MAX_SAMPLES}");
        }
        cfg.vis.samples = self.samples.unwrap_or(1);
        cfg.tir.samples = cfg.vis.samples;
        cfg.vis_size = self.vis_size;
        cfg.tir_sizes = tir_sizes;
        cfg.seed = self.seed;
        cfg.mesh = self.mesh.clone();
        cfg.target = self.target;
        cfg.mesh_scale = self.mesh_scale;
        cfg.mesh_default_material = Material::MliKapton;
        cfg.tir.radiometry = self.radiometry;
        cfg.tir.dn_mapping = self.tir_dn;
        cfg.tir.t_min = self.t_min;
        cfg.tir.t_max = self.t_max;
        cfg.tir_16bit = self.tir16;
        cfg.focal_plane = self.raw_tir.then(crate::focal_plane::FocalPlaneParams::default);
        cfg.tir_eclipse_minutes = self.eclipse_minutes;
        cfg.vis.specular = !self.no_specular;
        cfg.surface_detail = !self.flat;
        cfg.vis.earthshine = self.earthshine;
        cfg.vis.exposure = self.exposure;
        cfg.contact_sheet_thumb = self.sheet_thumb;
        cfg.contact_sheet_frames = self.sheet_frames;
        Ok(cfg)
    }
}

/// Most sub-pixel samples per axis `--samples` takes (16² = 256 rays per pixel).
pub const MAX_SAMPLES: u32 = 16;

/// The sequence these options describe (frames 120 unless `--frames`, sub-pixel samples
/// [`SEQUENCE_SAMPLES`] unless `--samples`; sizes, seed, noise, radiometry and lighting from the
/// dataset options).
pub fn sequence_config(
    name: SequenceName,
    args: &RenderOptions,
    cfg: &DatasetConfig,
) -> Result<SequenceConfig> {
    let rig = args.rig.as_deref().map(crate::rig::from_arg).transpose()?;
    let (vis_size, tir_size) = match &rig {
        Some(r) => {
            ensure!(
                r.vis.width == r.vis.height && r.tir.width == r.tir.height,
                "the sequences render square images: the rig's cameras are {}x{} and {}x{}",
                r.vis.width,
                r.vis.height,
                r.tir.width,
                r.tir.height
            );
            (r.vis.width as u32, r.tir.width as u32)
        }
        None => (cfg.vis_size, cfg.tir_sizes.first().copied().unwrap_or(512)),
    };
    Ok(SequenceConfig {
        frames: args.frames.unwrap_or(120),
        seed: cfg.seed,
        surface_seed: cfg.surface_seed,
        target: args.target,
        vis_size,
        tir_size,
        rig,
        vis: VisParams { samples: args.samples.unwrap_or(SEQUENCE_SAMPLES), ..cfg.vis },
        tir: TirParams { samples: args.samples.unwrap_or(SEQUENCE_SAMPLES), ..cfg.tir },
        noise: cfg.noise,
        write_tir16: args.tir16,
        focal_plane: args.raw_tir.then(crate::focal_plane::FocalPlaneParams::default),
        earth: crate::sequence::sequence_earth(
            name,
            args.earth_km.map(|km| km * 1000.0),
            cfg.seed,
            cfg.surface_seed,
        ),
        sun_phase_deg: args.sun_phase_deg,
        glare: args.glare.then(crate::glare::GlareParams::default),
        ..SequenceConfig::new(name)
    })
}

/// Renders the dataset (or the sequence) into `args.out` and returns a one-line summary of what
/// was written (the `fusion render` verb prints it). A progress bar shows on standard error
/// unless `fusion_io::console::quiet()`.
pub fn render(args: &RenderOptions) -> Result<String> {
    let cfg = args.config()?;
    let start = Instant::now();
    let quiet = fusion_io::console::quiet();
    if let Some(name) = args.sequence {
        if args.mesh.is_some() || args.flat {
            bail!(
                "--sequence renders a procedural target (--target) with its surface detail; --mesh and --flat do not apply"
            );
        }
        let seq = sequence_config(name, args, &cfg)?;
        let m = fusion_io::output::in_new_folder(&args.out, |dir| render_sequence(&seq, dir, !quiet))?;
        let [l, p, e] = m.phase_frames;
        return Ok(format!(
            "wrote sequence {} ({} frames at {} Hz: {l} light, {p} penumbra, {e} eclipse) to {} in {:.2} s (manifest.json, contact_sheet.png)",
            name.as_str(),
            m.frames.len(),
            seq.frame_rate_hz,
            args.out.display(),
            start.elapsed().as_secs_f64()
        ));
    }
    if args.rig.is_some() {
        bail!(
            "--rig renders a sequence (give --sequence NAME); the study's layout keeps its aligned cameras"
        );
    }
    let manifest = fusion_io::output::in_new_folder(&args.out, |dir| render_dataset(&cfg, dir, !quiet))?;
    let files: usize = manifest
        .frames
        .iter()
        .flat_map(|f| f.files.values())
        .map(|f| {
            [&f.clean, &f.noisy, &f.clean16, &f.noisy16, &f.raw, &f.shutter]
                .iter()
                .filter(|x| x.is_some())
                .count()
        })
        .sum();
    let sheet = manifest.contact_sheet.as_deref().map(|s| format!(", {s}")).unwrap_or_default();
    Ok(format!(
        "wrote {files} images in {} sets x {} frames to {} in {:.2} s (manifest.json{sheet})",
        manifest.sets.len(),
        manifest.frames.len(),
        args.out.display(),
        start.elapsed().as_secs_f64()
    ))
}
