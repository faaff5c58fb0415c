//! Properties of the play and of the project's PI operator that go through
//! its typed state ([`Snapshot`]): the semigroup property bit for bit, the
//! play's band, validation and reset. Rate independence, monotonicity, the
//! Lipschitz bound, odd symmetry and the branching rules of `H` are
//! properties of every implementation: `verification/conformance.rs` runs
//! them through `mfcbeam::suite::conformance`.

use crate::common;

use common::*;
use mfcbeam::prelude::*;
use proptest::prelude::*;

proptest! {
    #![proptest_config(config(256, "proptest-regressions/hysteresis_properties.txt"))]

    /// Semigroup: a run split at any sample and resumed from the saved state
    /// (set on a fresh operator) is bit-identical to the whole run.
    #[test]
    fn semigroup_split_and_resume_is_bit_identical(
        h in hysteresis_operator(12),
        v in signal(2..80, 6.0),
        split in any::<prop::sample::Index>(),
    ) {
        let k = split.index(v.len());
        let whole = h.clone().run(&v);
        let mut first = h.clone();
        let mut y = first.run(&v[..k]);
        let mut second = h.clone();
        second.set_state(&first.state()).unwrap();
        y.extend(second.run(&v[k..]));
        prop_assert_eq!(whole, y);
    }

    /// The play on its own: the output stays within `r` of the input and only
    /// moves when pushed.
    #[test]
    fn play_output_stays_within_the_threshold_band(
        r in 0.0f64..3.0,
        x0 in -5.0f64..5.0,
        v in signal(1..80, 6.0),
    ) {
        let mut p = PlayOperator::with_state(r, x0).unwrap();
        let mut prev = x0;
        for &vk in &v {
            let x = p.step(vk);
            prop_assert!((vk - x).abs() <= r * (1.0 + 2.0 * EPS) + 4.0 * EPS * vk.abs());
            // It moves only if the previous output left the band around vk.
            if (vk - prev).abs() <= r {
                prop_assert_eq!(x, prev);
            }
            prev = x;
        }
    }
}

/// The operator refuses bad parameters and states with the field named.
#[test]
fn validation_names_the_field() {
    let e = HysteresisOperator::new(vec![0.0, 2.0, 1.0], vec![1.0; 3]).unwrap_err();
    assert!(e.to_string().starts_with("hysteresis.thresholds[2]"), "{e}");
    let e = HysteresisOperator::new(vec![0.0, 1.0], vec![1.0, f64::NAN]).unwrap_err();
    assert!(e.to_string().starts_with("hysteresis.weights[1]"), "{e}");
    let mut h = HysteresisOperator::new(vec![0.0, 1.0], vec![1.0, 0.5]).unwrap();
    let e = h.set_state(&[0.0]).unwrap_err();
    assert!(matches!(e, ParameterError::LengthMismatch { .. }));
    // a failed set_state leaves the state untouched
    h.step(0.7);
    let before = h.state();
    assert!(h.set_state(&[0.0, 5.0]).is_err());
    assert_eq!(h.state(), before);
}

/// Reset returns to the virgin state.
#[test]
fn reset_returns_to_the_virgin_state() {
    let mut h = nominal_model().hysteresis().clone();
    let fresh = h.clone();
    h.run(&[300.0, -200.0, 50.0]);
    h.reset();
    assert_eq!(h, fresh);
}
