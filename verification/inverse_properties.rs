//! The analytic inverse (22) and the compensator (21): `H⁻¹∘H = H∘H⁻¹ = id`,
//! `W⁻¹∘W = W∘W⁻¹ = id` from matched admissible states, the hand example of
//! SPEC 2.1, the involution of the rules, agreement with an inverse found by
//! bisection of the forward operator, and saturation recovery.
//!
//! Identities are checked against a rounding bound that grows with the
//! number of plays and the conditioning `1/s_min` (see
//! `common::inverse_rounding`), and in addition against the bound of
//! 1e-12 relative to the signal's range.

mod common;

use common::*;
use mfcbeam::prelude::*;
use proptest::prelude::*;

/// `a = b` to the rounding bound `tol`, and to 1e-12 of the range of the
/// signals involved (`a`, `b` and the intermediate signal `mid`).
fn assert_identity(
    a: &[f64],
    b: &[f64],
    mid: &[f64],
    tol: f64,
    what: &str,
) -> Result<(), TestCaseError> {
    let err = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    let rel = 1e-12 * range(b).max(range(a)).max(range(mid));
    prop_assert!(
        err <= tol,
        "{what}: error {err:e} above rounding bound {tol:e}"
    );
    prop_assert!(
        err <= rel,
        "{what}: error {err:e} above 1e-12 of the range ({rel:e})"
    );
    Ok(())
}

proptest! {
    #![proptest_config(config(256, "proptest-regressions/inverse_properties.txt"))]

    /// `H⁻¹[H[v]] = v` from a random admissible state (reached by driving a
    /// random input from the virgin state), with the inverse state from (22).
    #[test]
    fn inverse_after_forward_is_identity(
        h in hysteresis_operator(12),
        prefix in signal(0..50, 6.0),
        v in signal(2..200, 6.0),
    ) {
        let mut fwd = h.clone();
        fwd.run(&prefix);
        let mut inv = fwd.inverse();
        let y = fwd.run(&v);
        let back = inv.run(&y);
        let tol = inverse_rounding(&h, 6.0, max_abs(&y));
        assert_identity(&back, &v, &y, tol, "H⁻¹∘H")?;
    }

    /// `H[H⁻¹[y]] = y` from a random admissible state.
    #[test]
    fn forward_after_inverse_is_identity(
        h in hysteresis_operator(12),
        prefix in signal(0..50, 6.0),
        y in signal(2..200, 6.0),
    ) {
        let mut fwd = h.clone();
        fwd.run(&prefix);
        let mut inv = fwd.inverse();
        let v = inv.run(&y);
        let again = fwd.run(&v);
        let tol = inverse_rounding(&h, max_abs(&v), 6.0);
        assert_identity(&again, &y, &v, tol, "H∘H⁻¹")?;
    }

    /// `W[W⁻¹[ς]] = ς`: the compensator (no limits) followed by the model,
    /// from matched states after a random history.
    #[test]
    fn model_after_compensator_is_identity(
        w in model(12),
        prefix in signal(0..50, 6.0),
        target in signal(2..200, 6.0),
    ) {
        let mut plant = w.clone();
        plant.run(&prefix);
        let mut comp = Compensator::new(&plant, CompensatorSettings::unlimited()).unwrap();
        let u = comp.run(&target);
        let y = plant.run(&u);
        let creep_max: f64 = w.creep().unwrap().weights().iter().map(|x| x.abs()).sum::<f64>() * (max_abs(&u) + 6.0);
        let tol = inverse_rounding(w.hysteresis(), max_abs(&u), 6.0 + creep_max) + 4.0 * EPS * creep_max;
        assert_identity(&y, &target, &u, tol, "W∘W⁻¹")?;
    }

    /// `W⁻¹[W[v]] = v` from matched states after a random history.
    #[test]
    fn compensator_after_model_is_identity(
        w in model(12),
        prefix in signal(0..50, 6.0),
        v in signal(2..200, 6.0),
    ) {
        let mut plant = w.clone();
        plant.run(&prefix);
        let mut comp = Compensator::new(&plant, CompensatorSettings::unlimited()).unwrap();
        let y = plant.run(&v);
        let back = comp.run(&y);
        let creep_max: f64 = w.creep().unwrap().weights().iter().map(|x| x.abs()).sum::<f64>() * 12.0;
        // The compensator's creep state follows `back`, the plant's `v`: their
        // difference is itself of rounding size, so allow the bound twice.
        let tol = 2.0 * inverse_rounding(w.hysteresis(), 6.0, max_abs(&y) + creep_max);
        assert_identity(&back, &v, &y, tol, "W⁻¹∘W")?;
    }

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

    /// Saturation: after clipped samples the compensator's forward plays equal
    /// the plant's fed with the clipped values — bit for bit — and the identity
    /// `W[W⁻¹[ς]] = ς` holds again as soon as the target is reachable.
    #[test]
    fn saturation_keeps_states_matched_and_the_identity_resumes(
        w in model(12),
        excursion in 2.0f64..5.0,
        limit in 1.0f64..3.0,
        tail in signal(5..60, 0.5),
    ) {
        let settings = CompensatorSettings::with_limits(-limit, limit);
        let mut comp = Compensator::new(&w, settings).unwrap();
        let mut plant = w.clone();
        // From the virgin state |x_i| <= limit, so |W| <= (Σ|w_H| + Σ|w_C|) limit:
        // targets `excursion` times that bound cannot be reached at their peaks.
        let bound = limit
            * w.hysteresis().weights().iter().chain(w.creep().unwrap().weights()).map(|x| x.abs()).sum::<f64>();
        let far: Vec<f64> = (0..40).map(|k| excursion * bound * ((k as f64) * 0.3).sin()).collect();
        let mut any_saturated = false;
        for &t in &far {
            let c = comp.compensate(t);
            prop_assert!(c.u >= -limit && c.u <= limit);
            any_saturated |= c.saturated;
            plant.step(c.u);
        }
        prop_assert!(any_saturated);
        prop_assert_eq!(&comp.state().forward, &plant.state().hysteresis);
        prop_assert_eq!(&comp.state().creep, &plant.state().creep);
        // Reachable targets near the current output: |u| stays well inside.
        let y0 = plant.hysteresis().output() + w.creep().unwrap().output();
        let targets: Vec<f64> = tail.iter().map(|d| y0 + 0.1 * min_slope(w.hysteresis()) * d).collect();
        let mut y = Vec::new();
        for &t in &targets {
            let c = comp.compensate(t);
            if c.saturated { return Ok(()); } // not reachable after all: nothing to check
            y.push(plant.step(c.u));
        }
        let tol = inverse_rounding(w.hysteresis(), limit, excursion * bound + 10.0);
        for (a, b) in y.iter().zip(&targets) {
            prop_assert!((a - b).abs() <= tol, "{a} vs {b}");
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

        let mut comp = Compensator::new(&w, CompensatorSettings::with_limits(-4.0, 4.0)).unwrap();
        let whole_u = comp.clone().run(&whole);
        let mut c1 = comp.clone();
        let mut u = c1.run(&whole[..k]);
        comp.set_state(&c1.state()).unwrap();
        u.extend(comp.run(&whole[k..]));
        prop_assert_eq!(whole_u, u);
    }

    /// Odd symmetry of `W` and of the compensator (symmetric limits) from the
    /// zero state, exactly.
    #[test]
    fn model_and_compensator_are_odd(w in model(12), v in signal(1..120, 6.0)) {
        let neg: Vec<f64> = v.iter().map(|x| -x).collect();
        let (a, b) = (w.clone().run(&v), w.clone().run(&neg));
        prop_assert!(a.iter().zip(&b).all(|(x, y)| *x == -*y));
        let comp = Compensator::new(&w, CompensatorSettings::with_limits(-3.0, 3.0)).unwrap();
        let (a, b) = (comp.clone().run(&v), comp.clone().run(&neg));
        prop_assert!(a.iter().zip(&b).all(|(x, y)| *x == -*y));
    }
}

/// The hand example of SPEC 2.1: `w = (1, 1)`, `r = (0, 1)` has slopes 1 then
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

/// The compensator refuses limits with `lower >= upper` or NaN.
#[test]
fn compensator_settings_are_validated() {
    let w = nominal_model();
    assert!(Compensator::new(&w, CompensatorSettings::with_limits(1.0, -1.0)).is_err());
    assert!(Compensator::new(&w, CompensatorSettings::with_limits(f64::NAN, 1.0)).is_err());
    assert!(CompensatorSettings::default().validate().is_ok());
    assert_eq!(CompensatorSettings::default().upper_limit, 1000.0);
}
