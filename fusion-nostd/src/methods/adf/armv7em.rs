//! The Armv7E-M form of the covariance loop: both details of a pixel in one word
//! (`ssub16` of `[2⁷·I_VIS, 2⁷·I_IR]` and the packed base layers), then three dual 16-bit
//! multiply-accumulates into 64 bits — `smlald` (`D_VIS² + D_IR²`), `smlsld` (`D_VIS² −
//! D_IR²`), `smlaldx` (`2·D_VIS·D_IR`) — and the two sums (`sxtah`, `add … asr #16`); the
//! three squares follow exactly by halving. 12.5 instructions per pixel (LLVM's loop spilled:
//! ≈ 22.7). Also the flight output row ([`u8_pixels`]).

/// The sums `[ΣD_IR, ΣD_VIS]` and `[ΣD_IR², ΣD_IR·D_VIS, ΣD_VIS²]` of the first `2·⌊n/2⌋`
/// pixels (`n` the shortest slice, at most 2¹⁵), and that pixel count.
pub(super) fn moments_pairs(iv: &[u8], it: &[u8], a: &[i32]) -> (usize, [i32; 2], [i64; 3]) {
    let n = iv.len().min(it.len()).min(a.len()).min(super::COV_CHUNK);
    let pairs = n / 2;
    if pairs == 0 {
        return (0, [0; 2], [0; 3]);
    }
    let end = a.as_ptr().wrapping_add(2 * pairs);
    let (mut sum_lo, mut sum_hi, mut diff_lo, mut diff_hi, mut x_lo, mut x_hi) =
        (0u32, 0u32, 0u32, 0u32, 0u32, 0u32);
    let (mut s_ir, mut s_vis) = (0i32, 0i32);
    // SAFETY: pass k reads iv[2k], iv[2k + 1], it[2k], it[2k + 1], a[2k], a[2k + 1] for
    // k < pairs, all inside the slices (n ≤ each length); the loop runs while the `a`
    // pointer has not reached `end` (pairs ≥ 1 passes). No memory is written but the pushed
    // r6, r7 and lr (the end pointer, read back at [sp, #8]), popped again; every other
    // register written is declared.
    // |D| < 2¹⁵ (both halves of a packed state are in 0..=32767 and 2⁷·I ≤ 32640), so
    // `ssub16` is exact; over ≤ 2¹⁵ pixels the 32-bit sums stay below 2³⁰ and the 64-bit
    // ones below 2⁴⁶.
    unsafe {
        core::arch::asm!(
            "push {{r6, r7, lr}}",
            "2:",
            "ldr r6, [r0], #4",
            "ldrb lr, [r1], #1",
            "ldrb r7, [r2], #1",
            "orr lr, lr, r7, lsl #16",
            "lsl lr, lr, #7",
            "ssub16 lr, lr, r6",      // [D_VIS, D_IR]
            "smlald r3, r4, lr, lr",
            "smlsld r5, r8, lr, lr",
            "smlaldx r9, r10, lr, lr",
            "sxtah r12, r12, lr",
            "add r11, r11, lr, asr #16",
            "ldr r6, [r0], #4",
            "ldrb lr, [r1], #1",
            "ldrb r7, [r2], #1",
            "orr lr, lr, r7, lsl #16",
            "lsl lr, lr, #7",
            "ssub16 lr, lr, r6",
            "smlald r3, r4, lr, lr",
            "smlsld r5, r8, lr, lr",
            "smlaldx r9, r10, lr, lr",
            "sxtah r12, r12, lr",
            "add r11, r11, lr, asr #16",
            "ldr r7, [sp, #8]",
            "cmp r0, r7",
            "bne 2b",
            "pop {{r6, r7, lr}}",
            inout("r0") a.as_ptr() => _,
            inout("r1") iv.as_ptr() => _,
            inout("r2") it.as_ptr() => _,
            inout("r3") sum_lo,
            inout("r4") sum_hi,
            inout("r5") diff_lo,
            inout("r8") diff_hi,
            inout("r9") x_lo,
            inout("r10") x_hi,
            inout("r11") s_ir,
            inout("r12") s_vis,
            inout("lr") end => _,
        );
    }
    let wide = |lo: u32, hi: u32| (i64::from(hi as i32) << 32) | i64::from(lo);
    let (sum, diff, cross) = (wide(sum_lo, sum_hi), wide(diff_lo, diff_hi), wide(x_lo, x_hi));
    (2 * pairs, [s_ir, s_vis], [(sum - diff) / 2, cross / 2, (sum + diff) / 2])
}

/// [`super::fused32`] and the 8-bit cast of every pixel of `out` (the shortest slice),
/// in one pass: `ssub16` for both details, `sxtah`/`add` for `A_IR + A_VIS + 2·D_VIS`, one
/// `smlal` for `p_IR·(D_IR − D_VIS) + 2²⁰`, the cast as `usat #8` (whose sticky Q flag is
/// the row's saturation: it saturates exactly when `raw_saturates`). Returns the pixels
/// done and whether one saturated. 24 instructions per pixel (LLVM's: ≈ 28).
pub(super) fn u8_pixels(p: i32, iv: &[u8], it: &[u8], a: &[i32], out: &mut [u8]) -> (usize, bool) {
    let n = iv.len().min(it.len()).min(a.len()).min(out.len());
    if n == 0 {
        return (0, false);
    }
    let end = a.as_ptr().wrapping_add(n);
    let q: u32;
    // SAFETY: pass k reads iv[k], it[k], a[k] and writes out[k] for k < n, all inside the
    // slices (n ≤ each length); the loop runs while the `a` pointer has not reached `end`
    // (n ≥ 1 passes). r6, r7 and lr (the end pointer, read back at [sp, #8]) are pushed and
    // popped; every other register written is declared. The Q flag is cleared first and
    // read last (flags are not preserved).
    unsafe {
        core::arch::asm!(
            "push {{r6, r7, lr}}",
            "mov r6, #0",
            "msr APSR_nzcvq, r6",         // clear Q
            "2:",
            "ldr r5, [r0], #4",           // packed base layers
            "ldrb r6, [r1], #1",
            "ldrb r7, [r2], #1",
            "orr r6, r6, r7, lsl #16",
            "lsl r6, r6, #7",
            "ssub16 r6, r6, r5",          // [D_VIS, D_IR]
            "sxth r7, r6",                // D_VIS
            "sxtah r8, r7, r5",           // D_VIS + A_VIS
            "add r8, r8, r5, asr #16",    // + A_IR
            "add r8, r8, r7",             // + D_VIS
            "rsb r7, r7, r6, asr #16",    // D_IR − D_VIS
            "mov r9, #0x100000",
            "mov r10, #0",
            "smlal r9, r10, r4, r7",      // p·(D_IR − D_VIS) + 2²⁰
            "lsl r10, r10, #11",
            "orr r10, r10, r9, lsr #21",  // ⌊…/2²¹⌋
            "add r10, r10, r8, lsl #8",   // raw (Q16)
            "asr r10, r10, #1",
            "add r10, r10, #16384",
            "usat r10, #8, r10, asr #15", // the cast; Q on saturation
            "strb r10, [r3], #1",
            "ldr r7, [sp, #8]",
            "cmp r0, r7",
            "bne 2b",
            "mrs r11, APSR",
            "pop {{r6, r7, lr}}",
            inout("r0") a.as_ptr() => _,
            inout("r1") iv.as_ptr() => _,
            inout("r2") it.as_ptr() => _,
            inout("r3") out.as_mut_ptr() => _,
            in("r4") p,
            out("r5") _,
            out("r8") _,
            out("r9") _,
            out("r10") _,
            out("r11") q,
            inout("lr") end => _,
        );
    }
    (n, q & (1 << 27) != 0)
}
