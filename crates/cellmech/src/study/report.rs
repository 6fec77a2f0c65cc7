//! A study's results: `study.csv` (one row per case), `study.json`, the figures (force /
//! control bars, overlaid curves) and a self-contained report (`report.md`, `report.html`
//! with the figures inlined).

use std::fmt::Write as _;
use std::path::Path;

use cellmech_io::{plot_xy, PlotSpec, Series, SeriesStyle};
use serde::Serialize;

use super::run::CaseRecord;
use super::spec::{Case, StudyError, StudySpec};

/// One row of `study.csv`.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct StudyRow {
    /// Case name.
    pub case: String,
    /// Member label per axis.
    pub labels: Vec<String>,
    /// `completed`, `failed` or `missing` (not run yet, e.g. in another shard).
    pub status: String,
    /// Force at the last point (nN).
    pub force_nn: Option<f64>,
    /// Displacement at the last point (µm).
    pub displacement_um: Option<f64>,
    /// Force / the control's force (compared axes at their control, others the same).
    pub force_over_control: Option<f64>,
    /// The case it is compared with.
    pub control: Option<String>,
    /// Nucleus max principal log strain at the last point, from the unstressed mesh.
    pub nucleus_strain: Option<f64>,
    /// The same from the test's reference state.
    pub nucleus_strain_from_reference: Option<f64>,
    /// MTs in tension / straight, AFs in tension, IFs in tension (filaments, not elements).
    pub filaments: [Option<f64>; 4],
    /// Newton iterations.
    pub iterations: usize,
    /// Wall time (s).
    pub wall_time_s: f64,
    /// Why it failed.
    pub error: Option<String>,
}

/// Rows of the study in case order; cases without a record are `missing`.
pub fn rows(spec: &StudySpec, cases: &[Case], records: &[Option<CaseRecord>]) -> Vec<StudyRow> {
    let completed_force = |i: usize| {
        records[i]
            .as_ref()
            .filter(|r| r.status == "completed")
            .and_then(|r| r.force_nn)
    };
    cases
        .iter()
        .enumerate()
        .map(|(i, case)| {
            let record = records[i].as_ref();
            let control = spec.control_of(cases, case);
            let ratio = match (completed_force(i), control.and_then(completed_force)) {
                (Some(f), Some(c)) if c != 0.0 => Some(f / c),
                _ => None,
            };
            StudyRow {
                case: case.name.clone(),
                labels: case.labels.clone(),
                status: record.map_or("missing".into(), |r| r.status.clone()),
                force_nn: record.and_then(|r| r.force_nn),
                displacement_um: record.and_then(|r| r.displacement_um),
                force_over_control: ratio,
                control: control.map(|c| cases[c].name.clone()),
                nucleus_strain: record.and_then(|r| r.nucleus_strain),
                nucleus_strain_from_reference: record.and_then(|r| r.nucleus_strain_from_reference),
                filaments: FILAMENT_COLUMNS
                    .map(|key| record.and_then(|r| r.filaments.get(key).copied())),
                iterations: record.map_or(0, |r| r.iterations),
                wall_time_s: record.map_or(0.0, |r| r.wall_time_s),
                error: record.and_then(|r| r.error.clone()),
            }
        })
        .collect()
}

/// The filament counts the study table shows.
const FILAMENT_COLUMNS: [&str; 4] = [
    "microtubule_filaments_in_tension",
    "microtubule_filaments_straight",
    "actin_filaments_in_tension",
    "intermediate_filaments_in_tension",
];

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or(String::new(), |v| format!("{v:.digits$}"))
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Writes `study.csv`, `study.json`, the figures and the report into `out`; returns the
/// files written (relative to `out`).
pub fn write_report(
    spec: &StudySpec,
    cases: &[Case],
    records: &[Option<CaseRecord>],
    out: &Path,
) -> Result<Vec<String>, StudyError> {
    let rows = rows(spec, cases, records);
    let err = |e: String| StudyError::Output(e);
    let mut files = Vec::new();
    // study.csv
    let mut csv = String::from("case");
    for (i, a) in spec.axes.iter().enumerate() {
        let _ = write!(csv, ",axis{i}_{}", a.kind);
    }
    csv.push_str(",status,displacement_um,force_nN,force_over_control,control,nucleus_max_log_strain,nucleus_max_log_strain_from_reference,mts_in_tension,mts_straight,afs_in_tension,ifs_in_tension,iterations,wall_time_s,error\n");
    for r in &rows {
        csv.push_str(&csv_field(&r.case));
        for l in &r.labels {
            csv.push(',');
            csv.push_str(&csv_field(l));
        }
        let _ = writeln!(
            csv,
            ",{},{},{},{},{},{},{},{},{},{},{},{},{:.2},{}",
            r.status,
            opt(r.displacement_um, 4),
            opt(r.force_nn, 6),
            opt(r.force_over_control, 4),
            r.control.as_deref().map(csv_field).unwrap_or_default(),
            opt(r.nucleus_strain, 5),
            opt(r.nucleus_strain_from_reference, 5),
            opt(r.filaments[0], 0),
            opt(r.filaments[1], 0),
            opt(r.filaments[2], 0),
            opt(r.filaments[3], 0),
            r.iterations,
            r.wall_time_s,
            r.error.as_deref().map(csv_field).unwrap_or_default()
        );
    }
    cellmech_io::write_atomic(&out.join("study.csv"), csv.as_bytes())
        .map_err(|e| err(e.to_string()))?;
    files.push("study.csv".to_string());
    let json = serde_json::json!({
        "title": spec.title,
        "study": spec.origin,
        "base": spec.base_origin,
        "axes": spec.axes.iter().map(|a| serde_json::json!({
            "kind": a.kind,
            "compared": a.compared,
            "members": a.members.iter().map(|m| serde_json::json!({
                "label": m.label,
                "set": m.set.iter().map(|(k, v)| format!("{k} = {v}")).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "set": spec.set.iter().map(|(k, v)| format!("{k} = {v}")).collect::<Vec<_>>(),
        "cases": rows,
    });
    let text = serde_json::to_string_pretty(&json).map_err(|e| err(e.to_string()))?;
    cellmech_io::write_atomic(&out.join("study.json"), text.as_bytes())
        .map_err(|e| err(e.to_string()))?;
    files.push("study.json".to_string());
    // Figures: force / control as bars (a line plot with markers per case index), and the
    // curves overlaid.
    let compared = spec.axes.iter().any(|a| a.compared);
    let mut figures = Vec::new();
    if compared {
        let bars: Vec<(String, f64)> = rows
            .iter()
            .filter_map(|r| r.force_over_control.map(|v| (r.case.clone(), v)))
            .collect();
        if !bars.is_empty() {
            let path = out.join("force-over-control.svg");
            cellmech_io::plot_bars(
                &path,
                &cellmech_io::BarSpec {
                    title: format!("{}: force / control", spec.title),
                    value_label: "force / control".into(),
                    bars,
                    reference: Some(1.0),
                },
            )
            .map_err(|e| err(e.to_string()))?;
            figures.push("force-over-control.svg".to_string());
        }
    }
    let series: Vec<Series> = cases
        .iter()
        .zip(records)
        .filter_map(|(c, r)| {
            let r = r.as_ref()?;
            (!r.curve.is_empty()).then(|| Series {
                label: c.name.clone(),
                points: r
                    .curve
                    .iter()
                    .map(|p| (p.displacement_um, p.force_nn))
                    .collect(),
                style: SeriesStyle::Line,
            })
        })
        .collect();
    if !series.is_empty() {
        let path = out.join("curves.svg");
        plot_xy(
            &path,
            &PlotSpec {
                title: format!("{}: every case", spec.title),
                x_label: "displacement from the reference state (um)".into(),
                y_label: "force (nN)".into(),
                series,
            },
        )
        .map_err(|e| err(e.to_string()))?;
        figures.push("curves.svg".to_string());
    }
    files.extend(figures.iter().cloned());
    // Report.
    let mut md = String::new();
    let _ = writeln!(md, "# {}\n", spec.title);
    let _ = writeln!(
        md,
        "Study `{}`, base scenario {}. Made by `cellmech study`; every number below is read from the cases' `record.json`.\n",
        spec.origin, spec.base_origin
    );
    if !spec.set.is_empty() {
        let _ = writeln!(md, "Set in every case:\n");
        for (k, v) in &spec.set {
            let _ = writeln!(md, "- `{k} = {v}`");
        }
        md.push('\n');
    }
    let _ = writeln!(md, "## Variants\n");
    for (i, a) in spec.axes.iter().enumerate() {
        let _ = writeln!(
            md,
            "Axis {i} (`{}`, {}):\n",
            a.kind,
            if a.compared {
                "compared with its control"
            } else {
                "context"
            }
        );
        for m in &a.members {
            let set = if m.set.is_empty() {
                "nothing changed".to_string()
            } else {
                m.set
                    .iter()
                    .map(|(k, v)| format!("`{k} = {v}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let _ = writeln!(md, "- `{}`: {set}", m.label);
        }
        md.push('\n');
    }
    let _ = writeln!(md, "## Results\n");
    let _ = writeln!(
        md,
        "| case | status | displacement (µm) | force (nN) | force / control | nucleus max log strain (from mesh / from reference) | MTs in tension / straight | AFs, IFs in tension | iterations | wall (s) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} / {} | {} / {} | {}, {} | {} | {:.1} |",
            r.case,
            r.status,
            opt(r.displacement_um, 2),
            opt(r.force_nn, 2),
            opt(r.force_over_control, 3),
            opt(r.nucleus_strain, 4),
            opt(r.nucleus_strain_from_reference, 4),
            opt(r.filaments[0], 0),
            opt(r.filaments[1], 0),
            opt(r.filaments[2], 0),
            opt(r.filaments[3], 0),
            r.iterations,
            r.wall_time_s
        );
    }
    let failed: Vec<&StudyRow> = rows.iter().filter(|r| r.status == "failed").collect();
    if !failed.is_empty() {
        let _ = writeln!(md, "\n## Failed cases\n");
        for r in failed {
            let _ = writeln!(
                md,
                "- `{}`: {}",
                r.case,
                r.error.as_deref().unwrap_or("(no reason recorded)")
            );
        }
    }
    let missing = rows.iter().filter(|r| r.status == "missing").count();
    if missing > 0 {
        let _ = writeln!(
            md,
            "\n{missing} case(s) have not run yet (another shard, or interrupted)."
        );
    }
    md.push('\n');
    for f in &figures {
        let _ = writeln!(md, "![{f}]({f})\n");
    }
    cellmech_io::write_atomic(&out.join("report.md"), md.as_bytes())
        .map_err(|e| err(e.to_string()))?;
    files.push("report.md".to_string());
    // The same as one HTML file with the SVG figures inlined.
    let mut html = String::from(
        "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>cellmech study</title>\
         <style>body{font-family:sans-serif;max-width:1000px;margin:auto}table{border-collapse:collapse}\
         td,th{border:1px solid #ccc;padding:2px 6px}</style></head><body><pre style=\"white-space:pre-wrap\">",
    );
    html.push_str(&md.replace('&', "&amp;").replace('<', "&lt;"));
    html.push_str("</pre>");
    for f in &figures {
        if let Ok(svg) = std::fs::read_to_string(out.join(f)) {
            html.push_str(&svg);
        }
    }
    html.push_str("</body></html>\n");
    cellmech_io::write_atomic(&out.join("report.html"), html.as_bytes())
        .map_err(|e| err(e.to_string()))?;
    files.push("report.html".to_string());
    Ok(files)
}
