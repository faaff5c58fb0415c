//! The input every operator bench uses.

#[allow(dead_code)] // only bank_limit uses it
pub mod state_stream;

// the CPU's description and the kernel set come from `internals`
#[cfg(feature = "internals")]
#[allow(dead_code)] // not every bench writes results
pub mod results;

/// A seeded random walk of `len` samples in [-600, 600] V with frequent
/// reversals, so that branch predictors see realistic play switching.
pub fn test_input(len: usize) -> Vec<f64> {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut v = 0.0f64;
    (0..len)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let step = ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 40.0;
            v = (v + step).clamp(-600.0, 600.0);
            v
        })
        .collect()
}

/// `rows` steps of reachable targets for a bank of `channels` channels: W
/// of the test input, each channel at its own phase.
#[allow(dead_code)] // not every bench uses it
pub fn bank_rows<T: mfcbeam::realtime::Real>(channels: usize, rows: usize) -> Vec<Vec<T>> {
    use mfcbeam::operators::traits::Operator;
    let targets = mfcbeam::operators::nominal::nominal_model().run(&test_input(4096));
    (0..rows)
        .map(|k| {
            (0..channels)
                .map(|ch| T::from_f64(targets[(k * 16 + ch * 37) % targets.len()]))
                .collect()
        })
        .collect()
}

/// A bank of `channels` channels of the nominal model, limits ±1000 V.
#[allow(dead_code)] // not every bench uses it
pub fn nominal_bank<T: mfcbeam::realtime::Real>(
    channels: usize,
) -> mfcbeam::operators::bank::CompensatorBank<T> {
    mfcbeam::operators::bank::CompensatorBank::<T>::uniform(
        &mfcbeam::realtime::nominal::PARAMETERS,
        channels,
        mfcbeam::realtime::CompensatorSettings::with_limits(-1000.0, 1000.0),
    )
    .unwrap()
}

/// The symbols `names` of the C library at `path` (one of those
/// `benches/peers/run.sh` builds), loaded `RTLD_LOCAL` so that each library
/// keeps its own; panics naming the library or the symbol it cannot find.
/// The caller gives each symbol its type.
#[cfg(target_os = "linux")]
#[allow(dead_code)] // not every bench uses it
pub fn c_symbols<const N: usize>(path: &str, names: [&str; N]) -> [*mut std::ffi::c_void; N] {
    use std::ffi::CString;
    // SAFETY: dlopen and dlsym with valid C strings; the handle is kept
    // open for the rest of the process.
    unsafe {
        let lib = libc::dlopen(
            CString::new(path).unwrap().as_ptr(),
            libc::RTLD_NOW | libc::RTLD_LOCAL,
        );
        assert!(!lib.is_null(), "cannot load {path}");
        names.map(|name| {
            let s = libc::dlsym(lib, CString::new(name).unwrap().as_ptr());
            assert!(!s.is_null(), "{path}: no symbol {name}");
            s
        })
    }
}
