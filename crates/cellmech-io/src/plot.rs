//! Line plots to PNG or SVG with plotters, using the bundled DejaVu Sans font (no system
//! font libraries at run time). The format follows the path's extension; the file is
//! written to a temporary file and renamed over the target (atomic).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::atomic::{commit_temp, temp_path, write_atomic};
use crate::error::WriteError;

/// DejaVu Sans (license in `assets/DejaVuSans-LICENSE.txt`).
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
pub(crate) const FONT_FAMILY: &str = "sans-serif";
const SIZE: (u32, u32) = (900, 600);
const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 23, 23),
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SeriesStyle {
    /// A polyline through the points.
    #[default]
    Line,
    /// A filled circle per point.
    Markers,
    /// Both.
    LineAndMarkers,
}

/// One labelled data series.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend entry.
    pub label: String,
    /// `(x, y)` points; non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub style: SeriesStyle,
}

/// A complete x-y plot.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlotSpec {
    /// Title above the plot.
    pub title: String,
    /// x-axis label, with unit (e.g. `indentation (µm)`).
    pub x_label: String,
    /// y-axis label, with unit.
    pub y_label: String,
    /// Series, drawn in order with distinct colours.
    pub series: Vec<Series>,
}

/// A plot that could not be produced.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The extension is neither `.png` nor `.svg`.
    #[error("{}: unknown plot format; use a .png or .svg file name", path.display())]
    UnknownFormat {
        /// The requested file.
        path: PathBuf,
    },
    /// The bundled font could not be loaded.
    #[error("the bundled font could not be loaded")]
    Font,
    /// Plotters failed while drawing.
    #[error("{}: drawing failed: {message}", path.display())]
    Draw {
        /// The requested file.
        path: PathBuf,
        /// Plotters' message.
        message: String,
    },
    /// The picture cannot be drawn as given (nothing to draw, zero extent, bad view angles).
    #[error("{}: {reason}", path.display())]
    InvalidPicture {
        /// The requested file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// Writing failed.
    #[error(transparent)]
    Write(#[from] WriteError),
}

pub(crate) fn register_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

/// Draws `spec` into `path` (`.png` or `.svg`, case-insensitive).
pub fn plot_xy(path: &Path, spec: &PlotSpec) -> Result<(), PlotError> {
    let format = PlotFormat::of(path)?;
    render(
        path,
        format,
        SIZE,
        |root| draw(root, spec),
        |root| draw(root, spec),
    )
}

/// Output format of a picture, chosen by the file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PlotFormat {
    Png,
    Svg,
}

impl PlotFormat {
    /// The format for `path`'s extension (`.png` or `.svg`, case-insensitive).
    pub(crate) fn of(path: &Path) -> Result<Self, PlotError> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        match ext.as_str() {
            "png" => Ok(Self::Png),
            "svg" => Ok(Self::Svg),
            _ => Err(PlotError::UnknownFormat {
                path: path.to_path_buf(),
            }),
        }
    }
}

/// Renders a picture of `size` pixels into `path` with the bundled font registered: the
/// bitmap drawer for PNG, the SVG drawer for SVG (two closures because the backends are
/// different types). The file is replaced atomically; nothing is left behind on failure.
pub(crate) fn render<P, S>(
    path: &Path,
    format: PlotFormat,
    size: (u32, u32),
    draw_png: P,
    draw_svg: S,
) -> Result<(), PlotError>
where
    P: FnOnce(DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), String>,
    S: FnOnce(DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), String>,
{
    register_font()?;
    let draw_err = |message: String| PlotError::Draw {
        path: path.to_path_buf(),
        message,
    };
    match format {
        PlotFormat::Png => {
            let temp = temp_path(path, "png");
            let result = {
                let root = BitMapBackend::new(&temp, size).into_drawing_area();
                draw_png(root)
            };
            if let Err(message) = result {
                let _ = std::fs::remove_file(&temp);
                return Err(draw_err(message));
            }
            commit_temp(&temp, path).map_err(|source| {
                let _ = std::fs::remove_file(&temp);
                WriteError {
                    path: path.to_path_buf(),
                    source,
                }
            })?;
            Ok(())
        }
        PlotFormat::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
                draw_svg(root).map_err(draw_err)?;
            }
            write_atomic(path, svg.as_bytes())?;
            Ok(())
        }
    }
}

/// Axis range covering the finite values and zero, with a 5 % margin; `(0, 1)` when empty.
pub(crate) fn axis_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if hi - lo <= 0.0 || !(hi - lo).is_finite() {
        return (0.0, 1.0);
    }
    let pad = 0.05 * (hi - lo);
    (
        if lo < 0.0 { lo - pad } else { lo },
        if hi > 0.0 { hi + pad } else { hi },
    )
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, spec: &PlotSpec) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let finite: Vec<Vec<(f64, f64)>> = spec
        .series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .copied()
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .collect()
        })
        .collect();
    let x = axis_range(finite.iter().flatten().map(|p| p.0));
    let y = axis_range(finite.iter().flatten().map(|p| p.1));
    let mut chart = ChartBuilder::on(&root)
        .caption(&spec.title, (FONT_FAMILY, 26))
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(&spec.x_label)
        .y_desc(&spec.y_label)
        .label_style((FONT_FAMILY, 16))
        .axis_desc_style((FONT_FAMILY, 18))
        .draw()
        .map_err(e)?;
    for (i, (series, points)) in spec.series.iter().zip(&finite).enumerate() {
        let color = COLORS[i % COLORS.len()];
        let style = ShapeStyle::from(color).stroke_width(2);
        let with_line = matches!(
            series.style,
            SeriesStyle::Line | SeriesStyle::LineAndMarkers
        );
        let with_marks = matches!(
            series.style,
            SeriesStyle::Markers | SeriesStyle::LineAndMarkers
        );
        if with_line {
            chart
                .draw_series(LineSeries::new(points.iter().copied(), style))
                .map_err(e)?;
        }
        if with_marks {
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(e)?;
        }
        // An invisible empty series carries the legend entry, drawn in the series' style.
        let entry = chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(e)?
            .label(series.label.as_str());
        match series.style {
            SeriesStyle::Line => {
                entry.legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
            }
            SeriesStyle::Markers => {
                entry.legend(move |(x, y)| Circle::new((x + 10, y), 3, color.filled()));
            }
            SeriesStyle::LineAndMarkers => {
                entry.legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (20, 0)], style)
                        + Circle::new((10, 0), 3, color.filled())
                });
            }
        }
    }
    if !spec.series.is_empty() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font((FONT_FAMILY, 16))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(e)?;
    }
    root.present().map_err(e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::scratch_dir;

    fn spec() -> PlotSpec {
        PlotSpec {
            title: "Sphere compression".into(),
            x_label: "plate displacement (µm)".into(),
            y_label: "force (nN)".into(),
            series: vec![
                Series {
                    label: "cellmech".into(),
                    points: (0..=20)
                        .map(|i| (0.1 * i as f64, 0.05 * (i * i) as f64))
                        .collect(),
                    style: SeriesStyle::Line,
                },
                Series {
                    label: "CalculiX".into(),
                    points: (0..=10)
                        .map(|i| (0.2 * i as f64, 0.2 * (i * i) as f64))
                        .collect(),
                    style: SeriesStyle::Markers,
                },
                Series {
                    label: "single point".into(),
                    points: vec![(1.0, f64::NAN), (1.5, 3.0)],
                    style: SeriesStyle::LineAndMarkers,
                },
                Series::default(),
            ],
        }
    }

    #[test]
    fn renders_png_and_svg() {
        let dir = scratch_dir("plot");
        let png = dir.join("curve.png");
        plot_xy(&png, &spec()).unwrap();
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert!(
            bytes.len() > 5_000,
            "a plot with text and lines, got {} bytes",
            bytes.len()
        );
        let svg_path = dir.join("curve.SVG");
        plot_xy(&svg_path, &spec()).unwrap();
        let svg = std::fs::read_to_string(&svg_path).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.contains("Sphere compression"),
            "{svg:.200}"
        );
        assert!(svg.contains("CalculiX") && svg.contains("force (nN)"));
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "no temporary files left: {names:?}");
    }

    #[test]
    fn empty_plots_and_unknown_formats() {
        let dir = scratch_dir("plot-empty");
        plot_xy(&dir.join("empty.svg"), &PlotSpec::default()).unwrap();
        let err = plot_xy(&dir.join("x.jpg"), &spec()).unwrap_err();
        assert!(
            err.to_string().contains("x.jpg: unknown plot format"),
            "{err}"
        );
    }

    #[test]
    fn ranges_include_zero_and_survive_degenerate_data() {
        assert_eq!(axis_range([2.0, 4.0].into_iter()), (0.0, 4.2));
        assert_eq!(axis_range([-1.0, 1.0].into_iter()), (-1.1, 1.1));
        assert_eq!(axis_range(std::iter::empty()), (0.0, 1.0));
        assert_eq!(axis_range([0.0, f64::NAN].into_iter()), (0.0, 1.0));
        let (lo, hi) = axis_range([-3.0].into_iter());
        assert!((lo + 3.15).abs() < 1e-12 && hi == 0.0);
    }
}
