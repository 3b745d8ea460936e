//! The study's other four methods, host-only (std, f64): GFF, MGFF, TEPGFL and DRIF.
//!
//! The study ranks seven methods; the no_std core carries the three it recommends for flight
//! (ADF, TSIFSD, IFEVIP). These four complete the comparison on the host, each written from its
//! paper (the module docs give the formulas, the parameters and where each comes from):
//! * [`gff`] — guided-filter fusion (Li, Kang, Hu 2013);
//! * [`mgff`] — multi-scale guided-filter fusion (Bavirisetti et al. 2019);
//! * [`tepgfl`] — fast-global-smoother decomposition + Gaussian fuzzy logic (Duan et al. 2022),
//!   with the smoother of Min et al. 2014 in [`fgs`];
//! * [`drif`] — different-resolution fusion by TV minimisation with FISTA (Du et al. 2018).
//!
//! GFF, MGFF and TEPGFL fuse two frames of the same size (the caller applies the rescale
//! policy); DRIF takes VIS at full size and TIR at its own, smaller, size and returns a frame
//! on the VIS grid. Images are `f64` in 0..255 grey-level units; results are real-valued, and
//! [`fuse_host_u8`] casts them to 8 bits as MATLAB's `uint8` does.

pub mod drif;
pub mod fgs;
pub mod gff;
pub mod guided_filter;
pub mod kernels;
pub mod mgff;
pub mod tepgfl;

use crate::{matlab_uint8, to_f64};
use anyhow::{Result, bail};
use fusion_io::Gray;
use std::time::Instant;

/// The four host-only methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HostMethod {
    /// Guided-filter fusion.
    Gff,
    /// Multi-scale guided-filter fusion.
    Mgff,
    /// Fast-global-smoother decomposition, Gaussian fuzzy-logic base fusion.
    Tepgfl,
    /// Different-resolution TV fusion.
    Drif,
}

impl HostMethod {
    /// All four, in the study's order.
    pub const ALL: [HostMethod; 4] =
        [HostMethod::Gff, HostMethod::Mgff, HostMethod::Tepgfl, HostMethod::Drif];

    /// Short name for tables, files and the CLI.
    pub fn name(self) -> &'static str {
        match self {
            HostMethod::Gff => "gff",
            HostMethod::Mgff => "mgff",
            HostMethod::Tepgfl => "tepgfl",
            HostMethod::Drif => "drif",
        }
    }

    /// Whether the method fuses frames of different sizes itself (no rescale policy).
    pub fn different_resolution(self) -> bool {
        self == HostMethod::Drif
    }
}

/// `Err` unless the two images have the same size.
pub(crate) fn same_size(method: &str, a: &Gray<f64>, b: &Gray<f64>) -> Result<()> {
    if (a.width, a.height) != (b.width, b.height) {
        bail!(
            "{method} fuses frames of the same size (VIS {}x{}, TIR {}x{}); rescale one first",
            a.width,
            a.height,
            b.width,
            b.height
        );
    }
    if a.data.is_empty() {
        bail!("{method}: empty frame");
    }
    Ok(())
}

/// Fuses with a host method, default parameters, real-valued result (0..255 units). GFF, MGFF
/// and TEPGFL need frames of one size; DRIF needs VIS an integer multiple of TIR.
pub fn fuse_host(method: HostMethod, vis: &Gray<f64>, tir: &Gray<f64>) -> Result<Gray<f64>> {
    if vis.data.iter().chain(&tir.data).any(|v| !v.is_finite()) {
        bail!("{}: non-finite input", method.name());
    }
    match method {
        HostMethod::Gff => gff::fuse_gff(vis, tir, &gff::GffParams::default()),
        HostMethod::Mgff => mgff::fuse_mgff(vis, tir, &mgff::MgffParams::default()),
        HostMethod::Tepgfl => tepgfl::fuse_tepgfl(vis, tir, &tepgfl::TepgflParams::default()),
        HostMethod::Drif => Ok(drif::fuse_drif(vis, tir, &drif::DrifParams::default())?.fused),
    }
}

/// A real-valued result cast to 8 bits as MATLAB's `uint8` (round half away, saturate).
pub fn cast_u8(raw: &Gray<f64>) -> Gray<u8> {
    Gray { width: raw.width, height: raw.height, data: raw.data.iter().map(|&v| matlab_uint8(v)).collect() }
}

/// [`fuse_host`] on 8-bit frames: `(8-bit result, real-valued result)`.
pub fn fuse_host_u8(method: HostMethod, vis: &Gray<u8>, tir: &Gray<u8>) -> Result<(Gray<u8>, Gray<f64>)> {
    let raw = fuse_host(method, &to_f64(vis), &to_f64(tir))?;
    Ok((cast_u8(&raw), raw))
}

/// [`fuse_host_u8`] timed once (wall time, seconds; these runs take far longer than the
/// timer's resolution, so one run per frame is the measurement).
pub fn fuse_host_timed(method: HostMethod, vis: &Gray<u8>, tir: &Gray<u8>) -> Result<(Gray<u8>, f64)> {
    let t = Instant::now();
    let (image, _) = fuse_host_u8(method, vis, tir)?;
    Ok((image, t.elapsed().as_secs_f64()))
}

#[cfg(test)]
pub(crate) mod test_images {
    use fusion_io::Gray;

    /// A flat image.
    pub fn constant(w: usize, h: usize, v: f64) -> Gray<f64> {
        Gray { width: w, height: h, data: vec![v; w * h] }
    }

    /// A deterministic image with smooth structure, an edge and a little pseudo-random texture,
    /// in 0..255.
    pub fn textured(w: usize, h: usize, seed: u64) -> Gray<f64> {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let k = seed as f64;
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let grain = (s % 21) as f64 - 10.0;
                let edge = if x + 0.5 * y > 0.6 * w as f64 { 50.0 } else { 0.0 };
                (100.0 + 40.0 * (0.3 * x + 0.1 * k).sin() + 30.0 * (0.2 * y - 0.2 * k).cos() + edge + grain)
                    .clamp(0.0, 255.0)
            })
            .collect();
        Gray { width: w, height: h, data }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_returns_the_vis_grid_and_casts_like_matlab() {
        let vis = Gray { width: 24, height: 16, data: (0..384).map(|i| (i * 7 % 256) as u8).collect() };
        let tir_same = Gray { width: 24, height: 16, data: (0..384).map(|i| (i * 3 % 200) as u8).collect() };
        let tir_half = Gray { width: 12, height: 8, data: (0..96).map(|i| (i * 5 % 256) as u8).collect() };
        for m in HostMethod::ALL {
            let tir = if m.different_resolution() { &tir_half } else { &tir_same };
            let (img, raw) = fuse_host_u8(m, &vis, tir).unwrap();
            assert_eq!((img.width, img.height), (24, 16), "{}", m.name());
            for (&b, &r) in img.data.iter().zip(&raw.data) {
                assert_eq!(b, matlab_uint8(r));
            }
        }
        // same-size methods refuse different sizes; DRIF refuses a non-integer ratio
        assert!(fuse_host_u8(HostMethod::Gff, &vis, &tir_half).is_err());
        let odd = Gray { width: 10, height: 8, data: vec![0; 80] };
        assert!(fuse_host_u8(HostMethod::Drif, &vis, &odd).is_err());
        let nan = Gray { width: 24, height: 16, data: vec![f64::NAN; 384] };
        assert!(fuse_host(HostMethod::Mgff, &nan, &nan).is_err());
    }
}
