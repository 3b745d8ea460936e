//! `cargo fuzz run rescale_u16`: see `fusion_fuzz::rescale_u16` (fuzz/src/lib.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| fusion_fuzz::rescale_u16(data));
