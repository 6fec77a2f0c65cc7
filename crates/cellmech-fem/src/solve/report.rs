//! What the solver reports to its [`super::Observer`]: one Newton iteration, one converged
//! increment.

use super::stabilize::StabilizationReport;

/// A converged increment.
#[derive(Debug, Clone)]
pub struct IncrementReport<'a> {
    /// Index of the analysis step (0-based).
    pub step_index: usize,
    /// Name of the analysis step.
    pub step_name: &'a str,
    /// Converged increments so far in this step (1-based).
    pub increment: usize,
    /// Step pseudo-time reached (0..1).
    pub step_time: f64,
    /// Total pseudo-time (sum of finished steps' durations + step_time · duration).
    pub total_time: f64,
    /// Newton iterations this increment took.
    pub iterations: usize,
    /// Relative residual norms ‖Rᵢ‖/scale of every iteration.
    pub residual_history: &'a [f64],
    /// Internal energy of all terms (nN·µm).
    pub energy: f64,
    /// What the viscous stabilisation did, when the step has it.
    pub stabilization: Option<StabilizationReport>,
}

/// One Newton iteration, for convergence tables.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct IterationReport {
    /// Iteration number within the increment (0 = predictor).
    pub iteration: usize,
    /// ‖R_free‖ / force scale after the update.
    pub residual_ratio: f64,
    /// |s δ·R| / |δ₀·R₀| after the update.
    pub energy_ratio: f64,
    /// The force scale (nN) the residual is measured against.
    pub force_scale: f64,
    /// Line-search step length used (1 = full Newton step).
    pub line_search: f64,
    /// ‖δ‖ (µm) of the iteration's correction.
    pub correction_norm: f64,
    /// The correction was a chord step: solved with an earlier factorisation
    /// ([`super::Convergence::chord_near_convergence`]).
    pub chord: bool,
    /// The correction was solved with a tangent factorised for it (a stiffness
    /// reformation, in FEBio's words); false for quasi-Newton and chord corrections.
    pub reformed: bool,
}
