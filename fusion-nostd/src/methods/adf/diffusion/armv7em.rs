//! The Armv7E-M copy of the row loop (Cortex-M4/M7), both bands per word, two pixels per
//! pass: one `ssub16` for both differences, the two table reads (`sxth`/`asr` index, `ldrsh`),
//! `pkhbt` to pack the fluxes, the sums as 16-bit halves (`qadd16`, `qsub16`: never clipping,
//! see `update_band`), then `qadd16` and `usat16 #15` for the next state. The same values as the
//! portable loop, so the same bits (the firmware's bit-exactness jobs compare the target's
//! frames with the host's). 42.5 instructions per pixel of both bands.

use super::flux::{TABLE_CENTRE, TABLE_ENTRIES};
use super::row::RowCarry;

/// One pixel of the row loop, both bands: `h_prev`, `partial` name the registers the
/// carried values come in, `h`, `next` the ones the new values go to (a second pixel swaps
/// them, so the loop needs no moves); `dr_prev` comes and goes in r9. Registers: r0 `p`
/// (at pc), r1 `q` (at ql), r2 `north` (at the previous pixel's entry), r3 `out`, r4 the
/// table's centre; r5, r11 (pc), r12, lr scratch.
macro_rules! pixel {
    ($h_prev:literal, $h:literal, $partial:literal, $next:literal) => {
        concat!(
            "ldrd r11, r12, [r0], #4\n", // pc, pr
            "ssub16 r12, r12, r11\n",    // pr − pc, both bands
            "sxth lr, r12\n",
            "ldrsh lr, [r4, lr, lsl #1]\n",
            "asr r12, r12, #16\n",
            "ldrsh r12, [r4, r12, lsl #1]\n",
            "pkhbt ",
            $h,
            ", lr, r12, lsl #16\n",     // h
            "ldrd r5, r12, [r1, #4]\n", // qc, qr
            "ssub16 r5, r5, r11\n",
            "sxth lr, r5\n",
            "ldrsh lr, [r4, lr, lsl #1]\n",
            "asr r5, r5, #16\n",
            "ldrsh r5, [r4, r5, lsl #1]\n",
            "pkhbt r5, lr, r5, lsl #16\n", // v
            "qadd16 lr, ",
            $h,
            ", r5\n", // h + v
            "qsub16 lr, lr, ",
            $h_prev,
            "\n",                  // − h_prev
            "qadd16 lr, lr, lr\n", // t2 = 2·(h + v − h_prev)
            "qadd16 ",
            $next,
            ", r5, r5\n",
            "qadd16 ",
            $next,
            ", ",
            $next,
            ", r9\n",             // the next partial: 2·v + dr_prev
            "ldr r5, [r1], #4\n", // ql
            "ssub16 r5, r5, r11\n",
            "sxth r9, r5\n",
            "ldrsh r9, [r4, r9, lsl #1]\n",
            "asr r5, r5, #16\n",
            "ldrsh r5, [r4, r5, lsl #1]\n",
            "pkhbt r5, r9, r5, lsl #16\n", // dl
            "qadd16 ",
            $partial,
            ", ",
            $partial,
            ", r5\n", // north sums of q's pixel i − 1
            "str ",
            $partial,
            ", [r2], #4\n",
            "ssub16 r9, r12, r11\n", // qr − pc
            "sxth r12, r9\n",
            "ldrsh r12, [r4, r12, lsl #1]\n",
            "asr r9, r9, #16\n",
            "ldrsh r9, [r4, r9, lsl #1]\n",
            "pkhbt r9, r12, r9, lsl #16\n", // dr (the next dr_prev)
            "qadd16 r12, r9, r5\n",         // dr + dl
            "ldr r5, [r2]\n",               // this pixel's north sums
            "qsub16 r12, r12, r5\n",        // s = dr + dl − north
            "qadd16 lr, lr, r12\n",         // the step t2 + s
            "qadd16 lr, r11, lr\n",
            "usat16 lr, #15, lr\n",
            "str lr, [r3], #4\n",
        )
    };
}

/// Runs the row loop of `Diffusion::row` on the pixels of `out` two at a time with the
/// flux `table`, updating `carry`; returns the pixels done (an even number; 0 when a slice
/// is too short or the row has one pixel, and the portable loop runs).
pub(super) fn row_pixels(
    table: &[i16],
    p: &[i32],
    q: &[i32],
    north: &mut [i32],
    out: &mut [i32],
    carry: &mut RowCarry,
) -> usize {
    let w = out.len();
    let pairs = w / 2;
    if pairs == 0 || p.len() < w + 2 || q.len() < w + 2 || north.len() < w + 2 || table.len() < TABLE_ENTRIES
    {
        return 0;
    }
    let centre = table.as_ptr().wrapping_add(TABLE_CENTRE);
    let end = out.as_mut_ptr().wrapping_add(2 * pairs);
    let RowCarry { mut h_prev, mut dr_prev, mut partial } = *carry;
    // SAFETY: pixel i (0 ≤ i < 2·pairs ≤ w) reads p[i + 1], p[i + 2], q[i], q[i + 1],
    // q[i + 2], north[i + 1], writes north[i] and out[i]: all inside the slices, whose
    // lengths are checked above (p, q, north ≥ w + 2); `ldrd` reads an `i32` slice, so its
    // address is word-aligned. The table reads are at `centre + 2·k` with k the
    // sign-extended 16-bit result of `ssub16`, so k in −32768..=32767 and every read lies
    // inside the 65 536 entries whatever the rows hold (the pipeline's states are in
    // 0..=32767 anyway: inputs `u8 << 7`, pads states or 0, outputs `usat16 #15`). The loop
    // runs while the output
    // pointer has not reached `end` (pairs ≥ 1 passes of two pixels). r6, r7 and the end
    // pointer are pushed and popped around the loop; every other register written is
    // declared.
    unsafe {
        core::arch::asm!(
            // r6 and r7 (LLVM's base and frame pointers, not available as operands) are
            // saved; they carry the second pixel's partial sums and the first pixel's east
            // flux. The end pointer lives on the stack, at [sp, #8].
            "push {{r6, r7, r11}}",
            "2:",
            pixel!("r8", "r7", "r10", "r6"),
            pixel!("r7", "r8", "r6", "r10"),
            "ldr r12, [sp, #8]",
            "cmp r3, r12",
            "bne 2b",
            "pop {{r6, r7, r11}}",
            inout("r0") p.as_ptr().wrapping_add(1) => _,
            inout("r1") q.as_ptr() => _,
            inout("r2") north.as_mut_ptr() => _,
            inout("r3") out.as_mut_ptr() => _,
            in("r4") centre,
            inout("r8") h_prev,
            inout("r9") dr_prev,
            inout("r10") partial,
            inout("r11") end => _,
            out("r5") _,
            out("r12") _,
            out("lr") _,
        );
    }
    *carry = RowCarry { h_prev, dr_prev, partial };
    2 * pairs
}
