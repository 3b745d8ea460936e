//! The Armv7E-M forms (Cortex-M4/M7, inline assembly) of IFEVIP's per-pixel loops: the
//! tabulated output rows (whole frame and strips) and the Bézier background's forward-difference
//! walk. Each gives the portable loop's bytes (checked against the host by `fusion budget`).

use super::{ADD_TABLE_LEN, GainTables};

impl GainTables {
    /// [`GainTables::row_in_place`] on the Cortex-M4/M7 in assembly, 17 instructions per pixel
    /// (LLVM unrolled the loop and spilled): the two table entries by `ldrd`, the 64-bit sum by
    /// `adds`/`adc`, `val >> 40` as the high word `asr #8` (the low word cannot carry into the
    /// floor), `usat #9` for the clamp to 0..=511, the saturation flag as the OR of the sums
    /// (bit 8 or 9). The same bytes as the portable loop. `None` when the rows differ in length.
    pub(super) fn row_in_place_arm(&self, out: &mut [u8], vis: &[u8], tir: &[u8]) -> Option<bool> {
        let w = out.len();
        if w == 0 || vis.len() != w || tir.len() != w {
            return None;
        }
        let end = out.as_mut_ptr().wrapping_add(w);
        let d_base = self.d_term.as_ptr().wrapping_add(255);
        let mut flag: u32 = 0;
        // SAFETY: pixel i reads out[i], vis[i], tir[i], r_term[R] (R ≤ 255 < 256) and
        // d_term[255 + IR − VIS] (0..=510 < 511); it writes out[i]; i < w, the length of every
        // slice (checked above), w ≥ 1. Every register written is declared.
        unsafe {
            core::arch::asm!(
                "2:",
                "ldrb r8, [r0]",
                "ldrb r9, [r1], #1",
                "ldrb r10, [r2], #1",
                "add r8, r4, r8, lsl #3",
                "sub r10, r10, r9",
                "add r10, r5, r10, lsl #3",
                "ldrd r11, r12, [r8]",
                "ldrd r8, r10, [r10]",
                "adds r11, r11, r8",
                "adc r12, r12, r10",
                "usat r12, #9, r12, asr #8",
                "add r12, r12, r9",
                "orr lr, lr, r12",
                "usat r12, #8, r12",
                "strb r12, [r0], #1",
                "cmp r0, r3",
                "bne 2b",
                inout("r0") out.as_mut_ptr() => _,
                inout("r1") vis.as_ptr() => _,
                inout("r2") tir.as_ptr() => _,
                in("r3") end,
                in("r4") self.r_term.as_ptr(),
                in("r5") d_base,
                out("r8") _,
                out("r9") _,
                out("r10") _,
                out("r11") _,
                out("r12") _,
                inout("lr") flag,
                options(nostack),
            );
        }
        Some(flag & 0x300 != 0)
    }
}

/// One row of the tabulated step 12 on the Cortex-M4/M7, in assembly (12 instructions per
/// pixel; LLVM's loop took ≈ 22): the table index `R·511 + IR − VIS` by one `mla` and a `sub`
/// from a base 255 entries in, `usat` for the clamp, and the saturation flag as the OR of
/// every sum (sums are below 512, so bit 8 is set exactly when one exceeded 255). The same
/// values as the portable loop. `None` when the rows are not all `w` long (the portable loop
/// then runs).
pub(super) fn output_row_arm(
    out: &mut [u8],
    vis: &[u8],
    tir: &[u8],
    r: &[i32],
    table: &[i32; ADD_TABLE_LEN],
) -> Option<bool> {
    let w = out.len();
    if w == 0 || vis.len() != w || tir.len() != w || r.len() < w {
        return None;
    }
    let end = out.as_mut_ptr().wrapping_add(w);
    let base = table.as_ptr().wrapping_add(255);
    let mut flag: u32 = 0;
    // SAFETY: pixel i reads vis[i], tir[i], the low byte of r[i] (little-endian) and
    // table[R·511 + IR − VIS + 255] with R, IR, VIS in 0..=255, i.e. inside 0..=130 815 <
    // ADD_TABLE_LEN; it writes out[i]; i < w, the length of every slice (checked above);
    // w ≥ 1. Every register written is declared.
    unsafe {
        core::arch::asm!(
            "2:",
            "ldrb r8, [r1], #1",
            "ldrb r9, [r2], #1",
            "ldrb r10, [r3], #4",
            "mla r10, r10, r5, r9",
            "sub r10, r10, r8",
            "ldr r10, [r4, r10, lsl #2]",
            "add r8, r8, r10",
            "orr r11, r11, r8",
            "usat r8, #8, r8",
            "strb r8, [r0], #1",
            "cmp r0, r12",
            "bne 2b",
            inout("r0") out.as_mut_ptr() => _,
            inout("r1") vis.as_ptr() => _,
            inout("r2") tir.as_ptr() => _,
            inout("r3") r.as_ptr() => _,
            in("r4") base,
            in("r5") 511u32,
            out("r8") _,
            out("r9") _,
            out("r10") _,
            inout("r11") flag,
            in("r12") end,
            options(nostack),
        );
    }
    Some(flag & 0x100 != 0)
}

/// The forward-difference walk of [`render`] on the Cortex-M4/M7 in assembly for a right shift
/// `sh` in `1..32` (leaves of side 16 to 256): `out[j] = low 32 bits of (v >> sh)` with `v`
/// the rounded numerator (`f + 2^(sh−1)`, carried in `v`), then `v += d1`, `d1 += d2`,
/// `d2 += d3`, all wrapping 64-bit additions — 12 instructions per pixel (LLVM's loop kept
/// the state on the stack: 30). The same values as `to_q` of the portable loop.
pub(super) fn step_row_arm(out: &mut [i32], [v, d1, d2, d3]: [i64; 4], sh: u32) {
    if out.is_empty() || !(1..32).contains(&sh) {
        return;
    }
    let end = out.as_mut_ptr_range().end;
    let lo = |x: i64| x as u32;
    let hi = |x: i64| (x >> 32) as u32;
    // SAFETY: writes out[0 .. len] (len ≥ 1; the loop stops at `end`); registers only
    // otherwise. r6/r7 are pushed and popped, every other register written is declared.
    unsafe {
        core::arch::asm!(
            "push {{r6, r7}}",
            "rsb r7, r5, #32",
            "2:",
            "lsr r6, r0, r5",
            "lsl r12, r1, r7",
            "orr r6, r6, r12",
            "str r6, [r10], #4",
            "adds r0, r0, r2",
            "adc r1, r1, r3",
            "adds r2, r2, r4",
            "adc r3, r3, lr",
            "adds r4, r4, r8",
            "adc lr, lr, r9",
            "cmp r10, r11",
            "bne 2b",
            "pop {{r6, r7}}",
            inout("r0") lo(v) => _,
            inout("r1") hi(v) => _,
            inout("r2") lo(d1) => _,
            inout("r3") hi(d1) => _,
            inout("r4") lo(d2) => _,
            inout("lr") hi(d2) => _,
            in("r8") lo(d3),
            in("r9") hi(d3),
            in("r5") sh,
            inout("r10") out.as_mut_ptr() => _,
            in("r11") end,
            out("r12") _,
        );
    }
}
