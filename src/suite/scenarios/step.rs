//! Figs. 12–13: a 100 V step at 1 s held 44 s through the beam, without
//! compensation (creep drift) and with it (the linear beam's step response).

use super::*;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::nominal::SAMPLE_TIME;

pub(super) static SCENARIO: Scenario = Scenario {
    id: "step",
    paper: "Figs. 12-13",
    description: "a 100 V step at 1 s held 44 s through the beam, without and with compensation",
    decimation: 25,
    columns: &[
        time(),
        input("v"),
        model_output("w_raw"),
        tip("tip_raw"),
        compensator_output("u"),
        model_output("w"),
        tip("tip"),
    ],
    compute,
    figure,
    claims,
};

fn compute(ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
    let n = samples(45.0);
    let v: Vec<f64> = (0..n)
        .map(|k| {
            if k as f64 * SAMPLE_TIME < 1.0 {
                0.0
            } else {
                100.0
            }
        })
        .collect();
    // without compensation: the voltage step goes straight to W
    let w_raw = ctx.plant(SCENARIO.id)?.run(&v);
    let tip_raw = ctx.beam().simulate(&w_raw);
    // with: the compensator shapes the voltage so that W gives the step
    let mut comp = ctx.compensator(SCENARIO.id, CompensatorSettings::default())?;
    let u: Vec<f64> = v.iter().map(|&t| comp.compensate(t).u).collect();
    let w = ctx.plant(SCENARIO.id)?.run(&u);
    let tip = ctx.beam().simulate(&w);
    Ok(ScenarioTrace::of(
        &SCENARIO,
        vec![time_axis(n), v, w_raw, tip_raw, u, w, tip],
    ))
}
fn figure(tr: &ScenarioTrace, _: &Traces) -> Option<Figure> {
    let tips = [
        ("tip_raw", "without compensation", GREY),
        ("tip", "with compensation", COLORS[0]),
    ];
    let voltages = [
        ("v", "step (uncompensated)", GREY),
        ("u", "compensator output", COLORS[1]),
    ];
    Some(Figure {
        title: "Figs. 12-13 — step response with and without compensation".into(),
        panels: vec![
            tr.time_panel("tip deflection", "w(L) (mm)", 1e3, &tips),
            tr.time_panel("balanced voltage", "u (V)", 1.0, &voltages),
        ],
    })
}
fn claims(tr: &ScenarioTrace, _: &Traces) -> Vec<Claim> {
    let t = tr.col("t");
    let (k0, k1) = (at_time(t, 1.2), at_time(t, 41.2));
    let drift = |w: &[f64]| 100.0 * (w[k1] - w[k0]) / w[k0];
    let before = drift(tr.col("w_raw"));
    let after = drift(tr.col("w"));
    let tip = tr.col("tip");
    let fin = tip[tip.len() - 1];
    let peak = tip.iter().fold(f64::NEG_INFINITY, |m, v| m.max(*v));
    let ks = at_time(t, 1.0);
    let settle = (ks..tip.len())
        .rev()
        .find(|&k| (tip[k] - fin).abs() > 0.02 * fin.abs())
        .map_or(0.0, |k| t[k + 1] - t[ks]);
    vec![
            Claim {
                figure: "Figs. 2, 12",
                claim: "creep drift of a 100 V step over 40 s (% of the value 0.2 s after the step)",
                measured: format!("{before:.2} % without, {after:.1e} % with compensation"),
                holds: before > 1.0 && after.abs() < 1e-6,
            },
            Claim {
                figure: "Fig. 13",
                claim: "compensated step response is that of a lightly damped linear beam (overshoot, 2 % settling time)",
                measured: format!(
                    "overshoot {:.1} %, settling {:.2} s, final {:.4} mm",
                    100.0 * (peak - fin) / fin,
                    settle,
                    fin * 1e3
                ),
                holds: peak > fin && settle > 0.0,
            },
        ]
}
