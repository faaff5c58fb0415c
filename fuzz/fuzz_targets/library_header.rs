#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| mfcbeam_fuzz::library_header(data));
