//! Run-time choice of the best instruction set for the host kernels, and the switch that caps
//! it ([`limit_isa`]).
//!
//! The hot kernels are plain portable Rust marked `#[inline(always)]`. On x86-64,
//! `dispatch!` compiles two more copies of a kernel, with AVX-512 (F, BW, VL) and with AVX2
//! enabled, and calls the best one the CPU has; a few kernels have hand-written AVX2 and
//! AVX-512 forms (`*/avx2.rs`, `*/avx512.rs`) chosen the same way. The arithmetic is integer
//! (or IEEE operations proven exact), so every copy gives the same bits. On every other target
//! (the flight targets included) the forms are chosen at compile time: the Armv7E-M forms
//! (`*/armv7em.rs`) on `thumbv7em`, the NEON forms (`*/neon.rs`) on AArch64, the portable code
//! elsewhere. [`limit_isa`] can still switch the NEON forms off (AArch64 has NEON by definition,
//! so there is nothing to detect); the Armv7E-M forms it does not change.
//!
//! [`limit_isa`] caps the choice for the whole process: the tests run every SIMD form and the
//! portable code on the same frames and compare the bytes (on x86-64 hosts and under
//! `qemu-aarch64`), and a benchmark measures the AVX2 forms on a machine that has AVX-512.

use core::sync::atomic::{AtomicU8, Ordering};

// The NEON forms read 32-bit words as 16-bit lanes and bytes, low half first.
#[cfg(all(target_arch = "aarch64", target_endian = "big"))]
compile_error!("the NEON forms assume little-endian AArch64 (aarch64_be is not supported)");

/// The instruction sets the host kernels choose from: the portable code, the x86-64 sets and
/// NEON. Not ordered (NEON and AVX2 are one level of [`limit_isa`]'s cap).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Isa {
    /// The portable Rust code (what every target without a SIMD form runs).
    Portable = 0,
    /// x86-64 AVX2.
    Avx2 = 1,
    /// x86-64 AVX-512 F, BW and VL.
    Avx512 = 2,
    /// AArch64 Advanced SIMD (NEON), which every AArch64 CPU has.
    Neon = 3,
}

impl Isa {
    /// Every set: the portable code, then the x86-64 sets plainest first, then NEON.
    pub const ALL: [Isa; 4] = [Isa::Portable, Isa::Avx2, Isa::Avx512, Isa::Neon];

    /// Its lower-case name (`portable`, `avx2`, `avx512`, `neon`).
    pub fn name(self) -> &'static str {
        match self {
            Isa::Portable => "portable",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
            Isa::Neon => "neon",
        }
    }

    /// Its level as a cap: 0 the portable code, 1 AVX2 or NEON, 2 AVX-512.
    const fn level(self) -> u8 {
        match self {
            Isa::Portable => 0,
            Isa::Avx2 | Isa::Neon => 1,
            Isa::Avx512 => 2,
        }
    }
}

/// The cap set by [`limit_isa`] (an [`Isa::level`]).
static CAP: AtomicU8 = AtomicU8::new(u8::MAX);

/// Caps the instruction set the host kernels use, for the whole process, from the next call
/// on: [`Isa::Portable`] runs the portable code everywhere (no AVX2, AVX-512 or NEON form),
/// [`Isa::Avx2`] (or [`Isa::Neon`], the same level) the AVX2 forms on a machine with AVX-512
/// and the NEON forms on AArch64, [`Isa::Avx512`] (the default) the best the CPU has. Every
/// choice gives the same output bits; only the time differs. For tests and benchmarks; calls in
/// progress on other threads may finish on the previous choice. The Armv7E-M forms are chosen
/// at compile time and not capped.
pub fn limit_isa(max: Isa) {
    CAP.store(max.level(), Ordering::Relaxed);
}

/// The instruction set the host kernels use now: the best the CPU has, under the cap of
/// [`limit_isa`]. Always [`Isa::Portable`] on targets with neither x86-64 nor NEON forms.
pub fn isa() -> Isa {
    #[cfg(target_arch = "x86_64")]
    {
        if has_avx512bw() {
            return Isa::Avx512;
        }
        if has_avx2() {
            return Isa::Avx2;
        }
    }
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    if has_neon() {
        return Isa::Neon;
    }
    Isa::Portable
}

/// Whether the cap allows the NEON forms (compiled in wherever this exists).
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
pub(crate) fn has_neon() -> bool {
    allowed(Isa::Neon)
}

/// Whether the cap allows `isa`.
#[cfg(any(target_arch = "x86_64", all(target_arch = "aarch64", target_feature = "neon")))]
fn allowed(isa: Isa) -> bool {
    CAP.load(Ordering::Relaxed) >= isa.level()
}

/// A CPU feature detected once: 0 unknown, 1 no, 2 yes.
#[cfg(target_arch = "x86_64")]
struct Feature(AtomicU8);

#[cfg(target_arch = "x86_64")]
impl Feature {
    const fn new() -> Self {
        Self(AtomicU8::new(0))
    }

    /// The cached answer, or `detect()`'s, cached.
    fn get(&self, detect: fn() -> bool) -> bool {
        match self.0.load(Ordering::Relaxed) {
            1 => false,
            2 => true,
            _ => {
                let yes = detect();
                self.0.store(if yes { 2 } else { 1 }, Ordering::Relaxed);
                yes
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
static AVX2: Feature = Feature::new();
#[cfg(target_arch = "x86_64")]
static AVX512BW: Feature = Feature::new();

/// Whether the cap allows AVX2 and this x86-64 CPU and OS support it (CPUID leaf 7 and the XCR0 YMM state).
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx2() -> bool {
    allowed(Isa::Avx2) && AVX2.get(detect_avx2)
}

/// Whether the cap allows AVX-512 and this x86-64 CPU and OS support AVX-512 F, BW and VL on 512-bit registers (CPUID leaf
/// 7 and the XCR0 opmask and ZMM states).
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx512bw() -> bool {
    allowed(Isa::Avx512) && AVX512BW.get(|| AVX2.get(detect_avx2) && detect_avx512bw())
}

#[cfg(target_arch = "x86_64")]
fn detect_avx2() -> bool {
    use core::arch::x86_64::{__cpuid, __cpuid_count};
    let leaf1 = __cpuid(1);
    let osxsave = leaf1.ecx & (1 << 27) != 0;
    let avx = leaf1.ecx & (1 << 28) != 0;
    if !(osxsave && avx) || __cpuid(0).eax < 7 {
        return false;
    }
    let avx2 = __cpuid_count(7, 0).ebx & (1 << 5) != 0;
    // SAFETY: OSXSAVE is set, so XGETBV is available.
    let xcr0 = unsafe { xgetbv0() };
    avx2 && xcr0 & 0b110 == 0b110
}

#[cfg(target_arch = "x86_64")]
fn detect_avx512bw() -> bool {
    use core::arch::x86_64::__cpuid_count;
    let ebx = __cpuid_count(7, 0).ebx;
    let (f, bw, vl) = (ebx & (1 << 16) != 0, ebx & (1 << 30) != 0, ebx & (1 << 31) != 0);
    // SAFETY: `detect_avx2` (called first) saw OSXSAVE, so XGETBV is available.
    let xcr0 = unsafe { xgetbv0() };
    // SSE, AVX, opmask, ZMM_Hi256 and Hi16_ZMM state enabled by the OS.
    f && bw && vl && xcr0 & 0b1110_0110 == 0b1110_0110
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "xsave")]
unsafe fn xgetbv0() -> u64 {
    // SAFETY: the caller guarantees XGETBV is available (CPUID.1:ECX.OSXSAVE).
    unsafe { core::arch::x86_64::_xgetbv(0) }
}

/// Defines `fn $name(args) -> ret` (`-> ()` when omitted) calling `$kernel(args)`, through
/// an AVX-512-compiled copy of the kernel on x86-64 CPUs that have AVX-512 F and BW, or an
/// AVX2-compiled copy on those that have AVX2.
macro_rules! dispatch {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) => $kernel:path) => {
        $crate::cpu::dispatch! { $(#[$meta])* $vis fn $name($($arg: $ty),*) -> () => $kernel }
    };
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty => $kernel:path) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl")]
                fn avx512_copy($($arg: $ty),*) -> $ret {
                    $kernel($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                fn avx2_copy($($arg: $ty),*) -> $ret {
                    $kernel($($arg),*)
                }
                if $crate::cpu::has_avx512bw() {
                    // SAFETY: the CPU supports AVX-512 F, BW and VL, checked at run time.
                    return unsafe { avx512_copy($($arg),*) };
                }
                if $crate::cpu::has_avx2() {
                    // SAFETY: the CPU supports AVX2, checked at run time just above.
                    return unsafe { avx2_copy($($arg),*) };
                }
            }
            $kernel($($arg),*)
        }
    };
}
pub(crate) use dispatch;
