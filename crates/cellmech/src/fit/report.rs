//! A fit's outputs: `fit.json` (everything), `fit-history.csv` (one row per iteration),
//! `fit.csv` (measured vs fitted curve), `fit.svg` and `fit.png` (the plot) and `fit.md`
//! (a short report). Every file is written atomically.

use std::fmt::Write as _;
use std::path::Path;

use cellmech_io::{plot_xy, PlotSpec, Series, SeriesStyle};

use super::spec::FitSpec;
use super::{FitError, FitOutcome};

fn out_err(e: impl std::fmt::Display) -> FitError {
    FitError::Output(e.to_string())
}

/// Writes the report files into `out`; returns their names.
pub fn write_report(
    outcome: &FitOutcome,
    spec: &FitSpec,
    out: &Path,
) -> Result<Vec<String>, FitError> {
    let mut files = vec![
        "fit.json".to_string(),
        "fit-history.csv".into(),
        "fit.csv".into(),
        "fit.svg".into(),
        "fit.png".into(),
        "fit.md".into(),
    ];
    // fit-history.csv
    let mut history = String::from("iteration,evaluations,cost,rms,damping,accepted");
    for p in &outcome.parameters {
        let _ = write!(history, ",{}_{}", p.key, p.unit);
    }
    history.push('\n');
    for h in &outcome.history {
        let _ = write!(
            history,
            "{},{},{:?},{:?},{:?},{}",
            h.iteration,
            h.evaluations,
            h.cost,
            h.rms,
            h.damping,
            u8::from(h.accepted)
        );
        for v in &h.values {
            let _ = write!(history, ",{v:?}");
        }
        history.push('\n');
    }
    cellmech_io::write_atomic(&out.join("fit-history.csv"), history.as_bytes()).map_err(out_err)?;
    // fit.csv
    let [xu, yu] = &outcome.units;
    let c = &outcome.curve;
    let mut table = format!("x_{xu},measured_{yu},fitted_{yu},residual_{yu},in_range\n");
    for i in 0..c.x.len() {
        let _ = writeln!(
            table,
            "{:?},{:?},{:?},{:?},{}",
            c.x[i],
            c.measured[i],
            c.fitted[i],
            c.fitted[i] - c.measured[i],
            u8::from(c.in_range[i])
        );
    }
    cellmech_io::write_atomic(&out.join("fit.csv"), table.as_bytes()).map_err(out_err)?;
    // The plot: measured points, the fitted model, the start.
    let points = |x: &[f64], y: &[f64]| x.iter().copied().zip(y.iter().copied()).collect();
    let plot = PlotSpec {
        title: outcome.title.clone(),
        x_label: format!("{} ({xu})", plain_name(&spec.data.x_name)),
        y_label: format!("{} ({yu})", plain_name(&spec.data.y_name)),
        series: vec![
            Series {
                label: "measured".into(),
                points: points(&c.x, &c.measured),
                style: SeriesStyle::Markers,
            },
            Series {
                label: "fitted model".into(),
                points: points(&c.model_x, &c.model_y),
                style: SeriesStyle::Line,
            },
            Series {
                label: "start".into(),
                points: points(&c.start_x, &c.start_y),
                style: SeriesStyle::Line,
            },
        ],
    };
    for file in ["fit.svg", "fit.png"] {
        plot_xy(&out.join(file), &plot).map_err(out_err)?;
    }
    // fit.md
    cellmech_io::write_atomic(&out.join("fit.md"), markdown(outcome).as_bytes())
        .map_err(out_err)?;
    // fit.json last: it lists the files.
    let mut with_files = outcome.clone();
    with_files.files = files.clone();
    cellmech_io::write_json_atomic(&out.join("fit.json"), &with_files).map_err(out_err)?;
    files.sort();
    Ok(files)
}

/// A measured column's name without its unit (`force [pN]` → `force`).
fn plain_name(header: &str) -> &str {
    header
        .split(['[', '('])
        .next()
        .map(str::trim)
        .filter(|n| !n.is_empty())
        .unwrap_or(header)
}

/// `value ± error unit` with the error's leading digits.
pub fn format_estimate(value: f64, error: Option<f64>, unit: &str) -> String {
    match error {
        Some(e) if e.is_finite() && e > 0.0 => {
            let digits = (2 - e.log10().floor() as i32).clamp(0, 12) as usize;
            format!("{value:.digits$} ± {e:.digits$} {unit}")
        }
        _ => format!("{value:.6} {unit} (error not determined)"),
    }
}

fn markdown(o: &FitOutcome) -> String {
    let mut s = format!("# {}\n\n", o.title);
    let _ = writeln!(
        s,
        "Fit file `{}`, measured curve `{}`, protocol `{}`: {} points fitted ({} vs {}, {} residuals).\n",
        o.origin,
        o.data,
        o.protocol,
        o.points,
        o.simulated[1],
        o.simulated[0],
        match o.residual {
            super::Residual::Absolute => "absolute",
            super::Residual::Relative => "relative",
        }
    );
    s.push_str("| parameter | start | fitted ± standard error | bounds |\n|---|---|---|---|\n");
    for p in &o.parameters {
        let _ = writeln!(
            s,
            "| `{}` | {} {} | {}{} | [{}, {}] |",
            p.key,
            p.start,
            p.unit,
            format_estimate(p.value, p.standard_error, &p.unit),
            if p.at_bound { " (at a bound)" } else { "" },
            p.lower,
            p.upper
        );
    }
    if let Some(r) = &o.correlation {
        s.push_str("\nCorrelation of the estimates:\n\n");
        for row in r {
            let cells: Vec<String> = row.iter().map(|v| format!("{v:+.4}")).collect();
            let _ = writeln!(s, "    {}", cells.join("  "));
        }
    }
    let _ = writeln!(
        s,
        "\nRMS residual {:.4e}, R² {:.6}; {} FE evaluations ({} solved now, the rest from `runs/`), {} iterations, stopped: {} ({}); wall time {:.1} s.\n",
        o.rms,
        o.r_squared,
        o.evaluations,
        o.fe_runs_solved,
        o.iterations,
        o.stop,
        if o.converged { "converged" } else { "not converged" },
        o.wall_time_s
    );
    s.push_str("![measured vs fitted](fit.svg)\n\nFiles: fit.json (everything), fit-history.csv (iterations), fit.csv (measured vs fitted), runs/HASH/ (every FE run, `case.toml` re-runs one).\n");
    s
}
