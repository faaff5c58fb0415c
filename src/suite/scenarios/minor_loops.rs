//! Fig. 8a: nested reversals inside the major loop — the Madelung rules and
//! Masing congruence, seen in the input–output plane.

use super::*;

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
    let loops = [("u", "h", "H[u]", COLORS[2]), ("u", "w", "W[u]", COLORS[1])];
    Some(Figure {
        title: "Fig. 8a — nested minor loops: Madelung rules, Masing congruence".into(),
        panels: vec![
            tr.loop_panel("loops", "u (V)", "effective voltage (V)", &loops),
            tr.time_panel("input", "u (V)", 1.0, &[("u", "u", COLORS[0])]),
        ],
    })
}
