//! Small numerical helpers shared by element kernels: a scalar abstraction with exact
//! second-order forward-mode automatic differentiation ([`hyperdual`]) and the rotation
//! maps of SO(3) written once for any such scalar ([`rotation`]).

pub mod hyperdual;
pub mod rotation;

pub use hyperdual::{HyperDual, Scalar, HD_N};
