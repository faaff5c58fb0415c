//! Reading a counterexample: the reference's value split into the model's
//! parts at one sample, and hints that name a likely cause where the
//! candidate's outputs match a known mistake exactly.
//!
//! The parts follow the model `y_k = S[H[u] + C[u]]_{k−d} + offset` (6),
//! (16), with the superposition operator `S` and the dead time `d`: each
//! part is the reference run on the same input with the later parts taken
//! away. A hint is given when the candidate's whole output on the written
//! input equals, within the failure's tolerance, the reference with one
//! part changed — creep removed, thresholds doubled or halved, the state
//! ignored, the first sample skipped, … — or differs from the reference at
//! the first sample only.

use super::{limit_settings, reference_compensator, reference_inverse_hysteresis, reference_model};
use crate::io::format_f64;
use crate::operators::model::ModelFile;
use crate::operators::traits::Operator;
use crate::realtime::preview;
use crate::suite::reference::NaiveModel;

/// Which operator a candidate implements (the hysteresis-only kind is a
/// [`Kind::Model`] whose files hold `H` alone).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `W` (or `H` alone): `u` in, `y` out.
    Model,
    /// `W⁻¹` with limits: `y_d` in, `u` out.
    Compensator,
    /// `H⁻¹`: `y` in, `u` out.
    InverseHysteresis,
}

/// The parts of the reference at one sample, and the likely causes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Explanation {
    /// The sample the parts are given at (the first where the candidate
    /// leaves the reference by more than the tolerance, if any).
    pub sample: usize,
    /// Each part as `name = value`, in the order they build up.
    pub parts: Vec<String>,
    /// Likely causes.
    pub hints: Vec<Hint>,
}

/// A likely cause: the candidate's outputs match the reference with one
/// known change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Hint {
    /// Every hysteresis threshold halved: a band width read as the threshold.
    ThresholdsHalved,
    /// Every hysteresis threshold doubled: a threshold read as a band width.
    ThresholdsDoubled,
    /// The model file's state ignored.
    StateIgnored,
    /// The creep part missing.
    CreepMissing,
    /// The superposition operator missing.
    SuperpositionMissing,
    /// The offset missing.
    OffsetMissing,
    /// The dead time ignored.
    DeadTimeIgnored,
    /// The initial state reported at sample 0, the first input applied from
    /// sample 1 on.
    FirstInputSkipped,
    /// The compensator's output not clipped to the limits.
    LimitsIgnored,
    /// The creep part driven by the current input (in a compensator, by
    /// the output being computed) instead of the previous one.
    CreepOfCurrentInput,
    /// Only sample 0 differs (or the input has one sample): a first-sample
    /// convention, nothing more precise matched.
    FirstSample,
}

impl std::fmt::Display for Hint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Hint::ThresholdsHalved => {
                "the candidate behaves as if every threshold were halved: a threshold r \
                 (half the dead band) taken for the band width; a band-width convention \
                 needs 2 r"
            }
            Hint::ThresholdsDoubled => {
                "the candidate behaves as if every threshold were doubled: a band width 2 r \
                 taken for the threshold r (half the dead band)"
            }
            Hint::StateIgnored => "the candidate ignores the model file's state and starts virgin",
            Hint::LimitsIgnored => {
                "the output is not clipped to the limits: the candidate ignores them (or \
                 reads other parameters for them)"
            }
            Hint::CreepOfCurrentInput => {
                "the creep part is driven by the current input (in a compensator, by the \
                 output being computed) instead of the previous one: the discrete creep \
                 operator (20) advances with v_(k-1), so C_k is known before v_k"
            }
            Hint::CreepMissing => {
                "the error is exactly the creep term C[u]: the creep part is missing (an \
                 implementation of H alone can decline such models with exit code 3)"
            }
            Hint::SuperpositionMissing => "the superposition operator S is missing",
            Hint::OffsetMissing => "the output offset is missing",
            Hint::DeadTimeIgnored => "the dead time is ignored",
            Hint::FirstInputSkipped => {
                "the candidate reports the initial state at sample 0 and applies the first \
                 input only from sample 1 on: in (8) the first input already passes through \
                 every play from its state"
            }
            Hint::FirstSample => {
                "only the first sample differs: check the initial-state convention (8) (the \
                 first input passes through each play from the file's state, or from 0 \
                 without one)"
            }
        })
    }
}

impl Explanation {
    /// The parts and hints as lines of text.
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !self.parts.is_empty() {
            out.push(format!(
                "the reference on input.csv at sample {}, by parts:",
                self.sample
            ));
            out.extend(self.parts.iter().map(|p| format!("  {p}")));
        }
        out.extend(self.hints.iter().map(|h| format!("hint: {h}")));
        out
    }
}

/// The reference output of `kind` on `file` and `input`: the naive
/// references of [`crate::suite::reference`] (`None` when the file is no
/// valid model).
pub fn reference_run(
    kind: Kind,
    file: &ModelFile,
    input: &[f64],
    limits: Option<(f64, f64)>,
) -> Option<Vec<f64>> {
    match kind {
        Kind::Model => Some(reference_model(file).ok()?.run(input)),
        Kind::InverseHysteresis => Some(reference_inverse_hysteresis(file).ok()?.run(input)),
        Kind::Compensator => {
            let mut c = reference_compensator(file, limit_settings(limits)).ok()?;
            Some(c.compensate_all(input).iter().map(|c| c.u).collect())
        }
    }
}

/// Explain a candidate's output `found` on `input` (the run written to
/// disk) against the reference of `kind`; `tolerance` is the failure's.
pub fn explain(
    kind: Kind,
    file: &ModelFile,
    input: &[f64],
    limits: Option<(f64, f64)>,
    found: &[f64],
    tolerance: f64,
) -> Explanation {
    let Some(reference) = reference_run(kind, file, input, limits) else {
        return Explanation::default();
    };
    let n = reference.len().min(found.len());
    let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol = tolerance.max(1e-9 * (1.0 + scale));
    // NaN (a non-finite output) is off too
    let off = |a: &[f64], k: usize| {
        let e = (a[k] - found[k]).abs();
        e.is_nan() || e > tol
    };
    let first = (0..n).find(|&k| off(&reference, k));
    let sample = first.unwrap_or(n.saturating_sub(1));
    let mut e = Explanation {
        sample,
        parts: if n == 0 {
            Vec::new()
        } else {
            parts(kind, file, input, &reference, sample)
        },
        hints: Vec::new(),
    };
    let Some(first) = first else {
        return e;
    };
    for (changed, hint) in variants(kind, file) {
        let v = reference_run(kind, &changed, input, limits)
            .or_else(|| unchecked_thresholds(kind, file, &changed, input));
        if v.is_some_and(|v| v.len() == n && (0..n).all(|k| !off(&v, k))) {
            e.hints.push(hint);
        }
    }
    if skipped_first(kind, file, input).is_some_and(|v| (0..n).all(|k| !off(&v, k))) {
        e.hints.push(Hint::FirstInputSkipped);
    }
    if kind == Kind::Compensator && limits.is_some() {
        let unlimited = reference_run(kind, file, input, None);
        if unlimited.is_some_and(|v| v.len() == n && (0..n).all(|k| !off(&v, k))) {
            e.hints.push(Hint::LimitsIgnored);
        }
    }
    if creep_of_current_input(kind, file, input, limits)
        .is_some_and(|v| v.len() == n && (0..n).all(|k| !off(&v, k)))
    {
        e.hints.push(Hint::CreepOfCurrentInput);
    }
    // the generic first-sample hint only where nothing more precise matched
    if e.hints.is_empty() && first == 0 && (1..n).all(|k| !off(&reference, k)) {
        e.hints.push(Hint::FirstSample);
    }
    e
}

/// The model with one part changed, and what it means if the candidate
/// behaves like it.
fn variants(kind: Kind, file: &ModelFile) -> Vec<(ModelFile, Hint)> {
    let mut out = Vec::new();
    let scaled = |f: f64| {
        let mut m = file.clone();
        m.hysteresis.thresholds.iter_mut().for_each(|r| *r *= f);
        m
    };
    out.push((scaled(0.5), Hint::ThresholdsHalved));
    out.push((scaled(2.0), Hint::ThresholdsDoubled));
    if file.hysteresis.state.is_some()
        || file.creep.as_ref().is_some_and(|c| c.state.is_some())
        || file.delay_state.is_some()
    {
        out.push((file.clone().without_state(), Hint::StateIgnored));
    }
    if kind == Kind::InverseHysteresis {
        return out;
    }
    if file.creep.is_some() {
        let mut m = file.clone();
        m.creep = None;
        out.push((m, Hint::CreepMissing));
    }
    if file.superposition.is_some() {
        let mut m = file.clone();
        m.superposition = None;
        out.push((m, Hint::SuperpositionMissing));
    }
    if file.offset.is_some_and(|o| o != 0.0) {
        let mut m = file.clone();
        m.offset = None;
        out.push((m, Hint::OffsetMissing));
    }
    if file.delay.is_some_and(|d| d > 0) {
        let mut m = file.clone();
        (m.delay, m.delay_state) = (None, None);
        out.push((m, Hint::DeadTimeIgnored));
    }
    out
}

/// The reference with the hysteresis thresholds of `changed`, where the
/// file's state is no admissible state for them (a state matched to `r`
/// need not be one for `r/2`, but a candidate with that mistake runs from
/// it all the same): the naive reference built from `file`, its thresholds
/// then replaced (its fields are public and unchecked). `H⁻¹` is the
/// inverse (22) of that `H`; a compensator has no such fallback.
fn unchecked_thresholds(
    kind: Kind,
    file: &ModelFile,
    changed: &ModelFile,
    input: &[f64],
) -> Option<Vec<f64>> {
    let mut model = NaiveModel::from_file(file).ok()?;
    model.hysteresis.r = changed.hysteresis.thresholds.clone();
    match kind {
        Kind::Model => Some(model.run(input)),
        Kind::InverseHysteresis => Some(model.hysteresis.inverse().run(input)),
        Kind::Compensator => None,
    }
}

/// The model (or its compensator) with the creep advanced by the current
/// input before it is read: `y_k = H[v]_k + C(χ advanced with v_k)`, the
/// compensator solving that for `v_k` by bisection and clipping. `None`
/// without creep, with `S` or a dead time, or for `H⁻¹`.
fn creep_of_current_input(
    kind: Kind,
    file: &ModelFile,
    input: &[f64],
    limits: Option<(f64, f64)>,
) -> Option<Vec<f64>> {
    if file.creep.is_none() || file.superposition.is_some() || file.delay.unwrap_or(0) > 0 {
        return None;
    }
    let mut m = NaiveModel::from_file(file).ok()?;
    let (lo_limit, hi_limit) = limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    let mut out = Vec::with_capacity(input.len());
    for &x in input {
        let held = m.hysteresis.x.first().copied().unwrap_or(0.0);
        let creep = m.creep.as_ref()?;
        // what the mistaken model outputs for v (no state change)
        let at = |v: f64| {
            let mut c = creep.clone();
            c.advance(v);
            m.hysteresis.evaluate(v) + c.output() + m.offset
        };
        let v = match kind {
            Kind::InverseHysteresis => return None,
            Kind::Model => {
                let v = if x.is_finite() { x } else { held };
                out.push(at(v));
                v
            }
            Kind::Compensator => {
                let v = if !x.is_finite() {
                    held
                } else {
                    let (mut lo, mut hi) = (held - 1.0, held + 1.0);
                    while at(lo) > x && lo > -1e300 {
                        lo = held - 2.0 * (held - lo);
                    }
                    while at(hi) < x && hi < 1e300 {
                        hi = held + 2.0 * (hi - held);
                    }
                    for _ in 0..200 {
                        let mid = 0.5 * (lo + hi);
                        if mid <= lo || mid >= hi {
                            break;
                        }
                        if at(mid) < x {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    let v = if (at(lo) - x).abs() <= (at(hi) - x).abs() {
                        lo
                    } else {
                        hi
                    };
                    v.clamp(lo_limit, hi_limit)
                };
                out.push(v);
                v
            }
        };
        let h = &mut m.hysteresis;
        for i in 0..h.r.len() {
            h.x[i] = (v - h.r[i]).max((v + h.r[i]).min(h.x[i]));
        }
        m.creep.as_mut()?.advance(v);
    }
    Some(out)
}

/// `H` (or `H⁻¹`, plus the offset) with the first input not passed through
/// the plays: sample 0 reports the output of the initial state, `Σ w_i x_i`,
/// and the rest continues from that state. `None` for a model with creep,
/// `S` or a dead time.
fn skipped_first(kind: Kind, file: &ModelFile, input: &[f64]) -> Option<Vec<f64>> {
    if input.is_empty()
        || file.creep.is_some()
        || file.superposition.is_some()
        || file.delay.unwrap_or(0) > 0
    {
        return None;
    }
    let model = NaiveModel::from_file(file).ok()?;
    let (mut h, offset) = match kind {
        Kind::Model => (model.hysteresis, model.offset),
        Kind::InverseHysteresis => (model.hysteresis.inverse(), 0.0),
        Kind::Compensator => return None,
    };
    let initial: f64 = h.w.iter().zip(&h.x).map(|(w, x)| w * x).sum();
    let mut out = vec![initial + offset];
    out.extend(h.run(&input[1..]).iter().map(|y| y + offset));
    Some(out)
}

/// The reference's value at `k`, by parts.
fn parts(kind: Kind, file: &ModelFile, input: &[f64], reference: &[f64], k: usize) -> Vec<String> {
    let inner = |with_creep: bool, with_s: bool| {
        let mut m = file.clone();
        (m.delay, m.delay_state, m.offset) = (None, None, None);
        if !with_creep {
            m.creep = None;
        }
        if !with_s {
            m.superposition = None;
        }
        m
    };
    let run = |m: &ModelFile, x: &[f64]| NaiveModel::from_file(m).ok().map(|mut w| w.run(x));
    let d = file.delay.unwrap_or(0);
    let offset = file.offset.unwrap_or(0.0);
    let line = |name: String, v: f64| format!("{name} = {}", format_f64(v));
    let mut out: Vec<String> = Vec::new();
    match kind {
        Kind::Model => {
            out.push(line(format!("u[{k}]"), input[k]));
            if k < d {
                out.push(format!(
                    "sample {k} is inside the dead time d = {d}: the output comes from the file's delay_state (or the first sample's value)"
                ));
                out.push(line(format!("y[{k}] (the reference)"), reference[k]));
                return out;
            }
            let j = k - d;
            let (Some(h), Some(hc), Some(shc)) = (
                run(&inner(false, false), input),
                run(&inner(true, false), input),
                run(&inner(true, true), input),
            ) else {
                return out;
            };
            out.push(line(format!("H[u] at sample {j}"), h[j]));
            if file.creep.is_some() {
                out.push(line(format!("C[u] at sample {j}"), hc[j] - h[j]));
            }
            if file.superposition.is_some() {
                out.push(line(format!("S[H + C] at sample {j}"), shc[j]));
            }
            if d > 0 {
                out.push(format!("dead time d = {d}: y[{k}] takes sample {j}"));
            }
            if file.offset.is_some() {
                out.push(line("offset".into(), offset));
            }
            out.push(line(format!("y[{k}] (the reference)"), reference[k]));
        }
        Kind::Compensator => {
            let target = preview(input, d, k);
            out.push(line(
                format!(
                    "target y_d[{}] (previewed by the dead time d = {d})",
                    (k + d).min(input.len() - 1)
                ),
                target,
            ));
            if file.offset.is_some() {
                out.push(line("offset".into(), offset));
            }
            let (Some(h), Some(hc), Some(shc)) = (
                run(&inner(false, false), reference),
                run(&inner(true, false), reference),
                run(&inner(true, true), reference),
            ) else {
                return out;
            };
            if file.superposition.is_some() {
                out.push(line("S[H + C][u] of the reference's u".into(), shc[k]));
            }
            if file.creep.is_some() {
                out.push(line(
                    "C[u] of the reference's u (subtracted before H⁻¹)".into(),
                    hc[k] - h[k],
                ));
            }
            out.push(line("H[u] of the reference's u".into(), h[k]));
            out.push(line(format!("u[{k}] (the reference)"), reference[k]));
        }
        Kind::InverseHysteresis => {
            out.push(line(format!("y[{k}]"), input[k]));
            out.push(line(
                format!("u[{k}] = H⁻¹[y] (the reference)"),
                reference[k],
            ));
            if let Some(h) = run(&inner(false, false), reference) {
                out.push(line("H[u] of that u (equals y)".into(), h[k]));
            }
        }
    }
    out
}
