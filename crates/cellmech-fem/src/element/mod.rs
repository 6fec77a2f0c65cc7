//! Element kernels and the sets that carry them.
//!
//! A kernel is a small pure function of one element's reference data and DOF values that
//! returns energy, residual and tangent; kernels never allocate and never see global data.
//! A set (a block of hexahedra, a truss family, a membrane, a tool's contact nodes, …) owns
//! the node lists, reference data and laws of its elements and implements [`ElementSet`],
//! which makes it a [`Term`](crate::term::Term) (see [`set`] for the split).
//!
//! Large element families are folders: `kernel.rs` (the pure kernel and its reference
//! data), `set.rs` (the [`ElementSet`] and outputs) and `tests.rs`.

pub mod beam;
pub mod hex8;
pub mod host_tie;
pub mod membrane;
pub mod pressure;
pub mod set;
pub mod spring;
pub mod truss;

pub use set::ElementSet;

/// Axial strain below which a filament element's force counts as zero (neither in tension
/// nor in compression): `|N| ≤ ZERO_FORCE_STRAIN · EA`. Round-off leaves forces of 1e-30 nN
/// in unloaded elements; counting those by their sign would report an unloaded family as
/// "in compression".
pub const ZERO_FORCE_STRAIN: f64 = 1e-9;

/// A kernel could not evaluate the element (the solver reacts by cutting the step).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum KernelError {
    /// det F <= 0 at a quadrature point (or a non-positive element volume ratio).
    #[error("inverted element: det F = {det_f:.3e} at quadrature point {qp}")]
    InvertedElement { qp: usize, det_f: f64 },
    /// The reference geometry itself is degenerate or inverted (det J0 <= 0).
    #[error("degenerate reference element: det J0 = {det_j0:.3e} at quadrature point {qp} (check the node order)")]
    DegenerateReference { qp: usize, det_j0: f64 },
}
