//! The core's thermal front end (`fusion_nostd::thermal`) on host frames: one camera's chain —
//! factory NUC tables, shutter re-levelling, bad-pixel map, column-noise filter — carried from
//! frame to frame, for the CLI (`fusion fuse --nuc --bad-pixels --column-filter`), the
//! navigation benchmark's raw-sensor streams and the Python package.

use anyhow::{Context, Result};
use fusion_io::Gray;
use fusion_io::thermal::{BadPixels, NucTables};
use fusion_nostd::thermal::{
    ColumnFilter, ColumnParams, Correction, column_filter_frame, correct_frame, shutter_update,
};

/// The column filter's radius used by the host tools (columns).
pub const COLUMN_RADIUS: u16 = 16;

/// The column filter of a [`ThermalChain`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Column {
    /// These parameters on every frame.
    Params(ColumnParams),
    /// Each frame's threshold from the frame itself after the tables and the map
    /// ([`column_threshold`]), this radius and smoothing.
    Auto {
        /// Radius of the profile's low-pass, columns.
        radius: u16,
        /// Temporal smoothing shift.
        smoothing: u8,
    },
}

/// One thermal camera's correction state.
pub struct ThermalChain {
    nuc: Option<NucTables>,
    bad: Option<BadPixels>,
    column: Option<Column>,
    filter: Box<ColumnFilter>,
}

impl ThermalChain {
    /// A chain of the given stages (each optional); `column`: the column filter's parameters.
    /// `Err` when the tables and the map are of different arrays.
    pub fn new(nuc: Option<NucTables>, bad: Option<BadPixels>, column: Option<Column>) -> Result<Self> {
        if let (Some(t), Some(b)) = (&nuc, &bad)
            && (t.width, t.height) != (b.width, b.height)
        {
            anyhow::bail!(
                "the NUC tables are of a {}x{} array, the bad-pixel map of a {}x{} one",
                t.width,
                t.height,
                b.width,
                b.height
            );
        }
        let check = match column {
            Some(Column::Params(p)) => Some(p),
            // Any valid threshold stands in for the frame's own.
            Some(Column::Auto { radius, smoothing }) => {
                Some(ColumnParams { threshold: 1, radius, smoothing })
            }
            None => None,
        };
        if let Some(p) = check {
            p.validate().map_err(|e| anyhow::anyhow!("column filter: {e}"))?;
        }
        Ok(ThermalChain { nuc, bad, column, filter: Box::new(ColumnFilter::new()) })
    }

    /// Whether any stage is present.
    pub fn is_active(&self) -> bool {
        self.nuc.is_some() || self.bad.is_some() || self.column.is_some()
    }

    /// Re-levels the NUC offsets from a shutter frame (no NUC tables: nothing to do).
    pub fn shutter(&mut self, shutter: &Gray<u16>) -> Result<fusion_nostd::thermal::ShutterReport> {
        let bad_view = self.bad.as_ref().map(|b| b.view()).transpose()?;
        let Some(t) = self.nuc.as_mut() else {
            anyhow::bail!("a shutter frame re-levels the NUC offsets: give the NUC tables");
        };
        shutter_update(&t.gain, &mut t.offset, bad_view.as_ref(), shutter.view()?)
            .map_err(|e| anyhow::anyhow!("shutter frame: {e}"))
    }

    /// One frame of raw counts through the chain (the column filter's estimate smoothed with
    /// the frames before when its parameters ask for it).
    pub fn correct(&mut self, raw: &Gray<u16>) -> Result<Gray<u16>> {
        let size = (raw.width, raw.height);
        for (what, got) in [
            ("NUC tables are", self.nuc.as_ref().map(|t| (t.width, t.height))),
            ("bad-pixel map is", self.bad.as_ref().map(|b| (b.width, b.height))),
        ] {
            if let Some(got) = got.filter(|&g| g != size) {
                anyhow::bail!("the {what} {}x{}, the thermal frame {}x{}", got.0, got.1, size.0, size.1);
            }
        }
        let stages = Correction {
            nuc: self.nuc.as_ref().map(|t| t.view()).transpose()?,
            bad: self.bad.as_ref().map(|b| b.view()).transpose()?,
        };
        let mut out = Gray::<u16>::new(raw.width, raw.height);
        correct_frame(&stages, None, raw.view()?, out.view_mut()?)
            .map_err(|e| anyhow::anyhow!("thermal correction: {e}"))?;
        // The column filter on the corrected frame, in place (`correct_frame`'s own last step).
        let params = match self.column {
            None => return Ok(out),
            Some(Column::Params(p)) => p,
            Some(Column::Auto { radius, smoothing }) => {
                ColumnParams { threshold: column_threshold(&out), radius, smoothing }
            }
        };
        column_filter_frame(&mut self.filter, out.view_mut()?, &params)
            .map_err(|e| anyhow::anyhow!("column filter: {e}"))?;
        Ok(out)
    }
}

/// A column-filter threshold for frames like `frame`: three standard deviations of the
/// horizontal differences of neighbouring pixels, estimated robustly (1.4826 × their median
/// absolute value, so that edges do not count), at least 1 count.
pub fn column_threshold(frame: &Gray<u16>) -> u16 {
    let mut d: Vec<u32> = frame
        .data
        .chunks_exact(frame.width.max(1))
        .flat_map(|r| r.windows(2).map(|w| u32::from(w[0].abs_diff(w[1]))))
        .collect();
    if d.is_empty() {
        return 1;
    }
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable(mid);
    (3.0 * 1.4826 * f64::from(*m))
        .round()
        .clamp(1.0, f64::from(fusion_nostd::thermal::column::COLUMN_MAX_THRESHOLD)) as u16
}

/// Reads the NUC tables and the bad-pixel map named on a command line (either may be absent).
pub fn load(
    nuc: Option<&std::path::Path>,
    bad: Option<&std::path::Path>,
) -> Result<(Option<NucTables>, Option<BadPixels>)> {
    let t = nuc.map(|p| NucTables::read(p).with_context(|| format!("--nuc {}", p.display()))).transpose()?;
    let b = bad
        .map(|p| BadPixels::read(p).with_context(|| format!("--bad-pixels {}", p.display())))
        .transpose()?;
    Ok((t, b))
}
