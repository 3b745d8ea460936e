//! The work word: one pixel of both bands in an `i32`, VIS in the low and TIR in the high 16
//! bits (Q7 states, see the number formats in [`super`]); the input [`Band`]s packed row by row
//! into it ([`fill_row`]), and its halves ([`lo`], [`hi`], [`half`], [`pack`]).

use super::STATE_BITS;
use crate::FrameRef;

/// One input band of the diffusion.
#[derive(Debug, Clone, Copy)]
pub enum Band<'a> {
    /// An 8-bit frame.
    Frame(FrameRef<'a, u8>),
    /// A constant frame of this level (the eclipse plan's VIS).
    Level(u8),
}

/// Two 8-bit values as a work word of Q7 states (both halves non-negative).
#[inline(always)]
fn pack_u8(vis: u8, tir: u8) -> i32 {
    (i32::from(tir) << (16 + STATE_BITS)) | (i32::from(vis) << STATE_BITS)
}

/// Writes row `y` of both bands, packed, into `dst` (`w` words).
pub(super) fn fill_row(dst: &mut [i32], vis: &Band<'_>, tir: &Band<'_>, y: usize) {
    match (vis, tir) {
        (Band::Frame(v), Band::Frame(t)) => pack_rows(dst, v.row(y), t.row(y)),
        (Band::Level(a), Band::Frame(t)) => {
            for (d, &b) in dst.iter_mut().zip(t.row(y)) {
                *d = pack_u8(*a, b);
            }
        }
        (Band::Frame(v), Band::Level(b)) => {
            for (d, &a) in dst.iter_mut().zip(v.row(y)) {
                *d = pack_u8(a, *b);
            }
        }
        (Band::Level(a), Band::Level(b)) => dst.fill(pack_u8(*a, *b)),
    }
}

crate::cpu::dispatch! {
    /// Two 8-bit rows as work words.
    fn pack_rows(dst: &mut [i32], vis: &[u8], tir: &[u8]) => pack_rows_kernel
}

#[inline(always)]
fn pack_rows_kernel(dst: &mut [i32], vis: &[u8], tir: &[u8]) {
    for ((d, &a), &b) in dst.iter_mut().zip(vis).zip(tir) {
        *d = pack_u8(a, b);
    }
}

/// The low (VIS) half of a work word, sign-extended.
#[inline(always)]
pub(in crate::methods::adf) fn lo(w: i32) -> i32 {
    i32::from(w as i16)
}

/// The high (TIR) half of a work word.
#[inline(always)]
pub(in crate::methods::adf) fn hi(w: i32) -> i32 {
    w >> 16
}

/// A work word from two 16-bit values.
#[inline(always)]
pub(in crate::methods::adf) fn pack(lo: i32, hi: i32) -> i32 {
    (hi << 16) | (lo & 0xFFFF)
}

/// Half `b` of a word: 0 the low (VIS), 1 the high (TIR).
#[inline(always)]
pub(super) fn half(w: i32, b: usize) -> i32 {
    if b == 0 { lo(w) } else { hi(w) }
}
