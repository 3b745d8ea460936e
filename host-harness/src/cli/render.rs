//! `fusion render`: the flags of [`render_host::render()`] (a dataset in the study's layout or a
//! rendezvous sequence), its summary line printed.

use anyhow::Result;
use clap::Args;
use render_host::RenderOptions;
use render_host::sequence::SequenceName;
use render_host::tir::{DnMapping, Radiometry};
use std::path::PathBuf;

#[derive(Args, Debug, Clone, PartialEq)]
pub struct RenderArgs {
    /// Output folder (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Frames per set [default: 20, or 4 with --demo; 120 with --sequence].
    #[arg(long)]
    pub frames: Option<usize>,
    /// Render a rendezvous sequence instead of the study's layout: `approach` (50 m → 5 m in
    /// light, the target tumbling), `flyaround` (a circumnavigation at 8 m through an
    /// eclipse) or `radial` (30 m → 5 m from above, the Earth behind the target, into the
    /// Earth's shadow), at 1 Hz, VIS `--vis-size`², TIR the first of `--tir-sizes`, with per-frame
    /// ground truth (`render_host::sequence`).
    #[arg(long, value_enum, value_name = "NAME")]
    pub sequence: Option<SequenceName>,
    /// Seed of every random draw (same seed, same bytes).
    #[arg(long, default_value_t = RenderOptions::default().seed)]
    pub seed: u64,
    /// VIS image size (square), px.
    #[arg(long, default_value_t = RenderOptions::default().vis_size, value_name = "PX")]
    pub vis_size: u32,
    /// TIR image sizes (square), px, one set each (comma separated) [default: half the VIS size
    /// and the VIS size; a sequence renders the first: half the VIS size, as navbench does].
    #[arg(long, value_delimiter = ',', value_name = "PX,PX")]
    pub tir_sizes: Option<Vec<u32>>,
    /// Render this OBJ mesh instead of the procedural target (datasets; README, "Your own
    /// target").
    #[arg(long, value_name = "FILE.obj", conflicts_with = "target")]
    pub mesh: Option<PathBuf>,
    /// The procedural target: `tango` (the Tango-like small satellite, a 0.74 m bus under one
    /// panel) or `boxwing` (a 0.9 m bus with two 1.3 m solar wings and a dish, 3.4 m across).
    #[arg(long, value_enum, value_name = "NAME", default_value = "tango")]
    pub target: render_host::scene::Target,
    /// Scale from the OBJ's units to metres.
    #[arg(long, default_value_t = RenderOptions::default().mesh_scale)]
    pub mesh_scale: f32,
    /// TIR radiometry: `radiometric` (εσT⁴/π with cos⁴ fall-off) or `study` (view-factor weighting).
    #[arg(long, value_enum, default_value_t = RenderOptions::default().radiometry)]
    pub radiometry: Radiometry,
    /// TIR DN mapping over the temperature range: linear in `radiance` or in `temperature`.
    #[arg(long, value_enum, default_value_t = RenderOptions::default().tir_dn)]
    pub tir_dn: DnMapping,
    /// TIR temperature mapped to DN 0, K.
    #[arg(long, default_value_t = RenderOptions::default().t_min)]
    pub t_min: f64,
    /// TIR temperature mapped to full scale, K.
    #[arg(long, default_value_t = RenderOptions::default().t_max)]
    pub t_max: f64,
    /// Also write 16-bit TIR PNGs (`clean16/`, `noisy16/`; with --sequence: `tir16/`, noisy).
    #[arg(long)]
    pub tir16: bool,
    /// Also write the thermal camera's raw 14-bit counts through a microbolometer model —
    /// fixed-pattern noise, column stripes, dead and hot pixels, drift, shutter closures — and
    /// its factory calibration, named in the manifest as `nuc` and `bad_pixels`. With
    /// --sequence: `tir_raw/`, `tir_shutter/`, `calibration/tir.nuc`,
    /// `calibration/tir_bad_pixels.png`; in the study's layout (frames 1 s apart): each TIR
    /// set's `raw/` and `shutter/`, `calibration/tir<size>.nuc` and `…_bad_pixels.png`.
    #[arg(long)]
    pub raw_tir: bool,
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
    #[arg(long, default_value_t = RenderOptions::default().exposure)]
    pub exposure: f32,
    /// Earthshine relative to the sun (VIS, also lights the eclipse set).
    #[arg(long, default_value_t = RenderOptions::default().earthshine)]
    pub earthshine: f32,
    /// Contact-sheet tile size, px (0 = no contact sheet). Tiles crop the frame to the target.
    #[arg(long, default_value_t = RenderOptions::default().sheet_thumb, value_name = "PX")]
    pub sheet_thumb: u32,
    /// Frames (columns) on the contact sheet, evenly spaced (0 = every frame).
    #[arg(long, default_value_t = RenderOptions::default().sheet_frames, value_name = "N")]
    pub sheet_frames: usize,
    /// A quick demo: 4 frames unless --frames is given.
    #[arg(long)]
    pub demo: bool,
    /// Sub-pixel samples per axis, VIS and TIR: each pixel integrates N × N rays, so that fine
    /// surface detail does not alias [default: 1; 4 with --sequence]
    #[arg(long, value_name = "N")]
    pub samples: Option<u32>,
    /// With --sequence: an offset camera pair instead of the aligned one — `offset` (the
    /// built-in rig: VIS 1024² of 30°, TIR 512² of 35° 0.2 m to its right, mild distortion) or an
    /// OpenCV stereo calibration (YAML or JSON, as `fusion register --rig`). The cameras' sizes
    /// are the rig's; the rig is written beside the frames (`calibration/rig.json`).
    #[arg(long, value_name = "offset|FILE", requires = "sequence")]
    pub rig: Option<PathBuf>,
    /// With --sequence: the Earth behind the target in both bands (ocean, land, clouds, the
    /// terminator, the limb; render_host::earth), seen from an orbit at KM altitude
    /// [default when given without a value: 500; `radial` has it at 500 without the option];
    /// Earth masks beside the target masks.
    #[arg(long, value_name = "KM", num_args = 0..=1, default_missing_value = "500", requires = "sequence")]
    pub earth: Option<f64>,
    /// With --sequence: the sun–target–camera phase angle at the first frame, degrees (0: the
    /// sun behind the camera, 180: behind the target); the trajectory is unchanged, the sun
    /// turns [default: the sequence's own sun, 14.3° on the approach, 68° on `radial`, where
    /// the sun then sets with the orbit].
    #[arg(long, value_name = "DEG", requires = "sequence")]
    pub sun_phase: Option<f64>,
    /// With --sequence: the sun's glare in the visible camera — its disc where it is in view,
    /// the optics' stray light around it, blooming along columns above the full well
    /// (render_host::glare); e.g. `--sun-phase 170` puts the sun beside the target.
    #[arg(long, requires = "sequence")]
    pub glare: bool,
}

impl From<RenderArgs> for RenderOptions {
    fn from(a: RenderArgs) -> Self {
        RenderOptions {
            out: a.out,
            frames: a.frames,
            sequence: a.sequence,
            seed: a.seed,
            vis_size: a.vis_size,
            tir_sizes: a.tir_sizes,
            mesh: a.mesh,
            target: a.target,
            mesh_scale: a.mesh_scale,
            radiometry: a.radiometry,
            tir_dn: a.tir_dn,
            t_min: a.t_min,
            t_max: a.t_max,
            tir16: a.tir16,
            raw_tir: a.raw_tir,
            eclipse_minutes: a.eclipse_minutes,
            no_specular: a.no_specular,
            flat: a.flat,
            exposure: a.exposure,
            earthshine: a.earthshine,
            sheet_thumb: a.sheet_thumb,
            sheet_frames: a.sheet_frames,
            demo: a.demo,
            samples: a.samples,
            rig: a.rig,
            earth_km: a.earth,
            sun_phase_deg: a.sun_phase,
            glare: a.glare,
        }
    }
}

/// Runs `fusion render`: renders, then prints the summary unless `--quiet`.
pub fn run(args: &RenderArgs) -> Result<()> {
    let summary = render_host::render(&args.clone().into())?;
    if !fusion_io::console::quiet() {
        outln!("{summary}")?;
    }
    Ok(())
}
