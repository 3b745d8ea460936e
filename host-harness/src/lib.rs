//! # host-harness
//!
//! The host side of the fusion project: f64 reference implementations, image I/O, metrics,
//! reports and the `fusion` command-line tool.

/// `print!` to standard output that returns an error (closed pipe, full disk) instead of
/// panicking: `out!(…)?`.
macro_rules! out {
    ($($t:tt)*) => { render_host::output::stdout_write(format_args!($($t)*)) };
}

/// `println!` that returns an error instead of panicking: `outln!(…)?`.
macro_rules! outln {
    () => { render_host::output::stdout_write(format_args!("\n")) };
    ($($t:tt)*) => { render_host::output::stdout_write(format_args!("{}\n", format_args!($($t)*))) };
}

/// `eprintln!` that never panics: a failure of standard error is remembered and ends the run
/// with status 1 (`render_host::output::stderr_failed`).
macro_rules! note {
    ($($t:tt)*) => { render_host::output::stderr_note(format_args!($($t)*)) };
}

pub mod agc;
pub mod budget;
pub mod cli;
pub mod color;
pub mod folders;
pub mod io;
pub mod memory;
pub mod methods;
pub mod metrics;
pub mod nav;
pub mod plot;
pub mod reference;
pub mod skip;
pub mod strips;
pub mod study;
pub mod study_methods;
pub mod testdata;

/// A host-side scratch for the core: the `i32` work planes and the `u8` band plane, on the heap.
pub struct CoreScratch {
    planes: [Vec<i32>; fusion_nostd::SCRATCH_PLANES],
    band: Vec<u8>,
}

impl CoreScratch {
    /// Scratch for frames of up to `pixels` pixels.
    pub fn new(pixels: usize) -> Self {
        Self { planes: std::array::from_fn(|_| vec![0; pixels]), band: vec![0; pixels] }
    }

    /// Pixels each plane holds.
    pub fn pixels(&self) -> usize {
        self.band.len()
    }

    /// The core view of the planes.
    pub fn view_mut(&mut self) -> fusion_nostd::ScratchMut<'_> {
        let [a, b, c] = &mut self.planes;
        fusion_nostd::ScratchMut::with_band([a, b, c], &mut self.band)
    }
}
