//! Why an increment or an analysis failed.

use crate::assembly::AssemblyError;
use crate::linsolve::LinSolveError;

/// Why one Newton increment failed (the stepper reacts by cutting the increment).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FailureReason {
    /// An element could not be evaluated (e.g. inverted).
    #[error(transparent)]
    Element(#[from] AssemblyError),
    /// The tangent could not be factorised.
    #[error(transparent)]
    Singular(#[from] LinSolveError),
    /// The residual grew beyond the divergence limit.
    #[error("Newton diverged at iteration {iteration}: |R|/|R0| = {ratio:.3e}")]
    Diverged {
        /// Iteration at which divergence was detected.
        iteration: usize,
        /// ‖Rᵢ‖/‖R₀‖.
        ratio: f64,
    },
    /// The residual rebounded: after falling to its lowest in the round it rose above both
    /// [`crate::solve::Convergence::rebound_ratio`] times that and the increment's first one.
    #[error(
        "Newton rebounded at iteration {iteration}: |R| rose {ratio:.3e}-fold above its lowest"
    )]
    Rebounded {
        /// Iteration at which it was detected.
        iteration: usize,
        /// ‖Rᵢ‖ over the round's lowest ‖R‖.
        ratio: f64,
    },
    /// The iteration limit was reached before convergence.
    #[error("no convergence in {iterations} iterations: |R|/scale = {residual:.3e}, energy ratio = {energy:.3e}")]
    MaxIterations {
        /// Iterations done.
        iterations: usize,
        /// Last relative residual.
        residual: f64,
        /// Last relative energy norm.
        energy: f64,
    },
    /// A residual or solution value was NaN or infinite.
    #[error("non-finite residual or solution at iteration {iteration}")]
    NotFinite {
        /// Iteration at which it happened.
        iteration: usize,
    },
    /// A term's augmentation or active-set loop did not settle.
    #[error("{0}")]
    Unsettled(String),
}

/// Why an analysis stopped. Every increment converged before it has been reported.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// The increment was cut below the minimum.
    #[error(
        "step '{step}' stopped at step time {time:.6}: the increment was cut to {increment:.3e}, \
         below the minimum {min_increment:.3e}; last failure: {reason}"
    )]
    IncrementTooSmall {
        /// Step name.
        step: String,
        /// Last converged step time (0..1).
        time: f64,
        /// The increment that failed last.
        increment: f64,
        /// The configured minimum.
        min_increment: f64,
        /// Why the last attempt failed.
        reason: FailureReason,
    },
    /// The step's input is inconsistent with the model.
    #[error("step '{step}': {message}")]
    InvalidStep {
        /// Step name.
        step: String,
        /// What is wrong.
        message: String,
    },
    /// The step ended without its stop condition being met.
    #[error(
        "step '{step}' ended without reaching its target: {monitor} = {last:.6e}, target {target:.6e}; \
         extend the step's motion"
    )]
    TargetNotReached {
        /// Step name.
        step: String,
        /// The monitored quantity.
        monitor: String,
        /// The target.
        target: f64,
        /// The value at the end of the step.
        last: f64,
    },
    /// A stabilised step ended in a state that is not an equilibrium: the re-solve without
    /// viscosity failed and the viscous forces left exceed the accepted fraction.
    #[error(
        "step '{step}' reached its end only with viscous stabilisation: the state there is not an \
         equilibrium (viscous forces {viscous_force_ratio:.3e} of the force scale, more than the \
         accepted {max:.1e}; the re-solve without viscosity failed), so its results are not reported \
         as converged; the increments before it are written"
    )]
    NotEquilibrated {
        /// Step name.
        step: String,
        /// ‖viscous forces‖ / force scale at the end.
        viscous_force_ratio: f64,
        /// The accepted fraction.
        max: f64,
    },
    /// The thread pool could not be built (the system refused the threads).
    #[error("cannot start the solver's threads: {0}")]
    Threads(String),
    /// The linear solver could not analyse the pattern.
    #[error(transparent)]
    LinearSolver(#[from] LinSolveError),
    /// The linear constraints do not fit the model.
    #[error(transparent)]
    Constraint(#[from] crate::constraint::ConstraintError),
}
