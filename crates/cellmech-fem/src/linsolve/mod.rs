//! Sparse linear solvers for the tangent system.
//!
//! Contract: the sparsity pattern ([`SparsityPattern`], lower triangle in CSC) is fixed for a
//! model. [`LinearSolver::analyze`] does the ordering and symbolic factorisation once;
//! [`LinearSolver::factorize`] is called every Newton iteration with new values in the same
//! pattern, and [`LinearSolver::solve_in_place`] solves with the last factorisation.

mod dense;
mod faer_solver;
pub mod ordering;
mod pattern;
pub mod test_matrices;
#[cfg(test)]
mod tests;
mod tree_cholesky;
pub use dense::DenseSolver;
pub use faer_solver::{
    AnalysisInfo, FaerSparseSolver, MixedPrecisionStats, DEFAULT_PARALLEL_MIN_FLOPS,
    MIXED_MAX_ITERATIONS, MIXED_SOLVE_TOLERANCE,
};
pub use ordering::FillOrdering;
pub use pattern::SparsityPattern;

/// The default solver of the engine: [`FaerSparseSolver`] with nested dissection, on at most
/// `threads` threads of the calling rayon pool (`0`: all; see [`FaerSparseSolver::new`]).
pub fn default_solver(threads: usize) -> Box<dyn LinearSolver> {
    Box::new(FaerSparseSolver::new(threads))
}

/// How the last numeric factorisation was done.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum FactorMethod {
    /// Cholesky LLᵀ (the matrix was positive definite).
    Cholesky,
    /// Symmetric indefinite LDLᵀ with Bunch-Kaufman pivoting.
    Ldlt,
    /// General LU (last resort).
    Lu,
}

/// Facts about a numeric factorisation, returned as data (never printed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct FactorInfo {
    /// Which factorisation succeeded.
    pub method: FactorMethod,
    /// Number of negative pivots (eigenvalues) when known: 0 for Cholesky, the inertia count for
    /// LDLᵀ. A positive count signals an unstable (e.g. buckling) equilibrium.
    pub negative_pivots: Option<usize>,
}

/// Errors of the linear solvers.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum LinSolveError {
    /// `factorize`/`solve` before `analyze`, or values of the wrong length.
    #[error("linear solver used out of order or with the wrong size: {0}")]
    Usage(String),
    /// Every factorisation tried failed: the tangent is singular.
    #[error("the tangent matrix is singular (all factorisations failed; last: {0})")]
    Singular(String),
}

/// A sparse direct solver with symbolic/numeric separation.
pub trait LinearSolver: Send {
    /// Orders and analyses the pattern (once per model).
    fn analyze(&mut self, pattern: &SparsityPattern) -> Result<(), LinSolveError>;
    /// Numeric factorisation of the matrix with these values (ordered as `pattern.row_idx`).
    fn factorize(&mut self, values: &[f64]) -> Result<FactorInfo, LinSolveError>;
    /// Overwrites `rhs` with the solution of the last factorised system.
    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinSolveError>;
    /// Like [`LinearSolver::solve_in_place`], for a direction that is an approximation
    /// anyway (a quasi-Newton or chord correction): the solver may return the solution of
    /// its factor without refining it (single precision: an error of about the condition
    /// number times 6e-8). The default is the full solve.
    fn solve_approximately_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinSolveError> {
        self.solve_in_place(rhs)
    }
    /// Like [`LinearSolver::solve_in_place`], to a relative accuracy of the solution of
    /// about `tolerance` (for a direction whose own approximation is of that size: the
    /// first correction of a quasi-Newton round). A solver that refines its solves may stop
    /// refining there; it never returns one less accurate than
    /// [`LinearSolver::solve_approximately_in_place`], and it still checks that its factor
    /// resolves the matrix. The default is the full solve.
    fn solve_to_in_place(&mut self, rhs: &mut [f64], tolerance: f64) -> Result<(), LinSolveError> {
        let _ = tolerance;
        self.solve_in_place(rhs)
    }
    /// What mixed precision did, for a solver that has it.
    fn mixed_precision_stats(&self) -> Option<MixedPrecisionStats> {
        None
    }
    /// The size of the factor the last analysis planned, for a solver that knows it.
    fn factor_size(&self) -> Option<FactorSize> {
        None
    }
}

/// How big a factorisation is: what one numeric factorisation costs in memory and work.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct FactorSize {
    /// Exact structural nonzeros of L (diagonal included) for the fill-reducing ordering.
    pub nonzeros: usize,
    /// Floating-point operations of one numeric Cholesky, `Σ_j c_j²` over L's columns.
    pub flops: f64,
}
