//! Running a scenario: build the model, run its steps with the output writers attached,
//! then write the plot and `summary.json` (also when the analysis stops early).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use cellmech_fem::solve::{
    FailureReason, IncrementReport, IterationReport, Observer, Problem, SolveError, Timings,
};
use serde::Serialize;

use crate::model::{build, BuildError};
use crate::output::{OutputWriter, StepSplit, StepStats};

use crate::analysis::{Analysis, CellStudy};

type Scenario = Analysis;

/// What a run did: written to `summary.json` and returned to the caller.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// cellmech version.
    pub version: &'static str,
    /// Scenario title.
    pub title: String,
    /// Where the scenario came from.
    pub scenario: String,
    /// `completed` or `failed`.
    pub status: String,
    /// Why the analysis stopped early, when it did.
    pub error: Option<String>,
    /// Seed of every random choice (a cell model's; none for a plain mesh).
    pub seed: Option<u64>,
    /// The cell model's resolved parameters, materials and geometry quality.
    pub cell: Option<CellStudy>,
    /// The cell protocol's results (test curve, reference state, forces at targets).
    pub protocol: Option<crate::protocol::results::ProtocolResults>,
    /// Mesh and system size.
    pub size: SystemSize,
    /// Per-step convergence statistics.
    pub steps: Vec<StepStats>,
    /// Wall-clock seconds: total, and the solver's split.
    pub wall_time_s: f64,
    /// Time in assembly, factorisation and solves.
    pub solver_timings: Timings,
    /// Every `curve.csv` column at the last converged increment (names carry units).
    pub final_values: BTreeMap<String, f64>,
    /// Every filament at the last converged increment, and the counts per family (`None`
    /// for a model without filaments).
    pub filaments: Option<crate::output::filaments::FilamentSnapshot>,
    /// The ALE rezonings between steps, in order (absent when the model has none).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub rezonings: Vec<crate::model::RezoneRecord>,
    /// The scenario as parsed (inputs echoed).
    pub input: toml::Table,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
}

/// Sizes of the model and its linear system.
#[derive(Debug, Clone, Serialize)]
pub struct SystemSize {
    /// Nodes.
    pub nodes: usize,
    /// Elements over all blocks.
    pub elements: usize,
    /// Degrees of freedom.
    pub dofs: usize,
    /// Stored nonzeros of the tangent (lower triangle; after eliminating embedded DOFs).
    pub tangent_nonzeros: usize,
    /// The factor of that tangent: exact nonzeros of L and flops of one factorisation
    /// (what each Newton iteration's factorisation costs; absent for a solver that does
    /// not report it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub factor: Option<cellmech_fem::linsolve::FactorSize>,
    /// DOFs eliminated by linear ties: embedded nodes (they follow their hosts) and hanging
    /// nodes of a locally refined mesh (they follow the coarse side).
    pub constrained_dofs: usize,
    /// What each embedding did.
    pub embedding: Vec<crate::model::EmbedSummary>,
    /// Hanging nodes of a locally refined mesh, tied in their 3 translations.
    pub hanging_nodes: usize,
    /// Filament families stress-free in the prestressed cell: the first pass (absent when
    /// every part is stress-free in the mesh).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prestressed_reference: Option<crate::model::PrestressedReferenceReport>,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The model could not be built.
    #[error("building the model")]
    Build(#[from] BuildError),
    /// An output could not be written.
    #[error("writing outputs: {0}")]
    Output(String),
    /// The analysis stopped early; every converged increment was written.
    #[error("the analysis stopped: {error} (converged results are in {})", out_dir.display())]
    Analysis {
        /// The solver's reason.
        error: SolveError,
        /// Where the outputs are.
        out_dir: PathBuf,
        /// The summary (also written to summary.json).
        summary: Box<RunSummary>,
    },
}

/// Forwards every event to two observers.
struct Tee<'a, 'b>(&'a mut OutputWriter, &'b mut dyn Observer);

impl Observer for Tee<'_, '_> {
    fn on_step_start(&mut self, i: usize, name: &str) {
        self.0.on_step_start(i, name);
        self.1.on_step_start(i, name);
    }
    fn on_iteration(&mut self, r: &IterationReport) {
        self.0.on_iteration(r);
        self.1.on_iteration(r);
    }
    fn on_increment(&mut self, p: &Problem, r: &IncrementReport<'_>) {
        self.0.on_increment(p, r);
        self.1.on_increment(p, r);
    }
    fn on_cutback(&mut self, t: f64, dt: f64, reason: &FailureReason) {
        self.0.on_cutback(t, dt, reason);
        self.1.on_cutback(t, dt, reason);
    }
}

/// Runs `scenario`, writing into `out_dir` (created if needed). `progress` sees every
/// solver event (the CLI's progress bar; pass `&mut NullObserver` for none).
pub fn run(
    scenario: &Scenario,
    out_dir: &Path,
    progress: &mut dyn Observer,
) -> Result<RunSummary, RunError> {
    run_with_threads(scenario, out_dir, progress, 0)
}

/// [`run`] with the solver's thread count set (`0`: rayon's default, see
/// `cellmech_fem::solve::Problem::set_threads`); a study running cases side by side gives
/// each a share of the cores.
pub fn run_with_threads(
    scenario: &Scenario,
    out_dir: &Path,
    progress: &mut dyn Observer,
    threads: usize,
) -> Result<RunSummary, RunError> {
    let start = Instant::now();
    std::fs::create_dir_all(out_dir)
        .map_err(|e| RunError::Output(format!("cannot create {}: {e}", out_dir.display())))?;
    let mut model = build(&scenario.model)?;
    if threads > 0 {
        model
            .problem
            .set_threads(threads)
            .map_err(|e| RunError::Output(format!("cannot start {threads} solver threads: {e}")))?;
    }
    let rezoner = crate::model::Rezoner::new(&scenario.model, &model).map_err(RunError::Output)?;
    // Every node's reference position: the mesh's, until a rezoning moves some.
    let mut reference = scenario.model.mesh.nodes.clone();
    let mut rezonings = Vec::new();
    // `rezonings.csv`, written as the rezonings happen (created by the first).
    let mut rezoning_csv: Option<cellmech_io::CurveWriter> = None;
    let mut writer = OutputWriter::new(
        out_dir,
        &model,
        reference.clone(),
        scenario.model.output.vtk_every,
    )
    .map_err(RunError::Output)?;
    if let Some(CellStudy {
        protocol: Some(plan),
        ..
    }) = &scenario.cell
    {
        writer.set_reference_step(plan.reference_step());
    }
    writer.record_state(&model.problem, 0, 0, 0.0, true);
    let mut failure = None;
    // Steps that ran to their end (a failed step's converged increments are written, but it
    // did not reach its end).
    let mut completed_steps = 0;
    for (index, step) in model.steps.iter().enumerate() {
        let mut tee = Tee(&mut writer, progress);
        let before = model.problem.timings();
        let result = model.problem.run_step(step, &mut tee);
        // (A step that failed before it started has no statistics of its own.)
        if let Some(s) = writer.stats.get_mut(index).filter(|s| s.name == step.name) {
            s.split = StepSplit {
                output_s: s.split.output_s,
                ..StepSplit::between(&before, &model.problem.timings())
            };
        }
        if let Err(e) = result {
            failure = Some(e);
            break;
        }
        completed_steps += 1;
        if let Some(e) = writer.error.take() {
            return Err(RunError::Output(e));
        }
        if let Some(rezoner) = rezoner.as_ref().filter(|r| r.after(index)) {
            match rezoner.rezone(&step.name, &mut model.problem, &mut reference) {
                Ok(Some((record, remaps))) => {
                    writer.remap(&remaps, &reference, model.problem.dof_map());
                    if rezoning_csv.is_none() {
                        rezoning_csv = Some(
                            cellmech_io::CurveWriter::create(
                                &out_dir.join("rezonings.csv"),
                                &crate::model::RezoneRecord::COLUMNS,
                            )
                            .map_err(|e| RunError::Output(e.to_string()))?,
                        );
                    }
                    if let Some(csv) = rezoning_csv.as_mut() {
                        csv.push_row(&record.row(index))
                            .map_err(|e| RunError::Output(e.to_string()))?;
                    }
                    rezonings.push(record);
                }
                Ok(None) => {}
                Err(message) => {
                    failure = Some(SolveError::InvalidStep {
                        step: step.name.clone(),
                        message: format!("the rezoning after the step failed: {message}"),
                    });
                    break;
                }
            }
        }
    }
    // The last iteration rows; a write error is reported unless the analysis already
    // failed (its own error says more, and the rows were written at its last cut-back).
    if let Err(e) = writer.flush_tables() {
        if failure.is_none() {
            return Err(RunError::Output(e));
        }
    }
    let mut files = vec![
        "curve.csv".to_string(),
        "convergence.csv".into(),
        "fields.pvd".into(),
    ];
    if writer.last_filaments.is_some() {
        files.push("filaments.csv".into());
    }
    if rezoning_csv.is_some() {
        files.push("rezonings.csv".into());
    }
    files.extend(crate::plots::plot_curves(scenario, &writer, out_dir).map_err(RunError::Output)?);
    // The last converged state as a picture (reference coordinates + displacement).
    let deformed: Vec<[f64; 3]> = {
        let (p, map) = (&model.problem, model.problem.dof_map());
        (0..scenario.model.mesh.num_nodes())
            .map(|n| std::array::from_fn(|c| reference[n][c] + p.u()[map.dof(n, c)]))
            .collect()
    };
    let picture = format!("deformed.{}", scenario.model.output.plot_format.extension());
    let last_step = writer.stats.last().map_or("start", |s| s.name.as_str());
    cellmech_io::plot_model_picture(
        &out_dir.join(&picture),
        &crate::output::model_view::model_picture_at(
            &scenario.model,
            &deformed,
            format!("{}: end of step '{last_step}'", scenario.title),
        ),
    )
    .map_err(|e| RunError::Output(e.to_string()))?;
    files.push(picture);
    let protocol = match &scenario.cell {
        Some(CellStudy {
            description,
            protocol: Some(plan),
        }) => crate::protocol::results::write_protocol_results(
            description,
            plan,
            &writer,
            completed_steps,
            out_dir,
            scenario.model.output.plot_format.extension(),
        )
        .map_err(RunError::Output)?,
        _ => None,
    };
    if let Some(p) = &protocol {
        files.extend(p.files.iter().cloned());
    }
    files.push("summary.json".into());
    let summary = RunSummary {
        version: env!("CARGO_PKG_VERSION"),
        title: scenario.title.clone(),
        scenario: scenario.origin.clone(),
        status: if failure.is_some() {
            "failed".into()
        } else {
            "completed".into()
        },
        error: failure.as_ref().map(ToString::to_string),
        seed: scenario.cell.as_ref().map(|c| c.description.seed),
        cell: scenario.cell.clone(),
        protocol,
        size: SystemSize {
            nodes: scenario.model.mesh.num_nodes(),
            elements: scenario.model.mesh.num_elements(),
            dofs: model.problem.dof_map().num_dofs(),
            tangent_nonzeros: model.problem.tangent_nonzeros(),
            factor: model.problem.factor_size(),
            constrained_dofs: model.problem.num_constrained_dofs(),
            embedding: model.embedding.clone(),
            hanging_nodes: model.hanging_nodes,
            prestressed_reference: model.prestressed_reference.clone(),
        },
        steps: writer.stats.clone(),
        wall_time_s: start.elapsed().as_secs_f64(),
        solver_timings: model.problem.timings(),
        final_values: match writer.rows.last() {
            Some(row) => writer
                .header
                .iter()
                .cloned()
                .zip(row.iter().copied())
                .skip(3)
                .collect(),
            None => BTreeMap::new(),
        },
        filaments: writer.last_filaments.clone(),
        rezonings,
        input: scenario.echo.clone(),
        files,
    };
    cellmech_io::write_json_atomic(&out_dir.join("summary.json"), &summary)
        .map_err(|e| RunError::Output(e.to_string()))?;
    match failure {
        Some(error) => Err(RunError::Analysis {
            error,
            out_dir: out_dir.to_path_buf(),
            summary: Box::new(summary),
        }),
        None => Ok(summary),
    }
}
