//! Observers receive the solver's events: CSV rows, VTU frames, progress bars and the
//! convergence table are all observers.

use super::error::FailureReason;
use super::newton::IterationReport;
use super::problem::Problem;
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

/// Receives solver events. All methods have empty defaults.
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

/// An observer that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NullObserver;

impl Observer for NullObserver {}
