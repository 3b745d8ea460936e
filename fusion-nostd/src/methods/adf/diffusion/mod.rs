//! ADF step 1: the Perona–Malik diffusion of both bands at once (the base layers).
//!
//! # Number formats
//!
//! | quantity | format | range |
//! |---|---|---|
//! | state `A_k` of one band | `i16`, Q7 grey levels | clamped to `0..=32767` (0 ..< 256 levels) after every update |
//! | one pixel of both bands (rows, pipeline, the base-layer plane) | `i32` word: VIS in the low half, TIR in the high half | — |
//! | neighbour difference `∇` | `i16` | `−32767..=32767` (two states) |
//! | pair flux `F(∇)` | `i16`, state units | \|F\| ≤ the largest node ≤ Δt/2·0.4306·κ_q + ½ ≤ [`MAX_FLUX`](flux::MAX_FLUX) = 1760 |
//! | step `Σ = 2·(h + v − h_prev) + (dr + dl − north)`, north sums | `i16` partial sums | every partial sum ≤ 12·1760 < 2¹⁵: nothing saturates |
//! | next state | `A + Σ`, clamped to `0..=32767` | — |
//!
//! The update is the published `A ← A + Δt·(Σ_axial c∇ + ½·Σ_diagonal c∇)`, `c = exp(−(∇/κ)²)`:
//! with `F = Δt/2·c·∇` (state units) it is `A + 2·Σ_axial F + Σ_diagonal F`, with no rounding
//! after the fluxes' own: the step is odd in the fluxes, so a band and its negative `255 − I`
//! diffuse to exact negatives, as in the f64 reference — as long as no state is clamped. The
//! clamp to 0..=32767 (which the f64 reference does not have) can act where the explicit scheme
//! overshoots: for Δt > 1/6 (the scheme's max-principle bound; the API allows up to 0.25) at
//! high-contrast single pixels, and by a few state units where the fluxes' rounding pushes a
//! pixel at 0 below it.
//!
//! **The flux function** ([`flux`], which documents its construction, its error and its
//! forms). `F(∇)` is a piecewise-linear function of `|∇|` on 64 segments, odd by construction,
//! defined by integer operations so that every target computes the same value; tabulated for
//! every 16-bit difference where a table read is cheaper than the arithmetic, held in
//! registers by the AVX-512, AVX2 and NEON row loops.
//!
//! **Both bands at once.** A work word holds one pixel of both bands; the Armv7E-M loop takes
//! both differences with one `ssub16` and sums both bands' fluxes with `qadd16`/`qsub16`
//! (16-bit halves), the AVX-512 loop runs 16 pixels × 2 bands per vector, the portable loop sums
//! each band in `i32`: the same values, since no partial sum leaves `i16`.
//!
//! **Pair fluxes and the row pipeline.** Each neighbour pair's flux is taken once, as
//! `F(later − earlier)` in row-major order, and enters both pixels with opposite signs (4 flux
//! evaluations per pixel and iteration instead of 8). The iterations run as a row pipeline
//! (temporal blocking): stage `k` turns each new row of iterate `k` into a row of iterate
//! `k + 1` and hands it straight on, so the frame is read and written once per group of
//! iterations and the work rows stay in cache.
//!
//! # Files
//!
//! * [`pack`]: the work word of both bands — the input [`Band`]s packed row by row, the
//!   word's halves.
//! * [`flux`]: the flux function ([`FluxFn`](flux::FluxFn)), its 128 KiB table and the byte
//!   tables of the shuffle forms, the bound [`MAX_FLUX`](flux::MAX_FLUX).
//! * [`row`]: the row update, one row of one iteration — the per-call constants
//!   ([`Diffusion`](row::Diffusion)), the portable row loop by pair fluxes and the hand-over
//!   to the instruction-set loops; the plain per-pixel update for frames too small for the
//!   pipeline.
//! * [`row_pipeline`]: the row pipeline (temporal blocking) and the entries [`diffuse_pair`] and
//!   [`diffuse_rows`].
//! * `simd.rs`: the row loop of the SIMD forms, written once for any register width;
//!   `avx2.rs`, `avx512.rs` (x86-64, chosen at run time) and `neon.rs` (AArch64) implement
//!   its lanes. `armv7em.rs`: the Armv7E-M DSP row loop (inline assembly, reading the table).
//! * `tests.rs`: the unit tests.

/// Fractional bits of the diffusion state.
pub(super) const STATE_BITS: u32 = 7;
/// The largest state (255.99 grey levels).
const STATE_MAX: i32 = i16::MAX as i32;

mod flux;
mod pack;
mod row;
mod row_pipeline;

pub use pack::Band;
pub(super) use pack::{hi, lo};
// ADF's tests build work words.
#[cfg(test)]
pub(super) use pack::pack;
pub use row_pipeline::diffuse_pair;
pub(crate) use row_pipeline::{diffuse_rows, stream_words};

#[cfg(fusion_arm_dsp)]
mod armv7em;

#[cfg(any(target_arch = "x86_64", all(target_arch = "aarch64", target_feature = "neon")))]
mod simd;

#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
mod neon;

#[cfg(target_arch = "x86_64")]
mod avx2;

#[cfg(target_arch = "x86_64")]
mod avx512;

#[cfg(test)]
mod tests;
