//! Horizontal bar charts (a value per named case, e.g. force / control in a disruption
//! study), PNG or SVG by the file extension, written atomically.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::plot::{render, PlotError, PlotFormat, FONT_FAMILY};

/// A bar chart: one bar per `(label, value)`, top to bottom in the given order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BarSpec {
    /// Title above the chart.
    pub title: String,
    /// Label of the value axis.
    pub value_label: String,
    /// Bars: label and value.
    pub bars: Vec<(String, f64)>,
    /// A vertical reference line (e.g. 1 for force / control).
    pub reference: Option<f64>,
}

/// Draws `spec` into `path` (`.png` or `.svg`).
pub fn plot_bars(path: &Path, spec: &BarSpec) -> Result<(), PlotError> {
    let format = PlotFormat::of(path)?;
    let height = 120 + 28 * spec.bars.len().max(1) as u32;
    render(
        path,
        format,
        (900, height),
        |root| draw(root, spec),
        |root| draw(root, spec),
    )
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, spec: &BarSpec) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let n = spec.bars.len().max(1) as f64;
    let hi = spec
        .bars
        .iter()
        .map(|b| b.1)
        .chain(spec.reference)
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let x_max = if hi > 0.0 { 1.25 * hi } else { 1.0 };
    let mut chart = ChartBuilder::on(&root)
        .caption(&spec.title, (FONT_FAMILY, 22))
        .margin(20)
        .x_label_area_size(45)
        .y_label_area_size(10)
        .build_cartesian_2d(0.0..x_max, 0.0..n)
        .map_err(e)?;
    chart
        .configure_mesh()
        .disable_y_mesh()
        .disable_y_axis()
        .x_desc(&spec.value_label)
        .label_style((FONT_FAMILY, 15))
        .axis_desc_style((FONT_FAMILY, 17))
        .draw()
        .map_err(e)?;
    let color = RGBColor(31, 119, 180);
    for (i, (label, value)) in spec.bars.iter().enumerate() {
        let top = n - i as f64;
        if value.is_finite() {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(0.0, top - 0.85), (*value, top - 0.15)],
                    color.mix(0.45).filled(),
                )))
                .map_err(e)?;
        }
        let text = format!("{label}  {value:.3}");
        chart
            .draw_series(std::iter::once(Text::new(
                text,
                (0.01 * x_max, top - 0.35),
                (FONT_FAMILY, 15).into_font(),
            )))
            .map_err(e)?;
    }
    if let Some(r) = spec.reference.filter(|r| r.is_finite()) {
        chart
            .draw_series(LineSeries::new(
                [(r, 0.0), (r, n)],
                ShapeStyle::from(RGBColor(214, 39, 40)).stroke_width(2),
            ))
            .map_err(e)?;
    }
    root.present().map_err(e)?;
    Ok(())
}
