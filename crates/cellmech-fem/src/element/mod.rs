//! Element kernels: small pure functions of element state that return energy, residual and
//! tangent. Kernels never allocate and never see global data.

pub mod beam;
pub mod hex8;
pub mod membrane;
pub mod pressure;
pub mod spring;
pub mod truss;

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
