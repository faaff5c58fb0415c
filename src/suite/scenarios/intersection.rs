//! Fig. 8b: three histories of `H` reaching one point of the input–output
//! plane with the input increasing, with different slopes there.

use super::*;

const NAMES: [(&str, &str, &str); 3] = [
    ("u_a", "h_a", "virgin curve"),
    ("u_b", "h_b", "after 1000 V, -483.5 V"),
    ("u_c", "h_c", "after 900 V, -465.7 V"),
];

pub(super) static SCENARIO: Scenario = Scenario {
    id: "intersection",
    paper: "Fig. 8b",
    description: "three histories of H reaching one point with the input increasing",
    decimation: 10,
    columns: &[
        time(),
        input("u_a"),
        model_output("h_a"),
        input("u_b"),
        model_output("h_b"),
        input("u_c"),
        model_output("h_c"),
    ],
    compute,
    figure,
    claims: no_claims,
};

fn compute(ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
    // the virgin curve to 200 V, and branches rising from reversals on the
    // descending branches from 1000 V and 900 V that cross it at 200 V
    let paths = [
        ramps(&[300.0], 400.0),
        ramps(&[1000.0, -483.5, 300.0], 400.0),
        ramps(&[900.0, -465.7, 300.0], 400.0),
    ];
    let n = paths.iter().map(Vec::len).max().unwrap_or(0);
    let mut columns = vec![("t", time_axis(n))];
    for (p, (un, hn, _)) in paths.iter().zip(NAMES) {
        let mut u = p.clone();
        let last = *u.last().expect("a path has samples");
        u.resize(n, last); // hold the end value
        let h = ctx.model.hysteresis().clone().run(&u);
        columns.push((un, u));
        columns.push((hn, h));
    }
    Ok(ScenarioTrace { columns })
}
fn figure(tr: &ScenarioTrace, _: &Traces) -> Option<Figure> {
    let all: Vec<Series> = NAMES
        .iter()
        .enumerate()
        .map(|(i, (u, h, l))| series(l, tr.col(u), tr.col(h), COLORS[i]))
        .collect();
    let zoom: Vec<Series> = NAMES
        .iter()
        .enumerate()
        .map(|(i, (u, h, l))| {
            let (x, ys) = window(tr.col(u), &[tr.col(h)], 150.0, 250.0);
            series(l, &x, &ys[0], COLORS[i])
        })
        .collect();
    Some(Figure {
        title: "Fig. 8b — intersection property: branches crossing at one point".into(),
        panels: vec![
            panel("three histories of H", "u (V)", "H[u] (V)", all),
            panel(
                "detail: one point, input increasing, three slopes",
                "u (V)",
                "H[u] (V)",
                zoom,
            ),
        ],
    })
}
