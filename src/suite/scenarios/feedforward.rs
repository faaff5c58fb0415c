//! Fig. 14: the flatness-based rest-to-rest move of the tip, 1 mm in 75 ms
//! from 2.9 s (σ = 1.1), through the compensator, `W` and the beam.

use super::*;
use crate::feedforward::{design, FeedforwardSettings, FlatParametrization};
use crate::operators::compensator::CompensatorSettings;
use crate::operators::supply::Supply;

pub(super) static SCENARIO: Scenario = Scenario {
    id: "feedforward",
    paper: "Fig. 14",
    description: "1 mm in 75 ms from 2.9 s (sigma 1.1) through compensator, W and beam",
    decimation: 1,
    columns: &[
        time(),
        flat_reference("y_d"),
        Column {
            abs_tol: 1e-8,
            rel_tol: 1e-10,
            justification: "D(d/dt) z_d: derivatives to 1e-10 of their scale, 30 factors applied",
            ..model_output("u_d")
        },
        compensator_output("u"),
        compensator_output("u_fs"),
        compensator_output("u_bs"),
        model_output("w"),
        tip("tip"),
    ],
    compute,
    figure,
    claims,
};

fn compute(ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
    let err = |e: &dyn std::fmt::Display| ScenarioError::new(SCENARIO.id, e);
    let flat = FlatParametrization::new(&ctx.modal).map_err(|e| err(&e))?;
    let ff = design(&flat, &FeedforwardSettings::default()).map_err(|e| err(&e))?;
    let supply = Supply::default();
    let (lo, hi) = supply.balanced_limits();
    let mut comp = ctx.compensator(SCENARIO.id, CompensatorSettings::with_limits(lo, hi))?;
    let r = SuppliedRun::new(comp.as_mut(), &ff.u_d, &supply);
    let w = ctx.plant(SCENARIO.id)?.run(&r.u);
    let tip = ctx.beam().simulate(&w);
    Ok(ScenarioTrace::of(
        &SCENARIO,
        vec![ff.t, ff.y_d, ff.u_d, r.u, r.front, r.back, w, tip],
    ))
}
fn figure(tr: &ScenarioTrace, _: &Traces) -> Option<Figure> {
    let (transition, end) = (tr.window(2.85, 3.1), tr.window(2.96, 2.99));
    let tracking = [
        ("y_d", "desired y_d", GREY),
        ("tip", "simulated tip", COLORS[0]),
    ];
    let patches = [("u_fs", "u_fs", COLORS[1]), ("u_bs", "u_bs", COLORS[2])];
    let detail = "detail at the end of the transition";
    Some(Figure {
        title: "Fig. 14 — flatness-based feedforward with compensation: 1 mm in 75 ms".into(),
        panels: vec![
            transition.time_panel("tracking", "w(L) (mm)", 1e3, &tracking),
            end.time_panel(detail, "w(L) (mm)", 1e3, &tracking),
            transition.time_panel("patch voltages", "V", 1.0, &patches),
        ],
    })
}
fn claims(tr: &ScenarioTrace, _: &Traces) -> Vec<Claim> {
    let t = tr.col("t");
    let (y_d, tip) = (tr.col("y_d"), tr.col("tip"));
    let y_t = y_d[y_d.len() - 1];
    let err = tip
        .iter()
        .zip(y_d)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let k_end = at_time(t, 2.975);
    let resid = tip[k_end + 1..]
        .iter()
        .map(|v| (v - y_t).abs())
        .fold(0.0, f64::max);
    let umax = tr
        .col("u_fs")
        .iter()
        .chain(tr.col("u_bs"))
        .fold(f64::NEG_INFINITY, |m, v| m.max(*v));
    vec![Claim {
            figure: "Fig. 14",
            claim: "1 mm in 75 ms (< one natural period) open loop: tracking error and residual vibration (% of the stroke)",
            measured: format!(
                "max error {:.3} %, residual after T {:.1e} %, peak patch voltage {umax:.0} V",
                100.0 * err / y_t,
                100.0 * resid / y_t
            ),
            holds: err < 0.01 * y_t && resid < 1e-3 * y_t && umax <= 1500.0,
        }]
}
