//! The nonlinear solver: full Newton–Raphson with line search inside automatic load
//! stepping with cutback, over a sequence of analysis steps.
//!
//! A [`Problem`] owns the terms, the assembler (pattern built once), the linear solver
//! (symbolic factorisation done once) and the state. [`Problem::run_step`] advances one
//! [`Step`] from pseudo-time 0 to 1 in increments, reporting every iteration and every
//! converged increment to an [`Observer`]. The engine never prints.

mod constrained;
mod control;
mod error;
mod newton;
mod norms;
mod problem;
mod reduced;
mod relax;
mod report;
mod rezoned;
mod stabilize;
mod step;

pub use control::{
    Activation, Convergence, Damping, Extrapolation, IterationMethod, Stabilization, StepControl,
    CHORD_CONTINUATION, CHORD_CONTRACTION, CHORD_WINDOW, NEAR_EQUILIBRIUM, ON_DIFFICULTY_FAILURES,
    QUASI_NEWTON_SOLVE_TOLERANCE,
};
pub use error::{FailureReason, SolveError};
pub use problem::{NullObserver, Observer, Problem, Timings, JUMP_WIDTH};
pub use relax::RelaxationStats;
pub use report::{IncrementReport, IterationReport};
pub use rezoned::remap_translations;
pub use stabilize::StabilizationReport;
pub use step::{GuessPath, Monitor, Motion, NodalLoad, Step, StopCondition};

#[cfg(test)]
mod tests;
