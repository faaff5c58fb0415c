//! `mfcbeam bench`: the real-time budget of compensators and models. The
//! reference (this library's heap `f64` implementation, timed in this
//! process) and every library and FMU (each timed inside its host
//! process) step the same targets in interleaved rounds; each step is
//! bracketed by the timer, and the table gives the latency percentiles,
//! the share of the sample time, the steps over the budget and the ratio
//! to the reference. A candidate whose outputs disagree with the
//! reference's beyond the conformance tolerance is refused: a fast wrong
//! answer is not a result.

use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Context, Result};

use mfcbeam::control::{Controller, LoopSample};
use mfcbeam::io::{read_model_file, write_atomic, Trace};
use mfcbeam::isolation::timer::{calibrate, empty_brackets, ticks, timer_name};
use mfcbeam::isolation::{
    pin_this_thread, CandidateSpec, HostError, HostedCandidate, HostedInstance, Role,
};
use mfcbeam::operators::nominal::nominal_model_file;
use mfcbeam::prelude::*;
use mfcbeam::suite::conformance::{tolerance, Rng};
use mfcbeam::suite::plots::{panel, series, write_figure_file, Figure, COLORS};

use super::args::{BenchArgs, BenchKind};
use super::Exit;

/// One candidate being timed.
struct Entry {
    name: String,
    unit: Unit,
    /// Every step's ticks, over all rounds.
    ticks: Vec<u64>,
    /// Why it was dropped, if it was.
    refused: Option<String>,
}

enum Unit {
    Reference(Reference),
    Hosted(Arc<HostedCandidate>, Box<HostedInstance>),
}

/// The reference in this process.
enum Reference {
    Compensator(Box<dyn ActuatorCompensator>),
    Model(Box<dyn ActuatorModel>),
    /// A built-in design; its inputs come in pairs.
    Controller(Box<dyn Controller>),
}

impl Reference {
    /// `targets` through the reference, each step timed: the outputs.
    fn run(&mut self, targets: &[f64], ticks_out: &mut Vec<u64>) -> Vec<f64> {
        let mut out = Vec::with_capacity(targets.len());
        match self {
            Self::Compensator(c) => {
                for &x in targets {
                    let t0 = ticks();
                    let r = black_box(c.compensate(black_box(x)));
                    let t1 = ticks();
                    ticks_out.push(t1.wrapping_sub(t0));
                    out.push(r.u);
                }
            }
            Self::Model(m) => {
                for &x in targets {
                    let t0 = ticks();
                    let y = black_box(m.step(black_box(x)));
                    let t1 = ticks();
                    ticks_out.push(t1.wrapping_sub(t0));
                    out.push(y);
                }
            }
            Self::Controller(c) => {
                for (k, pair) in targets.chunks_exact(2).enumerate() {
                    let s = LoopSample {
                        k,
                        t: 0.0,
                        reference: pair[0],
                        measurement: pair[1],
                    };
                    let t0 = ticks();
                    let r = black_box(c.step(black_box(&s)));
                    let t1 = ticks();
                    ticks_out.push(t1.wrapping_sub(t0));
                    // held (or failed): no number
                    out.push(r.ok().flatten().unwrap_or(f64::NAN));
                }
            }
        }
        out
    }
}

/// The targets of `--target`, `len` samples (a trace or a scenario is
/// repeated to fill them).
fn targets(a: &BenchArgs, file: &ModelFile, limits: (f64, f64), len: usize) -> Result<Vec<f64>> {
    let column = match a.kind {
        BenchKind::Compensator => "y_d",
        BenchKind::Model => "u",
        BenchKind::Controller => unreachable!("a controller's inputs are recorded"),
    };
    let base: Vec<f64> = match target_name(a) {
        "adversarial" => return Ok(adversarial(a.kind, file, limits, len)),
        id => {
            use mfcbeam::suite::scenarios::{run, scenario, ScenarioContext, SCENARIOS};
            if let Some(sc) = scenario(id) {
                let tr = run(sc, &ScenarioContext::nominal())?;
                match tr.columns.iter().find(|(n, _)| *n == column) {
                    Some((_, v)) => v.clone(),
                    None => {
                        let with: Vec<&str> = SCENARIOS
                            .iter()
                            .filter(|s| s.columns.iter().any(|c| c.name == column))
                            .map(|s| s.id)
                            .collect();
                        bail!(
                            "--target {id}: the scenario has no column {column} (those that have: {})",
                            with.join(", ")
                        );
                    }
                }
            } else {
                let path = Path::new(id);
                if !path.is_file() {
                    bail!(
                        "--target '{id}': neither adversarial, a scenario ({}) nor a trace file",
                        SCENARIOS
                            .iter()
                            .map(|s| s.id)
                            .collect::<Vec<_>>()
                            .join(", ")
                    );
                }
                let trace = Trace::read(path)?;
                trace.column(column)?
            }
        }
    };
    if base.is_empty() {
        bail!("--target {}: no samples", target_name(a));
    }
    Ok(base.iter().copied().cycle().take(len).collect())
}

/// `--target`, or the kind's default.
fn target_name(a: &BenchArgs) -> &str {
    match (&a.target, a.kind) {
        (Some(t), _) => t,
        (None, BenchKind::Controller) => "nominal",
        (None, _) => "adversarial",
    }
}

/// A controller's inputs, `len` samples of (reference, measurement): the
/// closed loop of a benchmark scenario run with the built-in `design`
/// (repeated to fill them), and the reference controller, fresh.
fn controller_inputs(
    a: &BenchArgs,
    model: &HysteresisCreepModel,
    len: usize,
) -> Result<(Vec<f64>, Box<dyn Controller>)> {
    use mfcbeam::beam::step_response_fit::{modal_model, BeamModelKind};
    use mfcbeam::control::{Benchmark, BuiltinController};
    let design = match BuiltinController::from_id(&a.controller) {
        Some(d @ (BuiltinController::Pid | BuiltinController::StateFeedback)) => d,
        _ => bail!("--controller '{}': not one of pid, lq", a.controller),
    };
    let id = target_name(a);
    if let Err(mfcbeam::control::ControlError::Invalid { reason, .. }) = Benchmark::scenario(id) {
        bail!("--target: {reason}");
    }
    let beam = mfcbeam::beam::BeamParameters::nominal();
    let elements = mfcbeam::beam::fe::DEFAULT_ELEMENTS;
    let modal = modal_model(&beam, BeamModelKind::Modal { elements })?;
    let bench = Benchmark::new(model.clone(), modal)?;
    let run = bench.run(id, bench.controller(design)?.as_mut())?;
    let pairs: Vec<f64> = run
        .trace
        .reference
        .iter()
        .zip(&run.trace.measurement)
        .flat_map(|(&r, &m)| [r, m])
        .collect();
    let inputs = pairs.iter().copied().cycle().take(2 * len).collect();
    Ok((inputs, bench.controller(design)?))
}

/// Adversarial targets: the sign reverses at every sample, so every play
/// switches branch; magnitudes random over the whole range; every 4th
/// sample beyond reach (the compensator saturates and re-seats its
/// inverse); every 11th a sub-normal step away from zero.
fn adversarial(kind: BenchKind, file: &ModelFile, limits: (f64, f64), len: usize) -> Vec<f64> {
    let reach = match kind {
        // W of a ramp to the upper limit: the largest target reached
        BenchKind::Compensator => HysteresisCreepModel::from_file(file)
            .map(|mut m| {
                let ramp: Vec<f64> = (0..=100).map(|k| limits.1 * k as f64 / 100.0).collect();
                m.run(&ramp).last().copied().unwrap_or(limits.1).abs()
            })
            .unwrap_or(limits.1.abs()),
        BenchKind::Model | BenchKind::Controller => limits.1.abs().min(limits.0.abs()),
    };
    let mut rng = Rng::new(0x2545_F491_4F6C_DD1D);
    (0..len)
        .map(|k| {
            let bits = rng.next_u64();
            let unit = (bits >> 11) as f64 / (1u64 << 53) as f64;
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            if k % 11 == 10 {
                sign * f64::from_bits(1 + (bits & 0xffff))
            } else if k % 4 == 3 && kind == BenchKind::Compensator {
                sign * reach * (1.2 + 0.3 * unit)
            } else {
                sign * reach * (0.05 + 0.9 * unit)
            }
        })
        .collect()
}

/// The most steps in one round of one candidate (a message of 32 bytes a
/// step, 64 MB).
const MAX_STEPS_PER_ROUND: usize = 2_000_000;

/// The most steps timed per candidate (their ticks: 80 MB).
const MAX_STEPS: usize = 10_000_000;

/// How closely a controller must agree with the built-in design it is
/// timed beside, relative to the largest correction: two implementations
/// of the same stable linear filter differ by rounding, some `ε` per
/// operation, far below this (the project's controller FMUs give the same
/// bits).
const CONTROLLER_AGREEMENT: f64 = 1e-9;

/// The latency figures of one candidate (ns).
#[derive(Debug, Clone, serde::Serialize)]
struct Figures {
    median: f64,
    p99: f64,
    p999: f64,
    p9999: f64,
    max: f64,
    over_budget: usize,
    steps: usize,
}

fn figures(ticks: &mut [u64], ns_per_tick: f64, budget_ns: f64) -> Figures {
    ticks.sort_unstable();
    let at = |q: f64| ticks[((ticks.len() - 1) as f64 * q).round() as usize] as f64 * ns_per_tick;
    Figures {
        median: at(0.5),
        p99: at(0.99),
        p999: at(0.999),
        p9999: at(0.9999),
        max: at(1.0),
        over_budget: ticks
            .iter()
            .filter(|&&t| t as f64 * ns_per_tick > budget_ns)
            .count(),
        steps: ticks.len(),
    }
}

/// The first sample where `found` and `expected` differ by more than
/// `tolerance` (a NaN where the reference has a number differs).
fn disagreement(expected: &[f64], found: &[f64], tolerance: f64) -> Option<(usize, f64)> {
    expected
        .iter()
        .zip(found)
        .enumerate()
        .find_map(|(k, (&e, &f))| {
            let error = (e - f).abs();
            let differs = if e.is_finite() {
                error.is_nan() || error > tolerance
            } else {
                e.to_bits() != f.to_bits() && !(e.is_nan() && f.is_nan())
            };
            differs.then_some((k, error))
        })
}

/// The CPU's clock now (from cpufreq, else `/proc/cpuinfo`), if readable.
fn frequency(cpu: usize) -> Option<String> {
    let path = format!("/sys/devices/system/cpu/cpu{cpu}/cpufreq/scaling_cur_freq");
    if let Some(khz) = std::fs::read_to_string(path)
        .ok()
        .and_then(|s| s.trim().parse::<f64>().ok())
    {
        return Some(format!("{:.2} GHz (cpufreq)", khz / 1e6));
    }
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    let mhz = info
        .lines()
        .find(|l| l.starts_with("cpu MHz"))?
        .split_once(':')?
        .1
        .trim()
        .parse::<f64>()
        .ok()?;
    Some(format!("{:.2} GHz (/proc/cpuinfo)", mhz / 1e3))
}

pub fn bench(a: &BenchArgs) -> Result<()> {
    // a round's outputs and ticks travel in one message, and every step's
    // ticks are kept: bounded so both stay far below their limits
    if a.steps == 0 || a.steps > MAX_STEPS_PER_ROUND {
        bail!(
            "--steps: must be in [1, {MAX_STEPS_PER_ROUND}], found {}",
            a.steps
        );
    }
    if a.rounds == 0 || a.rounds.saturating_mul(a.steps) > MAX_STEPS {
        bail!(
            "--rounds: must be at least 1, with --steps × --rounds at most {MAX_STEPS}, found {} × {}",
            a.steps,
            a.rounds
        );
    }
    if !(a.tolerance_scale.is_finite() && a.tolerance_scale >= 1.0) {
        bail!("--tolerance-scale: must be a finite number >= 1");
    }
    let longest = mfcbeam::realtime::limits::MAX_CANDIDATE_TIMEOUT;
    if !(a.timeout.is_finite() && a.timeout > 0.0 && a.timeout <= longest) {
        bail!("--timeout: must be a number of seconds in (0, {longest}]");
    }
    let file = match &a.model {
        Some(p) => {
            let f = read_model_file(p)?;
            HysteresisCreepModel::from_file(&f)
                .with_context(|| format!("--model {}", p.display()))?;
            f
        }
        None => nominal_model_file(),
    };
    let model = HysteresisCreepModel::from_file(&file)?;
    let ts_ns = file.sample_time * 1e9;
    let budget_ns = match a.budget {
        Some(us) if us.is_finite() && us > 0.0 => us * 1e3,
        Some(us) => bail!("--budget: must be a number of µs > 0, found {us}"),
        None => ts_ns,
    };
    let defaults = CompensatorSettings::default();
    let limits = a
        .limits
        .unwrap_or((defaults.lower_limit, defaults.upper_limit));
    let settings = CompensatorSettings::with_limits(limits.0, limits.1);
    let role = match a.kind {
        BenchKind::Compensator => Role::Compensator,
        BenchKind::Model => Role::Model,
        BenchKind::Controller => Role::Controller,
    };
    if a.kind == BenchKind::Controller && !a.library.is_empty() {
        bail!("--library: a controller is timed as an FMU (--fmu)");
    }
    let n_out = role.outputs();
    // the reference, then the candidates in their hosts
    let (all_targets, reference) = match a.kind {
        BenchKind::Compensator => (
            targets(a, &file, limits, a.steps)?,
            Reference::Compensator(Box::new(model.compensator(settings)?)),
        ),
        BenchKind::Model => (
            targets(a, &file, limits, a.steps)?,
            Reference::Model(Box::new(model.clone())),
        ),
        BenchKind::Controller => {
            let (inputs, c) = controller_inputs(a, &model, a.steps)?;
            (inputs, Reference::Controller(c))
        }
    };
    let reference_name = match a.kind {
        BenchKind::Controller => format!("reference (mfcbeam, {})", a.controller),
        _ => "reference (mfcbeam, f64)".into(),
    };
    let mut entries = vec![Entry {
        name: reference_name,
        unit: Unit::Reference(reference),
        ticks: Vec::new(),
        refused: None,
    }];
    let host = a.host.settings(a.timeout)?;
    let mut specs: Vec<(String, String, CandidateSpec)> = Vec::new();
    for l in &a.library {
        specs.push((
            format!("--library {}", l.display()),
            l.file_name()
                .map_or("library".into(), |n| n.to_string_lossy().into_owned()),
            CandidateSpec::Library {
                path: l
                    .canonicalize()
                    .with_context(|| format!("--library {}", l.display()))?
                    .display()
                    .to_string(),
                role,
                symbol_prefix: a.symbol_prefix.clone(),
                precision: a.precision.precision(),
            },
        ));
    }
    let variables = super::hosted::variable_map(&a.fmu_variable)?;
    for f in &a.fmu {
        specs.push((
            format!("--fmu {}", f.display()),
            f.file_name()
                .map_or("FMU".into(), |n| n.to_string_lossy().into_owned()),
            CandidateSpec::Fmu {
                path: f.display().to_string(),
                role,
                variables: variables.clone(),
                sample_time: file.sample_time,
            },
        ));
    }
    // named before pinning: the pinned thread sees one CPU
    let cpu_description = mfcbeam::realtime::cpu_description();
    let placement = match a.cpu {
        Some(cpu) => {
            pin_this_thread(cpu).map_err(|e| anyhow::anyhow!("--cpu: {e}"))?;
            format!("pinned to CPU {cpu}")
        }
        None => "not pinned (--cpu N pins)".into(),
    };
    for (option, name, spec) in specs {
        let candidate = HostedCandidate::start(&host, spec).map_err(|e| match e {
            e @ HostError::Refused(_) | e @ HostError::Host(_) => anyhow::anyhow!("{option}: {e}"),
            e => anyhow::anyhow!("{option}: {e}"),
        })?;
        if let Some(cpu) = a.cpu {
            candidate
                .pin(cpu)
                .map_err(|e| anyhow::anyhow!("{option}: --cpu: {e}"))?;
        }
        let takes_limits = candidate.loaded.takes_limits;
        let instance = candidate
            .instance(
                Some(&file).filter(|_| matches!(candidate.spec, CandidateSpec::Library { .. })),
                (a.kind == BenchKind::Compensator && takes_limits).then_some(limits),
            )
            .map_err(|e| anyhow::anyhow!("{option}: {e}"))?;
        let display = match &candidate.spec {
            CandidateSpec::Library { precision, .. } => format!("{name} ({precision:?})")
                .replace("F64", "f64")
                .replace("F32", "f32"),
            CandidateSpec::Fmu { .. } => format!("{name} (FMU)"),
        };
        entries.push(Entry {
            name: display,
            unit: Unit::Hosted(candidate, Box::new(instance)),
            ticks: Vec::new(),
            refused: None,
        });
    }

    let ns_per_tick = calibrate(Duration::from_millis(200));
    let mut empty = empty_brackets(100_000);
    let timer = figures(&mut empty, ns_per_tick, f64::INFINITY);
    let tolerance = a.tolerance_scale
        * match a.kind {
            BenchKind::Compensator => {
                let y_max = all_targets.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                tolerance::compensator(&file, limits.0.abs().max(limits.1.abs()), y_max)
            }
            BenchKind::Model => {
                let v_max = all_targets.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                tolerance::model(&file, v_max)
            }
            // set from the reference's corrections below
            BenchKind::Controller => 0.0,
        };
    let mut tolerance = tolerance;

    // round 0 warms the caches and predictors up and checks the outputs;
    // its times are dropped
    for round in 0..=a.rounds {
        let mut expected: Vec<f64> = Vec::new();
        // the reference first in every round (its outputs are the check);
        // the candidates in turn, their order rotating
        let n = entries.len();
        let order: Vec<usize> = std::iter::once(0)
            .chain((0..n - 1).map(|i| 1 + (i + round) % (n - 1).max(1)))
            .take(n)
            .collect();
        for i in order {
            let e = &mut entries[i];
            if e.refused.is_some() {
                continue;
            }
            match &mut e.unit {
                Unit::Reference(r) => {
                    expected = r.run(&all_targets, &mut e.ticks);
                    if a.kind == BenchKind::Controller && round == 0 {
                        // the same linear filter in another implementation:
                        // rounding, relative to the largest correction
                        let most = expected
                            .iter()
                            .filter(|v| v.is_finite())
                            .fold(0.0f64, |m, v| m.max(v.abs()));
                        tolerance = a.tolerance_scale * CONTROLLER_AGREEMENT * most.max(1e-300);
                    }
                    if round == 0 {
                        e.ticks.clear();
                    }
                }
                Unit::Hosted(c, instance) => match instance.run_timed(&all_targets) {
                    Ok((outputs, ticks)) => {
                        let found: Vec<f64> = outputs
                            .chunks_exact(n_out)
                            .map(|o| {
                                // a controller's held sample has no number
                                if a.kind == BenchKind::Controller && o[1] != 0.0 {
                                    f64::NAN
                                } else {
                                    o[0]
                                }
                            })
                            .collect();
                        if let Some(err) = c.first_error() {
                            e.refused = Some(format!("round {round}: it failed: {err}"));
                        } else if let Some((k, error)) = disagreement(&expected, &found, tolerance)
                        {
                            e.refused = Some(format!(
                                "round {round}, sample {k}: output {} where the reference gives {} (error {error:.3e}, tolerance {tolerance:.3e}): a fast wrong answer is not a result",
                                found[k], expected[k]
                            ));
                        } else if round > 0 {
                            e.ticks.extend_from_slice(&ticks);
                        }
                    }
                    Err(err) => {
                        e.refused = Some(format!("round {round}: {err}"));
                    }
                },
            }
        }
    }

    // the report
    let cpu = a.cpu.unwrap_or(0);
    println!(
        "latency of one step, {} ({} targets), {} rounds of {} steps per candidate, interleaved, after a round to warm up",
        format!("{:?}", a.kind).to_lowercase(),
        target_name(a),
        a.rounds,
        a.steps
    );
    println!("CPU: {cpu_description}");
    println!(
        "frequency: {}; kernels: {}; {placement}",
        frequency(cpu).unwrap_or_else(|| "not readable".into()),
        mfcbeam::realtime::kernel_set()
    );
    println!(
        "timer: {}, {:.3} ns per tick, empty bracket median {:.1} ns, max {:.0} ns (included below: the figures are upper bounds)",
        timer_name(),
        ns_per_tick,
        timer.median,
        timer.max
    );
    println!(
        "sample time {} µs, budget {} µs",
        ts_ns / 1e3,
        budget_ns / 1e3
    );
    println!(
        "| candidate | median (ns) | p99 (ns) | p99.9 (ns) | p99.99 (ns) | max (ns) | max / Ts | over budget | median / reference | p99.9 / reference |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut results = Vec::new();
    let mut reference_figures: Option<Figures> = None;
    let mut refused = Vec::new();
    for e in &mut entries {
        if let Some(why) = &e.refused {
            refused.push(format!("{}: refused: {why}", e.name));
            continue;
        }
        let f = figures(&mut e.ticks, ns_per_tick, budget_ns);
        let r = reference_figures.get_or_insert_with(|| f.clone()).clone();
        println!(
            "| {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.0} | {:.4} % | {} of {} | {:.2} | {:.2} |",
            e.name,
            f.median,
            f.p99,
            f.p999,
            f.p9999,
            f.max,
            100.0 * f.max / ts_ns,
            f.over_budget,
            f.steps,
            f.median / r.median,
            f.p999 / r.p999
        );
        results.push((e.name.clone(), f));
    }
    for line in &refused {
        println!("{line}");
    }
    if let Some(path) = &a.json {
        let value = serde_json::json!({
            "kind": format!("{:?}", a.kind).to_lowercase(),
            "target": target_name(a),
            "rounds": a.rounds,
            "steps_per_round": a.steps,
            "cpu": cpu_description,
            "frequency": frequency(cpu),
            "kernels": mfcbeam::realtime::kernel_set(),
            "placement": placement,
            "timer": { "name": timer_name(), "ns_per_tick": ns_per_tick, "empty_median_ns": timer.median },
            "sample_time_ns": ts_ns,
            "budget_ns": budget_ns,
            "candidates": results.iter().map(|(n, f)| serde_json::json!({"name": n, "ns": f})).collect::<Vec<_>>(),
            "refused": refused,
        });
        write_atomic(
            path,
            (serde_json::to_string_pretty(&value)? + "\n").as_bytes(),
        )
        .with_context(|| format!("--json {}", path.display()))?;
    }
    if let Some(path) = &a.histogram {
        histogram(&entries, ns_per_tick, path)?;
    }
    if !refused.is_empty() {
        return Err(Exit(1).into());
    }
    Ok(())
}

/// Each candidate's latency histogram: the share of steps per bin, up to
/// the largest p99.99.
fn histogram(entries: &[Entry], ns_per_tick: f64, path: &Path) -> Result<()> {
    let kept: Vec<&Entry> = entries
        .iter()
        .filter(|e| e.refused.is_none() && !e.ticks.is_empty())
        .collect();
    let top = kept
        .iter()
        .map(|e| e.ticks[((e.ticks.len() - 1) as f64 * 0.9999) as usize] as f64 * ns_per_tick)
        .fold(0.0f64, f64::max)
        .max(1.0);
    const BINS: usize = 200;
    let width = top / BINS as f64;
    let x: Vec<f64> = (0..BINS).map(|b| (b as f64 + 0.5) * width).collect();
    let curves = kept
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let mut counts = vec![0usize; BINS];
            for &t in &e.ticks {
                let b = ((t as f64 * ns_per_tick) / width) as usize;
                if b < BINS {
                    counts[b] += 1;
                }
            }
            let share: Vec<f64> = counts
                .iter()
                .map(|&c| 100.0 * c as f64 / e.ticks.len() as f64)
                .collect();
            series(&e.name, &x, &share, COLORS[i % COLORS.len()])
        })
        .collect();
    let figure = Figure {
        title: "latency of one step".into(),
        panels: vec![panel(
            "steps per bin",
            "latency (ns)",
            "share of steps (%)",
            curves,
        )],
    };
    write_figure_file(&figure, path)
        .map_err(|e| anyhow::anyhow!("--histogram {}: {e}", path.display()))
}
