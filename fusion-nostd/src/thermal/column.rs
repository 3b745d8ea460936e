//! Scene-based column-noise filter: the offsets a microbolometer's column readout adds to whole
//! columns, estimated from the scene and removed.
//!
//! A column offset `δ` at column `x` makes the horizontal difference `v(x) − v(x − 1)` of every
//! row `δ` larger and the next column's `δ` smaller, while the scene's differences vary from row
//! to row. Per frame, with `T` the threshold (counts), `r` the radius (columns), all integer:
//!
//! 1. `h(x)` = the mean of `v(x) − v(x − 1)` over the rows where `|v(x) − v(x − 1)| ≤ T`
//!    (0 where no row is), `h(0) = 0`, held in Q4 (sixteenths of a count, rounded half up) —
//!    the differences across a target's vertical edges are left out, not taken for column
//!    offsets (a clip at `T` would still bias the edge's columns by up to `T`);
//! 2. the column profile `c(x) = h(1) + … + h(x)` (Q4);
//! 3. its low-pass `s(x)` = the mean of `c` over columns `x − r ..= x + r` inside the frame
//!    (rounded half up), and the estimate `e(x) = c(x) − s(x)`: the profile's structure narrower
//!    than `2r + 1` columns (the readout's column pattern), not the scene's slow gradients;
//! 4. temporal smoothing (`smoothing = k > 0`, for sequences): the estimate held moves 1/2ᵏ of
//!    the way to each new frame's, rounded away from zero (as the AGC's mapping does);
//! 5. the output `v(x) − ⌊(e(x) + 8) / 16⌋`, clamped to 16 bits.
//!
//! Like the AGC, two orders: the frame's own estimate ([`ColumnFilter::accumulate`] every row,
//! [`ColumnFilter::update`], then [`ColumnFilter::apply`] every row: [`column_filter_frame`]), or
//! the previous frame's (per row `apply` then `accumulate`, `update` at the end of the frame: one
//! pass, for a camera read out line by line).
//!
//! What it leaves: the column offsets' own mean over the window (`σ_col/√(2r + 1)` for
//! independent column offsets of spread `σ_col`: a slow ripple, no longer stripes), and the
//! noise of the `h` summed along the profile like a random walk, about `σ_d·√(r/(3H))` for a
//! difference noise `σ_d` over `H` rows (less with temporal smoothing). The two balance near
//! `r ≈ σ_col·√(3H/2)/σ_d`; r = 16 suits a 512-row array whose column spread is near its
//! temporal noise.
//!
//! State: [`COLUMN_MAX_WIDTH`] columns of sum, row count, profile and estimate: 28 KiB.

use crate::error::Error;
use crate::frame::FrameMut;

/// The widest array the filter takes.
pub const COLUMN_MAX_WIDTH: usize = 2048;
/// The largest clip threshold, counts (keeps the Q4 profile inside `i32`).
pub const COLUMN_MAX_THRESHOLD: u16 = 32_767;
/// The largest temporal smoothing shift.
pub const COLUMN_MAX_SMOOTHING: u8 = 8;

/// Column-noise filter parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ColumnParams {
    /// Threshold `T` of the horizontal differences that count, counts (1 ..= 32 767): a few
    /// times the temporal noise of a difference (and more than the column offsets), below the
    /// scene's edges.
    pub threshold: u16,
    /// Radius `r` of the profile's low-pass, columns (≥ 1).
    pub radius: u16,
    /// Temporal smoothing shift `k` (0 = each frame's own estimate, at most 8).
    pub smoothing: u8,
}

impl ColumnParams {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), Error> {
        if self.threshold == 0 || self.threshold > COLUMN_MAX_THRESHOLD {
            return Err(Error::InvalidParameter { name: "column filter threshold" });
        }
        if self.radius == 0 {
            return Err(Error::InvalidParameter { name: "column filter radius" });
        }
        if self.smoothing > COLUMN_MAX_SMOOTHING {
            return Err(Error::InvalidParameter { name: "column filter smoothing" });
        }
        Ok(())
    }
}

/// The filter's state (zero when new, so it can live in `.bss`).
pub struct ColumnFilter {
    /// Per column, the sum of the differences within the threshold over the rows accumulated.
    acc: [i32; COLUMN_MAX_WIDTH],
    /// Per column, the rows whose difference was within the threshold.
    count: [u16; COLUMN_MAX_WIDTH],
    /// The profile `c` (Q4), then scratch.
    profile: [i32; COLUMN_MAX_WIDTH],
    /// The smoothed estimate `e` (Q4).
    estimate: [i32; COLUMN_MAX_WIDTH],
    width: usize,
    rows: u32,
    ready: bool,
}

impl Default for ColumnFilter {
    fn default() -> Self {
        Self::new()
    }
}

/// What one [`ColumnFilter::update`] found, for telemetry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ColumnReport {
    /// Rows the estimate was taken over.
    pub rows: u32,
    /// The largest correction applied to a column, counts.
    pub max_correction: u16,
}

impl ColumnFilter {
    /// No rows, no estimate.
    pub const fn new() -> Self {
        ColumnFilter {
            acc: [0; COLUMN_MAX_WIDTH],
            count: [0; COLUMN_MAX_WIDTH],
            profile: [0; COLUMN_MAX_WIDTH],
            estimate: [0; COLUMN_MAX_WIDTH],
            width: 0,
            rows: 0,
            ready: false,
        }
    }

    /// Forgets the rows and the estimate (a new sequence).
    pub fn reset(&mut self) {
        self.acc.fill(0);
        self.count.fill(0);
        self.rows = 0;
        self.width = 0;
        self.ready = false;
    }

    /// Whether rows of `width` fit the state (no estimate yet, or one of that width).
    pub(crate) fn fits(&self, width: usize) -> bool {
        width > 0 && width <= COLUMN_MAX_WIDTH && (!self.ready || self.width == width)
    }

    /// Whether an estimate exists (after the first [`ColumnFilter::update`]).
    pub fn has_estimate(&self) -> bool {
        self.ready
    }

    /// The correction subtracted from column `x`, counts (0 without an estimate).
    pub fn correction(&self, x: usize) -> i32 {
        if !self.ready {
            return 0;
        }
        self.estimate.get(x).map_or(0, |&e| (e + 8) >> 4)
    }

    /// Adds one row to the statistics. `Err` (nothing added) for a row wider than
    /// [`COLUMN_MAX_WIDTH`], of another width than the rows before, or one row too many
    /// (more than 16 384 before an update).
    pub fn accumulate(&mut self, row: &[u16], params: &ColumnParams) -> Result<(), Error> {
        params.validate()?;
        let w = row.len();
        if w == 0 || w > COLUMN_MAX_WIDTH {
            return Err(Error::InvalidParameter { name: "column filter width" });
        }
        if (self.rows > 0 || self.ready) && w != self.width {
            return Err(Error::SizeMismatch { expected: (self.width, 1), got: (w, 1) });
        }
        if self.rows as usize >= crate::MAX_DIMENSION {
            return Err(Error::InvalidParameter { name: "column filter rows (update first)" });
        }
        self.width = w;
        self.rows += 1;
        let t = i32::from(params.threshold);
        let cells = self.acc.iter_mut().zip(self.count.iter_mut()).skip(1);
        for ((a, c), (&v, &left)) in cells.zip(row.iter().skip(1).zip(row)) {
            let d = i32::from(v) - i32::from(left);
            if d.abs() <= t {
                *a += d;
                *c += 1;
            }
        }
        Ok(())
    }

    /// Subtracts the current estimate from `row` into `out` (same width as the rows accumulated).
    /// Without an estimate the row passes unchanged.
    pub fn apply(&self, row: &[u16], out: &mut [u16]) -> Result<(), Error> {
        if row.len() != out.len() {
            return Err(Error::BufferTooSmall { needed: row.len(), got: out.len() });
        }
        if !self.ready {
            out.copy_from_slice(row);
            return Ok(());
        }
        if row.len() != self.width {
            return Err(Error::SizeMismatch { expected: (self.width, 1), got: (row.len(), 1) });
        }
        for ((o, &v), &e) in out.iter_mut().zip(row).zip(&self.estimate) {
            *o = (i32::from(v) - ((e + 8) >> 4)).clamp(0, i32::from(u16::MAX)) as u16;
        }
        Ok(())
    }

    /// [`ColumnFilter::apply`] in place.
    pub fn apply_in_place(&self, row: &mut [u16]) -> Result<(), Error> {
        if !self.ready {
            return Ok(());
        }
        if row.len() != self.width {
            return Err(Error::SizeMismatch { expected: (self.width, 1), got: (row.len(), 1) });
        }
        for (v, &e) in row.iter_mut().zip(&self.estimate) {
            *v = (i32::from(*v) - ((e + 8) >> 4)).clamp(0, i32::from(u16::MAX)) as u16;
        }
        Ok(())
    }

    /// Builds the estimate from the rows accumulated (smoothed with the previous one when
    /// `params.smoothing > 0`), then empties the statistics. `Err` (state unchanged) for bad
    /// parameters or no rows.
    pub fn update(&mut self, params: &ColumnParams) -> Result<ColumnReport, Error> {
        params.validate()?;
        if self.rows == 0 {
            return Err(Error::InvalidParameter { name: "column filter (no rows)" });
        }
        let w = self.width.min(COLUMN_MAX_WIDTH);
        // Steps 1–2: h in Q4 (⌊(32·acc + n) / (2n)⌋, half up, n the rows counted), summed
        // into the profile.
        let mut c = 0i32;
        for ((p, &a), &n) in self.profile.iter_mut().zip(&self.acc).zip(&self.count).take(w) {
            if n > 0 {
                let n = i64::from(n);
                c += (32 * i64::from(a) + n).div_euclid(2 * n) as i32;
            }
            *p = c;
        }
        // Step 3: the running sum of the window [x − r, x + r] ∩ [0, w).
        let r = usize::from(params.radius);
        let at = |p: &[i32; COLUMN_MAX_WIDTH], i: usize| i64::from(p.get(i).copied().unwrap_or(0));
        let mut sum: i64 = (0..=r.min(w - 1)).map(|i| at(&self.profile, i)).sum();
        let shift = if self.ready { u32::from(params.smoothing) } else { 0 };
        let mut max_correction = 0u16;
        for x in 0..w {
            let (lo, hi) = (x.saturating_sub(r), (x + r).min(w - 1));
            // At least 1 (x lies in its window); `max` lets the compiler see the division is safe.
            let count = ((hi - lo + 1) as i64).max(1);
            let s = (2 * sum + count).div_euclid(2 * count) as i32;
            let e = at(&self.profile, x) as i32 - s;
            // Step 4: the held estimate moves towards e, the step rounded away from zero.
            if let Some(old) = self.estimate.get_mut(x) {
                let d = e - *old;
                *old = match shift {
                    0 => e,
                    k if d > 0 => *old + ((d + (1 << k) - 1) >> k),
                    k => *old + (d >> k),
                };
                max_correction = max_correction.max(((*old + 8) >> 4).unsigned_abs().min(65_535) as u16);
            }
            // Slide the window: x − r leaves, x + r + 1 enters.
            if x >= r {
                sum -= at(&self.profile, x - r);
            }
            if x + r + 1 < w {
                sum += at(&self.profile, x + r + 1);
            }
        }
        let report = ColumnReport { rows: self.rows, max_correction };
        self.ready = true;
        self.acc.fill(0);
        self.count.fill(0);
        self.rows = 0;
        Ok(report)
    }
}

/// The whole frame in place with its own estimate (smoothed with `filter`'s previous one when
/// `params.smoothing > 0`): every row accumulated, the estimate built, then subtracted.
pub fn column_filter_frame(
    filter: &mut ColumnFilter,
    mut frame: FrameMut<'_, u16>,
    params: &ColumnParams,
) -> Result<ColumnReport, Error> {
    params.validate()?;
    if !filter.fits(frame.width()) {
        return Err(Error::InvalidParameter { name: "column filter width" });
    }
    // The frame's own statistics: whatever was accumulated before is dropped.
    filter.acc.fill(0);
    filter.count.fill(0);
    filter.rows = 0;
    for row in frame.as_ref().rows() {
        filter.accumulate(row, params)?;
    }
    let report = filter.update(params)?;
    for row in frame.rows_mut() {
        filter.apply_in_place(row)?;
    }
    Ok(report)
}
