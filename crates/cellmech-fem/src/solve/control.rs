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
    /// Energy criterion: |δuᵢ·Rᵢ| ≤ `energy_tolerance` · E₀, E₀ the work |δ₀·R₀| of the
    /// increment's first correction, or of a contact round's first correction when that is
    /// larger (a round starts when an augmentation changed the terms).
    pub energy_tolerance: f64,
    /// Maximum Newton iterations per increment before the increment is cut.
    pub max_iterations: usize,
    /// Divergence: the increment is cut when ‖Rᵢ‖ exceeds this multiple of ‖R₀‖.
    pub divergence_ratio: f64,
    /// Divergence after progress: the increment is cut when, within a round (between
    /// augmentations), the residual rises above both this multiple of the lowest ‖R‖ the
    /// round reached and the increment's first ‖R₀‖ (0 disables it). A Newton or BFGS
    /// iteration that close to equilibrium that throws the state that far off does not come
    /// back: measured on the compression refined under the plates, one such attempt ran 11
    /// more iterations (11 indefinite factorisations, up to 146 negative pivots) before
    /// `max_iterations` cut it (docs/performance.md).
    pub rebound_ratio: f64,
    /// Most augmentation rounds (contact multipliers, active sets) per increment.
    pub max_augmentations: usize,
    /// Residual ratio below which the terms augment (contact status and multipliers) once
    /// per round before the round has converged (0: only at convergence, the classical
    /// nested augmented Lagrangian). An augmentation at convergence starts a new round,
    /// which throws away the digits the round spent its last iterations on; updating the
    /// status and multipliers once the residual is this small (an inexact Uzawa step)
    /// starts the next round from nearly the same state without them. An increment is
    /// still accepted only at a converged state where every term is settled. Default
    /// [`NEAR_EQUILIBRIUM`]: on the default compression 73 factorisations and 375
    /// residual evaluations instead of 82 and 472, forces within 4e-8 at 10 and 30 % and
    /// 4.4e-4 at 50 % (the bonded patch's path; docs/performance.md, "Contact updates
    /// before the last digits").
    pub early_augmentation: f64,
    /// Line search is tried when |R(u+δ)·δ| > this fraction of |R(u)·δ| (0 disables it).
    pub line_search_threshold: f64,
    /// How the iterations after the predictor get their direction.
    pub method: IterationMethod,
    /// Re-equilibrate the problem's relaxation blocks after every global
    /// update (nonlinear elimination, [`crate::solve::Problem::set_relaxation_blocks`]);
    /// no effect on a problem without blocks.
    pub relaxation: bool,
    /// Full Newton only: near convergence, solve with the last factorisation instead of
    /// refactorising (a chord step). Taken when the residual is within
    /// [`CHORD_WINDOW`] times `residual_tolerance` and the last full Newton step contracted
    /// it at least [`CHORD_CONTRACTION`]-fold (the quadratic regime, where the chord
    /// step's error is about the product of the last two errors); chord steps go on while
    /// each divides the residual at least [`CHORD_CONTINUATION`]-fold, and full Newton
    /// resumes as soon as one contracts less. Right after an augmentation that changed only
    /// multipliers ([`crate::term::Augmentation::Multipliers`]: same active set, same
    /// tangent) the first correction is a chord step too, whatever the residual; after one
    /// that changed the active set, a new factorisation. The convergence criteria are
    /// unchanged, so the accepted states meet the same tolerances.
    pub chord_near_convergence: bool,
    /// Trust region of the rotational DOFs (rad; 0: none). A correction whose largest
    /// nodal-rotation component exceeds this is shortened along its own direction until it
    /// does not, before the line search; so is an increment's first correction when it
    /// moves no prescribed DOF (an extrapolated or re-solved start, a rigid tool's motion;
    /// one carrying a prescribed motion is taken whole, to reach the targets). A beam node's
    /// rotation enters its kinematics through exp(θ̂), whose linearisation is good only for
    /// increments well below a radian: where filaments tied to the gel snap through, Newton
    /// otherwise proposed rotation corrections of 10-900 rad, and the increment failed
    /// (measured in docs/performance.md, "A trust region on the rotations").
    pub max_rotation_step: f64,
}

/// Newton tells the terms they are near equilibrium ([`crate::term::Term::set_near_equilibrium`])
/// once the residual is within this fraction of the force scale: a thousand times the
/// default residual tolerance, where a contact's trial pressures are within about that
/// fraction of their converged values, so the exact curvature term cannot push the
/// elements under a tool the way it can at the start of an increment.
pub const NEAR_EQUILIBRIUM: f64 = 1e-5;

/// Quasi-Newton (BFGS) solves the first correction after each factorisation to this
/// fraction of its size ([`crate::linsolve::LinearSolver::solve_to_in_place`]), not to the
/// linear solver's full accuracy: the corrections after it come from the same factor
/// without refinement (a single-precision factor's solve alone is off by 2e-2 to 0.7 on the
/// cell tangents) and the update pairs, so a more accurate first one buys nothing. Measured
/// on the default compression (88 factorisations): the same 397 Newton iterations and
/// forces as with full accuracy, 294 conjugate-gradient iterations of the mixed-precision
/// solves instead of 552 (docs/performance.md, "Quasi-Newton's reform solves").
pub const QUASI_NEWTON_SOLVE_TOLERANCE: f64 = 1e-2;

/// A chord step is tried when the residual ratio is at most this multiple of the
/// residual tolerance ([`Convergence::chord_near_convergence`]).
pub const CHORD_WINDOW: f64 = 1e3;

/// ... and the last full Newton step divided the residual by at least this factor.
pub const CHORD_CONTRACTION: f64 = 1e2;

/// A further chord step follows one that divided the residual by at least this factor.
pub const CHORD_CONTINUATION: f64 = 1e1;

/// How Newton's corrections after the first are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum IterationMethod {
    /// Full Newton: tangent assembled and factorised at every iteration.
    Newton,
    /// Quasi-Newton (BFGS, as FEBio's default): the increment's first factorisation is
    /// kept and corrected by up to `max_updates` rank-two updates (the limited-memory
    /// two-loop recursion); the tangent is reformed and refactorised when the updates run
    /// out, the residual grows, or an update would lose positive curvature. The
    /// convergence criteria are the same.
    Bfgs {
        /// Updates before a reform.
        max_updates: usize,
    },
}

impl IterationMethod {
    /// BFGS with FEBio's default of 10 updates before a reform, as the scenario keys and the
    /// cell models' `solver.iteration = "bfgs"` choose it.
    pub const fn bfgs() -> Self {
        IterationMethod::Bfgs { max_updates: 10 }
    }
}

impl Default for Convergence {
    fn default() -> Self {
        Convergence {
            residual_tolerance: 1e-8,
            energy_tolerance: 1e-12,
            max_iterations: 25,
            divergence_ratio: 1e6,
            rebound_ratio: 1e3,
            max_augmentations: 50,
            early_augmentation: NEAR_EQUILIBRIUM,
            line_search_threshold: 0.9,
            method: IterationMethod::Newton,
            relaxation: true,
            chord_near_convergence: true,
            max_rotation_step: 0.0,
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
    /// Increments that converge in at most this many iterations grow the next increment
    /// (full Newton; quasi-Newton steps use [`StepControl::easy_quasi_newton_iterations`]).
    pub easy_iterations: usize,
    /// The same for quasi-Newton (BFGS) steps, whose iterations are mostly solves with a
    /// kept factorisation and so take more of them for the same work: 10, after FEBio's
    /// time stepper (`opt_iter` = 11 with its BFGS default). With 5, as for full Newton, a
    /// BFGS step that converged every increment in 6-10 iterations never let them grow
    /// (docs/performance.md, "The first correction too").
    pub easy_quasi_newton_iterations: usize,
    /// Growth factor after an easy increment. An increment within this factor of the
    /// step's end (and within `max_increment`) takes the whole rest instead of leaving a
    /// sliver, except the retry after a cut-back and an aim at a stop monitor's crossing.
    pub growth: f64,
    /// Cut factor after a failed increment.
    pub cutback: f64,
    /// Newton convergence criteria.
    pub convergence: Convergence,
    /// Automatic viscous stabilisation (`None`: off). See [`Stabilization`].
    pub stabilization: Option<Stabilization>,
    /// Where Newton starts each increment after a step's first (a step's guess path, when
    /// it has one, takes precedence).
    pub extrapolation: Extrapolation,
}

/// The starting point of an increment's Newton iterations (as Abaqus `*STEP,
/// EXTRAPOLATION`). Measured in `docs/performance.md` ("Extrapolated starts"): it saves a
/// third of the iterations of a continuum between plates, and costs more than it saves
/// where nearly mechanistic parts (free filament beams) swing from one increment to the
/// next, so it is chosen per step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Extrapolation {
    /// From the last converged state (prescribed DOFs moved by the linearised predictor).
    #[default]
    None,
    /// From the last converged state plus the step's previous increment of displacement,
    /// scaled by the ratio of the increment sizes, with the prescribed DOFs at their
    /// targets (the first increment of a step starts from the converged state, and so does
    /// every retry after a failed attempt, until an increment converges). A path that
    /// continues as it went needs fewer iterations, and contact points the body is heading
    /// onto are predicted active ([`crate::term::Term::predict`]).
    Linear,
}

/// Automatic viscous stabilisation of a static step (as Abaqus `*STATIC, STABILIZE`): an
/// artificial viscosity carries the solve through buckling and snap-through; the energy it
/// dissipates is reported and kept small, and the step ends in a true equilibrium when one
/// exists. See the module `solve::stabilize` and `docs/stabilization.md`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stabilization {
    /// Fraction of the first increment's strain energy that the calibrated viscosity would
    /// dissipate over the same motion (Abaqus's default 2e-4).
    pub energy_fraction: f64,
    /// Largest accepted ratio of the step's dissipated energy to the strain energy; above
    /// it the damping factor is halved for the following increments (Abaqus's default 0.05).
    pub accuracy_tolerance: f64,
    /// A damping factor given explicitly instead of calibrated (dimensionless).
    pub factor: Option<f64>,
    /// Re-solve the step's last increment without viscosity so the final state is an
    /// equilibrium (kept damped, and reported so, when that fails).
    pub equilibrate_at_end: bool,
    /// From the step's start, or only once an increment has failed.
    pub activation: Activation,
    /// Largest ‖viscous forces‖ / force scale accepted in the step's final state when the
    /// re-solve without viscosity fails; above it the step fails (its results would not be
    /// an equilibrium).
    pub max_end_viscous_force: f64,
    /// Most relaxation increments at the step's final load when the re-solve without
    /// viscosity fails: the damped state flows on at fixed load with a viscosity that
    /// shrinks as its out-of-balance force does (pseudo-transient continuation), and the
    /// re-solve is tried again once that force is near the tolerance. 0: none.
    pub end_relaxation_increments: usize,
    /// Which motions the viscosity resists: every free DOF's (Abaqus), or only the relative
    /// motions that terms define (a fibre moving through the continuum it is tied to).
    pub damping: Damping,
}

/// Which motions the viscous stabilisation resists.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Damping {
    /// Every free DOF's motion over the increment, `(c/Δt) m_d Δu_d` (Abaqus `*STATIC,
    /// STABILIZE`): simple and general, but a body that moves a lot without any instability
    /// (a cell squeezed between plates) dissipates energy too, and a boosted viscosity slows
    /// all of it.
    #[default]
    Nodal,
    /// Only the relative motions that terms define through [`crate::term::Term::set_drag`]
    /// (a tied fibre node moving relative to its material point in the host: the drag of a
    /// viscous medium on a filament). Rigid motions and the continuum's own deformation are
    /// free; an instability that lives in the tied fibres (their buckling on the elastic
    /// foundation) is damped where it happens. Rotational DOFs keep the nodal viscosity. A
    /// step whose terms define no relative motion (every tied family switched off) gets
    /// [`Damping::Nodal`] instead: nothing would be damped otherwise.
    Relative,
}

/// Failed attempts in a row (the same increment cut again and again) after which
/// [`Activation::OnDifficulty`] switches the viscosity on.
pub const ON_DIFFICULTY_FAILURES: usize = 3;

/// When viscous stabilisation switches on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Activation {
    /// From the step's first increment (as Abaqus `*STATIC, STABILIZE`).
    Always,
    /// When [`ON_DIFFICULTY_FAILURES`] attempts of one increment have failed in a row (an
    /// ordinary cutback or two is left to the increment control): a step that converges
    /// without it is solved exactly as without stabilisation.
    OnDifficulty,
}

impl Default for Stabilization {
    fn default() -> Self {
        Stabilization {
            energy_fraction: 2e-4,
            accuracy_tolerance: 0.05,
            factor: None,
            equilibrate_at_end: true,
            activation: Activation::Always,
            max_end_viscous_force: 1e-3,
            end_relaxation_increments: 20,
            damping: Damping::Nodal,
        }
    }
}

impl Stabilization {
    /// Checks the settings; the message names the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!(
                    "stabilization {name} must be a finite number > 0, found {v}"
                ))
            }
        };
        positive("energy_fraction", self.energy_fraction)?;
        positive("accuracy_tolerance", self.accuracy_tolerance)?;
        positive("max_end_viscous_force", self.max_end_viscous_force)?;
        if let Some(c) = self.factor {
            positive("factor", c)?;
        }
        Ok(())
    }
}

impl StepControl {
    /// The iterations within which an increment counts as easy (the next one grows) for
    /// this step's iteration method.
    pub fn easy_iterations_of_method(&self) -> usize {
        match self.convergence.method {
            IterationMethod::Newton => self.easy_iterations,
            IterationMethod::Bfgs { .. } => self.easy_quasi_newton_iterations,
        }
    }
}

impl Default for StepControl {
    fn default() -> Self {
        StepControl {
            initial_increment: 0.1,
            min_increment: 1e-5,
            max_increment: 0.25,
            easy_iterations: 5,
            easy_quasi_newton_iterations: 10,
            growth: 1.5,
            cutback: 0.5,
            convergence: Convergence::default(),
            stabilization: None,
            extrapolation: Extrapolation::default(),
        }
    }
}
