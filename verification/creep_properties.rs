//! Properties of the creep operators (13)–(18), (20): the exact
//! zero-order-hold step, convergence to the dead-zone equilibrium, the log(t)
//! linearity of (15) between `1/a_1` and `1/a_m`, odd symmetry, the
//! semigroup property and the bits of the output's sum.

use crate::common;

use common::*;
use mfcbeam::operators::creep::{
    creep_gain, log_spaced_eigenvalues, ElementaryCreepOperator, LogCreepOperator,
};
use mfcbeam::operators::play::dead_zone;
use mfcbeam::prelude::*;
use proptest::prelude::*;

/// The equilibrium the elementary operator approaches under constant `v`.
fn equilibrium(v: f64, r: f64, chi0: f64) -> f64 {
    if v - chi0 > r {
        v - r
    } else if v - chi0 < -r {
        v + r
    } else {
        chi0
    }
}

/// Classical RK4 for `dχ/dt = a d_r(v − χ)` over one sample in `n` substeps.
fn rk4_sample(chi: f64, v: f64, r: f64, a: f64, ts: f64, n: usize) -> f64 {
    let f = |x: f64| a * dead_zone(v - x, r);
    let h = ts / n as f64;
    let mut x = chi;
    for _ in 0..n {
        let k1 = f(x);
        let k2 = f(x + 0.5 * h * k1);
        let k3 = f(x + 0.5 * h * k2);
        let k4 = f(x + h * k3);
        x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    x
}

proptest! {
    #![proptest_config(config(256, "proptest-regressions/creep_properties.txt"))]

    /// Exact ZOH step (20): under a constant input the discrete operator
    /// equals the closed-form ODE solution `e − (e − χ_0) exp(−a k T_s)` at
    /// every sample (after the one-sample delay), to accumulated rounding.
    #[test]
    fn elementary_creep_is_the_exact_zoh_solution(
        r in 0.0f64..2.0,
        log_a in -2.0f64..3.0,
        log_ts in -4.0f64..-2.0,
        chi0 in -5.0f64..5.0,
        v in -8.0f64..8.0,
        k_max in 1usize..2000,
    ) {
        let (a, ts) = (10f64.powf(log_a), 10f64.powf(log_ts));
        let mut op = ElementaryCreepOperator::new(r, a, ts).unwrap();
        op.set_state(&chi0).unwrap();
        let e = equilibrium(v, r, chi0);
        let scale = e.abs() + chi0.abs() + r;
        for k in 0..=k_max {
            let out = op.step(v); // χ_k, from k updates
            let exact = e - (e - chi0) * (-a * k as f64 * ts).exp();
            let tol = (8.0 * (k as f64 + 1.0) + a * k as f64 * ts) * EPS * scale;
            prop_assert!((out - exact).abs() <= tol, "k = {k}: {out} vs {exact}");
        }
    }

    /// The ZOH step agrees with an independent fine RK4 integration of the ODE
    /// for a random piecewise-constant input; RK4's error is `O((a h)^4)` per
    /// unit of `|v − χ|`, `h = T_s / 64`.
    #[test]
    fn elementary_creep_matches_rk4_integration_of_the_ode(
        r in 0.0f64..1.0,
        a_ts in 1e-3f64..1.0,
        v in signal(1..60, 3.0),
    ) {
        let ts = 1e-3;
        let a = a_ts / ts;
        let n = 64;
        let mut op = ElementaryCreepOperator::new(r, a, ts).unwrap();
        let mut chi = 0.0;
        let tol = (a_ts / n as f64).powi(4) * 10.0 * v.len() as f64 + 64.0 * n as f64 * EPS * 4.0;
        for &vk in &v {
            let out = op.step(vk);
            prop_assert!((out - chi).abs() <= tol, "{out} vs {chi}");
            chi = rk4_sample(chi, vk, r, a, ts, n);
        }
    }

    /// Convergence to the dead-zone equilibrium: under a constant input `χ`
    /// approaches `v ∓ r` (or stays where it is inside the dead zone) as
    /// `exp(−a t)`.
    #[test]
    fn creep_converges_to_the_dead_zone_equilibrium(
        r in 0.0f64..2.0,
        chi0 in -5.0f64..5.0,
        v in -8.0f64..8.0,
    ) {
        let (a, ts) = (50.0, 2e-4);
        let mut op = ElementaryCreepOperator::new(r, a, ts).unwrap();
        op.set_state(&chi0).unwrap();
        let e = equilibrium(v, r, chi0);
        let k = 8000; // a k Ts = 80
        for _ in 0..k {
            op.step(v);
        }
        let chi = op.state();
        prop_assert!((chi - e).abs() <= (-80.0f64).exp() * (e - chi0).abs() + 8.0 * k as f64 * EPS * 10.0);
        // The iteration stops once g·d_r rounds below half an ulp of χ, which
        // leaves |v − χ| − r of order ε |χ| / g with g = 1 − e^{−a T_s}.
        let g = creep_gain(a, ts);
        prop_assert!((v - chi).abs() <= r + 4.0 * EPS * (v.abs() + r) / g);
        if (v - chi0).abs() <= r {
            prop_assert_eq!(chi, chi0);
        }
    }

    /// Odd symmetry of the PI creep operator from the zero state, exactly.
    #[test]
    fn creep_operator_is_odd(c in creep_operator(12), v in signal(1..100, 4.0)) {
        let neg: Vec<f64> = v.iter().map(|x| -x).collect();
        let (a, b) = (c.clone().run(&v), c.clone().run(&neg));
        // exact equality as numbers (the dead zone returns +0.0 for both signs)
        prop_assert!(a.iter().zip(&b).all(|(x, y)| *x == -*y));
    }

    /// Semigroup: split, save the state, resume on a fresh operator:
    /// bit-identical.
    #[test]
    fn creep_split_and_resume_is_bit_identical(
        c in creep_operator(12),
        v in signal(2..100, 4.0),
        split in any::<prop::sample::Index>(),
    ) {
        let k = split.index(v.len());
        let whole = c.clone().run(&v);
        let mut first = c.clone();
        let mut y = first.run(&v[..k]);
        let mut second = c.clone();
        second.set_state(&first.state()).unwrap();
        y.extend(second.run(&v[k..]));
        prop_assert_eq!(whole, y);
    }
}

/// The output (16) summed as stated, each row from zero: lane `i mod 4`
/// adds `(w_i/m) Σ_j χ_ij` (its first term the product alone, each later
/// one fused with the sum), each row sum from `0`, then `(a₀ + a₂) + (a₁ +
/// a₃)`.
fn output_summed_from_zero(c: &CreepOperator) -> f64 {
    let (n, m) = c.shape();
    let mut chi = vec![0.0; n * m];
    c.state_flat_into(&mut chi).unwrap();
    let mut acc = [0.0f64; 4];
    for i in 0..n {
        let mut row = 0.0;
        for j in 0..m {
            row += chi[i * m + j];
        }
        // each weighted row after a lane's first fused with its partial
        // sum, as `std` builds add
        let w = c.weights()[i] / m as f64;
        acc[i % 4] = if i < 4 {
            w * row
        } else {
            w.mul_add(row, acc[i % 4])
        };
    }
    (acc[0] + acc[2]) + (acc[1] + acc[3])
}

/// A state of `len` values from `zeros`: `−0`, `+0` or `0.25` (a state the
/// kernels' sums of rows must keep the sign of zero through).
fn signed_zero_state(len: usize, zeros: &[u8]) -> Vec<f64> {
    (0..len)
        .map(|i| match zeros.get(i).copied().unwrap_or(2) {
            0 => -0.0,
            1 => 0.0,
            _ => 0.25,
        })
        .collect()
}

proptest! {
    #![proptest_config(config(256, "proptest-regressions/creep_properties.txt"))]

    /// The kernels sum each threshold's rows from its first row, one
    /// addition fewer on the step's chain: the output keeps the bits of the
    /// rows summed from zero (as the bank sums them), since the two row
    /// sums differ only where every row is `−0`, and no state holds one: a
    /// state set with zeros of both signs holds `+0`, and no update makes a
    /// `−0`. After every sample on the dispatched and the portable kernels.
    #[test]
    fn creep_output_has_the_bits_of_its_sum_from_zero(
        c in creep_operator(12),
        v in signal(1..40, 4.0),
        zeros in prop::collection::vec(0u8..3, 60),
    ) {
        let (n, m) = c.shape();
        let start = signed_zero_state(n * m, &zeros);
        for portable in [false, true] {
            let mut op = c.clone();
            op.set_state_flat(&start).unwrap();
            let no_negative_zero = |op: &CreepOperator| {
                let mut chi = vec![0.0; n * m];
                op.state_flat_into(&mut chi).unwrap();
                chi.iter().all(|x| x.to_bits() != (-0.0f64).to_bits())
            };
            prop_assert!(no_negative_zero(&op));
            prop_assert_eq!(op.output().to_bits(), output_summed_from_zero(&op).to_bits());
            for &x in &v {
                if portable { op.advance_portable(x); } else { op.advance(x); }
                prop_assert!(no_negative_zero(&op));
                prop_assert_eq!(op.output().to_bits(), output_summed_from_zero(&op).to_bits());
            }
        }
    }

    /// The dispatched creep pass gives the portable bits at every order, in
    /// `f64` and `f32`: 1 to 40 thresholds (whole 8- and 4-lane blocks and
    /// the scalar tail, whichever the kernel set has), states holding zeros
    /// of both signs, and inputs up to `10³⁸`, where `f32` sums overflow.
    #[test]
    fn dispatched_creep_gives_the_portable_bits_at_every_order(
        (c, ts) in creep_operator_at(40),
        v in signal(1..30, 4.0),
        zeros in prop::collection::vec(0u8..3, 240),
        huge in prop::collection::vec(prop::sample::select(vec![0.0, 1e30, -1e38, 3e38]), 3),
    ) {
        let (n, m) = c.shape();
        let start = signed_zero_state(n * m, &zeros);
        let inputs: Vec<f64> = v.iter().chain(&huge).copied().collect();
        let mut fast = c.clone();
        fast.set_state_flat(&start).unwrap();
        let mut slow = fast.clone();
        let make32 = |c: &CreepOperator| {
            let mut op = mfcbeam::realtime::Creep::<f32, mfcbeam::operators::heap::Heap>::new(
                c.thresholds(), c.weights(), c.eigenvalues(), ts,
            ).unwrap();
            op.set_state_flat(&start).unwrap();
            op
        };
        let (mut fast32, mut slow32) = (make32(&c), make32(&c));
        for &x in &inputs {
            prop_assert_eq!(fast.advance(x).to_bits(), slow.advance_portable(x).to_bits());
            let x32 = x as f32;
            prop_assert_eq!(fast32.advance(x32).to_bits(), slow32.advance_portable(x32).to_bits());
        }
        let (mut a, mut b) = (vec![0.0; n * m], vec![0.0; n * m]);
        fast.state_flat_into(&mut a).unwrap();
        slow.state_flat_into(&mut b).unwrap();
        prop_assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
        fast32.state_flat_into(&mut a).unwrap();
        slow32.state_flat_into(&mut b).unwrap();
        prop_assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
    }
}

/// `RoundingBounds` of a creep operator alone, at precision `eps`, virgin.
fn creep_bounds<'a>(
    thresholds: &'a [f64],
    weights: &'a [f64],
    eigenvalues: &'a [f64],
    sample_time: f64,
    eps: f64,
) -> mfcbeam::realtime::RoundingBounds<'a> {
    use mfcbeam::realtime::{CreepParameters, HysteresisParameters, ModelParameters};
    mfcbeam::realtime::RoundingBounds {
        parameters: ModelParameters {
            sample_time,
            hysteresis: HysteresisParameters {
                thresholds: &[0.0],
                weights: &[1.0],
            },
            creep: Some(CreepParameters {
                thresholds,
                weights,
                eigenvalues,
            }),
            superposition: None,
            dynamics: None,
            delay: 0,
            offset: 0.0,
            rate_gain: 0.0,
        },
        state_max: 0.0,
        eps,
    }
}

/// `max_k |C₃₂ − C₆₄|` over the first `k` samples of `v`, from virgin
/// operators: the `f32` real-time operator against the `f64` one.
fn f32_creep_deviations(c: &CreepOperator, sample_time: f64, v: &[f64]) -> Vec<f64> {
    let mut c64 = c.clone();
    let mut c32 = mfcbeam::realtime::Creep::<f32, mfcbeam::operators::heap::Heap>::new(
        c.thresholds(),
        c.weights(),
        c.eigenvalues(),
        sample_time,
    )
    .unwrap();
    let mut worst = 0.0f64;
    v.iter()
        .map(|&x| {
            let d = (f64::from(c32.advance(x as f32)) - c64.advance(x)).abs();
            worst = worst.max(d);
            worst
        })
        .collect()
}

proptest! {
    #![proptest_config(config(64, "proptest-regressions/creep_properties.txt"))]

    /// The creep sum's rounding bound over a run (`creep_sum_over`): after
    /// `k` samples from virgin, the `f32` operator lies within the `f32`
    /// and `f64` bounds for `k` samples of the `f64` one, at every `k`.
    /// Random walks (steps up to a tenth of the amplitude) move the slow
    /// operators by less than an `f32` ulp per sample, where they stall.
    #[test]
    fn f32_creep_stays_within_the_rounding_bound_over_its_samples(
        (c, ts) in creep_operator_at(12),
        steps in prop::collection::vec(-0.1f64..0.1, 100..2000),
        amplitude in 0.5f64..50.0,
    ) {
        let mut x = 0.0f64;
        let v: Vec<f64> = steps
            .iter()
            .map(|d| {
                x = (x + d * amplitude).clamp(-amplitude, amplitude);
                x
            })
            .collect();
        let v_max = max_abs(&v);
        let bound = |eps, k| {
            creep_bounds(c.thresholds(), c.weights(), c.eigenvalues(), ts, eps)
                .creep_sum_over(v_max, k)
        };
        for (k, &worst) in f32_creep_deviations(&c, ts, &v).iter().enumerate() {
            let samples = k as u64 + 1;
            let b = bound(f32::EPSILON as f64, samples) + bound(f64::EPSILON, samples);
            prop_assert!(worst <= b, "after {samples} samples: {worst:e} > {b:e}");
        }
    }
}

/// Where the run is short of the slow operators' time constants the bound
/// over the run is the sharper one, and still holds: the nominal creep (the
/// slowest operator `a = 0.05 s⁻¹`, `1/(aT_s) = 10⁵` samples) under a slow
/// sine in `f32` for 4096 samples. The bound over the run also stays at or
/// below the bound for any run, grows with the run and reaches it.
#[test]
fn the_creep_bound_over_a_run_is_sharper_and_holds() {
    use mfcbeam::realtime::nominal;
    let (r, w, a) = (
        &nominal::THRESHOLDS[..],
        &nominal::CREEP_WEIGHTS[..],
        &nominal::CREEP_EIGENVALUES[..],
    );
    let ts = nominal::PARAMETERS.sample_time;
    let c = CreepOperator::new(r, w, a, ts).unwrap();
    let v: Vec<f64> = (0..4096).map(|k| 600.0 * (k as f64 * 2e-3).sin()).collect();
    let worst = *f32_creep_deviations(&c, ts, &v).last().unwrap();
    let b32 = creep_bounds(r, w, a, ts, f32::EPSILON as f64);
    let b64 = creep_bounds(r, w, a, ts, f64::EPSILON);
    let over = b32.creep_sum_over(600.0, 4096) + b64.creep_sum_over(600.0, 4096);
    let any = b32.creep_sum(600.0) + b64.creep_sum(600.0);
    eprintln!("nominal creep, f32 against f64, 4096 samples: {worst:.3e}; bound over the run {over:.3e}, for any run {any:.3e}");
    assert!(worst > 0.0 && worst <= over, "{worst:e} > {over:e}");
    assert!(over < 0.2 * any, "{over:e} against {any:e}");
    let mut last = 0.0;
    for k in [1u64, 10, 100, 10_000, 1_000_000, 100_000_000] {
        let b = b32.creep_sum_over(600.0, k);
        assert!(b > last && b <= b32.creep_sum(600.0), "{k}: {b:e}");
        last = b;
    }
    // 10⁸ samples are 2000 time constants of the slowest operator: the
    // same bound, to rounding
    let limit = b32.creep_sum(600.0);
    assert!(
        (limit - last).abs() <= 4.0 * f64::EPSILON * limit,
        "{last:e} against {limit:e}"
    );
}

/// log(t) linearity of (15): the step response of the log(t)-creep operator
/// with eigenvalues (24) rises by `(v − r)/m` per decade of time between
/// `1/a_1` and `1/a_m`. Telescoping the sum gives the exact per-decade
/// increment `(v − r)/m · (e^{−a_m t} − e^{−10 a_1 t})`, so the deviation from
/// linearity is at most `a_m t + e^{−10 a_1 t}` (relative).
#[test]
fn log_creep_step_response_is_linear_in_log_t() {
    let ts = 2e-4;
    let m = 5;
    let a = log_spaced_eigenvalues(m, ts);
    let (v, r) = (1.0, 0.25);
    let mut op = LogCreepOperator::new(r, &a, ts).unwrap();
    let k_end = (1.0 / (a[m - 1] * ts)).round() as usize; // t = 1/a_m = 20 s
    let y: Vec<f64> = (0..=k_end).map(|_| op.step(v)).collect();
    let per_decade = (v - r) / m as f64;
    // every sample k from 1/a_1 up to a tenth of 1/a_m, compared with 10 k
    let k_start = (1.0 / (a[0] * ts)).round() as usize;
    let mut checked = 0;
    for k in k_start..=k_end / 10 {
        let t = k as f64 * ts;
        let inc = y[10 * k] - y[k];
        let exact = per_decade * ((-a[m - 1] * t).exp() - (-10.0 * a[0] * t).exp());
        assert!(
            (inc - exact).abs() <= 1e-9 * per_decade,
            "t = {t}: {inc} vs {exact}"
        );
        let dev = (inc - per_decade).abs() / per_decade;
        assert!(
            dev <= a[m - 1] * t + (-10.0 * a[0] * t).exp() + 1e-9,
            "t = {t}: {dev}"
        );
        checked += 1;
    }
    assert!(checked > 9000);
    // and in the middle decades the response is linear to 1 %
    let k_mid = (0.01 / (a[m - 1] * ts)).round() as usize;
    for k in k_start..=k_mid {
        assert!(((y[10 * k] - y[k]) / per_decade - 1.0).abs() <= 0.0101);
    }
}

/// `1 − e^{−aT_s}` as `−expm1(−aT_s)` keeps every digit where the literal form
/// loses five at `a = 0.05 s⁻¹`.
#[test]
fn creep_gain_is_computed_without_cancellation() {
    let g = creep_gain(0.05, 2e-4);
    let x: f64 = 1e-5;
    let series = x - x * x / 2.0 + x * x * x / 6.0;
    assert!((g - series).abs() <= 2.0 * EPS * series);
    // the literal form's error is of order ε / x, thousands of times more
    let literal = 1.0 - (-x).exp();
    assert!((literal - series).abs() > 1000.0 * EPS * series);
}

/// `expm1(x)` for `|x| < 1` in double-double arithmetic (about 106 bits):
/// the Taylor series summed with error-free transformations, returned as
/// `(hi, lo)` with `hi` the sum rounded to f64.
fn expm1_double_double(x: f64) -> (f64, f64) {
    fn two_sum(a: f64, b: f64) -> (f64, f64) {
        let s = a + b;
        let v = s - a;
        (s, (a - (s - v)) + (b - v))
    }
    fn add(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
        let (s, e) = two_sum(a.0, b.0);
        let (hi, lo) = two_sum(s, e + a.1 + b.1);
        (hi, lo)
    }
    fn mul(a: (f64, f64), b: f64) -> (f64, f64) {
        let p = a.0 * b;
        let e = a.0.mul_add(b, -p) + a.1 * b;
        two_sum(p, e)
    }
    fn div(a: (f64, f64), k: f64) -> (f64, f64) {
        let q = a.0 / k;
        let r = mul((q, 0.0), k);
        let rest = add(a, (-r.0, -r.1));
        add((q, 0.0), (rest.0 / k, 0.0))
    }
    let mut term = (x, 0.0);
    let mut sum = term;
    for k in 2..60 {
        term = div(mul(term, x), k as f64);
        sum = add(sum, term);
        if term.0.abs() < 1e-40 * sum.0.abs() {
            break;
        }
    }
    sum
}

/// The creep gains are computed by one `expm1` on every platform and with
/// or without `std` (the `libm` crate's), and at the nominal model's five
/// eigenvalues that one is correctly rounded: the gain is the nearest f64
/// to `1 − e^{−aT_s}` of the rounded `aT_s`, found here in double-double
/// arithmetic. A platform's C library that rounds correctly there gives
/// the same bits; mingw-w64's does not at two of them.
#[test]
fn the_nominal_creep_gains_are_correctly_rounded() {
    let ts = mfcbeam::realtime::nominal::SAMPLE_TIME;
    for a in mfcbeam::realtime::nominal::CREEP_EIGENVALUES {
        let x = -a * ts;
        let (hi, lo) = expm1_double_double(x);
        let ulp = f64::from_bits(hi.abs().to_bits() + 1) - hi.abs();
        // far enough from a midpoint between two f64 for `hi` to be the
        // correctly rounded value despite the reference's own ~2^-100
        assert!(lo.abs() < 0.49 * ulp, "a = {a}: too near a midpoint to say");
        assert_eq!(creep_gain(a, ts).to_bits(), (-hi).to_bits(), "a = {a}");
    }
}

/// Away from the nominal points the gain is within one ulp of the exact
/// value: correct rounding is asserted only at the nominal points above,
/// where it was checked, not promised by `libm` everywhere.
#[test]
fn creep_gains_are_within_an_ulp() {
    for ts in [1e-5, 1e-4, 2e-4, 1e-3] {
        for k in 0..=140 {
            let a = 10f64.powf(-3.0 + k as f64 * 0.05);
            let x = -a * ts;
            if x.abs() >= 1.0 {
                continue;
            }
            let (hi, lo) = expm1_double_double(x);
            let g = creep_gain(a, ts);
            let ulp = f64::from_bits(hi.abs().to_bits() + 1) - hi.abs();
            let err = ((-g - hi) - lo).abs();
            assert!(err <= ulp, "a = {a}, T_s = {ts}: {err:e} > {ulp:e}");
        }
    }
}
