//! `identify`: weights by constrained least squares, (23)–(25), from a
//! measured record, and the fit report as a dict.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use mfcbeam::identification::{
    check_record, fit_dynamics_and_delay, holdout_samples, identify_records,
    identify_with_initial_states, search_delay_records, search_rate_gain, CreepRegularisation,
    DelaySetting, DynamicsParts, FitErrors, FitRecord, FitStart, IdentificationError,
    IdentificationSettings, InitialStateSettings, RateGainSetting, Record, SearchCriterion,
    UnexcitedOperator,
};
use mfcbeam::io::TimeAxis;
use mfcbeam::operators::bank::Par;

use crate::arrays::{optional_signal, signal, value_error};
use crate::model::Model;

// the signature's literal (a Python signature shows literals only)
const _: () = assert!(mfcbeam::identification::DEFAULT_MAX_DELAY == 10);

/// Identify a model W = S[H + C] + offset from the input u (V) and the measured output y
/// sampled at `sample_time` (s), or at the timestamps `t` (s, mean step;
/// at most 1 % jitter).
///
/// Thresholds follow (23) and creep eigenvalues (24) unless given; the
/// weights solve the constrained least-squares problem (25), so the model
/// always has an inverse. The operators start virgin at the first sample;
/// by default the fit starts where |u| first reaches max|u| (every play's
/// state is known from there), and an output offset is fitted.
///
/// `superposition=M` fits a superposition operator S with M dead zones per
/// side after H + C (the modified PI model, for asymmetric loops) by
/// Kuhnen's error model; `superposition_kinks` places S⁻¹'s kinks on the
/// output axis instead of the rule. 0 (the default) is the paper's
/// symmetric model.
///
/// `holdout` is the fraction of the record at the end left out of the fit
/// and reported; `validate=(u2, y2)` reports the errors on another record,
/// `validate=[(u2, y2), (u3, y3), ...]` on several (report["validations"]:
/// one row per record with its input's dominant rate), each from
/// `validate_from` (default: `fit_from`, else where its |u| first reaches
/// max|u|).
///
/// `delay=d` fits a dead time of d whole samples (y_k is fitted by the
/// memory part at k − d); `delay="auto"` fits every d in 0..=max_delay and
/// keeps the best on the validation records (else the hold-out, else the
/// fit): report["delays"] holds each one's errors and
/// report["delay_criterion"] what chose it.
///
/// `records=[(u2, y2), ...]` fits one model to (u, y) and these records
/// together, each from the virgin state and from its own `fit_from`;
/// `offset="per-record"` gives each its own output offset (the model keeps
/// the first record's; report["records"] lists every record's fit and
/// offset). `dynamics=` any of "low-pass", "resonance", "delay-fraction",
/// comma-separated, fits linear dynamics after the hysteresis with the weights
/// (report["dynamics"]: the parameters and their standard errors); a part
/// the records do not determine raises ValueError. `validate_zero=(a, b)`
/// estimates each validation record's constant offset on its samples
/// a..b and reports its errors with it removed too ("zeroed").
/// `thresholds="reversals"` places half of the play thresholds at the
/// quantiles of the input's reversal half-amplitudes (the rest by (23)).
/// `creep_regularisation="gcv"` (or a number λ ≥ 0) adds a penalty
/// λ s² ‖w_C‖² on the creep weights, λ chosen by generalized
/// cross-validation on the fitted samples (report["creep_regularisation"]:
/// (λ, effective parameters)).
/// `rate_gain=β` (s, below the sample time) gives the plays the
/// rate-dependent thresholds r_i + β|Δu|/T_s, the hysteresis weights then
/// fitted non-negative; `rate_gain="auto"` searches β after the delay and
/// dynamics and keeps the best as `delay="auto"` does
/// (report["rate_gains"], report["rate_gain_criterion"]); report["rate_gain"]
/// is the model's β.
/// `fit_initial_state=True` fits each fitted record's initial memory (play
/// and creep states, and the state of G) together with the weights, in
/// rounds that each lower the squared error over every sample, after the
/// delay and dynamics searches: report["initial_state"] holds the RMS
/// error by round and each record's model in its fitted state.
///
/// Returns (model, report): the identified model (virgin state) and a dict
/// of the figures the command line prints; report["text"] is that text.
#[pyfunction]
#[pyo3(signature = (
    u, y, *, sample_time = None, t = None,
    hysteresis_operators = 12, creep_operators = 12, creep_eigenvalues = 5,
    hysteresis_thresholds = None, creep_thresholds = None, eigenvalues = None,
    epsilon_h = None, fit_offset = true, fit_from = None, holdout = 0.0, validate = None,
    superposition = 0, superposition_kinks = None, validate_from = None,
    delay = None, max_delay = 10, records = None, offset = "shared", dynamics = "none",
    validate_zero = None, thresholds = "uniform", fit_initial_state = false,
    creep_regularisation = None, rate_gain = None
))]
#[allow(clippy::too_many_arguments)]
pub fn identify<'py>(
    py: Python<'py>,
    u: &Bound<'py, PyAny>,
    y: &Bound<'py, PyAny>,
    sample_time: Option<f64>,
    t: Option<&Bound<'py, PyAny>>,
    #[pyo3(from_py_with = crate::arrays::counts::hysteresis_operators)] hysteresis_operators: usize,
    #[pyo3(from_py_with = crate::arrays::counts::creep_operators)] creep_operators: usize,
    #[pyo3(from_py_with = crate::arrays::counts::creep_eigenvalues)] creep_eigenvalues: usize,
    hysteresis_thresholds: Option<&Bound<'py, PyAny>>,
    creep_thresholds: Option<&Bound<'py, PyAny>>,
    eigenvalues: Option<&Bound<'py, PyAny>>,
    epsilon_h: Option<f64>,
    fit_offset: bool,
    #[pyo3(from_py_with = crate::arrays::counts::optional::fit_from)] fit_from: Option<usize>,
    holdout: f64,
    validate: Option<Bound<'py, PyAny>>,
    #[pyo3(from_py_with = crate::arrays::counts::superposition)] superposition: usize,
    superposition_kinks: Option<&Bound<'py, PyAny>>,
    #[pyo3(from_py_with = crate::arrays::counts::optional::validate_from)] validate_from: Option<
        usize,
    >,
    delay: Option<&Bound<'py, PyAny>>,
    #[pyo3(from_py_with = crate::arrays::counts::max_delay)] max_delay: usize,
    records: Option<Bound<'py, PyAny>>,
    offset: &str,
    dynamics: &str,
    validate_zero: Option<(usize, usize)>,
    thresholds: &str,
    fit_initial_state: bool,
    creep_regularisation: Option<&Bound<'py, PyAny>>,
    rate_gain: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Model, Bound<'py, PyDict>)> {
    // β (s) or "auto"
    let rate_gain = match rate_gain {
        None => RateGainSetting::Fixed(0.0),
        Some(r) => match r.extract::<f64>() {
            Ok(b) => format!("{b:e}").parse(),
            Err(_) => r
                .extract::<String>()
                .map_err(|_| "not a string or a number".to_string())
                .and_then(|s| s.parse()),
        }
        .map_err(|e: String| PyValueError::new_err(format!("rate_gain: {e}")))?,
    };
    // "none", "gcv" or λ
    let creep_regularisation = match creep_regularisation {
        None => CreepRegularisation::None,
        Some(r) => match r.extract::<f64>() {
            Ok(l) => format!("{l}").parse(),
            Err(_) => r
                .extract::<String>()
                .map_err(|_| "not a string or a number".to_string())
                .and_then(|s| s.parse()),
        }
        .map_err(|e: String| PyValueError::new_err(format!("creep_regularisation: {e}")))?,
    };
    let offset_per_record = match offset {
        "shared" => false,
        "per-record" => true,
        other => {
            return Err(PyValueError::new_err(format!(
                "offset: '{other}' is neither \"shared\" nor \"per-record\""
            )))
        }
    };
    let parts: DynamicsParts = dynamics
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("dynamics: {e}")))?;
    if let Some((a, b)) = validate_zero {
        if a >= b {
            return Err(PyValueError::new_err(format!(
                "validate_zero: ({a}, {b}) is not a non-empty stretch"
            )));
        }
    }
    let delay = match delay {
        None => DelaySetting::Fixed(0),
        Some(d) => match d.extract::<usize>() {
            Ok(n) => DelaySetting::Fixed(n),
            Err(_) => d
                .extract::<String>()
                .ok()
                .and_then(|s| (s == "auto").then_some(DelaySetting::Auto))
                .ok_or_else(|| {
                    PyValueError::new_err("delay: a number of samples >= 0 or \"auto\"")
                })?,
        },
    };
    let u = signal("u", u)?;
    let y = signal("y", y)?;
    let t = optional_signal("t", t)?;
    let (ts, jitter) = sample_time_of(sample_time, t.as_deref(), u.len())?;
    // the other fitted records
    let mut fitted = Vec::new();
    if let Some(list) = records {
        let list = list
            .cast::<PyList>()
            .map_err(|_| PyValueError::new_err("records: must be a list of pairs (u, y)"))?;
        for (i, r) in list.iter().enumerate() {
            let name = format!("records[{i}]");
            let (ru, ry): (Bound<'py, PyAny>, Bound<'py, PyAny>) = r.extract().map_err(|_| {
                PyValueError::new_err(format!("{name}: must be a pair (u, y) of arrays"))
            })?;
            fitted.push((
                signal(&format!("{name}[0]"), &ru)?,
                signal(&format!("{name}[1]"), &ry)?,
            ));
        }
    }
    if !fitted.is_empty() && holdout > 0.0 {
        return Err(PyValueError::new_err(
            "holdout: with several records, validate on another record instead",
        ));
    }
    for (i, (ru, _)) in fitted.iter().enumerate() {
        if let Some(k) = fit_from {
            if k >= ru.len() {
                return Err(PyValueError::new_err(format!(
                    "fit_from: records[{i}]: sample {k} is beyond its {} samples",
                    ru.len()
                )));
            }
        }
    }
    let holdout = holdout_samples(holdout, u.len()).map_err(value_error)?;
    // a tuple is one record, a list several
    let mut validation = Vec::new();
    if let Some(v) = validate {
        let records: Vec<(String, Bound<'py, PyAny>)> = if v.is_instance_of::<PyList>() {
            let list = v.cast::<PyList>()?;
            list.iter()
                .enumerate()
                .map(|(i, r)| (format!("validate[{i}]"), r))
                .collect()
        } else {
            vec![("validate".to_string(), v)]
        };
        for (name, record) in records {
            let (vu, vy): (Bound<'py, PyAny>, Bound<'py, PyAny>) =
                record.extract().map_err(|_| {
                    PyValueError::new_err(format!("{name}: must be a pair (u, y) of arrays"))
                })?;
            let vu = signal(&format!("{name}[0]"), &vu)?;
            let vy = signal(&format!("{name}[1]"), &vy)?;
            validation.push((name, vu, vy));
        }
    }
    let start = match (validate_from, fit_from) {
        (Some(k), _) | (None, Some(k)) => FitStart::Sample(k),
        (None, None) => FitStart::FirstAtMax,
    };
    let hysteresis_thresholds = match (
        thresholds,
        optional_signal("hysteresis_thresholds", hysteresis_thresholds)?,
    ) {
        ("uniform", given) => given,
        ("reversals", Some(_)) => {
            return Err(PyValueError::new_err(
                "thresholds: give either \"reversals\" or hysteresis_thresholds",
            ))
        }
        ("reversals", None) => {
            let all: Vec<f64> = u
                .iter()
                .chain(fitted.iter().flat_map(|(ru, _)| ru.iter()))
                .copied()
                .collect();
            Some(
                mfcbeam::identification::thresholds::reversal_thresholds(
                    &all,
                    hysteresis_operators,
                )
                .map_err(value_error)?,
            )
        }
        (other, _) => {
            return Err(PyValueError::new_err(format!(
                "thresholds: '{other}' is neither \"uniform\" nor \"reversals\""
            )))
        }
    };
    let settings = IdentificationSettings {
        hysteresis_operators,
        creep_operators,
        creep_eigenvalues,
        hysteresis_thresholds,
        creep_thresholds: optional_signal("creep_thresholds", creep_thresholds)?,
        eigenvalues: optional_signal("eigenvalues", eigenvalues)?,
        epsilon_h,
        fit_offset,
        fit_from,
        holdout,
        superposition,
        superposition_kinks: optional_signal("superposition_kinks", superposition_kinks)?,
        delay: match delay {
            DelaySetting::Fixed(d) => d,
            DelaySetting::Auto => 0,
        },
        offset_per_record,
        creep_regularisation,
        rate_gain: match rate_gain {
            RateGainSetting::Fixed(b) => b,
            RateGainSetting::Auto => 0.0,
        },
        ..IdentificationSettings::default()
    };
    if let RateGainSetting::Fixed(b) = rate_gain {
        if b >= ts {
            return Err(PyValueError::new_err(format!(
                "rate_gain: {b} s must be below the sample time {ts} s"
            )));
        }
    }
    let (id, validated, search, rate_search, initial) = py
        .detach(move || {
            let records: Vec<Record> = validation
                .iter()
                .map(|(name, vu, vy)| Record {
                    name,
                    u: vu,
                    y: vy,
                    from: start.resolve(vu, ts),
                    zero: validate_zero.map(|(a, b)| a..b),
                })
                .collect();
            // a bad record named before anything is fitted
            for r in &records {
                check_record(r.name, r.u, r.y, r.from).map_err(|e| {
                    IdentificationError::InvalidSetting {
                        field: "validate",
                        reason: match e {
                            IdentificationError::LengthMismatch { .. } if r.name == "validate" => {
                                e.to_string()
                            }
                            _ => format!("{}: {e}", r.name),
                        },
                    }
                })?;
            }
            let mut fit_records = vec![FitRecord {
                u: &u,
                y: &y,
                fit_from,
            }];
            fit_records.extend(fitted.iter().map(|(ru, ry)| FitRecord {
                u: ru,
                y: ry,
                fit_from,
            }));
            let (mut id, search) = match delay {
                DelaySetting::Fixed(_) => (identify_records(&fit_records, ts, &settings)?, None),
                DelaySetting::Auto => {
                    let (id, search) =
                        search_delay_records(&fit_records, ts, &settings, max_delay, &records)?;
                    (id, Some(search))
                }
            };
            if parts.any() {
                let s = IdentificationSettings {
                    delay: id.report.delay,
                    ..settings.clone()
                };
                // on this thread: the package leaves threads to its caller
                id = fit_dynamics_and_delay(&fit_records, ts, &s, parts, &records, Par::Seq)?;
            }
            // β after G (as the command line does)
            let mut rate_search = None;
            if rate_gain == RateGainSetting::Auto {
                let s = IdentificationSettings {
                    delay: id.report.delay,
                    dynamics: id.model.dynamics().map(|g| *g.parameters()),
                    ..settings.clone()
                };
                let (mut found, search) = search_rate_gain(&fit_records, ts, &s, &records)?;
                found.report.dynamics = id.report.dynamics.take();
                id = found;
                rate_search = Some(search);
            }
            let mut initial = None;
            if fit_initial_state {
                let s = IdentificationSettings {
                    delay: id.report.delay,
                    dynamics: id.model.dynamics().map(|g| *g.parameters()),
                    rate_gain: id.model.rate_gain().map_or(0.0, |r| r.rate_gain()),
                    ..settings.clone()
                };
                let (joint, states) = identify_with_initial_states(
                    &fit_records,
                    ts,
                    &s,
                    &InitialStateSettings::default(),
                    Par::Seq,
                )?;
                // the search's report stays with the model it found
                let dynamics = id.report.dynamics.take();
                id = joint;
                id.report.dynamics = dynamics;
                initial = Some(states);
            }
            let mut validated = Vec::new();
            for r in &records {
                validated.push(r.row(&id.model)?);
            }
            Ok::<_, IdentificationError>((id, validated, search, rate_search, initial))
        })
        .map_err(value_error)?;
    let r = &id.report;
    let d = PyDict::new(py);
    d.set_item("sample_time", ts)?;
    d.set_item("jitter", jitter)?;
    d.set_item("samples", r.samples)?;
    d.set_item("fitted", (r.fitted.start, r.fitted.end))?;
    d.set_item("skipped", r.fitted.start)?;
    d.set_item("skip_reason", &r.skip_reason)?;
    d.set_item("rms", r.fit.rms)?;
    d.set_item("rms_percent", r.fit.rms_percent())?;
    d.set_item("max", r.fit.max)?;
    d.set_item("max_percent", r.fit.max_percent())?;
    d.set_item("output_range", r.fit.output_range)?;
    d.set_item("holdout", r.holdout.map(|h| errors(py, &h)).transpose()?)?;
    let first = validated
        .first()
        .map(|v| errors(py, &v.errors))
        .transpose()?;
    d.set_item("validation", first)?;
    let rows = PyList::empty(py);
    for v in &validated {
        let row = errors(py, &v.errors)?;
        row.set_item("name", &v.name)?;
        row.set_item("start", v.from)?;
        row.set_item("rate", v.rate)?;
        match &v.zeroed {
            Some((offset, z)) => {
                row.set_item("zero_offset", offset)?;
                row.set_item("zeroed", errors(py, z)?)?;
            }
            None => {
                row.set_item("zero_offset", py.None())?;
                row.set_item("zeroed", py.None())?;
            }
        }
        rows.append(row)?;
    }
    d.set_item("validations", rows)?;
    let fits = PyList::empty(py);
    for f in &r.records {
        let row = errors(py, &f.fit)?;
        row.set_item("fitted", (f.fitted.start, f.fitted.end))?;
        row.set_item("offset", f.offset)?;
        fits.append(row)?;
    }
    d.set_item("records", fits)?;
    match &r.dynamics {
        None => d.set_item("dynamics", py.None())?,
        Some(g) => {
            let e = PyDict::new(py);
            e.set_item("low_pass", g.parameters.low_pass)?;
            e.set_item(
                "resonance_frequency",
                g.parameters.resonance.map(|r| r.frequency),
            )?;
            e.set_item(
                "resonance_damping",
                g.parameters.resonance.map(|r| r.damping),
            )?;
            e.set_item("delay_fraction", g.parameters.delay_fraction)?;
            e.set_item("standard_errors", g.standard_errors.to_vec())?;
            e.set_item("rms_static", g.rms_static)?;
            e.set_item("rms", g.rms)?;
            e.set_item("iterations", g.iterations)?;
            d.set_item("dynamics", e)?;
        }
    }
    d.set_item("offset", r.offset)?;
    d.set_item("condition_number", r.condition_number)?;
    d.set_item("rank", r.rank)?;
    d.set_item("unknowns", r.unknowns)?;
    d.set_item("epsilon_h", r.epsilon_h)?;
    d.set_item("kkt_residual", r.kkt_residual)?;
    d.set_item("iterations", r.iterations)?;
    let active = PyList::empty(py);
    for c in &r.active_constraints {
        let e = PyDict::new(py);
        e.set_item("group", c.group)?;
        e.set_item("index", c.index)?;
        e.set_item("bound", c.bound)?;
        active.append(e)?;
    }
    d.set_item("active_constraints", active)?;
    d.set_item("unexcited", operators(py, &r.unexcited)?)?;
    d.set_item("undetermined", operators(py, &r.undetermined)?)?;
    d.set_item("weights", r.weights.clone())?;
    d.set_item("standard_errors", r.standard_errors.clone())?;
    d.set_item("superposition", r.superposition.clone())?;
    d.set_item("delay", r.delay)?;
    d.set_item(
        "rate_gain",
        id.model.rate_gain().map_or(0.0, |g| g.rate_gain()),
    )?;
    d.set_item("creep_regularisation", r.creep_regularisation)?;
    match initial {
        None => d.set_item("initial_state", py.None())?,
        Some(states) => {
            let e = PyDict::new(py);
            e.set_item("rms", states.rms.clone())?;
            e.set_item("rounds", states.rounds)?;
            let models = PyList::empty(py);
            for file in &states.models {
                let inner = mfcbeam::operators::model::HysteresisCreepModel::from_file(file)
                    .map_err(value_error)?;
                models.append(Model { inner })?;
            }
            e.set_item("models", models)?;
            e.set_item("unwiped", states.unwiped.clone())?;
            d.set_item("initial_state", e)?;
        }
    }
    let mut text = r.to_string();
    match &search {
        None => {
            d.set_item("delays", py.None())?;
            d.set_item("delay_criterion", py.None())?;
        }
        Some(search) => {
            let rows = PyList::empty(py);
            for row in &search.rows {
                let e = search_row(py, &row.fit, row.holdout, &row.validations, row.score)?;
                e.set_item("delay", row.delay)?;
                rows.append(e)?;
            }
            d.set_item("delays", rows)?;
            d.set_item("delay_criterion", criterion_name(search.criterion))?;
            text.push_str(&search.to_string());
        }
    }
    match &rate_search {
        None => {
            d.set_item("rate_gains", py.None())?;
            d.set_item("rate_gain_criterion", py.None())?;
        }
        Some(search) => {
            let rows = PyList::empty(py);
            for row in &search.rows {
                let e = search_row(py, &row.fit, row.holdout, &row.validations, row.score)?;
                e.set_item("rate_gain", row.rate_gain)?;
                rows.append(e)?;
            }
            d.set_item("rate_gains", rows)?;
            d.set_item("rate_gain_criterion", criterion_name(search.criterion))?;
            text.push_str(&search.to_string());
        }
    }
    d.set_item("text", text)?;
    Ok((Model { inner: id.model }, d))
}

/// A search's row (a dead time's, a rate gain's) as the report gives it:
/// its errors and score; the caller adds the value tried.
fn search_row<'py>(
    py: Python<'py>,
    fit: &FitErrors,
    holdout: Option<FitErrors>,
    validations: &[FitErrors],
    score: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let e = PyDict::new(py);
    e.set_item("fit", errors(py, fit)?)?;
    e.set_item("holdout", holdout.map(|h| errors(py, &h)).transpose()?)?;
    let v = PyList::empty(py);
    for errs in validations {
        v.append(errors(py, errs)?)?;
    }
    e.set_item("validations", v)?;
    e.set_item("score", score)?;
    Ok(e)
}

/// What a search chose by, as the report names it.
fn criterion_name(criterion: SearchCriterion) -> &'static str {
    match criterion {
        SearchCriterion::Validation => "validation",
        SearchCriterion::Holdout => "holdout",
        SearchCriterion::Fit => "fit",
    }
}

/// The sample time from `sample_time` or the timestamps `t` (both: they must
/// agree), and the jitter of `t`.
fn sample_time_of(
    sample_time: Option<f64>,
    t: Option<&[f64]>,
    samples: usize,
) -> PyResult<(f64, Option<f64>)> {
    if let Some(ts) = sample_time {
        if !(ts.is_finite() && ts > 0.0) {
            return Err(PyValueError::new_err(format!(
                "sample_time: must be a finite number > 0, found {ts}"
            )));
        }
    }
    let Some(t) = t else {
        return match sample_time {
            Some(ts) => Ok((ts, None)),
            None => Err(PyValueError::new_err(
                "sample_time: give the sample time (s) or the timestamps t",
            )),
        };
    };
    if t.len() != samples {
        return Err(PyValueError::new_err(format!(
            "t: expected {samples} samples (as u), found {}",
            t.len()
        )));
    }
    let axis = TimeAxis::of(t).map_err(value_error)?;
    if let Some(ts) = sample_time {
        axis.check_sample_time(ts)
            .map_err(|m| PyValueError::new_err(format!("t: {m}")))?;
    }
    Ok((sample_time.unwrap_or(axis.sample_time), Some(axis.jitter)))
}

fn errors<'py>(py: Python<'py>, e: &FitErrors) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("samples", e.samples)?;
    d.set_item("rms", e.rms)?;
    d.set_item("rms_percent", e.rms_percent())?;
    d.set_item("max", e.max)?;
    d.set_item("max_percent", e.max_percent())?;
    d.set_item("output_range", e.output_range)?;
    Ok(d)
}

fn operators<'py>(py: Python<'py>, ops: &[UnexcitedOperator]) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for o in ops {
        let e = PyDict::new(py);
        e.set_item("group", o.group)?;
        e.set_item("index", o.index)?;
        e.set_item("threshold", o.threshold)?;
        list.append(e)?;
    }
    Ok(list)
}
