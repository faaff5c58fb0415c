//! The C API's runs (`mfcbeam_compensator_compensate_into`, `_f32_into`, `_f64_into`)
//! give the bits and flags of one per-sample call each, across their chunks
//! and calls, in place, and refuse NULL and uninitialised input as the
//! per-sample calls do.

use std::ffi::{c_char, c_int, CString};

use mfcbeam::*;

const NOMINAL: &str = include_str!("../../golden/nominal_model.json");

/// The nominal model with `S`, `G`, an offset and a dead time added: the
/// run's general path (every sample there, as `G` sends it).
fn full_model() -> String {
    let extra = r#""superposition": {"thresholds": [-500, -200, 0, 150, 400], "weights": [0.25, -0.25, 1, -0.2, -0.15]},
 "dynamics": {"low_pass": {"frequency": 2000.0}, "resonance": {"frequency": 740.0, "damping": 0.014}, "delay_fraction": 0.3},
 "delay": 2, "offset": 1.5,"#;
    NOMINAL.replacen('{', &format!("{{{extra}"), 1)
}

/// A seeded signal: a sweep past ±300 V (clipped at the limits used
/// below), with NaN and infinite targets among it.
fn targets(n: usize) -> Vec<f64> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    (0..n)
        .map(|k| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            match state % 97 {
                0 => f64::NAN,
                1 => f64::INFINITY,
                2 => f64::NEG_INFINITY,
                _ => {
                    let t = k as f64 * 2e-4;
                    420.0 * (2.0 * std::f64::consts::PI * 3.0 * t).sin()
                        + (state % 1000) as f64 * 0.05
                }
            }
        })
        .collect()
}

fn heap(json: &str) -> *mut MfcbeamCompensatorHandle {
    let text = CString::new(json).unwrap();
    let mut err = [0 as c_char; 256];
    // SAFETY: a NUL-terminated string and a buffer of its stated length.
    let c = unsafe {
        mfcbeam_compensator_from_json(text.as_ptr(), -300.0, 300.0, err.as_mut_ptr(), err.len())
    };
    assert!(!c.is_null());
    c
}

/// Lengths that cross the chunks: less than one, exactly some, and not.
const PIECES: [usize; 6] = [1, 63, 64, 65, 200, 1000];

#[test]
fn the_heap_run_gives_the_bits_of_its_steps_in_pieces_and_in_place() {
    for json in [NOMINAL.to_string(), full_model()] {
        let (stepped, by_run) = (heap(&json), heap(&json));
        let all = targets(PIECES.iter().sum());
        let (mut u, mut flags) = (all.clone(), vec![-7 as c_int; all.len()]);
        let mut start = 0;
        for (i, &len) in PIECES.iter().enumerate() {
            let (t, out) = (all[start..].as_ptr(), u[start..].as_mut_ptr());
            let f = flags[start..].as_mut_ptr();
            // SAFETY: `len` values from `start` in each buffer; every other
            // piece in place (`u` holds the targets there).
            let rc = unsafe {
                if i % 2 == 0 {
                    mfcbeam_compensator_compensate_into(by_run, out, out, f, len)
                } else {
                    mfcbeam_compensator_compensate_into(by_run, t, out, f, len)
                }
            };
            assert_eq!(rc, 0);
            start += len;
        }
        let mut clipped = 0;
        for (k, &target) in all.iter().enumerate() {
            let mut f: c_int = -7;
            // SAFETY: a live handle and a writable int.
            let v = unsafe { mfcbeam_compensator_compensate(stepped, target, &mut f) };
            assert_eq!(v.to_bits(), u[k].to_bits(), "sample {k}");
            assert_eq!(f, flags[k], "sample {k}");
            clipped += (f & MFCBEAM_FLAG_SATURATED != 0) as usize;
        }
        assert!(clipped > 0, "the signal reaches the limits");
        assert!(flags
            .iter()
            .any(|f| f & MFCBEAM_FLAG_NON_FINITE_TARGET != 0));
        // SAFETY: each handle freed once.
        unsafe {
            (
                mfcbeam_compensator_free(stepped),
                mfcbeam_compensator_free(by_run),
            )
        };
    }
}

/// A test that caller-owned storage, initialised from the nominal model
/// file, gives in two runs (the second without flags) the bits and flags
/// of one per-sample step each.
macro_rules! fixed_matches_its_steps {
    ($name:ident, $storage:ident, $t:ty, $init:ident, $step:ident, $run:ident) => {
        #[test]
        fn $name() {
            let text = CString::new(NOMINAL).unwrap();
            let mut err = [0 as c_char; 256];
            let mut boxes: Vec<Box<$storage>> = (0..2)
                .map(|_| {
                    // SAFETY: all-zero words are the storage's uninitialised
                    // state (the API refuses it until `*_init`).
                    let mut s: Box<$storage> = Box::new(unsafe { std::mem::zeroed() });
                    // SAFETY: storage, a NUL-terminated string, a buffer.
                    let rc = unsafe {
                        $init(
                            &mut *s,
                            text.as_ptr(),
                            -300.0,
                            300.0,
                            err.as_mut_ptr(),
                            err.len(),
                        )
                    };
                    assert_eq!(rc, 0);
                    s
                })
                .collect();
            let all: Vec<$t> = targets(1300).into_iter().map(|x| x as $t).collect();
            let (mut u, mut flags) = (vec![0.0 as $t; all.len()], vec![0 as c_int; all.len()]);
            let by_run = &mut *boxes[1] as *mut $storage;
            // SAFETY: 1300 values in each buffer; then NULL flags.
            unsafe {
                assert_eq!(
                    $run(
                        by_run,
                        all.as_ptr(),
                        u.as_mut_ptr(),
                        flags.as_mut_ptr(),
                        700
                    ),
                    0
                );
                let rest = all.len() - 700;
                let (t, out) = (all.as_ptr().add(700), u.as_mut_ptr().add(700));
                assert_eq!($run(by_run, t, out, std::ptr::null_mut(), rest), 0);
            }
            for (k, &target) in all.iter().enumerate() {
                let mut f: c_int = 0;
                // SAFETY: initialised storage, a writable int.
                let v = unsafe { $step(&mut *boxes[0], target, &mut f) };
                assert_eq!(v.to_bits(), u[k].to_bits(), "sample {k}");
                if k < 700 {
                    assert_eq!(f, flags[k], "sample {k}");
                }
            }
            assert!(flags.iter().any(|f| f & MFCBEAM_FLAG_SATURATED != 0));
        }
    };
}

fixed_matches_its_steps!(
    the_f64_storage_run_gives_the_bits_of_its_steps,
    MfcbeamCompensatorStorageF64,
    f64,
    mfcbeam_compensator_f64_init_json,
    mfcbeam_compensator_f64_compensate,
    mfcbeam_compensator_f64_compensate_into
);
fixed_matches_its_steps!(
    the_f32_storage_run_gives_the_bits_of_its_steps,
    MfcbeamCompensatorStorageF32,
    f32,
    mfcbeam_compensator_f32_init_json,
    mfcbeam_compensator_f32_compensate,
    mfcbeam_compensator_f32_compensate_into
);

#[test]
fn a_run_refuses_null_and_uninitialised_input_as_its_steps_do() {
    let t = [1.0, 2.0, 3.0];
    let (mut u, mut flags) = ([0.0; 3], [0 as c_int; 3]);
    // SAFETY: NULL handles; buffers of three.
    unsafe {
        let rc = mfcbeam_compensator_compensate_into(
            std::ptr::null_mut(),
            t.as_ptr(),
            u.as_mut_ptr(),
            flags.as_mut_ptr(),
            3,
        );
        assert_eq!(rc, -1);
        assert!(u.iter().all(|v| v.is_nan()));
        assert!(flags.iter().all(|&f| f == MFCBEAM_FLAG_INVALID_HANDLE));
        // NULL arrays as well: nothing to write, no crash, and no walk
        // over a length that only looks like one
        let rc = mfcbeam_compensator_compensate_into(
            std::ptr::null_mut(),
            std::ptr::null(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            usize::MAX / 16,
        );
        assert_eq!(rc, -1);
        let rc = mfcbeam_compensator_compensate_into(
            std::ptr::null_mut(),
            std::ptr::null(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            3,
        );
        assert_eq!(rc, -1);
        // zeroed storage is uninitialised
        let mut s: Box<MfcbeamCompensatorStorageF64> = Box::new(std::mem::zeroed());
        flags = [0; 3];
        let rc = mfcbeam_compensator_f64_compensate_into(
            &mut *s,
            t.as_ptr(),
            u.as_mut_ptr(),
            flags.as_mut_ptr(),
            3,
        );
        assert_eq!(rc, -1);
        assert!(flags.iter().all(|&f| f == MFCBEAM_FLAG_INVALID_HANDLE));
    }

    // a live handle and NULL arrays: -1, and nothing stepped
    let (c, twin) = (heap(NOMINAL), heap(NOMINAL));
    // SAFETY: live handles; NULL arrays with n > 0 are refused before use,
    // with n = 0 never read.
    unsafe {
        assert_eq!(
            mfcbeam_compensator_compensate_into(
                c,
                std::ptr::null(),
                u.as_mut_ptr(),
                std::ptr::null_mut(),
                3
            ),
            -1
        );
        assert_eq!(
            mfcbeam_compensator_compensate_into(
                c,
                t.as_ptr(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                3
            ),
            -1
        );
        assert_eq!(
            mfcbeam_compensator_compensate_into(
                c,
                std::ptr::null(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                0
            ),
            0
        );
        // a count no array can have: refused, not read
        assert_eq!(
            mfcbeam_compensator_compensate_into(
                c,
                t.as_ptr(),
                u.as_mut_ptr(),
                std::ptr::null_mut(),
                usize::MAX
            ),
            -1
        );
        for &target in &[250.0, -120.0, 40.0] {
            let (mut fa, mut fb) = (0, 0);
            let a = mfcbeam_compensator_compensate(c, target, &mut fa);
            let b = mfcbeam_compensator_compensate(twin, target, &mut fb);
            assert_eq!(
                (a.to_bits(), fa),
                (b.to_bits(), fb),
                "the refused runs left the state alone"
            );
        }
        mfcbeam_compensator_free(c);
        mfcbeam_compensator_free(twin);
    }
}
