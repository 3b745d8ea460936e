//! The `fusion render` front end: [`RenderArgs`] (a `clap::Args` struct) and [`run`].

use crate::dataset::{DatasetConfig, render_dataset};
use crate::scene::Material;
use crate::sequence::{SequenceConfig, SequenceName, render_sequence};
use crate::tir::{DnMapping, Radiometry};
use anyhow::{Result, bail};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `fusion render`: writes a synthetic VIS/TIR dataset in the study's layout.
#[derive(clap::Args, Debug, Clone, PartialEq)]
pub struct RenderArgs {
    /// Output folder (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Frames per set [default: 20, or 4 with --demo; 120 with --sequence].
    #[arg(long)]
    pub frames: Option<usize>,
    /// Render a rendezvous sequence instead of the study's layout: `approach` (50 m → 5 m in
    /// light, the target tumbling) or `flyaround` (a circumnavigation at 8 m through an
    /// eclipse), at 1 Hz, VIS `--vis-size`², TIR the first of `--tir-sizes`, with per-frame
    /// ground truth (`render_host::sequence`).
    #[arg(long, value_enum, value_name = "NAME")]
    pub sequence: Option<SequenceName>,
    /// Seed of every random draw (same seed, same bytes).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// VIS image size (square), px.
    #[arg(long, default_value_t = 1024, value_name = "PX")]
    pub vis_size: u32,
    /// TIR image sizes (square), px, one set each (comma separated).
    #[arg(long, value_delimiter = ',', default_values_t = [512, 1024], value_name = "PX,PX")]
    pub tir_sizes: Vec<u32>,
    /// Render this OBJ mesh instead of the procedural Tango-like target.
    #[arg(long, value_name = "FILE.obj")]
    pub mesh: Option<PathBuf>,
    /// Scale from the OBJ's units to metres.
    #[arg(long, default_value_t = 1.0)]
    pub mesh_scale: f32,
    /// TIR radiometry: `radiometric` (εσT⁴/π with cos⁴ fall-off) or `study` (view-factor weighting).
    #[arg(long, value_enum, default_value_t = Radiometry::Radiometric)]
    pub radiometry: Radiometry,
    /// TIR DN mapping over the temperature range: linear in `radiance` or in `temperature`.
    #[arg(long, value_enum, default_value_t = DnMapping::Temperature)]
    pub tir_dn: DnMapping,
    /// TIR temperature mapped to DN 0, K.
    #[arg(long, default_value_t = 150.0)]
    pub t_min: f64,
    /// TIR temperature mapped to full scale, K.
    #[arg(long, default_value_t = 400.0)]
    pub t_max: f64,
    /// Also write 16-bit TIR PNGs (`clean16/`, `noisy16/`; with --sequence: `tir16/`, noisy).
    #[arg(long)]
    pub tir16: bool,
    /// Also write TIR sets after this many minutes in eclipse (lumped transient).
    #[arg(long, value_name = "MINUTES")]
    pub eclipse_minutes: Option<f64>,
    /// Leave out the specular lobe in VIS.
    #[arg(long)]
    pub no_specular: bool,
    /// Flat faces: one albedo and one temperature per face, no cells, crinkles, bolts or
    /// in-face gradients (the target as rendered before the surface detail).
    #[arg(long)]
    pub flat: bool,
    /// VIS exposure: pixel value of a white Lambertian face lit by the sun at normal incidence.
    #[arg(long, default_value_t = crate::vis::DEFAULT_EXPOSURE)]
    pub exposure: f32,
    /// Earthshine relative to the sun (VIS, also lights the eclipse set).
    #[arg(long, default_value_t = 0.02)]
    pub earthshine: f32,
    /// Contact-sheet tile size, px (0 = no contact sheet). Tiles crop the frame to the target.
    #[arg(long, default_value_t = 160, value_name = "PX")]
    pub sheet_thumb: u32,
    /// Frames (columns) on the contact sheet, evenly spaced (0 = every frame).
    #[arg(long, default_value_t = 5, value_name = "N")]
    pub sheet_frames: usize,
    /// A quick demo: 4 frames unless --frames is given.
    #[arg(long)]
    pub demo: bool,
}

impl RenderArgs {
    /// The dataset configuration these arguments describe.
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
        if self.vis_size == 0 || self.tir_sizes.is_empty() || self.tir_sizes.contains(&0) {
            bail!("--vis-size and --tir-sizes must be positive");
        }
        cfg.vis_size = self.vis_size;
        cfg.tir_sizes = self.tir_sizes.clone();
        cfg.seed = self.seed;
        cfg.mesh = self.mesh.clone();
        cfg.mesh_scale = self.mesh_scale;
        cfg.mesh_default_material = Material::MliKapton;
        cfg.tir.radiometry = self.radiometry;
        cfg.tir.dn_mapping = self.tir_dn;
        cfg.tir.t_min = self.t_min;
        cfg.tir.t_max = self.t_max;
        cfg.tir_16bit = self.tir16;
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

/// The sequence these arguments describe (frames 120 unless `--frames`; sizes, seed, noise,
/// radiometry and lighting from the dataset options).
pub fn sequence_config(name: SequenceName, args: &RenderArgs, cfg: &DatasetConfig) -> SequenceConfig {
    SequenceConfig {
        frames: args.frames.unwrap_or(120),
        seed: cfg.seed,
        surface_seed: cfg.surface_seed,
        vis_size: cfg.vis_size,
        tir_size: cfg.tir_sizes.first().copied().unwrap_or(512),
        vis: cfg.vis,
        tir: cfg.tir,
        noise: cfg.noise,
        write_tir16: args.tir16,
        ..SequenceConfig::new(name)
    }
}

/// Runs `fusion render`: renders the dataset (or the sequence) and prints a one-line summary.
pub fn run(args: &RenderArgs) -> Result<()> {
    let cfg = args.config()?;
    let start = Instant::now();
    if let Some(name) = args.sequence {
        if args.mesh.is_some() || args.flat {
            bail!(
                "--sequence renders the procedural target with its surface detail; --mesh and --flat do not apply"
            );
        }
        let seq = sequence_config(name, args, &cfg);
        let quiet = crate::output::quiet();
        let m = crate::output::in_new_folder(&args.out, |dir| render_sequence(&seq, dir, !quiet))?;
        if !quiet {
            let [l, p, e] = m.phase_frames;
            crate::output::stdout_write(format_args!(
                "{}\n",
                format_args!(
                    "wrote sequence {} ({} frames at {} Hz: {l} light, {p} penumbra, {e} eclipse) to {} in {:.2} s (manifest.json, contact_sheet.png)",
                    name.as_str(),
                    m.frames.len(),
                    seq.frame_rate_hz,
                    args.out.display(),
                    start.elapsed().as_secs_f64()
                )
            ))?;
        }
        return Ok(());
    }
    let quiet = crate::output::quiet();
    let manifest = crate::output::in_new_folder(&args.out, |dir| render_dataset(&cfg, dir, !quiet))?;
    if !quiet {
        let files: usize = manifest
            .frames
            .iter()
            .flat_map(|f| f.files.values())
            .map(|f| [&f.clean, &f.noisy, &f.clean16, &f.noisy16].iter().filter(|x| x.is_some()).count())
            .sum();
        let sheet = manifest.contact_sheet.as_deref().map(|s| format!(", {s}")).unwrap_or_default();
        crate::output::stdout_write(format_args!(
            "{}\n",
            format_args!(
                "wrote {files} images in {} sets x {} frames to {} in {:.2} s (manifest.json{sheet})",
                manifest.sets.len(),
                manifest.frames.len(),
                args.out.display(),
                start.elapsed().as_secs_f64()
            )
        ))?;
    }
    Ok(())
}
