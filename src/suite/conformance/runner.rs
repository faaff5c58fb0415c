//! Running the properties: each on its own seeded generator, spread over
//! the cores, and a failing case shrunk to a small counterexample.

use super::*;
use crate::error::ModelError;
use crate::operators::model::ModelFile;

thread_local! {
    /// The property and case this thread is checking.
    static CURRENT: std::cell::Cell<Option<(&'static str, usize)>> =
        const { std::cell::Cell::new(None) };
}

/// The property and the index of the case the calling thread is checking
/// (shrunk or not), if it is checking one: what a candidate that ends the
/// process is reported with.
pub fn current_case() -> Option<(&'static str, usize)> {
    CURRENT.with(|c| c.get())
}

/// Run every property on `factory`, the properties spread over the
/// available cores (each has its own seeded generator, so the result does
/// not depend on the scheduling).
pub(crate) fn run_properties<F: ?Sized + Sync>(
    kind: &'static str,
    properties: &[Property<F>],
    factory: &F,
    settings: &ConformanceSettings,
) -> Result<ConformanceReport, ModelError> {
    settings.validate()?;
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(properties.len())
        .max(1);
    let mut results: Vec<Option<PropertyResult>> = vec![None; properties.len()];
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                scope.spawn(move || {
                    (t..properties.len())
                        .step_by(threads)
                        .map(|pi| (pi, run_property(pi, &properties[pi], factory, settings)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for h in handles {
            for (pi, r) in h.join().expect("a property check panicked") {
                results[pi] = Some(r);
            }
        }
    });
    Ok(ConformanceReport {
        kind,
        properties: results
            .into_iter()
            .map(|r| r.expect("every property ran"))
            .collect(),
    })
}

fn run_property<F: ?Sized>(
    pi: usize,
    p: &Property<F>,
    factory: &F,
    settings: &ConformanceSettings,
) -> PropertyResult {
    let mut rng = Rng::new(settings.seed ^ (0x9e37_79b9 * (pi as u64 + 1)));
    let mut result = PropertyResult {
        name: p.name,
        description: p.description,
        cases: 0,
        skipped: 0,
        skip_reason: None,
        failures: 0,
        worst_ratio: 0.0,
        worst_error: 0.0,
        tolerance: 0.0,
        counterexample: None,
        not_on_fixed_model: None,
    };
    if let Some(fixed) = &settings.fixed_model {
        let has_creep = fixed.creep.is_some() && !settings.hysteresis_only;
        result.not_on_fixed_model = p
            .not_on_fixed_model
            .or((p.hysteresis_alone && has_creep).then_some("needs H alone; the model has creep"));
        if result.not_on_fixed_model.is_some() {
            return result;
        }
    }
    for i in 0..settings.cases.min(p.max_cases) {
        let case = (p.generate)(&mut rng, settings, i);
        let case = if settings.hysteresis_only {
            case.hysteresis_part()
        } else {
            case
        };
        CURRENT.with(|c| c.set(Some((p.name, i))));
        let outcome = evaluate(|| (p.check)(&case, factory, settings));
        let (error, tolerance) = match &outcome {
            Outcome::Skipped => continue,
            Outcome::Unsupported(reason) => {
                result.skipped += 1;
                result.skip_reason.get_or_insert_with(|| reason.clone());
                continue;
            }
            Outcome::Held { error, tolerance } => (*error, *tolerance),
            Outcome::Failed(f) => (f.error, f.tolerance),
        };
        result.cases += 1;
        let ratio = if error == 0.0 {
            0.0
        } else if tolerance > 0.0 {
            error / tolerance
        } else {
            f64::INFINITY
        };
        if ratio > result.worst_ratio || result.cases == 1 {
            result.worst_ratio = ratio;
            result.worst_error = error;
            result.tolerance = tolerance;
        }
        if let Outcome::Failed(failure) = outcome {
            result.failures += 1;
            if result.counterexample.is_none() {
                let (unshrunk_case, unshrunk_failure) = (case.clone(), (*failure).clone());
                let (case, failure) = if settings.shrink {
                    shrink(case, *failure, settings.shrink_budget, |c| {
                        evaluate(|| (p.check)(c, factory, settings))
                    })
                } else {
                    (case, *failure)
                };
                result.counterexample = Some(Counterexample {
                    case_index: i,
                    case,
                    failure,
                    unshrunk_case,
                    unshrunk_failure,
                });
            }
        }
    }
    CURRENT.with(|c| c.set(None));
    result
}

/// Make a failing case smaller while it still fails: a shorter input (cut
/// after the failing sample, then chunks and single samples removed), a
/// smaller model (state, creep, eigenvalues, thresholds dropped), rounder
/// numbers.
pub(crate) fn shrink(
    case: Case,
    failure: Failure,
    budget: usize,
    check: impl Fn(&Case) -> Outcome,
) -> (Case, Failure) {
    let mut best = (case, failure);
    let mut budget = budget;
    let attempt = |c: Case, best: &mut (Case, Failure), budget: &mut usize| -> bool {
        if *budget == 0 || HysteresisCreepModel::from_file(&c.model).is_err() {
            return false;
        }
        *budget -= 1;
        if let Outcome::Failed(f) = check(&c) {
            *best = (c, *f);
            true
        } else {
            false
        }
    };
    for _pass in 0..4 {
        let mut progress = false;
        // 1. cut the input after the failing sample
        let cut = best.1.sample + 1;
        if cut < best.0.input.len() {
            let mut c = best.0.clone();
            c.input.truncate(cut);
            progress |= attempt(c, &mut best, &mut budget);
        }
        // 2. remove chunks of the input, halving their size
        let mut size = best.0.input.len() / 2;
        while size >= 1 && budget > 0 {
            let mut start = 0;
            while start + size <= best.0.input.len() && best.0.input.len() > size {
                let mut c = best.0.clone();
                c.input.drain(start..start + size);
                if !attempt(c, &mut best, &mut budget) {
                    start += size;
                } else {
                    progress = true;
                }
            }
            size /= 2;
        }
        // 3. a smaller model
        for reduce in MODEL_REDUCTIONS {
            loop {
                let mut c = best.0.clone();
                if !reduce(&mut c.model) || !attempt(c, &mut best, &mut budget) {
                    break;
                }
                progress = true;
            }
        }
        // 4. rounder numbers
        for digits in [0i32, 1, 2, 3] {
            let mut c = best.0.clone();
            let before = c.clone();
            round_case(&mut c, digits);
            if c != before && attempt(c, &mut best, &mut budget) {
                progress = true;
                break;
            }
        }
        if !progress || budget == 0 {
            break;
        }
    }
    best
}

type Reduction = fn(&mut ModelFile) -> bool;

const MODEL_REDUCTIONS: [Reduction; 6] = [
    |m| {
        let had =
            m.hysteresis.state.is_some() || m.creep.as_ref().is_some_and(|c| c.state.is_some());
        m.hysteresis.state = None;
        if let Some(c) = &mut m.creep {
            c.state = None;
        }
        had
    },
    |m| m.creep.take().is_some(),
    |m| match &mut m.creep {
        Some(c) if c.eigenvalues.len() > 1 => {
            c.eigenvalues.pop();
            if let Some(s) = &mut c.state {
                s.iter_mut().for_each(|row| {
                    row.pop();
                });
            }
            true
        }
        _ => false,
    },
    |m| match &mut m.creep {
        Some(c) if c.thresholds.len() > 1 => {
            c.thresholds.pop();
            c.weights.pop();
            if let Some(s) = &mut c.state {
                s.pop();
            }
            true
        }
        _ => false,
    },
    |m| {
        let h = &mut m.hysteresis;
        if h.thresholds.len() > 1 {
            h.thresholds.pop();
            h.weights.pop();
            if let Some(s) = &mut h.state {
                s.pop();
            }
            true
        } else {
            false
        }
    },
    |m| {
        // drop the first play above r_0: the others move down one place
        let h = &mut m.hysteresis;
        if h.thresholds.len() > 2 && h.state.is_none() {
            h.thresholds.remove(1);
            h.weights.remove(1);
            true
        } else {
            false
        }
    },
];

/// Round to `digits` significant digits (0: to integers where that keeps the value non-zero).
fn round_to(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    if digits == 0 {
        let r = x.round();
        return if r == 0.0 { x } else { r };
    }
    let e = x.abs().log10().floor() as i32;
    let f = 10f64.powi(digits - 1 - e);
    (x * f).round() / f
}

fn round_case(c: &mut Case, digits: i32) {
    for v in &mut c.input {
        *v = round_to(*v, digits.max(1) + 1);
    }
    if c.model.hysteresis.state.is_none() {
        for r in c.model.hysteresis.thresholds.iter_mut() {
            *r = round_to(*r, digits);
        }
    }
    for w in c.model.hysteresis.weights.iter_mut() {
        *w = round_to(*w, digits.max(1));
    }
    if let Some(cr) = &mut c.model.creep {
        if cr.state.is_none() {
            for r in cr.thresholds.iter_mut() {
                *r = round_to(*r, digits);
            }
        }
        for a in cr.eigenvalues.iter_mut() {
            *a = round_to(*a, digits.max(1));
        }
    }
}
