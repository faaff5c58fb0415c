//! Properties of the actuator model `W = H + C` (6) and of its hysteresis
//! part `H` (10): agreement with the reference, the paper's inputs, odd
//! symmetry, the state semantics of the model file (split and resume), and
//! on hysteresis-only models rate independence, monotonicity, the Lipschitz
//! bound, the Madelung rules (i)–(iii), the Masing rule and the intersection
//! property.

use super::candidate;
use super::cases::{
    case_model, input_length, nested_extrema, path, random_dynamics, random_input, reach, refine,
    segment, superposition_is_odd, superposition_model, valid_extrema, with_every_part,
    with_state_after, ModelShape, Rng,
};
use super::fixed::resume_from_saved;
use super::{compare, fail, refused, tolerance, two, Case, ConformanceReport, ConformanceSettings};
use super::{ModelFactory, Outcome, Properties, Property};
use crate::error::ModelError;
use crate::operators::model::{DynamicsData, ModelFile};
use crate::operators::nominal::nominal_model_file;
use crate::operators::traits::{ActuatorModel, Operator};
use crate::realtime::RoundingBounds;
use crate::suite::reference::{NaiveDynamics, NaiveModel};
use crate::suite::signal::Staircase;

/// Run every property of the model on the implementations `factory` builds.
pub fn check_model(
    factory: &ModelFactory<'_>,
    settings: &ConformanceSettings,
) -> Result<ConformanceReport, ModelError> {
    model_properties().check(factory, settings)
}

/// The properties of the model, to run, count or rerun one by name.
pub fn model_properties<'a>() -> Properties<ModelFactory<'a>> {
    let p = Property::<ModelFactory<'a>>::new;
    Properties::new(
        "model",
    vec![
        p("agreement", "W equals the naive reference (10), (16), (20) on random models, states and inputs", usize::MAX, any_case, agreement),
        p("paper_inputs", "W equals the reference on the nominal model and the paper's inputs (Figs. 2, 3, 8a)", 3, paper_case, agreement),
        p("odd_symmetry", "W[-v] = -W[v] from the virgin state (6)", usize::MAX, virgin_case, odd_symmetry),
        p("split_and_resume", "the candidate resumed from the model file's state continues its own whole run (state semantics)", usize::MAX, any_case, split_and_resume),
        p("dynamics_after_memory", "G is linear and acts after S[H + C] only: W with G equals the naive G applied to the candidate's own W without it", usize::MAX, dynamics_case, dynamics_after_memory).needs_other_models("the same model without G"),
        p("rate_independence", "H: samples inserted on monotone segments change nothing at the original samples (7)", usize::MAX, hysteresis_case, rate_independence).needs_hysteresis_alone(),
        p("monotonicity", "H: on a monotone input the output moves the same way with slope >= s_min (11)", usize::MAX, hysteresis_case, monotonicity).needs_hysteresis_alone(),
        p("superposition_monotone", "S alone: on an increasing input each output step lies between its smallest and largest slope times the input step", usize::MAX, superposition_case, superposition_monotone).needs_other_models("S alone"),
        p("lipschitz", "H: |H[u] - H[v]| <= (sum |w_i|) max |u - v| from one state (10)", usize::MAX, hysteresis_case, lipschitz).needs_hysteresis_alone(),
        p("madelung_turning_point", "H: a minor loop wiped out earlier leaves the curve from a turning point unchanged (Madelung i)", usize::MAX, extrema_case, madelung_i).needs_hysteresis_alone(),
        p("madelung_return_point", "H: from p1 to p2 and back returns exactly to p1 (Madelung ii, return-point memory)", usize::MAX, extrema_case, madelung_ii).needs_hysteresis_alone(),
        p("madelung_wiping_out", "H: continued beyond p1 the curve is the one that led to p1 (Madelung iii)", usize::MAX, extrema_case, madelung_iii).needs_hysteresis_alone(),
        p("masing", "H: a branch from a turning point is the initial loading curve scaled by 2 (Masing)", usize::MAX, extrema_case, masing).needs_hysteresis_alone(),
        p("intersection", "H: branches from different histories meet at one point with different slopes (Fig. 8b)", 1, nominal_hysteresis_case, intersection).needs_hysteresis_alone(),
    ],
    )
}

fn build(factory: &ModelFactory, case: &Case) -> Result<Box<dyn ActuatorModel>, Outcome> {
    factory(&case.model).map_err(refused)
}

fn reference(case: &Case) -> NaiveModel {
    NaiveModel::from_file(&case.model).expect("conformance cases are valid models")
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

fn input_len(rng: &mut Rng, settings: &ConformanceSettings) -> usize {
    input_length(rng, settings.max_samples)
}

/// A random model of `shape` and a random input reaching beyond its thresholds.
fn signal_case(rng: &mut Rng, s: &ConformanceSettings, shape: ModelShape) -> Case {
    let model = case_model(rng, s, shape);
    let n = input_len(rng, s);
    let input = random_input(rng, n, 1.2 * reach(&model));
    Case {
        model,
        input,
        limits: None,
    }
}

/// `S` alone ([`superposition_model`]) on a sorted input: a monotone sweep.
fn superposition_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let n = input_len(rng, s);
    let mut case = superposition_model(rng, n);
    case.input.sort_by(f64::total_cmp);
    case
}

fn any_case(rng: &mut Rng, s: &ConformanceSettings, i: usize) -> Case {
    let case = signal_case(rng, s, ModelShape::Any);
    if s.fixed_model.is_some() {
        return case;
    }
    with_every_part(rng, s, i, case)
}

fn virgin_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    signal_case(rng, s, ModelShape::Virgin)
}

fn hysteresis_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    signal_case(rng, s, ModelShape::HysteresisOnly)
}

fn extrema_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let model = case_model(rng, s, ModelShape::HysteresisOnly);
    let input = nested_extrema(rng, 1.2 * reach(&model));
    Case {
        model,
        input,
        limits: None,
    }
}

/// The paper's inputs on the nominal model, shortened to 1.6 s (8000
/// samples) so that slow candidates run them quickly: the Fig. 3 staircase,
/// the Fig. 2 rectangle and the Fig. 8a nested reversals.
pub(crate) fn paper_input(i: usize) -> Vec<f64> {
    match i % 3 {
        0 => Staircase::full_loop(1000.0, 4, 0.02, 0.08).sample(2e-4),
        1 => (0..8_000)
            .map(|k| {
                if (1000..5000).contains(&k) {
                    500.0
                } else {
                    0.0
                }
            })
            .collect(),
        _ => path(
            &[
                900.0, -900.0, 600.0, -300.0, 400.0, 0.0, 300.0, -300.0, 400.0,
            ],
            200,
        ),
    }
}

/// The nominal model, or in the fixed mode the fixed model, and how much
/// inputs made for the nominal model are scaled for it (1 for the nominal
/// model itself).
pub(crate) fn nominal_or_fixed(s: &ConformanceSettings, nominal: ModelFile) -> (ModelFile, f64) {
    match &s.fixed_model {
        Some(m) => (m.clone(), reach(m) / reach(&nominal)),
        None => (nominal, 1.0),
    }
}

fn paper_case(_: &mut Rng, s: &ConformanceSettings, i: usize) -> Case {
    let (model, scale) = nominal_or_fixed(s, nominal_model_file());
    Case {
        model,
        input: paper_input(i).iter().map(|v| scale * v).collect(),
        limits: None,
    }
}

fn nominal_hysteresis_case(_: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let mut nominal = nominal_model_file();
    nominal.creep = None;
    let (model, scale) = nominal_or_fixed(s, nominal);
    Case {
        model,
        input: vec![200.0 * scale, 1000.0 * scale, 900.0 * scale],
        limits: None,
    }
}

fn agreement(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    let mut cand = candidate!(build(factory, case));
    let expected = reference(case).run(&case.input);
    let found = cand.run(&case.input);
    let tol = s.tolerance_scale * tolerance::model(&case.model, max_abs(&case.input));
    compare(&case.input, &expected, &found, tol, "W")
}

/// A random model with dynamics (when the settings draw them; else the
/// property skips).
fn dynamics_case(rng: &mut Rng, s: &ConformanceSettings, _: usize) -> Case {
    let mut case = signal_case(rng, s, ModelShape::Any);
    if s.dynamics {
        case.model.dynamics = Some(random_dynamics(rng, case.model.sample_time));
    }
    case
}

/// `y = G[S[H + C]]` delayed, plus the offset: the candidate's output with
/// `G` (from rest) against the naive `G` applied to its own output without
/// it (offset removed and put back; `G` commutes with the dead time, both
/// at rest on the first value). Two runs of the candidate and one of `G`.
fn dynamics_after_memory(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    let Some(g) = &case.model.dynamics else {
        return Outcome::Skipped;
    };
    let mut with = case.model.clone();
    with.dynamics = Some(DynamicsData {
        state: None,
        ..g.clone()
    });
    with.delay_state = None;
    let mut without = with.clone();
    without.dynamics = None;
    let plain = Case {
        model: without,
        ..case.clone()
    };
    let dynamic = Case {
        model: with,
        ..case.clone()
    };
    let mut a = candidate!(build(factory, &plain));
    let mut b = candidate!(build(factory, &dynamic));
    let offset = case.model.offset.unwrap_or(0.0);
    let mut naive = NaiveDynamics::of(&dynamic.model).expect("the case has dynamics");
    let expected: Vec<f64> = a
        .run(&case.input)
        .into_iter()
        .map(|y| naive.step(y - offset) + offset)
        .collect();
    let found = b.run(&case.input);
    let tol = 2.0 * s.tolerance_scale * tolerance::model(&dynamic.model, max_abs(&case.input));
    compare(
        &case.input,
        &expected,
        &found,
        tol,
        "W with G against G[W without G]",
    )
}

/// On an increasing input, `S` alone moves by between `σ_min` and `σ_max`
/// times each input step (its smallest and largest slope): each output step
/// is compared with itself clamped into that interval, within the rounding
/// of two outputs.
fn superposition_monotone(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    if case.model.superposition.is_none() {
        return Outcome::Skipped;
    }
    let (lo, hi) = RoundingBounds {
        parameters: case.model.parameters(),
        state_max: 0.0,
        eps: f64::EPSILON,
    }
    .superposition_slopes();
    let mut cand = candidate!(build(factory, case));
    let v = &case.input;
    let found: Vec<f64> = cand.run(v).windows(2).map(|y| y[1] - y[0]).collect();
    let expected: Vec<f64> = v
        .windows(2)
        .zip(&found)
        .map(|(v, &dy)| dy.clamp(lo * (v[1] - v[0]), hi * (v[1] - v[0])))
        .collect();
    let tol = 2.0 * s.tolerance_scale * tolerance::model(&case.model, max_abs(v));
    compare(
        v,
        &expected,
        &found,
        tol,
        "output step against [σ_min, σ_max] × input step",
    )
}

fn odd_symmetry(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    if !superposition_is_odd(&case.model) {
        return Outcome::Skipped; // an asymmetric S makes W asymmetric
    }
    let mut model = case.model.clone();
    model.hysteresis.state = None;
    if let Some(c) = &mut model.creep {
        c.state = None;
    }
    let virgin = Case {
        model,
        ..case.clone()
    };
    let (mut a, mut b) = candidate!(two(|| build(factory, &virgin)));
    let neg: Vec<f64> = case.input.iter().map(|x| -x).collect();
    let expected: Vec<f64> = a.run(&case.input).iter().map(|y| -y).collect();
    let found = b.run(&neg);
    let tol = s.exact_or(tolerance::model(&virgin.model, max_abs(&case.input)));
    compare(&neg, &expected, &found, tol, "W[-v] vs -W[v]")
}

/// The candidate's own whole run against the candidate resumed, half way,
/// from the model file's state (the reference's state after the first
/// half): state semantics alone, whatever the candidate's outputs (those
/// are `agreement`'s).
fn split_and_resume(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    let tol = 2.0 * s.tolerance_scale * tolerance::model(&case.model, max_abs(&case.input));
    if s.fixed_model.is_some() {
        return resume_from_saved(&case.input, || factory(&case.model), tol);
    }
    if case.input.len() < 2 {
        return Outcome::Skipped;
    }
    let k = case.input.len() / 2;
    let mut cand = candidate!(build(factory, case));
    let whole = cand.run(&case.input);
    let resumed = Case {
        model: with_state_after(&case.model, &case.input[..k]),
        input: case.input[k..].to_vec(),
        limits: None,
    };
    let mut cand = candidate!(build(factory, &resumed));
    let found = cand.run(&resumed.input);
    // two runs, each within the rounding bound of the exact outputs
    compare(
        &resumed.input,
        &whole[k..],
        &found,
        tol,
        "second half from the saved state against the whole run",
    )
}

fn hysteresis_only(case: &Case) -> bool {
    case.model.creep.is_none() && case.model.dynamics.is_none()
}

fn rate_independence(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    if !hysteresis_only(case) || case.input.len() < 2 {
        return Outcome::Skipped;
    }
    let (mut a, mut b) = candidate!(two(|| build(factory, case)));
    let k = 3;
    let fine = refine(&case.input, k);
    let expected = a.run(&case.input);
    let found: Vec<f64> = b.run(&fine).into_iter().step_by(k + 1).collect();
    let tol = s.exact_or(tolerance::model(&case.model, max_abs(&case.input)));
    compare(
        &fine,
        &expected,
        &found,
        tol,
        "refined input at the original samples",
    )
}

fn monotonicity(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    if !hysteresis_only(case) || case.input.is_empty() {
        return Outcome::Skipped;
    }
    let mut cand = candidate!(build(factory, case));
    // the input as a history, then a monotone ramp in the direction of its sign
    let r = reach(&case.model);
    let start = case.input[case.input.len() - 1];
    let dir = if start >= 0.0 { -1.0 } else { 1.0 };
    let ramp: Vec<f64> = (1..=20)
        .map(|j| start + dir * 0.15 * r * j as f64)
        .collect();
    cand.run(&case.input);
    let mut signal = vec![start];
    signal.extend(&ramp);
    let y = cand.run(&signal);
    let s_min = tolerance::min_slope(&case.model);
    let tol = s.tolerance_scale * tolerance::model(&case.model, max_abs(&signal));
    // required: dir (y_{k+1} − y_k) >= s_min |Δv| − tol; compare the deficit with 0
    let deficit: Vec<f64> = y
        .windows(2)
        .zip(signal.windows(2))
        .map(|(yw, vw)| (s_min * (vw[1] - vw[0]).abs() - dir * (yw[1] - yw[0])).max(0.0))
        .collect();
    compare(
        &signal,
        &vec![0.0; deficit.len()],
        &deficit,
        tol,
        "slope deficit on a monotone input",
    )
}

fn lipschitz(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    if !hysteresis_only(case) || case.input.len() < 2 {
        return Outcome::Skipped;
    }
    let (mut a, mut b) = candidate!(two(|| build(factory, case)));
    // a perturbation of alternating sign, 1 % of the reach
    let d = 0.01 * reach(&case.model);
    let v: Vec<f64> = case
        .input
        .iter()
        .enumerate()
        .map(|(k, x)| x + if k % 3 == 0 { d } else { -0.5 * d })
        .collect();
    let w_abs: f64 = case.model.hysteresis.weights.iter().map(|w| w.abs()).sum();
    let yu = a.run(&case.input);
    let yv = b.run(&v);
    let tol = s.tolerance_scale * tolerance::model(&case.model, max_abs(&v));
    let excess: Vec<f64> = yu
        .iter()
        .zip(&yv)
        .map(|(p, q)| ((p - q).abs() - w_abs * d).max(0.0))
        .collect();
    compare(
        &v,
        &vec![0.0; excess.len()],
        &excess,
        tol,
        "|H[u] - H[v]| beyond the Lipschitz bound",
    )
}

/// Extrema and the reversal fraction of an extrema case, if valid.
fn extrema(case: &Case) -> Option<(&[f64], f64)> {
    (hysteresis_only(case) && valid_extrema(&case.input)).then(|| {
        (
            &case.input[..case.input.len() - 1],
            case.input[case.input.len() - 1],
        )
    })
}

/// The extrema of an extrema case, its last turning point `p1 = e_k` and
/// the reversal `p2 = p1 + g (e_{k−1} − p1)` inside the last branch
/// (Madelung II and III).
fn last_reversal(case: &Case) -> Option<(&[f64], f64, f64)> {
    let (e, g) = extrema(case)?;
    let p1 = e[e.len() - 1];
    Some((e, p1, p1 + g * (e[e.len() - 2] - p1)))
}

const SUB: usize = 3;

fn madelung_i(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    let Some((e, g)) = extrema(case) else {
        return Outcome::Skipped;
    };
    let k = e.len() - 1;
    if k < 2 {
        return Outcome::Skipped;
    }
    // a minor loop at e_1 toward e_2, wiped out by the move to e_2
    let mut looped = e[..=1].to_vec();
    looped.extend([e[1] + g * (e[2] - e[1]), e[1]]);
    looped.extend_from_slice(&e[2..]);
    let tail = segment(e[k], e[k - 1], 7);
    let (mut a, mut b) = candidate!(two(|| build(factory, case)));
    a.run(&path(e, SUB));
    let signal = [path(&looped, SUB), tail.clone()].concat();
    b.run(&path(&looped, SUB));
    let expected = a.run(&tail);
    let found = b.run(&tail);
    let tol = s.exact_or(tolerance::model(&case.model, max_abs(e)));
    compare(
        &signal,
        &expected,
        &found,
        tol,
        "curve from the last turning point",
    )
}

fn madelung_ii(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    let Some((e, p1, p2)) = last_reversal(case) else {
        return Outcome::Skipped;
    };
    let mut cand = candidate!(build(factory, case));
    let first = path(e, SUB);
    let y_p1 = *cand.run(&first).last().expect("a path has samples");
    let out = segment(p1, p2, SUB);
    let back = segment(p2, p1, SUB);
    cand.run(&out);
    let y_back = *cand.run(&back).last().expect("a segment has samples");
    let signal = [first, out, back].concat();
    let tol = s.exact_or(tolerance::model(&case.model, max_abs(e)));
    compare(&signal, &[y_p1], &[y_back], tol, "output back at p1")
}

fn madelung_iii(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    let Some((e, p1, p2)) = last_reversal(case) else {
        return Outcome::Skipped;
    };
    let dir = (p1 - e[e.len() - 2]).signum();
    let onward = segment(p1, p1 + dir * 0.5 * reach(&case.model), 9);
    let (mut a, mut b) = candidate!(two(|| build(factory, case)));
    a.run(&path(e, SUB));
    let expected = a.run(&onward);
    let signal = [
        path(e, SUB),
        segment(p1, p2, SUB),
        segment(p2, p1, SUB),
        onward.clone(),
    ]
    .concat();
    b.run(&signal[..signal.len() - onward.len()]);
    let found = b.run(&onward);
    let tol = s.exact_or(tolerance::model(&case.model, max_abs(&signal)));
    compare(
        &signal,
        &expected,
        &found,
        tol,
        "continuation beyond p1 after the minor loop",
    )
}

fn masing(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    let Some((e, _)) = extrema(case) else {
        return Outcome::Skipped;
    };
    let k = e.len() - 1;
    let (u_r, target) = (e[k], e[k - 1]);
    let dir = (target - u_r).signum();
    let branch = segment(u_r, target, 23);
    // the initial loading curve φ of the candidate itself, from the virgin
    // state along one monotone ramp through every |u − u_R|/2 needed
    let half: Vec<f64> = branch.iter().map(|u| (u - u_r).abs() / 2.0).collect();
    let mut virgin_case = case.clone();
    virgin_case.model.hysteresis.state = None;
    let (mut hist, mut virgin) = match (build(factory, case), build(factory, &virgin_case)) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(o), _) | (_, Err(o)) => return o,
    };
    let mut ramp = vec![0.0];
    ramp.extend(&half);
    let phi = virgin.run(&ramp);
    let first = path(e, SUB);
    let y_r = *hist.run(&first).last().expect("a path has samples");
    let found = hist.run(&branch);
    let expected: Vec<f64> = phi[1..].iter().map(|p| y_r + dir * 2.0 * p).collect();
    let tol = 4.0 * s.tolerance_scale * tolerance::model(&case.model, max_abs(e));
    compare(
        &[first, branch].concat(),
        &expected,
        &found,
        tol,
        "branch vs 2 φ(|u - u_R|/2)",
    )
}

/// Branch slopes at `(u*, y*)`: the virgin curve's, then for each top of
/// the case the ascending branch's from the reversal (found by bisection on
/// `run`) whose branch passes through the point. `Err` carries a failure:
/// a branch that does not reach the point.
fn intersection_slopes(
    case: &Case,
    run: impl Fn(&[f64]) -> Result<Vec<f64>, Outcome>,
    tol: impl Fn(f64) -> f64,
) -> Result<Vec<f64>, Outcome> {
    let (u_star, tops) = (case.input[0], &case.input[1..]);
    let virgin = run(&[segment(0.0, u_star, 5), vec![u_star + 1.0]].concat())?;
    let y_star = virgin[virgin.len() - 2];
    let tol = tol(y_star);
    let mut slopes = vec![virgin[virgin.len() - 1] - y_star];
    for &top in tops {
        let branch = |m: f64| {
            [
                path(&[top, m], 5),
                segment(m, u_star, 5),
                vec![u_star + 1.0],
            ]
            .concat()
        };
        let (mut lo, mut hi) = (-top, u_star - 1e-9);
        // 50 halvings of ~1000 V: the reversal to 1e-12 V
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            let y = run(&branch(mid))?;
            if y[y.len() - 2] < y_star {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let signal = branch(hi);
        let y = run(&signal)?;
        let y_at = y[y.len() - 2];
        if (y_at - y_star).abs() > tol {
            return Err(fail(
                &signal,
                &[y_star],
                &[y_at],
                signal.len() - 2,
                (y_at - y_star).abs(),
                tol,
                "the branch does not reach the point".into(),
            ));
        }
        slopes.push(y[y.len() - 1] - y_at);
    }
    Ok(slopes)
}

/// Two branch slopes closer than this merge.
const MERGE: f64 = 1e-6;

/// The first pair of slopes that merge.
fn merging(slopes: &[f64]) -> Option<(usize, usize)> {
    (0..slopes.len())
        .flat_map(|i| (0..i).map(move |j| (j, i)))
        .find(|&(j, i)| (slopes[i] - slopes[j]).abs() <= MERGE)
}

fn intersection(case: &Case, factory: &ModelFactory, s: &ConformanceSettings) -> Outcome {
    if !hysteresis_only(case) || case.input.len() != 3 {
        return Outcome::Skipped;
    }
    let tol = |y_star: f64| {
        s.tolerance_scale * (tolerance::model(&case.model, 1000.0) + 1e-9 * y_star.abs())
    };
    // the premise, on the reference: its branches cross (a model shrunk to
    // one play, say, has none that do)
    let naive = |signal: &[f64]| -> Result<Vec<f64>, Outcome> { Ok(reference(case).run(signal)) };
    match intersection_slopes(case, naive, tol) {
        Ok(slopes) if merging(&slopes).is_none() => {}
        _ => return Outcome::Skipped,
    }
    let run =
        |signal: &[f64]| -> Result<Vec<f64>, Outcome> { Ok(build(factory, case)?.run(signal)) };
    let slopes = match intersection_slopes(case, run, tol) {
        Ok(slopes) => slopes,
        Err(o) => return o,
    };
    if let Some((j, i)) = merging(&slopes) {
        return fail(
            &case.input,
            &[slopes[j]],
            &[slopes[i]],
            i,
            (slopes[i] - slopes[j]).abs(),
            MERGE,
            format!(
                "branches {j} and {i} merge instead of crossing (slopes closer than {MERGE:e}, as the reference's are not): slopes {slopes:?}"
            ),
        );
    }
    Outcome::Held {
        error: 0.0,
        tolerance: tol(0.0),
    }
}
