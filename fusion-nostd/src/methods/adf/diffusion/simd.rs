//! The row loop of the SIMD forms (AVX2, AVX-512, NEON), written once for any register width: [`Lanes`] is
//! what a form provides (its register type, its loads and stores, its 16-bit lane arithmetic
//! and its flux), [`row_blocks`] the loop over whole blocks of `Lanes::WORDS` pixels (both
//! bands per 32-bit word, so `2·WORDS` lanes of `i16`). `avx2.rs` (8 pixels), `avx512.rs`
//! (16 pixels) and `neon.rs` (4 pixels), each with the flux function's segments in registers,
//! each implement [`Lanes`] and call [`row_blocks`] from a function compiled for their
//! instruction set, where every method here is inlined.
//!
//! Every sum in the loop is one of the portable loop's (`update_band` and the north sums) in
//! saturating 16-bit lanes; no partial sum reaches 2¹⁵ (`MAX_FLUX`), so the lanes hold the
//! portable values exactly and the output bits are the portable loop's.

use super::pack::{hi, lo, pack};
use super::row::RowCarry;

/// One SIMD form of the row loop. A value of the implementing type exists only on a CPU that
/// has the form's instruction set (its constructor is compiled for that set), so its methods
/// may issue the set's instructions.
pub(super) trait Lanes {
    /// A register of `WORDS` words: `2·WORDS` lanes of `i16`.
    type V: Copy;
    /// Pixels per block.
    const WORDS: usize;
    /// All lanes 0.
    fn zero(&self) -> Self::V;
    /// Word `WORDS − 1` = `w`, every other word 0.
    fn top(&self, w: i32) -> Self::V;
    /// The first `WORDS` words of `s` (the callers pass at least `WORDS`; all 0 otherwise). A
    /// register, not an `Option` of one: LLVM builds an `Option` of a vector through the stack on
    /// AArch64.
    fn load(&self, s: &[i32]) -> Self::V;
    /// Stores to `s[at..at + WORDS]`, `None` (nothing written) past the end.
    fn store(&self, s: &mut [i32], at: usize, x: Self::V) -> Option<()>;
    /// Word `i` of `x`.
    fn word(&self, x: Self::V, i: usize) -> i32;
    /// The flux of every lane's difference (in `−32768..=32767`).
    fn flux(&self, d: Self::V) -> Self::V;
    /// The fluxes of `x[i] − c` (the AVX2 and NEON forms read their tables once per pair; the
    /// NEON form takes `|x − c|` and its sign from `x` and `c`).
    #[inline(always)]
    fn flux4(&self, x: [Self::V; 4], c: Self::V) -> [Self::V; 4] {
        x.map(|x| self.flux(self.sub(x, c)))
    }
    /// Lane-wise wrapping difference (exact for the states' differences, `|d| < 2¹⁵`).
    fn sub(&self, a: Self::V, b: Self::V) -> Self::V;
    /// Lane-wise saturating sum.
    fn adds(&self, a: Self::V, b: Self::V) -> Self::V;
    /// Lane-wise saturating difference.
    fn subs(&self, a: Self::V, b: Self::V) -> Self::V;
    /// Lane-wise `max(a, 0)`.
    fn max0(&self, a: Self::V) -> Self::V;
    /// `[prev[WORDS − K..], cur[..WORDS − K]]`: `cur` moved up by `K` words (`K` = 1 or 2),
    /// the vacated words from the top of `prev`.
    fn up<const K: usize>(&self, prev: Self::V, cur: Self::V) -> Self::V;
}

/// Runs the row loop of `Diffusion::row` on whole blocks of `L::WORDS` pixels from the start of
/// the row, updating `carry`; returns the pixels done. Inlined into each form's entry point
/// (compiled for its instruction set).
#[inline(always)]
pub(super) fn row_blocks<L: Lanes>(
    l: &L,
    p: &[i32],
    q: &[i32],
    north: &mut [i32],
    out: &mut [i32],
    carry: &mut RowCarry,
) -> usize {
    let n = L::WORDS;
    // On AArch64 every slice is cut to the blocks' reach once, so that the loop's bounds checks
    // fold into its condition (six instructions per block fewer on the Cortex-A53). Not on
    // x86-64: there the AVX2 loop ran 3.7 % fewer instructions with the cut but 8 % slower on
    // smooth frames and 4 % on noise (`row_loop_times`, BENCHMARKS.md).
    #[cfg(target_arch = "aarch64")]
    let (p, q, north, out) = {
        let len = out.len().min(p.len().saturating_sub(2)).min(q.len().saturating_sub(2));
        let len = len.min(north.len().saturating_sub(1));
        let (Some(p), Some(q), Some(north), Some(out)) =
            (p.get(..len + 2), q.get(..len + 2), north.get_mut(..len + 1), out.get_mut(..len))
        else {
            return 0;
        };
        (p, q, north, out)
    };
    // The top word holds the carried value; the other words (and `v_prev`) are 0, so that the
    // first block writes the unused `north[0]` exactly as the portable loop does.
    let mut h_prev = l.top(carry.h_prev);
    let mut v_prev = l.zero();
    let mut dr_prev = l.top(carry.dr_prev);
    let mut x = 0;
    while x + n <= out.len() {
        // The block's words: pixels x .. x + n with one padding word each side, and the north
        // sums of pixels x + 1 .. x + n + 1 (the padded row's indices).
        let (Some(ps), Some(qs), Some(ns)) =
            (p.get(x..x + n + 2), q.get(x..x + n + 2), north.get(x + 1..x + n + 1))
        else {
            break;
        };
        let (pc, pr) = (l.load(from(ps, 1)), l.load(from(ps, 2)));
        let (ql, qc, qr) = (l.load(qs), l.load(from(qs, 1)), l.load(from(qs, 2)));
        let n_here = l.load(ns);
        let [h, v, dr, dl] = l.flux4([pr, qc, qr, ql], pc);
        let west = l.up::<1>(h_prev, h);
        let t = l.subs(l.adds(h, v), west);
        let s = l.subs(l.adds(dr, dl), n_here);
        let step = l.adds(l.adds(t, t), s);
        let next = l.max0(l.adds(pc, step));
        // The north sums of the row below at x − 1 .. x + n − 2 (pixel indices 0-based):
        // 2·v(k) + dr(k − 1) + dl(k + 1).
        let v_up = l.up::<1>(v_prev, v);
        let dr_up = l.up::<2>(dr_prev, dr);
        let below = l.adds(l.adds(l.adds(v_up, v_up), dr_up), dl);
        if l.store(out, x, next).is_none() || l.store(north, x, below).is_none() {
            break;
        }
        (h_prev, v_prev, dr_prev) = (h, v, dr);
        x += n;
    }
    if x > 0 {
        // The last whole block's fluxes (what the next block would take as `*_prev`).
        let (v_last, dr_before) = (l.word(v_prev, n - 1), l.word(dr_prev, n - 2));
        let partial = |f: fn(i32) -> i32| 2 * f(v_last) + f(dr_before);
        *carry = RowCarry {
            h_prev: l.word(h_prev, n - 1),
            dr_prev: l.word(dr_prev, n - 1),
            partial: pack(partial(lo), partial(hi)),
        };
    }
    x
}

/// `s` from word `k` on (empty past the end).
#[inline(always)]
fn from(s: &[i32], k: usize) -> &[i32] {
    s.get(k..).unwrap_or(&[])
}
