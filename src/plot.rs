//! SVG charts (plotters): line charts of simulated trajectories against
//! time, linear or logarithmic in y, and the rate–noise trade-off figure.

use plotters::prelude::*;
use std::path::Path;

/// One named curve of a chart.
pub struct Series {
    /// Legend label.
    pub name: String,
    /// Points (t, value).
    pub points: Vec<(f64, f64)>,
    /// Colour of the line.
    pub color: RGBColor,
    /// Dashed (estimates, envelopes) or solid (true values).
    pub dashed: bool,
}

impl Series {
    /// A solid or dashed series.
    pub fn new(
        name: impl Into<String>,
        points: Vec<(f64, f64)>,
        color: RGBColor,
        dashed: bool,
    ) -> Self {
        Series {
            name: name.into(),
            points,
            color,
            dashed,
        }
    }
}

/// The palette used for successive series.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

/// Draws `series` into an SVG file at `path`; `log_y` uses a logarithmic y
/// axis (non-positive values are dropped from the log plot, not clamped).
/// The x axis is time, "t [s]" ([`line_chart_x`] names another).
pub fn line_chart(
    path: &Path,
    title: &str,
    y_label: &str,
    series: &[Series],
    log_y: bool,
) -> Result<(), String> {
    line_chart_x(path, title, ("t [s]", y_label), series, log_y)
}

/// [`line_chart`] with the x axis named `labels.0` (and the y axis
/// `labels.1`): for figures against something other than time.
pub fn line_chart_x(
    path: &Path,
    title: &str,
    (x_label, y_label): (&str, &str),
    series: &[Series],
    log_y: bool,
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let pts = |s: &Series| -> Vec<(f64, f64)> {
        s.points
            .iter()
            .copied()
            .filter(|&(t, v)| t.is_finite() && v.is_finite() && (!log_y || v > 0.0))
            .collect()
    };
    let all: Vec<(f64, f64)> = series.iter().flat_map(pts).collect();
    if all.is_empty() {
        return Err(format!("{}: nothing to plot", path.display()));
    }
    let (t0, t1) = all
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let t1 = if t1 > t0 { t1 } else { t0 + 1.0 };
    let (y0, y1) = y_range(all.iter().map(|p| p.1), log_y);
    // The legend stands to the right of the plot, where it hides no curve.
    let longest = series
        .iter()
        .map(|s| s.name.chars().count())
        .max()
        .unwrap_or(0);
    let legend_w = (48 + 8 * longest).min(420) as u32;
    let root = SVGBackend::new(path, (900 + legend_w, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (plot, legend) = root.split_horizontally(900);
    draw_legend(&legend, series).map_err(|e| err(&e))?;
    let mut builder = ChartBuilder::on(&plot);
    builder
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70);
    macro_rules! draw {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .y_label_formatter(&|v: &f64| {
                    if log_y {
                        format!("{v:.0e}")
                    } else {
                        format!("{v:.3}")
                    }
                })
                .draw()
                .map_err(|e| err(&e))?;
            for s in series {
                let p = pts(s);
                let style = s.color.stroke_width(2);
                if s.dashed {
                    chart
                        .draw_series(DashedLineSeries::new(p, 6, 4, style))
                        .map_err(|e| err(&e))?;
                } else {
                    chart
                        .draw_series(LineSeries::new(p, style))
                        .map_err(|e| err(&e))?;
                }
            }
        }};
    }
    if log_y {
        draw!(builder
            .build_cartesian_2d(t0..t1, (y0..y1).log_scale())
            .map_err(|e| err(&e))?);
    } else {
        draw!(builder
            .build_cartesian_2d(t0..t1, y0..y1)
            .map_err(|e| err(&e))?);
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// The y range of a chart of `values`: on a log scale from the decade at
/// least a quarter decade below the smallest positive value (so that the
/// lowest points are drawn clear of the axis, not on it) to the decade at or above the
/// largest, at most 16 decades; on a linear scale the values' range with 5 %
/// on either side.
pub fn y_range(values: impl Iterator<Item = f64>, log_y: bool) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log_y || *v > 0.0))
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    if lo > hi {
        return if log_y { (0.1, 1.0) } else { (0.0, 1.0) };
    }
    if log_y {
        let top = 10f64.powf(hi.log10().ceil());
        let lo = lo.max(hi * 1e-16);
        // at least a quarter decade of room below the lowest point
        let floor = 10f64.powf((lo.log10() - 0.25).floor());
        (floor, top)
    } else {
        let pad = if hi > lo {
            0.05 * (hi - lo)
        } else {
            1e-3_f64.max(lo.abs() * 0.1)
        };
        (lo - pad, hi + pad)
    }
}

/// The legend of a line chart in its own area: one entry per series, its
/// line (dashed or solid) and its name.
fn draw_legend(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    series: &[Series],
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    for (k, s) in series.iter().enumerate() {
        let y = 50 + 24 * k as i32;
        let style = s.color.stroke_width(2);
        let pieces: &[(i32, i32)] = if s.dashed {
            &[(4, 14), (20, 30)]
        } else {
            &[(4, 30)]
        };
        for &(a, b) in pieces {
            area.draw(&PathElement::new(vec![(a, y), (b, y)], style))?;
        }
        area.draw(&Text::new(
            s.name.clone(),
            (38, y - 8),
            ("sans-serif", 15).into_font().color(&BLACK),
        ))?;
    }
    Ok(())
}

/// One panel of [`tradeoff_chart`]: a curve against α, its knee point.
fn tradeoff_panel(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    y_label: &str,
    points: &[(f64, f64)],
    knee: Option<(f64, f64)>,
    color: RGBColor,
    err: &dyn Fn(&dyn std::fmt::Display) -> String,
) -> Result<(), String> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|&(a, v)| a.is_finite() && v.is_finite() && v > 0.0)
        .collect();
    if pts.is_empty() {
        return Err(err(&"nothing to plot"));
    }
    let (a0, a1) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), p| (l.min(p.0), h.max(p.0)));
    let (y0, y1) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), p| (l.min(p.1), h.max(p.1)));
    let (a0, a1) = if a1 > a0 {
        (a0 - 0.03 * (a1 - a0), a1 + 0.03 * (a1 - a0))
    } else {
        (a0 - 1.0, a0 + 1.0)
    };
    let (y0, y1) = if y1 > y0 {
        (y0 / 1.5, y1 * 1.5)
    } else {
        (y0 / 10.0, y0 * 10.0)
    };
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(a0..a1, (y0..y1).log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("decay rate alpha [1/s]")
        .y_desc(y_label)
        .y_label_formatter(&|v: &f64| format!("{v:.1e}"))
        .draw()
        .map_err(|e| err(&e))?;
    let style = color.stroke_width(2);
    chart
        .draw_series(LineSeries::new(pts.clone(), style))
        .map_err(|e| err(&e))?
        .label(y_label.to_string())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
    chart
        .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
        .map_err(|e| err(&e))?;
    if let Some(k) = knee.filter(|k| k.1.is_finite() && k.1 > 0.0) {
        let red = RGBColor(214, 39, 40);
        chart
            .draw_series(std::iter::once(Circle::new(k, 7, red.stroke_width(2))))
            .map_err(|e| err(&e))?
            .label(format!("knee (alpha = {:.3})", k.0))
            .legend(move |(x, y)| Circle::new((x + 9, y), 5, red.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| err(&e))?;
    Ok(())
}

/// The rate–noise trade-off figure: two panels against α (logarithmic y),
/// the certified error bound per unit noise amplitude above and the largest
/// gain max ‖L_l‖₂ below, each with the knee circled. `points` are
/// (α, error bound, max gain) of the certified points.
pub fn tradeoff_chart(
    path: &Path,
    title: &str,
    points: &[(f64, f64, f64)],
    knee: Option<(f64, f64, f64)>,
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let root = SVGBackend::new(path, (900, 760)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(title, ("sans-serif", 22))
        .map_err(|e| err(&e))?;
    let (upper, lower) = root.split_vertically(370);
    let eb: Vec<(f64, f64)> = points.iter().map(|p| (p.0, p.1)).collect();
    let gain: Vec<(f64, f64)> = points.iter().map(|p| (p.0, p.2)).collect();
    tradeoff_panel(
        &upper,
        "certified ||e(inf)|| per unit noise",
        &eb,
        knee.map(|k| (k.0, k.1)),
        PALETTE[0],
        &err,
    )?;
    tradeoff_panel(
        &lower,
        "max ||L_l||_2",
        &gain,
        knee.map(|k| (k.0, k.2)),
        PALETTE[2],
        &err,
    )?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
