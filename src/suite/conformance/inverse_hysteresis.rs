//! Properties of the inverse PI operator `H⁻¹` (22): agreement with the
//! direct sums of the transformation rules, `H∘H⁻¹ = id` and `H⁻¹∘H = id`
//! from matched admissible states, odd symmetry, rate independence and the
//! state semantics of the model file.

use super::candidate;
use super::cases::{
    case_model, input_length, random_input, reach, refine, with_state_after, ModelShape, Rng,
};
use super::{compare, refused, tolerance, two, Case, ConformanceReport, ConformanceSettings};
use super::{InverseHysteresisFactory, Outcome, Properties, Property};
use crate::error::ModelError;
use crate::operators::traits::{InverseHysteresis, Operator};
use crate::suite::reference::{naive_inverse_hysteresis, NaiveModel};

/// Run every property of the inverse hysteresis on the implementations `factory` builds.
pub fn check_inverse_hysteresis(
    factory: &InverseHysteresisFactory<'_>,
    settings: &ConformanceSettings,
) -> Result<ConformanceReport, ModelError> {
    inverse_hysteresis_properties().check(factory, settings)
}

/// The properties of the inverse hysteresis, to run, count or rerun one by name.
pub fn inverse_hysteresis_properties<'a>() -> Properties<InverseHysteresisFactory<'a>> {
    // every property runs on as many cases as asked
    let p = |name, description, generate, check| {
        Property::<InverseHysteresisFactory<'a>>::new(
            name,
            description,
            usize::MAX,
            generate,
            check,
        )
    };
    Properties::new(
        "inverse hysteresis",
        vec![
            p(
                "agreement",
                "H⁻¹ equals the direct sums of the rules (22) applied to the model's state",
                output_case,
                agreement,
            ),
            p(
                "forward_after_inverse",
                "H[H⁻¹[y]] = y from matched admissible states",
                output_case,
                forward_after_inverse,
            ),
            p(
                "inverse_after_forward",
                "H⁻¹[H[v]] = v from matched admissible states",
                voltage_case,
                inverse_after_forward,
            ),
            p(
                "odd_symmetry",
                "H⁻¹[-y] = -H⁻¹[y] from the virgin state",
                virgin_case,
                odd_symmetry,
            ),
            p(
                "rate_independence",
                "samples inserted on monotone segments change nothing at the original samples",
                virgin_case,
                rate_independence,
            ),
            p(
                "split_and_resume",
                "H⁻¹ built from the model file's state continues H⁻¹∘H (state semantics)",
                voltage_case,
                split_and_resume,
            ),
        ],
    )
}

fn build(
    factory: &InverseHysteresisFactory,
    case: &Case,
) -> Result<Box<dyn InverseHysteresis>, Outcome> {
    factory(&case.model).map_err(refused)
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

fn hysteresis_only(rng: &mut Rng, s: &ConformanceSettings, virgin: bool) -> Case {
    let mut model = case_model(rng, s, ModelShape::HysteresisOnly);
    let r = reach(&model);
    if !virgin && s.fixed_model.is_none() && rng.chance(0.5) {
        let len = rng.int(1, 60);
        let history = random_input(rng, len, 1.2 * r);
        model = with_state_after(&model, &history);
    }
    let n = input_length(rng, s.max_samples);
    let input = random_input(rng, n, 1.2 * r);
    Case {
        model,
        input,
        limits: None,
    }
}

fn forward(case: &Case) -> NaiveModel {
    NaiveModel::from_file(&case.model).expect("conformance cases are valid models")
}

/// Voltages `v` (the property maps them through `H`).
fn voltage_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    hysteresis_only(rng, s, false)
}

/// Outputs `y = H[v]` of a random `v`: the range `H⁻¹` is used on.
fn output_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let mut case = hysteresis_only(rng, s, false);
    case.input = forward(&case).run(&case.input);
    case
}

fn virgin_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let mut case = hysteresis_only(rng, s, true);
    case.input = forward(&case).run(&case.input);
    case
}

fn y_bound(case: &Case, y: &[f64], v: &[f64]) -> f64 {
    tolerance::inverse(&case.model, max_abs(v), max_abs(y))
}

fn agreement(case: &Case, factory: &InverseHysteresisFactory, s: &ConformanceSettings) -> Outcome {
    let mut cand = candidate!(build(factory, case));
    let expected = naive_inverse_hysteresis(&case.model)
        .expect("valid case")
        .run(&case.input);
    let found = cand.run(&case.input);
    let tol = s.tolerance_scale * y_bound(case, &case.input, &expected);
    compare(&case.input, &expected, &found, tol, "H⁻¹")
}

fn forward_after_inverse(
    case: &Case,
    factory: &InverseHysteresisFactory,
    s: &ConformanceSettings,
) -> Outcome {
    let mut cand = candidate!(build(factory, case));
    let v = cand.run(&case.input);
    let y = forward(case).run(&v);
    let tol = s.tolerance_scale * y_bound(case, &case.input, &v);
    compare(&case.input, &case.input, &y, tol, "H[H⁻¹[y]]")
}

fn inverse_after_forward(
    case: &Case,
    factory: &InverseHysteresisFactory,
    s: &ConformanceSettings,
) -> Outcome {
    let mut cand = candidate!(build(factory, case));
    let y = forward(case).run(&case.input);
    let found = cand.run(&y);
    let tol = s.tolerance_scale * y_bound(case, &y, &case.input);
    compare(&y, &case.input, &found, tol, "H⁻¹[H[v]]")
}

fn odd_symmetry(
    case: &Case,
    factory: &InverseHysteresisFactory,
    s: &ConformanceSettings,
) -> Outcome {
    let mut virgin = case.clone();
    virgin.model.hysteresis.state = None;
    let (mut a, mut b) = candidate!(two(|| build(factory, &virgin)));
    let neg: Vec<f64> = case.input.iter().map(|x| -x).collect();
    let expected: Vec<f64> = a.run(&case.input).iter().map(|v| -v).collect();
    let found = b.run(&neg);
    let tol = s.exact_or(y_bound(&virgin, &case.input, &expected));
    compare(&neg, &expected, &found, tol, "H⁻¹[-y] vs -H⁻¹[y]")
}

fn rate_independence(
    case: &Case,
    factory: &InverseHysteresisFactory,
    s: &ConformanceSettings,
) -> Outcome {
    if case.input.len() < 2 {
        return Outcome::Skipped;
    }
    let (mut a, mut b) = candidate!(two(|| build(factory, case)));
    let k = 3;
    let fine = refine(&case.input, k);
    let expected = a.run(&case.input);
    let found: Vec<f64> = b.run(&fine).into_iter().step_by(k + 1).collect();
    let tol = s.exact_or(y_bound(case, &case.input, &expected));
    compare(
        &fine,
        &expected,
        &found,
        tol,
        "refined input at the original samples",
    )
}

fn split_and_resume(
    case: &Case,
    factory: &InverseHysteresisFactory,
    s: &ConformanceSettings,
) -> Outcome {
    if s.fixed_model.is_some() {
        let y = forward(case).run(&case.input);
        let tol = 2.0 * s.tolerance_scale * y_bound(case, &y, &case.input);
        return super::fixed::resume_from_saved(&y, || factory(&case.model), tol);
    }
    if case.input.len() < 2 {
        return Outcome::Skipped;
    }
    let k = case.input.len() / 2;
    let mut h = forward(case);
    h.run(&case.input[..k]);
    let y = h.run(&case.input[k..]);
    let resumed = Case {
        model: with_state_after(&case.model, &case.input[..k]),
        input: y.clone(),
        limits: None,
    };
    let mut cand = candidate!(build(factory, &resumed));
    let found = cand.run(&y);
    let tol = s.tolerance_scale * y_bound(case, &y, &case.input);
    compare(
        &y,
        &case.input[k..],
        &found,
        tol,
        "H⁻¹ from the saved state",
    )
}
