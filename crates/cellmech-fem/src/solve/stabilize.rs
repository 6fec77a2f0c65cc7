//! Automatic viscous stabilisation of a static step, in the manner of Abaqus
//! `*STATIC, STABILIZE`: a small artificial viscosity carries a structure through local
//! instabilities (buckling, snap-through, a floppy mode) that would stop a static Newton
//! solve, and the energy it dissipates is measured and kept small.
//!
//! # The forces
//!
//! Within an increment from `uₙ` over the pseudo-time `Δt`, every free DOF `d` feels the
//! viscous force `f_d = (c / Δt) · m_d · (u_d − uₙ,d)` opposing its motion, added to the
//! internal forces, with tangent `(c / Δt) · m_d` on the diagonal. The weights `m_d` are the
//! absolute diagonal of the tangent at the step's first assembly. Abaqus uses a mass matrix
//! of unit density instead; the tangent's diagonal exists for every DOF type (rotations,
//! filament-only nodes), needs no element method, and scales with the local stiffness, so
//! the damping factor `c` is dimensionless and does not depend on the units or the mesh.
//! A damped DOF whose diagonal is zero (a mechanism) gets the mean weight. Constrained
//! (slave) and prescribed DOFs are not damped.
//!
//! With [`Damping::Relative`] the translations are not damped at the DOFs: the terms that
//! define relative motions (elastic ties of filaments to a host continuum) add a drag
//! `(c/Δt) m_s (g − g₀)` against each tied node's slip `g` since the increment's start
//! ([`crate::term::Term::set_drag`], kept in sync by the problem through `epoch`), and
//! only the rotations keep the force at the DOF. `c` is calibrated and adapted as below.
//!
//! With [`Activation::OnDifficulty`] the stabiliser sets its weights and calibrates `c` on
//! the step's first increment as usual (on the undamped predictor the solve computes
//! anyway) but keeps the viscosity off until one increment has failed
//! [`ON_DIFFICULTY_FAILURES`] times in a row (ordinary cutbacks are the increment control's
//! business: switching on at the first one changed the bonded-contact path of the cell
//! compression test, see `docs/stabilization.md`); then it switches on, boosted as after
//! any failure. A step that converges without it is solved exactly as
//! without stabilisation.
//!
//! # The damping factor
//!
//! Unless given explicitly, `c` is calibrated on the step's first increment: its undamped
//! predictor `δ₀` (a linear solve) stores the strain energy `½ δ₀·K δ₀`, and `c` is chosen
//! so that the same motion would dissipate `energy_fraction` of it:
//! `c = energy_fraction · ½ δ₀·Kδ₀ · Δt / Σ m_d δ₀,d²`. When the step's first tangent cannot
//! be factorised, `c = energy_fraction · Δt / 2` (the same formula with the Rayleigh
//! quotient taken as 1). A cut increment (smaller `Δt`) is damped more, which is what helps
//! it through.
//!
//! # Accuracy
//!
//! The calibrated `c` (Abaqus's default fraction 2e-4) is far too small to carry a structure
//! through a snap in a few increments: during a snap the viscous forces must balance the
//! out-of-balance load, which needs `c/Δt · m` of the order of the negative stiffness. So
//! `c` adapts, as in Abaqus's adaptive stabilisation: a failed increment is retried with
//! ten times more viscosity (and half the increment); after an easy increment, or when the
//! step's dissipated energy exceeds `accuracy_tolerance` times the strain energy, a boosted
//! `c` is halved again, never below the calibrated value. After every converged increment
//! the energy dissipated in it, `Σ (c/Δt) m_d Δu_d²`, is added to the step's total and
//! reported. At the end of the step the viscous forces are switched off and Newton
//! re-converges at the same load, so the step's final state is a true equilibrium; when that
//! fails (the structure is still unstable there), the damped state is kept and the
//! remaining viscous force is reported.

use super::control::{Activation, Damping, Stabilization, ON_DIFFICULTY_FAILURES};

/// Factor on `c` after a failed increment.
const BOOST: f64 = 10.0;
/// Largest `c` as a multiple of the calibrated one.
const MAX_BOOST: f64 = 1e8;

/// The stabilisation state of one step.
#[derive(Debug, Clone)]
pub(super) struct Stabilizer {
    /// The step's settings.
    pub settings: Stabilization,
    /// Weight `m_d` of each DOF (0 where not damped): calibrates `c`, and scales the
    /// terms' drag with [`Damping::Relative`].
    pub weight: Vec<f64>,
    /// Weight of the viscosity applied at each DOF itself: `weight` with [`Damping::Nodal`],
    /// only the rotations' with [`Damping::Relative`] (the translations are damped through
    /// the terms' drag).
    pub nodal_weight: Vec<f64>,
    /// DOF values at the start of the current increment.
    pub u_start: Vec<f64>,
    /// Damping factor `c`, once calibrated.
    pub factor: Option<f64>,
    /// The calibrated (or given) factor: the floor `c` returns to.
    pub base: f64,
    /// `c / Δt` of the current increment (0 switches the forces off).
    pub rate: f64,
    /// Pseudo-time length `Δt` of the current increment.
    pub dt: f64,
    /// Whether the weights have been set (at the first assembly after activation).
    pub weighted: bool,
    /// Whether the viscosity is switched on (see [`Activation`]).
    pub active: bool,
    /// Failed attempts since the last converged increment.
    pub failures_in_a_row: usize,
    /// Energy dissipated over the step's committed increments (nN·µm).
    pub dissipated: f64,
    /// Times `c` was halved to keep the dissipated energy small.
    pub halvings: usize,
    /// Bumped whenever `rate` or `u_start` changes, so that the terms' drag
    /// ([`Damping::Relative`]) is set again only then.
    pub epoch: u64,
}

/// What the stabilisation did in one converged increment.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StabilizationReport {
    /// Damping factor `c` used (dimensionless).
    pub factor: f64,
    /// Energy dissipated in this increment (nN·µm).
    pub increment_dissipated: f64,
    /// Energy dissipated so far in the step (nN·µm).
    pub step_dissipated: f64,
    /// `step_dissipated` / strain energy of the converged state.
    pub dissipated_fraction: f64,
    /// ‖viscous forces‖ / the increment's force scale in the reported state (0 when the
    /// end-of-step equilibrium re-solve succeeded).
    pub viscous_force_ratio: f64,
    /// True when the reported state is an equilibrium without viscous forces (the
    /// end-of-step re-solve).
    pub equilibrated: bool,
}

impl Stabilizer {
    /// A stabiliser for a step over `n` DOFs (weights set at the step's first assembly).
    pub fn new(settings: Stabilization, n: usize) -> Self {
        Stabilizer {
            factor: settings.factor,
            base: settings.factor.unwrap_or(0.0),
            settings,
            weight: vec![0.0; n],
            nodal_weight: vec![0.0; n],
            u_start: vec![0.0; n],
            rate: 0.0,
            dt: 1.0,
            weighted: false,
            active: settings.activation == Activation::Always,
            failures_in_a_row: 0,
            dissipated: 0.0,
            halvings: 0,
            epoch: 0,
        }
    }

    /// Whether the viscosity acts on every free DOF (else only through the terms' drag).
    pub fn nodal(&self) -> bool {
        self.settings.damping == Damping::Nodal
    }

    /// Sets `c / Δt` (0 switches the forces off).
    pub fn set_rate(&mut self, rate: f64) {
        self.rate = rate;
        self.epoch += 1;
    }

    /// Restarts the viscous motion from `u` with `c / Δt = rate`.
    pub fn restart_from(&mut self, u: &[f64], rate: f64) {
        self.u_start.copy_from_slice(u);
        self.set_rate(rate);
    }

    /// Sets the weights from the tangent's diagonal (`diagonal(d)`) on the damped DOFs;
    /// `rotation(d)` says which DOFs are rotations (damped at the DOF itself with
    /// [`Damping::Relative`] too: a filament's cross-sections turning in the gel, measured
    /// against a gel that does not spin, which holds in these tests).
    pub fn set_weights(
        &mut self,
        damped: impl Fn(usize) -> bool,
        diagonal: impl Fn(usize) -> f64,
        rotation: impl Fn(usize) -> bool,
    ) {
        let (mut sum, mut count) = (0.0, 0usize);
        for (d, w) in self.weight.iter_mut().enumerate() {
            *w = if damped(d) { diagonal(d).abs() } else { 0.0 };
            if *w > 0.0 {
                sum += *w;
                count += 1;
            }
        }
        // A damped DOF with no stiffness of its own (a mechanism, e.g. a straight unstressed
        // bar pushed sideways) is where viscosity is needed most: it gets the mean weight.
        let mean = if count > 0 { sum / count as f64 } else { 1.0 };
        for (d, w) in self.weight.iter_mut().enumerate() {
            if *w == 0.0 && damped(d) {
                *w = mean;
            }
        }
        let nodal = self.nodal();
        for (d, w) in self.nodal_weight.iter_mut().enumerate() {
            *w = if nodal || rotation(d) {
                self.weight[d]
            } else {
                0.0
            };
        }
        self.weighted = true;
    }

    /// Calibrates `c` from the undamped predictor `delta` with `energy = |δ₀·Kδ₀|` over an
    /// increment `dt`; falls back to `energy_fraction · dt / 2` when the predictor carries no
    /// information.
    pub fn calibrate(&mut self, delta: Option<&[f64]>, energy: f64) -> f64 {
        let dt = self.dt;
        let fraction = self.settings.energy_fraction;
        let weighted: f64 = delta.map_or(0.0, |delta| {
            delta.iter().zip(&self.weight).map(|(x, w)| w * x * x).sum()
        });
        let c = if weighted > 0.0 && weighted.is_finite() && energy.is_finite() && energy > 0.0 {
            fraction * 0.5 * energy * dt / weighted
        } else {
            fraction * 0.5 * dt
        };
        self.factor = Some(c);
        self.base = c;
        self.set_rate(c / dt);
        c
    }

    /// After a failed increment: ten times more viscosity for the retry (which is also
    /// shorter, so `c/Δt` grows twentyfold per cut), up to `MAX_BOOST` times the base.
    /// A stabiliser waiting for difficulty switches on, boosted the same way.
    pub fn boost(&mut self) {
        self.failures_in_a_row += 1;
        if !self.active {
            if self.failures_in_a_row < ON_DIFFICULTY_FAILURES {
                return;
            }
            self.active = true;
        }
        if let Some(c) = self.factor.as_mut() {
            *c = (*c * BOOST).min(MAX_BOOST * self.base);
        }
    }

    /// Starts an increment at `u` over `dt`.
    pub fn start_increment(&mut self, u: &[f64], dt: f64) {
        self.u_start.copy_from_slice(u);
        self.dt = dt;
        self.set_rate(match self.factor {
            Some(c) if self.active => c / dt,
            _ => 0.0,
        });
    }

    /// Adds the viscous forces at `u` to `residual` (internal forces).
    pub fn add_forces(&self, u: &[f64], residual: &mut [f64]) {
        if self.rate == 0.0 {
            return;
        }
        for (d, &w) in self.nodal_weight.iter().enumerate() {
            if w > 0.0 {
                residual[d] += self.rate * w * (u[d] - self.u_start[d]);
            }
        }
    }

    /// Adds the viscous tangent to the diagonal entries `values[diagonal_position(d)]`.
    pub fn add_tangent(&self, values: &mut [f64], diagonal_position: impl Fn(usize) -> usize) {
        if self.rate == 0.0 {
            return;
        }
        for (d, &w) in self.nodal_weight.iter().enumerate() {
            if w > 0.0 {
                values[diagonal_position(d)] += self.rate * w;
            }
        }
    }

    /// Energy the viscous forces at the DOFs dissipate moving from the increment start to
    /// `u` (with [`Damping::Relative`] only the rotations': the terms' drag books its own).
    pub fn dissipation(&self, u: &[f64]) -> f64 {
        self.nodal_weight
            .iter()
            .enumerate()
            .map(|(d, &w)| {
                let du = u[d] - self.u_start[d];
                self.rate * w * du * du
            })
            .sum()
    }

    /// ‖viscous forces at the DOFs‖ at `u` (the terms' drag not included).
    pub fn force_norm(&self, u: &[f64]) -> f64 {
        self.nodal_weight
            .iter()
            .enumerate()
            .map(|(d, &w)| {
                let f = self.rate * w * (u[d] - self.u_start[d]);
                f * f
            })
            .sum::<f64>()
            .sqrt()
    }

    /// Books a converged increment that dissipated `increment` with strain energy
    /// `strain_energy` at its end. A boosted `c` is halved (not below the base) after an
    /// `easy` increment or when the step's dissipated energy exceeds the accuracy
    /// tolerance. Returns the step's dissipated fraction.
    pub fn commit(&mut self, increment: f64, strain_energy: f64, easy: bool) -> f64 {
        self.failures_in_a_row = 0;
        self.dissipated += increment;
        let fraction = if strain_energy.abs() > 0.0 {
            self.dissipated / strain_energy.abs()
        } else if self.dissipated > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        if easy || fraction > self.settings.accuracy_tolerance {
            if let Some(c) = self.factor.as_mut() {
                if *c > self.base {
                    *c = (0.5 * *c).max(self.base);
                    self.halvings += 1;
                }
            }
        }
        fraction
    }
}
