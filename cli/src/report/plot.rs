//! The experiments' plots: SVG line and scatter plots a person can read
//! (plotters), written whole or not at all through [`crate::output`].

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::output::write_bytes;

/// A line of a plot: its name, points, colour (an index into a fixed
/// palette, so that related lines can share one) and whether it is dashed.
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub color: usize,
    pub dashed: bool,
}

/// Draws `series` as lines on a 900×560 SVG; `log2_x` puts x on a log₂ axis
/// (ticks labelled with the real values).
pub fn line_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log2_x: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let mut svg = String::new();
    let tx = |x: f64| if log2_x { x.log2() } else { x };
    let xs = series.iter().flat_map(|s| s.points.iter().map(|p| tx(p.0)));
    let (x0, x1) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    let y1 = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .fold(0.0f64, f64::max)
        * 1.08;
    let root = SVGBackend::with_string(&mut svg, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = frame(&root, title, 22).build_cartesian_2d(x0..x1, 0.0..y1.max(1e-9))?;
    let fmt_x = |v: &f64| {
        if log2_x {
            let b = 2f64.powf(*v).round();
            if b >= 1024.0 {
                format!("{} KiB", b / 1024.0)
            } else {
                format!("{b} B")
            }
        } else {
            format!("{v}")
        }
    };
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .x_labels(if log2_x { (x1 - x0) as usize + 1 } else { 10 })
        .x_label_formatter(&fmt_x)
        .draw()?;
    for s in series {
        let color = Palette99::pick(s.color).to_rgba();
        let pts: Vec<(f64, f64)> = s.points.iter().map(|&(x, y)| (tx(x), y)).collect();
        let style = color.stroke_width(2);
        if s.dashed {
            chart
                .draw_series(DashedLineSeries::new(pts.clone(), 6, 4, style))?
                .label(&s.name)
                .legend(legend_line(color, 5));
        } else {
            chart
                .draw_series(LineSeries::new(pts.clone(), style))?
                .label(&s.name)
                .legend(legend_line(color, 18));
        }
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
    }
    labels(&mut chart, SeriesLabelPosition::UpperLeft)?;
    root.present()?;
    drop(chart);
    drop(root);
    write_bytes(path, svg.as_bytes())?;
    Ok(())
}

/// Draws `points` as dots (one colour per series) and `fronts` as step
/// lines through their points on a 900×600 SVG, x on a log₁₀ axis: the
/// scatter of a speed/quality trade with its Pareto fronts.
pub fn scatter_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    points: &[Series],
    fronts: &[Series],
) -> Result<(), Box<dyn std::error::Error>> {
    let mut svg = String::new();
    {
        let all = points.iter().chain(fronts).flat_map(|s| s.points.iter());
        let (mut x0, mut x1, mut y1) = (f64::INFINITY, 0.0f64, 0.0f64);
        for &(x, y) in all.filter(|p| p.0 > 0.0 && p.0.is_finite() && p.1.is_finite()) {
            (x0, x1, y1) = (x0.min(x), x1.max(x), y1.max(y));
        }
        if !x0.is_finite() {
            (x0, x1) = (1.0, 10.0);
        }
        let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = frame(&root, title, 20)
            .build_cartesian_2d((x0 / 1.5..x1 * 1.5).log_scale(), 0.0..(y1 * 1.08).max(1e-9))?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .draw()?;
        for s in fronts {
            let color = Palette99::pick(s.color).to_rgba();
            let mut steps = Vec::new();
            for w in s.points.windows(2) {
                steps.extend([w[0], (w[1].0, w[0].1)]);
            }
            steps.extend(s.points.last());
            chart
                .draw_series(DashedLineSeries::new(steps, 6, 4, color.stroke_width(2)))?
                .label(&s.name)
                .legend(legend_line(color, 18));
        }
        for s in points {
            let color = Palette99::pick(s.color).to_rgba();
            chart
                .draw_series(s.points.iter().map(|&p| Circle::new(p, 4, color.filled())))?
                .label(&s.name)
                .legend(move |(x, y)| Circle::new((x + 9, y), 4, color.filled()));
        }
        labels(&mut chart, SeriesLabelPosition::UpperRight)?;
        root.present()?;
    }
    write_bytes(path, svg.as_bytes())?;
    Ok(())
}

/// A legend entry's mark: a line `length` pixels long in `color`.
fn legend_line(color: RGBAColor, length: i32) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + length, y)], color.stroke_width(2))
}

/// Draws the series' names at `position`, on a light box.
fn labels<'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, CT>,
    position: SeriesLabelPosition,
) -> Result<(), Box<dyn std::error::Error>> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .draw()?;
    Ok(())
}

/// A chart's frame on `root`: its title (in `size` points), its margin and
/// the room for its axes' labels.
fn frame<'a, 'b, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: &str,
    size: u32,
) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(root);
    // A model that is not the default is named in every plot's title.
    let title = match crate::args::model_note() {
        Some(model) => format!("{title} ({model})"),
        None => title.to_string(),
    };
    b.caption(title, ("sans-serif", size))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(64);
    b
}
