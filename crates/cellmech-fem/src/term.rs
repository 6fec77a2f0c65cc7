//! Terms: everything that contributes energy, residual and tangent to the global system.
//!
//! A [`Term`] is a family of small "elements", each coupling a short list of global DOFs.
//! Continuum blocks, membranes, trusses, beams, springs, pressure loads and rigid-tool
//! contact are all terms, so one assembler and one finite-difference harness
//! ([`crate::verify::tangent::check_term`]) serve them all. The assembler gathers the
//! element's DOF values, calls [`Term::evaluate`], and scatters the result.
//!
//! The engine's element families do not implement `Term` by hand: they implement
//! [`ElementSet`](crate::element::ElementSet) (name, element count, element nodes, kernel
//! dispatch, optional hooks) and get `Term` from the one blanket implementation in
//! [`crate::element::set`]. Other terms (e.g. constraints) may still implement `Term`
//! directly.

use crate::dof::DofMap;
use crate::element::KernelError;
use crate::mesh::ElementKind;

/// Largest number of DOFs of one element of any term (hex8: 24; a host tie: 27).
pub const MAX_ELEMENT_DOFS: usize = 27;

/// An energy term of the total potential.
pub trait Term: Send + Sync {
    /// Name used in messages and outputs (e.g. the element-set name).
    fn name(&self) -> &str;

    /// Number of elements of this term.
    fn num_elements(&self) -> usize;

    /// Writes the global DOFs of element `e` into `dofs` and returns how many there are
    /// (at most [`MAX_ELEMENT_DOFS`]). The order is the order of `u_e` in [`Term::evaluate`].
    fn element_dofs(&self, e: usize, dof_map: &DofMap, dofs: &mut [usize]) -> usize;

    /// Energy, residual (internal force, `∂Π_e/∂u_e`) and optionally the row-major tangent
    /// (`∂²Π_e/∂u_e²`) of element `e` given its DOF values `u_e` (displacements, and for
    /// rotational DOFs the increments the term interprets).
    fn evaluate(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError>;

    /// Per-element results for writers after a converged increment (`u`: all DOF values).
    fn outputs(&self, _u: &[f64], _dof_map: &DofMap) -> Result<Option<TermOutput>, KernelError> {
        Ok(None)
    }

    /// Named scalar results after a converged increment (e.g. a tool's reaction force),
    /// with units in the names (`tool_force_z_nN`). Written as extra curve columns.
    fn scalar_outputs(&self, _u: &[f64], _dof_map: &DofMap) -> Vec<(String, f64)> {
        Vec::new()
    }

    /// Named scalars measured from the state `u_from` instead of the reference mesh (e.g. a
    /// continuum block's largest principal log strain from a test's prestressed reference
    /// state). Default: none.
    fn scalar_outputs_from(
        &self,
        _u: &[f64],
        _u_from: &[f64],
        _dof_map: &DofMap,
    ) -> Vec<(String, f64)> {
        Vec::new()
    }

    /// Called before every attempt at an increment with the step and the step time the
    /// increment is heading for, so that terms driven by their own load program (e.g. a rigid
    /// tool's motion) can position themselves.
    fn set_load_state(&mut self, _state: &LoadState) {}

    /// Called before every attempt at an increment, after [`Term::set_load_state`], with
    /// the state Newton starts from (the last converged state, or a prediction of the
    /// increment's end: an extrapolation or a guess path), so that a term with a status
    /// (e.g. a contact's active set) can predict it from where the body is heading.
    fn predict(&mut self, _u: &[f64], _dof_map: &DofMap) {}

    /// Called by Newton before every evaluation with whether the last measured residual was
    /// within [`crate::solve::NEAR_EQUILIBRIUM`] of the force scale: a term whose tangent
    /// is deliberately inexact far from equilibrium (e.g. a contact's lagged curvature term)
    /// may then use its exact derivative, so the last iterations converge quadratically.
    fn set_near_equilibrium(&mut self, _near: bool) {}

    /// Called when Newton has converged. A term with an inner loop (augmented-Lagrangian
    /// multipliers, an active set) updates itself and says whether it is settled; if any term
    /// is not, Newton continues from the current state.
    fn augment(&mut self, _u: &[f64], _dof_map: &DofMap) -> Augmentation {
        Augmentation::Settled
    }

    /// The increment converged and is accepted: make trial history permanent.
    fn commit(&mut self, _u: &[f64], _dof_map: &DofMap) {}

    /// The increment failed: return to the last committed state.
    fn rollback(&mut self) {}

    /// Keep a copy of the current trial state (within an increment, after Newton has
    /// converged) so that a further attempt started from it can return to it with
    /// [`Term::restore_trial`] if it fails. Terms without trial state need not implement it.
    fn save_trial(&mut self) {}

    /// Return to the trial state kept by the last [`Term::save_trial`].
    fn restore_trial(&mut self) {}

    /// Whether the term follows moved reference positions ([`Term::move_reference`]): an
    /// ALE rezoning ([`crate::rezone`]) moves only nodes all of whose terms do.
    fn follows_reference_moves(&self) -> bool {
        false
    }

    /// Some nodes' reference positions moved (an ALE rezoning between steps,
    /// [`crate::solve::Problem::remap_nodes`]): `reference` holds every node's new reference
    /// position, `moved[node]` says which changed, and `u` is the remapped state, which the
    /// term may correct at its moved nodes (a contact puts a node the remapping left inside
    /// its tool back onto the tool's surface). A term that
    /// [`Term::follows_reference_moves`] updates its reference geometry and any state kept
    /// at nodes; the default does nothing (such a term's nodes are never moved).
    fn move_reference(
        &mut self,
        _reference: &[[f64; 3]],
        _moved: &[bool],
        _u: &mut [f64],
        _dof_map: &DofMap,
    ) -> Result<(), String> {
        Ok(())
    }

    /// Viscous stabilisation of the relative motions this term defines
    /// ([`crate::solve::Damping::Relative`]): with `Some(drag)`, add to its forces a
    /// viscous force against each relative motion since `drag.u_start` (e.g. a tied node's
    /// slip relative to its material point), of stiffness `drag.rate` times a weight taken
    /// from `drag.weight` (the stabiliser's per-DOF weights), and its derivative to the
    /// tangent, so that Newton, line search and the relaxation blocks all see it; `None`
    /// switches it off. Not part of the returned energy. Returns whether the term has such
    /// motions. Default: none.
    fn set_drag(&mut self, _drag: Option<&Drag<'_>>, _dof_map: &DofMap) -> bool {
        false
    }

    /// Adds the drag forces of [`Term::set_drag`] at `u` into `out` (global DOFs), for the
    /// viscous-force check at the end of a step, and returns the energy the drag dissipates
    /// from `drag.u_start` to `u` (`Σ k_drag |Δ relative motion|²`, as the nodal
    /// viscosity's). Default: nothing, 0.
    fn add_drag_forces(&self, _u: &[f64], _dof_map: &DofMap, _out: &mut [f64]) -> f64 {
        0.0
    }
}

/// The viscous drag of a stabilised increment, handed to [`Term::set_drag`].
#[derive(Debug, Clone, Copy)]
pub struct Drag<'a> {
    /// `c / Δt` of the increment (1/time × dimensionless).
    pub rate: f64,
    /// DOF values at the increment's start (the drag resists motion away from them).
    pub u_start: &'a [f64],
    /// The stabiliser's weight of each DOF (the absolute tangent diagonal at the step's
    /// first assembly, nN/µm for translations).
    pub weight: &'a [f64],
}

/// Where the load program is: a term's view of the analysis time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadState {
    /// Index of the analysis step (0-based).
    pub step_index: usize,
    /// Step time the current increment is heading for (0..1).
    pub step_time: f64,
}

/// Result of [`Term::augment`].
#[derive(Debug, Clone, PartialEq)]
pub enum Augmentation {
    /// Nothing changed: the converged state is final for this term.
    Settled,
    /// The active set changed (and perhaps multipliers): the tangent changed; Newton must
    /// continue with a new factorisation. The message says how far from settled (e.g. the
    /// largest penetration) for logs.
    Updated(String),
    /// Only multipliers changed, on the same active set: the tangent is the same function
    /// of the state (exactly for bonded and flat frictionless contact; a curved tool's
    /// tangent has a multiplier-weighted curvature term), so Newton may continue with the
    /// factorisation it has ([`crate::solve::Convergence::chord_near_convergence`]).
    Multipliers(String),
}

/// Per-element results of one term, as cells for a viewer.
#[derive(Debug, Clone, PartialEq)]
pub struct TermOutput {
    /// Kind of the cells.
    pub kind: ElementKind,
    /// Flat node connectivity of the cells.
    pub connectivity: Vec<usize>,
    /// Cell fields (one value tuple per element).
    pub fields: Vec<CellField>,
}

/// One named per-cell field with `components` values per cell.
#[derive(Debug, Clone, PartialEq)]
pub struct CellField {
    /// Field name with its unit, e.g. `von_mises_kPa`.
    pub name: String,
    /// Components per cell (1, 3, 6 or 9).
    pub components: usize,
    /// `components × cells` values.
    pub values: Vec<f64>,
}
