//! Run-time choice of the best instruction set for the portable kernels (x86-64 hosts only).
//!
//! The hot kernels are plain portable Rust marked `#[inline(always)]`. On x86-64,
//! [`dispatch!`] compiles two more copies of a kernel, with AVX-512 (F, BW, VL) and with AVX2
//! enabled, and calls the best one the CPU has. The arithmetic is integer (or IEEE operations
//! proven exact), so every copy gives the same bits. On every other target (the flight targets
//! included) the macro is a direct call.

#[cfg(target_arch = "x86_64")]
use core::sync::atomic::{AtomicU8, Ordering};

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

/// Whether this x86-64 CPU and OS support AVX2 (CPUID leaf 7 and the XCR0 YMM state).
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx2() -> bool {
    AVX2.get(detect_avx2)
}

/// Whether this x86-64 CPU and OS support AVX-512 F, BW and VL on 512-bit registers (CPUID leaf
/// 7 and the XCR0 opmask and ZMM states).
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx512bw() -> bool {
    AVX512BW.get(|| has_avx2() && detect_avx512bw())
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
    // SAFETY: `has_avx2` (called first) saw OSXSAVE, so XGETBV is available.
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
