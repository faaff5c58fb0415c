//! `mfcbeam identify`: a model from one or more measured records, its fit
//! report and, with a held-out part or other records, the validation
//! table; `mfcbeam estimate-state`: the memory a record starts in, for a
//! fixed model.

use anyhow::{anyhow, bail, Context, Result};

use mfcbeam::identification::validate_record_from_state;
use mfcbeam::identification::{
    check_record, dominant_rate, fit_dynamics_and_delay, holdout_samples, identify_records,
    identify_with_initial_states, search_delay_records, search_rate_gain, DelaySetting, FitRecord,
    FitStart, IdentificationSettings, InitialStateSettings, RateGainSetting, Record, StateEstimate,
    StateSettings, ValidationRow, ValidationTable,
};
use mfcbeam::io::{read_model_file, write_json, Trace};
use mfcbeam::operators::bank::Par;
use mfcbeam::operators::model::{HysteresisCreepModel, ModelFile};
use mfcbeam::operators::traits::Operator;

use super::args::{EstimateStateArgs, IdentifyArgs, OffsetSetting, StateAt, ThresholdRule};
use super::trace_sample_time;

pub(super) fn identify(a: &IdentifyArgs) -> Result<()> {
    let first = Trace::read(&a.input[0])?;
    let ts = trace_sample_time(&first, a.sample_time, None)?;
    let jitter = if first.has_column("t") && first.len() > 1 {
        Some(first.time_axis()?.jitter)
    } else {
        None
    };
    // every fitted record: its name, input and output
    let mut fitted = vec![(
        a.input[0].display().to_string(),
        first.column("u")?,
        first.column("y")?,
    )];
    for path in &a.input[1..] {
        let other = Trace::read(path)?;
        other.check_time_column(ts)?;
        fitted.push((
            path.display().to_string(),
            other.column("u")?,
            other.column("y")?,
        ));
    }
    if let RateGainSetting::Fixed(b) = a.rate_gain {
        if b >= ts {
            bail!("--rate-gain: {b} s must be below the sample time {ts} s");
        }
    }
    let several = fitted.len() > 1;
    if several && a.holdout.is_some() {
        bail!("--holdout: with several --input records, validate on another record (--validate) instead");
    }
    let (u, y) = (&fitted[0].1, &fitted[0].2);
    let holdout =
        holdout_samples(a.holdout.unwrap_or(0.0), u.len()).map_err(|e| anyhow!("--{e}"))?;
    let mut validation = Vec::new();
    for path in &a.validate {
        let other = Trace::read(path)?;
        other.check_time_column(ts)?;
        validation.push((path, other.column("u")?, other.column("y")?));
    }
    // each record's own start
    let starts: Vec<Option<usize>> = fitted
        .iter()
        .map(|(_, u, _)| a.fit_from.map(|f| f.resolve(u, ts)))
        .collect();
    if several {
        for ((name, u, _), start) in fitted.iter().zip(&starts) {
            if let Some(k) = start {
                if *k >= u.len() {
                    bail!(
                        "--fit-from: {name}: sample {k} is beyond its {} samples",
                        u.len()
                    );
                }
            }
        }
    }
    let validate_from = a.validate_from.or(a.fit_from).unwrap_or_default();
    if let Some(p) = &a.plot {
        if !matches!(p.extension().and_then(|e| e.to_str()), Some("png" | "svg")) {
            bail!("--plot: {}: name a .png or .svg file", p.display());
        }
    }
    let hysteresis_thresholds = match (a.thresholds, &a.hysteresis_thresholds) {
        (ThresholdRule::Uniform, given) => given.clone(),
        (ThresholdRule::Reversals, Some(_)) => {
            bail!("--thresholds reversals: give either the rule or --hysteresis-thresholds")
        }
        (ThresholdRule::Reversals, None) => {
            let all: Vec<f64> = fitted
                .iter()
                .flat_map(|(_, u, _)| u.iter().copied())
                .collect();
            Some(
                mfcbeam::identification::thresholds::reversal_thresholds(
                    &all,
                    a.hysteresis_operators,
                )
                .map_err(|e| anyhow!("--{e}"))?,
            )
        }
    };
    let mut settings = IdentificationSettings {
        fit_offset: !a.no_offset,
        fit_from: starts[0],
        holdout,
        hysteresis_operators: a.hysteresis_operators,
        creep_operators: a.creep_operators,
        creep_eigenvalues: a.creep_eigenvalues,
        hysteresis_thresholds,
        creep_thresholds: a.creep_thresholds.clone(),
        eigenvalues: a.eigenvalues.clone(),
        epsilon_h: a.epsilon_h,
        superposition: a.superposition,
        superposition_kinks: a.superposition_kinks.clone(),
        delay: match a.delay {
            DelaySetting::Fixed(d) => d,
            DelaySetting::Auto => 0,
        },
        offset_per_record: a.offset == OffsetSetting::PerRecord,
        dynamics: None,
        creep_regularisation: a.creep_regularisation,
        rate_gain: match a.rate_gain {
            RateGainSetting::Fixed(b) => b,
            RateGainSetting::Auto => 0.0,
        },
    };
    // the settings are options: named as such, not after the input file
    if let Err(mfcbeam::identification::IdentificationError::InvalidSetting { field, reason }) =
        settings.validate()
    {
        bail!("--{}: {reason}", field.replace('_', "-"));
    }
    if matches!(a.delay, DelaySetting::Auto) {
        mfcbeam::realtime::limits::check(
            "max-delay",
            mfcbeam::realtime::limits::MAX_DELAY_SEARCH,
            a.max_delay,
        )
        .map_err(|e| anyhow!("--{e}"))?;
    }
    let names: Vec<String> = validation
        .iter()
        .map(|(path, _, _)| path.display().to_string())
        .collect();
    let mut records: Vec<Record> = Vec::with_capacity(validation.len());
    for ((_, vu, vy), name) in validation.iter().zip(&names) {
        let zero = match &a.validate_zero {
            Some(z) => Some(
                z.resolve(vu.len(), ts)
                    .map_err(|e| anyhow!("--validate-zero: {name}: {e}"))?,
            ),
            None => None,
        };
        records.push(Record {
            name,
            u: vu,
            y: vy,
            from: validate_from.resolve(vu, ts),
            zero,
        });
    }
    // a record's own errors first, so that a bad one is named by its file
    for r in &records {
        check_record(r.name, r.u, r.y, r.from).with_context(|| r.name.to_string())?;
    }
    let fit_records: Vec<FitRecord> = fitted
        .iter()
        .zip(&starts)
        .map(|((_, u, y), &fit_from)| FitRecord { u, y, fit_from })
        .collect();
    let name_of = |e: mfcbeam::identification::IdentificationError| -> anyhow::Error {
        let what = if several {
            "the --input records".to_string()
        } else {
            a.input[0].display().to_string()
        };
        anyhow!("{what}: {e}")
    };
    let (mut id, search) = match a.delay {
        DelaySetting::Fixed(_) => (
            identify_records(&fit_records, ts, &settings).map_err(name_of)?,
            None,
        ),
        DelaySetting::Auto => {
            let (id, search) =
                search_delay_records(&fit_records, ts, &settings, a.max_delay, &records)
                    .map_err(name_of)?;
            (id, Some(search))
        }
    };
    if a.dynamics.any() {
        let s = IdentificationSettings {
            delay: id.report.delay,
            ..settings.clone()
        };
        let fit = on_threads(a.threads, |par| {
            fit_dynamics_and_delay(&fit_records, ts, &s, a.dynamics, &records, par)
        })?;
        id = fit.map_err(|e| match e {
            mfcbeam::identification::IdentificationError::InvalidSetting {
                field: "dynamics",
                reason,
            } => anyhow!("--dynamics: {reason}"),
            e => name_of(e),
        })?;
    }
    // β after G: a linear lag also widens the loops with the rate, so a
    // search without the dynamics found takes them for rate dependence
    let rate_search = match a.rate_gain {
        RateGainSetting::Fixed(_) => None,
        RateGainSetting::Auto => {
            settings.delay = id.report.delay;
            settings.dynamics = id.model.dynamics().map(|g| *g.parameters());
            let (mut found, search) =
                search_rate_gain(&fit_records, ts, &settings, &records).map_err(name_of)?;
            found.report.dynamics = id.report.dynamics.take();
            // the later stages fit with the gain chosen
            settings.rate_gain = search.chosen;
            id = found;
            Some(search)
        }
    };
    let initial_states = if a.fit_initial_state {
        let s = IdentificationSettings {
            delay: id.report.delay,
            dynamics: id.model.dynamics().map(|g| *g.parameters()),
            ..settings.clone()
        };
        let (joint, states) = on_threads(a.threads, |par| {
            identify_with_initial_states(
                &fit_records,
                ts,
                &s,
                &InitialStateSettings::default(),
                par,
            )
        })?
        .map_err(name_of)?;
        // the search's report stays with the model it found
        let dynamics = id.report.dynamics.take();
        id = joint;
        id.report.dynamics = dynamics;
        Some(states)
    } else {
        None
    };
    let mut rows = Vec::new();
    for r in &records {
        match a.validate_state_until {
            None => rows.push(r.row(&id.model)?),
            Some(until) => {
                // the record's memory estimated on its window, scored after it
                let file = id.model.to_file().without_state();
                let until = window_end(until, r.u.len(), ts)
                    .map_err(|e| anyhow!("--validate-state-until: {}: {e}", r.name))?;
                let estimate = estimate(&file, r.u, r.y, until, &StateSettings::default())
                    .map_err(|e| anyhow!("--validate-state-until: {}: {e}", r.name))?;
                let model = HysteresisCreepModel::from_file(&estimate.model)?;
                rows.push(validate_record_from_state(
                    &model,
                    r.name,
                    r.u,
                    r.y,
                    r.from.max(until),
                    r.zero.clone(),
                )?);
            }
        }
    }
    if let Some(p) = &a.plot {
        // each fitted record's model as fitted: in its fitted initial state
        let started: Vec<HysteresisCreepModel> = match &initial_states {
            Some(states) => states
                .models
                .iter()
                .map(HysteresisCreepModel::from_file)
                .collect::<Result<_, _>>()?,
            None => id.record_models.clone(),
        };
        let fit = started[0].clone().run(u);
        let mut others: Vec<(String, Vec<f64>)> = Vec::new();
        for ((name, fu, fy), model) in fitted.iter().zip(&started).skip(1) {
            let fit = model.clone().run(fu);
            others.push((
                format!("{name} (fitted)"),
                fit.iter().zip(fy).map(|(a, b)| a - b).collect(),
            ));
        }
        for (path, vu, vy) in &validation {
            let fit = id.model.clone().run(vu);
            let e = fit.iter().zip(vy.iter()).map(|(a, b)| a - b).collect();
            others.push((path.display().to_string(), e));
        }
        let fitted_range = &id.report.fitted;
        mfcbeam::suite::plots::write_identification_plot(p, u, y, &fit, ts, fitted_range, &others)
            .map_err(anyhow::Error::msg)?;
    }
    write_json(&a.output, &id.model.to_file().without_state())?;
    if let Some(j) = jitter {
        eprintln!(
            "sample time          {ts:?} s (mean step of t; jitter {:.2e} of a step)",
            j
        );
    }
    eprint!("{}", id.report);
    if let Some(search) = &search {
        eprint!("{search}");
    }
    if let Some(search) = &rate_search {
        eprint!("{search}");
    }
    if let Some(states) = &initial_states {
        let rms: Vec<String> = states.rms.iter().map(|r| format!("{r:.4e}")).collect();
        eprintln!(
            "initial state        fitted with the weights in {} rounds: RMS error over every sample {}",
            states.rounds,
            rms.join(" → ")
        );
        for ((name, _, _), unwiped) in fitted.iter().zip(&states.unwiped) {
            if !unwiped.is_empty() {
                eprintln!("initial state        {name}: plays {unwiped:?} keep their memory through the record (their states rest on its level alone)");
            }
        }
    }
    if let Some(g) = &id.report.dynamics {
        eprint!("{}", DynamicsLine(g));
        eprintln!(
            "dynamics: dead time    {} samples with them (and {} of the resonance's lag)",
            id.report.delay,
            g.parameters.lag()
        );
    }
    // are the measured minor loops congruent (what a PI model can follow)?
    let from = id.report.fitted.start;
    if let Some(span) = mfcbeam::identification::thresholds::median_branch(&u[from..]) {
        let c =
            |y: &[f64]| mfcbeam::identification::thresholds::branch_congruence(u, y, from, span);
        if let (Some(measured), Some(model)) = (c(y), c(&id.model.clone().run(u))) {
            eprintln!(
                "minor loops          {} branches of at least {span:.4e}: y(u_a ± s) − y(u_a) spreads about its median by {:.4} % of the range measured, {:.4} % in the model (H alone has one curve, Masing; S, creep and G spread it)",
                measured.branches, measured.spread_percent, model.spread_percent
            );
        }
    }
    if several || !rows.is_empty() {
        // the fitted records first, then one row per validation record
        let mut table = Vec::new();
        for (i, (name, fu, _)) in fitted.iter().enumerate() {
            let (from, errors) = match id.report.records.get(i) {
                Some(r) => (r.fitted.start, r.fit),
                None => (id.report.fitted.start, id.report.fit),
            };
            table.push(ValidationRow {
                name: name.clone(),
                from,
                errors,
                rate: dominant_rate(fu, ts),
                zeroed: None,
            });
        }
        table.extend(rows);
        eprint!("{}", ValidationTable(table));
    }
    if several && settings.offset_per_record && settings.fit_offset {
        let first = id
            .report
            .records
            .first()
            .map_or(id.model.offset(), |r| r.offset);
        for (r, (name, _, _)) in id.report.records.iter().zip(&fitted) {
            eprintln!("offset of {name}: {:.6e}", r.offset);
        }
        eprintln!("the model file keeps the first record's offset, {first:.6e}");
    }
    if let Some(p) = &a.plot {
        eprintln!("mfcbeam: wrote {}", p.display());
    }
    eprintln!("mfcbeam: wrote {}", a.output.display());
    Ok(())
}

/// `f` with `threads` threads (`--threads`): 0 for one per core, 1 for
/// this thread alone (`Par::Seq`), else a pool of that many.
fn on_threads<R: Send>(threads: usize, f: impl FnOnce(Par) -> R + Send) -> Result<R> {
    Ok(match threads {
        1 => f(Par::Seq),
        n => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| anyhow!("--threads {n}: {e}"))?
            .install(|| f(Par::rayon(0))),
    })
}

/// `--until` of a record of `len` samples as a sample count.
fn window_end(until: FitStart, len: usize, ts: f64) -> Result<usize> {
    let k = match until {
        FitStart::FirstAtMax => len,
        other => other.resolve(&[], ts),
    };
    if k < 2 || k > len {
        bail!(
            "the window must end within the record's {len} samples, at sample 2 or later, not {k}"
        );
    }
    Ok(k)
}

fn estimate(
    file: &ModelFile,
    u: &[f64],
    y: &[f64],
    until: usize,
    settings: &StateSettings,
) -> Result<StateEstimate, mfcbeam::identification::IdentificationError> {
    mfcbeam::identification::estimate_state(
        file,
        u,
        y,
        &StateSettings {
            until: Some(until),
            ..settings.clone()
        },
    )
}

pub(super) fn estimate_state(a: &EstimateStateArgs) -> Result<()> {
    let file = read_model_file(&a.model)?;
    // the model checked here, so that a bad one is named by its file
    HysteresisCreepModel::from_file(&file).with_context(|| a.model.display().to_string())?;
    let trace = Trace::read(&a.input)?;
    trace.check_time_column(file.sample_time)?;
    let (u, y) = (trace.column("u")?, trace.column("y")?);
    let name = a.input.display().to_string();
    let until = match a.until {
        Some(t) => window_end(t, u.len(), file.sample_time).map_err(|e| anyhow!("--until: {e}"))?,
        None => u.len(),
    };
    let settings = StateSettings {
        fit_offset: !a.keep_offset,
        fit_creep: !a.keep_creep,
        fit_dynamics: !a.keep_dynamics,
        ..StateSettings::default()
    };
    let estimate = estimate(&file, &u, &y, until, &settings).map_err(|e| anyhow!("{name}: {e}"))?;
    let written = match a.state_at {
        StateAt::Start => estimate.model.clone(),
        StateAt::End => estimate.model_after_window(&u)?,
    };
    write_json(&a.output, &written)?;
    eprintln!(
        "window               samples 0..{until} ({:.6} s) of {name}",
        until as f64 * file.sample_time
    );
    let limit = if estimate.iterations >= settings.max_iterations {
        " (the limit: the error was still falling)"
    } else {
        ""
    };
    eprintln!(
        "error rms            {:.6e} in the window ({:.6e} from the prior state); {} steps{limit}",
        estimate.rms, estimate.prior_rms, estimate.iterations
    );
    eprintln!(
        "offset               {:.6e}",
        estimate.model.offset.unwrap_or(0.0)
    );
    if estimate.unwiped.is_empty() {
        eprintln!("memory               every play was moved in the window: nothing of the past is left after it");
    } else {
        let list: Vec<String> = estimate.unwiped.iter().map(|i| i.to_string()).collect();
        eprintln!(
            "memory               plays {} were not moved in the window: their states after it rest on the output level alone",
            list.join(", ")
        );
    }
    let at = match a.state_at {
        StateAt::Start => "at the record's first sample".to_string(),
        StateAt::End => format!("after sample {}", until - 1),
    };
    eprintln!("mfcbeam: wrote {} (state {at})", a.output.display());
    Ok(())
}

/// The fitted dynamics in one block of the report.
struct DynamicsLine<'a>(&'a mfcbeam::identification::DynamicsReport);

impl std::fmt::Display for DynamicsLine<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let g = self.0;
        let se = |s: Option<f64>| s.map_or("?".to_string(), |s| format!("{s:.2e}"));
        if let Some(fc) = g.parameters.low_pass {
            writeln!(
                f,
                "dynamics: low-pass    {fc:.6e} Hz ± {}",
                se(g.standard_errors[0])
            )?;
        }
        if let Some(r) = g.parameters.resonance {
            writeln!(
                f,
                "dynamics: resonance   {:.6e} Hz ± {}, damping {:.6e} ± {}",
                r.frequency,
                se(g.standard_errors[1]),
                r.damping,
                se(g.standard_errors[2])
            )?;
        }
        let tau = g.parameters.delay_fraction;
        match g.standard_errors[3] {
            Some(se) => writeln!(
                f,
                "dynamics: delay fraction {tau:.6} samples ± {se:.2e} (on top of the dead time)"
            )?,
            None if tau != 0.0 => writeln!(
                f,
                "dynamics: delay fraction {tau:.6} samples, at its bound (the dead time was tried one sample either way)"
            )?,
            None => {}
        }
        writeln!(
            f,
            "dynamics: output error rms {:.6e} without, {:.6e} with them ({} steps)",
            g.rms_static, g.rms, g.iterations
        )
    }
}
