//! The PI operator with rate-dependent thresholds `r_i + g|Δu|` and its
//! exact inverse (docs/MATHEMATICS.md §4.3): with no rate it is `H`; each
//! step is continuous and non-decreasing in its input; the inverse reaches
//! the target and the state of the step it inverts, to rounding (on a flat
//! piece, where rounding decides which of its inputs it takes); a non-finite sample changes
//! nothing; bad parameters are refused.

use mfcbeam::operators::hysteresis::HysteresisOperator;
use mfcbeam::operators::rate_dependent::RateDependentHysteresis;
use mfcbeam::realtime::ParameterError;
use mfcbeam::suite::conformance::Rng;

const TS: f64 = 1e-4;

/// Increasing thresholds from 0 and non-negative weights with `w_0 > 0`.
fn random_parameters(rng: &mut Rng, n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut r = vec![0.0];
    for _ in 1..n {
        let last = *r.last().unwrap();
        r.push(last + rng.uniform(5.0, 80.0));
    }
    let w = (0..n)
        .map(|i| {
            if i == 0 {
                rng.uniform(0.05, 1.0)
            } else if rng.uniform(0.0, 1.0) < 0.2 {
                0.0
            } else {
                rng.uniform(0.0, 0.5)
            }
        })
        .collect();
    (r, w)
}

/// A jagged drive: ramps, jumps and reversals within ±amplitude.
fn random_input(rng: &mut Rng, len: usize, amplitude: f64) -> Vec<f64> {
    let mut u = 0.0f64;
    (0..len)
        .map(|_| {
            let step = if rng.uniform(0.0, 1.0) < 0.05 {
                rng.uniform(-0.5, 0.5) * amplitude
            } else {
                rng.uniform(-0.03, 0.03) * amplitude
            };
            u = (u + step).clamp(-amplitude, amplitude);
            u
        })
        .collect()
}

/// An operator of random parameters and rate gain after a random history.
fn random_operator(rng: &mut Rng) -> (RateDependentHysteresis, f64) {
    let n = 1 + (rng.uniform(0.0, 12.0) as usize);
    let (r, w) = random_parameters(rng, n);
    let beta = rng.uniform(0.0, 0.95) * TS;
    let mut h = RateDependentHysteresis::new(&r, &w, beta, TS).unwrap();
    let amplitude = 1.5 * r.last().unwrap() + 50.0;
    for u in random_input(rng, 200, amplitude) {
        h.step(u);
    }
    (h, amplitude)
}

/// A bound on the magnitude of a step's terms: the input or a state, plus
/// the largest threshold and the rate term `g|u − u_{k−1}|` (at most
/// `2g` times the largest input or state). The sum adds `n` of them, each
/// times a weight: its rounding is within `n ε Σ w_i` times this.
fn scale(h: &RateDependentHysteresis, r_max: f64, u: f64) -> f64 {
    let x = h
        .play_states()
        .iter()
        .chain(h.last_input().as_ref())
        .fold(u.abs(), |m, x| m.max(x.abs()));
    x + r_max + h.gain() * (2.0 * x)
}

#[test]
fn with_no_rate_it_is_h() {
    let mut rng = Rng::new(41);
    for _ in 0..20 {
        let (r, w) = random_parameters(&mut rng, 8);
        let mut rate = RateDependentHysteresis::new(&r, &w, 0.0, TS).unwrap();
        let mut h = HysteresisOperator::new(&r, &w).unwrap();
        // the same plays; the sums may round in another order
        let bound = 8.0 * f64::EPSILON * w.iter().sum::<f64>() * 1000.0;
        for u in random_input(&mut rng, 500, 400.0) {
            let (a, b) = (rate.step(u), h.step(u));
            assert!((a - b).abs() <= bound, "{a} vs {b}");
            assert_eq!(rate.play_states(), h.play_states());
        }
    }
}

#[test]
fn a_step_is_continuous_and_non_decreasing_in_its_input() {
    let mut rng = Rng::new(42);
    for _ in 0..50 {
        let (h, amplitude) = random_operator(&mut rng);
        let states = h.play_states().len() as f64;
        let points = 2000;
        let du = 2.0 * amplitude / points as f64;
        let mut previous = h.output_at(-amplitude);
        for k in 1..=points {
            let u = -amplitude + k as f64 * du;
            let y = h.output_at(u);
            // slopes lie in [0, Σ w_i (1 + g)]; each output carries n
            // roundings of the scale
            let weights_sum = h_weights_sum(&h);
            let r_max = *h.thresholds().last().unwrap();
            let rounding = 8.0 * states * f64::EPSILON * weights_sum * scale(&h, r_max, u);
            assert!(y >= previous - rounding, "u = {u}: {y} after {previous}");
            assert!(
                y - previous <= weights_sum * (1.0 + h.gain()) * du + rounding,
                "u = {u}: a jump of {}",
                y - previous
            );
            previous = y;
        }
    }
}

/// `Σ w_i`: the slope when every play moves, over `1 ± g`.
fn h_weights_sum(h: &RateDependentHysteresis) -> f64 {
    h.weights().iter().sum()
}

#[test]
fn the_inverse_reaches_the_target_and_the_state_of_the_step() {
    let mut rng = Rng::new(43);
    for _ in 0..40 {
        let (mut forward, amplitude) = random_operator(&mut rng);
        let n = forward.play_states().len() as f64;
        let r_max = *forward.thresholds().last().unwrap();
        let weights_sum = h_weights_sum(&forward);
        // the smallest slope off the flat pieces: one play's, w_i (1 − g)
        let slope = forward
            .weights()
            .iter()
            .filter(|&&w| w > 0.0)
            .fold(f64::INFINITY, |m, &w| m.min(w))
            * (1.0 - forward.gain());
        for u in random_input(&mut rng, 400, amplitude) {
            let mut inverse = forward.clone();
            let before = forward.clone();
            let y = forward.step(u);
            let found = inverse.invert(y);
            // y is known to n roundings of the scale; off a flat piece
            // the input to that over the smallest slope
            let s = scale(&before, r_max, u);
            let rounding = 8.0 * n * f64::EPSILON * weights_sum * s;
            let again = before.output_at(found);
            assert!(
                (again - y).abs() <= rounding,
                "y = {y}, W(W⁻¹(y)) = {again}"
            );
            // on a flat piece every weighted play is flat: the same states
            for ((a, b), w) in forward
                .play_states()
                .iter()
                .zip(inverse.play_states())
                .zip(forward.weights())
            {
                if *w > 0.0 {
                    assert!(
                        (a - b).abs() <= (1.0 + forward.gain()) * rounding / slope,
                        "{a} vs {b}"
                    );
                }
            }
        }
    }
}

#[test]
fn inverse_then_forward_reaches_any_target() {
    let mut rng = Rng::new(44);
    for _ in 0..40 {
        let (h, amplitude) = random_operator(&mut rng);
        let n = h.play_states().len() as f64;
        let weights_sum = h_weights_sum(&h);
        for _ in 0..50 {
            let y = rng.uniform(-1.2, 1.2) * weights_sum * amplitude;
            let mut inverse = h.clone();
            let u = inverse.invert(y);
            let s = scale(&h, *h.thresholds().last().unwrap(), u);
            let reached = h.output_at(u);
            assert!(
                (reached - y).abs() <= 8.0 * n * f64::EPSILON * weights_sum * s,
                "target {y}, reached {reached}"
            );
        }
    }
}

#[test]
fn a_non_finite_sample_changes_nothing() {
    let (r, w) = (vec![0.0, 10.0, 30.0], vec![0.5, 0.3, 0.2]);
    let mut h = RateDependentHysteresis::new(&r, &w, 0.5 * TS, TS).unwrap();
    for u in [5.0, 40.0, -12.0] {
        h.step(u);
    }
    h.invert(3.0);
    let before = h.clone();
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(h.step(bad).is_nan());
        assert!(h.invert(bad).is_nan());
        assert_eq!(h, before);
    }
}

#[test]
fn bad_parameters_are_refused() {
    let r = [0.0, 10.0, 30.0];
    let refused =
        |r: &[f64], w: &[f64], beta: f64| RateDependentHysteresis::new(r, w, beta, TS).unwrap_err();
    assert!(matches!(
        refused(&r, &[0.5, -0.1, 0.2], 0.0),
        ParameterError::NegativeWeight { index: 1, .. }
    ));
    assert!(matches!(
        refused(&r, &[0.0, 0.1, 0.2], 0.0),
        ParameterError::PartialSumNotPositive { index: 0, .. }
    ));
    for beta in [-1e-6, TS, 2.0 * TS, f64::NAN] {
        let e = refused(&r, &[0.5, 0.1, 0.2], beta);
        assert!(
            matches!(
                e,
                ParameterError::OutOfHalfOpenRange {
                    field: "rate_gain",
                    ..
                }
            ),
            "{e}"
        );
    }
    assert!(matches!(
        refused(&[0.0, 10.0], &[0.5, 0.1, 0.2], 0.0),
        ParameterError::LengthMismatch { .. }
    ));
    assert!(matches!(
        refused(&[1.0, 10.0, 30.0], &[0.5, 0.1, 0.2], 0.0),
        ParameterError::FirstThresholdNotZero { .. }
    ));
}
