//! Cortex-M7 (`thumbv7em-none-eabihf`, QEMU `mps2-an500`): start-up from `cortex-m-rt`, the
//! semihosting trap, fault handlers. Instructions are counted outside the guest by the TCG
//! plugin `fw/plugin/insn_count.c` between calls of the marker functions, so [`instret`] has
//! nothing to read here.

use cortex_m_rt::{ExceptionFrame, entry, exception};

/// Target name printed in the report.
pub const NAME: &str = "arm";

/// One semihosting request: `bkpt 0xAB` with the operation in `r0`, the argument in `r1`.
///
/// # Safety
/// `arg` must be what the operation expects (a pointer to a valid parameter block for most).
pub unsafe fn semihost_call(op: usize, arg: usize) -> usize {
    let ret: usize;
    // SAFETY: the caller passes a valid request; QEMU services it and resumes after the bkpt.
    unsafe { core::arch::asm!("bkpt #0xab", inout("r0") op => ret, in("r1") arg, options(nostack)) };
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

/// Executes a permanently undefined instruction (UsageFault, escalated to HardFault).
pub fn undefined_instruction() {
    // SAFETY: raises an exception on purpose; the handler ends the emulation.
    unsafe { core::arch::asm!("udf #0", options(nomem, nostack)) };
}

#[entry]
fn entry() -> ! {
    crate::main()
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    crate::fault("HardFault", frame.pc() as usize, 0)
}

#[exception]
unsafe fn DefaultHandler(irqn: i16) -> ! {
    crate::fault("unexpected exception", 0, irqn as usize)
}
