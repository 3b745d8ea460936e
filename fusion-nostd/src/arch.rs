//! The Armv7E-M DSP instructions (Cortex-M4/M7) that the portable kernels use inline, one short
//! register-only sequence each, as safe functions. Compiled only where `build.rs` sets
//! `cfg(fusion_arm_dsp)`. The kernels whose whole loop is assembly keep it beside their
//! portable form, in their module's `armv7em.rs` (like the `avx2.rs` and `avx512.rs` forms of the
//! x86-64 hosts).

/// `acc + x.lo·y.lo + x.hi·y.hi` on the signed 16-bit halves (`smlad`). The caller keeps the
/// sum inside `i32` (the sticky Q flag, which nothing reads, is set otherwise).
#[inline(always)]
pub(crate) fn smlad(x: i32, y: i32, acc: i32) -> i32 {
    let out: i32;
    // SAFETY: one register-only instruction (no memory, no stack; the flags but Q untouched).
    unsafe {
        core::arch::asm!(
            "smlad {o}, {x}, {y}, {a}",
            o = out(reg) out,
            x = in(reg) x,
            y = in(reg) y,
            a = in(reg) acc,
            options(pure, nomem, nostack, preserves_flags),
        );
    }
    out
}

/// Lane by lane (16-bit halves), `|r − l| + |g − bias|`: two `ssub16` and a `sel` for each
/// absolute difference (the `sel` reads the GE flags its `ssub16` set, so the seven
/// instructions stay one block), `uadd16` for the sum. Lanes do not carry into each other.
#[inline(always)]
pub(crate) fn lane_abs_sum(l: u32, r: u32, g: u32, bias: u32) -> u32 {
    let packed: u32;
    // SAFETY: register-only instructions (no memory, no stack); they set and read the APSR.GE
    // flags, which no other code relies on.
    unsafe {
        core::arch::asm!(
            "ssub16 {x}, {s2}, {s0}",
            "ssub16 {t}, {s0}, {s2}",
            "sel {x}, {t}, {x}",
            "ssub16 {y}, {gy}, {bias}",
            "ssub16 {t}, {bias}, {gy}",
            "sel {y}, {t}, {y}",
            "uadd16 {x}, {x}, {y}",
            x = out(reg) packed,
            y = out(reg) _,
            t = out(reg) _,
            s0 = in(reg) l,
            s2 = in(reg) r,
            gy = in(reg) g,
            bias = in(reg) bias,
            options(pure, nomem, nostack),
        );
    }
    packed
}
