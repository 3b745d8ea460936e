//! `cargo fuzz run rescale_f32`: see `fusion_fuzz::rescale_f32` (fuzz/src/lib.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| fusion_fuzz::rescale_f32(data));
