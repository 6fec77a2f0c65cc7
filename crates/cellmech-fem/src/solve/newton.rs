//! One load increment solved by full Newton–Raphson with a line search.
//!
//! Iteration 0 linearises at the converged start state and applies the whole prescribed
//! increment through `K_fp·Δu_p` (a consistent predictor: no element is distorted by moving
//! boundary nodes alone). Later iterations solve `K δ = f_ext − r_int` on the free DOFs with
//! the prescribed DOFs fixed, then search along δ when the residual's projection on δ has
//! not dropped enough. Convergence needs both the residual and the energy criterion.

use super::control::{
    Convergence, IterationMethod, StepControl, CHORD_CONTINUATION, CHORD_CONTRACTION, CHORD_WINDOW,
    NEAR_EQUILIBRIUM, QUASI_NEWTON_SOLVE_TOLERANCE,
};
use super::error::FailureReason;
use super::norms::norm_where;
use super::problem::{Observer, Problem};
use super::reduced::solver_pattern;
use super::report::IterationReport;
use std::time::Instant;

use crate::assembly::AssemblyOutput;
use crate::term::Augmentation;

/// Largest quasi-Newton correction as a multiple of the previous step before the tangent
/// is reformed.
const MAX_QUASI_NEWTON_GROWTH: f64 = 10.0;
/// Largest `s·r_prev / s·y` of an accepted BFGS update (the square of FEBio's bound on the
/// update's condition number, 1e5).
const MAX_UPDATE_CONDITION: f64 = 1e10;

/// A residual this small relative to the force scale is round-off: converged.
const ROUND_OFF: f64 = 1e-13;
/// A correction this small relative to the model size (`Problem::set_length_scale`) is
/// round-off of the coordinates: converged.
pub(super) const COORDINATE_ROUND_OFF: f64 = 1e-13;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn dot_free(a: &[f64], b: &[f64], prescribed: &[bool]) -> f64 {
    a.iter()
        .zip(b)
        .zip(prescribed)
        .filter(|(_, &p)| !p)
        .map(|((x, y), _)| x * y)
        .sum()
}

impl Problem {
    /// Tells every term whether Newton is near equilibrium ([`crate::term::Term::set_near_equilibrium`]).
    fn set_near_equilibrium(&mut self, near: bool) {
        for term in &mut self.terms {
            term.set_near_equilibrium(near);
        }
    }

    /// Solves the increment to the prescribed values `target_u` (prescribed DOFs) and loads
    /// `target_f`. On success `self.u`, `self.residual` and `self.energy` hold the converged
    /// state and the iteration count is returned; on failure the state is garbage and the
    /// caller restores it. `start_moved`: Newton starts away from the last converged state
    /// (an extrapolation, a guess path, or a state reached with viscous forces), so the
    /// relaxation blocks are re-equilibrated there first; at a converged state they already
    /// are. `energy_floor`: the least reference of the energy criterion (0: the work of the
    /// first correction alone), left in `work.increment_energy` with the reference used.
    pub(super) fn newton_increment(
        &mut self,
        target_u: &[f64],
        target_f: &[f64],
        start_moved: bool,
        energy_floor: f64,
        control: &StepControl,
        observer: &mut dyn Observer,
    ) -> Result<usize, FailureReason> {
        let conv = &control.convergence;
        let n = self.u.len();
        self.f_ext.copy_from_slice(target_f);
        self.work.history.clear();
        for d in 0..n {
            self.work.du_prescribed[d] = if self.prescribed[d] {
                target_u[d] - self.u[d]
            } else {
                0.0
            };
        }
        let relaxing = self.relaxation.is_some() && conv.relaxation;
        if relaxing && start_moved {
            let tolerance = conv.residual_tolerance * self.work.scale;
            self.relax_blocks(tolerance);
        }
        // Factorisations counted at the last report: a report whose count moved describes a
        // correction solved with a fresh factorisation.
        let mut factorizations_reported = self.timings.factorizations;
        let quasi_newton = match conv.method {
            IterationMethod::Newton => 0,
            IterationMethod::Bfgs { max_updates } => max_updates,
        };
        // How accurately a fresh factorisation's correction is solved: in full for Newton,
        // to the quasi-Newton's own accuracy for BFGS.
        let direction_tolerance = if quasi_newton > 0 {
            QUASI_NEWTON_SOLVE_TOLERANCE
        } else {
            0.0
        };
        // Iteration 0: linearise at the converged start state.
        self.assemble_full(true)?;
        self.set_first_rhs();
        let r0 = norm_where(&self.work.rhs, &self.prescribed, false);
        let mut scale_floor = r0.max(norm_where(&self.f_ext, &self.prescribed, false));
        match self.stabilizer_needs_calibration() {
            Some(true) => self.calibrate_stabilizer()?,
            Some(false) => {
                // Waiting for difficulty: calibrate on the real, undamped predictor.
                self.factorize_and_solve(direction_tolerance)?;
                let energy = self.correction_work();
                if let Some(st) = &mut self.stabilizer {
                    st.calibrate(Some(&self.work.delta), energy);
                    st.set_rate(0.0);
                }
            }
            None => self.factorize_and_solve(direction_tolerance)?,
        }
        // The energy criterion's reference: the work of the increment's first correction, or
        // of a later round's first correction (after the terms changed) when that is larger.
        // A good start (an extrapolated one) leaves the first correction tiny, and a contact
        // status change later in the increment then moves the body by far more: measured
        // against the tiny start, the round's energy ratio had to fall 12 orders below its
        // own first correction's, long after the residual criterion was met.
        // `energy_floor` (0: none) is the driver's estimate of the first correction's work
        // from the converged start, for a start extrapolated close to the solution.
        let mut energy_reference = self.correction_work().max(energy_floor);
        self.work.increment_energy = energy_reference;
        // Quasi-Newton state: the residual before the last step, its norm, and whether the
        // tangent must be reformed at the next iteration.
        self.work.updates = 0;
        if quasi_newton > 0 {
            self.work.r_prev.resize(n, 0.0);
            for d in 0..n {
                self.work.r_prev[d] = if self.prescribed[d] {
                    0.0
                } else {
                    self.work.rhs[d]
                };
            }
        }
        let mut previous_norm = f64::INFINITY;
        let mut reform = false;
        let mut step_length = 1.0;
        let mut augmentations = 0;
        let mut round_start = 0;
        // The lowest residual (force units) of the current round.
        let mut round_best = f64::INFINITY;
        // Whether the last correction was a chord step (full Newton near convergence), and
        // the residual ratio before it.
        let mut chord = false;
        let mut previous_ratio = f64::INFINITY;
        // Whether the last augmentation changed only multipliers (the tangent is the one
        // factorised near convergence: a chord step may follow it at once).
        let mut same_tangent = false;
        // Whether this round has let the terms augment before converging
        // ([`Convergence::early_augmentation`]).
        let mut early_checked = false;
        for iteration in 0.. {
            // Update and evaluate at the new point (tangent included for the next solve).
            let tolerance = conv.residual_tolerance * scale_floor.max(self.work.scale);
            if iteration == 0 {
                // The rotations' trust region bounds the first correction too when it moves
                // no prescribed DOF (an extrapolated or re-solved start, a rigid tool's
                // motion): shortening it then leaves no prescribed DOF short of its target.
                // From an extrapolated start past a filament's snap-through, or at the
                // re-solve without viscosity, the unbounded correction turned held MT
                // nodes by radians (docs/performance.md, "The first correction too").
                if conv.max_rotation_step > 0.0 && self.work.du_prescribed.iter().all(|&x| x == 0.0)
                {
                    step_length = self.rotation_step_limit(conv.max_rotation_step);
                }
                for d in 0..n {
                    self.u[d] += step_length * self.work.delta[d];
                }
                self.set_near_equilibrium(false);
                if relaxing {
                    self.relax_blocks(tolerance);
                }
                self.evaluate(quasi_newton == 0)?;
            } else {
                step_length =
                    self.line_search(conv, quasi_newton == 0, relaxing.then_some(tolerance))?;
            }
            let (residual_ratio, energy_ratio, scale) =
                self.measure(&mut scale_floor, step_length, energy_reference);
            self.work.scale = scale;
            if iteration == 0 && scale > 0.0 {
                // What the first correction contracted: the start's residual.
                previous_ratio = r0 / scale;
            }
            // The next evaluation's tangent: exact where the terms lag it far from
            // equilibrium, once the residual says the state is close.
            self.set_near_equilibrium(residual_ratio <= NEAR_EQUILIBRIUM);
            let report = IterationReport {
                iteration,
                residual_ratio,
                energy_ratio,
                force_scale: scale,
                line_search: step_length,
                correction_norm: self.work.delta.iter().map(|x| x * x).sum::<f64>().sqrt(),
                chord,
                reformed: self.timings.factorizations > factorizations_reported,
            };
            factorizations_reported = self.timings.factorizations;
            self.work.history.push(residual_ratio);
            observer.on_iteration(&report);
            if !residual_ratio.is_finite() {
                return Err(FailureReason::NotFinite { iteration });
            }
            // At round-off level the energy ratio carries no information (e.g. a step that
            // starts in equilibrium), so the residual alone decides there.
            let correction =
                step_length * self.work.delta.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let converged = scale == 0.0
                || residual_ratio <= ROUND_OFF
                || correction <= COORDINATE_ROUND_OFF * self.length_scale
                || (residual_ratio <= conv.residual_tolerance
                    && energy_ratio <= conv.energy_tolerance);
            let residual_force = residual_ratio * scale;
            let rebounded = conv.rebound_ratio > 0.0
                && residual_force > r0
                && residual_force > conv.rebound_ratio * round_best;
            round_best = round_best.min(residual_force);
            let augmented = if converged {
                match self.augment_terms() {
                    None => return Ok(iteration + 1),
                    some => some,
                }
            } else if r0 > 0.0 && residual_ratio * scale > conv.divergence_ratio * r0 {
                return Err(FailureReason::Diverged {
                    iteration,
                    ratio: residual_ratio * scale / r0,
                });
            } else if rebounded {
                return Err(FailureReason::Rebounded {
                    iteration,
                    ratio: residual_force / round_best,
                });
            } else if iteration - round_start >= conv.max_iterations {
                return Err(FailureReason::MaxIterations {
                    iterations: iteration + 1,
                    residual: residual_ratio,
                    energy: energy_ratio,
                });
            } else if !early_checked && residual_ratio <= conv.early_augmentation {
                // Near enough to equilibrium that the terms' status and multipliers are
                // what they will be at it: update them now rather than after the round's
                // last digits, which an update would throw away.
                early_checked = true;
                self.augment_terms()
            } else {
                None
            };
            if let Some((message, multipliers_only)) = augmented {
                same_tangent = multipliers_only;
                augmentations += 1;
                self.timings.augmentations += 1;
                if augmentations > conv.max_augmentations {
                    return Err(FailureReason::Unsettled(format!(
                        "{augmentations} augmentations without settling: {message}"
                    )));
                }
                // The terms changed: re-evaluate here and continue Newton.
                self.set_near_equilibrium(false);
                if relaxing {
                    self.relax_blocks(conv.residual_tolerance * scale);
                }
                self.evaluate(quasi_newton == 0)?;
                round_start = iteration;
                round_best = f64::INFINITY;
                early_checked = false;
                // Quasi-Newton keeps its factorisation and updates when only
                // multipliers changed (the tangent did not).
                reform = reform || !multipliers_only;
            }
            for d in 0..n {
                self.work.rhs[d] = if self.prescribed[d] {
                    0.0
                } else {
                    self.f_ext[d] - self.residual[d]
                };
            }
            if quasi_newton == 0 {
                // The residual a round starts from: the last one measured, or, right after
                // the terms changed, the one they changed it to.
                let before = if augmentations > 0 && iteration == round_start {
                    norm_where(&self.work.rhs, &self.prescribed, false) / scale
                } else {
                    residual_ratio
                };
                chord = if augmentations > 0 && iteration == round_start {
                    // Right after an augmentation that kept the active set, at the state
                    // Newton converged to with its last factorisation: the same tangent,
                    // whatever the multipliers' change did to the residual.
                    same_tangent && conv.chord_near_convergence
                } else {
                    self.chord_step_pays(
                        conv,
                        iteration,
                        round_start,
                        step_length,
                        chord,
                        previous_ratio,
                    )
                };
                previous_ratio = before;
                if chord {
                    // The last factorisation, no update pairs: a chord step.
                    self.work.updates = 0;
                    self.quasi_newton_direction()?;
                    self.timings.chord_steps += 1;
                } else {
                    self.factorize_and_solve(direction_tolerance)?;
                }
                if augmentations > 0 && iteration == round_start {
                    energy_reference = energy_reference.max(self.correction_work());
                }
                continue;
            }
            // Quasi-Newton: book the last step as an update, then reuse the factorisation
            // unless the updates ran out, the residual grew or curvature was lost.
            let residual_norm = norm_where(&self.work.rhs, &self.prescribed, false);
            // Right after a multiplier-only augmentation the residual jumped without a step:
            // nothing to book, and its growth is no sign of lost curvature.
            let jumped = augmentations > 0 && iteration == round_start && !reform;
            let curvature = jumped || self.book_update(step_length);
            if reform
                || !curvature
                || self.work.updates >= quasi_newton
                || (!jumped && residual_norm > previous_norm)
            {
                self.assemble_full(false)?;
                self.factorize_and_solve(direction_tolerance)?;
                self.work.updates = 0;
                reform = false;
            } else {
                // A quasi-Newton correction far longer than the last step means the updates
                // have lost the tangent (floppy modes): reform instead. (Not after a
                // multiplier jump: the last step was the converging round's last, tiny one.)
                let last_step =
                    step_length * self.work.delta.iter().map(|x| x * x).sum::<f64>().sqrt();
                self.quasi_newton_direction()?;
                let length = self.work.delta.iter().map(|x| x * x).sum::<f64>().sqrt();
                if !jumped && !(length <= MAX_QUASI_NEWTON_GROWTH * last_step) {
                    self.assemble_full(false)?;
                    self.factorize_and_solve(direction_tolerance)?;
                    self.work.updates = 0;
                }
            }
            if augmentations > 0 && iteration == round_start {
                energy_reference = energy_reference.max(self.correction_work());
            }
            previous_norm = residual_norm;
            self.work.r_prev.copy_from_slice(&self.work.rhs);
        }
        unreachable!("the loop only ends by returning")
    }

    /// Whether full Newton may solve this iteration with the last factorisation
    /// ([`Convergence::chord_near_convergence`]): the residual is within the chord window,
    /// and the last step (from residual ratio `before`) was a full step of this round
    /// (after the terms last changed) that contracted the residual at least
    /// [`CHORD_CONTRACTION`]-fold (so the factorisation is of a nearby tangent of the same
    /// active set), or itself a chord step that contracted it at least
    /// [`CHORD_CONTINUATION`]-fold.
    fn chord_step_pays(
        &self,
        conv: &Convergence,
        iteration: usize,
        round_start: usize,
        step_length: f64,
        after_chord: bool,
        before: f64,
    ) -> bool {
        // The increment's first correction is a full step of the first round too (from the
        // start's residual, `before`): from an extrapolated start it can leave the residual
        // within the window, where a chord step finishes what a second factorisation would.
        let first_round_start = iteration == 0 && round_start == 0;
        if !conv.chord_near_convergence
            || (iteration <= round_start && !first_round_start)
            || step_length != 1.0
        {
            return false;
        }
        let Some(&now) = self.work.history.last() else {
            return false;
        };
        let contraction = if after_chord {
            CHORD_CONTINUATION
        } else {
            CHORD_CONTRACTION
        };
        now <= CHORD_WINDOW * conv.residual_tolerance && now * contraction <= before
    }

    /// Stores the last step `s·δ` and the residual change it caused as a BFGS update pair
    /// (`r_prev` holds the residual before the step, `rhs` after). False when the pair
    /// has no positive curvature (then the caller reforms).
    fn book_update(&mut self, step_length: f64) -> bool {
        let n = self.u.len();
        let k = self.work.updates;
        if self.work.qn_s.len() <= k {
            self.work.qn_s.push(vec![0.0; n]);
            self.work.qn_y.push(vec![0.0; n]);
            self.work.qn_rho.push(0.0);
            self.work.qn_alpha.push(0.0);
        }
        let (mut sy, mut ss, mut yy) = (0.0, 0.0, 0.0);
        for d in 0..n {
            // Prescribed DOFs moved only in the predictor: no part of a later direction.
            let (step, change) = if self.prescribed[d] {
                (0.0, 0.0)
            } else {
                (
                    step_length * self.work.delta[d],
                    self.work.r_prev[d] - self.work.rhs[d],
                )
            };
            self.work.qn_s[k][d] = step;
            self.work.qn_y[k][d] = change;
            sy += step * change;
            ss += step * step;
            yy += change * change;
        }
        // Positive curvature, and a secant that agrees with the energy the step was
        // predicted to release (s·r_prev / s·y near 1 for a quadratic; Matthies–Strang's
        // condition-number bound, 1e5 on its square root as in FEBio).
        if !(sy > 1e-12 * (ss * yy).sqrt()) {
            return false;
        }
        let predicted: f64 = (0..n)
            .filter(|&d| !self.prescribed[d])
            .map(|d| step_length * self.work.delta[d] * self.work.r_prev[d])
            .sum();
        if !(predicted / sy <= MAX_UPDATE_CONDITION) {
            return false;
        }
        self.work.qn_rho[k] = 1.0 / sy;
        self.work.updates = k + 1;
        true
    }

    /// δ ≈ K⁻¹·rhs from the kept factorisation and the stored updates (limited-memory
    /// BFGS two-loop recursion, with the factorised tangent as the initial inverse).
    fn quasi_newton_direction(&mut self) -> Result<(), FailureReason> {
        let n = self.u.len();
        let k = self.work.updates;
        let work = &mut self.work;
        work.delta.copy_from_slice(&work.rhs);
        for i in (0..k).rev() {
            let alpha = work.qn_rho[i] * dot(&work.qn_s[i], &work.delta);
            work.qn_alpha[i] = alpha;
            for d in 0..n {
                work.delta[d] -= alpha * work.qn_y[i][d];
            }
        }
        let start = Instant::now();
        // The direction is an approximation anyway: no refinement of a single-precision
        // factor's solve (the first solve after each factorisation is refined and checks
        // that single precision resolves the matrix).
        let (solver, delta) = (&mut self.solver, &mut self.work.delta);
        self.pool
            .install(|| solver.solve_approximately_in_place(delta))?;
        self.timings.solve_s += start.elapsed().as_secs_f64();
        self.expand_correction();
        let work = &mut self.work;
        for i in 0..k {
            let beta = work.qn_rho[i] * dot(&work.qn_y[i], &work.delta);
            let c = work.qn_alpha[i] - beta;
            for d in 0..n {
                work.delta[d] += c * work.qn_s[i][d];
            }
        }
        if self.work.delta.iter().any(|x| !x.is_finite()) {
            return Err(FailureReason::NotFinite { iteration: 0 });
        }
        Ok(())
    }

    /// Residual (and tangent when asked) at the current `u`.
    fn evaluate(&mut self, with_tangent: bool) -> Result<(), FailureReason> {
        if with_tangent {
            return self.assemble_full(false);
        }
        self.sync_drag();
        let start = Instant::now();
        let (assembler, terms, u, prescribed) =
            (&self.assembler, &self.terms, &self.u, &self.prescribed);
        let output = AssemblyOutput {
            residual: &mut self.residual,
            magnitude: Some(&mut self.work.magnitude),
            tangent: None,
            predictor: None,
        };
        let condensation = &mut self.condensation;
        self.energy = self.pool.install(|| match condensation {
            Some(c) => c.assemble(assembler, terms, u, prescribed, output),
            None => assembler.assemble(terms, u, prescribed, output),
        })?;
        if let Some(st) = &self.stabilizer {
            st.add_forces(&self.u, &mut self.residual);
        }
        self.timings.residual_only_s += start.elapsed().as_secs_f64();
        self.timings.residual_evaluations += 1;
        Ok(())
    }

    /// Lets every term augment; `None` when all are settled, else the first message.
    /// Augments every term: `None` when all are settled, otherwise the first message and
    /// whether only multipliers changed (no term changed its active set).
    fn augment_terms(&mut self) -> Option<(String, bool)> {
        let mut message = None;
        let mut multipliers_only = true;
        for term in &mut self.terms {
            let m = match term.augment(&self.u, &self.dof_map) {
                Augmentation::Settled => continue,
                Augmentation::Updated(m) => {
                    multipliers_only = false;
                    m
                }
                Augmentation::Multipliers(m) => m,
            };
            message.get_or_insert(format!("{}: {m}", term.name()));
        }
        message.map(|m| (m, multipliers_only))
    }

    /// The work |δ·R| of the last solved correction against the right-hand side it was
    /// solved for, over the free DOFs: what the energy criterion measures against.
    fn correction_work(&self) -> f64 {
        dot_free(&self.work.delta, &self.work.rhs, &self.prescribed).abs()
    }

    /// Residual ratio, energy ratio and force scale at the current point.
    fn measure(
        &self,
        scale_floor: &mut f64,
        step_length: f64,
        energy_reference: f64,
    ) -> (f64, f64, f64) {
        let n = self.u.len();
        let mut out_of_balance = 0.0;
        let mut reactions = 0.0;
        let mut work = 0.0;
        let mut internal = 0.0;
        for d in 0..n {
            let r = self.f_ext[d] - self.residual[d];
            if self.prescribed[d] {
                reactions += r * r;
            } else {
                out_of_balance += r * r;
                work += step_length * self.work.delta[d] * r;
                internal += self.work.magnitude[d] * self.work.magnitude[d];
            }
        }
        let scale = scale_floor.max(reactions.sqrt()).max(internal.sqrt());
        *scale_floor = scale;
        let residual_ratio = if scale > 0.0 {
            out_of_balance.sqrt() / scale
        } else {
            0.0
        };
        let energy_ratio = if energy_reference > 0.0 {
            work.abs() / energy_reference
        } else {
            0.0
        };
        (residual_ratio, energy_ratio, scale)
    }

    /// Factorises the assembled tangent and solves for the correction, to `tolerance` of
    /// its size ([`crate::linsolve::LinearSolver::solve_to_in_place`]; 0: in full).
    fn factorize_and_solve(&mut self, tolerance: f64) -> Result<(), FailureReason> {
        let (solver, work) = (&mut self.solver, &mut self.work);
        let start = Instant::now();
        let mut factored = None;
        // The times are booked whether or not the factorisation and solve succeed: a
        // matrix that every method fails on (LLᵀ, LDLᵀ, LU) costs the most of all.
        let result = self.pool.install(|| {
            let factor = solver.factorize(&work.values);
            factored = Some(Instant::now());
            let factor = factor?;
            work.delta.copy_from_slice(&work.rhs);
            solver.solve_to_in_place(&mut work.delta, tolerance)?;
            Ok::<_, FailureReason>(factor)
        });
        let (factored, solved) = (factored.unwrap_or(start), Instant::now());
        self.timings.factorization_s += (factored - start).as_secs_f64();
        self.timings.solve_s += (solved - factored).as_secs_f64();
        let factor = result?;
        self.last_factor = Some(factor);
        self.expand_correction();
        self.timings.factorizations += 1;
        if self.work.delta.iter().any(|x| !x.is_finite()) {
            return Err(FailureReason::NotFinite { iteration: 0 });
        }
        Ok(())
    }

    /// Assembles residual, tangent (and the prescribed-motion predictor when asked) at `u`.
    pub(super) fn assemble_full(&mut self, with_predictor: bool) -> Result<(), FailureReason> {
        self.sync_drag();
        let start = Instant::now();
        let predictor = with_predictor.then_some((
            self.work.du_prescribed.as_slice(),
            self.work.predictor.as_mut_slice(),
        ));
        let (assembler, terms, u, prescribed) =
            (&self.assembler, &self.terms, &self.u, &self.prescribed);
        let output = AssemblyOutput {
            residual: &mut self.residual,
            magnitude: Some(&mut self.work.magnitude),
            tangent: Some(&mut self.work.values),
            predictor,
        };
        let condensation = &mut self.condensation;
        self.energy = self.pool.install(|| match condensation {
            Some(c) => c.assemble(assembler, terms, u, prescribed, output),
            None => assembler.assemble(terms, u, prescribed, output),
        })?;
        if let Some(st) = &self.stabilizer {
            st.add_forces(&self.u, &mut self.residual);
            let pattern = solver_pattern(&self.condensation, &self.assembler);
            st.add_tangent(&mut self.work.values, |d| pattern.col_ptr[d]);
        }
        self.timings.assembly_s += start.elapsed().as_secs_f64();
        self.timings.assemblies += 1;
        Ok(())
    }

    /// Sets the stabiliser's weights at the step's first assembly (the tangent's diagonal
    /// on the free, unconstrained DOFs). When its damping factor is still to be calibrated:
    /// `Some(active)`; else `None`.
    fn stabilizer_needs_calibration(&mut self) -> Option<bool> {
        let st = self.stabilizer.as_mut()?;
        if !st.weighted {
            let pattern = solver_pattern(&self.condensation, &self.assembler);
            let constraints = self.condensation.as_ref().map(|c| c.constraints());
            let (prescribed, values) = (&self.prescribed, &self.work.values);
            let dof_map = &self.dof_map;
            st.set_weights(
                |d| !prescribed[d] && !constraints.is_some_and(|c| c.is_slave(d)),
                |d| values[pattern.col_ptr[d]],
                |d| dof_map.node_of(d).1 >= 3,
            );
        }
        st.factor.is_none().then_some(st.active)
    }

    /// Calibrates the damping factor on the undamped predictor of the step's first
    /// increment (see `solve::stabilize`), then solves that predictor again with the
    /// viscosity in the tangent.
    fn calibrate_stabilizer(&mut self) -> Result<(), FailureReason> {
        let undamped = self.factorize_and_solve(0.0);
        let energy = self.correction_work();
        let pattern = solver_pattern(&self.condensation, &self.assembler);
        let Some(st) = &mut self.stabilizer else {
            return undamped;
        };
        let delta = undamped.is_ok().then_some(self.work.delta.as_slice());
        st.calibrate(delta, energy);
        st.add_tangent(&mut self.work.values, |d| pattern.col_ptr[d]);
        if !st.nodal() {
            // The drag lives in the terms: assemble again with it (the start may have
            // moved from the increment's start, so its forces are not zero either).
            self.assemble_full(true)?;
            self.set_first_rhs();
        }
        self.factorize_and_solve(0.0)
    }

    /// The right-hand side of an increment's first solve: the prescribed DOFs' remaining
    /// motion, and on the free DOFs the out-of-balance force less the prescribed motion's
    /// predictor (assembled with it).
    fn set_first_rhs(&mut self) {
        for d in 0..self.u.len() {
            self.work.rhs[d] = if self.prescribed[d] {
                self.work.du_prescribed[d]
            } else {
                self.f_ext[d] - self.residual[d] - self.work.predictor[d]
            };
        }
    }

    /// Residual only at `u + s δ` (into `residual_trial`, with its magnitude and energy);
    /// returns δ·R(s) on free DOFs.
    fn trial_projection(&mut self, s: f64) -> Result<f64, FailureReason> {
        self.sync_drag();
        let start = Instant::now();
        self.work.trial_step = None;
        for d in 0..self.u.len() {
            self.work.trial[d] = self.u[d] + s * self.work.delta[d];
        }
        let (assembler, terms, trial, prescribed) = (
            &self.assembler,
            &self.terms,
            &self.work.trial,
            &self.prescribed,
        );
        let output = AssemblyOutput {
            residual: &mut self.work.residual_trial,
            magnitude: Some(&mut self.work.magnitude_trial),
            tangent: None,
            predictor: None,
        };
        let condensation = &mut self.condensation;
        self.work.energy_trial = self.pool.install(|| match condensation {
            Some(c) => c.assemble(assembler, terms, trial, prescribed, output),
            None => assembler.assemble(terms, trial, prescribed, output),
        })?;
        if let Some(st) = &self.stabilizer {
            st.add_forces(&self.work.trial, &mut self.work.residual_trial);
        }
        self.work.trial_step = Some(s);
        self.timings.residual_only_s += start.elapsed().as_secs_f64();
        self.timings.residual_evaluations += 1;
        Ok(self.projection(&self.work.residual_trial))
    }

    fn projection(&self, residual: &[f64]) -> f64 {
        (0..self.u.len())
            .filter(|&d| !self.prescribed[d])
            .map(|d| self.work.delta[d] * (self.f_ext[d] - residual[d]))
            .sum()
    }

    /// The longest step along δ that keeps every rotational DOF's change within
    /// `max_rotation_step` (1 when that holds for the full step or the bound is off).
    fn rotation_step_limit(&mut self, max_rotation_step: f64) -> f64 {
        if max_rotation_step <= 0.0 {
            return 1.0;
        }
        let largest = self
            .rotation_dofs
            .iter()
            .fold(0.0f64, |m, &d| m.max(self.work.delta[d].abs()));
        if largest > max_rotation_step {
            self.timings.rotation_limited_steps += 1;
            max_rotation_step / largest
        } else {
            1.0
        }
    }

    /// Chooses the step length along δ, moves `u` there and assembles residual and tangent.
    /// The full step, or the longest the rotations' trust region allows
    /// ([`Convergence::max_rotation_step`]), unless it inverts an element (then halve) or the
    /// projection g(s) = δ·R(u+sδ) stays above `threshold·g(0)` (then secant steps on g,
    /// keeping the best |g|, never beyond the first step).
    fn line_search(
        &mut self,
        conv: &Convergence,
        with_tangent: bool,
        relax: Option<f64>,
    ) -> Result<f64, FailureReason> {
        let g0 = self.projection(&self.residual);
        let longest = self.rotation_step_limit(conv.max_rotation_step);
        if let Some(tolerance) = relax {
            if self.relaxed_full_step(conv, with_tangent, tolerance, g0, longest) {
                return Ok(longest);
            }
        }
        let mut s = longest;
        let mut g1 = loop {
            match self.trial_projection(s) {
                Ok(g) => break g,
                Err(e) if s > longest / 32.0 => {
                    let _ = e;
                    s *= 0.5;
                }
                Err(e) => return Err(e),
            }
        };
        if conv.line_search_threshold > 0.0
            && g0 > 0.0
            && g1.abs() > conv.line_search_threshold * g0
        {
            let (mut best_s, mut best_g) = (s, g1);
            let (mut s_prev, mut g_prev) = (0.0, g0);
            for _ in 0..5 {
                let denom = g_prev - g1;
                if denom == 0.0 {
                    break;
                }
                let s_new = (s - g1 * (s - s_prev) / denom).clamp(0.1 * s, longest);
                s_prev = s;
                g_prev = g1;
                s = s_new;
                match self.trial_projection(s) {
                    Ok(g) => g1 = g,
                    Err(_) => break,
                }
                if g1.abs() < best_g.abs() {
                    best_s = s;
                    best_g = g1;
                }
                if g1.abs() <= conv.line_search_threshold * g0 {
                    break;
                }
            }
            s = best_s;
        }
        for d in 0..self.u.len() {
            self.u[d] += s * self.work.delta[d];
        }
        if let Some(tolerance) = relax {
            self.relax_blocks(tolerance);
        } else if !with_tangent && self.work.trial_step == Some(s) {
            // `u` is now the last trial point, bit for bit (the same sum as in
            // `trial_projection`): its residual is already there.
            let work = &mut self.work;
            std::mem::swap(&mut self.residual, &mut work.residual_trial);
            std::mem::swap(&mut work.magnitude, &mut work.magnitude_trial);
            self.energy = work.energy_trial;
            work.trial_step = None;
            return Ok(s);
        }
        self.evaluate(with_tangent)?;
        Ok(s)
    }

    /// With relaxation blocks, the full step is tried first where it will end: `u + s δ`
    /// with the blocks relaxed there, evaluated once (tangent too when asked). It is kept
    /// when the projection `δ·R` there passes the line search's test (or the line search
    /// is off); otherwise `u` is put back and the line search runs from the start as
    /// without relaxation. Before, every iteration evaluated the residual twice, at the
    /// trial point and again after the relaxation moved the blocks (docs/performance.md,
    /// "One residual per relaxed iteration").
    fn relaxed_full_step(
        &mut self,
        conv: &Convergence,
        with_tangent: bool,
        tolerance: f64,
        g0: f64,
        s: f64,
    ) -> bool {
        self.work.trial.copy_from_slice(&self.u);
        for d in 0..self.u.len() {
            self.u[d] += s * self.work.delta[d];
        }
        self.relax_blocks(tolerance);
        self.work.trial_step = None;
        if self.evaluate(with_tangent).is_ok() {
            let g1 = self.projection(&self.residual);
            if conv.line_search_threshold <= 0.0
                || !(g0 > 0.0)
                || g1.abs() <= conv.line_search_threshold * g0
            {
                return true;
            }
        }
        self.u.copy_from_slice(&self.work.trial);
        false
    }

    /// Moves every relaxation block to its own equilibrium at the current `u` (see
    /// `solve::relax`), holding prescribed and constrained DOFs.
    fn relax_blocks(&mut self, tolerance: f64) {
        self.sync_drag();
        let Some(relaxation) = &mut self.relaxation else {
            return;
        };
        let (prescribed, constraints) = (
            &self.prescribed,
            self.condensation.as_ref().map(|c| c.constraints()),
        );
        let damping = self
            .stabilizer
            .as_ref()
            .filter(|st| st.rate != 0.0)
            .map(|st| (st.nodal_weight.as_slice(), st.u_start.as_slice(), st.rate));
        let (pool, terms, u) = (&self.pool, &self.terms, &mut self.u);
        pool.install(|| {
            relaxation.relax(
                terms,
                u,
                &self.f_ext,
                |d| prescribed[d] || constraints.is_some_and(|c| c.is_slave(d) || c.is_master(d)),
                damping,
                tolerance,
            )
        });
    }
}
