//! The transformation rules (22) themselves and the project's compensator
//! through its typed state: the hand example, the involution of the rules,
//! the recursive `r'` against the direct sums, agreement with an inverse
//! found by bisection of the forward operator, and split-and-resume through
//! the model file bit for bit. The identities `H⁻¹∘H = H∘H⁻¹ = W⁻¹∘W =
//! W∘W⁻¹ = id`, odd symmetry and saturation recovery hold for every
//! implementation: `verification/conformance.rs`.

use crate::common;

use common::*;
use mfcbeam::prelude::*;
use proptest::prelude::*;

proptest! {
    #![proptest_config(config(256, "proptest-regressions/inverse_properties.txt"))]

    /// Applying the rules (22) twice gives back `H`, to rounding.
    #[test]
    fn transformation_rules_are_an_involution(h in hysteresis_operator(12), prefix in signal(0..50, 6.0)) {
        let mut fwd = h.clone();
        fwd.run(&prefix);
        let back = fwd.inverse().inverse();
        let n = h.len() as f64;
        let cond = h.partial_sums().iter().fold(0.0f64, |m, s| m.max(*s)) / min_slope(&h);
        for (a, b) in back.thresholds().iter().zip(h.thresholds()) {
            prop_assert!((a - b).abs() <= 4.0 * n * EPS * cond * reach(&h));
        }
        let w_max = h.weights().iter().fold(0.0f64, |m, w| m.max(w.abs()));
        for (a, b) in back.weights().iter().zip(h.weights()) {
            prop_assert!((a - b).abs() <= 8.0 * EPS * cond * cond * w_max);
        }
        let x = 6.0 + reach(&h);
        for (a, b) in back.play_states().iter().zip(fwd.play_states()) {
            prop_assert!((a - b).abs() <= 8.0 * n * EPS * cond * cond * x);
        }
    }

    /// The inverse agrees with an independent one: the root of
    /// `v ↦ H_state[v] − y`, found by bisection on the forward operator.
    #[test]
    fn inverse_agrees_with_bisection_of_the_forward_operator(
        h in hysteresis_operator(8),
        prefix in signal(0..30, 6.0),
        y in signal(1..30, 4.0),
    ) {
        let mut fwd = h.clone();
        fwd.run(&prefix);
        let mut inv = fwd.inverse();
        let tol = inverse_rounding(&h, 100.0, 6.0) + 1e-13 * 100.0;
        for &yk in &y {
            let v = inv.step(yk);
            // H_state[·] is strictly increasing, so bisection finds its root.
            let (mut lo, mut hi) = (-100.0, 100.0);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if fwd.clone().step(mid) < yk { lo = mid } else { hi = mid }
            }
            prop_assert!((v - 0.5 * (lo + hi)).abs() <= tol / min_slope(&h));
            fwd.step(v);
        }
    }

    /// Semigroup of `W` and of the compensator, and of the model file's
    /// state semantics: split, save (through JSON), resume — bit-identical.
    #[test]
    fn split_and_resume_through_the_model_file_is_bit_identical(
        w in model(12),
        v in signal(2..120, 6.0),
        split in any::<prop::sample::Index>(),
    ) {
        let k = split.index(v.len());
        let whole = w.clone().run(&v);
        let mut first = w.clone();
        let mut y = first.run(&v[..k]);
        let json = serde_json::to_string(&first.to_file()).unwrap();
        let file: ModelFile = serde_json::from_str(&json).unwrap();
        let mut second = HysteresisCreepModel::from_file(&file).unwrap();
        y.extend(second.run(&v[k..]));
        prop_assert_eq!(&whole, &y);

        let mut comp = w.compensator(CompensatorSettings::with_limits(-4.0, 4.0)).unwrap();
        let whole_u = comp.clone().run(&whole);
        let mut c1 = comp.clone();
        let mut u = c1.run(&whole[..k]);
        comp.set_state(&c1.state()).unwrap();
        u.extend(comp.run(&whole[k..]));
        prop_assert_eq!(whole_u, u);
    }

}

/// The hand example of `docs/MATHEMATICS.md` §2.1: `w = (1, 1)`, `r = (0, 1)` has slopes 1 then
/// 2; its inverse has `r' = (0, 1)`, `w' = (1, −1/2)`, slopes 1 then 1/2.
#[test]
fn hand_example_of_spec_2_1() {
    let h = HysteresisOperator::new(vec![0.0, 1.0], vec![1.0, 1.0]).unwrap();
    let inv = h.inverse();
    assert_eq!(inv.thresholds(), &[0.0, 1.0]);
    assert_eq!(inv.weights(), &[1.0, -0.5]);
    assert_eq!(inv.partial_sums(), vec![1.0, 0.5]);
    let mut fwd = h.clone();
    let mut inv = inv;
    for v in [0.5, 1.0, 2.0, 3.0, 1.0, -2.0, 0.25] {
        assert_eq!(inv.step(fwd.step(v)), v);
    }
}

/// The inverse's parameters (recursive `r'`) against the direct sums of (22)
/// in the reference implementation.
#[test]
fn inverse_parameters_match_direct_sums() {
    use mfcbeam::suite::reference::NaiveHysteresis;
    let mut rng = Lcg(7);
    for plays in [1, 2, 5, 12, 20] {
        let inc: Vec<f64> = (1..plays).map(|_| rng.uniform(10.0, 150.0)).collect();
        let sums: Vec<f64> = (0..plays).map(|_| rng.uniform(0.05, 1.0)).collect();
        let h = HysteresisOperator::new(
            thresholds_from_increments(&inc),
            weights_from_partial_sums(&sums),
        )
        .unwrap();
        let fast = h.inverse();
        let control = NaiveHysteresis {
            r: h.thresholds().to_vec(),
            w: h.weights().to_vec(),
            x: h.play_states().to_vec(),
        }
        .inverse();
        let cond = 1.0 / min_slope(&h);
        for (a, b) in fast.thresholds().iter().zip(&control.r) {
            assert!((a - b).abs() <= 4.0 * plays as f64 * EPS * b.abs());
        }
        for (a, b) in fast.weights().iter().zip(&control.w) {
            assert!((a - b).abs() <= 4.0 * EPS * b.abs() * cond);
        }
    }
}

/// The compensator refuses limits with `lower >= upper` or NaN.
#[test]
fn compensator_settings_are_validated() {
    let w = nominal_model();
    assert!(w
        .compensator(CompensatorSettings::with_limits(1.0, -1.0))
        .is_err());
    assert!(w
        .compensator(CompensatorSettings::with_limits(f64::NAN, 1.0))
        .is_err());
    assert!(CompensatorSettings::default().validate().is_ok());
    assert_eq!(CompensatorSettings::default().upper_limit, 1000.0);
}
