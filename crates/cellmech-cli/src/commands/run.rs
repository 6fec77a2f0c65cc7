//! `cellmech run`.

use std::process::ExitCode;

use anyhow::Context;
use cellmech::run::{RunError, RunSummary};
use cellmech_fem::solve::NullObserver;

use crate::args::RunArgs;
use crate::progress::StepProgress;

pub fn run(args: &RunArgs) -> anyhow::Result<ExitCode> {
    let scenario = match &args.scenario {
        Some(path) => cellmech::scenario::load(path)
            .with_context(|| format!("reading scenario {}", path.display()))?,
        None => cellmech::examples::default_scenario().context("the built-in default scenario")?,
    };
    let quiet = args.report.quiet || args.report.json;
    if !quiet {
        eprintln!(
            "cellmech {}: {} ({})",
            env!("CARGO_PKG_VERSION"),
            scenario.title,
            scenario.origin
        );
    }
    let mut progress = StepProgress::new(scenario.model.steps.len());
    let mut null = NullObserver;
    let observer: &mut dyn cellmech_fem::solve::Observer =
        if quiet { &mut null } else { &mut progress };
    let result = cellmech::run::run(&scenario, &args.out, observer);
    progress.finish();
    match result {
        Ok(summary) => {
            report(args, &summary);
            Ok(ExitCode::SUCCESS)
        }
        Err(RunError::Analysis {
            error,
            out_dir,
            summary,
        }) => {
            report(args, &summary);
            eprintln!("error: the analysis stopped: {error}");
            eprintln!(
                "every converged increment is written in {}",
                out_dir.display()
            );
            Ok(ExitCode::from(1))
        }
        Err(other) => {
            Err(anyhow::Error::new(other).context(format!("running {}", scenario.origin)))
        }
    }
}

fn report(args: &RunArgs, summary: &RunSummary) {
    if args.report.json {
        match serde_json::to_string(summary) {
            Ok(text) => out!("{text}"),
            Err(e) => eprintln!("error: cannot encode the summary: {e}"),
        }
        return;
    }
    if args.report.quiet {
        return;
    }
    let iterations: usize = summary.steps.iter().map(|s| s.iterations).sum();
    let increments: usize = summary.steps.iter().map(|s| s.increments).sum();
    eprintln!(
        "{}: {} increments, {} Newton iterations, {:.2} s ({} dofs)",
        summary.status, increments, iterations, summary.wall_time_s, summary.size.dofs
    );
    match &summary.protocol {
        // A cell protocol: its own results, not every column of curve.csv.
        Some(p) => {
            if let Some(f) = p.reference_force_nn {
                eprintln!("  force at the reference/contact state: {f:.4} nN");
            }
            for (target, point) in &p.at_deformations {
                if p.kind == "afm-indentation" {
                    // The targets are depths (µm) from first contact, not deformations.
                    eprintln!(
                        "  at {target} um indentation: force {:.4} nN, contact radius {:.3} um, nucleus max log strain from first contact {:.4}",
                        point.force_nn,
                        point.contact_radius_um,
                        point.nucleus_max_principal_log_strain_from_reference
                    );
                } else {
                    eprintln!(
                        "  at {:.0} % deformation: force {:.2} nN, nucleus aspect ratio {:.3}, nucleus max log strain {:.3}",
                        100.0 * target,
                        point.force_nn,
                        point.nucleus_aspect_ratio,
                        point.nucleus_max_principal_log_strain
                    );
                }
            }
            if let (Some(last), true) = (&p.last, p.kind == "afm-indentation") {
                eprintln!(
                    "  last point: indentation {:.3} um, force {:.4} nN, nucleus max log strain from first contact {:.4}",
                    last.displacement_um,
                    last.force_nn,
                    last.nucleus_max_principal_log_strain_from_reference
                );
            } else if let Some(last) = &p.last {
                eprintln!(
                    "  last point: travel {:.3} um, force {:.2} nN, normalised stiffness {:.3} kPa, nucleus aspect ratio {:.3}, nucleus max log strain {:.3}",
                    last.displacement_um,
                    last.force_nn,
                    last.normalised_stiffness_kpa,
                    last.nucleus_aspect_ratio,
                    last.nucleus_max_principal_log_strain
                );
            }
            if let Some(depth) = p.tip_passes_between_nodes_at_um {
                eprintln!(
                    "  warning: from {depth:.3} um of indentation the tip passes between the surface nodes into the cell (a mesh node lies more than five penetration tolerances inside it); the curve beyond is the mesh's, not the model's: refine the mesh at the site (cell.refinement.element_size with max_levels)"
                );
            }
            if let Some(at) = p.continuum_folds_at_um {
                eprintln!(
                    "  warning: from {at:.3} um an element of the cell has folded over (a corner Jacobian <= 0: its map is no longer one-to-one, though its Gauss points are valid); the curve beyond depends on the mesh there: curve.csv's <block>_min_corner_jacobian_ratio and the VTU cell field min_corner_jacobian_ratio show where"
                );
            }
            if let Some(r) = p.support_reaction_max_nn {
                eprintln!("  largest support reaction: {r:.2e} nN");
            }
        }
        None => {
            for (name, value) in &summary.final_values {
                eprintln!("  {name} = {value:.6}");
            }
        }
    }
    eprintln!("outputs in {}:", args.out.display());
    for f in &summary.files {
        eprintln!("  {}", args.out.join(f).display());
    }
}
