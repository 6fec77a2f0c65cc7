//! Writers attached to a run as observers: the force curve (`curve.csv`), the convergence
//! table (`convergence.csv`), the per-filament table (`filaments.csv`, see [`filaments`]) and
//! the ParaView series (`fields/*.vtu` + `fields.pvd`). Every
//! file is written as results are produced, through atomic replacement, so a crash keeps
//! every converged increment.

use std::path::{Path, PathBuf};

use cellmech_fem::element::KernelError;
use cellmech_fem::solve::{
    FailureReason, IncrementReport, IterationReport, Observer, Problem, StabilizationReport,
    Timings,
};
use cellmech_io::{CurveWriter, Field, PvdSeries, VtuBlock, VtuFrame};

pub mod filaments;
pub mod model_view;

use crate::model::filaments::FilamentIndex;
use crate::model::{BuiltModel, CurveDofs, ShapeProbe};

/// Convergence statistics of one step.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct StepStats {
    /// Step name.
    pub name: String,
    /// Converged increments.
    pub increments: usize,
    /// Newton iterations over all attempts.
    pub iterations: usize,
    /// Failed attempts that were cut back.
    pub cutbacks: usize,
    /// The reasons of the cutbacks.
    pub cutback_reasons: Vec<String>,
    /// Wall-clock seconds from the step's start to its last converged increment.
    pub wall_time_s: f64,
    /// Viscous stabilisation at the step's last increment (absent when the step had none
    /// or it never switched on).
    pub stabilization: Option<StabilizationReport>,
    /// Increments solved with viscous forces on.
    pub stabilized_increments: usize,
    /// Largest damping factor used in the step.
    pub max_stabilization_factor: f64,
    /// Where the step's time went.
    pub split: StepSplit,
}

/// The time split of one step: the solver's parts (from [`Timings`]) and the output.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepSplit {
    /// Residual and tangent assembly (s).
    pub assembly_s: f64,
    /// Residual and tangent assemblies.
    pub assemblies: usize,
    /// Residual-only assembly (s).
    pub residual_only_s: f64,
    /// Residual-only assemblies.
    pub residual_evaluations: usize,
    /// Numeric factorisation (s).
    pub factorization_s: f64,
    /// Numeric factorisations.
    pub factorizations: usize,
    /// Triangular solves (s).
    pub solve_s: f64,
    /// The relaxation blocks' local solves (s).
    pub relaxation_s: f64,
    /// Extra Newton rounds started by contact status changes or multiplier updates.
    pub augmentations: usize,
    /// Corrections shortened by the rotations' trust region (`solver.rotation_step`).
    #[serde(default)]
    pub rotation_limited_steps: usize,
    /// Writing results (curves, tables, VTU frames) while the step ran (s).
    pub output_s: f64,
}

impl StepSplit {
    /// The solver's part of the split between two readings of [`Timings`] (output: 0).
    pub fn between(before: &Timings, after: &Timings) -> Self {
        StepSplit {
            assembly_s: after.assembly_s - before.assembly_s,
            assemblies: after.assemblies - before.assemblies,
            residual_only_s: after.residual_only_s - before.residual_only_s,
            residual_evaluations: after.residual_evaluations - before.residual_evaluations,
            factorization_s: after.factorization_s - before.factorization_s,
            factorizations: after.factorizations - before.factorizations,
            solve_s: after.solve_s - before.solve_s,
            relaxation_s: after.relaxation.seconds - before.relaxation.seconds,
            augmentations: after.augmentations - before.augmentations,
            rotation_limited_steps: after.rotation_limited_steps - before.rotation_limited_steps,
            output_s: 0.0,
        }
    }
}

/// Writes outputs as the solver converges increments.
pub struct OutputWriter {
    curves: Vec<CurveDofs>,
    probes: Vec<ShapeProbe>,
    support_dofs: Vec<usize>,
    /// Column names of `curve.csv` (with units).
    pub header: Vec<String>,
    /// Every converged row of `curve.csv`.
    pub rows: Vec<Vec<f64>>,
    /// Increments and iterations per step, and cutbacks.
    pub stats: Vec<StepStats>,
    /// The first output error, if any (the run stops on it).
    pub error: Option<String>,
    /// Every filament at the last recorded state (`None` for a model without filaments).
    pub last_filaments: Option<filaments::FilamentSnapshot>,
    filaments: FilamentIndex,
    filaments_csv: Option<CurveWriter>,
    curve_csv: CurveWriter,
    convergence_csv: CurveWriter,
    increments_csv: CurveWriter,
    /// Strains are also measured from the end of this step (a test's reference state).
    reference_step: Option<usize>,
    /// The DOF values at that state, once reached.
    u_reference: Option<Vec<f64>>,
    /// The last converged state of the reference step while it runs.
    reference_candidate: Option<Vec<f64>>,
    /// Columns of the strains from the reference state (NaN before it is reached).
    from_reference_columns: usize,
    pvd: PvdSeries,
    vtk_every: usize,
    attempt: usize,
    nodes: Vec<[f64; 3]>,
    step_start: std::time::Instant,
}

impl OutputWriter {
    /// After an ALE rezoning: the new reference positions of every node, and the earlier
    /// states kept (the test's reference state) mapped onto the moved nodes.
    pub fn remap(
        &mut self,
        remaps: &[cellmech_fem::rezone::NodeRemap],
        reference: &[[f64; 3]],
        dof_map: &cellmech_fem::dof::DofMap,
    ) {
        self.nodes = reference.to_vec();
        for u in [&mut self.u_reference, &mut self.reference_candidate]
            .into_iter()
            .flatten()
        {
            cellmech_fem::solve::remap_translations(remaps, dof_map, u);
        }
    }

    /// Creates the output files in `dir` (which must exist) for this model.
    pub fn new(
        dir: &Path,
        model: &BuiltModel,
        nodes: Vec<[f64; 3]>,
        vtk_every: usize,
    ) -> Result<Self, String> {
        let mut header = vec!["step".to_string(), "increment".into(), "time".into()];
        for c in &model.curves {
            header.extend(c.columns());
        }
        let p = &model.problem;
        for term in p.terms() {
            header.extend(
                term.scalar_outputs(p.u(), p.dof_map())
                    .into_iter()
                    .map(|(n, _)| n),
            );
        }
        let before = header.len();
        for term in p.terms() {
            header.extend(
                term.scalar_outputs_from(p.u(), p.u(), p.dof_map())
                    .into_iter()
                    .map(|(n, _)| n),
            );
        }
        let from_reference_columns = header.len() - before;
        header.extend(filaments::curve_columns(&model.filaments));
        for probe in &model.probes {
            header.extend(probe.columns());
        }
        if !model.support_dofs.is_empty() {
            header.push("support_reaction_max_nN".into());
        }
        let columns: Vec<&str> = header.iter().map(String::as_str).collect();
        let curve_csv =
            CurveWriter::create(&dir.join("curve.csv"), &columns).map_err(|e| e.to_string())?;
        let convergence_header = [
            "step",
            "attempt",
            "iteration",
            "residual_ratio",
            "energy_ratio",
            "force_scale_nN",
            "line_search",
            "correction_norm_um",
            "chord",
            "reformed",
        ];
        let convergence_csv =
            CurveWriter::create(&dir.join("convergence.csv"), &convergence_header)
                .map_err(|e| e.to_string())?;
        let increments_header = [
            "step",
            "increment",
            "time",
            "iterations",
            "energy_nNum",
            "stabilization_factor",
            "dissipated_increment_nNum",
            "dissipated_step_nNum",
            "dissipated_fraction",
            "viscous_force_ratio",
            "negative_pivots",
        ];
        let increments_csv = CurveWriter::create(&dir.join("increments.csv"), &increments_header)
            .map_err(|e| e.to_string())?;
        let pvd = PvdSeries::new(dir, "fields").map_err(|e| e.to_string())?;
        let filaments_csv = if model.filaments.filaments.is_empty() {
            None
        } else {
            Some(
                CurveWriter::create(&dir.join("filaments.csv"), &filaments::CSV_COLUMNS)
                    .map_err(|e| e.to_string())?,
            )
        };
        Ok(OutputWriter {
            curves: model.curves.clone(),
            probes: model.probes.clone(),
            support_dofs: model.support_dofs.clone(),
            header,
            rows: Vec::new(),
            stats: Vec::new(),
            error: None,
            last_filaments: None,
            filaments: model.filaments.clone(),
            filaments_csv,
            curve_csv,
            convergence_csv,
            increments_csv,
            reference_step: None,
            u_reference: None,
            reference_candidate: None,
            from_reference_columns,
            pvd,
            vtk_every,
            attempt: 0,
            nodes,
            step_start: std::time::Instant::now(),
        })
    }

    /// Also measure strains from the end of step `step` (the test's reference state): the
    /// `*_from_reference` columns, NaN until that state is reached.
    pub fn set_reference_step(&mut self, step: Option<usize>) {
        self.reference_step = step;
    }

    /// Path of the ParaView series file.
    pub fn pvd_path(&self) -> PathBuf {
        self.pvd.pvd_path()
    }

    /// The column with this name, over all rows.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let k = self.header.iter().position(|h| h == name)?;
        Some(self.rows.iter().map(|r| r[k]).collect())
    }

    /// Appends a `curve.csv` row for the problem's current state (and a VTU frame when
    /// `with_frame`). Called for the initial state and after every converged increment.
    pub fn record_state(
        &mut self,
        problem: &Problem,
        step: usize,
        increment: usize,
        time: f64,
        with_frame: bool,
    ) {
        let mut row = vec![step as f64, increment as f64, time];
        for c in &self.curves {
            let u =
                c.dofs.iter().map(|&d| problem.u()[d]).sum::<f64>() / c.dofs.len().max(1) as f64;
            row.push(u);
            row.push(c.sign * problem.reaction_sum(c.dofs.iter().copied()));
        }
        for term in problem.terms() {
            row.extend(
                term.scalar_outputs(problem.u(), problem.dof_map())
                    .into_iter()
                    .map(|(_, v)| v),
            );
        }
        match &self.u_reference {
            Some(u_from) => {
                for term in problem.terms() {
                    row.extend(
                        term.scalar_outputs_from(problem.u(), u_from, problem.dof_map())
                            .into_iter()
                            .map(|(_, v)| v),
                    );
                }
            }
            None => row.extend(std::iter::repeat_n(f64::NAN, self.from_reference_columns)),
        }
        if let Some(values) = self.record_filaments(problem, step, increment, time) {
            row.extend(values);
        }
        for probe in &self.probes {
            row.extend(probe.measure(&self.nodes, problem));
        }
        if !self.support_dofs.is_empty() {
            let max = self
                .support_dofs
                .iter()
                .map(|&d| problem.reaction(d).abs())
                .fold(0.0, f64::max);
            row.push(max);
        }
        let result = self.curve_csv.push_row(&row);
        self.record(result);
        self.rows.push(row);
        if with_frame {
            let result = write_frame(
                &mut self.pvd,
                time,
                problem,
                &self.nodes,
                Vec::new(),
                &self.filaments,
            );
            self.record(result);
        }
    }

    /// Adds the time since `start` to the current step's output time.
    fn add_output_time(&mut self, start: std::time::Instant) {
        if let Some(s) = self.stats.last_mut() {
            s.split.output_s += start.elapsed().as_secs_f64();
        }
    }

    /// Writes the table rows still held in memory (`convergence.csv`'s last rows).
    pub fn flush_tables(&mut self) -> Result<(), String> {
        self.convergence_csv.flush().map_err(|e| e.to_string())
    }

    /// Evaluates every filament, appends its `filaments.csv` rows, keeps the snapshot and
    /// returns the `curve.csv` values (`None` without filaments; NaN if the evaluation failed).
    fn record_filaments(
        &mut self,
        problem: &Problem,
        step: usize,
        increment: usize,
        time: f64,
    ) -> Option<Vec<f64>> {
        let csv = self.filaments_csv.as_mut()?;
        let results = match filaments::evaluate(&self.filaments, problem, &self.nodes) {
            Ok(r) => r,
            Err(e) => {
                self.error.get_or_insert(e);
                let n = filaments::curve_columns(&self.filaments).len();
                return Some(vec![f64::NAN; n]);
            }
        };
        let written = filaments::push_csv_rows(csv, step, increment, time, &results);
        self.record(written);
        let counts = filaments::family_counts(&self.filaments, &results);
        let values = filaments::curve_values(&counts);
        self.last_filaments = Some(filaments::FilamentSnapshot {
            step,
            increment,
            time,
            family_names: self
                .filaments
                .families
                .iter()
                .map(|f| f.name.clone())
                .collect(),
            families: counts,
            filaments: results,
        });
        Some(values)
    }

    fn record<T, E: std::fmt::Display>(&mut self, result: Result<T, E>) {
        if let Err(e) = result {
            self.error.get_or_insert(e.to_string());
        }
    }
}

impl Observer for OutputWriter {
    fn on_step_start(&mut self, _index: usize, name: &str) {
        self.stats.push(StepStats {
            name: name.into(),
            ..Default::default()
        });
        self.attempt = 0;
        self.step_start = std::time::Instant::now();
    }

    fn on_iteration(&mut self, r: &IterationReport) {
        let start = std::time::Instant::now();
        let step = self.stats.len().saturating_sub(1);
        if let Some(s) = self.stats.last_mut() {
            s.iterations += 1;
        }
        let row = [
            step as f64,
            self.attempt as f64,
            r.iteration as f64,
            r.residual_ratio,
            r.energy_ratio,
            r.force_scale,
            r.line_search,
            r.correction_norm,
            f64::from(u8::from(r.chord)),
            f64::from(u8::from(r.reformed)),
        ];
        // A row per Newton iteration: written at least once a second and at the end of
        // every increment or failed attempt (`flush` below), not a file rewrite each.
        let result = self
            .convergence_csv
            .push_row_deferred(&row, CONVERGENCE_MAX_AGE);
        self.record(result);
        self.add_output_time(start);
    }

    fn on_increment(&mut self, problem: &Problem, report: &IncrementReport<'_>) {
        let start = std::time::Instant::now();
        self.attempt += 1;
        let result = self.convergence_csv.flush();
        self.record(result);
        let elapsed = self.step_start.elapsed().as_secs_f64();
        if let Some(s) = self.stats.last_mut() {
            s.increments += 1;
            s.wall_time_s = elapsed;
            if let Some(st) = report.stabilization {
                s.stabilization = Some(st);
                s.max_stabilization_factor = s.max_stabilization_factor.max(st.factor);
                if st.factor > 0.0 {
                    s.stabilized_increments += 1;
                }
            }
        }
        let st = report.stabilization;
        let row = [
            report.step_index as f64,
            report.increment as f64,
            report.total_time,
            report.iterations as f64,
            report.energy,
            st.map_or(0.0, |s| s.factor),
            st.map_or(0.0, |s| s.increment_dissipated),
            st.map_or(0.0, |s| s.step_dissipated),
            st.map_or(0.0, |s| s.dissipated_fraction),
            st.map_or(0.0, |s| s.viscous_force_ratio),
            // The inertia of the increment's last factorised tangent (0 when Cholesky
            // took it; NaN when unknown): a positive count means the state Newton converged
            // to is not a stable equilibrium (a viscosity in that tangent hides some).
            problem
                .last_factor()
                .and_then(|f| f.negative_pivots)
                .map_or(f64::NAN, |n| n as f64),
        ];
        let result = self.increments_csv.push_row(&row);
        self.record(result);
        let step_end = (report.step_time - 1.0).abs() < 1e-12;
        // The reference state is the last converged state of the reference step (which a
        // stop condition may end before its step time 1, or at its start without an
        // increment: then the last state before it): kept while the steps up to it run, in
        // use from its end (or, when it ends early, from the next step on).
        match self.reference_step {
            Some(r) if report.step_index <= r => {
                // One buffer for all the increments up to the reference state.
                let candidate = self.reference_candidate.get_or_insert_with(Vec::new);
                candidate.clear();
                candidate.extend_from_slice(problem.u());
                if step_end && r == report.step_index {
                    self.u_reference = self.reference_candidate.take();
                }
            }
            Some(r) if report.step_index > r && self.u_reference.is_none() => {
                self.u_reference = self.reference_candidate.take();
            }
            _ => {}
        }
        let due = step_end || (self.vtk_every > 0 && report.increment % self.vtk_every == 0);
        self.record_state(
            problem,
            report.step_index,
            report.increment,
            report.total_time,
            due,
        );
        self.add_output_time(start);
    }

    fn on_cutback(&mut self, _t: f64, _dt: f64, reason: &FailureReason) {
        self.attempt += 1;
        let result = self.convergence_csv.flush();
        self.record(result);
        if let Some(s) = self.stats.last_mut() {
            s.cutbacks += 1;
            s.cutback_reasons.push(reason.to_string());
        }
    }
}

/// The longest a `convergence.csv` row waits in memory before the file is rewritten (rows
/// are also written at the end of every increment and failed attempt).
const CONVERGENCE_MAX_AGE: std::time::Duration = std::time::Duration::from_secs(1);

/// Writes the current state as one frame of the series: reference points with the
/// displacement field (use ParaView's "Warp By Vector") and any `extra` point fields, and
/// every term's cells with their fields; the line cells of filament families also get
/// `filament_id` and `filament_family` (an index into the model's filament families) from
/// `filaments`, so that a viewer can threshold one filament.
pub fn write_frame(
    pvd: &mut PvdSeries,
    time: f64,
    problem: &Problem,
    nodes: &[[f64; 3]],
    extra: Vec<Field>,
    filaments: &FilamentIndex,
) -> Result<(), String> {
    let map = problem.dof_map();
    let displacement: Vec<f64> = (0..nodes.len())
        .flat_map(|n| (0..3).map(move |c| problem.u()[map.dof(n, c)]))
        .collect();
    let mut outputs = Vec::new();
    let mut cell_data = Vec::new();
    for (t, term) in problem.terms().iter().enumerate() {
        let output: Option<_> = term
            .outputs(problem.u(), map)
            .map_err(|e: KernelError| format!("outputs of '{}': {e}", term.name()))?;
        if let Some(o) = output {
            let mut data: Vec<Field> = o
                .fields
                .iter()
                .map(|f| Field::new(f.name.clone(), f.components, f.values.clone()))
                .collect();
            if let Some((ids, families)) = filaments.term_cell_ids(t) {
                data.push(Field::new("filament_id", 1, ids));
                data.push(Field::new("filament_family", 1, families));
            }
            outputs.push(o);
            cell_data.push(data);
        }
    }
    let blocks = outputs
        .iter()
        .zip(cell_data)
        .map(|(o, cell_data)| VtuBlock {
            kind: o.kind,
            connectivity: &o.connectivity,
            cell_data,
        })
        .collect();
    let frame = VtuFrame {
        points: nodes,
        blocks,
        point_data: std::iter::once(Field::new("displacement_um", 3, displacement))
            .chain(extra)
            .collect(),
    };
    pvd.add_frame(time, &frame)
        .map(|_| ())
        .map_err(|e| e.to_string())
}
