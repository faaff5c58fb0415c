//! `include/mfcbeam.h` is what cbindgen generates from this crate now: the
//! header cannot drift from the library. `MFCBEAM_BLESS=1` rewrites it.

use std::path::Path;

#[test]
fn header_is_current() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).unwrap();
    let bindings = cbindgen::Builder::new()
        .with_crate(dir)
        .with_config(config)
        .generate()
        .expect("cbindgen parses the C API");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    let generated = String::from_utf8(generated).unwrap();
    let path = dir.join("../include/mfcbeam.h");
    if std::env::var_os("MFCBEAM_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let current = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        current == generated,
        "include/mfcbeam.h is stale: regenerate with MFCBEAM_BLESS=1 cargo test -p mfcbeam-capi --test header"
    );
}
