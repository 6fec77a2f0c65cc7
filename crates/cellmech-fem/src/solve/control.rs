//! Step control and convergence criteria.

use serde::Serialize;

/// Newton convergence criteria, all relative (forces here span 1e-4 to 1e3 nN, so an
/// absolute tolerance would silently accept wrong answers on small loads).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Convergence {
    /// Residual criterion: ‖R_free‖ ≤ `residual_tolerance` · force scale, where the force
    /// scale is the largest of ‖f_ext‖, ‖reactions‖, the first residual of the increment and
    /// the size of the internal forces that balance at the free DOFs (Σ|element forces|,
    /// which is what a prestressed structure carries with no external load).
    pub residual_tolerance: f64,
    /// Energy criterion: |δuᵢ·Rᵢ| ≤ `energy_tolerance` · |δu₀·R₀|.
    pub energy_tolerance: f64,
    /// Maximum Newton iterations per increment before the increment is cut.
    pub max_iterations: usize,
    /// Divergence: the increment is cut when ‖Rᵢ‖ exceeds this multiple of ‖R₀‖.
    pub divergence_ratio: f64,
    /// Most augmentation rounds (contact multipliers, active sets) per increment.
    pub max_augmentations: usize,
    /// Line search is tried when |R(u+δ)·δ| > this fraction of |R(u)·δ| (0 disables it).
    pub line_search_threshold: f64,
}

impl Default for Convergence {
    fn default() -> Self {
        Convergence {
            residual_tolerance: 1e-8,
            energy_tolerance: 1e-12,
            max_iterations: 25,
            divergence_ratio: 1e6,
            max_augmentations: 50,
            line_search_threshold: 0.9,
        }
    }
}

/// Automatic load stepping of one analysis step (pseudo-time runs from 0 to 1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StepControl {
    /// First increment as a fraction of the step.
    pub initial_increment: f64,
    /// Smallest increment; below it the analysis stops with a clear error.
    pub min_increment: f64,
    /// Largest increment.
    pub max_increment: f64,
    /// Increments that converge in at most this many iterations grow the next increment.
    pub easy_iterations: usize,
    /// Growth factor after an easy increment.
    pub growth: f64,
    /// Cut factor after a failed increment.
    pub cutback: f64,
    /// Newton convergence criteria.
    pub convergence: Convergence,
}

impl Default for StepControl {
    fn default() -> Self {
        StepControl {
            initial_increment: 0.1,
            min_increment: 1e-5,
            max_increment: 0.25,
            easy_iterations: 5,
            growth: 1.5,
            cutback: 0.5,
            convergence: Convergence::default(),
        }
    }
}
