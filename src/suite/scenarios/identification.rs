//! Section 4.1: the periodic staircase whose amplitude shrinks each period,
//! the plant's response, and the output of the model identified from it by
//! (23)–(25).

use super::*;
use crate::identification::{identify, IdentificationSettings};
use crate::operators::nominal::SAMPLE_TIME;
use crate::suite::signal::Staircase;

pub(super) static SCENARIO: Scenario = Scenario {
    id: "identification",
    paper: "Sec. 4.1",
    description: "periodic staircase shrinking each period, 40 s, and the identified model's fit",
    decimation: 20,
    columns: &[
        time(),
        input("u"),
        model_output("y"),
        super::Column {
                    justification: "model identified by QR + QP + polish: weights to ~1e-11, outputs to 1e-8 V; 1e-6 V leaves room for another QP solver",
                    abs_tol: 1e-6,
                    rel_tol: 0.0,
                    ..model_output("y_fit")
                },
    ],
    compute,
    figure,
    claims,
};

fn compute(ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
    let u = Staircase::shrinking_loops(1000.0, 4, 3, 0.1, 40.0 / 48.0 - 0.1).sample(SAMPLE_TIME);
    let y = ctx.plant(SCENARIO.id)?.run(&u);
    let id = identify(&u, &y, SAMPLE_TIME, &IdentificationSettings::default())
        .map_err(|e| ScenarioError::new(SCENARIO.id, e))?;
    let fit = id.model.clone().run(&u);
    Ok(ScenarioTrace::of(
        &SCENARIO,
        vec![time_axis(u.len()), u, y, fit],
    ))
}
fn figure(tr: &ScenarioTrace, _: &Traces) -> Option<Figure> {
    let t = tr.col("t");
    let e: Vec<f64> = tr
        .col("y_fit")
        .iter()
        .zip(tr.col("y"))
        .map(|(a, b)| a - b)
        .collect();
    Some(Figure {
        title: "Sec. 4.1 — identification on a shrinking periodic staircase".into(),
        panels: vec![
            panel(
                "measurement and identified model",
                "t (s)",
                "V",
                vec![
                    series("measured y", t, tr.col("y"), COLORS[0]),
                    series("identified W[u]", t, tr.col("y_fit"), COLORS[1]),
                ],
            ),
            panel(
                "fit error",
                "t (s)",
                "W[u] - y (V)",
                vec![series("error", t, &e, COLORS[2])],
            ),
        ],
    })
}
fn claims(tr: &ScenarioTrace, _: &Traces) -> Vec<Claim> {
    let e = tr
        .col("y_fit")
        .iter()
        .zip(tr.col("y"))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let r = range(tr.col("y"));
    vec![Claim {
            figure: "Sec. 4.1",
            claim: "constrained least squares recovers the model from the shrinking staircase (max fit error, % of range)",
            measured: format!("{:.1e} %", 100.0 * e / r),
            holds: e < 1e-8 * r,
        }]
}
