//! Fig. 3: a smooth staircase over the full range `[−1000, 1000]` V: the
//! hysteresis loop, with the vertical creep sections at each plateau.

use super::{
    fig3_staircase, input, model_output, no_claims, time, time_axis, tip, Scenario,
    ScenarioContext, ScenarioError, ScenarioTrace, Traces,
};
use crate::operators::traits::Operator;
use crate::suite::plots::{panel, series, Figure, COLORS};

pub(super) static SCENARIO: Scenario = Scenario {
    id: "staircase",
    paper: "Fig. 3",
    description: "smooth staircase over the full range [-1000, 1000] V: hysteresis loop with creep at each step",
    decimation: 20,
    columns: &[
        time(),
        input("u"),
        model_output("w"),
        model_output("h"),
        tip("tip"),
    ],
    compute,
    figure,
    claims: no_claims,
};

fn compute(ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
    let u = fig3_staircase(1000.0);
    let w = ctx.plant(SCENARIO.id)?.run(&u);
    let h = ctx.model.hysteresis().clone().run(&u);
    let tip = ctx.beam().simulate(&w);
    Ok(ScenarioTrace::of(
        &SCENARIO,
        vec![time_axis(u.len()), u, w, h, tip],
    ))
}
fn figure(tr: &ScenarioTrace, _: &Traces) -> Option<Figure> {
    let t = tr.col("t");
    Some(Figure {
        title: "Fig. 3 — staircase over the full range: hysteresis with creep".into(),
        panels: vec![
            panel(
                "time",
                "t (s)",
                "V",
                vec![
                    series("u", t, tr.col("u"), COLORS[0]),
                    series("W[u]", t, tr.col("w"), COLORS[1]),
                ],
            ),
            panel(
                "hysteresis loop",
                "u (V)",
                "effective voltage (V)",
                vec![
                    series("W[u] (with creep)", tr.col("u"), tr.col("w"), COLORS[1]),
                    series(
                        "H[u] (hysteresis only)",
                        tr.col("u"),
                        tr.col("h"),
                        COLORS[2],
                    ),
                ],
            ),
        ],
    })
}
