//! The flight variant's 8-bit kernel: both bands in lane words, the window sums of the
//! difference kept as running column sums, chunk by chunk the weight-free part, the Scharr
//! weights and the output; memory independent of the frame height (the strips run it on
//! windows).

use super::*;

/// Rows of lane words the flight kernel keeps ([`flight_u8`]): the `2r + 2` rows of the
/// 35×35 window's entering and leaving rows plus one ahead (`2r + 3`).
pub(crate) const fn lane_ring_rows(radius: usize) -> usize {
    2 * radius + 3
}

/// `i32` words the flight kernel needs for a `w`-wide frame: the padded column-sum row
/// (`w + 2r + 1`) and the lane ring (`(2r + 3)·w`) — independent of the frame height.
pub(crate) const fn flight_words(w: usize, radius: usize) -> usize {
    w + 2 * radius + 1 + lane_ring_rows(radius) * w
}

/// Whether the flight kernel fits: `cols` words for the column sums, `lanes` for the ring.
pub(super) fn flight_fits(w: usize, radius: usize, cols: usize, lanes: usize) -> bool {
    cols > w + 2 * radius && lanes >= lane_ring_rows(radius) * w
}

/// The flight variant's 8-bit fusion, row by row (replicate borders throughout): the rows
/// `y0 .. y0 + out.height()` of the frame pair `(vis, tir)` into `out`.
///
/// Both bands' pixels go into lane words ([`lane_pair`]: VIS + IR·2¹⁶), kept in a ring of
/// [`lane_ring_rows`] rows of `lanes` (`(2r + 3)·W` words): the rows `y − r − 1 ..= y + r + 1`
/// around output row `y`, keyed by their unclamped index (a key beyond the frame holds the
/// edge row), each converted once when it enters.
/// Only `d = Σ_IR − Σ_VIS` of the box sums enters ([`fused_u8`] in the form below), so the
/// window sums are of the difference `I_IR − I_VIS`: `cols` (at least `W + 2r + 1` entries)
/// keeps each column's vertical window sum at `r + x`, summed over the window at the first
/// row and then updated by one entering and one leaving row per output row ([`column_step`])
/// and padded with copies of the edge columns (`r` on the left, `r + 1` on the right), so the
/// horizontal running sum over it needs no border test. Then, chunk by chunk of the row, in short passes (few
/// live values each): the weight-free part of each pixel, packed as below; the Scharr columns
/// of both bands ([`scharr_columns_pair`]); per pixel the weights ([`scharr_l1_pair`],
/// `w_VIS + w_IR·2¹⁶`) and the output. Returns (some pixel had both gradients 0, some output
/// saturated). The memory does not grow with the frame height, and any row range gives the
/// rows of the whole-frame run: the strip pipeline ([`crate::strips`]) runs it on windows.
/// The caller checks the memory ([`flight_fits`], [`flight_words`]): with short `cols` or
/// `lanes` the kernel writes nothing and returns `(false, false)`.
///
/// With `c = 2·taps`, `d = c·(a − 128) + r` (`a = ⌊(d + 128c)/c⌋ ∈ [0, 255]`,
/// `0 ≤ r < c ≤ 7938`), `q_VIS = I_VIS + a ∈ [0, 510]`, `q_IR = I_IR − a + 255 ∈ [0, 510]`
/// (packed `q_VIS + q_IR·2⁹ + (r + taps)·2¹⁸`, `r + taps < 3·taps < 2¹⁴`), the numerator
/// of [`fused_u8`] is `U = c·(w_VIS·(q_VIS − 128) + w_IR·(q_IR − 128)) + w_VIS·r +
/// w_IR·(c − r) + e`, `e = den + ⌊den/2¹⁶⌋`, `den = taps·σ`, so `x = ⌊U/c⌋ = w_VIS·q_VIS +
/// w_IR·q_IR − 128σ + ⌊(w_VIS·(r + taps) + w_IR·(2c − r − taps) + ⌊den/2¹⁶⌋)/c⌋` (that
/// numerator is non-negative and below 2²⁸: one unsigned 32-bit division) and the output is
/// `k = ⌊x/σ⌋ = ⌊(x + 128σ)/σ⌋ − 128` (`x + 128σ ≥ 0`: another unsigned division) clamped
/// to `0..=255`, saturated exactly when `k ∉ 0..256` (σ ≤ 16320 < 2¹⁶ and `taps` is odd, so
/// `2¹⁶ ∤ den` and the `U = 0` edge of [`fused_u8`] never arises).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn flight_u8_kernel<const WIDE: bool>(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    taps: u32,
    radius: usize,
    cols: &mut [i32],
    lanes: &mut [i32],
    mut out: FrameMut<'_, u8>,
    y0: usize,
) -> (bool, bool) {
    const TWO: NonZeroU32 = NonZeroU32::MIN.saturating_add(1);
    let (w, h) = vis.size();
    let c = NonZeroU32::new(2 * taps).unwrap_or(TWO);
    let by_c = ByC(c);
    let bias = 128 * c.get() as i32; // d + 128c > 0: |d| ≤ 255·taps
    // q = I_VIS + I_IR·2⁹ + dd·2¹⁸ + a·(1 − 2⁹ − c·2¹⁸) + 255·2⁹ + taps·2¹⁸ (wrapping; exact
    // in the end).
    let a_factor = 1u32.wrapping_sub(1 << 9).wrapping_sub(c.get() << 18);
    let q_const = (255 << 9) + (taps << 18);
    let (mut zero, mut sat) = (false, 0i32);
    let k =
        Consts { c, by_c, inv_c: 1.0 / f64::from(c.get()), magic: MagicC::new(c), taps, a_factor, q_const };
    // Per column of a chunk: the two lane words of the Scharr columns and, one column to the
    // right of its pixel (the centre of its window), the packed weight-free part.
    let mut buf = [[0u32; 3]; CHUNK + 2];
    let mut wide = Wide::new();
    let span = 2 * radius + 1;
    let Some(cols) = cols.get_mut(..w + span) else { return (zero, false) };
    let ring = lane_ring_rows(radius) as isize;
    let Some(lanes) = lanes.get_mut(..ring as usize * w) else { return (zero, false) };
    let slot = |k: isize| k.checked_rem_euclid(ring).unwrap_or(0) as usize * w;
    // Converts the (clamped) frame row `k` into the ring slot of key `k`.
    let fill = |lanes: &mut [i32], k: isize| {
        let dst = lanes.get_mut(slot(k)..slot(k) + w).unwrap_or(&mut []);
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        if WIDE {
            lane_pairs(dst, vis.row_clamped(k), tir.row_clamped(k));
            return;
        }
        for ((o, &v), &t) in dst.iter_mut().zip(vis.row_clamped(k)).zip(tir.row_clamped(k)) {
            *o = lane_pair(v, t);
        }
    };
    let first = y0 as isize;
    for k in first - radius as isize - 1..=first + radius as isize + 1 {
        fill(lanes, k);
    }
    // The lane weights of `column_step` (opaque: kept in registers, not rebuilt per pixel).
    let lane_weights = core::hint::black_box(LANE_WEIGHTS);
    for (y, dst) in (y0..h).zip(out.rows_mut()) {
        let yi = y as isize;
        if yi > first {
            fill(lanes, yi + radius as isize + 1);
        }
        let (left, rest) = cols.split_at_mut(radius.min(cols.len()));
        let (mid, right) = rest.split_at_mut(w.min(rest.len()));
        let lane_row = |k: isize| lanes.get(slot(k)..slot(k) + w).unwrap_or(&[]);
        if yi == first {
            mid.fill(0);
            for k in yi - radius as isize..=yi + radius as isize {
                for ((m, &t), &v) in mid.iter_mut().zip(tir.row_clamped(k)).zip(vis.row_clamped(k)) {
                    *m += i32::from(t) - i32::from(v);
                }
            }
        } else {
            let (enter, leave) = (lane_row(yi + radius as isize), lane_row(yi - radius as isize - 1));
            column_steps_any::<WIDE>(mid, enter, leave, lane_weights);
        }
        let (first_col, last_col) = (mid.first().copied().unwrap_or(0), mid.last().copied().unwrap_or(0));
        left.fill(first_col);
        right.fill(last_col);
        let cols = &*cols;
        // The running window sum of the pixel x = the sum of cols[x ..= x + 2r], plus the bias.
        let mut sum = cols.iter().take(span).sum::<i32>() + bias;
        let rows = [lane_row(yi - 1), lane_row(yi), lane_row(yi + 1)];
        let (iv, ii) = (vis.row(y), tir.row(y));
        let mut x0 = 0;
        while x0 < w {
            let n = CHUNK.min(w - x0);
            let chunk = FlightChunk {
                enter: cols.get(x0 + span..x0 + span + n).unwrap_or(&[]),
                leave: cols.get(x0..x0 + n).unwrap_or(&[]),
                iv: cut(iv, x0, n),
                ii: cut(ii, x0, n),
                rows,
                x0,
            };
            let o = dst.get_mut(x0..x0 + n).unwrap_or(&mut []);
            if WIDE {
                #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
                chunk_neon(&chunk, &k, &mut sum, &mut wide, &mut buf, o, &mut zero, &mut sat);
                #[cfg(not(all(target_arch = "aarch64", target_feature = "neon")))]
                chunk_wide(&chunk, &k, &mut sum, &mut wide, o, &mut zero, &mut sat);
            } else {
                chunk_portable(&chunk, &k, &mut sum, &mut buf, o, &mut zero, &mut sat);
            }
            x0 += n;
        }
    }
    (zero, sat != 0)
}

/// `mid[x] = column_step(mid[x], enter[x], leave[x], lane_weights)` for every `x`: on AArch64
/// in the wide form by NEON (`column_steps`, `neon.rs`), else lane by lane.
#[inline(always)]
fn column_steps_any<const WIDE: bool>(mid: &mut [i32], enter: &[i32], leave: &[i32], lane_weights: [i32; 2]) {
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    if WIDE {
        return column_steps(mid, enter, leave);
    }
    for ((m, &e), &l) in mid.iter_mut().zip(enter).zip(leave) {
        *m = column_step(*m, e, l, lane_weights);
    }
}

/// Whether the flight kernel's chunks take the wide form (x86-64: [`chunk_wide`], the divisions
/// in floating point, in separate passes the compiler vectorises; AArch64 with NEON, unless
/// `cpu::limit_isa` caps it at the portable code: `chunk_neon`, `neon.rs`) or the portable
/// one ([`chunk_portable`]: integer divisions in one pass, the fewest instructions on the
/// flight microcontrollers). Both give the same bytes (unit test
/// `wide_and_portable_chunks_agree`, which on AArch64 — under `qemu-aarch64` in CI — checks
/// the NEON chunk and row loops; and the SIMD-forms test).
#[inline(always)]
pub(super) fn wide_chunks() -> bool {
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    {
        crate::cpu::has_neon()
    }
    #[cfg(not(all(target_arch = "aarch64", target_feature = "neon")))]
    {
        cfg!(target_arch = "x86_64")
    }
}

/// [`flight_u8_kernel`] in this target's chunk form ([`wide_chunks`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn flight_u8_chunks(
    vis: FrameRef<'_, u8>,
    tir: FrameRef<'_, u8>,
    taps: u32,
    radius: usize,
    cols: &mut [i32],
    lanes: &mut [i32],
    out: FrameMut<'_, u8>,
    y0: usize,
) -> (bool, bool) {
    if wide_chunks() {
        flight_u8_kernel::<true>(vis, tir, taps, radius, cols, lanes, out, y0)
    } else {
        flight_u8_kernel::<false>(vis, tir, taps, radius, cols, lanes, out, y0)
    }
}

/// The per-frame constants of the flight kernel's output (see [`flight_u8_kernel`]).
pub(super) struct Consts {
    pub(super) c: NonZeroU32,
    pub(super) by_c: ByC,
    /// `1/c` in `f64` for [`div_c_f64`] (x86-64's wide chunk).
    #[cfg_attr(all(target_arch = "aarch64", target_feature = "neon"), allow(dead_code))]
    pub(super) inv_c: f64,
    /// `⌊n/c⌋` by a multiplication ([`MagicC`], the NEON chunk).
    #[cfg_attr(not(all(target_arch = "aarch64", target_feature = "neon")), allow(dead_code))]
    pub(super) magic: MagicC,
    pub(super) taps: u32,
    pub(super) a_factor: u32,
    pub(super) q_const: u32,
}

/// One chunk of a row: the column sums entering and leaving each pixel's window, the pixels,
/// the three lane rows of the Scharr columns and the chunk's first column.
pub(super) struct FlightChunk<'a> {
    pub(super) enter: &'a [i32],
    pub(super) leave: &'a [i32],
    pub(super) iv: &'a [u8],
    pub(super) ii: &'a [u8],
    pub(super) rows: [&'a [i32]; 3],
    pub(super) x0: usize,
}

/// The packed weight-free part of a pixel (see [`flight_u8_kernel`]) from its window sum
/// `dd` (biased) and `a = ⌊dd/c⌋`.
#[inline(always)]
pub(super) fn packed(k: &Consts, dd: u32, a: u32, iv: u8, ii: u8) -> u32 {
    let low = u32::from(iv) + (u32::from(ii) << 9) + k.q_const;
    a.wrapping_mul(k.a_factor).wrapping_add(dd << 18).wrapping_add(low)
}

/// The 8-bit output of a pixel from its weights (`σ = w_VIS + w_IR > 0`) and packed part,
/// with the two divisions given: `(value, k >> 8)` (non-zero when saturated).
#[inline(always)]
pub(super) fn output(
    k: &Consts,
    (gv, gi, sigma): (u32, u32, u32),
    q: u32,
    div_c: impl Fn(u32) -> u32,
    div_s: impl Fn(u32, u32) -> u32,
) -> (u8, i32) {
    let (qv, qi, rt) = (q & 0x1FF, q >> 9 & 0x1FF, q >> 18);
    // w_VIS·r + w_IR·(c − r) + den = w_VIS·(r + taps) + w_IR·(2c − (r + taps)).
    let f = div_c(gv * rt + gi * (2 * k.c.get() - rt) + ((k.taps * sigma) >> 16));
    // ⌊x/σ⌋ = ⌊(x + 128σ)/σ⌋ − 128, and x + 128σ ≥ 0.
    let v = div_s(gv * qv + gi * qi + f, sigma) as i32 - 128;
    (v.clamp(0, 255) as u8, v >> 8)
}

/// One chunk in one pass with integer divisions (the flight targets: one `udiv` each).
#[inline(always)]
pub(super) fn chunk_portable(
    ch: &FlightChunk<'_>,
    k: &Consts,
    sum: &mut i32,
    buf: &mut [[u32; 3]; CHUNK + 2],
    out: &mut [u8],
    zero: &mut bool,
    sat: &mut i32,
) {
    let n = out.len();
    let Some(buf) = buf.get_mut(..n + 2) else { return };
    let pixels = ch.iv.iter().zip(ch.ii);
    for ((b, (&enter, &leave)), (&iv, &ii)) in
        buf.iter_mut().skip(1).zip(ch.enter.iter().zip(ch.leave)).zip(pixels)
    {
        let dd = *sum as u32;
        *sum += enter - leave;
        b[2] = packed(k, dd, k.by_c.div(dd), iv, ii);
    }
    let store = |[s, d, _]: &mut [u32; 3], sm, df| (*s, *d) = (sm, df);
    scharr_columns_pair(ch.rows, Border::Replicate, ch.x0, buf, store);
    for (o, w) in out.iter_mut().zip(buf.windows(3)) {
        let &[[s0, d0, _], [_, d1, q], [s2, d2, _]] = w else { continue };
        let wts = scharr_l1_pair([s0, s2], [d0, d1, d2]);
        let (gv, gi) = (wts & 0xFFFF, wts >> 16);
        let (gv, gi, sigma) = match NonZeroU32::new(gv + gi) {
            Some(sigma) => (gv, gi, sigma),
            None => flat(zero),
        };
        let (v, s) = output(k, (gv, gi, sigma.get()), q, |n| k.by_c.div(n), |n, _| div_sigma(n, sigma));
        *o = v;
        *sat |= s;
    }
}

/// `⌊n / c⌋` for the frame's constant `c = 2·taps` (the portable chunk form: one `udiv` on the
/// flight targets; the wide form uses [`div_c_f64`]).
#[derive(Clone, Copy)]
pub(super) struct ByC(pub(super) NonZeroU32);

impl ByC {
    #[inline(always)]
    pub(super) fn div(self, n: u32) -> u32 {
        n / self.0
    }
}

/// `⌊n / σ⌋` of the portable chunk form (the wide form uses [`div_sigma_f32`]).
#[inline(always)]
pub(super) fn div_sigma(n: u32, sigma: NonZeroU32) -> u32 {
    n / sigma
}

/// The lane weights (−1, 1) and (1, −1) of [`column_step`] (low lane first).
pub(super) const LANE_WEIGHTS: [i32; 2] = [0x0001_FFFF, 0xFFFF_0001u32 as i32];

/// `col + (I_IR − I_VIS)(entering) − (I_IR − I_VIS)(leaving)` from two lane words
/// ([`lane_pair`]: VIS + IR·2¹⁶): on Arm two dual multiply-accumulates (`smlad` with the lane
/// weights `[up, down]` = [`LANE_WEIGHTS`]), else lane by lane.
#[inline(always)]
#[cfg_attr(not(fusion_arm_dsp), allow(unused_variables))]
pub(super) fn column_step(col: i32, enter: i32, leave: i32, [up, down]: [i32; 2]) -> i32 {
    #[cfg(fusion_arm_dsp)]
    {
        crate::arch::smlad(leave, down, crate::arch::smlad(enter, up, col))
    }
    #[cfg(not(fusion_arm_dsp))]
    {
        let diff = |v: i32| (v >> 16) - (v & 0xFFFF);
        col + diff(enter) - diff(leave)
    }
}

/// The weights `(1, 1, σ = 2)` of a pixel whose two saliencies are 0, noting it in `zero`
/// (rare: kept out of the hot loop).
#[cold]
#[inline(never)]
pub(super) fn flat(zero: &mut bool) -> (u32, u32, NonZeroU32) {
    *zero = true;
    (1, 1, NonZeroU32::MIN.saturating_add(1))
}
