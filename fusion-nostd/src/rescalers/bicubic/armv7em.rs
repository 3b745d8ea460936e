//! The Armv7E-M form (Cortex-M4/M7, inline assembly) of the bicubic 2× vertical pass.

use super::HROW;

/// [`super::vertical`] on the Cortex-M4/M7, two outputs per loop pass in assembly (14 instructions
/// per output: four `ldr` and `mul`/`mla`, `ubfx` + two `add` for the round-half-to-even,
/// `usat … asr #S`, `strb`; LLVM's loop reloaded the row pointers and took ≈ 20). The same
/// `i32` arithmetic as [`super::round_even_sat`] (`|N| < 2²⁵`, no overflow). Returns the outputs
/// done (an even count; the portable loop finishes the rest).
pub(super) fn vertical_arm<const S: u32>(out: &mut [u8], rows: [&[i32; HROW]; 4], w: [i32; 4]) -> usize {
    let n = out.len().min(HROW) & !1;
    if n == 0 {
        return 0;
    }
    let [r0, r1, r2, r3] = rows;
    let [w0, w1, w2, w3] = w;
    let end = out.as_mut_ptr().wrapping_add(n);
    // One output: four rows times their weights, round half to even, clamp, store. The loop
    // body is two of them.
    macro_rules! two_outputs {
        ($($line:literal),+) => {
            core::arch::asm!(
                "push {{r6, r7}}",
                "movw r6, #{half}",
                "2:",
                $($line,)+
                $($line,)+
                "cmp r4, r5",
                "bne 2b",
                "pop {{r6, r7}}",
                s = const S,
                half = const (1u32 << (S - 1)) - 1,
                inout("r0") r0.as_ptr() => _,
                inout("r1") r1.as_ptr() => _,
                inout("r2") r2.as_ptr() => _,
                inout("r3") r3.as_ptr() => _,
                inout("r4") out.as_mut_ptr() => _,
                in("r5") end,
                in("r8") w0,
                in("r9") w1,
                in("r10") w2,
                in("r11") w3,
                out("r12") _,
                out("lr") _,
            )
        };
    }
    // SAFETY: output i < n ≤ HROW reads element i of each of the four HROW-long rows and
    // writes out[i] (n ≤ out.len()); n ≥ 2 and even, so the loop ends at `end`. r6/r7 are
    // pushed and popped, every other register written is declared.
    unsafe {
        two_outputs!(
            "ldr lr, [r0], #4",
            "mul r12, lr, r8",
            "ldr lr, [r1], #4",
            "mla r12, lr, r9, r12",
            "ldr lr, [r2], #4",
            "mla r12, lr, r10, r12",
            "ldr lr, [r3], #4",
            "mla r12, lr, r11, r12",
            "ubfx r7, r12, #{s}, #1",
            "add r12, r12, r7",
            "add r12, r12, r6",
            "usat r12, #8, r12, asr #{s}",
            "strb r12, [r4], #1"
        );
    }
    n
}
