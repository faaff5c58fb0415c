//! Figures of the scenarios (each scenario draws its own with these
//! helpers), mirroring the paper's (Figs. 2, 3, 8, 9, 10,
//! 12–14), written as SVG and PNG with `plotters` and the DejaVu Sans font
//! shipped in `assets/fonts` (no system fonts needed).

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

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

/// A panel with a title, axis labels and curves.
pub fn panel(title: &str, x_label: &str, y_label: &str, series: Vec<Series>) -> Panel {
    Panel {
        title: title.into(),
        x_label: x_label.into(),
        y_label: y_label.into(),
        series,
    }
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

pub const COLORS: [RGBColor; 4] = [
    RGBColor(0, 0, 0),
    RGBColor(200, 40, 40),
    RGBColor(30, 90, 200),
    RGBColor(20, 140, 60),
];
pub const GREY: RGBColor = RGBColor(160, 160, 160);

pub fn series(label: &str, x: &[f64], y: &[f64], color: RGBColor) -> Series {
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

pub fn scaled(v: &[f64], f: f64) -> Vec<f64> {
    v.iter().map(|x| x * f).collect()
}

pub fn window(t: &[f64], cols: &[&[f64]], lo: f64, hi: f64) -> (Vec<f64>, Vec<Vec<f64>>) {
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

/// Draw `fig` with curves `width` pixels wide.
///
/// The bitmap backend draws 1-pixel curves: its rasterizer turns a 2-pixel
/// segment that is exactly vertical in pixels (a step) into a line running
/// out of the panel, which showed in the step figure at t = 1 s.
fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    fig: &Figure,
    width: u32,
) -> Result<(), String> {
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
            let points = on_distinct_pixels(&s.points, |p| chart.backend_coord(p));
            chart
                .draw_series(LineSeries::new(points, color.stroke_width(width)))
                .map_err(err)?
                .label(s.label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(width))
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

/// The points of a curve without those that fall on the pixel of the point
/// kept before them: the drawn curve is the same (the backends draw between
/// whole pixels) and the files are several times smaller.
fn on_distinct_pixels(
    points: &[(f64, f64)],
    pixel: impl Fn(&(f64, f64)) -> (i32, i32),
) -> Vec<(f64, f64)> {
    let mut last = None;
    let mut kept = Vec::with_capacity(points.len());
    for p in points {
        let here = pixel(p);
        if last != Some(here) {
            kept.push(*p);
            last = Some(here);
        }
    }
    kept
}

/// Write `fig` as `stem.svg` and `stem.png`.
pub fn write_figure(fig: &Figure, stem: &Path) -> Result<Vec<PathBuf>, String> {
    let svg = stem.with_extension("svg");
    let png = stem.with_extension("png");
    write_figure_file(fig, &svg)?;
    write_figure_file(fig, &png)?;
    Ok(vec![svg, png])
}

/// Write `fig` to `path`, SVG or PNG by its extension, atomically (the old
/// file or the complete new one, see [`crate::io::write_atomic_via`]).
pub fn write_figure_file(fig: &Figure, path: &Path) -> Result<(), String> {
    register();
    let h = 330 * fig.panels.len() as u32 + 50;
    let extension = path.extension().and_then(|e| e.to_str());
    if !matches!(extension, Some("svg" | "png")) {
        return Err(format!("{}: name a .png or .svg file", path.display()));
    }
    let drawn = crate::io::write_atomic_via(path, |tmp| {
        if extension == Some("svg") {
            draw(SVGBackend::new(tmp, (1000, h)).into_drawing_area(), fig, 2)
        } else {
            draw(
                BitMapBackend::new(tmp, (1000, h)).into_drawing_area(),
                fig,
                1,
            )
        }
    });
    match drawn {
        Ok(Ok(())) => Ok(()),
        Ok(Err(e)) => Err(format!("{}: {e}", path.display())),
        Err(e) => Err(e.to_string()),
    }
}

/// The identification figure: measured and model output over the input
/// (the loops), and the residual over time, with the fitted samples marked.
pub fn write_identification_plot(
    path: &Path,
    u: &[f64],
    y: &[f64],
    fit: &[f64],
    sample_time: f64,
    fitted: &std::ops::Range<usize>,
    validation: &[(String, Vec<f64>)],
) -> Result<(), String> {
    let time = |n: usize| -> Vec<f64> { (0..n).map(|k| k as f64 * sample_time).collect() };
    let r = fitted.clone();
    let e: Vec<f64> = fit.iter().zip(y).map(|(a, b)| a - b).collect();
    let mut panels = vec![
        panel(
            "output over input (fitted samples)",
            "u",
            "y",
            vec![
                series("measured", &u[r.clone()], &y[r.clone()], COLORS[0]),
                series("identified model", &u[r.clone()], &fit[r], COLORS[1]),
            ],
        ),
        panel(
            "residual (model - measured) over time",
            "t (s)",
            "residual",
            vec![series("residual", &time(e.len()), &e, COLORS[2])],
        ),
    ];
    if !validation.is_empty() {
        let curves = validation
            .iter()
            .enumerate()
            .map(|(i, (name, e))| series(name, &time(e.len()), e, COLORS[(i + 3) % COLORS.len()]))
            .collect();
        panels.push(panel(
            "validation records: residual over time",
            "t (s)",
            "residual",
            curves,
        ));
    }
    let fig = Figure {
        title: "identification: measurement and identified model".into(),
        panels,
    };
    write_figure_file(&fig, path)
}

/// Output over input of several records in one panel (the loops at each
/// rate), each from sample `from` on.
pub fn write_loops_plot(
    path: &Path,
    title: &str,
    records: &[(String, &[f64], &[f64])],
    from: usize,
) -> Result<(), String> {
    let curves = records
        .iter()
        .enumerate()
        .map(|(i, (name, u, y))| {
            let k = from.min(u.len());
            series(name, &u[k..], &y[k..], COLORS[i % COLORS.len()])
        })
        .collect();
    let fig = Figure {
        title: title.into(),
        panels: vec![panel("output over input", "u (V)", "y", curves)],
    };
    write_figure_file(&fig, path)
}

#[cfg(test)]
mod tests {
    use super::on_distinct_pixels;

    /// Whole pixels of a point on a grid of 0.5 units, as a backend maps it.
    fn pixel(p: &(f64, f64)) -> (i32, i32) {
        ((p.0 * 2.0).floor() as i32, (p.1 * 2.0).floor() as i32)
    }

    #[test]
    fn thinning_keeps_the_curve_pixel_for_pixel() {
        // dense samples of a loop: out and back, with repeats and reversals
        let points: Vec<(f64, f64)> = (0..2000)
            .map(|k| {
                let t = k as f64 * 0.01;
                (5.0 * t.sin(), 3.0 * (1.3 * t).cos())
            })
            .collect();
        let kept = on_distinct_pixels(&points, pixel);
        assert!(
            kept.len() < points.len() / 2,
            "{} of {}",
            kept.len(),
            points.len()
        );
        // the pixel path with repeats collapsed is the same before and after
        let path = |ps: &[(f64, f64)]| {
            let mut out: Vec<(i32, i32)> = ps.iter().map(pixel).collect();
            out.dedup();
            out
        };
        assert_eq!(path(&kept), path(&points));
        // no two kept neighbours share a pixel, and the first point stays
        assert!(kept.windows(2).all(|w| pixel(&w[0]) != pixel(&w[1])));
        assert_eq!(kept[0], points[0]);
    }

    #[test]
    fn an_empty_or_single_point_curve_is_kept() {
        assert!(on_distinct_pixels(&[], pixel).is_empty());
        assert_eq!(on_distinct_pixels(&[(1.0, 2.0)], pixel), vec![(1.0, 2.0)]);
    }
}
