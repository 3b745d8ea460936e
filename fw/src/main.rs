//! Firmware smoke image: upscales a TIR frame held in external SDRAM with the core's bicubic
//! rescaler and reports a checksum over semihosting. Later stages (issue 7) add the fusion
//! pipeline, instruction markers and the RV32 image.
#![no_std]
#![no_main]

use core::panic::PanicInfo;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use fusion_nostd::{Filter, Frame512, Frame1024, rescale};

#[unsafe(link_section = ".bigram")]
static mut TIR: Frame512 = Frame512::filled(0);
#[unsafe(link_section = ".bigram")]
static mut OUT: Frame1024 = Frame1024::filled(0);

/// Calls every public entry point with sizes and data the optimiser cannot see, so the
/// `panic-check` link covers all their code paths, not just the ones the demo sizes reach.
#[cfg(any(feature = "panic-check", feature = "exercise"))]
fn exercise_entry_points() {
    use core::hint::black_box;
    use fusion_nostd::{FrameMut, FrameRef};
    static mut U8_IN: [u8; 4096] = [0; 4096];
    static mut U8_OUT: [u8; 4096] = [0; 4096];
    static mut U16_IN: [u16; 1024] = [0; 1024];
    static mut U16_OUT: [u16; 1024] = [0; 1024];
    static mut F32_IN: [f32; 1024] = [0.0; 1024];
    static mut F32_OUT: [f32; 1024] = [0.0; 1024];
    // SAFETY: single-threaded; the only references to these buffers.
    let (a, b, c, d, e, f) = unsafe {
        (
            &*core::ptr::addr_of!(U8_IN),
            &mut *core::ptr::addr_of_mut!(U8_OUT),
            &*core::ptr::addr_of!(U16_IN),
            &mut *core::ptr::addr_of_mut!(U16_OUT),
            &*core::ptr::addr_of!(F32_IN),
            &mut *core::ptr::addr_of_mut!(F32_OUT),
        )
    };
    let dims =
        || (black_box(7usize), black_box(9usize), black_box(13usize), black_box(4usize), black_box(8usize));
    let (sw, sh, dw, dh, stride) = dims();
    for filter in [Filter::Cubic, Filter::Area] {
        let filter = black_box(filter);
        if let (Ok(s), Ok(o)) = (FrameRef::with_stride(a, sw, sh, stride), FrameMut::new(b, dw, dh)) {
            let _ = black_box(rescale(s, o, filter));
        }
        if let (Ok(s), Ok(o)) = (FrameRef::new(c, sw, sh), FrameMut::new(d, dw, dh)) {
            let _ = black_box(rescale(s, o, filter));
        }
        if let (Ok(s), Ok(o)) = (FrameRef::new(e, sw, sh), FrameMut::new(f, dw, dh)) {
            let _ = black_box(rescale(s, o, filter));
        }
    }
}

#[entry]
fn main() -> ! {
    #[cfg(any(feature = "panic-check", feature = "exercise"))]
    exercise_entry_points();
    // SAFETY: single-threaded firmware; these are the only references to the frames.
    let (tir, out) = unsafe { (&mut *core::ptr::addr_of_mut!(TIR), &mut *core::ptr::addr_of_mut!(OUT)) };
    for (i, p) in tir.pixels_mut().iter_mut().enumerate() {
        *p = (i.wrapping_mul(2_654_435_761) >> 13) as u8;
    }
    let code = match rescale(tir.view(), out.view_mut(), Filter::Cubic) {
        Ok(()) => {
            let sum = out.pixels().iter().fold(0u32, |s, &p| s.wrapping_mul(31).wrapping_add(u32::from(p)));
            hprintln!("cubic 512->1024 checksum {:08x}", sum);
            debug::EXIT_SUCCESS
        }
        Err(_) => debug::EXIT_FAILURE,
    };
    debug::exit(code);
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(not(feature = "panic-check"))]
#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

/// With `--features panic-check` any panic path the optimiser could not remove from the linked
/// image calls this undefined symbol, so the link fails: a build that links has no panic path.
#[cfg(feature = "panic-check")]
#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    unsafe extern "C" {
        fn fusion_core_has_a_reachable_panic_path() -> !;
    }
    // SAFETY: never defined; only reached if a panic path survives optimisation (link error).
    unsafe { fusion_core_has_a_reachable_panic_path() }
}
