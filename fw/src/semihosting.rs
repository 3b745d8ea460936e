//! Semihosting, shared by both targets: the host (QEMU with
//! `-semihosting-config enable=on,target=native`) services file I/O and exit requests.
//!
//! Only the trap differs between the architectures (see [`crate::arch::semihost_call`]):
//! Arm executes `bkpt 0xAB` with the operation in `r0` and the argument in `r1`; RISC-V
//! executes the uncompressed `slli x0,x0,0x1f; ebreak; srai x0,x0,7` sequence with them in
//! `a0`/`a1`; AArch64 executes `hlt #0xf000` with them in `x0`/`x1` (parameter blocks of 64-bit
//! words, and `SYS_EXIT` takes a block). The operation numbers and parameter blocks are the same ("Semihosting for
//! AArch32 and AArch64", v2; RISC-V reuses them).

use crate::arch::semihost_call;

const SYS_OPEN: usize = 0x01;
const SYS_CLOSE: usize = 0x02;
const SYS_WRITE: usize = 0x05;
const SYS_READ: usize = 0x06;
const SYS_FLEN: usize = 0x0C;
const SYS_EXIT: usize = 0x18;

/// `ADP_Stopped_ApplicationExit`: QEMU exits with status 0.
const EXIT_SUCCESS: usize = 0x20026;
/// `ADP_Stopped_RunTimeErrorUnknown`: QEMU exits with status 1.
const EXIT_FAILURE: usize = 0x20023;

/// `fopen` modes of `SYS_OPEN`.
#[derive(Clone, Copy)]
#[repr(usize)]
pub enum Mode {
    /// `"rb"`.
    ReadBinary = 1,
    /// `"w"` (used with the special name `:tt` for the console).
    Write = 4,
    /// `"wb"`.
    WriteBinary = 5,
}

/// A host file handle.
#[derive(Clone, Copy)]
pub struct Handle(usize);

/// Why a semihosting file operation failed.
#[derive(Clone, Copy, Debug)]
pub enum IoError {
    /// `SYS_OPEN` returned -1.
    Open,
    /// `SYS_FLEN` returned -1.
    Length,
    /// Fewer bytes than requested were transferred.
    Short,
}

fn call(op: usize, args: &[usize]) -> usize {
    // SAFETY: the parameter block lives for the duration of the call; QEMU only reads it (and
    // the buffers it points to, which the callers keep borrowed).
    unsafe { semihost_call(op, args.as_ptr() as usize) }
}

/// Opens a host file (relative names are relative to QEMU's working directory).
pub fn open(name: &str, mode: Mode) -> Result<Handle, IoError> {
    // SYS_OPEN wants a NUL-terminated name as well as its length.
    let mut buf = [0u8; 64];
    let bytes = name.as_bytes();
    // Leave at least one NUL at the end.
    match buf.get_mut(..bytes.len()).filter(|b| b.len() < 64) {
        Some(dst) => dst.copy_from_slice(bytes),
        None => return Err(IoError::Open),
    }
    let h = call(SYS_OPEN, &[buf.as_ptr() as usize, mode as usize, bytes.len()]);
    if h == usize::MAX { Err(IoError::Open) } else { Ok(Handle(h)) }
}

/// Closes a handle.
pub fn close(h: Handle) {
    call(SYS_CLOSE, &[h.0]);
}

/// The file's length in bytes.
pub fn flen(h: Handle) -> Result<usize, IoError> {
    let n = call(SYS_FLEN, &[h.0]);
    if n == usize::MAX { Err(IoError::Length) } else { Ok(n) }
}

/// Reads exactly `buf.len()` bytes.
pub fn read_exact(h: Handle, buf: &mut [u8]) -> Result<(), IoError> {
    // SYS_READ returns the number of bytes *not* read.
    let left = call(SYS_READ, &[h.0, buf.as_mut_ptr() as usize, buf.len()]);
    if left == 0 { Ok(()) } else { Err(IoError::Short) }
}

/// Writes all of `data`.
pub fn write_all(h: Handle, data: &[u8]) -> Result<(), IoError> {
    // SYS_WRITE returns the number of bytes *not* written.
    let left = call(SYS_WRITE, &[h.0, data.as_ptr() as usize, data.len()]);
    if left == 0 { Ok(()) } else { Err(IoError::Short) }
}

/// Reads the whole host file `name` into the start of `buf`; returns its length.
pub fn read_file(name: &str, buf: &mut [u8]) -> Result<usize, IoError> {
    let h = open(name, Mode::ReadBinary)?;
    let result = flen(h).and_then(|n| match buf.get_mut(..n) {
        Some(dst) => read_exact(h, dst).map(|()| n),
        None => Err(IoError::Short),
    });
    close(h);
    result
}

/// Writes `data` to the host file `name` (created or truncated).
pub fn write_file(name: &str, data: &[u8]) -> Result<(), IoError> {
    let h = open(name, Mode::WriteBinary)?;
    let result = write_all(h, data);
    close(h);
    result
}

/// Ends the emulation: QEMU exits with status 0 when `success`, 1 otherwise.
pub fn exit(success: bool) -> ! {
    // On AArch32 and RV32 SYS_EXIT takes the reason code itself in the argument register, not
    // a pointer to a block (QEMU cannot pass a status through it: 0 or 1 only); on AArch64 it
    // takes a block of the reason and a status.
    let reason = if success { EXIT_SUCCESS } else { EXIT_FAILURE };
    loop {
        #[cfg(target_arch = "aarch64")]
        call(SYS_EXIT, &[reason, usize::from(!success)]);
        // SAFETY: SYS_EXIT does not return under QEMU; the loop covers a debugger that resumes.
        #[cfg(not(target_arch = "aarch64"))]
        unsafe {
            semihost_call(SYS_EXIT, reason)
        };
    }
}

/// The console (`:tt`), written through a small line buffer so each semihosting call carries
/// a whole line.
pub struct Console {
    handle: Option<Handle>,
    buf: [u8; 256],
    len: usize,
}

impl Console {
    /// Opens the console; when that fails, output is dropped.
    pub fn open() -> Self {
        Self { handle: open(":tt", Mode::Write).ok(), buf: [0; 256], len: 0 }
    }

    /// Writes out the buffered bytes.
    pub fn flush(&mut self) {
        if let (Some(h), Some(data)) = (self.handle, self.buf.get(..self.len)) {
            let _ = write_all(h, data);
        }
        self.len = 0;
    }
}

impl core::fmt::Write for Console {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for &b in s.as_bytes() {
            if self.len >= self.buf.len() {
                self.flush();
            }
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
            if b == b'\n' {
                self.flush();
            }
        }
        Ok(())
    }
}
