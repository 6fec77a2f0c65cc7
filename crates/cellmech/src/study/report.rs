//! A study's results: `study.csv` (one row per case), `study.json`, the figures (force /
//! control bars, a tornado chart per `modulus` axis, overlaid curves) and a self-contained report (`report.md`, `report.html`
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
    /// Increments solved with viscous stabilisation on.
    pub stabilized_increments: usize,
    /// Largest fraction of a step's strain energy the stabilisation dissipated.
    pub dissipated_fraction: f64,
    /// Largest imbalance of the two tools' forces over the curve (tension, compression).
    pub tool_force_imbalance: Option<f64>,
    /// Wall time (s).
    pub wall_time_s: f64,
    /// The first displacement (µm) from which the mesh no longer represents the model:
    /// an element folded over, or (AFM) the tip passed between the surface nodes. `None`:
    /// valid to the end.
    pub mesh_invalid_from_um: Option<f64>,
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
                stabilized_increments: record.map_or(0, |r| r.stabilized_increments),
                dissipated_fraction: record.map_or(0.0, |r| r.dissipated_fraction),
                tool_force_imbalance: record.and_then(|r| r.tool_force_imbalance),
                wall_time_s: record.map_or(0.0, |r| r.wall_time_s),
                mesh_invalid_from_um: record.and_then(|r| {
                    [r.folds_at_um, r.tip_passes_between_nodes_at_um]
                        .into_iter()
                        .flatten()
                        .reduce(f64::min)
                }),
                error: record.and_then(|r| r.error.clone()),
            }
        })
        .collect()
}

/// One component of a `modulus` axis in the tornado chart: the force change from the
/// control when its modulus is at the axis's smallest and largest factor.
#[derive(Debug, Clone, PartialEq)]
pub struct SensitivityBar {
    /// Component (e.g. `cytoplasm`).
    pub component: String,
    /// (force / control − 1) × 100 at the smallest factor (`None`: the case failed or is
    /// missing).
    pub low_percent: Option<f64>,
    /// The same at the largest factor.
    pub high_percent: Option<f64>,
}

impl SensitivityBar {
    /// Width of the bar: from the lowest to the highest of 0 (the control), low and high.
    pub fn span(&self) -> f64 {
        cellmech_io::TornadoBar {
            label: String::new(),
            low: self.low_percent,
            high: self.high_percent,
        }
        .span(0.0)
    }
}

/// The tornado data of a `modulus` axis: its smallest and largest factor and one bar per
/// component, widest first (ties keep the axis's order). Only the cases with every other
/// axis at its member 0 (the control, or a context axis's first member) are used.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivity {
    /// Index of the axis.
    pub axis: usize,
    /// Smallest factor (the bars' `low` end).
    pub low_factor: f64,
    /// Largest factor (`high`; equal to `low_factor` when the axis has one factor, and then
    /// only `low_percent` is set).
    pub high_factor: f64,
    /// Bars, widest first.
    pub bars: Vec<SensitivityBar>,
}

/// The tornado data of every `modulus` axis of the study.
pub fn sensitivities(spec: &StudySpec, cases: &[Case], rows: &[StudyRow]) -> Vec<Sensitivity> {
    let mut out = Vec::new();
    for (ai, axis) in spec.axes.iter().enumerate() {
        if axis.kind != "modulus" {
            continue;
        }
        let factors: Vec<f64> = axis
            .members
            .iter()
            .filter_map(|m| m.scaled.as_ref().map(|(_, f)| *f))
            .collect();
        if factors.is_empty() {
            continue;
        }
        let low_factor = factors.iter().copied().fold(f64::INFINITY, f64::min);
        let high_factor = factors.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        // The change from the control of the case with `member` on this axis and member 0
        // on every other.
        let change = |member: usize| -> Option<f64> {
            let i = cases.iter().position(|c| {
                c.members
                    .iter()
                    .enumerate()
                    .all(|(a, &m)| if a == ai { m == member } else { m == 0 })
            })?;
            rows[i].force_over_control.map(|r| (r - 1.0) * 100.0)
        };
        let mut bars: Vec<SensitivityBar> = Vec::new();
        for (mi, member) in axis.members.iter().enumerate() {
            let Some((component, factor)) = &member.scaled else {
                continue;
            };
            let k = match bars.iter().position(|b| &b.component == component) {
                Some(k) => k,
                None => {
                    bars.push(SensitivityBar {
                        component: component.clone(),
                        low_percent: None,
                        high_percent: None,
                    });
                    bars.len() - 1
                }
            };
            if *factor == low_factor {
                bars[k].low_percent = change(mi);
            } else if *factor == high_factor {
                bars[k].high_percent = change(mi);
            }
        }
        // Widest on top; a stable sort keeps the axis's order among equal spans.
        bars.sort_by(|a, b| b.span().total_cmp(&a.span()));
        out.push(Sensitivity {
            axis: ai,
            low_factor,
            high_factor,
            bars,
        });
    }
    out
}

/// The filament counts the study table shows.
const FILAMENT_COLUMNS: [&str; 4] = [
    "microtubule_filaments_in_tension",
    "microtubule_filaments_straight",
    "actin_filaments_in_tension",
    "intermediate_filaments_in_tension",
];

/// A row's stabilisation, e.g. `25 (68.0 % of a step's strain energy)`, or `0`.
fn stabilized(r: &StudyRow) -> String {
    if r.stabilized_increments == 0 {
        "0".into()
    } else {
        format!(
            "{} ({:.1} % of a step's strain energy)",
            r.stabilized_increments,
            100.0 * r.dissipated_fraction
        )
    }
}

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
    csv.push_str(",status,displacement_um,force_nN,force_over_control,control,nucleus_max_log_strain,nucleus_max_log_strain_from_reference,mts_in_tension,mts_straight,afs_in_tension,ifs_in_tension,iterations,stabilized_increments,dissipated_fraction,tool_force_imbalance,wall_time_s,mesh_invalid_from_um,error\n");
    for r in &rows {
        csv.push_str(&csv_field(&r.case));
        for l in &r.labels {
            csv.push(',');
            csv.push_str(&csv_field(l));
        }
        let _ = writeln!(
            csv,
            ",{},{},{},{},{},{},{},{},{},{},{},{},{},{:.4},{},{:.2},{},{}",
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
            r.stabilized_increments,
            r.dissipated_fraction,
            r.tool_force_imbalance
                .map_or(String::new(), |v| format!("{v:.2e}")),
            r.wall_time_s,
            opt(r.mesh_invalid_from_um, 4),
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
    let sensitivity = sensitivities(spec, cases, &rows);
    for sens in &sensitivity {
        if !sens
            .bars
            .iter()
            .any(|b| b.low_percent.is_some() || b.high_percent.is_some())
        {
            continue;
        }
        let name = if sensitivity.len() == 1 {
            "tornado.svg".to_string()
        } else {
            format!("tornado-axis{}.svg", sens.axis)
        };
        let path = out.join(&name);
        cellmech_io::plot_tornado(
            &path,
            &cellmech_io::TornadoSpec {
                title: format!("{}: sensitivity", spec.title),
                value_label: "force change from control (%)".into(),
                low_label: format!("modulus x {}", sens.low_factor),
                high_label: format!("modulus x {}", sens.high_factor),
                bars: sens
                    .bars
                    .iter()
                    .map(|b| cellmech_io::TornadoBar {
                        label: b.component.clone(),
                        low: b.low_percent,
                        high: b.high_percent,
                    })
                    .collect(),
                reference: 0.0,
            },
        )
        .map_err(|e| err(e.to_string()))?;
        figures.push(name);
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
        "| case | status | displacement (µm) | force (nN) | force / control | nucleus max log strain (from mesh / from reference) | MTs in tension / straight | AFs, IFs in tension | iterations | stabilised increments (energy dissipated) | wall (s) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} / {} | {} / {} | {}, {} | {} | {} | {:.1} |",
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
            stabilized(r),
            r.wall_time_s
        );
    }
    let invalid: Vec<_> = rows
        .iter()
        .filter_map(|r| r.mesh_invalid_from_um.map(|d| (r, d)))
        .collect();
    if !invalid.is_empty() {
        let _ = writeln!(
            md,
            "\nWhere the mesh stopped representing the model (an element folded over, or the tip passed between the surface nodes; points beyond are the mesh's, not the model's):\n"
        );
        for (r, d) in invalid {
            let _ = writeln!(md, "- `{}`: from {d:.3} µm", r.case);
        }
    }
    for sens in &sensitivity {
        let _ = writeln!(
            md,
            "\n## Sensitivity (axis {})\n\nForce change from the control (%), widest span first (the tornado chart).\n",
            sens.axis
        );
        let _ = writeln!(
            md,
            "| component | modulus x {} | modulus x {} | span |",
            sens.low_factor, sens.high_factor
        );
        let _ = writeln!(md, "|---|---|---|---|");
        for b in &sens.bars {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {:.1} |",
                b.component,
                opt(b.low_percent, 1),
                opt(b.high_percent, 1),
                b.span()
            );
        }
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
    let carried: Vec<&StudyRow> = rows
        .iter()
        .filter(|r| r.status == "completed" && r.stabilized_increments > 0)
        .collect();
    if !carried.is_empty() {
        let _ = writeln!(
            md,
            "\n## Cases whose path needed viscous stabilisation\n\nEach ended in equilibrium (re-solved without viscosity, or viscous forces below the accepted fraction), so its end point is a solution; its path was carried by the viscosity, and a large dissipated fraction means the curve between the converged points is not an equilibrium path.\n"
        );
        for r in carried {
            let _ = writeln!(md, "- `{}`: {}", r.case, stabilized(r));
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn record(case: &Case, force: Option<f64>) -> CaseRecord {
        CaseRecord {
            name: case.name.clone(),
            labels: case.labels.clone(),
            set: Vec::new(),
            status: if force.is_some() {
                "completed"
            } else {
                "failed"
            }
            .into(),
            error: force.is_none().then(|| "stopped".to_string()),
            seed: None,
            force_nn: force,
            displacement_um: Some(1.0),
            nucleus_strain: None,
            nucleus_strain_from_reference: None,
            filaments: Default::default(),
            at_deformations: Vec::new(),
            iterations: 3,
            factorizations: 1,
            stabilized_increments: 0,
            dissipated_fraction: 0.0,
            tool_force_imbalance: None,
            folds_at_um: None,
            tip_passes_between_nodes_at_um: None,
            wall_time_s: 0.5,
            curve: Vec::new(),
            shared_from: None,
        }
    }

    /// A disruption study of the AFs alone: its control and `no-actin`.
    fn actin_disruption() -> (StudySpec, Vec<Case>) {
        let spec = crate::study::spec::parse(
            "base = \"suspended-tension\"\n[[axis]]\nkind = \"disruption\"\nfamilies = [\"actin\"]\n",
            "test",
            Path::new("."),
        )
        .unwrap();
        let cases = spec.cases();
        (spec, cases)
    }

    /// A modulus study with made-up forces (control 2 nN).
    fn study(forces: &[(&str, Option<f64>)]) -> (StudySpec, Vec<Case>, Vec<StudyRow>) {
        let spec = crate::study::spec::parse(
            "base = \"suspended-tension\"\n[[axis]]\nkind = \"modulus\"\n\
             components = [\"cytoplasm\", \"nucleus\", \"actin\"]\nfactors = [1.5, 0.5]\n",
            "test",
            Path::new("."),
        )
        .unwrap();
        let cases = spec.cases();
        let records: Vec<Option<CaseRecord>> = cases
            .iter()
            .map(|c| {
                let f = forces
                    .iter()
                    .find(|(n, _)| *n == c.name)
                    .map_or(Some(2.0), |(_, f)| *f);
                Some(record(c, f))
            })
            .collect();
        let rows = rows(&spec, &cases, &records);
        (spec, cases, rows)
    }

    #[test]
    fn the_tornado_takes_each_component_at_its_low_and_high_factor_widest_first() {
        let (spec, cases, rows) = study(&[
            ("control", Some(2.0)),
            ("cytoplasm-x0p5", Some(1.4)), // -30 %
            ("cytoplasm-x1p5", Some(2.5)), // +25 %
            ("nucleus-x0p5", Some(1.98)),  // -1 %
            ("nucleus-x1p5", Some(2.02)),  // +1 %
            ("actin-x0p5", Some(1.0)),     // -50 %
            ("actin-x1p5", Some(2.2)),     // +10 %
        ]);
        let s = sensitivities(&spec, &cases, &rows);
        assert_eq!(s.len(), 1);
        let s = &s[0];
        // Factors listed high first: low is still the smallest.
        assert_eq!((s.low_factor, s.high_factor), (0.5, 1.5));
        let names: Vec<&str> = s.bars.iter().map(|b| b.component.as_str()).collect();
        assert_eq!(names, ["actin", "cytoplasm", "nucleus"]);
        let close = |a: Option<f64>, b: f64| (a.unwrap() - b).abs() < 1e-9;
        assert!(close(s.bars[0].low_percent, -50.0), "{:?}", s.bars[0]);
        assert!(close(s.bars[0].high_percent, 10.0), "{:?}", s.bars[0]);
        assert!(close(s.bars[1].low_percent, -30.0));
        assert!(close(s.bars[1].high_percent, 25.0));
        assert!(close(s.bars[2].low_percent, -1.0));
        assert!(close(s.bars[2].high_percent, 1.0));
        assert!((s.bars[0].span() - 60.0).abs() < 1e-9);
    }

    #[test]
    fn a_failed_case_leaves_its_end_of_the_bar_empty() {
        let (spec, cases, rows) = study(&[
            ("cytoplasm-x0p5", None),
            ("cytoplasm-x1p5", Some(3.0)), // +50 %
        ]);
        let s = &sensitivities(&spec, &cases, &rows)[0];
        assert_eq!(s.bars[0].component, "cytoplasm");
        assert_eq!(s.bars[0].low_percent, None);
        assert!((s.bars[0].high_percent.unwrap() - 50.0).abs() < 1e-9);
        // The others did not change the force.
        assert_eq!(s.bars[1].span(), 0.0);
    }

    /// The report (`report.md`, `study.csv`) of an AF disruption study whose `no-actin`
    /// case `change` edits (the control stays clean).
    fn report_with_changed_case(tag: &str, change: impl Fn(&mut CaseRecord)) -> (String, String) {
        let dir = std::env::temp_dir().join(format!("cellmech-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let (spec, cases) = actin_disruption();
        let records: Vec<Option<CaseRecord>> = cases
            .iter()
            .map(|c| {
                let mut r = record(c, Some(2.0));
                if c.name != "control" {
                    change(&mut r);
                }
                Some(r)
            })
            .collect();
        write_report(&spec, &cases, &records, &dir).unwrap();
        let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
        let csv = std::fs::read_to_string(dir.join("study.csv")).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        (md, csv)
    }

    /// `study.csv`'s values in `columns`, per case name.
    fn csv_values(csv: &str, columns: &[&str]) -> Vec<(String, Vec<String>)> {
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let at: Vec<usize> = columns
            .iter()
            .map(|c| header.iter().position(|h| h == c).unwrap())
            .collect();
        lines
            .map(|line| {
                let v: Vec<&str> = line.split(',').collect();
                (
                    v[0].to_string(),
                    at.iter().map(|&k| v[k].to_string()).collect(),
                )
            })
            .collect()
    }

    /// A case whose mesh stopped representing the model (a folded element, a tip between
    /// the nodes) says from where, in `study.csv` and the report: the earlier of the two.
    #[test]
    fn a_mesh_that_went_invalid_is_reported_from_the_first_depth() {
        let (md, csv) = report_with_changed_case("fold", |r| {
            r.folds_at_um = Some(1.675);
            r.tip_passes_between_nodes_at_um = Some(1.775);
        });
        assert!(md.contains("- `no-actin`: from 1.675 µm"), "{md}");
        assert!(!md.contains("- `control`: from"), "{md}");
        for (case, v) in csv_values(&csv, &["mesh_invalid_from_um"]) {
            let want = if case == "control" { "" } else { "1.6750" };
            assert_eq!(v, [want], "{case}");
        }
    }

    /// A completed case whose path needed the viscosity says so in the table, in its own
    /// section of the report and in `study.csv`; a clean case does not.
    #[test]
    fn a_stabilised_path_is_reported_not_hidden() {
        let (md, csv) = report_with_changed_case("stab", |r| {
            r.stabilized_increments = 25;
            r.dissipated_fraction = 0.68;
            r.tool_force_imbalance = Some(0.47);
        });
        assert!(
            md.contains("## Cases whose path needed viscous stabilisation"),
            "{md}"
        );
        assert!(
            md.contains("- `no-actin`: 25 (68.0 % of a step's strain energy)"),
            "{md}"
        );
        let section = &md[md.find("## Cases whose path").unwrap()..];
        assert!(!section.contains("`control`"), "{md}");
        for (case, v) in csv_values(
            &csv,
            &[
                "stabilized_increments",
                "dissipated_fraction",
                "tool_force_imbalance",
            ],
        ) {
            let want = if case == "control" {
                ["0", "0.0000", ""]
            } else {
                ["25", "0.6800", "4.70e-1"]
            };
            assert_eq!(v, want, "{case}");
        }
    }

    #[test]
    fn the_tornado_chart_is_in_the_report_of_a_modulus_study_only() {
        let dir = std::env::temp_dir().join(format!("cellmech-tornado-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let (spec, cases, _) = study(&[("actin-x0p5", Some(1.0))]);
        let records: Vec<Option<CaseRecord>> =
            cases.iter().map(|c| Some(record(c, Some(2.0)))).collect();
        let files = write_report(&spec, &cases, &records, &dir).unwrap();
        assert!(files.contains(&"tornado.svg".to_string()), "{files:?}");
        let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
        assert!(md.contains("![tornado.svg](tornado.svg)"), "{md}");
        assert!(md.contains("## Sensitivity"), "{md}");
        let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
        assert!(html.contains("sensitivity"));
        // A disruption study has none.
        let (spec, cases) = actin_disruption();
        let records: Vec<Option<CaseRecord>> =
            cases.iter().map(|c| Some(record(c, Some(2.0)))).collect();
        let out = dir.join("disruption");
        std::fs::create_dir_all(&out).unwrap();
        let files = write_report(&spec, &cases, &records, &out).unwrap();
        assert!(!files.iter().any(|f| f.starts_with("tornado")), "{files:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
