//! Terms: everything that contributes energy, residual and tangent to the global system.
//!
//! A [`Term`] is a family of small "elements", each coupling a short list of global DOFs.
//! Continuum blocks, membranes, trusses, beams and rigid-tool contact are all terms, so one
//! assembler and one finite-difference harness serve them all. The assembler gathers the
//! element's DOF values, calls [`Term::evaluate`], and scatters the result.

use crate::dof::DofMap;
use crate::element::KernelError;
use crate::mesh::ElementKind;

/// Largest number of DOFs of one element of any term (hex8: 24).
pub const MAX_ELEMENT_DOFS: usize = 24;

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
