//! Figures of the scenarios, mirroring the paper's (Figs. 2, 3, 8, 9, 10,
//! 12–14), written as SVG and PNG with `plotters` and the DejaVu Sans font
//! shipped in `assets/fonts` (no system fonts needed).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use crate::suite::scenarios::ScenarioTrace;

const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register() {
    REGISTER.call_once(|| {
        // the font is compiled in; it parses, or this build is broken
        let _ = register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// One curve.
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub color: RGBColor,
}

/// One panel: axes with units and curves.
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
}

/// A figure: panels stacked vertically.
pub struct Figure {
    pub title: String,
    pub panels: Vec<Panel>,
}

const COLORS: [RGBColor; 4] = [
    RGBColor(0, 0, 0),
    RGBColor(200, 40, 40),
    RGBColor(30, 90, 200),
    RGBColor(20, 140, 60),
];
const GREY: RGBColor = RGBColor(160, 160, 160);

fn series(label: &str, x: &[f64], y: &[f64], color: RGBColor) -> Series {
    // at most ~4000 points a curve: plenty for a figure, small files
    let step = (x.len() / 4000).max(1);
    Series {
        label: label.into(),
        points: x
            .iter()
            .zip(y)
            .step_by(step)
            .map(|(&a, &b)| (a, b))
            .collect(),
        color,
    }
}

fn scaled(v: &[f64], f: f64) -> Vec<f64> {
    v.iter().map(|x| x * f).collect()
}

fn window(t: &[f64], cols: &[&[f64]], lo: f64, hi: f64) -> (Vec<f64>, Vec<Vec<f64>>) {
    let idx: Vec<usize> = (0..t.len()).filter(|&k| t[k] >= lo && t[k] <= hi).collect();
    (
        idx.iter().map(|&k| t[k]).collect(),
        cols.iter()
            .map(|c| idx.iter().map(|&k| c[k]).collect())
            .collect(),
    )
}

fn bounds(panel: &Panel) -> (f64, f64, f64, f64) {
    let mut b = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for s in &panel.series {
        for &(x, y) in &s.points {
            if x.is_finite() && y.is_finite() {
                b = (b.0.min(x), b.1.max(x), b.2.min(y), b.3.max(y));
            }
        }
    }
    if !b.0.is_finite() {
        return (0.0, 1.0, 0.0, 1.0);
    }
    let pad = |lo: f64, hi: f64| {
        let d = (hi - lo).abs().max(1e-12 * hi.abs().max(1e-30));
        (lo - 0.04 * d, hi + 0.04 * d)
    };
    let (x0, x1) = if b.1 > b.0 { (b.0, b.1) } else { pad(b.0, b.1) };
    let (y0, y1) = pad(b.2, b.3);
    (x0, x1, y0, y1)
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, fig: &Figure) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(&fig.title, ("sans-serif", 22)).map_err(err)?;
    let areas = root.split_evenly((fig.panels.len(), 1));
    for (area, panel) in areas.iter().zip(&fig.panels) {
        let (x0, x1, y0, y1) = bounds(panel);
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(panel.x_label.as_str())
            .y_desc(panel.y_label.as_str())
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(err)?;
        for s in &panel.series {
            let color = s.color;
            chart
                .draw_series(LineSeries::new(
                    s.points.iter().copied(),
                    color.stroke_width(2),
                ))
                .map_err(err)?
                .label(s.label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                });
        }
        if panel.series.len() > 1 {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 13))
                .position(SeriesLabelPosition::LowerRight)
                .draw()
                .map_err(err)?;
        }
    }
    root.present().map_err(err)
}

/// Write `fig` as `stem.svg` and `stem.png`.
pub fn write_figure(fig: &Figure, stem: &Path) -> Result<Vec<PathBuf>, String> {
    register();
    let h = 330 * fig.panels.len() as u32 + 50;
    let svg = stem.with_extension("svg");
    let png = stem.with_extension("png");
    draw(SVGBackend::new(&svg, (1000, h)).into_drawing_area(), fig)
        .map_err(|e| format!("{}: {e}", svg.display()))?;
    draw(BitMapBackend::new(&png, (1000, h)).into_drawing_area(), fig)
        .map_err(|e| format!("{}: {e}", png.display()))?;
    Ok(vec![svg, png])
}

fn col<'a>(t: &'a ScenarioTrace, name: &str) -> &'a [f64] {
    t.column(name).unwrap_or(&[])
}

/// The figure of a scenario (`others` gives access to the other scenarios,
/// for overlays such as the uncompensated loop behind Fig. 10).
pub fn figure(
    id: &str,
    tr: &ScenarioTrace,
    others: &HashMap<&str, ScenarioTrace>,
) -> Option<Figure> {
    let t = col(tr, "t");
    let p = |title: &str, x: &str, y: &str, series: Vec<Series>| Panel {
        title: title.into(),
        x_label: x.into(),
        y_label: y.into(),
        series,
    };
    let fig = match id {
        "rectangle" => Figure {
            title: "Fig. 2 — rectangular voltage: creep and remanent offset".into(),
            panels: vec![
                p(
                    "input",
                    "t (s)",
                    "u (V)",
                    vec![series("u", t, col(tr, "u"), COLORS[0])],
                ),
                p(
                    "effective voltage W[u]",
                    "t (s)",
                    "W[u] (V)",
                    vec![series("W[u]", t, col(tr, "w"), COLORS[1])],
                ),
                p(
                    "tip deflection",
                    "t (s)",
                    "w(L) (mm)",
                    vec![series("tip", t, &scaled(col(tr, "tip"), 1e3), COLORS[2])],
                ),
            ],
        },
        "staircase" => Figure {
            title: "Fig. 3 — staircase over the full range: hysteresis with creep".into(),
            panels: vec![
                p(
                    "time",
                    "t (s)",
                    "V",
                    vec![
                        series("u", t, col(tr, "u"), COLORS[0]),
                        series("W[u]", t, col(tr, "w"), COLORS[1]),
                    ],
                ),
                p(
                    "hysteresis loop",
                    "u (V)",
                    "effective voltage (V)",
                    vec![
                        series("W[u] (with creep)", col(tr, "u"), col(tr, "w"), COLORS[1]),
                        series(
                            "H[u] (hysteresis only)",
                            col(tr, "u"),
                            col(tr, "h"),
                            COLORS[2],
                        ),
                    ],
                ),
            ],
        },
        "minor-loops" => Figure {
            title: "Fig. 8a — nested minor loops: Madelung rules, Masing congruence".into(),
            panels: vec![
                p(
                    "loops",
                    "u (V)",
                    "effective voltage (V)",
                    vec![
                        series("H[u]", col(tr, "u"), col(tr, "h"), COLORS[2]),
                        series("W[u]", col(tr, "u"), col(tr, "w"), COLORS[1]),
                    ],
                ),
                p(
                    "input",
                    "t (s)",
                    "u (V)",
                    vec![series("u", t, col(tr, "u"), COLORS[0])],
                ),
            ],
        },
        "intersection" => {
            let names = [
                ("u_a", "h_a", "virgin curve"),
                ("u_b", "h_b", "after 1000 V, -483.5 V"),
                ("u_c", "h_c", "after 900 V, -465.7 V"),
            ];
            let all: Vec<Series> = names
                .iter()
                .enumerate()
                .map(|(i, (u, h, l))| series(l, col(tr, u), col(tr, h), COLORS[i]))
                .collect();
            let zoom: Vec<Series> = names
                .iter()
                .enumerate()
                .map(|(i, (u, h, l))| {
                    let (x, ys) = window(col(tr, u), &[col(tr, h)], 150.0, 250.0);
                    series(l, &x, &ys[0], COLORS[i])
                })
                .collect();
            Figure {
                title: "Fig. 8b — intersection property: branches crossing at one point".into(),
                panels: vec![
                    p("three histories of H", "u (V)", "H[u] (V)", all),
                    p(
                        "detail: one point, input increasing, three slopes",
                        "u (V)",
                        "H[u] (V)",
                        zoom,
                    ),
                ],
            }
        }
        "log-creep" => {
            let u = col(tr, "u");
            let c = col(tr, "c");
            let mut panels_series = Vec::new();
            for j in 0..6 {
                let start = 20.0 * j as f64 + 0.1; // end of the j-th transition
                let at = |x: f64| t.iter().position(|&v| v >= x);
                let (Some(k0), Some(k1)) = (at(start), at(start + 19.8)) else {
                    continue;
                };
                if k0 + 2 >= k1 {
                    continue;
                }
                let x: Vec<f64> = (k0 + 1..k1).map(|k| (t[k] - t[k0]).log10()).collect();
                let y: Vec<f64> = (k0 + 1..k1).map(|k| c[k] - c[k0]).collect();
                panels_series.push(series(
                    &format!("plateau {} ({:.0} V)", j + 1, u[k1]),
                    &x,
                    &y,
                    COLORS[j % 4],
                ));
            }
            Figure {
                title: "Fig. 9 — creep over a logarithmic time axis".into(),
                panels: vec![
                    p(
                        "creep part C after each step",
                        "log10(t - t_step / s)",
                        "C - C(t_step) (V)",
                        panels_series,
                    ),
                    p(
                        "effective voltage",
                        "t (s)",
                        "W[u] (V)",
                        vec![series("W[u]", t, col(tr, "w"), COLORS[1])],
                    ),
                ],
            }
        }
        "identification" => {
            let e: Vec<f64> = col(tr, "y_fit")
                .iter()
                .zip(col(tr, "y"))
                .map(|(a, b)| a - b)
                .collect();
            Figure {
                title: "Sec. 4.1 — identification on a shrinking periodic staircase".into(),
                panels: vec![
                    p(
                        "measurement and identified model",
                        "t (s)",
                        "V",
                        vec![
                            series("measured y", t, col(tr, "y"), COLORS[0]),
                            series("identified W[u]", t, col(tr, "y_fit"), COLORS[1]),
                        ],
                    ),
                    p(
                        "fit error",
                        "t (s)",
                        "W[u] - y (V)",
                        vec![series("error", t, &e, COLORS[2])],
                    ),
                ],
            }
        }
        "compensated" => {
            let mut loop_series = Vec::new();
            if let Some(st) = others.get("staircase") {
                loop_series.push(series(
                    "without compensation: W[u] over u",
                    col(st, "u"),
                    col(st, "w"),
                    GREY,
                ));
            }
            loop_series.push(series(
                "with compensation: W[W^-1[y_d]] over y_d",
                col(tr, "y_d"),
                col(tr, "y"),
                COLORS[0],
            ));
            Figure {
                title: "Fig. 10 — compensated staircase: linear input-output".into(),
                panels: vec![
                    p(
                        "loops",
                        "commanded (V)",
                        "effective voltage (V)",
                        loop_series,
                    ),
                    p(
                        "patch voltages from the compensator",
                        "t (s)",
                        "V",
                        vec![
                            series("u_fs", t, col(tr, "u_fs"), COLORS[1]),
                            series("u_bs", t, col(tr, "u_bs"), COLORS[2]),
                        ],
                    ),
                    p(
                        "tip deflection",
                        "t (s)",
                        "w(L) (mm)",
                        vec![series("tip", t, &scaled(col(tr, "tip"), 1e3), COLORS[0])],
                    ),
                ],
            }
        }
        "step" => Figure {
            title: "Figs. 12-13 — step response with and without compensation".into(),
            panels: vec![
                p(
                    "tip deflection",
                    "t (s)",
                    "w(L) (mm)",
                    vec![
                        series(
                            "without compensation",
                            t,
                            &scaled(col(tr, "tip_raw"), 1e3),
                            GREY,
                        ),
                        series(
                            "with compensation",
                            t,
                            &scaled(col(tr, "tip"), 1e3),
                            COLORS[0],
                        ),
                    ],
                ),
                p(
                    "balanced voltage",
                    "t (s)",
                    "u (V)",
                    vec![
                        series("step (uncompensated)", t, col(tr, "v"), GREY),
                        series("compensator output", t, col(tr, "u"), COLORS[1]),
                    ],
                ),
            ],
        },
        "feedforward" => {
            let (tw, cs) = window(t, &[col(tr, "y_d"), col(tr, "tip")], 2.85, 3.1);
            let (td, ds) = window(t, &[col(tr, "y_d"), col(tr, "tip")], 2.96, 2.99);
            let (tu, us) = window(t, &[col(tr, "u_fs"), col(tr, "u_bs")], 2.85, 3.1);
            Figure {
                title: "Fig. 14 — flatness-based feedforward with compensation: 1 mm in 75 ms"
                    .into(),
                panels: vec![
                    p(
                        "tracking",
                        "t (s)",
                        "w(L) (mm)",
                        vec![
                            series("desired y_d", &tw, &scaled(&cs[0], 1e3), GREY),
                            series("simulated tip", &tw, &scaled(&cs[1], 1e3), COLORS[0]),
                        ],
                    ),
                    p(
                        "detail at the end of the transition",
                        "t (s)",
                        "w(L) (mm)",
                        vec![
                            series("desired y_d", &td, &scaled(&ds[0], 1e3), GREY),
                            series("simulated tip", &td, &scaled(&ds[1], 1e3), COLORS[0]),
                        ],
                    ),
                    p(
                        "patch voltages",
                        "t (s)",
                        "V",
                        vec![
                            series("u_fs", &tu, &us[0], COLORS[1]),
                            series("u_bs", &tu, &us[1], COLORS[2]),
                        ],
                    ),
                ],
            }
        }
        _ => return None,
    };
    Some(fig)
}
