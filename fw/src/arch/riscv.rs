//! RV32IMAC (`riscv32imac-unknown-none-elf`, QEMU `virt -bios none`): a hand-written start
//! (stack, `.bss`, trap vector), the semihosting trap and the `minstret` counter.
//!
//! QEMU jumps to 0x8000_0000 in machine mode; `fw/riscv-virt.ld` puts `_start` there. With
//! `-icount shift=0,sleep=off`, `minstret` counts every retired guest instruction exactly.

/// Target name printed in the report.
pub const NAME: &str = "riscv";

core::arch::global_asm!(
    r#"
    .section .text.start, "ax"
    .global _start
_start:
    .option push
    .option norelax
    la gp, __global_pointer$
    .option pop
    la sp, _stack_start
    la t0, fw_trap_entry
    csrw mtvec, t0
    la t0, __sbss
    la t1, __ebss
1:  bgeu t0, t1, 2f
    sw zero, 0(t0)
    addi t0, t0, 4
    j 1b
2:  call fw_rust_main
3:  j 3b

    .section .text.fw_trap, "ax"
    .balign 4
fw_trap_entry:
    csrr a0, mcause
    csrr a1, mepc
    csrr a2, mtval
    la sp, _stack_start
    call fw_trap
4:  j 4b

    /* The three-instruction semihosting sequence must stay uncompressed and in one page. */
    .section .text.fw_semihost_call, "ax"
    .balign 16
    .global fw_semihost_call
fw_semihost_call:
    .option push
    .option norvc
    slli x0, x0, 0x1f
    ebreak
    srai x0, x0, 7
    .option pop
    ret
"#
);

unsafe extern "C" {
    fn fw_semihost_call(op: usize, arg: usize) -> usize;
}

/// One semihosting request: operation in `a0`, argument in `a1`, result in `a0`.
///
/// # Safety
/// `arg` must be what the operation expects (a pointer to a valid parameter block for most).
pub unsafe fn semihost_call(op: usize, arg: usize) -> usize {
    // SAFETY: forwarded from the caller.
    unsafe { fw_semihost_call(op, arg) }
}

/// `minstret`/`minstreth` as one 64-bit value (re-read when the high half ticked).
#[inline(always)]
pub fn instret() -> Option<u64> {
    loop {
        let (hi, lo, hi2): (u32, u32, u32);
        // SAFETY: machine-mode CSR reads.
        unsafe {
            core::arch::asm!(
                "csrr {0}, minstreth",
                "csrr {1}, minstret",
                "csrr {2}, minstreth",
                out(reg) hi,
                out(reg) lo,
                out(reg) hi2,
                options(nomem, nostack, preserves_flags)
            )
        };
        if hi == hi2 {
            return Some((u64::from(hi) << 32) | u64::from(lo));
        }
    }
}

/// The current stack pointer.
#[inline(always)]
pub fn sp() -> usize {
    let sp: usize;
    // SAFETY: reads a register.
    unsafe { core::arch::asm!("mv {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    sp
}

/// Executes an illegal instruction (trap with `mcause` 2).
pub fn undefined_instruction() {
    // SAFETY: raises an exception on purpose; the trap handler ends the emulation.
    unsafe { core::arch::asm!("unimp", options(nomem, nostack)) };
}

#[unsafe(no_mangle)]
extern "C" fn fw_rust_main() -> ! {
    crate::main()
}

#[unsafe(no_mangle)]
extern "C" fn fw_trap(mcause: usize, mepc: usize, mtval: usize) -> ! {
    let _ = mtval;
    crate::fault("trap", mepc, mcause)
}
