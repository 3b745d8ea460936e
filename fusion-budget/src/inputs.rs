//! The budget's inputs: the rendered budget pair, synthetic pairs, and the 16-bit counts and
//! host AGC the firmware's AGC runs are compared with.

#[allow(unused_imports)]
use super::*;

/// The committed budget pair: a rendered Tango-like target in light (VIS 1024², TIR 512², noisy),
/// see `fw/README.md`.
pub fn budget_pair() -> Result<(Gray<u8>, Gray<u8>)> {
    let dir = fw::fw_dir().join("data");
    let vis = load_gray_u8(&dir.join("tango_vis_light_1024.png"), ColorPolicy::Refuse)?;
    let tir = load_gray_u8(&dir.join("tango_tir_512.png"), ColorPolicy::Refuse)?;
    ensure!(
        (vis.width, vis.height, tir.width, tir.height) == (1024, 1024, 512, 512),
        "budget pair has the wrong size"
    );
    Ok((vis, tir))
}

/// A synthetic pair at sizes that are not a factor of two apart (VIS `w×h`, TIR about half),
/// with black background, a gradient "bus", a saturated glint, stripes and hashed noise, so the
/// general rescale path and the saturation guards are exercised.
pub fn synthetic_pair(w: usize, h: usize) -> (Gray<u8>, Gray<u8>) {
    let hash = |x: usize, y: usize, s: u32| {
        let mut v = (x as u32).wrapping_mul(0x9E37_79B1) ^ (y as u32).wrapping_mul(0x85EB_CA77) ^ s;
        v ^= v >> 15;
        v = v.wrapping_mul(0x2C1B_3C6D);
        v ^= v >> 12;
        v
    };
    let mut vis = Gray::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (x * 1000 / w, y * 1000 / h);
            let noise = (hash(x, y, 1) % 9) as i32 - 4;
            let base: i32 = if (300..700).contains(&u) && (350..650).contains(&v) {
                if (550..600).contains(&u) && (400..430).contains(&v) {
                    255
                } else {
                    60 + (u as i32 - 300) / 3
                }
            } else if (100..900).contains(&u) && (480..520).contains(&v) {
                if (u / 40) % 2 == 0 { 30 } else { 140 }
            } else {
                2
            };
            vis.data[y * w + x] = (base + noise).clamp(0, 255) as u8;
        }
    }
    let (tw, th) = (w.div_ceil(2) + 1, h.div_ceil(2) - 1);
    let mut tir = Gray::new(tw, th);
    for y in 0..th {
        for x in 0..tw {
            let (u, v) = (x * 1000 / tw, y * 1000 / th);
            let noise = (hash(x, y, 2) % 7) as i32 - 3;
            let base: i32 = if (300..700).contains(&u) && (350..650).contains(&v) {
                170 + ((u + v) / 50) as i32
            } else if (100..900).contains(&u) && (480..520).contains(&v) {
                230
            } else {
                12
            };
            tir.data[y * tw + x] = (base + noise).clamp(0, 255) as u8;
        }
    }
    (vis, tir)
}

/// The host's AGC of `counts` with a fresh state, as an AGC run of the image computes it.
pub fn agc_host(counts: &Gray<u16>, kind: fw::AgcKind) -> Result<Gray<u8>> {
    fusion_engine::agc::map_counts(&mut fusion_engine::agc::fresh(), counts, &kind.params(counts.data.len()))
}

/// The budget pair's TIR frame as 14-bit counts, the input of the AGC runs: each 8-bit level
/// times 64 plus a deterministic 6-bit dither (the AGC's cost does not depend on the values
/// beyond the histogram's spread).
pub fn counts_of(tir: &Gray<u8>) -> Gray<u16> {
    let data = tir
        .data
        .iter()
        .enumerate()
        .map(|(i, &v)| (u16::from(v) << 6) | ((i as u32).wrapping_mul(2_654_435_761) >> 26) as u16)
        .collect();
    Gray { width: tir.width, height: tir.height, data }
}

/// Frames of the thermal front end's raw sequence in the budget job, and the one (by index)
/// the shutter closes before.
pub const THERMAL_FRAMES: usize = 3;
/// The frame of [`raw_thermal`]'s sequence that comes with a shutter frame.
pub const THERMAL_SHUTTER_FRAME: usize = 1;

/// The budget pair's TIR frame as a short raw video of the renderer's focal plane
/// (`render_host::focal_plane`, default parameters; frames 1 s apart from 19 s after
/// calibration: drift, stripes, dead and hot pixels, fresh noise each frame), the shutter
/// closing before frame [`THERMAL_SHUTTER_FRAME`], with its factory tables and map and the
/// column filter's parameters (threshold from the first corrected frame,
/// [`fusion_engine::thermal::column_threshold`]; temporal smoothing 2⁻³, so the filter's state
/// carries from frame to frame): the input of the thermal front-end runs.
pub fn raw_thermal(tir: &Gray<u8>) -> Result<fw::ThermalInputs> {
    use render_host::focal_plane::{FocalPlane, FocalPlaneParams};
    let fp = FocalPlane::new(FocalPlaneParams::default(), tir.width, tir.height, 250.0);
    let v = render_host::Image {
        width: tir.width as u32,
        height: tir.height as u32,
        data: tir.data.iter().map(|&t| f32::from(t) / 255.0).collect(),
    };
    let mut rng = render_host::noise::rng_for(7, 0);
    let gray = |data| Gray { width: tir.width, height: tir.height, data };
    let frames: Vec<fw::ThermalFrame> = (0..THERMAL_FRAMES)
        .map(|k| {
            let t = 19.0 + k as f64;
            let shutter = (k == THERMAL_SHUTTER_FRAME).then(|| gray(fp.shutter(150.0, t, &mut rng)));
            fw::ThermalFrame { raw: gray(fp.raw(&v, t, &mut rng)), shutter }
        })
        .collect();
    let nuc = fusion_io::thermal::NucTables {
        width: tir.width,
        height: tir.height,
        gain: fp.nuc_gain.clone(),
        offset: fp.nuc_offset.clone(),
    };
    let bad = fusion_io::thermal::BadPixels::from_mask(tir.width, tir.height, &fp.bad_mask());
    let first = frames.first().context("no thermal frame")?;
    let corrected = fusion_engine::thermal::ThermalChain::new(Some(nuc.clone()), Some(bad.clone()), None)?
        .correct(&first.raw)?;
    let column = fusion_nostd::thermal::ColumnParams {
        threshold: fusion_engine::thermal::column_threshold(&corrected),
        radius: fusion_engine::thermal::COLUMN_RADIUS,
        smoothing: 3,
    };
    Ok(fw::ThermalInputs { frames, nuc, bad, column })
}

/// The thermal runs of a job on `inputs`: one per frame, the shutter bit where it has one.
pub fn thermal_runs(inputs: &fw::ThermalInputs) -> impl Iterator<Item = fw::RunSpec> + '_ {
    inputs.frames.iter().map(|f| fw::RunSpec::thermal(f.shutter.is_some()))
}

/// The host's result of the thermal front-end runs, frame by frame: the offsets re-levelled
/// at each shutter frame, the chain in one call per frame (`fusion_nostd::thermal::correct_frame`,
/// the column filter's state carried on), then the linear AGC (a fresh state each frame) —
/// what the image computes stage by stage.
pub fn thermal_host(t: &fw::ThermalInputs) -> Result<Vec<Gray<u8>>> {
    let mut chain = fusion_engine::thermal::ThermalChain::new(
        Some(t.nuc.clone()),
        Some(t.bad.clone()),
        Some(fusion_engine::thermal::Column::Params(t.column)),
    )?;
    t.frames
        .iter()
        .map(|f| {
            if let Some(flat) = &f.shutter {
                chain.shutter(flat)?;
            }
            let corrected = chain.correct(&f.raw)?;
            fusion_engine::agc::map_counts(
                &mut fusion_engine::agc::fresh(),
                &corrected,
                &fusion_nostd::AgcParams::linear(),
            )
        })
        .collect()
}
