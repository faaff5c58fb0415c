//! Properties of the play and the Prandtl–Ishlinskii operator, (7)–(12) and
//! SPEC section 10: rate independence, Lipschitz bound, strict monotonicity,
//! odd symmetry and the semigroup property (split and resume).

mod common;

use common::*;
use mfcbeam::prelude::*;
use proptest::prelude::*;

/// Insert `k` linearly interpolated samples between consecutive samples.
fn refine(v: &[f64], k: usize) -> Vec<f64> {
    let mut out = vec![v[0]];
    for w in v.windows(2) {
        for j in 1..=k {
            out.push(w[0] + (w[1] - w[0]) * j as f64 / (k + 1) as f64);
        }
        out.push(w[1]);
    }
    out
}

proptest! {
    #![proptest_config(config(256, "proptest-regressions/hysteresis_properties.txt"))]

    /// Rate independence (7): inserting samples on the monotone segments
    /// between samples changes nothing at the original samples — bit for bit,
    /// because each play output is one of `x`, `v − r`, `v + r` and a later
    /// sample on the same monotone segment dominates an earlier one.
    #[test]
    fn rate_independence_inserting_samples_changes_nothing(
        h in hysteresis_operator(12),
        v in signal(2..60, 6.0),
        k in 1usize..5,
    ) {
        let mut coarse = h.clone();
        let mut fine = h.clone();
        let y = coarse.run(&v);
        let yf = fine.run(&refine(&v, k));
        for (i, &yi) in y.iter().enumerate() {
            prop_assert_eq!(yi.to_bits(), yf[i * (k + 1)].to_bits());
        }
        prop_assert_eq!(coarse.state(), fine.state());
    }

    /// Lipschitz bound: `‖H[u] − H[v]‖∞ ≤ (Σ|w_i|) ‖u − v‖∞` from one state.
    #[test]
    fn lipschitz_bound_from_one_state(
        h in hysteresis_operator(12),
        prefix in signal(0..40, 6.0),
        u in signal(1..80, 6.0),
        noise in signal(80..81, 1.0),
        scale in 1e-6f64..1.0,
    ) {
        let mut start = h.clone();
        start.run(&prefix);
        let v: Vec<f64> = u.iter().zip(&noise).map(|(a, d)| a + scale * d).collect();
        let yu = start.clone().run(&u);
        let yv = start.clone().run(&v);
        let w_abs: f64 = h.weights().iter().map(|w| w.abs()).sum();
        let du = u.iter().zip(&v).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let dy = yu.iter().zip(&yv).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let tol = 2.0 * pi_rounding(&h, 8.0);
        prop_assert!(dy <= w_abs * du + tol, "dy = {dy}, bound = {}", w_abs * du);
    }

    /// Strict monotonicity on monotone inputs when every `s_j > 0` (11): each
    /// increase of the input by `Δ` raises the output by at least `s_min Δ`.
    #[test]
    fn strictly_monotone_on_monotone_inputs(
        h in hysteresis_operator(12),
        prefix in signal(0..40, 6.0),
        steps in prop::collection::vec(1e-3f64..0.5, 1..60),
        down in any::<bool>(),
    ) {
        let mut op = h.clone();
        op.run(&prefix);
        let sign = if down { -1.0 } else { 1.0 };
        let mut v = prefix.last().copied().unwrap_or(0.0);
        let mut y_prev = op.step(v);
        let tol = 2.0 * pi_rounding(&h, 40.0);
        let s_min = min_slope(&h);
        for d in steps {
            v += sign * d;
            let y = op.step(v);
            prop_assert!(sign * (y - y_prev) >= s_min * d - tol);
            prop_assert!(sign * (y - y_prev) > 0.0);
            y_prev = y;
        }
    }

    /// Odd symmetry from the zero state: `H[−v] = −H[v]`, exactly (the clamps
    /// and the sums are odd in floating point too).
    #[test]
    fn odd_symmetry_from_the_zero_state(h in hysteresis_operator(12), v in signal(1..80, 6.0)) {
        let neg: Vec<f64> = v.iter().map(|x| -x).collect();
        let y = h.clone().run(&v);
        let yn = h.clone().run(&neg);
        for (a, b) in y.iter().zip(&yn) {
            prop_assert_eq!(*a, -*b);
        }
    }

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
    let e = h.set_state(&vec![0.0]).unwrap_err();
    assert!(matches!(e, ModelError::LengthMismatch { .. }));
    // a failed set_state leaves the state untouched
    h.step(0.7);
    let before = h.state();
    assert!(h.set_state(&vec![0.0, 5.0]).is_err());
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
