//! The results of a cell protocol, derived from the recorded increments (the in-memory
//! rows of the output writer, addressed through the plan's typed tool handles and the
//! cell's test axis): the test's own
//! curve (force vs elongation with the normalised stiffness for tension; force vs
//! deformation for compression) with the nucleus strain and shape, written as
//! `tension.csv` / `compression.csv`, their plots, and the numbers for `summary.json`.

use std::path::Path;

use cellmech_io::{plot_xy, CurveWriter, PlotSpec, Series, SeriesStyle};
use serde::Serialize;

use super::{Holder, ProtocolPlan};
use crate::cell::CellDescription;
use crate::output::OutputWriter;

/// One row of the test curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TestPoint {
    /// Tension: elongation from the reference state (µm); compression: plate travel from
    /// contact (µm); AFM: tip travel from first contact, the indentation (µm).
    pub displacement_um: f64,
    /// Compression: travel / cell diameter (the deformation of the diameter); tension:
    /// elongation / cell diameter.
    pub strain: f64,
    /// Force on the moving tool along the test (tension positive when pulling,
    /// compression positive when pushing) (nN).
    pub force_nn: f64,
    /// Tension: force / (π D²/4) / (elongation / D) (kPa); compression: the same with the
    /// deformation; AFM: NaN (see the apparent modulus instead).
    pub normalised_stiffness_kpa: f64,
    /// Largest first principal logarithmic strain in the nucleus, measured from the
    /// unstressed mesh (includes the prestress).
    pub nucleus_max_principal_log_strain: f64,
    /// The same measured from the test's reference state (tension: the unloaded state
    /// after the prestress; compression: first contact): the strain the test causes.
    pub nucleus_max_principal_log_strain_from_reference: f64,
    /// Nucleus length along the test axis over its mean transverse width.
    pub nucleus_aspect_ratio: f64,
    /// Smallest ratio of current to reference Jacobian at the corners of the cell's hex8
    /// elements (cytoplasm and nucleus; `hex8_min_corner_jacobian_ratio`): 1 undeformed,
    /// ≤ 0 once an element has folded over, which its Gauss points do not show.
    pub continuum_min_corner_jacobian_ratio: f64,
    /// AFM: radius of the contact zone around the tip's axis (µm; see
    /// `RigidContact::contact_radius`); NaN for the other tests.
    pub contact_radius_um: f64,
    /// Tension and compression: how far the two tools' forces are from balancing each
    /// other, |F_moving + F_fixed| / max(|F_moving|, |F_fixed|, 1e-3 F_max) along the test
    /// axis, F_max the largest force on the moving tool (0 when every force is zero). In equilibrium with free supports it is round-off; a viscously
    /// stabilised increment shows the viscous forces' resultant here, which the
    /// stabilisation's own norm-based measure understates
    /// (docs/suspended-cell-validation.md). NaN for AFM (the base is clamped).
    pub tool_force_imbalance: f64,
}

/// What a protocol run showed.
#[derive(Debug, Clone, Serialize)]
pub struct ProtocolResults {
    /// `micropipette-tension`, `microplate-compression` or `afm-indentation`.
    pub kind: String,
    /// Largest support reaction during the prestress step (nN): ~0 for a free cell.
    pub prestress_support_reaction_max_nn: Option<f64>,
    /// Largest support reaction over the whole analysis (nN), to compare with the force.
    pub support_reaction_max_nn: Option<f64>,
    /// Force on the moving tool at the reference (tension) or contact (compression) state.
    pub reference_force_nn: Option<f64>,
    /// Tension with `grip = "cap"`: the caps (nodes, gripped area, the ring moved onto the
    /// grip radius).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caps: Option<super::grip::CapReport>,
    /// The test curve, from the reference state on.
    pub curve: Vec<TestPoint>,
    /// Compression: the point at the end of each compression step; AFM: at each depth.
    pub at_deformations: Vec<(f64, TestPoint)>,
    /// The last point (end of the test or the last converged increment).
    pub last: Option<TestPoint>,
    /// AFM: the apparent Young's modulus fitted to the loading curve (`None` with fewer than
    /// three points in the fit range), or why the fit failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub apparent_modulus: Option<Result<super::apparent_modulus::ApparentModulusFit, String>>,
    /// AFM: the first indentation (µm from first contact) at which a mesh node that is not
    /// a contact candidate lay deeper inside the tip than the protocol's pierce tolerance
    /// (five penetration tolerances): from there the tip has passed between the surface
    /// nodes into the cell, and the curve is the discretisation's, not the model's (refine
    /// the mesh at the site, `refinement.element_size`). `None`: it never did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tip_passes_between_nodes_at_um: Option<f64>,
    /// Tension and compression: the largest [`TestPoint::tool_force_imbalance`] over the test
    /// curve and the displacement (µm) where it is; `None` for AFM. Above about 1e-3 the
    /// curve has points that are not in equilibrium (viscously stabilised increments).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub largest_tool_force_imbalance: Option<(f64, f64)>,
    /// The first point of the test curve (its displacement, µm: elongation, plate travel or
    /// indentation) at which an element of the cell's continuum had folded over: a corner
    /// Jacobian ≤ 0 (`TestPoint::continuum_min_corner_jacobian_ratio`). From there the
    /// mesh, not the model, shapes the solution where the fold is (for AFM, under the tip:
    /// see docs/adherent-cell.md). `None`: no element folded.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub continuum_folds_at_um: Option<f64>,
    /// Files written.
    pub files: Vec<String>,
}

/// Computes the test curve from the writer's rows and writes its CSV and plots into `dir`.
/// Returns `None` when the scenario has no loading protocol. `completed_steps` is the number
/// of steps that reached their end: a target deformation or depth is reported only when its
/// step is one of them (the last converged increment of a failed step is not at the target).
pub fn write_protocol_results(
    cell: &CellDescription,
    plan: &ProtocolPlan,
    writer: &OutputWriter,
    completed_steps: usize,
    dir: &Path,
    plot_extension: &str,
) -> Result<Option<ProtocolResults>, String> {
    let (kind, holder, reference_step, sign, loading) = match plan {
        ProtocolPlan::MicropipetteTension {
            moving,
            reference_step,
            stretch_step,
            ..
        } => (
            "micropipette-tension",
            moving.clone(),
            *reference_step,
            1.0,
            vec![*stretch_step],
        ),
        ProtocolPlan::MicroplateCompression {
            moving_tool,
            contact_step,
            deformations,
            ..
        } => (
            "microplate-compression",
            Holder::Tool(moving_tool.clone()),
            *contact_step,
            -1.0,
            deformations.iter().map(|(s, _)| *s).collect(),
        ),
        ProtocolPlan::AfmIndentation {
            tip,
            contact_step,
            depths,
            retract_step,
            ..
        } => (
            "afm-indentation",
            Holder::Tool(tip.clone()),
            *contact_step,
            -1.0,
            depths
                .iter()
                .map(|(s, _)| *s)
                .chain(retract_step.iter().copied())
                .collect(),
        ),
        ProtocolPlan::Prestress => return Ok(None),
    };
    let column = |name: &str| {
        writer
            .column(name)
            .ok_or_else(|| format!("curve.csv has no column {name}"))
    };
    let step = column("step")?;
    let u = column(&holder.displacement_column(cell.axis))?;
    let f = column(&holder.force_column(cell.axis))?;
    let strain = column("nucleus_max_principal_log_strain")?;
    let strain_from_reference = column("nucleus_max_principal_log_strain_from_reference")?;
    let aspect = column("nucleus_aspect_ratio")?;
    // Element validity over every continuum block the cell has (NaN where none reports).
    let corner_ratio: Vec<f64> = ["cytoplasm", "nucleus"]
        .iter()
        .filter_map(|block| writer.column(&format!("{block}_min_corner_jacobian_ratio")))
        .fold(vec![f64::NAN; step.len()], |acc, c| {
            acc.iter().zip(&c).map(|(a, b)| a.min(*b)).collect()
        });
    // The other tool's force, to check the two balance (tension and compression).
    let fixed_force = match plan {
        ProtocolPlan::MicropipetteTension { fixed, .. } => {
            Some(column(&fixed.force_column(cell.axis))?)
        }
        ProtocolPlan::MicroplateCompression { fixed_tool, .. } => {
            Some(column(&fixed_tool.force_column(cell.axis))?)
        }
        _ => None,
    };
    // Near the unloaded reference state both forces are round-off: measured against a
    // thousandth of the largest force instead.
    let force_floor = 1e-3 * f.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let imbalance = |r: usize| match &fixed_force {
        Some(g) => {
            let larger = f[r].abs().max(g[r].abs()).max(force_floor);
            if larger > 0.0 {
                (f[r] + g[r]).abs() / larger
            } else {
                0.0
            }
        }
        None => f64::NAN,
    };
    // The tip's contact radius (AFM only).
    let contact_radius = match plan {
        ProtocolPlan::AfmIndentation { tip, .. } => Some(column(&tip.contact_radius_column())?),
        _ => None,
    };
    // Cells without minimal supports (the clamped adherent cell) have no such column.
    let support = writer.column("support_reaction_max_nN").unwrap_or_default();
    let d = cell.cell_diameter;
    let area = std::f64::consts::PI * d * d / 4.0;
    let last_row_of = |s: usize| step.iter().rposition(|&k| k as usize == s);
    let prestress_support_reaction_max_nn = step
        .iter()
        .zip(&support)
        .filter(|(k, _)| **k == 0.0)
        .map(|(_, r)| *r)
        .reduce(f64::max);
    let mut results = ProtocolResults {
        kind: kind.into(),
        prestress_support_reaction_max_nn,
        support_reaction_max_nn: support.iter().copied().reduce(f64::max),
        reference_force_nn: None,
        caps: match plan {
            ProtocolPlan::MicropipetteTension { caps, .. } => caps.clone(),
            _ => None,
        },
        curve: Vec::new(),
        at_deformations: Vec::new(),
        last: None,
        apparent_modulus: None,
        tip_passes_between_nodes_at_um: None,
        largest_tool_force_imbalance: None,
        continuum_folds_at_um: None,
        files: Vec::new(),
    };
    // The reference state is the end of its step: none when that step did not finish. A
    // reference step that needed no increment (the plates of a cell that did not contract
    // already touch it) ends where the step before it ended.
    let Some(reference) = (reference_step < completed_steps)
        .then(|| step.iter().rposition(|&k| k as usize <= reference_step))
        .flatten()
    else {
        return Ok(Some(results));
    };
    results.reference_force_nn = Some(sign * f[reference]);
    let point = |r: usize| {
        let displacement = sign * (u[r] - u[reference]);
        let e = displacement / d;
        let force = sign * f[r];
        TestPoint {
            displacement_um: displacement,
            strain: e,
            force_nn: force,
            // Per unit of the cell's cross-section: meaningless under a tip (NaN there).
            normalised_stiffness_kpa: if e > 0.0 && kind != "afm-indentation" {
                force / area / e
            } else {
                f64::NAN
            },
            nucleus_max_principal_log_strain: strain[r],
            nucleus_max_principal_log_strain_from_reference: if r == reference {
                0.0
            } else {
                strain_from_reference[r]
            },
            nucleus_aspect_ratio: aspect[r],
            continuum_min_corner_jacobian_ratio: corner_ratio[r],
            contact_radius_um: contact_radius.as_ref().map_or(f64::NAN, |c| c[r]),
            tool_force_imbalance: imbalance(r),
        }
    };
    let mut curve_rows = vec![reference];
    results.curve.push(point(reference));
    for r in reference + 1..step.len() {
        if loading.contains(&(step[r] as usize)) {
            results.curve.push(point(r));
            curve_rows.push(r);
        }
    }
    let targets = match plan {
        ProtocolPlan::MicroplateCompression { deformations, .. } => deformations.clone(),
        ProtocolPlan::AfmIndentation { depths, .. } => depths.clone(),
        _ => Vec::new(),
    };
    for (s, target) in targets {
        if s >= completed_steps {
            continue;
        }
        if let Some(r) = last_row_of(s) {
            results.at_deformations.push((target, point(r)));
        }
    }
    results.last = results.curve.last().copied();
    if let ProtocolPlan::AfmIndentation {
        tip,
        pierce_tolerance,
        ..
    } = plan
    {
        if let Some(inside) = writer.column(&tip.deepest_node_inside_column()) {
            results.tip_passes_between_nodes_at_um = curve_rows
                .iter()
                .find(|&&r| inside[r] > *pierce_tolerance)
                .map(|&r| point(r).displacement_um);
        }
    }
    if fixed_force.is_some() {
        results.largest_tool_force_imbalance = results
            .curve
            .iter()
            .map(|p| (p.tool_force_imbalance, p.displacement_um))
            .reduce(|a, b| if b.0 > a.0 { b } else { a });
    }
    // `+ 0.0`: a fold already there at the reference point reads 0, not −0.
    results.continuum_folds_at_um = curve_rows
        .iter()
        .find(|&&r| corner_ratio[r] <= 0.0)
        .map(|&r| point(r).displacement_um + 0.0);
    let (stem, x_label, x_column) = match kind {
        "micropipette-tension" => ("tension", "elongation (µm)", "elongation_um"),
        "afm-indentation" => (
            "indentation",
            "indentation from first contact (µm)",
            "indentation_um",
        ),
        _ => (
            "compression",
            "plate travel from contact (µm)",
            "plate_travel_um",
        ),
    };
    let csv = format!("{stem}.csv");
    let mut columns = vec![
        x_column,
        "strain_of_diameter",
        "force_nN",
        "normalised_stiffness_kPa",
        "nucleus_max_principal_log_strain",
        "nucleus_max_principal_log_strain_from_reference",
        "nucleus_aspect_ratio",
        "continuum_min_corner_jacobian_ratio",
    ];
    if contact_radius.is_some() {
        columns.push("contact_radius_um");
    } else {
        columns.push("tool_force_imbalance");
    }
    let mut out = CurveWriter::create(&dir.join(&csv), &columns).map_err(|e| e.to_string())?;
    for p in &results.curve {
        let row = [
            p.displacement_um,
            p.strain,
            p.force_nn,
            p.normalised_stiffness_kpa,
            p.nucleus_max_principal_log_strain,
            p.nucleus_max_principal_log_strain_from_reference,
            p.nucleus_aspect_ratio,
            p.continuum_min_corner_jacobian_ratio,
            if contact_radius.is_some() {
                p.contact_radius_um
            } else {
                p.tool_force_imbalance
            },
        ];
        out.push_row(&row[..columns.len()])
            .map_err(|e| e.to_string())?;
    }
    results.files.push(csv);
    let series = |label: &str, y: fn(&TestPoint) -> f64| Series {
        label: label.into(),
        points: results
            .curve
            .iter()
            .map(|p| (p.displacement_um, y(p)))
            .collect(),
        style: SeriesStyle::LineAndMarkers,
    };
    let title = match plan {
        ProtocolPlan::MicropipetteTension { .. } => "Suspended cell: micropipette tension".into(),
        ProtocolPlan::AfmIndentation { site, .. } => {
            format!("Adherent cell: AFM indentation at the {site}")
        }
        _ => "Suspended cell: microplate compression".to_string(),
    };
    let plots = [
        (
            format!("{stem}-force.{plot_extension}"),
            if kind == "afm-indentation" {
                "force on the tip (nN)"
            } else {
                "force on the moving tool (nN)"
            },
            vec![series("force", |p| p.force_nn)],
        ),
        (
            format!("{stem}-nucleus.{plot_extension}"),
            "nucleus max principal log strain",
            vec![
                series("from the unstressed mesh", |p| {
                    p.nucleus_max_principal_log_strain
                }),
                series("from the reference state", |p| {
                    p.nucleus_max_principal_log_strain_from_reference
                }),
            ],
        ),
    ];
    let mut plots = plots.to_vec();
    if let ProtocolPlan::AfmIndentation { tip_radius, .. } = plan {
        // The contact radius against Hertz's √(R d) for a half-space (a guide: the cell is
        // neither flat nor homogeneous).
        let hertz = Series {
            label: "Hertz sqrt(R d), half-space".into(),
            points: results
                .curve
                .iter()
                .map(|p| {
                    (
                        p.displacement_um,
                        (tip_radius * p.displacement_um.max(0.0)).sqrt(),
                    )
                })
                .collect(),
            style: SeriesStyle::Line,
        };
        plots.push((
            format!("{stem}-contact-radius.{plot_extension}"),
            "contact radius (µm)",
            vec![series("model", |p| p.contact_radius_um), hertz],
        ));
    }
    if sign > 0.0 {
        // The validation band: normalised stiffness 2.6 ± 0.5 kPa near 100 % elongation
        // (Nagayama et al. 2006, shared/spec/cell-models.md "Validation data").
        let x_end = d.max(results.curve.last().map_or(0.0, |p| p.displacement_um));
        let band = |label: &str, k: f64| Series {
            label: label.into(),
            points: vec![(0.0, k), (x_end, k)],
            style: SeriesStyle::Line,
        };
        plots.push((
            format!("{stem}-stiffness.{plot_extension}"),
            "normalised stiffness F/(pi D^2/4)/(elongation/D) (kPa)",
            vec![
                series("model", |p| p.normalised_stiffness_kpa),
                band("experiments 2.6 kPa (Nagayama 2006)", 2.6),
                band("2.6 - 0.5 kPa", 2.1),
                band("2.6 + 0.5 kPa", 3.1),
            ],
        ));
    }
    if let ProtocolPlan::AfmIndentation {
        fit, depths, site, ..
    } = plan
    {
        // The loading part of the curve (the retract step is not fitted).
        let last_depth_step = depths.last().map_or(0, |(s, _)| *s);
        let loading: Vec<&TestPoint> = results
            .curve
            .iter()
            .zip(&curve_rows)
            .filter(|(_, r)| step[**r] as usize <= last_depth_step)
            .map(|(p, _)| p)
            .collect();
        let depth: Vec<f64> = loading.iter().map(|p| p.displacement_um).collect();
        let force: Vec<f64> = loading.iter().map(|p| p.force_nn).collect();
        let result = super::apparent_modulus::fit_apparent_modulus(&depth, &force, fit);
        if let Ok(f) = &result {
            let file = format!("{stem}-fit.{plot_extension}");
            super::apparent_modulus::write_fit_plot(
                &dir.join(&file),
                &format!("Adherent cell at the {site}: apparent modulus"),
                &depth,
                &force,
                f,
            )
            .map_err(|e| e.to_string())?;
            results.files.push(file);
        }
        results.apparent_modulus = Some(result.map_err(|e| e.to_string()));
    }
    for (file, y_label, series) in plots {
        let spec = PlotSpec {
            title: title.clone(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series,
        };
        plot_xy(&dir.join(&file), &spec).map_err(|e| e.to_string())?;
        results.files.push(file);
    }
    Ok(Some(results))
}
