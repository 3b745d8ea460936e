//! The 8-tap column pass on the Cortex-M4/M7 for the two forms IFEVIP runs at every frame size
//! — `u8` frame → [`Output::U8`] (the IR onto the quadtree grid) and `i32` plane →
//! [`Output::Same`] (the background back onto the frame) — in assembly, two columns per loop
//! pass: the weight read once for both, `ldrb`/`ldr` and `smlal` per tap and column, the
//! rounding in 32 bits (LLVM's schedule reloaded the eight row pointers and the weights for
//! every output: ≈ 49 instructions per output; this is ≈ 31). The same exact `i64` sums and
//! the same rounding as [`cols_n`]: `u8` sources keep `|Σ| < 2³⁹`, so the rounded sum fits
//! `i32` and `usat #8` is the clamp; `Same` keeps the low 32 bits, as `finish` does.

use super::{Taps, finish, row_n};
use crate::{FrameMut, FrameRef};

/// `pairs` pairs of outputs of one row: tap `t` of output column `x` reads the sample at
/// `src + t·step + x·size_of::<T>()` with weight `ws[t]`.
pub(super) type Kernel<T> = unsafe fn(src: *const T, step: usize, ws: &[i32; 8], out: *mut i32, pairs: usize);

/// The two-column loop: `$load` reads tap `t`'s two samples (at `r5`) into r9 and r10,
/// `$advance` is the byte step to the next column pair, `$clamp` the optional `usat`.
/// r6/r7 are pushed and popped, every other register written is declared.
macro_rules! cols8_asm {
    ($src:expr, $step:expr, $ws:expr, $out:expr, $pairs:expr,
     [$($load:literal),+], $advance:literal, [$($clamp:literal),*]) => {
        core::arch::asm!(
            "push {{r6, r7}}",
            "2:",
            "mov r5, r0",
            "ldr r8, [r2]",
            $($load,)+
            "smull r11, r12, r9, r8",
            "smull lr, r6, r10, r8",
            "add r5, r5, r1", "ldr r8, [r2, #4]", $($load,)+
            "smlal r11, r12, r9, r8", "smlal lr, r6, r10, r8",
            "add r5, r5, r1", "ldr r8, [r2, #8]", $($load,)+
            "smlal r11, r12, r9, r8", "smlal lr, r6, r10, r8",
            "add r5, r5, r1", "ldr r8, [r2, #12]", $($load,)+
            "smlal r11, r12, r9, r8", "smlal lr, r6, r10, r8",
            "add r5, r5, r1", "ldr r8, [r2, #16]", $($load,)+
            "smlal r11, r12, r9, r8", "smlal lr, r6, r10, r8",
            "add r5, r5, r1", "ldr r8, [r2, #20]", $($load,)+
            "smlal r11, r12, r9, r8", "smlal lr, r6, r10, r8",
            "add r5, r5, r1", "ldr r8, [r2, #24]", $($load,)+
            "smlal r11, r12, r9, r8", "smlal lr, r6, r10, r8",
            "add r5, r5, r1", "ldr r8, [r2, #28]", $($load,)+
            "smlal r11, r12, r9, r8", "smlal lr, r6, r10, r8",
            // The low 32 bits of (Σ + 2²⁹) >> 30 per column, then the optional clamp.
            "adds r11, r11, #0x20000000",
            "adc r12, r12, #0",
            "lsr r11, r11, #30",
            "orr r11, r11, r12, lsl #2",
            $(concat!($clamp, " r11, #8, r11"),)*
            "adds lr, lr, #0x20000000",
            "adc r6, r6, #0",
            "lsr lr, lr, #30",
            "orr lr, lr, r6, lsl #2",
            $(concat!($clamp, " lr, #8, lr"),)*
            "strd r11, lr, [r3], #8",
            concat!("add r0, r0, #", $advance),
            "subs r4, r4, #1",
            "bne 2b",
            "pop {{r6, r7}}",
            inout("r0") $src => _,
            in("r1") $step,
            in("r2") $ws.as_ptr(),
            inout("r3") $out => _,
            inout("r4") $pairs => _,
            out("r5") _,
            out("r8") _,
            out("r9") _,
            out("r10") _,
            out("r11") _,
            out("r12") _,
            out("lr") _,
        )
    };
}

/// `u8` samples, [`super::Output::U8`].
///
/// # Safety
/// For every `t < 8` and `x < 2·pairs` the sample address lies in one readable row, and
/// `out` has `2·pairs` writable, word-aligned `i32`; `pairs ≥ 1`.
pub(super) unsafe fn u8_to_u8(src: *const u8, step: usize, ws: &[i32; 8], out: *mut i32, pairs: usize) {
    // SAFETY: the caller's contract.
    unsafe { cols8_asm!(src, step, ws, out, pairs, ["ldrb r9, [r5]", "ldrb r10, [r5, #1]"], 2, ["usat"]) }
}

/// `i32` samples, [`super::Output::Same`] (the low 32 bits of the rounded sum).
///
/// # Safety
/// As [`u8_to_u8`], with `i32` samples.
pub(super) unsafe fn i32_to_same(src: *const i32, step: usize, ws: &[i32; 8], out: *mut i32, pairs: usize) {
    // SAFETY: the caller's contract.
    unsafe { cols8_asm!(src, step, ws, out, pairs, ["ldrd r9, r10, [r5]"], 8, []) }
}

/// The 8-tap row pass of an `i32` plane, one output per loop pass in assembly: the table
/// row's start and weights read in place, four `ldrd` sample pairs, four `ldrd` weight
/// pairs, eight `smull`/`smlal`, the low 32 bits of the rounded sum as `finish` keeps them
/// for [`super::Output::Same`] (`CLAMP` false), or that value through `usat #8` for
/// [`super::Output::U8`] (`CLAMP` true; equal to `finish` when the rounded sum fits `i32`,
/// which the callers guarantee) — ≈ 26 instructions per output where the Rust loop around
/// [`dot8_arm`] took ≈ 36.
///
/// # Safety
/// `table` holds `outputs` rows of 10 words `[start, count, w₀ … w₇]`, each with
/// `0 ≤ start` and `start + 8 ≤` the length of the row at `src`; `out` has `outputs`
/// writable `i32`; `outputs ≥ 1`.
unsafe fn row8<const CLAMP: bool>(src: *const i32, table: *const i32, out: *mut i32, outputs: usize) {
    macro_rules! row8_asm {
        ($($clamp:literal)?) => {
            // SAFETY: the caller's contract; every register written is declared.
            unsafe {
                core::arch::asm!(
                    "2:",
                    "ldr r5, [r1]",
                    "add r5, r0, r5, lsl #2",
                    "ldrd r8, r9, [r5]",
                    "ldrd r10, r11, [r1, #8]",
                    "smull r12, lr, r8, r10",
                    "smlal r12, lr, r9, r11",
                    "ldrd r8, r9, [r5, #8]",
                    "ldrd r10, r11, [r1, #16]",
                    "smlal r12, lr, r8, r10",
                    "smlal r12, lr, r9, r11",
                    "ldrd r8, r9, [r5, #16]",
                    "ldrd r10, r11, [r1, #24]",
                    "smlal r12, lr, r8, r10",
                    "smlal r12, lr, r9, r11",
                    "ldrd r8, r9, [r5, #24]",
                    "ldrd r10, r11, [r1, #32]",
                    "smlal r12, lr, r8, r10",
                    "smlal r12, lr, r9, r11",
                    "adds r12, r12, #0x20000000",
                    "adc lr, lr, #0",
                    "lsr r12, r12, #30",
                    "orr r12, r12, lr, lsl #2",
                    $($clamp,)?
                    "str r12, [r2], #4",
                    "add r1, r1, #40",
                    "subs r3, r3, #1",
                    "bne 2b",
                    in("r0") src,
                    inout("r1") table => _,
                    inout("r2") out => _,
                    inout("r3") outputs => _,
                    out("r5") _,
                    out("r8") _,
                    out("r9") _,
                    out("r10") _,
                    out("r11") _,
                    out("r12") _,
                    out("lr") _,
                    options(nostack),
                );
            }
        };
    }
    if CLAMP {
        row8_asm!("usat r12, #8, r12");
    } else {
        row8_asm!();
    }
}

/// The row pass with [`row8`] when every table row's eight samples lie inside the source
/// rows; returns false (nothing written) otherwise. `CLAMP` ([`super::Output::U8`]) only
/// for sources in `0..=255` (then `|Σ| < 2³⁹` and the rounded sum fits `i32`).
pub(super) fn rows8<const CLAMP: bool>(
    src: FrameRef<'_, i32>,
    taps: &Taps<'_>,
    mut dst: FrameMut<'_, i32>,
) -> bool {
    let (sw, w) = (src.width(), dst.width());
    let rows = taps.table.chunks_exact(10);
    let inside = taps.stride == 10
        && rows.len() >= w
        && rows.take(w).all(|r| r.first().is_some_and(|&s| s >= 0 && s as usize + 8 <= sw));
    if w == 0 || !inside || dst.height() != src.height() {
        return false;
    }
    for (d, s) in dst.rows_mut().zip(src.rows()) {
        // Always true: a view's rows are exactly its width long.
        if d.len() >= w && s.len() >= sw {
            // SAFETY: the table has ≥ w rows of 10 words, each with 0 ≤ start and
            // start + 8 ≤ sw ≤ the length of `s` (checked above); `d` holds ≥ w `i32`;
            // w ≥ 1.
            unsafe { row8::<CLAMP>(s.as_ptr(), taps.table.as_ptr(), d.as_mut_ptr(), w) };
        }
    }
    true
}

/// The column pass with `kernel` on every output row whose eight source rows are evenly
/// spaced in memory and at least as wide as `dst` (every row of a frame view); the odd
/// last column, and any row that is not, by the portable sum.
pub(super) fn cols8<T: Copy + Into<i64>, const U8: bool>(
    src: FrameRef<'_, T>,
    taps: &Taps<'_>,
    mut dst: FrameMut<'_, i32>,
    kernel: Kernel<T>,
) {
    let w = dst.width();
    for (d, row) in dst.rows_mut().zip(taps.table.chunks_exact(taps.stride.max(1))) {
        let Some((start, ws)) = row_n::<8>(row) else {
            d.fill(0);
            continue;
        };
        let rows: [&[T]; 8] =
            core::array::from_fn(|t| if start + t < src.height() { src.row(start + t) } else { &[] });
        let [first, second, ..] = rows;
        let base = first.as_ptr() as usize;
        let step = (second.as_ptr() as usize).wrapping_sub(base);
        let even = rows
            .iter()
            .enumerate()
            .all(|(t, r)| r.len() >= w && r.as_ptr() as usize == base.wrapping_add(t.wrapping_mul(step)));
        let pairs = if even && d.len() >= w { w / 2 } else { 0 };
        if pairs > 0 {
            // SAFETY: output column x < 2·pairs ≤ w of tap t reads `rows[t][x]` (every row
            // has ≥ w samples and starts at base + t·step, checked above); `d` holds ≥ w
            // word-aligned `i32`.
            unsafe { kernel(first.as_ptr(), step, ws, d.as_mut_ptr(), pairs) };
        }
        for (x, o) in d.iter_mut().enumerate().skip(2 * pairs) {
            let acc = rows
                .iter()
                .zip(ws)
                .fold(0i64, |acc, (r, &wt)| acc + r.get(x).map_or(0, |&v| v.into()) * i64::from(wt));
            *o = finish::<U8>(acc);
        }
    }
}

/// The 8-tap dot product of `i32` samples on the Cortex-M4/M7: four `ldrd` pairs and eight
/// `smull`/`smlal` (LLVM's schedule of the portable `dot` spills to the stack). The same
/// exact `i64` sum.
#[inline(always)]
pub(super) fn dot8_arm(seg: &[i32; 8], ws: &[i32; 8]) -> i64 {
    let (lo, hi): (u32, u32);
    // SAFETY: reads the 32 bytes of each array (word-aligned `i32` arrays, as `ldrd` needs on
    // the Cortex-M); registers only otherwise, no stack, flags untouched.
    unsafe {
        core::arch::asm!(
            "ldrd {a}, {b}, [{s}]",
            "ldrd {c}, {d}, [{w}]",
            "smull {lo}, {hi}, {a}, {c}",
            "smlal {lo}, {hi}, {b}, {d}",
            "ldrd {a}, {b}, [{s}, #8]",
            "ldrd {c}, {d}, [{w}, #8]",
            "smlal {lo}, {hi}, {a}, {c}",
            "smlal {lo}, {hi}, {b}, {d}",
            "ldrd {a}, {b}, [{s}, #16]",
            "ldrd {c}, {d}, [{w}, #16]",
            "smlal {lo}, {hi}, {a}, {c}",
            "smlal {lo}, {hi}, {b}, {d}",
            "ldrd {a}, {b}, [{s}, #24]",
            "ldrd {c}, {d}, [{w}, #24]",
            "smlal {lo}, {hi}, {a}, {c}",
            "smlal {lo}, {hi}, {b}, {d}",
            s = in(reg) seg.as_ptr(),
            w = in(reg) ws.as_ptr(),
            a = out(reg) _,
            b = out(reg) _,
            c = out(reg) _,
            d = out(reg) _,
            lo = out(reg) lo,
            hi = out(reg) hi,
            options(pure, readonly, nostack, preserves_flags),
        );
    }
    ((u64::from(hi) << 32) | u64::from(lo)) as i64
}
