//! Fig. 2: a rectangular voltage, `u = 500 V` on `[5, 45)` s, else 0, for
//! 90 s: the creep after each edge and the remanent offset at the end.

use super::{
    at_time, input, model_output, samples, time, time_axis, tip, Claim, Scenario, ScenarioContext,
    ScenarioError, ScenarioTrace, Traces,
};
use crate::operators::nominal::SAMPLE_TIME;
use crate::suite::plots::{panel, scaled, series, Figure, COLORS};

pub(super) static SCENARIO: Scenario = Scenario {
    id: "rectangle",
    paper: "Fig. 2",
    description: "u = 500 V on [5, 45) s, else 0, 90 s: creep after the step, remanent offset",
    decimation: 50,
    columns: &[time(), input("u"), model_output("w"), tip("tip")],
    compute,
    figure,
    claims,
};

fn compute(ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
    let n = samples(90.0);
    let u: Vec<f64> = (0..n)
        .map(|k| {
            let t = k as f64 * SAMPLE_TIME;
            if (5.0..45.0).contains(&t) {
                500.0
            } else {
                0.0
            }
        })
        .collect();
    let w = ctx.plant(SCENARIO.id)?.run(&u);
    let tip = ctx.beam().simulate(&w);
    Ok(ScenarioTrace::of(&SCENARIO, vec![time_axis(n), u, w, tip]))
}
fn figure(tr: &ScenarioTrace, _: &Traces) -> Option<Figure> {
    let t = tr.col("t");
    Some(Figure {
        title: "Fig. 2 — rectangular voltage: creep and remanent offset".into(),
        panels: vec![
            panel(
                "input",
                "t (s)",
                "u (V)",
                vec![series("u", t, tr.col("u"), COLORS[0])],
            ),
            panel(
                "effective voltage W[u]",
                "t (s)",
                "W[u] (V)",
                vec![series("W[u]", t, tr.col("w"), COLORS[1])],
            ),
            panel(
                "tip deflection",
                "t (s)",
                "w(L) (mm)",
                vec![series("tip", t, &scaled(tr.col("tip"), 1e3), COLORS[2])],
            ),
        ],
    })
}
fn claims(tr: &ScenarioTrace, _: &Traces) -> Vec<Claim> {
    let (t, w) = (tr.col("t"), tr.col("w"));
    let step = w[at_time(t, 5.2)];
    let offset = w[w.len() - 1];
    vec![Claim {
        figure: "Fig. 2",
        claim:
            "after the rectangle the output keeps a remanent offset (% of the response to the step)",
        measured: format!("{:.2} % at 90 s", 100.0 * offset / step),
        holds: offset / step > 1e-3,
    }]
}
