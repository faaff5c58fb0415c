//! Fig. 10: the staircase of Fig. 3 as a desired effective voltage, through
//! the compensator `W⁻¹` (21), the plant `W` and the beam: the input–output
//! relation becomes linear.

use super::*;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::supply::Supply;

/// Output at the last upward and the last downward zero crossing of the
/// input (linear interpolation): their gap is the loop width at zero input.
fn loop_width_at_zero(u: &[f64], y: &[f64]) -> f64 {
    let (mut up, mut down) = (None, None);
    for k in 0..u.len().saturating_sub(1) {
        let (a, b) = (u[k], u[k + 1]);
        let cross = |a: f64, b: f64| y[k] + (y[k + 1] - y[k]) * (0.0 - a) / (b - a);
        if a < 0.0 && b >= 0.0 {
            up = Some(cross(a, b));
        }
        if a > 0.0 && b <= 0.0 {
            down = Some(cross(a, b));
        }
    }
    match (up, down) {
        (Some(a), Some(b)) => (b - a).abs(),
        _ => f64::NAN,
    }
}

pub(super) static SCENARIO: Scenario = Scenario {
    id: "compensated",
    paper: "Fig. 10",
    description:
        "the staircase of Fig. 3 (as desired effective voltage) through W^-1 then W and the beam",
    decimation: 20,
    columns: &[
        time(),
        input("y_d"),
        compensator_output("u"),
        flag("saturated"),
        compensator_output("u_fs"),
        compensator_output("u_bs"),
        model_output("y"),
        tip("tip"),
    ],
    compute,
    figure,
    claims,
};

fn compute(ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
    let y_d = fig3_staircase(500.0);
    let mut comp = ctx.compensator(SCENARIO.id, CompensatorSettings::default())?;
    let r = SuppliedRun::new(comp.as_mut(), &y_d, &Supply::default());
    let y = ctx.plant(SCENARIO.id)?.run(&r.u);
    let tip = ctx.beam().simulate(&y);
    let t = time_axis(y_d.len());
    Ok(ScenarioTrace::of(
        &SCENARIO,
        vec![t, y_d, r.u, r.saturated, r.front, r.back, y, tip],
    ))
}
fn figure(tr: &ScenarioTrace, all: &Traces) -> Option<Figure> {
    let patches = [("u_fs", "u_fs", COLORS[1]), ("u_bs", "u_bs", COLORS[2])];
    let mut loops = Vec::new();
    if let Some(st) = all.get("staircase") {
        loops.push(series(
            "without compensation: W[u] over u",
            st.col("u"),
            st.col("w"),
            GREY,
        ));
    }
    loops.push(series(
        "with compensation: W[W^-1[y_d]] over y_d",
        tr.col("y_d"),
        tr.col("y"),
        COLORS[0],
    ));
    Some(Figure {
        title: "Fig. 10 — compensated staircase: linear input-output".into(),
        panels: vec![
            panel("loops", "commanded (V)", "effective voltage (V)", loops),
            tr.time_panel("patch voltages from the compensator", "V", 1.0, &patches),
            tr.tip_panel(COLORS[0]),
        ],
    })
}
fn claims(tr: &ScenarioTrace, all: &Traces) -> Vec<Claim> {
    let Some(st) = all.get("staircase") else {
        return Vec::new();
    };
    let before = 100.0 * loop_width_at_zero(st.col("u"), st.col("w")) / range(st.col("w"));
    let after = 100.0 * loop_width_at_zero(tr.col("y_d"), tr.col("y")) / range(tr.col("y"));
    vec![Claim {
            figure: "Figs. 3, 10",
            claim: "the compensator removes the hysteresis loop (width at zero input, % of the output range)",
            measured: format!("{before:.2} % before, {after:.1e} % after"),
            holds: before > 1.0 && after < 1e-6,
        }]
}
