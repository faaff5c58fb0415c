//! Properties of the compensator `W⁻¹` (21): agreement with the reference,
//! `W∘W⁻¹ = id` and `W⁻¹∘W = id` from matched states, the paper's
//! compensated staircase, odd symmetry, the state semantics of the model
//! file, the saturation flags and the recovery after saturation.
//!
//! A model with dead time `d` is compensated with the targets previewed by
//! `d` samples (the file contract's `compensate`): `W[W⁻¹[y]] = y` holds
//! from sample `d` on, and `W⁻¹[W[v]] = v` up to `d` samples before the end
//! (the last `d` targets are held).

use super::candidate;
use super::cases::{
    case_model, delay_of, input_length, random_input, reach, superposition_is_odd,
    superposition_model, with_every_part, with_state_after, ModelShape, Rng,
};
use super::fixed::{resume_from_saved, CompensatorSteps};
use super::{
    compare, compare_from, fail, refused, tolerance, two, Case, ConformanceReport,
    ConformanceSettings,
};
use super::{CompensatorFactory, Outcome, Properties, Property};
use crate::error::ModelError;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::nominal::nominal_model_file;
use crate::operators::traits::{ActuatorCompensator, Compensated, Operator};
use crate::suite::reference::{NaiveCompensator, NaiveModel};
use crate::suite::signal::Staircase;

/// Run every property of the compensator on the implementations `factory` builds.
pub fn check_compensator(
    factory: &CompensatorFactory<'_>,
    settings: &ConformanceSettings,
) -> Result<ConformanceReport, ModelError> {
    compensator_properties().check(factory, settings)
}

/// The properties of the compensator, to run, count or rerun one by name.
pub fn compensator_properties<'a>() -> Properties<CompensatorFactory<'a>> {
    let p = Property::<CompensatorFactory<'a>>::new;
    Properties::new(
        "compensator",
    vec![
        p("agreement", "W⁻¹ equals the naive reference compensator (21), (22) on random models, states and targets", usize::MAX, target_case, agreement),
        p("model_after_compensator", "W[W⁻¹[y]] = y from matched states (no limits)", usize::MAX, target_case, model_after_compensator),
        p("compensator_after_model", "W⁻¹[W[v]] = v from matched states (no limits)", usize::MAX, voltage_case, compensator_after_model),
        p("superposition_inverse", "S alone (H the identity, no creep): S[S⁻¹[y]] = y (no limits)", usize::MAX, superposition_target_case, model_after_compensator).needs_other_models("S alone"),
        p("superposition_left_inverse", "S alone: S⁻¹[S[z]] = z (no limits)", usize::MAX, superposition_voltage_case, compensator_after_model).needs_other_models("S alone"),
        p("paper_staircase", "the Fig. 10 staircase on the nominal model: W[W⁻¹[y_d]] = y_d, nothing saturated", 1, paper_case, model_after_compensator),
        p("odd_symmetry", "W⁻¹[-y] = -W⁻¹[y] from the virgin state with symmetric limits", usize::MAX, virgin_case, odd_symmetry),
        p("split_and_resume", "a compensator from the model file's state continues W⁻¹∘W (state semantics)", usize::MAX, voltage_case, split_and_resume),
        p("saturation_flags", "outputs stay within the limits and exactly the clipped samples are flagged", usize::MAX, saturating_case, saturation_flags),
        p("saturation_recovery", "after clipped samples W[W⁻¹[y]] = y again as soon as y is reachable", usize::MAX, saturating_case, saturation_recovery),
    ],
    )
}

/// The amplitude of random voltages: beyond the largest threshold, but
/// inside a fixed compensator's own limits (its targets stay reachable).
fn voltage_amplitude(s: &ConformanceSettings, model: &crate::operators::model::ModelFile) -> f64 {
    let a = 1.2 * reach(model);
    match s.fixed_limits {
        Some((lo, hi)) => a.min(0.95 * lo.abs().min(hi.abs())),
        None => a,
    }
}

fn settings_of(case: &Case) -> CompensatorSettings {
    super::limit_settings(case.limits)
}

fn build(
    factory: &CompensatorFactory,
    case: &Case,
) -> Result<Box<dyn ActuatorCompensator>, Outcome> {
    factory(&case.model, settings_of(case)).map_err(refused)
}

fn plant(case: &Case) -> NaiveModel {
    NaiveModel::from_file(&case.model).expect("conformance cases are valid models")
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

fn outputs(c: &[Compensated]) -> Vec<f64> {
    c.iter().map(|c| c.u).collect()
}

/// The case with its input replaced by the targets `W[v]` of it (reachable).
fn targets_of(mut case: Case) -> Case {
    case.input = plant(&case).run(&case.input);
    case
}

/// Random model and targets `W[v]` of a random input `v`.
fn target_case(rng: &mut Rng, s: &ConformanceSettings, i: usize) -> Case {
    targets_of(voltage_case(rng, s, i))
}

/// Random model and random voltages `v` (the property maps them through `W`).
fn voltage_case(rng: &mut Rng, s: &ConformanceSettings, i: usize) -> Case {
    let model = case_model(rng, s, ModelShape::Any);
    let n = input_length(rng, s.max_samples);
    let input = random_input(rng, n, voltage_amplitude(s, &model));
    let case = Case {
        model,
        input,
        limits: None,
    };
    if s.fixed_model.is_some() {
        return case;
    }
    with_every_part(rng, s, i, case)
}

/// `S` alone ([`superposition_model`]) and random arguments `z`.
fn superposition_voltage_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let n = input_length(rng, s.max_samples);
    superposition_model(rng, n)
}

/// `S` alone and targets `S[z]` of random arguments.
fn superposition_target_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    targets_of(superposition_voltage_case(rng, s, 0))
}

fn virgin_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let model = case_model(rng, s, ModelShape::Virgin);
    let n = input_length(rng, s.max_samples);
    let r = reach(&model);
    let input = random_input(rng, n, voltage_amplitude(s, &model));
    targets_of(Case {
        model,
        input,
        limits: Some(s.fixed_limits.unwrap_or((-0.8 * r, 0.8 * r))),
    })
}

fn paper_case(_: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let d = CompensatorSettings::default();
    let (model, scale) = super::model::nominal_or_fixed(s, nominal_model_file());
    Case {
        model,
        input: Staircase::full_loop(500.0 * scale, 4, 0.05, 0.2).sample(2e-4),
        limits: Some((d.lower_limit, d.upper_limit)),
    }
}

/// Tight limits and targets far beyond what they allow, then back inside.
fn saturating_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let model = case_model(rng, s, ModelShape::Any);
    let r = reach(&model);
    let limit = match s.fixed_limits {
        Some((lo, hi)) => lo.abs().min(hi.abs()),
        None => rng.uniform(0.2, 0.8) * r,
    };
    let gain: f64 = model
        .hysteresis
        .weights
        .iter()
        .chain(model.creep.iter().flat_map(|c| c.weights.iter()))
        .map(|w| w.abs())
        .sum();
    let excursion = rng.uniform(2.0, 5.0) * gain * (limit + r);
    let n = rng.int(10, s.max_samples.max(10));
    let input = (0..n)
        .map(|k| excursion * (k as f64 * rng.uniform(0.1, 0.5)).sin())
        .collect();
    Case {
        model,
        input,
        limits: Some(s.fixed_limits.unwrap_or((-limit, limit))),
    }
}

fn agreement(case: &Case, factory: &CompensatorFactory, s: &ConformanceSettings) -> Outcome {
    let mut cand = candidate!(build(factory, case));
    let mut reference =
        NaiveCompensator::from_file(&case.model, settings_of(case)).expect("valid case");
    let expected = outputs(&reference.compensate_all(&case.input));
    let found = outputs(&cand.compensate_all(&case.input));
    let tol = s.tolerance_scale
        * tolerance::compensator(&case.model, max_abs(&expected), max_abs(&case.input));
    compare(&case.input, &expected, &found, tol, "u")
}

fn model_after_compensator(
    case: &Case,
    factory: &CompensatorFactory,
    s: &ConformanceSettings,
) -> Outcome {
    let mut cand = candidate!(build(factory, case));
    let out = cand.compensate_all(&case.input);
    if let Some(k) = out.iter().position(|c| c.saturated) {
        let why = if case.limits.is_none() {
            "flagged saturated without limits"
        } else {
            "saturated on a reachable target"
        };
        return fail(
            &case.input,
            &[0.0],
            &[1.0],
            k,
            f64::INFINITY,
            0.0,
            format!("sample {k} {why}"),
        );
    }
    let u = outputs(&out);
    let y = plant(case).run(&u);
    let tol =
        s.tolerance_scale * tolerance::compensator(&case.model, max_abs(&u), max_abs(&case.input));
    let d = delay_of(&case.model);
    compare_from(&case.input, &case.input, &y, d, tol, "W[W⁻¹[y]]")
}

/// The first `n − d` samples: with dead time `d` the last `d` outputs of a
/// previewed run answer the held last target.
fn without_held_tail(x: &[f64], d: usize) -> &[f64] {
    &x[..x.len().saturating_sub(d)]
}

fn compensator_after_model(
    case: &Case,
    factory: &CompensatorFactory,
    s: &ConformanceSettings,
) -> Outcome {
    let mut cand = candidate!(build(factory, case));
    let targets = plant(case).run(&case.input);
    let found = outputs(&cand.compensate_all(&targets));
    let tol = s.tolerance_scale
        * tolerance::compensator(&case.model, max_abs(&case.input), max_abs(&targets));
    let d = delay_of(&case.model);
    compare(
        &targets,
        without_held_tail(&case.input, d),
        without_held_tail(&found, d),
        tol,
        "W⁻¹[W[v]]",
    )
}

fn odd_symmetry(case: &Case, factory: &CompensatorFactory, s: &ConformanceSettings) -> Outcome {
    if !superposition_is_odd(&case.model) {
        return Outcome::Skipped; // an asymmetric S makes W asymmetric
    }
    let mut virgin = case.clone();
    virgin.model.hysteresis.state = None;
    if let Some(c) = &mut virgin.model.creep {
        c.state = None;
    }
    if let Some((lo, hi)) = virgin.limits {
        let l = lo.abs().min(hi.abs());
        virgin.limits = Some((-l, l));
    }
    let (mut a, mut b) = candidate!(two(|| build(factory, &virgin)));
    let neg: Vec<f64> = case.input.iter().map(|x| -x).collect();
    let expected: Vec<f64> = outputs(&a.compensate_all(&case.input))
        .iter()
        .map(|u| -u)
        .collect();
    let found = outputs(&b.compensate_all(&neg));
    let tol = s.exact_or(tolerance::compensator(
        &virgin.model,
        max_abs(&expected),
        max_abs(&case.input),
    ));
    compare(&neg, &expected, &found, tol, "W⁻¹[-y] vs -W⁻¹[y]")
}

fn split_and_resume(case: &Case, factory: &CompensatorFactory, s: &ConformanceSettings) -> Outcome {
    if s.fixed_model.is_some() {
        // the targets W[v], previewed once over the whole signal
        let targets = plant(case).run(&case.input);
        let d = delay_of(&case.model);
        let z: Vec<f64> = (0..targets.len())
            .map(|k| crate::realtime::preview(&targets, d, k))
            .collect();
        let tol = 2.0
            * s.tolerance_scale
            * tolerance::compensator(&case.model, max_abs(&case.input), max_abs(&targets));
        return resume_from_saved(
            &z,
            || factory(&case.model, settings_of(case)).map(CompensatorSteps),
            tol,
        );
    }
    if case.input.len() < 2 {
        return Outcome::Skipped;
    }
    let k = case.input.len() / 2;
    // the plant runs the first half; its state goes into the model file
    let mut p = plant(case);
    p.run(&case.input[..k]);
    let targets = p.run(&case.input[k..]);
    let resumed = Case {
        model: with_state_after(&case.model, &case.input[..k]),
        input: targets.clone(),
        limits: None,
    };
    let mut cand = candidate!(build(factory, &resumed));
    let found = outputs(&cand.compensate_all(&targets));
    let tol = s.tolerance_scale
        * tolerance::compensator(&case.model, max_abs(&case.input), max_abs(&targets));
    let d = delay_of(&case.model);
    compare(
        &targets,
        without_held_tail(&case.input[k..], d),
        without_held_tail(&found, d),
        tol,
        "W⁻¹ from the saved state",
    )
}

fn saturation_flags(case: &Case, factory: &CompensatorFactory, s: &ConformanceSettings) -> Outcome {
    let Some((lo, hi)) = case.limits else {
        return Outcome::Skipped;
    };
    let mut cand = candidate!(build(factory, case));
    let mut reference =
        NaiveCompensator::from_file(&case.model, settings_of(case)).expect("valid case");
    let tol = s.tolerance_scale
        * tolerance::compensator(&case.model, hi.abs().max(lo.abs()), max_abs(&case.input));
    let mut any = false;
    // the candidate's whole run first (an external candidate runs once)
    let found = cand.compensate_all(&case.input);
    let d = delay_of(&case.model);
    for (k, c) in found.iter().enumerate() {
        let r = reference.compensate(crate::realtime::preview(&case.input, d, k));
        any |= r.saturated;
        if !(c.u >= lo && c.u <= hi) {
            return fail(
                &case.input[..=k],
                &[r.u],
                &[c.u],
                k,
                f64::INFINITY,
                0.0,
                format!("sample {k}: output {} outside the limits [{lo}, {hi}]", c.u),
            );
        }
        // a flag may differ only where the unclipped value is within rounding of a limit
        let edge = (reference.last_request() - lo)
            .abs()
            .min((reference.last_request() - hi).abs())
            <= tol;
        if c.saturated != r.saturated && !edge {
            let (e, f) = (
                f64::from(u8::from(r.saturated)),
                f64::from(u8::from(c.saturated)),
            );
            return fail(
                &case.input[..=k],
                &[e],
                &[f],
                k,
                1.0,
                0.0,
                format!("sample {k}: saturated flag {f}, expected {e}"),
            );
        }
    }
    if !any {
        return Outcome::Skipped;
    }
    Outcome::Held {
        error: 0.0,
        tolerance: 0.0,
    }
}

fn saturation_recovery(
    case: &Case,
    factory: &CompensatorFactory,
    s: &ConformanceSettings,
) -> Outcome {
    let Some((lo, hi)) = case.limits else {
        return Outcome::Skipped;
    };
    let mut cand = candidate!(build(factory, case));
    let mut p = plant(case);
    let mut any = false;
    for c in cand.compensate_all(&case.input) {
        // at a limit, flagged or not: the flags are another property's business
        any |= c.saturated || c.u <= lo || c.u >= hi;
        p.step(c.u.clamp(lo, hi));
    }
    if !any {
        return Outcome::Skipped;
    }
    // reachable targets: W of small moves around the plant's last input,
    // well inside the limits, both ways (8 samples: 5.6 rad of the sine),
    // so that a shrunk counterexample stays short
    let last = p.hysteresis.x[0].clamp(0.5 * lo, 0.5 * hi);
    let v: Vec<f64> = (1..=8)
        .map(|j| last + 0.2 * hi.min(-lo) * (j as f64 * 0.7).sin())
        .collect();
    let mut probe = p.clone();
    let targets = probe.run(&v);
    let found = outputs(&cand.compensate_all(&targets));
    let y = p.run(&found);
    let tol = s.tolerance_scale
        * tolerance::compensator(&case.model, hi.abs().max(lo.abs()), max_abs(&case.input));
    let signal = [case.input.clone(), targets.clone()].concat();
    let d = delay_of(&case.model);
    match compare_from(&signal, &targets, &y, d, tol, "W[W⁻¹[y]] after saturation") {
        Outcome::Failed(mut f) => {
            f.sample += case.input.len();
            Outcome::Failed(f)
        }
        o => o,
    }
}
