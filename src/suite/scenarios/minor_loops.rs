//! Fig. 8a: nested reversals inside the major loop — the Madelung rules and
//! Masing congruence, seen in the input–output plane.

use super::{
    input, model_output, no_claims, ramps, time, time_axis, Scenario, ScenarioContext,
    ScenarioError, ScenarioTrace, Traces,
};
use crate::operators::traits::Operator;
use crate::suite::plots::{panel, series, Figure, COLORS};

pub(super) static SCENARIO: Scenario = Scenario {
    id: "minor-loops",
    paper: "Fig. 8a",
    description: "nested reversals inside the major loop: Madelung rules, Masing congruence",
    decimation: 10,
    columns: &[time(), input("u"), model_output("w"), model_output("h")],
    compute,
    figure,
    claims: no_claims,
};

fn compute(ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
    let u = ramps(
        &[
            900.0, -900.0, 600.0, -300.0, 400.0, 0.0, 300.0, -300.0, 400.0, 0.0, 300.0, -900.0,
            900.0,
        ],
        400.0,
    );
    let w = ctx.plant(SCENARIO.id)?.run(&u);
    let h = ctx.model.hysteresis().clone().run(&u);
    Ok(ScenarioTrace::of(
        &SCENARIO,
        vec![time_axis(u.len()), u, w, h],
    ))
}
fn figure(tr: &ScenarioTrace, _: &Traces) -> Option<Figure> {
    Some(Figure {
        title: "Fig. 8a — nested minor loops: Madelung rules, Masing congruence".into(),
        panels: vec![
            panel(
                "loops",
                "u (V)",
                "effective voltage (V)",
                vec![
                    series("H[u]", tr.col("u"), tr.col("h"), COLORS[2]),
                    series("W[u]", tr.col("u"), tr.col("w"), COLORS[1]),
                ],
            ),
            panel(
                "input",
                "t (s)",
                "u (V)",
                vec![series("u", tr.col("t"), tr.col("u"), COLORS[0])],
            ),
        ],
    })
}
