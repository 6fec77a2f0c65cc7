//! The one [`Term`] adapter of every element family: implement [`ElementSet`] (name, element
//! count, element nodes, kernel dispatch, and the optional hooks) and the type is a `Term`
//! through the blanket implementation below, with the DOF gathering written once.
//!
//! # Split between kernel and set
//! * The **kernel** is a pure function of one element's reference data and DOF values
//!   (`hex8_evaluate`, `truss_evaluate`, `membrane_evaluate`, `beam_evaluate_with`,
//!   `spring_evaluate`, …): no allocation, no global data, fixed-size buffers.
//! * The **set** owns the elements' node lists, the per-element reference data and the
//!   laws, and implements [`ElementSet`]: [`ElementSet::evaluate_element`] picks element
//!   `e`'s data and calls the kernel. [`ElementSet::element_dofs_into`] (default: components
//!   `0..NODE_DOFS` of each node of [`ElementSet::element_nodes`]) and
//!   [`ElementSet::gather`] (the element's DOF values from the global vector, for outputs)
//!   are provided.
//! * Hooks with state (a tool's load program, augmented-Lagrangian updates, commit and
//!   rollback of history, prestrain ramps) and per-element outputs are default methods that
//!   the blanket `Term` implementation forwards ([`ElementSet::on_load_state`],
//!   [`ElementSet::on_predict`], [`ElementSet::on_converged`], [`ElementSet::on_commit`],
//!   [`ElementSet::on_rollback`], [`ElementSet::cell_outputs`],
//!   [`ElementSet::curve_outputs`]).
//!
//! The set types keep their own public constructors and fields; the methods here have
//! names distinct from [`Term`]'s so that both traits can be in scope.

use crate::dof::DofMap;
use crate::element::KernelError;
use crate::term::{Augmentation, Drag, LoadState, Term, TermOutput, MAX_ELEMENT_DOFS};

/// A family of elements sharing one kernel; every implementor is a [`Term`].
pub trait ElementSet: Send + Sync {
    /// Largest number of DOFs of one element of the set (at most [`MAX_ELEMENT_DOFS`]).
    const ELEMENT_DOFS: usize;

    /// DOF components taken from every element node by the default
    /// [`ElementSet::element_dofs_into`]: 3 translations (beams: 6, with the rotations).
    const NODE_DOFS: usize = 3;

    /// Name of the set (messages, output prefixes).
    fn set_name(&self) -> &str;

    /// Number of elements the assembler sees (0 for a set switched off).
    fn element_count(&self) -> usize;

    /// Global node indices of element `e`.
    fn element_nodes(&self, e: usize) -> &[usize];

    /// Energy, residual and optionally the row-major tangent of element `e` at its DOF
    /// values `u_e` (in the order of [`ElementSet::element_dofs_into`]): the kernel call.
    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError>;

    /// Global DOFs of element `e` (returns their number): by default components
    /// `0..NODE_DOFS` of each node of [`ElementSet::element_nodes`], node-major.
    fn element_dofs_into(&self, e: usize, dof_map: &DofMap, dofs: &mut [usize]) -> usize {
        let nodes = self.element_nodes(e);
        for (a, &node) in nodes.iter().enumerate() {
            for c in 0..Self::NODE_DOFS {
                dofs[Self::NODE_DOFS * a + c] = dof_map.dof(node, c);
            }
        }
        Self::NODE_DOFS * nodes.len()
    }

    /// Writes element `e`'s DOF values taken from the global vector `u` into `u_e` and
    /// returns how many there are (for outputs and post-processing).
    fn gather(&self, e: usize, u: &[f64], dof_map: &DofMap, u_e: &mut [f64]) -> usize {
        let mut dofs = [0usize; MAX_ELEMENT_DOFS];
        let n = self.element_dofs_into(e, dof_map, &mut dofs);
        for (value, &dof) in u_e.iter_mut().zip(&dofs[..n]) {
            *value = u[dof];
        }
        n
    }

    /// Per-element results for writers ([`Term::outputs`]).
    fn cell_outputs(
        &self,
        _u: &[f64],
        _dof_map: &DofMap,
    ) -> Result<Option<TermOutput>, KernelError> {
        Ok(None)
    }

    /// Named scalar results, written as curve columns ([`Term::scalar_outputs`]).
    fn curve_outputs(&self, _u: &[f64], _dof_map: &DofMap) -> Vec<(String, f64)> {
        Vec::new()
    }

    /// Named scalars measured from the state `u_from` ([`Term::scalar_outputs_from`]).
    fn curve_outputs_from(
        &self,
        _u: &[f64],
        _u_from: &[f64],
        _dof_map: &DofMap,
    ) -> Vec<(String, f64)> {
        Vec::new()
    }

    /// The increment about to be attempted ([`Term::set_load_state`]).
    fn on_load_state(&mut self, _state: &LoadState) {}

    /// The state Newton starts the increment from ([`Term::predict`]).
    fn on_predict(&mut self, _u: &[f64], _dof_map: &DofMap) {}

    /// Whether Newton is near equilibrium ([`Term::set_near_equilibrium`]).
    fn on_near_equilibrium(&mut self, _near: bool) {}

    /// Newton converged: inner-loop update ([`Term::augment`]).
    fn on_converged(&mut self, _u: &[f64], _dof_map: &DofMap) -> Augmentation {
        Augmentation::Settled
    }

    /// The increment is accepted ([`Term::commit`]).
    fn on_commit(&mut self, _u: &[f64], _dof_map: &DofMap) {}

    /// The increment failed ([`Term::rollback`]).
    fn on_rollback(&mut self) {}

    /// Keep the trial state ([`Term::save_trial`]).
    fn on_save_trial(&mut self) {}

    /// Back to the kept trial state ([`Term::restore_trial`]).
    fn on_restore_trial(&mut self) {}

    /// Whether the set follows moved reference positions ([`Term::follows_reference_moves`]).
    fn follows_reference_moves(&self) -> bool {
        false
    }

    /// Reference positions of some nodes moved ([`Term::move_reference`]). Default: the
    /// set keeps no reference geometry of its own.
    fn on_reference_moved(
        &mut self,
        _reference: &[[f64; 3]],
        _moved: &[bool],
        _u: &mut [f64],
        _dof_map: &DofMap,
    ) -> Result<(), String> {
        Ok(())
    }

    /// Viscous drag of the set's relative motions ([`Term::set_drag`]).
    fn on_drag(&mut self, _drag: Option<&Drag<'_>>, _dof_map: &DofMap) -> bool {
        false
    }

    /// Drag forces into global DOFs, and the energy dissipated ([`Term::add_drag_forces`]).
    fn drag_forces_of_set(&self, _u: &[f64], _dof_map: &DofMap, _out: &mut [f64]) -> f64 {
        0.0
    }
}

impl<S: ElementSet> Term for S {
    fn name(&self) -> &str {
        self.set_name()
    }

    fn num_elements(&self) -> usize {
        self.element_count()
    }

    fn element_dofs(&self, e: usize, dof_map: &DofMap, dofs: &mut [usize]) -> usize {
        const { assert!(S::ELEMENT_DOFS <= MAX_ELEMENT_DOFS) };
        self.element_dofs_into(e, dof_map, dofs)
    }

    #[inline]
    fn evaluate(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        self.evaluate_element(e, u_e, residual, tangent)
    }

    fn outputs(&self, u: &[f64], dof_map: &DofMap) -> Result<Option<TermOutput>, KernelError> {
        self.cell_outputs(u, dof_map)
    }

    fn scalar_outputs(&self, u: &[f64], dof_map: &DofMap) -> Vec<(String, f64)> {
        self.curve_outputs(u, dof_map)
    }

    fn scalar_outputs_from(
        &self,
        u: &[f64],
        u_from: &[f64],
        dof_map: &DofMap,
    ) -> Vec<(String, f64)> {
        self.curve_outputs_from(u, u_from, dof_map)
    }

    fn set_load_state(&mut self, state: &LoadState) {
        self.on_load_state(state)
    }

    fn follows_reference_moves(&self) -> bool {
        ElementSet::follows_reference_moves(self)
    }

    fn move_reference(
        &mut self,
        reference: &[[f64; 3]],
        moved: &[bool],
        u: &mut [f64],
        dof_map: &DofMap,
    ) -> Result<(), String> {
        self.on_reference_moved(reference, moved, u, dof_map)
    }

    fn predict(&mut self, u: &[f64], dof_map: &DofMap) {
        self.on_predict(u, dof_map)
    }

    fn set_near_equilibrium(&mut self, near: bool) {
        self.on_near_equilibrium(near)
    }

    fn augment(&mut self, u: &[f64], dof_map: &DofMap) -> Augmentation {
        self.on_converged(u, dof_map)
    }

    fn commit(&mut self, u: &[f64], dof_map: &DofMap) {
        self.on_commit(u, dof_map)
    }

    fn rollback(&mut self) {
        self.on_rollback()
    }

    fn save_trial(&mut self) {
        self.on_save_trial()
    }

    fn restore_trial(&mut self) {
        self.on_restore_trial()
    }

    fn set_drag(&mut self, drag: Option<&Drag<'_>>, dof_map: &DofMap) -> bool {
        self.on_drag(drag, dof_map)
    }

    fn add_drag_forces(&self, u: &[f64], dof_map: &DofMap, out: &mut [f64]) -> f64 {
        self.drag_forces_of_set(u, dof_map, out)
    }
}
