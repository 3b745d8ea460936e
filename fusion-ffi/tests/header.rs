//! `include/fusion.h` is what cbindgen generates from the crate today: a change to the C
//! interface that is not in the committed header fails here. `FUSION_FFI_BLESS=1` rewrites it.

use std::path::Path;

#[test]
fn committed_header_is_current() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen parses the crate")
        .write(&mut generated);
    let path = crate_dir.join("include/fusion.h");
    if std::env::var_os("FUSION_FFI_BLESS").is_some() {
        std::fs::write(&path, &generated).expect("write include/fusion.h");
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "include/fusion.h is stale: regenerate it with `FUSION_FFI_BLESS=1 cargo test --test header` in fusion-ffi/"
    );
}
