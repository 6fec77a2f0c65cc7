//! Tornado (sensitivity) charts: one horizontal bar per parameter, spanning from the
//! result with the parameter lowered to the result with it raised (e.g. the relative
//! change of a study's force when a modulus is halved and increased by half), largest span
//! on top. PNG or SVG by the file extension, written atomically.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::plot::{render, PlotError, PlotFormat, FONT_FAMILY};

/// One bar of a tornado chart.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TornadoBar {
    /// The parameter (e.g. `cytoplasm`).
    pub label: String,
    /// The result with the parameter lowered (`None`: not available, e.g. a failed case).
    pub low: Option<f64>,
    /// The result with the parameter raised.
    pub high: Option<f64>,
}

impl TornadoBar {
    /// The bar's extent: from the smallest to the largest of the reference, `low` and
    /// `high`.
    pub fn extent(&self, reference: f64) -> (f64, f64) {
        let values = [Some(reference), self.low, self.high];
        let finite = values.iter().flatten().filter(|v| v.is_finite());
        let lo = finite.clone().fold(f64::INFINITY, |a, &b| a.min(b));
        let hi = finite.fold(f64::NEG_INFINITY, |a, &b| a.max(b));
        (lo, hi)
    }

    /// Width of the bar (the sort key of a tornado chart).
    pub fn span(&self, reference: f64) -> f64 {
        let (lo, hi) = self.extent(reference);
        hi - lo
    }
}

/// A tornado chart. Bars are drawn top to bottom in the given order (sort them by
/// [`TornadoBar::span`] first); each bar is two segments from the reference line, one to
/// `low` and one to `high`, in two colours named in the legend.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TornadoSpec {
    /// Title above the chart.
    pub title: String,
    /// Label of the value axis (e.g. `force change from control (%)`).
    pub value_label: String,
    /// Legend entry of the `low` segments (e.g. `modulus x 0.5`).
    pub low_label: String,
    /// Legend entry of the `high` segments.
    pub high_label: String,
    /// The bars.
    pub bars: Vec<TornadoBar>,
    /// Where the bars start (the control: 0 for a relative change).
    pub reference: f64,
}

/// Draws `spec` into `path` (`.png` or `.svg`).
pub fn plot_tornado(path: &Path, spec: &TornadoSpec) -> Result<(), PlotError> {
    let format = PlotFormat::of(path)?;
    let height = 170 + 40 * spec.bars.len().max(1) as u32;
    render(
        path,
        format,
        (900, height),
        |root| draw(root, spec),
        |root| draw(root, spec),
    )
}

const LOW: RGBColor = RGBColor(31, 119, 180);
const HIGH: RGBColor = RGBColor(255, 127, 14);

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    spec: &TornadoSpec,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let n = spec.bars.len().max(1) as f64;
    let r = if spec.reference.is_finite() {
        spec.reference
    } else {
        0.0
    };
    let (lo, hi) = spec
        .bars
        .iter()
        .map(|b| b.extent(r))
        .fold((r, r), |(a, b), (c, d)| (a.min(c), b.max(d)));
    // Room on both sides for the value labels; a chart of zeros still has a width.
    let half = (hi - r).max(r - lo).max(1e-9);
    let pad = 0.45 * half;
    let (x0, x1) = (lo.min(r - 0.15 * half) - pad, hi.max(r + 0.15 * half) + pad);
    // Title and legend above the chart.
    let (head, body) = root.split_vertically(80);
    let head = head.titled(&spec.title, (FONT_FAMILY, 22)).map_err(e)?;
    for (k, (label, color)) in [(&spec.low_label, LOW), (&spec.high_label, HIGH)]
        .into_iter()
        .enumerate()
    {
        let x = 160 + 260 * k as i32;
        head.draw(&Rectangle::new(
            [(x, 12), (x + 22, 26)],
            color.mix(0.75).filled(),
        ))
        .map_err(e)?;
        head.draw(&Text::new(
            label.clone(),
            (x + 30, 11),
            (FONT_FAMILY, 15).into_font(),
        ))
        .map_err(e)?;
    }
    let mut chart = ChartBuilder::on(&body)
        .margin(20)
        .margin_top(5)
        .x_label_area_size(45)
        .y_label_area_size(130)
        .build_cartesian_2d(x0..x1, 0.0..n)
        .map_err(e)?;
    let labels: Vec<String> = spec.bars.iter().map(|b| b.label.clone()).collect();
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(spec.bars.len().max(1) * 2 + 1)
        .y_label_formatter(&|y| {
            // A label at each bar's centre (n - i - 0.5), none elsewhere.
            let k = n - y - 0.5;
            let i = k.round();
            if (k - i).abs() < 1e-6 && i >= 0.0 {
                labels.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .x_desc(&spec.value_label)
        .label_style((FONT_FAMILY, 15))
        .axis_desc_style((FONT_FAMILY, 17))
        .draw()
        .map_err(e)?;
    let text_offset = 0.01 * (x1 - x0);
    for (i, bar) in spec.bars.iter().enumerate() {
        let top = n - i as f64;
        // The longer segment first, so a shorter one on the same side stays visible.
        let mut segments: Vec<(f64, RGBColor, f64)> = [(bar.low, LOW, 0.0), (bar.high, HIGH, 0.0)]
            .into_iter()
            .filter_map(|(v, c, _)| v.filter(|v| v.is_finite()).map(|v| (v, c, (v - r).abs())))
            .collect();
        segments.sort_by(|a, b| b.2.total_cmp(&a.2));
        for (v, color, _) in &segments {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(r, top - 0.8), (*v, top - 0.2)],
                    color.mix(0.75).filled(),
                )))
                .map_err(e)?;
        }
        for (v, _, _) in &segments {
            // The value just outside the segment's end.
            let (x, h) = if *v >= r {
                (v + text_offset, HPos::Left)
            } else {
                (v - text_offset, HPos::Right)
            };
            let style =
                TextStyle::from((FONT_FAMILY, 14).into_font()).pos(Pos::new(h, VPos::Center));
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("{v:+.1}"),
                    (x, top - 0.5),
                    style,
                )))
                .map_err(e)?;
        }
        if segments.is_empty() {
            chart
                .draw_series(std::iter::once(Text::new(
                    "no result".to_string(),
                    (r + text_offset, top - 0.6),
                    (FONT_FAMILY, 14).into_font(),
                )))
                .map_err(e)?;
        }
    }
    chart
        .draw_series(LineSeries::new(
            [(r, 0.0), (r, n)],
            ShapeStyle::from(BLACK).stroke_width(2),
        ))
        .map_err(e)?;
    root.present().map_err(e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::scratch_dir;

    fn spec() -> TornadoSpec {
        TornadoSpec {
            title: "Sensitivity".into(),
            value_label: "force change from control (%)".into(),
            low_label: "modulus x 0.5".into(),
            high_label: "modulus x 1.5".into(),
            bars: vec![
                TornadoBar {
                    label: "cytoplasm".into(),
                    low: Some(-30.0),
                    high: Some(20.0),
                },
                TornadoBar {
                    label: "nucleus".into(),
                    low: Some(-1.0),
                    high: None,
                },
            ],
            reference: 0.0,
        }
    }

    #[test]
    fn the_extent_spans_low_high_and_the_reference() {
        let b = &spec().bars;
        assert_eq!(b[0].extent(0.0), (-30.0, 20.0));
        assert_eq!(b[0].span(0.0), 50.0);
        assert_eq!(b[1].extent(0.0), (-1.0, 0.0));
        let same_side = TornadoBar {
            label: "x".into(),
            low: Some(2.0),
            high: Some(5.0),
        };
        assert_eq!(same_side.extent(0.0), (0.0, 5.0));
    }

    #[test]
    fn renders_svg_and_png_with_the_labels() {
        let dir = scratch_dir("tornado");
        let svg = dir.join("tornado.svg");
        plot_tornado(&svg, &spec()).unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        for word in [
            "Sensitivity",
            "cytoplasm",
            "nucleus",
            "modulus x 0.5",
            "-30.0",
            "+20.0",
        ] {
            assert!(text.contains(word), "{word} missing");
        }
        let png = dir.join("tornado.png");
        plot_tornado(&png, &spec()).unwrap();
        assert_eq!(&std::fs::read(&png).unwrap()[..4], b"\x89PNG");
        let empty = TornadoSpec::default();
        plot_tornado(&dir.join("empty.svg"), &empty).unwrap();
        assert!(plot_tornado(&dir.join("t.pdf"), &spec()).is_err());
    }
}
