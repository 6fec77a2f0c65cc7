//! The problem: terms, DOFs, assembler, linear solver and state, and the step driver.

use super::control::{Convergence, Damping, Extrapolation, IterationMethod, StepControl};
use super::error::FailureReason;
use super::error::SolveError;
use super::norms::norm_where;
use super::relax::{Relaxation, RelaxationStats};
use super::report::{IncrementReport, IterationReport};
use super::stabilize::{StabilizationReport, Stabilizer};
use super::step::{Monitor, Motion, Step};
use crate::assembly::Assembler;
use crate::constraint::condense::Condensation;
use crate::constraint::LinearConstraints;
use crate::dof::DofMap;
use crate::linsolve::{FactorInfo, LinearSolver, MixedPrecisionStats};
use crate::term::{LoadState, Term};

/// Buffers reused by every Newton iteration (allocated once per problem).
#[derive(Debug, Clone)]
pub(super) struct Work {
    pub values: Vec<f64>,
    pub predictor: Vec<f64>,
    pub rhs: Vec<f64>,
    pub delta: Vec<f64>,
    pub trial: Vec<f64>,
    pub du_prescribed: Vec<f64>,
    pub residual_trial: Vec<f64>,
    /// The magnitude and energy that go with `residual_trial`, and the step length it was
    /// evaluated at (None once `residual_trial` no longer describes a trial point): the
    /// line search's accepted trial becomes the new state without a second assembly.
    pub magnitude_trial: Vec<f64>,
    pub energy_trial: f64,
    pub trial_step: Option<f64>,
    pub magnitude: Vec<f64>,
    pub history: Vec<f64>,
    /// Force scale of the last measured iteration (nN).
    pub scale: f64,
    /// The energy criterion's reference at the start of the last Newton increment (nN·µm):
    /// the work of its first correction, or the floor it was given.
    pub increment_energy: f64,
    /// Quasi-Newton: the residual before the last step (free DOFs).
    pub r_prev: Vec<f64>,
    /// Quasi-Newton update pairs (steps, residual changes), 1/(s·y), and the two-loop's α.
    pub qn_s: Vec<Vec<f64>>,
    pub qn_y: Vec<Vec<f64>>,
    pub qn_rho: Vec<f64>,
    pub qn_alpha: Vec<f64>,
    /// Update pairs in use.
    pub updates: usize,
}

/// Wall-clock time spent in the hot parts of the solver, summed over the problem's life.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Timings {
    /// Residual and tangent assembly (s).
    pub assembly_s: f64,
    /// Residual-only assembly in line searches (s).
    pub residual_only_s: f64,
    /// Numeric factorisation (s).
    pub factorization_s: f64,
    /// Triangular solves (s).
    pub solve_s: f64,
    /// Number of tangent assemblies.
    pub assemblies: usize,
    /// Number of residual-only assemblies (timed in `residual_only_s`).
    pub residual_evaluations: usize,
    /// Extra Newton rounds started because a term augmented after convergence (a contact
    /// status change or a multiplier update).
    pub augmentations: usize,
    /// Number of numeric factorisations.
    pub factorizations: usize,
    /// Newton corrections solved with an earlier factorisation near convergence (chord
    /// steps, [`crate::solve::Convergence::chord_near_convergence`]).
    pub chord_steps: usize,
    /// Corrections shortened by the rotations' trust region
    /// ([`crate::solve::Convergence::max_rotation_step`]).
    pub rotation_limited_steps: usize,
    /// The relaxation blocks' local solves (nonlinear elimination): count, iterations,
    /// undone solves and time.
    pub relaxation: RelaxationStats,
    /// What the linear solver's mixed precision did (zeros when it is off:
    /// [`crate::linsolve::FaerSparseSolver::with_mixed_precision`]).
    pub mixed_precision: MixedPrecisionStats,
}

/// A nonlinear static problem.
///
/// Threads: the problem owns one rayon pool, shared by assembly and factorisation, and runs
/// every assembly, factorisation and solve inside it (`ThreadPool::install`), so their
/// parallel sections start from a pool thread and never cross rayon's cross-thread latch.
/// The pool has [`Problem::threads`] threads: by default rayon's choice (`RAYON_NUM_THREADS`
/// when set, else one per logical CPU); [`Problem::set_threads`] changes it. Results are
/// bitwise identical on any number of threads (`docs/performance.md`, section "Threads").
pub struct Problem {
    pub(super) pool: rayon::ThreadPool,
    pub(super) dof_map: DofMap,
    pub(super) terms: Vec<Box<dyn Term>>,
    pub(super) assembler: Assembler,
    pub(super) solver: Box<dyn LinearSolver>,
    /// DOFs no element couples: always held at their value.
    pub(super) untouched: Vec<bool>,
    pub(super) prescribed: Vec<bool>,
    pub(super) u: Vec<f64>,
    pub(super) f_ext: Vec<f64>,
    pub(super) residual: Vec<f64>,
    pub(super) energy: f64,
    pub(super) last_factor: Option<FactorInfo>,
    pub(super) timings: Timings,
    pub(super) work: Work,
    total_time: f64,
    steps_done: usize,
    /// Size of the model (µm), when known: a Newton correction below
    /// [`super::newton::COORDINATE_ROUND_OFF`] times it is round-off of the coordinates.
    pub(super) length_scale: f64,
    /// Linear constraints eliminated exactly (embedded nodes), if any.
    pub(super) condensation: Option<Condensation>,
    /// Viscous stabilisation of the running step, if it has one.
    pub(super) stabilizer: Option<Stabilizer>,
    /// Blocks of DOFs re-equilibrated after every global update (nonlinear elimination).
    pub(super) relaxation: Option<Relaxation>,
    /// The stabiliser epoch the terms' drag was last set from (`None`: drag off).
    pub(super) drag_epoch: Option<u64>,
    /// The rotational DOFs ([`DofMap::rotation_dofs`]), for the rotations' trust region.
    pub(super) rotation_dofs: Vec<usize>,
}

/// Receives the solver's events: CSV rows, VTU frames, progress bars and the convergence
/// table are all observers. All methods have empty defaults. It lives with [`Problem`],
/// whose converged state `on_increment` shows it.
pub trait Observer {
    /// A step starts.
    fn on_step_start(&mut self, _step_index: usize, _step_name: &str) {}
    /// A Newton iteration finished.
    fn on_iteration(&mut self, _report: &IterationReport) {}
    /// An increment converged; the problem holds the converged state.
    fn on_increment(&mut self, _problem: &Problem, _report: &IncrementReport<'_>) {}
    /// An increment failed and will be retried with a smaller increment.
    fn on_cutback(&mut self, _step_time: f64, _increment: f64, _reason: &FailureReason) {}
}

/// Least and most shrink of the viscosity per relaxation increment at the final load.
const RELAX_SHRINK_MOST: f64 = 0.1;
const RELAX_SHRINK_LEAST: f64 = 0.5;
/// Growth of the viscosity after a failed relaxation increment.
const RELAX_BACK_OFF: f64 = 10.0;
/// The re-solve without viscosity is tried again once the viscous force is within this
/// many residual tolerances.
const RELAX_RESOLVE_FACTOR: f64 = 10.0;

/// Outcome of the relaxation at a stabilised step's final load.
struct FinalRelaxation {
    /// Energy the relaxation increments dissipated (nN·µm).
    dissipated: f64,
    /// ‖viscous forces‖ / force scale in the state reached (0 when re-solved).
    viscous_force_ratio: f64,
    /// Whether the state reached is an equilibrium without viscosity.
    equilibrated: bool,
}

/// An observer that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NullObserver;

impl Observer for NullObserver {}

/// Width (in step time) below which the bracket around a stop condition's crossing is taken
/// to hold a jump of the monitored quantity rather than a root: the step then ends at the
/// first converged state beyond it (1e-6 of the step: below any physical resolution of a
/// tool's travel, and far above the round-off of the step time).
pub const JUMP_WIDTH: f64 = 1e-6;

impl Problem {
    /// Declares the model size (e.g. its bounding-box diagonal, µm). Newton then also
    /// accepts an increment whose correction is below round-off of the coordinates
    /// (1e-13 of this size): the only way to recognise equilibrium in a step that carries
    /// no load at all, where every force scale is itself round-off.
    pub fn set_length_scale(&mut self, length: f64) {
        self.length_scale = if length.is_finite() && length > 0.0 {
            length
        } else {
            0.0
        };
    }

    /// Builds the pattern and the symbolic factorisation for these terms, and the thread
    /// pool (rayon's default size; see [`Problem::set_threads`]).
    pub fn new(
        dof_map: DofMap,
        terms: Vec<Box<dyn Term>>,
        solver: Box<dyn LinearSolver>,
    ) -> Result<Self, SolveError> {
        Self::build(dof_map, terms, None, solver)
    }

    /// Like [`Problem::new`], with linear constraints (slave = Σ w·master, e.g. embedded
    /// nodes) eliminated exactly by condensation: see [`crate::constraint`]. Slave DOFs
    /// can be neither prescribed nor loaded (use [`LinearConstraints::distribute`]); their
    /// values follow the masters after every solve, and reactions appear on the masters.
    pub fn with_constraints(
        dof_map: DofMap,
        terms: Vec<Box<dyn Term>>,
        constraints: LinearConstraints,
        solver: Box<dyn LinearSolver>,
    ) -> Result<Self, SolveError> {
        Self::build(dof_map, terms, Some(constraints), solver)
    }

    fn build(
        dof_map: DofMap,
        terms: Vec<Box<dyn Term>>,
        constraints: Option<LinearConstraints>,
        mut solver: Box<dyn LinearSolver>,
    ) -> Result<Self, SolveError> {
        let pool = build_pool(0)?;
        let assembler = Assembler::new(&dof_map, &terms);
        let mut untouched = assembler.untouched_dofs();
        let condensation = match constraints {
            Some(c) if !c.is_empty() || c.num_dofs() != dof_map.num_dofs() => {
                let condensation = Condensation::new(c, assembler.pattern())?;
                super::reduced::reduce_untouched(condensation.constraints(), &mut untouched);
                Some(condensation)
            }
            _ => None,
        };
        let pattern = super::reduced::solver_pattern(&condensation, &assembler);
        pool.install(|| solver.analyze(pattern))?;
        let n = dof_map.num_dofs();
        let nnz = pattern.nnz();
        let rotation_dofs = dof_map.rotation_dofs();
        Ok(Problem {
            pool,
            dof_map,
            terms,
            assembler,
            solver,
            prescribed: untouched.clone(),
            untouched,
            u: vec![0.0; n],
            f_ext: vec![0.0; n],
            residual: vec![0.0; n],
            energy: 0.0,
            last_factor: None,
            timings: Timings::default(),
            work: Work {
                values: vec![0.0; nnz],
                predictor: vec![0.0; n],
                rhs: vec![0.0; n],
                delta: vec![0.0; n],
                trial: vec![0.0; n],
                du_prescribed: vec![0.0; n],
                residual_trial: vec![0.0; n],
                magnitude_trial: vec![0.0; n],
                energy_trial: 0.0,
                trial_step: None,
                magnitude: vec![0.0; n],
                history: Vec::with_capacity(64),
                scale: 0.0,
                increment_energy: 0.0,
                r_prev: Vec::new(),
                qn_s: Vec::new(),
                qn_y: Vec::new(),
                qn_rho: Vec::new(),
                qn_alpha: Vec::new(),
                updates: 0,
            },
            total_time: 0.0,
            steps_done: 0,
            length_scale: 0.0,
            condensation,
            stabilizer: None,
            relaxation: None,
            drag_epoch: None,
            rotation_dofs,
        })
    }

    /// Nonlinear elimination (see `solve::relax`): after every global Newton update, each
    /// block of global DOFs is moved to its own equilibrium by a local Newton solve with
    /// all other DOFs held. For nearly mechanistic parts held at a few points (a free
    /// filament's interior nodes) this resolves their large swings exactly instead of by
    /// the global linearisation. The equilibrium found is the same; only the path of the
    /// iterations changes. With BFGS the updates then act on the condensed problem (the
    /// blocks' residuals are zero after every update). An empty list
    /// switches it off.
    pub fn set_relaxation_blocks(&mut self, blocks: Vec<Vec<usize>>) {
        let relaxation = Relaxation::new(blocks, &self.terms, &self.dof_map);
        self.relaxation = (relaxation.len() > 0).then_some(relaxation);
    }

    /// What the relaxation blocks did so far (zeros without them).
    pub fn relaxation_stats(&self) -> RelaxationStats {
        self.relaxation
            .as_ref()
            .map(|r| r.stats)
            .unwrap_or_default()
    }

    /// Sets the number of threads for assembly and factorisation: `0` for rayon's default
    /// (`RAYON_NUM_THREADS` when set, else one per logical CPU), `1` for none besides the
    /// pool's own. Builds a new pool; fails only when the system refuses the threads (the
    /// old pool is kept then). A linear solver sizes its workspace for the pool it was
    /// analysed in, so a larger pool set later is used by assembly only.
    pub fn set_threads(&mut self, threads: usize) -> Result<(), SolveError> {
        self.pool = build_pool(threads)?;
        Ok(())
    }

    /// Number of threads of the problem's pool.
    pub fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }

    /// Runs `f` on the problem's thread pool (for callers that assemble or factorise
    /// outside [`Problem::run_step`] and want the same parallelism).
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        self.pool.install(f)
    }

    /// The DOF numbering.
    pub fn dof_map(&self) -> &DofMap {
        &self.dof_map
    }

    /// The terms, in assembly order.
    pub fn terms(&self) -> &[Box<dyn Term>] {
        &self.terms
    }

    /// The assembler (pattern and colouring).
    pub fn assembler(&self) -> &Assembler {
        &self.assembler
    }

    /// Current DOF values (displacements; µm).
    pub fn u(&self) -> &[f64] {
        &self.u
    }

    /// Reaction on DOF `dof` (nN): the force the constraint applies to the body,
    /// `r_int − f_ext`, meaningful for prescribed DOFs at a converged state.
    pub fn reaction(&self, dof: usize) -> f64 {
        self.residual[dof] - self.f_ext[dof]
    }

    /// Sum of the reactions over `dofs`.
    pub fn reaction_sum(&self, dofs: impl IntoIterator<Item = usize>) -> f64 {
        dofs.into_iter().map(|d| self.reaction(d)).sum()
    }

    /// Whether `dof` is prescribed in the current step.
    pub fn is_prescribed(&self, dof: usize) -> bool {
        self.prescribed[dof]
    }

    /// Internal energy at the last converged state (nN·µm).
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// The last numeric factorisation's facts (method, negative pivots).
    pub fn last_factor(&self) -> Option<FactorInfo> {
        self.last_factor
    }

    /// The size of the factor the linear solver planned for this problem's tangent (nonzeros
    /// of L and flops of one factorisation), if the solver reports it.
    pub fn factor_size(&self) -> Option<crate::linsolve::FactorSize> {
        self.solver.factor_size()
    }

    /// Time spent assembling, factorising and solving so far.
    pub fn timings(&self) -> Timings {
        Timings {
            relaxation: self.relaxation_stats(),
            mixed_precision: self.solver.mixed_precision_stats().unwrap_or_default(),
            ..self.timings
        }
    }

    /// Total pseudo-time reached.
    pub fn total_time(&self) -> f64 {
        self.total_time
    }

    /// Runs one analysis step from its start (pseudo-time 0) to its end (1) with automatic
    /// increment control. Every converged increment is reported to `observer` before the next
    /// starts, so a failure keeps everything converged so far.
    pub fn run_step(&mut self, step: &Step, observer: &mut dyn Observer) -> Result<(), SolveError> {
        self.check_step(step)?;
        let n = self.u.len();
        let step_index = self.steps_done;
        observer.on_step_start(step_index, &step.name);
        self.prescribed.copy_from_slice(&self.untouched);
        let u_start = self.u.clone();
        let mut u_end = self.u.clone();
        for &(dof, motion) in &step.prescribed {
            self.prescribed[dof] = true;
            u_end[dof] = match motion {
                Motion::Hold => u_start[dof],
                Motion::To(v) => v,
                Motion::By(dv) => u_start[dof] + dv,
            };
        }
        let f_start = self.f_ext.clone();
        let mut f_end = self.f_ext.clone();
        for load in &step.loads {
            f_end[load.dof] = load.value;
        }
        let control = &step.control;
        // A new stabiliser counts its epochs from 0 again: switch the old drag off first.
        self.stabilizer = None;
        self.sync_drag();
        self.stabilizer = control.stabilization.map(|mut s| {
            // Relative damping needs terms with relative motions (tied filaments); a model
            // without any (every tied family switched off) gets the nodal viscosity.
            if s.damping == Damping::Relative {
                let dof_map = &self.dof_map;
                let any = self
                    .terms
                    .iter_mut()
                    .fold(false, |any, t| t.set_drag(None, dof_map) || any);
                if !any {
                    s.damping = Damping::Nodal;
                }
            }
            Stabilizer::new(s, n)
        });
        let mut time = 0.0;
        let mut dt = control.initial_increment.min(control.max_increment);
        let mut increments = 0;
        let mut target_u = vec![0.0; n];
        let mut target_f = vec![0.0; n];
        // The step's last converged increment of displacement and its size, for the
        // extrapolated start of the next.
        let mut last_increment: Option<(Vec<f64>, f64)> = None;
        // The energy criterion's reference of the step's last converged increment and its
        // size. The reference is the work of an increment's first correction; from an
        // extrapolated start that correction is only the extrapolation's error, so the
        // criterion would ask for the last digits of a near-solution (the tension's stretch
        // spent a chord step per increment on them, with the residual already 1e-9 of the
        // force scale). An extrapolated increment's reference is at least the last one's,
        // scaled by the square of the ratio of the increments (a converged start's first
        // correction and residual both grow with the increment).
        let mut last_energy: Option<(f64, f64)> = None;
        // A failed attempt is retried from the converged state: the extrapolation may be
        // what made it fail. The next converged increment extrapolates again.
        let mut extrapolate = true;
        // A quasi-Newton step retries a failed increment with full Newton (a fresh tangent at
        // every iteration is what a hard increment needs); the next increment after a
        // converged one returns to the step's method.
        let newton_control = StepControl {
            convergence: Convergence {
                method: IterationMethod::Newton,
                ..control.convergence
            },
            ..*control
        };
        let mut full_newton = false;
        // Stop condition: g = monitor - target at the last committed state, and a trial time
        // known to lie beyond the crossing.
        let gap = |p: &Problem| {
            step.stop
                .as_ref()
                .and_then(|s| p.monitor(&s.monitor).map(|v| v - s.target))
        };
        // Terms see the new step before anything is monitored (e.g. a tool's direction of
        // motion in this step).
        let step_start = LoadState {
            step_index,
            step_time: 0.0,
        };
        for term in &mut self.terms {
            term.set_load_state(&step_start);
        }
        // The monitor at a trial (`g`, from `g0` at the last committed state) crossed the
        // target beyond its tolerance: the trial overshot (at most 60 times per step).
        let overshot = |g: Option<f64>, g0: f64, overshoots: usize| {
            let (stop, g) = (step.stop.as_ref()?, g?);
            (g.abs() > stop.tolerance && g.signum() != g0.signum() && overshoots < 60).then_some(g)
        };
        let mut g_prev = gap(self);
        let mut beyond: Option<(f64, f64)> = None;
        let mut overshoots = 0;
        // Accepted increments in a row that stayed short of the crossing (the end beyond it
        // kept): after two, the next aim is the bracket's middle, not the regula falsi's.
        let mut kept = 0;
        // Set when the bracket around the crossing is narrower than JUMP_WIDTH and the
        // monitor is still not within tolerance: it jumps across the target there (a contact
        // force as the next node touches), and the step ends at the first converged state
        // beyond the jump.
        let mut across_jump = false;
        let mut ended_in_jump = false;
        let reached = |g: Option<f64>| match (&step.stop, g) {
            (Some(s), Some(g)) => g.abs() <= s.tolerance,
            _ => false,
        };
        while time < 1.0 && !reached(g_prev) && !ended_in_jump {
            let rest = 1.0 - time;
            // (`extrapolate` is false exactly while the last attempt failed: this one is
            // its shorter retry.)
            let stretch = extrapolate
                && beyond.is_none()
                && rest <= control.growth * dt
                && rest <= control.max_increment;
            if time + dt > 1.0 - 1e-12 || stretch {
                // The step's end, or within one growth of the increment from it: reached
                // now rather than after a sliver of an increment that costs as many
                // iterations as a full one (the default compression's prestress: 0.375
                // then 0.125 became 0.5). Not right after a cut-back (its retry stays
                // short) nor when aiming at a monitor's crossing.
                dt = rest;
            }
            let t = time + dt;
            for d in 0..n {
                target_u[d] = if self.prescribed[d] {
                    u_start[d] + t * (u_end[d] - u_start[d])
                } else {
                    0.0
                };
                target_f[d] = f_start[d] + t * (f_end[d] - f_start[d]);
            }
            let saved_u = self.u.clone();
            let saved_f = self.f_ext.clone();
            let load_state = LoadState {
                step_index,
                step_time: t,
            };
            for term in &mut self.terms {
                term.set_load_state(&load_state);
            }
            let known = step.stop.as_ref().is_some_and(|s| s.known_before_solving);
            if let (true, Some(g0), false) = (known, g_prev, across_jump) {
                // A monitor known before solving: an overshooting trial is rejected without
                // a Newton solve of it, and the next aims at the crossing.
                if let Some(g) = overshot(gap(self), g0, overshoots) {
                    overshoots += 1;
                    kept = 0;
                    beyond = Some((t, g));
                    dt = regula_falsi(t - time, g0, g);
                    continue;
                }
            }
            if let Some(st) = &mut self.stabilizer {
                st.start_increment(&saved_u, t - time);
            }
            let mut energy_floor = 0.0;
            let guessed = if let Some(guess) = &step.guess {
                guess.write_at(t, &self.prescribed, &mut self.u);
                true
            } else if let (Extrapolation::Linear, true, Some((du, dt_last))) =
                (control.extrapolation, extrapolate, &last_increment)
            {
                // Prescribed DOFs go to their targets with the rest (the predictor then
                // has nothing left to move): a state whose free and prescribed parts were
                // moved apart would strain the elements between them.
                let ratio = dt / dt_last;
                for d in 0..n {
                    self.u[d] = if self.prescribed[d] {
                        target_u[d]
                    } else {
                        self.u[d] + ratio * du[d]
                    };
                }
                if let Some((energy, dt_energy)) = last_energy {
                    energy_floor = energy * (dt / dt_energy).powi(2);
                }
                true
            } else {
                false
            };
            if guessed {
                if let Some(c) = &self.condensation {
                    // Tied DOFs follow their masters exactly, whatever the guess says.
                    c.constraints().enforce(&mut self.u);
                }
            }
            for term in &mut self.terms {
                term.predict(&self.u, &self.dof_map);
            }
            let attempt = if full_newton {
                &newton_control
            } else {
                control
            };
            let outcome = self.newton_increment(
                &target_u,
                &target_f,
                guessed,
                energy_floor,
                attempt,
                observer,
            );
            if let (Ok(_), Some(g0), false) = (&outcome, g_prev, across_jump) {
                if let Some(g) = overshot(gap(self), g0, overshoots) {
                    // Overshot the target: reject, and aim at the crossing.
                    overshoots += 1;
                    kept = 0;
                    for term in &mut self.terms {
                        term.rollback();
                    }
                    self.u = saved_u;
                    self.f_ext = saved_f;
                    beyond = Some((t, g));
                    dt = regula_falsi(t - time, g0, g);
                    continue;
                }
            }
            let increment_energy = self.work.increment_energy;
            match outcome {
                Ok(mut iterations) => {
                    let final_increment = t >= 1.0 - 1e-12;
                    // The end's re-solve without viscosity, and the relaxation towards it,
                    // take full Newton, as a failed quasi-Newton increment's retry does: the
                    // damped state is close, but the undamped problem there is the hardest
                    // of the step.
                    let stabilization = self.finish_stabilized_increment(
                        final_increment,
                        &target_u,
                        &target_f,
                        if final_increment {
                            &newton_control
                        } else {
                            attempt
                        },
                        observer,
                        &mut iterations,
                    );
                    full_newton = false;
                    if let (true, Some(st), Some(settings)) =
                        (final_increment, stabilization, control.stabilization)
                    {
                        if !st.equilibrated
                            && st.viscous_force_ratio > settings.max_end_viscous_force
                        {
                            // Back to the last equilibrium, which is what was reported.
                            for term in &mut self.terms {
                                term.rollback();
                            }
                            self.u = saved_u;
                            self.stabilizer = None;
                            return Err(SolveError::NotEquilibrated {
                                step: step.name.clone(),
                                viscous_force_ratio: st.viscous_force_ratio,
                                max: settings.max_end_viscous_force,
                            });
                        }
                    }
                    for term in &mut self.terms {
                        term.commit(&self.u, &self.dof_map);
                    }
                    extrapolate = true;
                    last_energy = Some((increment_energy, t - time));
                    if control.extrapolation == Extrapolation::Linear {
                        let (du, dt_last) =
                            last_increment.get_or_insert_with(|| (vec![0.0; n], 0.0));
                        for d in 0..n {
                            du[d] = self.u[d] - saved_u[d];
                        }
                        *dt_last = t - time;
                    }
                    time = t;
                    increments += 1;
                    let report = IncrementReport {
                        step_index,
                        step_name: &step.name,
                        increment: increments,
                        step_time: time,
                        total_time: self.total_time + time * step.duration,
                        iterations,
                        residual_history: &self.work.history,
                        energy: self.energy,
                        stabilization,
                    };
                    observer.on_increment(self, &report);
                    if iterations <= attempt.easy_iterations_of_method() {
                        dt = (dt * control.growth).min(control.max_increment);
                    }
                    let g_before = g_prev;
                    g_prev = gap(self);
                    if let (Some((t_beyond, g_beyond)), Some(g)) = (beyond, g_prev) {
                        let crossed = g_before.is_some_and(|g0| g0.signum() != g.signum());
                        if across_jump && (crossed || time >= t_beyond) {
                            ended_in_jump = !reached(g_prev);
                        } else if !reached(g_prev) && t_beyond - time <= JUMP_WIDTH {
                            // One last increment, to the converged side beyond the jump.
                            across_jump = true;
                            dt = t_beyond - time;
                        } else if kept >= 2 {
                            // The regula falsi keeps creeping from one side (a monitor that
                            // is flat, or a step function of the time): halve the bracket.
                            kept += 1;
                            dt = 0.5 * (t_beyond - time);
                        } else if g != g_beyond {
                            kept += 1;
                            dt = (t_beyond - time) * (g / (g - g_beyond)).clamp(0.02, 1.0);
                        }
                    }
                }
                Err(reason) => {
                    for term in &mut self.terms {
                        term.rollback();
                    }
                    self.u = saved_u;
                    self.f_ext = saved_f;
                    observer.on_cutback(time, dt, &reason);
                    extrapolate = false;
                    full_newton = control.convergence.method != IterationMethod::Newton;
                    dt *= control.cutback;
                    if let Some(st) = &mut self.stabilizer {
                        st.boost();
                    }
                    if dt < control.min_increment {
                        return Err(SolveError::IncrementTooSmall {
                            step: step.name.clone(),
                            time,
                            increment: dt,
                            min_increment: control.min_increment,
                            reason,
                        });
                    }
                }
            }
        }
        if let (Some(stop), Some(g), false) = (&step.stop, g_prev, ended_in_jump) {
            if g.abs() > stop.tolerance {
                return Err(SolveError::TargetNotReached {
                    step: step.name.clone(),
                    monitor: format!("{:?}", stop.monitor),
                    target: stop.target,
                    last: g + stop.target,
                });
            }
        }
        self.total_time += step.duration;
        self.steps_done += 1;
        self.stabilizer = None;
        Ok(())
    }

    /// Energy the viscosity dissipated since the increment's start and the norm of its
    /// forces at the current state (nodal viscosity and the terms' drag, on the free DOFs);
    /// `None` without stabilisation.
    fn viscous_dissipation_and_force(&self) -> Option<(f64, f64)> {
        let st = self.stabilizer.as_ref()?;
        let mut dissipated = st.dissipation(&self.u);
        let mut force = st.force_norm(&self.u);
        if self.drag_epoch.is_some() {
            // Once per increment: the allocation does not matter.
            let mut forces = vec![0.0; self.u.len()];
            for term in &self.terms {
                dissipated += term.add_drag_forces(&self.u, &self.dof_map, &mut forces);
            }
            let drag = norm_where(&forces, &self.prescribed, false);
            force = (force * force + drag * drag).sqrt();
        }
        Some((dissipated, force))
    }

    /// Sets the terms' drag ([`crate::term::Term::set_drag`]) from the stabiliser when its
    /// rate or start state changed since the last call, and switches it off when the
    /// stabiliser is gone, off, or nodal.
    pub(super) fn sync_drag(&mut self) {
        let wanted = self
            .stabilizer
            .as_ref()
            .filter(|st| !st.nodal() && st.rate != 0.0)
            .map(|st| st.epoch);
        if wanted == self.drag_epoch {
            return;
        }
        let (terms, dof_map) = (&mut self.terms, &self.dof_map);
        match (&self.stabilizer, wanted) {
            (Some(st), Some(_)) => {
                let drag = crate::term::Drag {
                    rate: st.rate,
                    u_start: &st.u_start,
                    weight: &st.weight,
                };
                for term in terms.iter_mut() {
                    term.set_drag(Some(&drag), dof_map);
                }
            }
            _ => {
                for term in terms.iter_mut() {
                    term.set_drag(None, dof_map);
                }
            }
        }
        self.drag_epoch = wanted;
    }

    /// After a stabilised increment converged: books its dissipated energy and, at the end
    /// of the step, re-solves without viscosity so the final state is an equilibrium (the
    /// damped state is kept when that fails). `None` without stabilisation.
    fn finish_stabilized_increment(
        &mut self,
        final_increment: bool,
        target_u: &[f64],
        target_f: &[f64],
        control: &StepControl,
        observer: &mut dyn Observer,
        iterations: &mut usize,
    ) -> Option<StabilizationReport> {
        let (mut increment, force) = self.viscous_dissipation_and_force()?;
        let st = self.stabilizer.as_ref()?;
        let scale = self.work.scale;
        let ratio = |force: f64| if scale > 0.0 { force / scale } else { 0.0 };
        let mut viscous_force_ratio = ratio(force);
        let rate = st.rate;
        let relaxations = st.settings.end_relaxation_increments;
        let mut equilibrated = rate == 0.0;
        let tolerance = control.convergence.residual_tolerance;
        if final_increment && st.settings.equilibrate_at_end && viscous_force_ratio > tolerance {
            if self.resolve_without_viscosity(target_u, target_f, control, observer, iterations) {
                equilibrated = true;
                viscous_force_ratio = 0.0;
            } else if relaxations > 0 {
                let relaxed = self.relax_at_final_load(
                    target_u,
                    target_f,
                    control,
                    observer,
                    iterations,
                    (rate, viscous_force_ratio, relaxations),
                );
                increment += relaxed.dissipated;
                equilibrated = relaxed.equilibrated;
                viscous_force_ratio = relaxed.viscous_force_ratio;
            }
        }
        let energy = self.energy;
        let st = self.stabilizer.as_mut()?;
        let factor = if st.active {
            st.factor.unwrap_or(0.0)
        } else {
            0.0
        };
        let easy = *iterations <= control.easy_iterations;
        let dissipated_fraction = st.commit(increment, energy, easy);
        Some(StabilizationReport {
            factor,
            increment_dissipated: increment,
            step_dissipated: st.dissipated,
            dissipated_fraction,
            viscous_force_ratio,
            equilibrated,
        })
    }

    /// Re-solves the current increment without viscosity, from the damped state. On failure
    /// the damped state (DOFs, terms' trial state, viscosity) is restored and `false`
    /// returned.
    fn resolve_without_viscosity(
        &mut self,
        target_u: &[f64],
        target_f: &[f64],
        control: &StepControl,
        observer: &mut dyn Observer,
        iterations: &mut usize,
    ) -> bool {
        let damped_u = self.u.clone();
        // The re-solve may augment (contact multipliers, active sets): keep the damped
        // state's terms so that a failed re-solve returns to exactly that state.
        for term in &mut self.terms {
            term.save_trial();
        }
        let rate = self.stabilizer.as_ref().map_or(0.0, |st| st.rate);
        if let Some(st) = &mut self.stabilizer {
            st.set_rate(0.0);
        }
        // Not `start_moved`: the damped state has every relaxation block in (damped)
        // equilibrium already, and re-equilibrating them without viscosity before the first
        // global step lets an unstable block (a held MT at its buckling load) jump to a far
        // equilibrium of its own: measured on the suspended-cell compression with MTs on an
        // elastic foundation, the re-solve then started at 0.12-0.44 of the force scale
        // instead of the viscous forces' 1e-5 and diverged (docs/stabilization.md).
        match self.newton_increment(target_u, target_f, false, 0.0, control, observer) {
            Ok(more) => {
                *iterations += more;
                true
            }
            Err(_) => {
                self.u = damped_u;
                for term in &mut self.terms {
                    term.restore_trial();
                }
                if let Some(st) = &mut self.stabilizer {
                    st.set_rate(rate);
                }
                // The state was assembled there before: this cannot fail.
                let _ = self.assemble_full(false);
                false
            }
        }
    }

    /// Pseudo-transient continuation at the step's final load (Kelley & Keyes 1998): when
    /// the re-solve without viscosity fails at the end of a stabilised step, the damped
    /// state flows on at fixed load, one implicit viscous increment at a time from the
    /// state the last one reached. The viscosity `c/Δt` starts at the last increment's
    /// (`start.0`) and shrinks with the out-of-balance force (by the ratio of the last two
    /// viscous-force norms, between 1/10 and 1/2 per increment; tenfold back up after a
    /// failed one), so the flow goes down the energy towards a stable equilibrium and turns
    /// into Newton's method as it gets there. Once the viscous force is within ten times
    /// the residual tolerance the re-solve without viscosity is tried again. At most
    /// `start.2` increments; the state reached is kept either way, with its own viscous
    /// force reported, and the caller's check of that force stands.
    fn relax_at_final_load(
        &mut self,
        target_u: &[f64],
        target_f: &[f64],
        control: &StepControl,
        observer: &mut dyn Observer,
        iterations: &mut usize,
        start: (f64, f64, usize),
    ) -> FinalRelaxation {
        let (mut rate, mut last_ratio, most) = start;
        let tolerance = control.convergence.residual_tolerance;
        let mut dissipated = 0.0;
        for _ in 0..most {
            let from = self.u.clone();
            for term in &mut self.terms {
                term.save_trial();
            }
            if let Some(st) = &mut self.stabilizer {
                st.restart_from(&self.u, rate);
            }
            match self.newton_increment(target_u, target_f, false, 0.0, control, observer) {
                Ok(more) => {
                    *iterations += more;
                    let Some((increment, force)) = self.viscous_dissipation_and_force() else {
                        break;
                    };
                    dissipated += increment;
                    let scale = self.work.scale;
                    let now = if scale > 0.0 { force / scale } else { 0.0 };
                    let shrink = if last_ratio > 0.0 {
                        (now / last_ratio).clamp(RELAX_SHRINK_MOST, RELAX_SHRINK_LEAST)
                    } else {
                        RELAX_SHRINK_MOST
                    };
                    rate *= shrink;
                    last_ratio = now;
                    if now <= tolerance {
                        let equilibrated = self.resolve_without_viscosity(
                            target_u, target_f, control, observer, iterations,
                        );
                        return FinalRelaxation {
                            dissipated,
                            viscous_force_ratio: if equilibrated { 0.0 } else { now },
                            equilibrated,
                        };
                    }
                    if now <= RELAX_RESOLVE_FACTOR * tolerance
                        && self.resolve_without_viscosity(
                            target_u, target_f, control, observer, iterations,
                        )
                    {
                        return FinalRelaxation {
                            dissipated,
                            viscous_force_ratio: 0.0,
                            equilibrated: true,
                        };
                    }
                }
                Err(_) => {
                    self.u = from;
                    for term in &mut self.terms {
                        term.restore_trial();
                    }
                    rate *= RELAX_BACK_OFF;
                    let _ = self.assemble_full(false);
                }
            }
        }
        FinalRelaxation {
            dissipated,
            viscous_force_ratio: last_ratio,
            equilibrated: false,
        }
    }

    /// Value of a monitored quantity at the current state (`None` if a named term output
    /// does not exist).
    pub fn monitor(&self, monitor: &Monitor) -> Option<f64> {
        match monitor {
            Monitor::ReactionSum(dofs) => Some(self.reaction_sum(dofs.iter().copied())),
            Monitor::TermScalar(name) => self.terms.iter().find_map(|t| {
                t.scalar_outputs(&self.u, &self.dof_map)
                    .into_iter()
                    .find(|(n, _)| n == name)
                    .map(|(_, v)| v)
            }),
        }
    }

    fn check_step(&self, step: &Step) -> Result<(), SolveError> {
        let n = self.u.len();
        let invalid = |message: String| SolveError::InvalidStep {
            step: step.name.clone(),
            message,
        };
        if !(step.duration > 0.0) {
            return Err(invalid(format!(
                "duration must be > 0, found {}",
                step.duration
            )));
        }
        let c: &StepControl = &step.control;
        if !(c.min_increment > 0.0
            && c.min_increment <= c.initial_increment
            && c.initial_increment <= 1.0)
        {
            return Err(invalid(format!(
                "increments must satisfy 0 < min ({}) <= initial ({}) <= 1",
                c.min_increment, c.initial_increment
            )));
        }
        if let Some(&(dof, _)) = step.prescribed.iter().find(|(d, _)| *d >= n) {
            return Err(invalid(format!(
                "prescribed DOF {dof} does not exist ({n} DOFs)"
            )));
        }
        if let Some(g) = &step.guess {
            let times_ok = g.times.len() == g.values.len()
                && g.times.windows(2).all(|w| w[0] < w[1])
                && g.times.iter().all(|t| t.is_finite());
            if !times_ok
                || g.values
                    .iter()
                    .any(|v| v.len() != n || v.iter().any(|x| !x.is_finite()))
            {
                return Err(invalid(format!(
                    "the guess path needs increasing finite knot times, one per state, and {n} \
                     finite values per state"
                )));
            }
        }
        if let Some(stop) = &step.stop {
            if self.monitor(&stop.monitor).is_none() {
                return Err(invalid(format!(
                    "no quantity {:?} to monitor",
                    stop.monitor
                )));
            }
            if !(stop.tolerance > 0.0) {
                return Err(invalid(format!(
                    "the stop tolerance must be > 0, found {}",
                    stop.tolerance
                )));
            }
        }
        if let Some(load) = step.loads.iter().find(|l| l.dof >= n) {
            return Err(invalid(format!(
                "loaded DOF {} does not exist ({n} DOFs)",
                load.dof
            )));
        }
        self.check_step_constraints(step).map_err(invalid)?;
        if let Some(s) = &c.stabilization {
            s.validate().map_err(invalid)?;
        }
        Ok(())
    }
}

/// The problem's thread pool: `threads` threads (0: rayon's default).
/// The increment that reaches the crossing of a monitor that went from `g0` to `g` over
/// `span` of step time, if it is linear (regula falsi), kept within 2–98 % of the span.
fn regula_falsi(span: f64, g0: f64, g: f64) -> f64 {
    span * (g0 / (g0 - g)).clamp(0.02, 0.98)
}

fn build_pool(threads: usize) -> Result<rayon::ThreadPool, SolveError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("cellmech-{i}"))
        .build()
        .map_err(|e| SolveError::Threads(e.to_string()))
}
