//! Hostile model files through the C API's JSON constructors: counts above
//! their limits and the fuzzers' findings (`fuzz/regressions/capi`) give
//! NULL (or -1) and a message of one line, never an abort.

use std::ffi::{c_char, CStr, CString};

fn refusal(json: &str) -> String {
    let text = CString::new(json).unwrap();
    let mut err = [0 as c_char; 512];
    // SAFETY: a NUL-terminated string and a buffer of the stated length.
    let m = unsafe { mfcbeam::mfcbeam_model_from_json(text.as_ptr(), err.as_mut_ptr(), err.len()) };
    assert!(m.is_null(), "accepted: {json}");
    // SAFETY: the library NUL-terminates the message.
    let model_message = unsafe { CStr::from_ptr(err.as_ptr()) }
        .to_string_lossy()
        .into_owned();
    // SAFETY: as above.
    let c = unsafe {
        mfcbeam::mfcbeam_compensator_from_json(
            text.as_ptr(),
            -1000.0,
            1000.0,
            err.as_mut_ptr(),
            err.len(),
        )
    };
    assert!(c.is_null(), "accepted: {json}");
    // SAFETY: as above.
    let compensator_message = unsafe { CStr::from_ptr(err.as_ptr()) }
        .to_string_lossy()
        .into_owned();
    for message in [&model_message, &compensator_message] {
        assert!(!message.is_empty());
        assert!(
            !message.contains('\n') && !message.contains('\r'),
            "{message:?}"
        );
    }
    model_message
}

const MODEL: &str =
    r#""sample_time": 0.0002, "hysteresis": {"thresholds": [0, 100], "weights": [0.5, 0.25]}"#;

#[test]
fn counts_above_their_limits_are_refused_with_one_line() {
    for delay in [
        "1000000000000",
        "18446744073709551615",
        "100000000",
        "100001",
    ] {
        let m = refusal(&format!("{{{MODEL}, \"delay\": {delay}}}"));
        assert!(
            m.contains("delay") && m.contains("exceeds the limit"),
            "{m}"
        );
    }
    let eigenvalues: Vec<String> = (1..=65).map(|i| i.to_string()).collect();
    let m = refusal(&format!(
        "{{{MODEL}, \"creep\": {{\"thresholds\": [0], \"weights\": [0], \"eigenvalues\": [{}]}}}}",
        eigenvalues.join(",")
    ));
    assert!(m.contains("creep.eigenvalues: 65 exceeds the limit"), "{m}");
}

/// Fuzzing finding (capi): a field name with a line break in it made the
/// "unknown field" message two lines.
#[test]
fn finding_a_field_name_with_a_line_break_still_gives_one_line() {
    let m = refusal(&format!("{{\"a\\nb\": 1, {MODEL}}}"));
    assert!(m.contains("unknown field"), "{m}");
    let bytes = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fuzz/regressions/capi/multi-line-message"
    ))
    .unwrap();
    let text = &bytes[..bytes.iter().position(|&b| b == 0).unwrap()];
    refusal(std::str::from_utf8(text).unwrap());
}
