//! Cortex-A53 (`aarch64-unknown-none`, QEMU `virt -cpu cortex-a53`): a hand-written start at
//! EL1 (FP/SIMD on, an identity map with the RAM as normal cacheable memory, `.bss`, the
//! exception vectors), the semihosting trap and fault handling. Instructions are counted outside
//! the guest by the TCG plugin `fw/plugin/insn_count.c`, as on the Cortex-M7, so [`instret`] has
//! nothing to read here.
//!
//! QEMU loads the ELF image and starts it at `_start` in EL1 with the MMU off. With the MMU off
//! every data access is to Device memory, where an unaligned access faults; the kernels load
//! unaligned words and vectors, so the start-up maps the first 4 GiB with 1 GiB blocks first:
//! `0..1 GiB` as Device (the `virt` board's peripherals; never executable: PXN and UXN),
//! `1..2 GiB` (the RAM at 0x4000_0000) as normal write-back memory (table `fw_page_table`,
//! `MAIR_EL1` attribute 1); the TLB is invalidated before the MMU is turned on.

/// Target name printed in the report.
pub const NAME: &str = "a53";

core::arch::global_asm!(
    r#"
    .section .text.start, "ax"
    .global _start
_start:
    mov x0, #(3 << 20)
    msr cpacr_el1, x0
    isb
    ldr x0, =_stack_start
    mov sp, x0
    ldr x0, =fw_vectors
    msr vbar_el1, x0
    ldr x0, =0xff00
    msr mair_el1, x0
    ldr x0, =(25 | (1 << 8) | (1 << 10) | (3 << 12) | (1 << 23))
    msr tcr_el1, x0
    ldr x0, =fw_page_table
    msr ttbr0_el1, x0
    tlbi vmalle1
    dsb ish
    isb
    mrs x0, sctlr_el1
    orr x0, x0, #1
    orr x0, x0, #(1 << 2)
    orr x0, x0, #(1 << 12)
    bic x0, x0, #(1 << 1)
    msr sctlr_el1, x0
    isb
    ldr x0, =__sbss
    ldr x1, =__ebss
1:  cmp x0, x1
    b.hs 2f
    str xzr, [x0], #8
    b 1b
2:  bl fw_rust_main
3:  b 3b

    .section .text.fw_trap, "ax"
fw_trap_entry:
    mrs x0, esr_el1
    mrs x1, elr_el1
    mrs x2, far_el1
    ldr x3, =_stack_start
    mov sp, x3
    bl fw_trap
4:  b 4b

    .section .text.fw_vectors, "ax"
    .balign 2048
fw_vectors:
    .rept 16
    .balign 128
    b fw_trap_entry
    .endr

    .section .data.fw_page_table, "aw"
    .balign 4096
fw_page_table:
    .quad 0x00000000 | (3 << 53) | (1 << 10) | (0 << 2) | 1
    .quad 0x40000000 | (1 << 10) | (3 << 8) | (1 << 2) | 1
    .quad 0x80000000 | (3 << 53) | (1 << 10) | (0 << 2) | 1
    .quad 0xc0000000 | (3 << 53) | (1 << 10) | (0 << 2) | 1
    .fill 508, 8, 0
"#
);

/// One semihosting request: `hlt #0xf000` with the operation in `w0`, the argument in `x1`.
///
/// # Safety
/// `arg` must be what the operation expects (a pointer to a valid parameter block for most).
pub unsafe fn semihost_call(op: usize, arg: usize) -> usize {
    let ret: usize;
    // SAFETY: the caller passes a valid request; QEMU services it and resumes after the hlt.
    unsafe { core::arch::asm!("hlt #0xf000", inout("x0") op => ret, in("x1") arg, options(nostack)) };
    ret
}

/// The retired-instruction counter, if the guest can read one (not on this target).
#[inline(always)]
pub fn instret() -> Option<u64> {
    None
}

/// The current stack pointer.
#[inline(always)]
pub fn sp() -> usize {
    let sp: usize;
    // SAFETY: reads a register.
    unsafe { core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    sp
}

/// Executes a permanently undefined instruction (a synchronous exception).
pub fn undefined_instruction() {
    // SAFETY: raises an exception on purpose; the handler ends the emulation.
    unsafe { core::arch::asm!("udf #0", options(nomem, nostack)) };
}

#[unsafe(no_mangle)]
extern "C" fn fw_rust_main() -> ! {
    crate::main()
}

#[unsafe(no_mangle)]
extern "C" fn fw_trap(esr: usize, elr: usize, far: usize) -> ! {
    let _ = far;
    crate::fault("trap", elr, esr)
}
