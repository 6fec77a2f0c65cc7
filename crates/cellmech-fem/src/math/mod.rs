//! Small numerical helpers shared by element kernels: a scalar abstraction with exact
//! second-order forward-mode automatic differentiation ([`hyperdual`]) and the rotation
//! maps of SO(3) written once for any such scalar ([`rotation`]), and the `[T; 3]` vector
//! helpers used throughout the engine ([`vec3`]).

pub mod hyperdual;
pub mod rotation;
pub mod vec3;

pub use hyperdual::{HyperDual, Scalar, HD_N};
