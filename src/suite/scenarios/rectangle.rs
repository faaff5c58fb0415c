//! Fig. 2: a rectangular voltage, `u = 500 V` on `[5, 45)` s, else 0, for
//! 90 s: the creep after each edge and the remanent offset at the end.

use super::*;
use crate::operators::nominal::SAMPLE_TIME;

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
    Some(Figure {
        title: "Fig. 2 — rectangular voltage: creep and remanent offset".into(),
        panels: vec![
            tr.time_panel("input", "u (V)", 1.0, &[("u", "u", COLORS[0])]),
            tr.time_panel("W[u]", "W[u] (V)", 1.0, &[("w", "W[u]", COLORS[1])]),
            tr.tip_panel(COLORS[2]),
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
