//! Fig. 3: a smooth staircase over the full range `[−1000, 1000]` V: the
//! hysteresis loop, with the vertical creep sections at each plateau.

use super::*;

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
    let signals = [("u", "u", COLORS[0]), ("w", "W[u]", COLORS[1])];
    let loops = [
        ("u", "w", "W[u] (with creep)", COLORS[1]),
        ("u", "h", "H[u] (hysteresis only)", COLORS[2]),
    ];
    Some(Figure {
        title: "Fig. 3 — staircase over the full range: hysteresis with creep".into(),
        panels: vec![
            tr.time_panel("time", "V", 1.0, &signals),
            tr.loop_panel("hysteresis loop", "u (V)", "effective voltage (V)", &loops),
        ],
    })
}
