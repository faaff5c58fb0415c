//! The closed-loop benchmark's scenarios (`crate::control::benchmark`): the
//! Fig. 14 move open loop and with the two built-in 2-DOF designs, nominal
//! and with a tip impulse, a step load, an error in `W` and sensor noise.

use super::*;
use crate::control::{
    score, Benchmark, BuiltinController, LoopTrace, Scores, IMPULSE, MODEL_ERROR, NOISE, STEP_LOAD,
};

/// A tip deflection of the closed loop (m).
const fn loop_tip(name: &'static str) -> Column {
    Column {
        name,
        unit: "m",
        abs_tol: 1e-11,
        rel_tol: 1e-9,
        justification: "closed loop: gains from Riccati and LU solves (1e-13 relative) through a stable loop; 1e-11 m is 1e-8 of the stroke",
    }
}

/// A voltage of the closed loop (V).
const fn loop_voltage(name: &'static str) -> Column {
    Column {
        name,
        unit: "V",
        abs_tol: 1e-6,
        rel_tol: 1e-9,
        justification: "closed loop: the gains' rounding times the loop gain (1e5 V/m at most) on 1e-11 m; 1e-6 V",
    }
}

/// A disturbance input, exactly as generated.
const fn disturbance(name: &'static str, unit: &'static str) -> Column {
    Column {
        name,
        unit,
        abs_tol: 1e-15,
        rel_tol: 1e-12,
        justification: "generated: closed-form samples and a seeded generator",
    }
}

const COLUMNS: &[Column] = &[
    time(),
    flat_reference("y_d"),
    disturbance("force", "N"),
    disturbance("noise", "m"),
    tip("tip_open"),
    loop_tip("tip_pid"),
    loop_tip("tip_lq"),
    compensator_output("u_open"),
    loop_voltage("u_pid"),
    loop_voltage("u_lq"),
    loop_voltage("correction_pid"),
    loop_voltage("correction_lq"),
];

macro_rules! loop_scenario {
    ($name:ident, $id:literal, $paper:literal, $description:literal, $claims:ident) => {
        pub(super) static $name: Scenario = Scenario {
            id: concat!("loop-", $id),
            paper: $paper,
            description: $description,
            decimation: 10,
            columns: COLUMNS,
            compute: |ctx| compute(ctx, &$name, $id),
            figure: |tr, _| figure(tr, $description),
            claims: $claims,
        };
    };
}

loop_scenario!(
    NOMINAL,
    "nominal",
    "Sec. 5",
    "Fig. 14 open loop and 2-DOF (PID; LQ with observer) on the nominal plant",
    nominal_claims
);
loop_scenario!(
    IMPULSE_SCENARIO,
    "impulse",
    "Sec. 5",
    "Fig. 14 with tip impulses of 5e-5 N s at 2.93 s and 3.1 s, open loop and 2-DOF",
    impulse_claims
);
loop_scenario!(
    STEP_LOAD_SCENARIO,
    "step-load",
    "Sec. 5",
    "Fig. 14 with a 5 mN tip load from 3.2 s, open loop and 2-DOF",
    step_load_claims
);
loop_scenario!(
    MODEL_ERROR_SCENARIO,
    "model-error",
    "Sec. 5",
    "Fig. 14 with the true W's hysteresis weights x1.1 and creep weights x1.3, open loop and 2-DOF",
    model_error_claims
);
loop_scenario!(
    NOISE_SCENARIO,
    "noise",
    "Sec. 5",
    "Fig. 14 with 1 um rms sensor noise, open loop and 2-DOF",
    noise_claims
);

fn compute(
    ctx: &ScenarioContext,
    info: &'static Scenario,
    id: &str,
) -> Result<ScenarioTrace, ScenarioError> {
    let err = |e: &dyn std::fmt::Display| ScenarioError::new(info.id, e);
    let bench = Benchmark::new(ctx.model.clone(), ctx.modal.clone()).map_err(|e| err(&e))?;
    let mut runs = Vec::new();
    for kind in BuiltinController::ALL {
        let mut controller = bench.controller(kind).map_err(|e| err(&e))?;
        runs.push(
            bench
                .run(id, controller.as_mut())
                .map_err(|e| err(&e))?
                .trace,
        );
    }
    let [open, pid, lq] = <[LoopTrace; 3]>::try_from(runs).expect("three controllers");
    Ok(ScenarioTrace::of(
        info,
        vec![
            open.t,
            open.reference,
            open.force,
            open.noise,
            open.tip,
            pid.tip,
            lq.tip,
            open.u,
            pid.u,
            lq.u,
            pid.correction,
            lq.correction,
        ],
    ))
}

fn figure(tr: &ScenarioTrace, description: &str) -> Option<Figure> {
    let window = tr.window(2.85, 4.0);
    let tips = [
        ("y_d", "desired y_d", GREY),
        ("tip_open", "open loop", COLORS[0]),
        ("tip_pid", "2-DOF PID", COLORS[1]),
        ("tip_lq", "2-DOF LQ + observer", COLORS[2]),
    ];
    let corrections = [
        ("correction_pid", "PID", COLORS[1]),
        ("correction_lq", "LQ + observer", COLORS[2]),
    ];
    Some(Figure {
        title: description.into(),
        panels: vec![
            window.time_panel("tip deflection", "w(L) (mm)", 1e3, &tips),
            window.time_panel(
                "feedback correction of the effective voltage",
                "V",
                1.0,
                &corrections,
            ),
        ],
    })
}

/// The scores of one controller's columns.
fn scores(tr: &ScenarioTrace, controller: &str) -> Scores {
    let trace = LoopTrace {
        t: tr.col("t").to_vec(),
        reference: tr.col("y_d").to_vec(),
        tip: tr.col(&format!("tip_{controller}")).to_vec(),
        ..LoopTrace::default()
    };
    let settings = crate::feedforward::FeedforwardSettings::default();
    score(&trace, settings.start, settings.start + settings.duration)
}

/// `max |u| < 1000 V`: no sample clipped to the balanced supply limit.
fn within_limits(tr: &ScenarioTrace, controller: &str) -> (f64, bool) {
    let u = tr.col(&format!("u_{controller}"));
    let peak = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let (_, hi) = Supply::default().balanced_limits();
    (Supply::default().offset() + peak, peak < hi)
}

/// Fig. 14's open-loop tracking error on the nominal plant (m).
fn fig14_error(all: &Traces) -> Option<f64> {
    all.get("loop-nominal").map(|t| scores(t, "open").max_error)
}

fn pct(x: f64) -> f64 {
    100.0 * x / 1e-3
}

fn nominal_claims(tr: &ScenarioTrace, _: &Traces) -> Vec<Claim> {
    let open = scores(tr, "open");
    let (pid, lq) = (scores(tr, "pid"), scores(tr, "lq"));
    let (v_pid, ok_pid) = within_limits(tr, "pid");
    let (v_lq, ok_lq) = within_limits(tr, "lq");
    vec![Claim {
        figure: "Sec. 5",
        claim: "2-DOF on the nominal plant: feedback does not spoil the feedforward (max tracking error, % of the stroke; peak patch voltage)",
        measured: format!(
            "open {:.3} %, PID {:.3} % ({v_pid:.0} V), LQ {:.3} % ({v_lq:.0} V)",
            pct(open.max_error),
            pct(pid.max_error),
            pct(lq.max_error)
        ),
        holds: pid.max_error <= open.max_error && lq.max_error <= open.max_error && ok_pid && ok_lq,
    }]
}

fn impulse_claims(tr: &ScenarioTrace, _: &Traces) -> Vec<Claim> {
    disturbance_claims(tr, &format!("tip impulses of {IMPULSE:e} N s"))
}

fn step_load_claims(tr: &ScenarioTrace, _: &Traces) -> Vec<Claim> {
    disturbance_claims(tr, &format!("a {:.0} mN tip load", STEP_LOAD * 1e3))
}

fn disturbance_claims(tr: &ScenarioTrace, what: &str) -> Vec<Claim> {
    let open = scores(tr, "open");
    ["pid", "lq"]
        .into_iter()
        .map(|c| {
            let s = scores(tr, c);
            let (peak, ok) = within_limits(tr, c);
            let cut = open.after_rms / s.after_rms;
            Claim {
                figure: "Sec. 5",
                claim: if c == "pid" {
                    "2-DOF PID cuts the rms tracking error after the transition at least 5x against open loop, within the supply limits"
                } else {
                    "2-DOF LQ + observer cuts the rms tracking error after the transition at least 5x against open loop, within the supply limits"
                },
                measured: format!(
                    "{what}: {:.2} um -> {:.2} um ({cut:.1}x), residual {:.2} um, peak patch voltage {peak:.0} V",
                    open.after_rms * 1e6,
                    s.after_rms * 1e6,
                    s.residual * 1e6
                ),
                holds: cut >= 5.0 && ok,
            }
        })
        .collect()
}

fn model_error_claims(tr: &ScenarioTrace, all: &Traces) -> Vec<Claim> {
    let bound = fig14_error(all).unwrap_or(f64::NAN);
    let (open, pid, lq) = (scores(tr, "open"), scores(tr, "pid"), scores(tr, "lq"));
    let (peak, ok) = within_limits(tr, "lq");
    vec![Claim {
        figure: "Sec. 5",
        claim: "with W off (hysteresis weights x1.1, creep x1.3) 2-DOF LQ + observer keeps Fig. 14's tracking error within 3x the error-free open loop's",
        measured: format!(
            "open {:.3} %, LQ {:.3} % (bound {:.3} %, peak {peak:.0} V); the PID baseline {:.3} % misses it",
            pct(open.max_error),
            pct(lq.max_error),
            pct(3.0 * bound),
            pct(pid.max_error)
        ),
        holds: lq.max_error <= 3.0 * bound && ok && MODEL_ERROR == (1.1, 1.3),
    }]
}

fn noise_claims(tr: &ScenarioTrace, all: &Traces) -> Vec<Claim> {
    let bound = fig14_error(all).unwrap_or(f64::NAN);
    let (pid, lq) = (scores(tr, "pid"), scores(tr, "lq"));
    vec![Claim {
        figure: "Sec. 5",
        claim: "with sensor noise the 2-DOF loops keep the tracking error within 2x the error-free open loop's",
        measured: format!(
            "noise {:.1} um rms: PID {:.3} % (after the transition {:.2} um rms), LQ {:.3} % ({:.2} um rms)",
            NOISE * 1e6,
            pct(pid.max_error),
            pid.after_rms * 1e6,
            pct(lq.max_error),
            lq.after_rms * 1e6
        ),
        holds: pid.max_error <= 2.0 * bound && lq.max_error <= 2.0 * bound,
    }]
}
