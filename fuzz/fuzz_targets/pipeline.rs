//! `cargo fuzz run pipeline`: see `fusion_fuzz::pipeline` (fuzz/src/lib.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| fusion_fuzz::pipeline(data));
